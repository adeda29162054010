"""Basic solid textures: object position and the checkerboard.

Textures are pure functions of texture-space points ``(n, 3)`` float64 and the texel
footprint ``dpdx``, ``dpdy`` (``(n, 3)`` float64 each, or ``None`` for point sampling).
They return ``(n, c)`` float64 linear values.
"""

from __future__ import annotations

import numpy as np

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
) -> np.ndarray:
    """Mean of the signed checker ``(-1) ** (floor(x/Cx) + floor(y/Cy) + floor(z/Cz))``.

    ``box``: ``(3,)`` cell sizes (Cx, Cy, Cz). With a footprint the mean is taken in
    closed form over the axis-aligned box that bounds the texel's parallelogram
    (the checker is separable, so the box mean is the product of three 1D means of a
    square wave, each the difference of its triangle-wave integral). Returns ``(n,)``
    float64 in ``[-1, 1]``: +1 for the even cells.
    """
    t = points / box
    t += _PLANE_NUDGE * np.maximum(1.0, np.abs(t))
    if dpdx is None or dpdy is None:
        return _sign(np.floor(t).sum(axis=1))
    half = (np.abs(dpdx) + np.abs(dpdy)) * (0.5 / box)
    wide = half > 1e-12
    mean = _triangle(t + half)
    mean -= _triangle(t - half)
    np.divide(mean, 2.0 * half, out=mean, where=wide)
    np.clip(mean, -1.0, 1.0, out=mean)  # far out, t +- half round: keep the mean a mean
    if not wide.all():  # no footprint along an axis: point-sample that axis
        mean[~wide] = _sign(np.floor(t[~wide]))
    return mean.prod(axis=1)


def checker(points, box, color_even, color_odd, dpdx=None, dpdy=None) -> np.ndarray:
    """Checkerboard colours ``(n, c)``: ``color_even`` on even cells, ``color_odd`` on odd."""
    s = checker_parity(points, np.asarray(box, dtype=np.float64), dpdx, dpdy)
    w = (0.5 * (1.0 + s))[:, None]
    even = np.asarray(color_even, dtype=np.float64)
    odd = np.asarray(color_odd, dtype=np.float64)
    return w * even + (1.0 - w) * odd
