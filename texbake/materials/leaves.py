"""The leaves of a material's graph, each over a whole batch of points: a texture's colour
or value, the position, the normal, and a texture at warped points.

Every leaf gives ``(mean, variance)``: ``(n, c)`` float64 arrays, the variance the
leaf's spread over each texel's footprint (None: none known, or point sampling) that the
non-linear nodes after it average their functions over (``native/materials.cpp``):

- a texture's **colour** is its own filtered texel mean (its spread is not known: None);
- a **value** of noise, turbulence or fBm: the filtered octave sum, and as its spread
  the variance its octaves keep inside the texel: each octave's weight squared times the
  basis' variance (measured once per basis, interpolation and seed) times the share the
  filter took out of it (``1 - fade_factor``: all of it for an octave the footprint drops
  or ``max_octaves`` caps);
- marble's value ``0.5 + 0.5 sin(phase)``, its phase a Gaussian over the texel
  (``solid.marble_phase``): the sine's mean and variance over it, in closed form;
- wood's rings and the checker, 0 or 1 inside the texel: the share ``t`` of ones and
  ``t (1 - t)``;
- the **position**, per axis 0 to 1 over the mesh's box: the box of the footprint's
  parallelogram spreads it by ``(dqdx^2 + dqdy^2) / 12`` (over the box's side squared);
- the **normal**: no spread;
- a **warp**: the texture at ``q + amount * by``, its footprint widened by the
  spread of the displacement (a box of the same variance added to it).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import _native
from ..textures.context import EvalContext
from ..textures.mapping import place_and_evaluate
from ..textures.spec import turbulence_args

Value = tuple[np.ndarray, "np.ndarray | None"]


def texture_colour(spec, q, dqdx, dqdy, bounds, max_octaves) -> Value:
    """``((n, 3), None)``: the texture's colour at bake-space points ``q`` (its placement applied)."""
    return place_and_evaluate(spec, q, dqdx, dqdy, bounds=bounds, max_octaves=max_octaves), None


def texture_value(spec, q, dqdx, dqdy, bounds, max_octaves, *, spread: bool = True) -> Value:
    """``((n, 1), (n, 1) or None)``: the scalar before the texture's colour map, and its
    spread (None unless ``spread``: no node reads it)."""
    p, dx, dy = spec.placement()(q, dqdx, dqdy)
    ctx = EvalContext(dx, dy, bounds, max_octaves)
    footprint = () if dx is None or dy is None else (dx, dy)
    bad = np.zeros(len(p), dtype=bool)
    if not all(np.isfinite(np.sum(a)) for a in (p, *footprint)):  # a NaN or infinity makes its sum one (as _Texture.__call__)
        bad = ~np.isfinite(p).all(axis=1)
        for a in footprint:
            bad |= ~np.isfinite(a).all(axis=1)
    if bad.any():  # as a texture's colour: NaN in, NaN out
        zero = np.zeros_like(p)
        p = np.where(bad[:, None], zero, p)
        if dx is not None and dy is not None:
            ctx = EvalContext(np.where(bad[:, None], zero, dx), np.where(bad[:, None], zero, dy), bounds, max_octaves)
    mean, var = _VALUES[spec.name](spec, p, ctx, spread)
    mean[bad] = np.nan
    return mean[:, None], None if var is None else var[:, None]


def _octaves(spec, p, ctx: EvalContext, spread: bool):
    from ..textures.noise import octave_count
    from ..textures.solid import turbulence

    signed = spec.name == "fbm"
    args = turbulence_args(spec) if spec.name != "noise" else {
        "scale": spec.scale, "offset": spec.offset, "octaves": 1, "basis": spec.basis, "interpolation": spec.interpolation,
        "seed": spec.seed, "lacunarity": 2.0, "gain": 0.5}
    cap = None if spec.name == "noise" else ctx.max_octaves
    width = ctx.width  # (computed each time it is read)
    t = turbulence(p, width, signed=signed, max_octaves=cap, **args)
    mean = 0.5 + 0.5 * t if signed else t
    if width is None or not spread:
        return mean, None
    count = octave_count(args["octaves"], args["gain"], cap, basis=args["basis"], seed=args["seed"])
    kept = np.empty(len(p))
    _native.octave_spread(np.ascontiguousarray(width), count.evaluated, float(args["lacunarity"]), float(args["gain"]),
                          float(args["scale"]), kept)
    left_out = sum(args["gain"] ** (2 * k) for k in range(count.evaluated, args["octaves"]))
    return mean, basis_variance(args["basis"], args["interpolation"], args["seed"]) / count.norm**2 * (kept + left_out)


