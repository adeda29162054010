"""Texture specs: declarative, validated descriptions of a texture and its parameters.

A spec is a pydantic model chosen by its ``name``; unknown parameters and out-of-range
values are rejected with a message naming them. The same spec serves the library, the
command line and the service (as JSON).

Annotations here are plain (no ``from __future__ import annotations``): pydantic would
evaluate every string annotation again as each model class is made, the larger part of
this module's import. The models build their validators on first use (``defer_build``):
a bake validates one texture, not all of them.
"""

import dataclasses
import functools
import json
from itertools import pairwise
from typing import Annotated, Any, ClassVar, Literal, get_args

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError, model_validator

from ..errors import TextureError
from ..validation import describe, did_you_mean, json_error_text, shown
from .context import EvalContext, Placement

Vec3 = tuple[float, float, float]
Colour = Annotated[tuple[float, float, float], Field(description="linear RGB")]


class Transform(BaseModel):
    """Placement of the texture field in object space: scale, then rotate, then translate.

    The texture is evaluated at ``texture_from_object(p)``, the inverse of this placement,
    so a larger ``scale`` gives larger features and the field moves with the object.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    scale: Annotated[float, Field(gt=0)] | tuple[float, float, float] = 1.0
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
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    name: str  # each texture's own Literal: the discriminator
    transform: Transform = Transform()
    space: Literal["object", "world"] = Field(
        "object",
        description="object: the field moves with the object; world: the field stays put "
        "and the object, placed by `model`, moves through it",
    )
    model: Transform = Field(Transform(), description="modelling transform: object to world")
    channels: ClassVar[int] = 3  # of the colour it gives
    emits: ClassVar[bool] = False  # light, not a surface colour: the GLB binds its map as emissive too

    def placement(self) -> Placement:
        """Object space to this texture's space: the object moved through a world-space
        field by ``model`` (space "world"), then the field's own ``transform``."""
        steps = []
        if self.space == "world" and self.model != Transform():  # the object moves through the field
            m = self.model.object_from_texture()
            steps.append((m[:3, :3].T, m[:3, 3]))
        if self.transform != Transform():  # the identity costs nothing
            m = self.transform.texture_from_object()
            steps.append((m[:3, :3].T, m[:3, 3]))
        return Placement(tuple(steps))

    def evaluate(self, points: np.ndarray, ctx: EvalContext) -> np.ndarray:
        """``(n, channels)`` float64 linear values at ``(n, 3)`` texture-space points."""
        raise NotImplementedError

    def reads_hull(self) -> bool:
        """Whether :meth:`evaluate` reads ``ctx.hull`` (a bake makes it only then)."""
        return False

    def placed_bounds(self, ctx: EvalContext) -> np.ndarray | None:
        """``(2, 3)`` box in this texture's space that holds the object: its bounding box
        (``ctx.bounds``) through the placement, boxed again; None without bounds."""
        if ctx.bounds is None:
            return None
        lo, hi = np.asarray(ctx.bounds, dtype=np.float64)
        corners = np.array([[(lo, hi)[(k >> axis) & 1][axis] for axis in range(3)] for k in range(8)])
        placed, _, _ = self.placement()(corners, None, None)
        return np.array([placed.min(axis=0), placed.max(axis=0)])

    def __call__(self, points: np.ndarray, ctx: EvalContext) -> np.ndarray:
        """:meth:`evaluate`, with NaN in every channel where a point or its footprint is
        not finite (NaN in, NaN out: such a point has no place in the pattern)."""
        footprint = () if ctx.dpdx is None or ctx.dpdy is None else (ctx.dpdx, ctx.dpdy)
        if all(np.isfinite(np.sum(a)) for a in (points, *footprint)):  # a NaN or infinity makes its sum one
            return self.evaluate(points, ctx)  # (an overflowing sum takes the row-by-row check below)
        bad = ~np.isfinite(points).all(axis=1)
        if ctx.dpdx is not None and ctx.dpdy is not None:
            bad |= ~(np.isfinite(ctx.dpdx).all(axis=1) & np.isfinite(ctx.dpdy).all(axis=1))
        if not bad.any():
            return self.evaluate(points, ctx)
        zero = np.zeros_like(points)
        if ctx.dpdx is not None and ctx.dpdy is not None:
            ctx = dataclasses.replace(ctx, dpdx=np.where(bad[:, None], zero, ctx.dpdx), dpdy=np.where(bad[:, None], zero, ctx.dpdy))
        out = self.evaluate(np.where(bad[:, None], zero, points), ctx)
        out[bad] = np.nan
        return out


