"""Request and response schemas of the API."""

from __future__ import annotations

from pydantic import BaseModel

from texbake.settings import BakeSettings

__all__ = ["BakeSettings", "JobOut", "JobPage", "MaterialInfo", "MeshInfo", "Problem", "ServerConfig", "ServerLimits", "SetOut"]


class Problem(BaseModel):
    """Every 4xx answer: what is wrong, naming the field or file; ``errors`` lists each
    problem of a request that failed validation."""

    detail: str
    errors: list[dict] | None = None


class SetOut(BaseModel):
    """A texture set of a done job (its report's ``sets``): its name (its material's), the
    materials whose faces it holds, its size, its texture's name, its UDIM tiles (none: one
    image) and the files it wrote (the mesh's GLB, OBJ or USD and ``report.json`` belong to
    every set: see ``files`` of the job)."""

    name: str
    materials: list[str]
    size: list[int]
    texture: str
    tiles: list[int] = []
    files: list[str] = []

    @classmethod
    def from_report(cls, report: dict) -> list[SetOut]:
        bake = (report.get("settings") or {}).get("texture") or {}
        out = []
        for entry in report.get("sets") or []:
            texture = ((entry.get("settings") or {}).get("texture") or bake).get("name", "")
            size = entry.get("size") or []
            out.append(cls(name=entry["name"], materials=entry.get("materials") or [entry["name"]], texture=texture,
                           size=[size, size] if isinstance(size, int) else list(size),
                           tiles=[t["tile"] for t in entry.get("tiles") or []], files=entry.get("outputs") or []))
        return out


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
    sets: list[SetOut] = []  # once done: the texture sets, each with its tiles and files


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


class MaterialInfo(BaseModel):
    """A material of an uploaded mesh, as a bake takes it: its name (a key of ``materials``),
    its faces, whether they have UVs (``all``, ``some`` or ``none``) and the UDIM tiles
    those lie in (none: the unit square, or no UVs)."""

    name: str
    faces: int
    uv: str
    tiles: list[int] = []


class MeshInfo(BaseModel):
    """What ``POST /v1/inspect`` read of a mesh: its name, counts, materials (in the order
    a bake makes their texture sets) and what the loader warned of."""

    mesh: str
    faces: int
    vertices: int
    parts: list[str]
    materials: list[MaterialInfo]
    warnings: list[str] = []
