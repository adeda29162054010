"""Basic solid textures: object position and the checkerboard.

Textures are pure functions of texture-space points ``(n, 3)`` float64 and the texel
footprint ``dpdx``, ``dpdy`` (``(n, 3)`` float64 each, or ``None`` for point sampling).
They return ``(n, c)`` float64 linear values.
"""

from __future__ import annotations

import numpy as np

from .. import _native

# Relative nudge applied before ``floor`` so that a surface lying exactly on a lattice
# plane (z = 0, a cube centred at the origin) falls consistently on one side of it
# instead of flickering between both with the last bit of rounding.
_PLANE_NUDGE = 1e-10


def position(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Points normalised per axis to the box ``[lo, hi]``: ``(n, 3)`` in ``[0, 1]``."""
    extent = np.where(hi > lo, hi - lo, 1.0)
    return np.clip((points - lo) / extent, 0.0, 1.0)


def _triangle(t: np.ndarray) -> np.ndarray:
    """Integral from 0 to ``t`` of the wave that is +1 on [0, 1) and -1 on [1, 2), period 2."""
    u = t - 2.0 * np.floor(0.5 * t)
    return 1.0 - np.abs(u - 1.0)


def _sign(cells: np.ndarray) -> np.ndarray:
    """+1 for even, -1 for odd whole numbers (as floats)."""
    return 1.0 - 2.0 * (cells - 2.0 * np.floor(0.5 * cells))


def checker_parity(
    points: np.ndarray,
    box: np.ndarray,
    dpdx: np.ndarray | None = None,
    dpdy: np.ndarray | None = None,
    clip: np.ndarray | None = None,
    hull: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Mean of the signed checker ``(-1) ** (floor(x/Cx) + floor(y/Cy) + floor(z/Cz))``.

    ``box``: ``(3,)`` cell sizes (Cx, Cy, Cz). With a footprint the mean is taken in
    closed form over the footprint parallelogram ``p + a dpdx + b dpdy`` (``a``, ``b`` in
    [-1/2, 1/2]), cut into ``SPLIT x SPLIT`` smaller parallelograms, each averaged over the
    axis-aligned box that bounds it (the checker is separable, so a box mean is the
    product of three 1D means of a square wave, each the difference of its
    triangle-wave integral): the boxes hug the texel's plane, so little is averaged from
    off it, and a footprint along the axes is exact. ``clip``: ``(2, 3)`` box (texture
    space) the surface lies in, e.g. the object's bounding box; the boxes are cut to it,
    so a texel on a wall does not average the cell below a flat base it stands on
    (an axis whose point lies outside ``clip`` is not cut), and a point on a cell plane
    counts as on the side towards the box's centre, so that a face lying on the box's max
    face shows the cell inside the object, as a face on its min face does (without
    ``clip``: the side above). ``hull`` (``EvalContext.hull``): for footprints cut to the
    part of a texel a chart covers, the corners of that part's convex hull in footprint
    coordinates; those boxes are also cut to the hull's own box, so that where a chart's
    border slants across a texel along a cell plane, nothing is averaged from the far side
    (the footprint's box of the same centre and covariance reaches over it). Returns
    ``(n,)`` float64 in ``[-1, 1]``: +1 for the even cells.
    """
    c = None if clip is None else np.asarray(clip, dtype=np.float64) / box
    if dpdx is None or dpdy is None:  # point-sampled: compiled, one pass (the arithmetic below)
        out = np.empty(len(points))
        centre = np.full(3, np.nan) if c is None else 0.5 * (c[0] + c[1])
        _native.checker_points(np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(box, dtype=np.float64),
                               centre, _PLANE_NUDGE, out)
        return out
    t = points / box
    # towards the inside of ``clip`` (else up): a face on the plane of a max face is inside too
    inward = 1.0 if c is None else np.where(t > 0.5 * (c[0] + c[1]), -1.0, 1.0)
    t += inward * _PLANE_NUDGE * np.maximum(1.0, np.abs(t))
    ex, ey = dpdx / box, dpdy / box
    lo, hi = np.full_like(t, -np.inf), np.full_like(t, np.inf)
    if c is not None:
        slack = 1e-9 * np.maximum(1.0, np.abs(c))
        inside = (t >= c[0] - slack[0]) & (t <= c[1] + slack[1])  # (n, 3): cut only where the point is inside
        lo, hi = np.where(inside, c[0], -np.inf), np.where(inside, c[1], np.inf)
    if hull is not None and len(hull[0]):
        rows, corners = hull
        at = t[rows, None, :] + corners[:, :, :1] * ex[rows, None, :] + corners[:, :, 1:] * ey[rows, None, :]  # (k, H, 3)
        some = np.isfinite(at).any(axis=(1, 2))  # a row of NaN: no hull
        rows, at = rows[some], at[some]
        h_lo, h_hi = np.nanmin(at, axis=1), np.nanmax(at, axis=1)
        slack = 1e-9 * np.maximum(1.0, np.abs(t[rows]))
        inside = (t[rows] >= h_lo - slack) & (t[rows] <= h_hi + slack)
        lo[rows] = np.where(inside, np.maximum(lo[rows], h_lo), lo[rows])
        hi[rows] = np.where(inside, np.minimum(hi[rows], h_hi), hi[rows])
    out = np.empty(len(t))
    # each point's mean over SPLIT x SPLIT pieces of its footprint, each over its box cut to
    # [lo, hi]; an axis with no width (or cut to nothing) is point-sampled (native/textures.cpp)
    _native.checker_parity(*(np.ascontiguousarray(a) for a in (t, ex, ey, lo, hi)), SPLIT, out)
    return out


# Sub-parallelograms a side in the checker's footprint (see ``checker_parity``): the
# 1-sample checker's RMSE on Suzanne at 512^2 is 1.39x that of 16 point samples with 1
# (one box around the whole footprint), 0.67x with 2, 0.58x with 4.
SPLIT = 4


def checker(points, box, color_even, color_odd, dpdx=None, dpdy=None, clip=None, hull=None) -> np.ndarray:
    """Checkerboard colours ``(n, c)``: ``color_even`` on even cells, ``color_odd`` on odd
    (``clip``, ``hull``: see :func:`checker_parity`)."""
    s = checker_parity(points, np.asarray(box, dtype=np.float64), dpdx, dpdy, clip, hull)
    w = (0.5 * (1.0 + s))[:, None]
    even = np.asarray(color_even, dtype=np.float64)
    odd = np.asarray(color_odd, dtype=np.float64)
    return w * even + (1.0 - w) * odd