class Position(_Texture):
    """The object-space point, normalised per axis to the mesh's bounding box (RGB = XYZ)."""

    name: Literal["position"] = "position"

    def placement(self) -> Placement:  # normalised to the mesh's box: the transform does not apply
        return Placement(super().placement().steps[:1] if self.space == "world" and self.model != Transform() else ())

    def evaluate(self, points, ctx):
        from .basic import position

        box = np.array([[0.0] * 3, [1.0] * 3]) if ctx.bounds is None else np.asarray(ctx.bounds, float)
        return position(points, box[0], box[1])


class Checker(_Texture):
    """The lecture's checkerboard: boxes of size (Cx, Cy, Cz) in two colours.

    Uses ``floor`` (no anomaly at 0) and a closed-form filter over the texel's footprint
    parallelogram, cut to the object's bounding box (``basic.checker_parity``).
    """

    name: Literal["checker"] = "checker"
    box: tuple[
        Annotated[float, Field(gt=0)], Annotated[float, Field(gt=0)], Annotated[float, Field(gt=0)]
    ] = (0.125, 0.125, 0.125)
    color_even: Colour = (0.9, 0.9, 0.9)
    color_odd: Colour = (0.05, 0.05, 0.05)
    filtered: bool = Field(True, description="box-filter over the texel footprint")

    def evaluate(self, points, ctx):
        from .basic import checker

        dpdx, dpdy = (ctx.dpdx, ctx.dpdy) if self.filtered else (None, None)
        return checker(points, self.box, self.color_even, self.color_odd, dpdx, dpdy, self.placed_bounds(ctx), ctx.hull)

    def reads_hull(self) -> bool:
        return self.filtered


def _check_knots(knots, values) -> None:
    if len(knots) != len(values) or not knots:
        raise ValueError(f"expected one knot for each of at least one value, got {len(knots)} knots for {len(values)} values")
    if any(b <= a for a, b in pairwise(knots)):
        raise ValueError(f"expected increasing knots, got {list(knots)}")


class ColourMap(BaseModel):
    """A spline colour curve: colours at increasing knots, Catmull-Rom in between."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    knots: tuple[float, ...] = (0.0, 1.0)
    colours: tuple[Colour, ...] = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))

    @model_validator(mode="after")
    def _check(self):
        _check_knots(self.knots, self.colours)
        return self

    def __call__(self, t: np.ndarray) -> np.ndarray:
        """``(n, 3)`` colours of ``(n,)`` values."""
        from .colour import colours

        return colours(self.knots, self.colours, t)


class Curve(BaseModel):
    """A scalar spline curve (one colour channel)."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    knots: tuple[float, ...]
    values: tuple[float, ...]

    @model_validator(mode="after")
    def _check(self):
        _check_knots(self.knots, self.values)
        return self


class NoiseBasis(BaseModel):
    """Which noise: the lecture's lattice (value) noise or Perlin's gradient noise."""

    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    basis: Literal["value", "perlin"] = "value"
    interpolation: Literal["linear", "cubic", "catmull-rom"] = Field("linear", description="value noise only")
    seed: Annotated[int, Field(ge=0, le=2**32 - 1)] = 0


class TurbulenceParams(NoiseBasis):
    """Octaves of noise: ``sum_k gain^k noise(lacunarity^k (scale p + offset))``."""

    scale: Annotated[float, Field(gt=0, le=1e6)] = 4.0
    offset: Annotated[float, Field(ge=-1e9, le=1e9)] = 0.0
    octaves: Annotated[int, Field(ge=1, le=30)] = 8
    lacunarity: Annotated[float, Field(ge=1.1, le=8.0)] = 2.0
    gain: Annotated[float, Field(gt=0, lt=1)] = 0.5


class Noise(_Texture, NoiseBasis):
    """Scaled and offset lattice noise: ``noise(scale * p + offset)``, through a colour map."""

    name: Literal["noise"] = "noise"
    scale: Annotated[float, Field(gt=0, le=1e6)] = 8.0
    offset: Annotated[float, Field(ge=-1e9, le=1e9)] = 0.0
    colormap: ColourMap = ColourMap()

    def evaluate(self, points, ctx):
        from .solid import turbulence

        t = turbulence(points, ctx.width, scale=self.scale, offset=self.offset, octaves=1, basis=self.basis,
                       interpolation=self.interpolation, seed=self.seed)
        return self.colormap(t)


