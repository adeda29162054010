"""Colour maps: a spline colour curve tabulated once, looked up per point (numba)."""

from __future__ import annotations

import functools

import numba as nb  # pip install numba
import numpy as np

from .solid import spline

SIZE = 4096  # samples of the curve; linear interpolation between them errs < 1e-6


@functools.lru_cache(maxsize=64)
def table(knots: tuple[float, ...], colours: tuple[tuple[float, float, float], ...]) -> np.ndarray:
    """``(SIZE, 3)`` float64 samples of the Catmull-Rom curve through the colours."""
    k = np.asarray(knots, dtype=np.float64)
    return spline(np.linspace(k[0], k[-1], SIZE), k, np.asarray(colours, dtype=np.float64))


@nb.njit(cache=True, parallel=True, nogil=True)
def _lookup(values, samples, lo, hi, out):
    n = values.shape[0]
    last = samples.shape[0] - 1
    step = last / (hi - lo) if hi > lo else 0.0
    for i in nb.prange(n):
        x = (values[i] - lo) * step
        x = min(max(x, 0.0), float(last))  # also maps NaN to 0
        j = min(int(x), last - 1)
        f = x - j
        for c in range(3):
            out[i, c] = samples[j, c] * (1.0 - f) + samples[j + 1, c] * f


def colours(knots, colour_list, values: np.ndarray) -> np.ndarray:
    """``(n, 3)`` colours of ``(n,)`` values through the colour map."""
    samples = table(tuple(knots), tuple(tuple(c) for c in colour_list))
    out = np.empty((len(values), 3))
    _lookup(np.ascontiguousarray(values, dtype=np.float64), samples, float(knots[0]), float(knots[-1]), out)
    return out
