"""Solid textures and their evaluation.

``evaluate(spec, points, footprint)`` maps object-space points (and their texel
footprints) through the spec's transform into texture space and evaluates the texture
there. It reads nothing but its arguments.
"""

from __future__ import annotations

import numpy as np

from . import basic
from .spec import TEXTURES, Checker, Position, TextureSpec, Transform, parse_spec

__all__ = ["evaluate", "parse_spec", "TextureSpec", "Transform", "TEXTURES", "Checker", "Position"]


def evaluate(spec, points, footprint=None, *, bounds=None) -> np.ndarray:
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

    Returns
    -------
    (n, channels) float64 linear values.
    """
    spec = parse_spec(spec)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = None if footprint is None else np.asarray(footprint, dtype=np.float64).reshape(-1, 2, 3)
    dpdx, dpdy = (None, None) if f is None else (f[:, 0], f[:, 1])
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
    raise TypeError(f"no evaluator for texture {spec.name!r}")  # pragma: no cover