class Turbulence(_Texture, TurbulenceParams):
    """Perlin's turbulence in [0, 1], filtered by the texel footprint.

    Each octave is shrunk towards its mean by the share a box filter over the footprint
    keeps of it; octaves finer than 1/8 of the footprint are skipped (their mean added;
    see ``noise.octave_sum``); those near the footprint's size are evaluated at its four
    quarters (``noise.quarter_octave_sums``). Filtered, the colour is the mean of the
    quarters' colours, each the colour map's mean over the value's spread inside the
    quarter (:func:`filtered_colours`), not the colour of the filtered value.
    """

    name: Literal["turbulence"] = "turbulence"
    colormap: ColourMap = ColourMap()

    def evaluate(self, points, ctx):
        from .solid import quarter_turbulence, turbulence

        if ctx.dpdx is None or ctx.dpdy is None:
            return self.colormap(turbulence(points, None, max_octaves=ctx.max_octaves, **turbulence_args(self)))
        t = quarter_turbulence(points, ctx.dpdx, ctx.dpdy, ctx.width, max_octaves=ctx.max_octaves, **turbulence_args(self))
        return filtered_colours(self.colormap, t, ctx.width, self, ctx.max_octaves, quarters=True)


def filtered_colours(colormap: ColourMap, t: np.ndarray, width: np.ndarray, params: TurbulenceParams,
                     max_octaves: int | None, *, quarters: bool = False) -> np.ndarray:
    """``(n, 3)`` mean colours of a filtered octave sum ``t`` ``(n,)`` in [0, 1] (turbulence,
    or fBm as ``0.5 + 0.5 fBm``: the same spread) at footprints ``width`` ``(n,)``: the value
    taken as Gaussian about ``t`` with the spread the filter took out of it
    (``noise.octave_spread``, over the octaves' normalisation), through the colour map
    (``colour.spread_colours``).

    ``quarters``: ``t`` is ``(4, n)``, the sum at each footprint's four quarters
    (``solid.quarter_turbulence``), each with a quarter's spread; the colour is the mean of
    the four colours (the footprint's mean colour), not the colour of their mean."""
    from .colour import spread_colours
    from .noise import octave_count, octave_spread, octave_variance

    args = {k: v for k, v in turbulence_args(params).items() if k != "offset"}
    norm = octave_count(params.octaves, params.gain).norm
    spread = octave_spread(width, max_octaves=max_octaves, quarters=quarters, **args) / norm
    whole = np.sqrt(sum(params.gain ** (2 * k) for k in range(params.octaves)) * octave_variance(params.basis, params.interpolation,
                                                                                                  params.seed)) / norm
    parts = len(t) if quarters else 1
    values, spreads = np.reshape(t, -1), np.tile(spread, parts)
    out = spread_colours(colormap.knots, colormap.colours, values, spreads, whole)
    point = spreads == 0  # a zero footprint: the point-sampled colour exactly
    if point.any():
        out[point] = colormap(values[point])
    return out.reshape(parts, -1, 3).mean(axis=0) if quarters else out


class FBm(_Texture, TurbulenceParams):
    """Fractional Brownian motion: signed octave sum, shown as 0.5 + 0.5 fBm."""

    name: Literal["fbm"] = "fbm"
    colormap: ColourMap = ColourMap()

    def evaluate(self, points, ctx):
        from .solid import turbulence

        t = turbulence(points, ctx.width, signed=True, max_octaves=ctx.max_octaves, **turbulence_args(self))
        if ctx.width is None:
            return self.colormap(0.5 + 0.5 * t)
        return filtered_colours(self.colormap, 0.5 + 0.5 * t, ctx.width, self, ctx.max_octaves)


MARBLE_COLOURS = ColourMap(
    knots=(0.0, 0.35, 0.65, 0.85, 1.0),
    colours=((0.08, 0.07, 0.09), (0.45, 0.42, 0.45), (0.85, 0.83, 0.8), (0.93, 0.92, 0.9), (0.98, 0.97, 0.95)),
)
WOOD_COLOURS = ColourMap(knots=(0.0, 1.0), colours=((0.55, 0.33, 0.14), (0.30, 0.15, 0.05)))