def _marble(spec, p, ctx: EvalContext, spread: bool):
    from ..textures.solid import marble_phase

    phase, s = marble_phase(p, ctx.width, axis="xyz".index(spec.axis), frequency=spec.frequency, amplitude=spec.amplitude,
                            max_octaves=ctx.max_octaves, **turbulence_args(spec.turbulence))
    fade = np.exp(-0.5 * s**2)
    sine = np.sin(phase)
    mean = 0.5 + 0.5 * sine * fade
    if ctx.width is None or not spread:
        return mean, None
    square = 0.5 * (1.0 - np.exp(-2.0 * s**2) * np.cos(2.0 * phase))  # E sin^2 over the phase's Gaussian
    return mean, 0.25 * np.maximum(square - (sine * fade) ** 2, 0.0)


def _wood(spec, p, ctx: EvalContext, spread: bool):
    from ..textures.solid import wood

    t = wood(p, ctx.width, ring_width=spec.ring_width, wobble=spec.wobble, wobbles=spec.wobbles, twist=spec.twist,
             dpdx=ctx.dpdx, dpdy=ctx.dpdy)
    return t, None if ctx.width is None or not spread else t * (1.0 - t)


def _checker(spec, p, ctx: EvalContext, spread: bool):
    from ..textures.basic import checker_parity

    filtered = spec.filtered and ctx.dpdx is not None
    parity = checker_parity(p, np.asarray(spec.box, dtype=np.float64), ctx.dpdx if filtered else None,
                            ctx.dpdy if filtered else None, spec.placed_bounds(ctx))
    t = 0.5 * (1.0 + parity)  # 1 on the even cells (color_even)
    return t, t * (1.0 - t) if filtered and spread else None


_VALUES = {"noise": _octaves, "turbulence": _octaves, "fbm": _octaves, "marble": _marble, "wood": _wood, "checker": _checker}


@functools.cache
def basis_variance(basis: str, interpolation: str, seed: int) -> float:
    """The variance of one octave of the noise over space (measured at 65536 points spread
    over its 256-cell period; a fixed draw, so the same every run)."""
    from ..textures.noise import noise

    points = np.random.default_rng(0x5EED).uniform(0.0, 256.0, (1 << 16, 3))
    return float(noise(points, basis=basis, interpolation=interpolation, seed=seed).var())


def position(q, dqdx, dqdy, bounds) -> Value:
    """``((n, 3), (n, 3) or None)``: the point per axis over the box ``bounds`` (2, 3), in [0, 1]."""
    box = np.array([[0.0] * 3, [1.0] * 3]) if bounds is None else np.asarray(bounds, dtype=np.float64)
    extent = np.where(box[1] > box[0], box[1] - box[0], 1.0)
    mean = np.clip((q - box[0]) / extent, 0.0, 1.0)
    if dqdx is None or dqdy is None:
        return mean, None
    return mean, (dqdx**2 + dqdy**2) / (12.0 * extent**2)


def warped_points(q, dqdx, dqdy, by: Value, amount: float, axis: str):
    """``(q', dqdx', dqdy')``: the points moved by ``amount * by`` (``by`` ``(n, 1)``: along
    ``axis``; ``(n, 3)``: as a vector), the footprints widened by the move's spread (a box
    of its variance, ``12 var``, added to the footprint's square)."""
    mean, var = by
    move = np.zeros_like(q)
    if mean.shape[1] == 1:
        move[:, "xyz".index(axis)] = amount * mean[:, 0]
    else:
        move[:] = amount * mean
    if dqdx is None or dqdy is None or var is None:
        return q + move, dqdx, dqdy
    width2 = np.maximum(np.einsum("ij,ij->i", dqdx, dqdx), np.einsum("ij,ij->i", dqdy, dqdy))
    extra = 12.0 * amount**2 * var.sum(axis=1)
    grow = np.sqrt(np.divide(width2 + extra, width2, out=np.ones_like(width2), where=width2 > 0))[:, None]
    return q + move, dqdx * grow, dqdy * grow
