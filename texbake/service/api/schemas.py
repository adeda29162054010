"""Request and response schemas of the API."""

from __future__ import annotations

from pydantic import BaseModel

from texbake.settings import BakeSettings

__all__ = ["BakeSettings", "JobOut", "JobPage", "Problem", "ServerConfig", "ServerLimits"]


class Problem(BaseModel):
    """Every 4xx answer: what is wrong, naming the field or file; ``errors`` lists each
    problem of a request that failed validation."""

    detail: str
    errors: list[dict] | None = None


class JobOut(BaseModel):
    id: str
    url: str
    state: str
    progress: float | None = None
    error: str | None = None
    mesh: str
    settings: dict
    attempts: int
    created: str
    updated: str
    report: dict | None = None
    warnings: list[str] = []  # the bake report's: fallback atlas, overlapping UVs kept, transfer misses
    files: list[str] = []


class JobPage(BaseModel):
    jobs: list[JobOut]
    total: int
    offset: int
    limit: int


class ServerLimits(BaseModel):
    """This server's limits (``BAKE_MAX_*``), tighter than or equal to the bake's own."""

    max_upload_bytes: int
    max_size: int
    max_samples: int
    max_frames: int
    max_faces: int
    jobs_per_client: int


class ServerConfig(BaseModel):
    """What a client needs to know before it uploads: whether an API key is needed, the
    limits, the mesh formats taken, the files a mesh may bring beside it (``files``: an
    OBJ's MTL and images, a glTF's buffers and images) and how many, and the JSON Schema of
    ``BakeSettings``."""

    auth: bool
    limits: ServerLimits
    formats: list[str]
    companions: list[str]
    max_companions: int
    settings_schema: dict