class Marble(_Texture):
    """Perlin's marble: ``MarbleColor(sin(frequency * x + amplitude * turbulence(p)))``.

    Point-sampled, evaluated in one pass (``colour.marble_colours``). Filtered, the
    colour is the mean of the colour map's means over the phase spread of each of the
    footprint's four quarters (``colour.quarter_marble_colours``), not the colour of the
    filtered value.
    """

    name: Literal["marble"] = "marble"
    axis: Literal["x", "y", "z"] = "x"
    frequency: Annotated[float, Field(gt=0, le=1e6)] = 12.0
    amplitude: Annotated[float, Field(ge=0, le=1e3)] = 4.0
    turbulence: TurbulenceParams = TurbulenceParams()
    colormap: ColourMap = MARBLE_COLOURS

    def evaluate(self, points, ctx):
        from .colour import marble_colours, quarter_marble_colours

        args = {"axis": "xyz".index(self.axis), "frequency": self.frequency, "amplitude": self.amplitude,
                "max_octaves": ctx.max_octaves, **turbulence_args(self.turbulence)}
        if ctx.dpdx is None or ctx.dpdy is None:  # point samples: the fused kernel
            return marble_colours(points, None, self.colormap.knots, self.colormap.colours, **args)
        return quarter_marble_colours(points, ctx.dpdx, ctx.dpdy, ctx.width, self.colormap.knots, self.colormap.colours, **args)


class Wood(_Texture):
    """Wood grain: rings ``D + A rings(r / M + K sin(N theta + B z))`` about a tilted axis.

    ``ring_width`` is M, ``wobble`` K, ``wobbles`` N, ``twist`` B, ``tilt`` the rotation T
    of the ring axis (XYZ Euler degrees); D and A are the colour map's ends. Filtered, the
    colour is the two ends mixed by the share of ring 1 in the texel (the mean colour: the
    point-sampled rings are only ever 0 or 1).
    """

    name: Literal["wood"] = "wood"
    ring_width: Annotated[float, Field(gt=0, le=1e6)] = 0.04
    wobble: Annotated[float, Field(ge=0, le=100)] = 0.3
    wobbles: Annotated[float, Field(ge=0, le=1000)] = 4.0
    twist: Annotated[float, Field(ge=-1e3, le=1e3)] = 2.0
    tilt: Vec3 = (0.0, 0.0, 0.0)
    colormap: ColourMap = WOOD_COLOURS

    def placement(self) -> Placement:
        """Then the ring axis turned by ``tilt`` T: ``T^-1 q``."""
        steps = super().placement().steps
        if any(self.tilt):
            steps += ((Transform(rotate=self.tilt).object_from_texture()[:3, :3], None),)
        return Placement(steps)

    def evaluate(self, points, ctx):
        from .solid import wood

        t = wood(points, ctx.width, ring_width=self.ring_width, wobble=self.wobble, wobbles=self.wobbles, twist=self.twist,
                 dpdx=ctx.dpdx, dpdy=ctx.dpdy)
        if ctx.width is None:
            return self.colormap(t)
        # the rings are 0 or 1: the mean colour over a texel is the colours of 0 and 1 mixed
        ends = self.colormap(np.array([0.0, 1.0]))
        return ends[0] + t[:, None] * (ends[1] - ends[0])


