"""Solid textures and their evaluation, after pbrt's texture interface.

The textures and their noise follow the procedural-texturing lecture (Brian Russin,
"Procedural Texturing", module 3C of Johns Hopkins EP 605.767 Applied Computer Graphics;
kept at ``../shared/reference/procedural-texturing-lecture.txt`` from the project folder),
cited as "the lecture" everywhere else.

``evaluate(spec, points, footprint)`` takes object-space points and their texel
footprints through the spec's :class:`~texbake.textures.context.Placement` into texture
space, points and differentials together, and the spec evaluates itself there with an
:class:`~texbake.textures.context.EvalContext`. Each spec class owns its evaluation
(``evaluate``); the registry is the ``TextureSpec`` union in ``spec.py``. It reads nothing
but its arguments.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._lazy import lazy_names
from .context import EvalContext, Placement
from .mapping import place_and_evaluate

if TYPE_CHECKING:
    from .spec import TEXTURES, TextureSpec, Transform, parse_spec

__all__ = ["TEXTURES", "EvalContext", "Placement", "TextureSpec", "Transform", "evaluate", "parse_spec"]
# the specs' models on first use: the pipeline places a field (mapping) in every bake, a
# bake of mesh maps alone evaluates no texture
__getattr__ = lazy_names(__name__, dict.fromkeys(("TEXTURES", "TextureSpec", "Transform", "parse_spec"), "spec"))


def evaluate(spec, points, footprint=None, *, bounds=None, max_octaves=None) -> np.ndarray:
    """Evaluate a texture at object-space points.

    Parameters
    ----------
    spec : TextureSpec, dict or str
        The texture: a parsed spec, a mapping with its ``name`` and parameters, a texture
        name or a JSON object (see :func:`parse_spec`; a string is never read as a path).
    points : (n, 3) array_like of float
        Object-space points; cast to float64. One point of shape ``(3,)`` is taken as
        ``(1, 3)``.
    footprint : (n, 2, 3) array_like of float, optional
        ``dpdx`` and ``dpdy``: the object-space change of the point over one texel in x
        and in y; cast to float64. None (the default) point-samples the texture.
    bounds : (2, 3) array_like of float, optional
        Object-space bounding box ``(lo, hi)`` of the mesh: ``position`` maps it to
        ``[0, 1]^3``, the flame stands on its base and the filtered checkerboard's
        footprints are cut to it. None: the unit cube.
    max_octaves : int, optional
        Cap on the octaves of turbulence-based textures (turbulence, fbm, marble,
        flame); the capped octaves add their mean. None: the spec's own count.

    Returns
    -------
    values : (n, 3) ndarray of float64
        Linear RGB; in ``[0, 1]`` except the flame, which is light and may exceed 1. NaN
        in every channel of a point that is NaN or infinite (or whose footprint is),
        in object or texture space.

    Raises
    ------
    TextureError
        The spec is not a known texture or has an unknown or out-of-range parameter.
    """
    from .spec import parse_spec

    spec = parse_spec(spec)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = None if footprint is None else np.asarray(footprint, dtype=np.float64).reshape(-1, 2, 3)
    return place_and_evaluate(spec, p, None if f is None else f[:, 0], None if f is None else f[:, 1], bounds=bounds,
                              max_octaves=max_octaves)
