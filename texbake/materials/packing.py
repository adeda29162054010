"""Packing templates: several scalar channels of a material in one image, one in each of its
R, G, B (and A) channels, as engines read them.

Built in (:data:`PACKINGS`): ``orm``, glTF's and Unreal's (R occlusion, G roughness, B
metallic: the GLB's metallic-roughness and occlusion textures); ``hdrp-mask``, Unity
HDRP's mask map (R metallic, G occlusion, B detail mask, A smoothness: 1 - roughness).
A user template is JSON: ``{"name": "rma", "channels": ["roughness", "metallic",
"occlusion"]}``, each channel a scalar channel's name, ``{"channel": NAME, "invert":
true}`` (1 - it), or a number. A channel the material does not give takes its default
(``model.DEFAULTS``: occlusion 1, roughness 1, metallic 0, height 0, opacity 1).

Packing copies the baked maps' values as they are (inverted: ``1 - x`` in float32), so a
packed channel is the separate map exactly (written as the same data bytes).
"""

from __future__ import annotations

import json
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import ParameterError
from ..validation import describe, did_you_mean, shown

ScalarChannel = Literal["roughness", "metallic", "height", "occlusion", "opacity"]  # the scalar channels (graph.CHANNELS)


class Inverted(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    channel: ScalarChannel
    invert: bool = False


Source = Annotated[ScalarChannel | Inverted | Annotated[float, Field(ge=0, le=1)],
                   Field(description="a scalar channel, {channel, invert} or a value from 0 to 1")]


class PackTemplate(BaseModel):
    """A packed image: its ``name`` (the map's, and its file's stem) and what each of its
    1 to 4 channels holds."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field(..., pattern=r"^[a-z][a-z0-9_-]{0,31}$")
    channels: tuple[Source, ...] = Field(..., min_length=1, max_length=4)


PACKINGS: dict[str, PackTemplate] = {
    "orm": PackTemplate(name="orm", channels=("occlusion", "roughness", "metallic")),
    "hdrp-mask": PackTemplate(name="hdrp-mask", channels=("metallic", "occlusion", 1.0, Inverted(channel="roughness", invert=True))),
}


def parse_packing(value) -> PackTemplate:
    """A template from a :class:`PackTemplate`, a built-in name, a dict or JSON text (never a
    path); :class:`ParameterError` naming ``packing``."""
    if isinstance(value, PackTemplate):
        return value
    if isinstance(value, str):
        text = value.strip()
        if text in PACKINGS:
            return PACKINGS[text]
        if not text.startswith("{"):
            raise ParameterError("packing", f"unknown template {shown(text, 60)} ({did_you_mean(text, list(PACKINGS))}"
                                 f"built in: {', '.join(PACKINGS)}; or a template object)")
        try:
            value = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ParameterError("packing", f"not valid JSON: {exc.msg}") from None
    try:
        return PackTemplate.model_validate(value)
    except ValidationError as exc:
        field, problem = describe(exc.errors(include_url=False), PackTemplate.model_json_schema(), subject="packing")[0]
        raise ParameterError("packing", f"{field}: {problem}" if field else problem) from None


def pack(template: PackTemplate, images: dict[str, np.ndarray], defaults: dict) -> np.ndarray:
    """``(h, w, k)`` float32: the template's channels from ``images`` (channel -> ``(h, w, 1)``
    baked map), a channel without a map from ``defaults`` (channel -> value)."""
    shape = next(iter(images.values())).shape[:2]
    out = np.empty((*shape, len(template.channels)), dtype=np.float32)
    for k, source in enumerate(template.channels):
        name, invert = (source.channel, source.invert) if isinstance(source, Inverted) else (source, False)
        if isinstance(name, float):
            out[..., k] = name
        elif name in images:
            out[..., k] = images[name][..., 0]
        else:
            out[..., k] = float(defaults[name])  # type: ignore[arg-type]
        if invert:
            np.subtract(np.float32(1.0), out[..., k], out=out[..., k])
    return out