class Flame(_Texture):
    """Watt and Watt's flame: ``(1 - y/h) flame_color(|x/b| + turbulence(x, t))``.

    The flame spans (-b, 0) to (b, h) in the x-y plane about its axis, which stands
    upright (along y) on the centre of the object's base: the middle of the bounding
    box's bottom face (its min-y face). ``height`` h is the object's height (the box's
    y extent) and ``half_width`` b half its width (x extent) unless given; ``transform``
    moves, turns and scales the flame from there.
    ``red``, ``green`` and ``blue`` are spline curves of ``|x/b| + turbulence``, highest
    at the centre, green and blue falling off faster than red.
    """

    name: Literal["flame"] = "flame"
    emits: ClassVar[bool] = True
    half_width: Annotated[float, Field(gt=0, le=1e6)] | None = Field(None, description="none: half the object's width")
    height: Annotated[float, Field(gt=0, le=1e6)] | None = Field(None, description="none: the object's height")
    time: Annotated[float, Field(ge=-1e6, le=1e6)] = 0.0
    rise: Annotated[float, Field(ge=-1e3, le=1e3)] = 1.0
    turbulence_amount: Annotated[float, Field(ge=0, le=100)] = 0.6
    turbulence: TurbulenceParams = TurbulenceParams(scale=6.0, octaves=6)
    red: Curve = Curve(knots=(0.0, 0.6, 1.1), values=(1.0, 0.9, 0.0))
    green: Curve = Curve(knots=(0.0, 0.35, 0.8), values=(0.95, 0.45, 0.0))
    blue: Curve = Curve(knots=(0.0, 0.2, 0.45), values=(0.8, 0.15, 0.0))

    def evaluate(self, points, ctx):
        from .solid import flame, spline

        base, half_width, height = self.frame(ctx.bounds)
        s, weight = flame(points - base, ctx.width, half_width=half_width, height=height, time=self.time, rise=self.rise,
                          turbulence_amount=self.turbulence_amount, max_octaves=ctx.max_octaves,
                          **turbulence_args(self.turbulence))
        rgb = [spline(s, np.asarray(c.knots), np.asarray(c.values)[:, None])[:, 0] for c in (self.red, self.green, self.blue)]
        return np.clip(np.column_stack(rgb), 0.0, None) * weight[:, None]

    def frame(self, bounds: np.ndarray | None) -> tuple[np.ndarray, float, float]:
        """``(foot (3,), b, h)``: where the foot of the flame's axis lands in this texture's
        space, the flame's half width and its height.

        ``bounds``: ``(2, 3)`` bounding box of the object in the bake's texture space
        (None: the unit cube). The flame's frame is that space moved to the centre of the
        box's bottom (min-y) face, then placed by the spec's placement, so a transform
        moves, turns and scales the flame from the object's base: the foot is returned as
        the placement's linear part applied to it (the points subtract it). b and h are
        ``half_width`` and ``height``, else half the box's x extent and its y extent.
        """
        box = np.array([[0.0] * 3, [1.0] * 3]) if bounds is None else np.asarray(bounds, dtype=np.float64)
        foot = np.array([0.5 * (box[0, 0] + box[1, 0]), box[0, 1], 0.5 * (box[0, 2] + box[1, 2])])
        ends, _, _ = self.placement()(np.array([foot, np.zeros(3)]), None, None)
        b = self.half_width if self.half_width is not None else 0.5 * float(box[1, 0] - box[0, 0])
        h = self.height if self.height is not None else float(box[1, 1] - box[0, 1])
        return ends[0] - ends[1], b or 1.0, h or 1.0


def turbulence_args(params: TurbulenceParams) -> dict:
    """Keyword arguments of ``solid.turbulence`` from a spec holding turbulence fields."""
    names = ("scale", "offset", "octaves", "lacunarity", "gain", "basis", "interpolation", "seed")
    return {name: getattr(params, name) for name in names}


TextureSpec = Annotated[Position | Checker | Noise | Turbulence | FBm | Marble | Wood | Flame, Field(discriminator="name")]
TEXTURE_CLASSES: tuple[type[_Texture], ...] = get_args(get_args(TextureSpec)[0])

TEXTURES = {cls.model_fields["name"].default: cls for cls in TEXTURE_CLASSES}


@functools.cache
def _adapter() -> TypeAdapter:
    """The validator of the union of every texture, built on first use: building it
    builds every texture's schema, while a bake validates one texture (by its class)."""
    return TypeAdapter(TextureSpec)


@functools.cache
def _schema(name: str) -> dict:
    """The JSON Schema of texture ``name``, its own parameters first (then the placement's)."""
    schema = TEXTURES[name].model_json_schema()
    shared = set(_Texture.model_fields)
    schema["properties"] = dict(sorted(schema["properties"].items(), key=lambda item: item[0] in shared))
    return schema


def _describe(name: str, error: ValidationError) -> str:
    """The problems of a spec of texture ``name``, written for a person, each path from the
    spec's top: ``marble has no parameter 'octaves' (it has: ...)``, ``turbulence.octaves:
    expected a whole number from 1 to 30, got 99``; ``; `` between several."""
    parts = [f"{field}: {problem}" if field else problem if problem.startswith(name) else f"{name}: {problem}"
             for field, problem in describe(error.errors(include_url=False), _schema(name), subject=name)]
    return "; ".join(parts)


