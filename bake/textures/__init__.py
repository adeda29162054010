"""Solid textures and their evaluation.

``evaluate(spec, points, footprint)`` maps object-space points (and their texel
footprints) through the spec's transform into texture space and evaluates the texture
there. It reads nothing but its arguments.
"""

from __future__ import annotations

import numpy as np

from . import basic
from .spec import (
    TEXTURES,
    Checker,
    ColourMap,
    FBm,
    Flame,
    Marble,
    Noise,
    Position,
    TextureSpec,
    Transform,
    Turbulence,
    Wood,
    parse_spec,
)

__all__ = ["evaluate", "parse_spec", "TextureSpec", "Transform", "TEXTURES"]


def _colours(colormap: ColourMap, t: np.ndarray) -> np.ndarray:
    from .colour import colours

    return colours(colormap.knots, colormap.colours, t)


def _width(dpdx, dpdy) -> np.ndarray | None:
    """Footprint width per point: the longer of the two texel edges."""
    if dpdx is None:
        return None
    return np.sqrt(np.maximum(np.einsum("ij,ij->i", dpdx, dpdx), np.einsum("ij,ij->i", dpdy, dpdy)))


def evaluate(spec, points, footprint=None, *, bounds=None, max_octaves=None) -> np.ndarray:
    """Evaluate a texture at object-space points.

    Parameters
    ----------
    spec : texture spec, dict, name or JSON (see :func:`parse_spec`)
    points : (n, 3) float
        Object-space points.
    footprint : (n, 2, 3) float or None
        ``dpdx`` and ``dpdy``: the object-space change of the point over one texel in
        x and in y. ``None`` point-samples the texture.
    bounds : (2, 3) float or None
        Object-space bounding box of the mesh (used by ``position``); the unit cube if
        ``None``.
    max_octaves : int or None
        Cap on the octaves of turbulence-based textures (turbulence, fbm, marble, flame);
        the capped octaves add their mean. ``None``: the spec's own count.

    Returns
    -------
    (n, channels) float64 linear values.
    """
    spec = parse_spec(spec)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = None if footprint is None else np.asarray(footprint, dtype=np.float64).reshape(-1, 2, 3)
    dpdx, dpdy = (None, None) if f is None else (f[:, 0], f[:, 1])
    if spec.space == "world" and spec.model != Transform():  # the object moves through the field
        m = spec.model.object_from_texture()
        p = p @ m[:3, :3].T + m[:3, 3]
        if f is not None:
            dpdx, dpdy = dpdx @ m[:3, :3].T, dpdy @ m[:3, :3].T
    q = p
    if spec.transform != Transform():  # the identity costs nothing
        m = spec.transform.texture_from_object()
        q = p @ m[:3, :3].T + m[:3, 3]
        if f is not None:
            dpdx, dpdy = dpdx @ m[:3, :3].T, dpdy @ m[:3, :3].T
    if isinstance(spec, Position):
        box = np.array([[0.0] * 3, [1.0] * 3]) if bounds is None else np.asarray(bounds, float)
        return basic.position(p, box[0], box[1])
    if isinstance(spec, Checker):
        if not spec.filtered:
            dpdx = dpdy = None
        return basic.checker(q, spec.box, spec.color_even, spec.color_odd, dpdx, dpdy)

    from . import solid

    width = _width(dpdx, dpdy)
    if isinstance(spec, Noise):
        t = solid.turbulence(q, width, scale=spec.scale, offset=spec.offset, octaves=1, basis=spec.basis,
                             interpolation=spec.interpolation, seed=spec.seed)
        return _colours(spec.colormap, t)
    if isinstance(spec, (Turbulence, FBm)):
        t = solid.turbulence(q, width, signed=isinstance(spec, FBm), max_octaves=max_octaves, **_turbulence_args(spec))
        return _colours(spec.colormap, 0.5 + 0.5 * t if isinstance(spec, FBm) else t)
    if isinstance(spec, Marble):
        t = solid.marble(q, width, axis="xyz".index(spec.axis), frequency=spec.frequency,
                         amplitude=spec.amplitude, max_octaves=max_octaves, **_turbulence_args(spec.turbulence))
        return _colours(spec.colormap, t)
    if isinstance(spec, Wood):
        if any(spec.tilt):
            tilt = Transform(rotate=spec.tilt).object_from_texture()[:3, :3]
            q = q @ tilt  # T^-1 p: the ring axis turned by T
        t = solid.wood(q, width, ring_width=spec.ring_width, wobble=spec.wobble, wobbles=spec.wobbles, twist=spec.twist)
        return _colours(spec.colormap, t)
    if isinstance(spec, Flame):
        s, weight = solid.flame(q, width, half_width=spec.half_width, height=spec.height, time=spec.time,
                                rise=spec.rise, turbulence_amount=spec.turbulence_amount, max_octaves=max_octaves,
                                **_turbulence_args(spec.turbulence))
        rgb = [solid.spline(s, np.asarray(c.knots), np.asarray(c.values)[:, None])[:, 0] for c in (spec.red, spec.green, spec.blue)]
        return np.clip(np.column_stack(rgb), 0.0, None) * weight[:, None]
    raise TypeError(f"no evaluator for texture {spec.name!r}")  # pragma: no cover


def _turbulence_args(params) -> dict:
    """Keyword arguments of ``solid.turbulence`` from a spec holding turbulence fields."""
    names = ("scale", "offset", "octaves", "lacunarity", "gain", "basis", "interpolation", "seed")
    return {name: getattr(params, name) for name in names}
