"""Request and response schemas of the API."""

from __future__ import annotations

from pydantic import BaseModel

from bake.settings import BakeSettings

__all__ = ["BakeSettings", "JobOut", "JobPage", "Problem"]


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