def with_overrides(value, assignments: list[str]) -> _Texture:
    """A spec with ``key.sub=value`` assignments applied (values are JSON, else strings).

    ``with_overrides("marble", ["turbulence.octaves=6"])``. A bad ``value`` raises
    :class:`TextureError` starting ``texture:``, a bad assignment one starting ``set:``
    (the command line's ``--texture`` and ``--set``); unknown keys are named with the
    parameters there are.
    """
    try:
        spec = parse_spec(value)
    except TextureError as exc:
        raise TextureError(f"texture: {exc}") from None
    data = {"name": spec.name, **spec.model_dump(mode="json", exclude_defaults=True)}
    whole = spec.model_dump(mode="json")  # a group set in part keeps the rest of its values (not its class's defaults)
    for item in assignments:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            raise TextureError(f"set: expected key=value (e.g. turbulence.octaves=6), got {item!r}")
        try:
            parsed = json.loads(raw)
        except json.JSONDecodeError:
            parsed = raw
        node: Any = data
        full: Any = whole
        *parents, leaf = key.strip().split(".")
        for part in parents:
            full = full.get(part, {}) if isinstance(full, dict) else {}
            node = node.setdefault(part, full if not isinstance(full, dict) else dict(full))
            if not isinstance(node, dict):
                raise TextureError(f"set: {item!r}: {part!r} is one value, not a group of parameters")
        node[leaf] = parsed
    try:
        return parse_spec(data)
    except TextureError as exc:
        raise TextureError(f"set: {exc}") from None


def catalogue() -> list[dict]:
    """Every texture with its parameters: name, default, allowed range, description."""
    out = []
    for name, cls in TEXTURES.items():
        schema = cls.model_json_schema()
        params = []
        for field, info in cls.model_fields.items():
            if field == "name":
                continue
            prop = schema["properties"].get(field, {})
            limits = {k: prop[k] for k in ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "enum") if k in prop}
            default = info.default.model_dump(mode="json") if isinstance(info.default, BaseModel) else info.default
            params.append({"name": field, "default": default, "limits": limits, "description": info.description or ""})
        out.append({"name": name, "description": (cls.__doc__ or "").strip().splitlines()[0], "parameters": params})
    return out


def json_schema() -> dict:
    """The JSON Schema of a texture spec (all textures, discriminated by ``name``)."""
    return _adapter().json_schema()


MAX_NESTING = 32  # of JSON text given as a spec: deeper is refused before parsing (json.loads recurses)


def _nesting(text: str) -> int:
    """The deepest nesting of ``{`` and ``[`` in JSON ``text``, outside strings (no parse)."""
    depth = deepest = 0
    in_string = escaped = False
    for c in text:
        if in_string:
            if escaped:
                escaped = False
            elif c == "\\":
                escaped = True
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "{[":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "}]":
            depth -= 1
    return deepest


def parse_spec(value) -> _Texture:
    """A texture spec from a spec object, a dict, a texture name or JSON text.

    Pure: a string is a name or JSON, never a path (only the command line reads spec
    files). Raises :class:`TextureError` naming the unknown texture (and the name it is
    close to), the bad parameter (and the texture's parameters) or where JSON text (a
    string starting with ``{`` or ``[``) fails to parse; any other string that is not a
    known name is an unknown texture, whatever it names.
    """
    if isinstance(value, _Texture):
        return value
    if isinstance(value, str):
        value = _from_text(value)
    if not isinstance(value, dict):
        raise TextureError(f"expected a texture name or a spec (a mapping with a 'name'), got {type(value).__name__}")
    if "name" not in value:
        raise TextureError(f"a spec needs a 'name' (one of {', '.join(sorted(TEXTURES))}), got the keys {', '.join(map(str, value))}")
    if not isinstance(value["name"], str) or value["name"] not in TEXTURES:  # a dict would not even hash
        raise TextureError(_unknown(value["name"]))
    try:
        return TEXTURES[value["name"]].model_validate(value)  # the union's choice, without building the others
    except ValidationError as exc:
        raise TextureError(_describe(value["name"], exc)) from None


def _unknown(name) -> str:
    """``unknown texture 'marbel' (did you mean 'marble'? known: ...)``."""
    return f"unknown texture {shown(name, 80)} ({did_you_mean(name, sorted(TEXTURES))}known: {', '.join(sorted(TEXTURES))})"


def _from_text(value: str):
    """A texture name's spec, or the JSON text's object (a TextureError for anything else)."""
    text = value.strip()
    if text in TEXTURES:
        return {"name": text}
    if not text.startswith(("{", "[")):
        raise TextureError(_unknown(text))
    if _nesting(text) > MAX_NESTING:
        raise TextureError(f"JSON spec nested deeper than {MAX_NESTING} levels")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise TextureError(json_error_text(exc)) from None
    if not isinstance(data, dict):
        raise TextureError(f"expected a JSON object with a 'name', got a {type(data).__name__}")
    return data
