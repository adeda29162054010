"""Request and response schemas of the API."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field


class BakeSettings(BaseModel):
    """What to bake: the same settings as the library and the command line."""

    model_config = ConfigDict(extra="forbid")

    texture: Any = Field("checker", description="texture spec: a name or a spec object (see GET /v1/textures)")
    size: int = Field(1024, ge=1, le=16384)
    quality: Literal["draft", "default", "final"] | None = Field(None, description="preset of samples, filtering and octave cap (default: 'default')")
    samples: int | None = Field(None, ge=1, le=1024, description="samples per texel (default: the preset's)")
    margin: int = Field(16, ge=0, le=4096)
    uv: Literal["auto", "unwrap", "keep"] = "auto"
    texture_space: Literal["unit", "object"] = "unit"
    shading: Literal["decal", "ambient-diffuse", "full"] = "decal"
    fmt: Literal["png", "exr", "tif"] = "png"
    bits: int | None = None


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
    files: list[str] = []


class JobPage(BaseModel):
    jobs: list[JobOut]
    total: int
    offset: int
    limit: int
