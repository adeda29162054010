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


def _square_wave_integral(t: np.ndarray) -> np.ndarray:
    """Integral from 0 to ``t`` of the wave that is +1 on [0, 1) and -1 on [1, 2), period 2."""
    u = np.mod(t, 2.0)
    return 1.0 - np.abs(u - 1.0)


def _nudge(t: np.ndarray) -> np.ndarray:
    return t + _PLANE_NUDGE * np.maximum(1.0, np.abs(t))


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
    t = _nudge(points / box)
    if dpdx is None or dpdy is None:
        return np.prod(1.0 - 2.0 * np.mod(np.floor(t), 2.0), axis=1)
    half = 0.5 * (np.abs(dpdx) + np.abs(dpdy)) / box
    wide = half > 1e-12
    a = t - half
    b = t + half
    mean = np.divide(
        _square_wave_integral(b) - _square_wave_integral(a),
        2.0 * half,
        out=np.zeros_like(t),
        where=wide,
    )
    point = 1.0 - 2.0 * np.mod(np.floor(t), 2.0)
    return np.prod(np.where(wide, mean, point), axis=1)


def checker(points, box, color_even, color_odd, dpdx=None, dpdy=None) -> np.ndarray:
    """Checkerboard colours ``(n, c)``: ``color_even`` on even cells, ``color_odd`` on odd."""
    s = checker_parity(points, np.asarray(box, dtype=np.float64), dpdx, dpdy)
    w = (0.5 * (1.0 + s))[:, None]
    even = np.asarray(color_even, dtype=np.float64)
    odd = np.asarray(color_odd, dtype=np.float64)
    return w * even + (1.0 - w) * odd
