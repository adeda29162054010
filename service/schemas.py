"""Request and response schemas of the API."""

from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import BaseModel, ConfigDict, Field, PlainSerializer, PlainValidator, model_validator

from bake.errors import TextureError
from bake.imageio import BITS
from bake.textures.spec import TEXTURES, TextureSpec, parse_spec


def _texture(value: Any):
    """A texture name or spec object; never a path (``parse_spec`` reads no files)."""
    try:
        return parse_spec(value)
    except TextureError as exc:
        raise ValueError(str(exc)) from None


TextureName = Literal[tuple(TEXTURES)]  # type: ignore[valid-type]  # the registry's names, as an enum
Texture = Annotated[
    Any,
    PlainValidator(_texture, json_schema_input_type=Union[TextureName, TextureSpec]),  # noqa: UP007  # values, not annotations
    PlainSerializer(lambda spec: spec.model_dump(mode="json"), return_type=dict),
]


class BakeSettings(BaseModel):
    """What to bake: the same settings as the library and the command line."""

    model_config = ConfigDict(extra="forbid")

    texture: Texture = Field("checker", description="texture: a name or a spec object (see GET /v1/textures)", validate_default=True)
    size: int = Field(1024, ge=1, le=16384)
    quality: Literal["draft", "default", "final"] | None = Field(None, description="preset of samples, filtering and octave cap (default: 'default')")
    samples: int | None = Field(None, ge=1, le=1024, description="samples per texel (default: the preset's)")
    margin: int = Field(16, ge=0, le=4096)
    uv: Literal["auto", "unwrap", "keep"] = "auto"
    texture_space: Literal["unit", "object"] = "unit"
    shading: Literal["decal", "ambient-diffuse", "full"] = "decal"
    fmt: Literal["png", "exr", "tif"] = "png"
    bits: Literal[8, 16, 32] | None = Field(None, description="png 8 or 16; exr 16 (half) or 32; tif 8, 16 or 32 (default: png 8, exr 16, tif 16)")

    @model_validator(mode="after")
    def _bits_fit_format(self):
        if self.bits is not None and self.bits not in BITS[self.fmt]:
            raise ValueError(f"bits: {self.fmt} takes {' or '.join(map(str, BITS[self.fmt]))} bits, got {self.bits}")
        return self


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
    files: list[str] = []


class JobPage(BaseModel):
    jobs: list[JobOut]
    total: int
    offset: int
    limit: int
