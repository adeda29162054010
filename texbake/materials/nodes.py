"""The nodes of a material's graph: what each op takes and gives.

A node is a JSON object with an ``op`` and its inputs and parameters. An input is a
number (a scalar constant), three numbers (a linear RGB constant), the name of a node in
the material's ``nodes``, or a node written in place; a texture spec (an object with a
``name``, as ``--texture`` takes it) in place of a node is that texture's colour. Each
op's entry in :data:`OPS` says which of its keys are inputs and of which kind, and its
parameters as a pydantic model (unknown keys and bad values are named); a new op is one
entry here and its kernel in ``native/materials.cpp`` (``program.py`` maps ops to it).

Kinds: ``scalar`` (one channel) or ``colour`` (three). A scalar given where a colour is
taken is grey (the same value in each channel); a colour where a scalar is taken is an
error naming the node (pick a channel, or the luminance, with ``channel``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from ..meshmaps.kinds import KINDS
from ..textures.spec import ColourMap, Curve

SCALAR, COLOUR, ANY = "scalar", "colour", "any"


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {value}")
    return value


Finite = Annotated[float, AfterValidator(_finite)]


class _Params(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class NoParams(_Params):
    pass


class TextureParams(_Params):
    """``texture``: the spec (a name, or an object with its ``name`` and parameters);
    ``output``: its ``colour``, or its ``value``, the scalar before its colour map
    (noise, turbulence, fbm, marble, wood, checker)."""

    texture: Any
    output: Literal["colour", "value"] = "colour"


class WarpParams(TextureParams):
    """The texture evaluated at the points moved by ``amount * by``: along ``axis`` for a
    scalar ``by``, by its three channels as a vector for a colour one."""

    amount: Finite = 0.1
    axis: Literal["x", "y", "z"] = "x"


class ConstantParams(_Params):
    value: Finite | tuple[Finite, Finite, Finite]


class ChannelParams(_Params):
    channel: Literal["r", "g", "b", "x", "y", "z", "luminance"] = "luminance"


class ClampParams(_Params):
    min: Finite = 0.0
    max: Finite = 1.0

    @model_validator(mode="after")
    def _order(self):
        if self.max < self.min:
            raise ValueError(f"max: expected at least min ({self.min}), got {self.max}")
        return self


class ThresholdParams(_Params):
    at: Finite = 0.5


class SmoothstepParams(_Params):
    edge0: Finite = 0.0
    edge1: Finite = 1.0

    @model_validator(mode="after")
    def _order(self):
        if not self.edge1 > self.edge0:
            raise ValueError(f"edge1: expected more than edge0 ({self.edge0}), got {self.edge1}")
        return self


class RemapParams(_Params):
    """Through a ``colormap`` (to a colour) or a ``curve`` (to a scalar): one of them."""

    colormap: ColourMap | None = None
    curve: Curve | None = None

    @model_validator(mode="after")
    def _one(self):
        if (self.colormap is None) == (self.curve is None):
            raise ValueError("remap: expected a colormap (to a colour) or a curve (to a scalar), one of them")
        return self


class BlendParams(_Params):
    mode: Literal["overlay", "screen", "multiply"] = Field(..., description="the layer b over the base a")


class MeshMapParams(_Params):
    """``map``: the mesh map read (``texbake.meshmaps``: ao, curvature, thickness... one the
    bake's ``maps`` lists), at each sample's texel."""

    map: Literal[KINDS]  # type: ignore[valid-type]


class MtlxParams(_Params):
    """A channel of a MaterialX document (``texbake.mtlx``): the document's XML text, its
    ``path`` (for messages), the ``channel`` and the ``kind`` it gives."""

    document: str = Field(..., max_length=4_000_000)
    channel: str
    kind: Literal["scalar", "colour"]
    path: str = "<mtlx>"


@dataclass(frozen=True)
class Op:
    """An op: its inputs (name -> kind taken), its parameters, and what it gives: a kind,
    or ``"widest"`` (colour if any of ``widest_of`` is), ``"input"`` (the kind of its
    ``input``), or a function of the parameters."""

    inputs: dict[str, str]
    params: type[_Params]
    gives: str
    summary: str
    widest_of: tuple[str, ...] = ()


def _widest(*names: str) -> dict[str, Any]:
    return {"gives": "widest", "widest_of": names}


OPS: dict[str, Op] = {
    "texture": Op({}, TextureParams, "texture", "a texture's colour, or its value (the scalar before its colour map)"),
    "constant": Op({}, ConstantParams, "constant", "a number (scalar) or three (linear RGB)"),
    "position": Op({}, NoParams, COLOUR, "the point, per axis 0 to 1 over the mesh's bounding box"),
    "normal": Op({}, NoParams, COLOUR, "the surface normal, each component -1 to 1"),
    "channel": Op({"input": COLOUR}, ChannelParams, SCALAR, "one channel of a colour, or its luminance"),
    "combine": Op({"r": SCALAR, "g": SCALAR, "b": SCALAR}, NoParams, COLOUR, "a colour of three scalars"),
    "mix": Op({"a": ANY, "b": ANY, "mask": SCALAR}, NoParams, summary="a where mask is 0, b where it is 1", **_widest("a", "b")),
    "add": Op({"a": ANY, "b": ANY}, NoParams, summary="a + b", **_widest("a", "b")),
    "subtract": Op({"a": ANY, "b": ANY}, NoParams, summary="a - b", **_widest("a", "b")),
    "multiply": Op({"a": ANY, "b": ANY}, NoParams, summary="a * b", **_widest("a", "b")),
    "divide": Op({"a": ANY, "b": ANY}, NoParams, summary="a / b (0 where b is 0)", **_widest("a", "b")),
    "power": Op({"a": ANY, "b": ANY}, NoParams, summary="max(a, 0) ** b", **_widest("a", "b")),
    "invert": Op({"input": ANY}, NoParams, "input", "1 - input"),
    "clamp": Op({"input": ANY}, ClampParams, "input", "input clamped to [min, max]"),
    "threshold": Op({"input": ANY}, ThresholdParams, "input", "1 where input >= at, else 0"),
    "smoothstep": Op({"input": ANY}, SmoothstepParams, "input", "Hermite step from edge0 to edge1"),
    "remap": Op({"input": SCALAR}, RemapParams, "remap", "a scalar through a colour map (to a colour) or a curve"),
    "blend": Op({"a": ANY, "b": ANY}, BlendParams, summary="the layer b over the base a: overlay, screen or multiply",
                **_widest("a", "b")),
    "warp": Op({"by": ANY}, WarpParams, "texture", "a texture at the points moved by amount * by (domain warp)"),
    "mtlx": Op({}, MtlxParams, "kind", "a channel of a MaterialX document's surface shader (--material FILE.mtlx)"),
    "mesh_map": Op({}, MeshMapParams, "mesh_map", "a mesh map of the bake (ao, curvature, thickness...) at the sample's texel: "
                   "a scalar for the one-channel maps, else a colour"),
}

# textures whose scalar before the colour map a "value" output gives
VALUED = ("noise", "turbulence", "fbm", "marble", "wood", "checker")
LEAVES = ("texture", "constant", "position", "normal", "warp", "mtlx", "mesh_map")  # evaluated outside the program (but warp's input)
