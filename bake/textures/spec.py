"""Texture specs: declarative, validated descriptions of a texture and its parameters.

A spec is a pydantic model chosen by its ``name``; unknown parameters and out-of-range
values are rejected with a message naming them. The same spec serves the library, the
command line and the service (as JSON).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError

from ..errors import TextureError

Vec3 = tuple[float, float, float]
Colour = Annotated[tuple[float, float, float], Field(description="linear RGB")]


class Transform(BaseModel):
    """Placement of the texture field in object space: scale, then rotate, then translate.

    The texture is evaluated at ``texture_from_object(p)``, the inverse of this placement,
    so a larger ``scale`` gives larger features and the field moves with the object.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    scale: Union[Annotated[float, Field(gt=0)], tuple[float, float, float]] = 1.0
    rotate: Vec3 = Field((0.0, 0.0, 0.0), description="XYZ Euler angles, degrees")
    translate: Vec3 = (0.0, 0.0, 0.0)

    def object_from_texture(self) -> np.ndarray:
        """``(4, 4)`` float64 matrix placing texture space in object space."""
        s = np.broadcast_to(np.asarray(self.scale, dtype=np.float64), (3,))
        if np.any(s <= 0):
            raise TextureError(f"transform.scale: must be positive, got {self.scale}")
        ax, ay, az = np.radians(self.rotate)
        rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
        ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
        rz = np.array([[np.cos(az), -np.sin(az), 0], [np.sin(az), np.cos(az), 0], [0, 0, 1]])
        m = np.eye(4)
        m[:3, :3] = rz @ ry @ rx @ np.diag(s)
        m[:3, 3] = self.translate
        return m

    def texture_from_object(self) -> np.ndarray:
        """``(4, 4)`` float64 inverse of :meth:`object_from_texture`."""
        return np.linalg.inv(self.object_from_texture())


class _Texture(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    transform: Transform = Transform()
    channels: int = 3


class Position(_Texture):
    """The object-space point, normalised per axis to the mesh's bounding box (RGB = XYZ)."""

    name: Literal["position"] = "position"


class Checker(_Texture):
    """The lecture's checkerboard: boxes of size (Cx, Cy, Cz) in two colours.

    Uses ``floor`` (no anomaly at 0) and a closed-form box filter over the texel footprint.
    """

    name: Literal["checker"] = "checker"
    box: tuple[
        Annotated[float, Field(gt=0)], Annotated[float, Field(gt=0)], Annotated[float, Field(gt=0)]
    ] = (0.125, 0.125, 0.125)
    color_even: Colour = (0.9, 0.9, 0.9)
    color_odd: Colour = (0.05, 0.05, 0.05)
    filtered: bool = Field(True, description="box-filter over the texel footprint")


TextureSpec = Annotated[Union[Position, Checker], Field(discriminator="name")]
_ADAPTER = TypeAdapter(TextureSpec)

TEXTURES = {cls.model_fields["name"].default: cls for cls in (Position, Checker)}


def _describe(error: ValidationError) -> str:
    parts = []
    for e in error.errors():
        where = ".".join(str(x) for x in e["loc"]) or "spec"
        parts.append(f"{where}: {e['msg']}")
    return "; ".join(parts)


def parse_spec(value) -> _Texture:
    """A texture spec from a spec object, a dict, a texture name, JSON text or a JSON file.

    Raises :class:`TextureError` naming the unknown texture or the bad parameter.
    """
    if isinstance(value, _Texture):
        return value
    if isinstance(value, (str, Path)):
        text = str(value).strip()
        if text in TEXTURES:
            return TEXTURES[text]()
        if text.startswith("{"):
            try:
                value = json.loads(text)
            except json.JSONDecodeError as exc:
                raise TextureError(f"texture spec is not valid JSON: {exc}") from None
        elif Path(text).suffix.lower() == ".json" and Path(text).is_file():
            try:
                value = json.loads(Path(text).read_text())
            except (OSError, json.JSONDecodeError) as exc:
                raise TextureError(f"{text}: cannot read texture spec: {exc}") from None
        else:
            known = ", ".join(sorted(TEXTURES))
            raise TextureError(f"unknown texture {text!r} (known: {known})")
    if not isinstance(value, dict):
        raise TextureError(f"texture spec must be a name or a mapping, got {type(value).__name__}")
    if "name" not in value:
        raise TextureError("texture spec has no 'name'")
    if value["name"] not in TEXTURES:
        known = ", ".join(sorted(TEXTURES))
        raise TextureError(f"unknown texture {value['name']!r} (known: {known})")
    try:
        return _ADAPTER.validate_python(value)
    except ValidationError as exc:
        raise TextureError(f"texture {value['name']!r}: {_describe(exc)}") from None
