"""The bake's settings: one model, the whole input of a bake besides the mesh.

The library takes it (``bake_mesh(mesh, settings)``, or keyword arguments that build it),
the command line has one option per field, the service's ``settings`` form field is it,
and a batch manifest line is one (plus its ``mesh``). The limits are written here once;
the service may only tighten them (``texbake.service.core.config``).

Quality presets: ``quality`` names a preset of ``samples``, ``filtering``, ``precision``
and ``max_octaves`` (``texbake.quality.PRESETS``); those of them set explicitly override the
preset (pydantic's ``model_fields_set`` tells which were set). :meth:`BakeSettings.quality_settings`
gives the resolved four. ``samples`` above 1 given explicitly means point samples unless
``filtering=True`` is given too (a filtered sample is already blurred by a whole texel:
averaging several of them blurs twice, and their error stays that of one filtered sample).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal, Union

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    PlainSerializer,
    PlainValidator,
    StrictBool,
    ValidationError,
    field_validator,
    model_validator,
)

from .errors import ParameterError, TextureError
from .output.images import BITS
from .quality import PRESETS, Quality
from .textures.spec import TEXTURES, TextureSpec, parse_spec
from .validation import describe


def _texture(value: Any):
    """A texture name, JSON text or spec object; never a path (``parse_spec`` reads no files)."""
    try:
        return parse_spec(value)
    except TextureError as exc:
        raise ValueError(str(exc)) from None


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {value}")
    return value


TextureName = Literal[tuple(TEXTURES)]  # type: ignore[valid-type]  # the registry's names, as an enum
Texture = Annotated[
    Any,
    PlainValidator(_texture, json_schema_input_type=Union[TextureName, TextureSpec]),  # noqa: UP007  # values, not annotations
    PlainSerializer(lambda spec: spec.model_dump(mode="json"), return_type=dict),
]
Finite = Annotated[float, AfterValidator(_finite)]
MAX_TEXELS = 65536  # a side of the image
Texels = Annotated[int, Field(ge=1, le=MAX_TEXELS)]


class BakeSettings(BaseModel):
    """What to bake and how (see ``bake_mesh`` for what each setting does)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    texture: Texture = Field("checker", validate_default=True, description="texture: a name or a spec object (see `texbake textures`)")
    size: Texels | tuple[Texels, Texels] = Field(1024, description="image size in texels: one number (square), or width and height")
    quality: Literal["default", "final"] | None = Field(
        None, description="preset of samples, filtering, precision and octave cap (none: 'default'); those set explicitly override it")
    samples: int = Field(1, ge=1, le=1024, description="samples per texel, stratified (default: the preset's)")
    filtering: StrictBool = Field(True, description="antialias by the texel footprint (default: the preset's; off when samples > 1 is given without it)")
    precision: Literal["float64", "float32"] = Field("float64", description="texture-space points as float64 or rounded to float32 (default: the preset's)")
    max_octaves: int | None = Field(None, ge=1, le=30, description="cap on the octaves of noise-based textures; none: the spec's own (default: the preset's)")
    margin: int = Field(16, ge=0, le=4096, description="texels of margin filled around charts")
    uv: Literal["auto", "unwrap", "keep"] = Field("auto", description="keep the mesh's UVs when usable (auto), always unwrap, or require them")
    charting: Literal["auto", "planar", "xatlas"] = Field(
        "auto", description="how an unwrap cuts charts: planar (faces grouped by normal, as Smart UV Project), xatlas "
        "(fewer seams and less stretch on small organic meshes, slower), or auto: planar for CAD-like meshes and "
        "meshes of over 6k faces, xatlas otherwise")
    texture_space: Literal["unit", "object"] = Field("unit", description="unit: the bounding box scaled to start at 0 with its longest side 1; object: coordinates as they are")
    shading: Literal["decal", "ambient-diffuse", "full"] = Field("decal", description="decal: albedo only; the others also bake a lit map")
    light: tuple[Finite, Finite, Finite] = Field((0.3, 0.5, 0.8), description="light direction x, y, z for lit maps")
    bump: Texture | None = Field(None, description="texture whose luminance is bumped into a tangent-space normal map")
    bump_strength: Finite = Field(1.0, description="scale of the bump")
    frames: list[Finite] | None = Field(None, min_length=1, max_length=1024, description="times to bake an animated texture (the flame) at")
    cage: Finite | None = Field(None, gt=0, description="maximum transfer ray distance from a source mesh (default: 5% of the bounding-box diagonal)")
    seed: int = Field(0, ge=0, le=2**31 - 1, description="seed of the sample jitter and the error probe")
    max_faces: int = Field(5_000_000, ge=1, le=100_000_000, description="meshes with more faces are rejected")
    unwrap_deadline: Finite = Field(120.0, gt=0, le=86400, description="seconds xatlas may run before a fallback atlas is used")
    format: Literal["png", "exr", "tif"] = Field("png", description="image format of the maps")
    bits: Literal[8, 16, 32] | None = Field(None, description="png 8 or 16; exr 16 (half) or 32; tif 8, 16 or 32 (default: png 8, exr 16, tif 16)")
    obj: StrictBool = Field(False, description="also write OBJ + MTL")

    @field_validator("format", mode="before")
    @classmethod
    def _format_name(cls, value):
        if isinstance(value, str):
            value = value.lower().lstrip(".")
            return "tif" if value == "tiff" else value
        return value

    @model_validator(mode="after")
    def _consistent(self):
        if self.bits is not None and self.bits not in BITS[self.format]:
            raise ValueError(f"bits: {self.format} takes {' or '.join(map(str, BITS[self.format]))} bits, got {self.bits}")
        if self.frames is not None and "time" not in type(self.texture).model_fields:
            raise ValueError(f"frames: texture {self.texture.name!r} has no time to animate")
        return self

    @property
    def width_height(self) -> tuple[int, int]:
        return (self.size, self.size) if isinstance(self.size, int) else self.size

    def quality_settings(self) -> Quality:
        """The preset's samples, filtering, precision and octave cap, overridden by those set here."""
        preset = PRESETS[self.quality or "default"]
        given = self.model_fields_set
        chosen = {name: getattr(self if name in given else preset, name) for name in Quality.__dataclass_fields__}
        if "samples" in given and self.samples > 1 and "filtering" not in given:
            chosen["filtering"] = False  # several samples converge to the texel mean; filtering each would blur it twice
        return Quality(**chosen)

    @classmethod
    def build(cls, settings: BakeSettings | dict | None = None, **options) -> BakeSettings:
        """Settings from a model or a dict, with keyword ``options`` on top; a bad one
        raises :class:`ParameterError` naming it."""
        data = {} if settings is None else settings
        if isinstance(data, BakeSettings):
            if not options:
                return data
            data = data.model_dump(exclude_unset=True)
        try:
            return cls.model_validate({**data, **options})
        except ValidationError as exc:
            raise parameter_error(exc) from None


# what a field allows, where its JSON Schema's words would be clumsy
ALLOWED = {"size": f"a whole number from 1 to {MAX_TEXELS} (or width,height)", "light": "3 finite numbers (x,y,z)"}


def describe_errors(errors: Sequence[Mapping[str, Any]]) -> list[tuple[str, str]]:
    """``(field, problem)`` for each bad setting of a failed validation (pydantic's error
    dicts, located from the settings' top): the field, the value and what is allowed."""
    return describe(errors, _schema(), hints=ALLOWED)


@functools.cache
def _schema() -> dict:
    return BakeSettings.model_json_schema()


def parameter_error(error: ValidationError) -> ParameterError:
    """One :class:`ParameterError` for a failed validation, naming the first bad field
    (``size: expected a whole number from 1 to 65536 (or width,height), got 'abc'``); any
    others follow it, ``; field: problem`` each."""
    problems = describe_errors(error.errors(include_url=False))
    (name, problem), rest = problems[0], problems[1:]
    return ParameterError(name or "settings", "; ".join([problem, *(f"{n or 'settings'}: {p}" for n, p in rest)]))
