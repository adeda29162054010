"""Plain float64 numpy references for the noise kernels, for checks and tests.

``value_noise`` is the lecture's lattice noise written out as the lecture states it
(``INDEX(i, j, k) = PERM(i + PERM(j + PERM(k)))``, the lerps along x, then y, then z),
with ``floor`` where the lecture's sample code has ``(int)``. ``lecture_sample_code`` is
that sample code as written (float32, ``+10000``, ``(int)`` truncation), kept to show
where it breaks. Nothing here shares code with ``noise.py`` but the tables (data); it is
slow and simple on purpose.

Shapes: points ``(n, 3)`` float64 in, values ``(n,)`` float64 out.
"""

from __future__ import annotations

import numpy as np

from ..textures.noise import tables


def lattice(i: np.ndarray, seed: int = 0) -> np.ndarray:
    """``noiseTable[INDEX(i, j, k)]`` at ``(n, 3)`` int64 lattice points: ``(n,)`` float64."""
    table, index = tables(seed)
    ix, iy, iz = np.asarray(i, dtype=np.int64).T
    return table[index[(ix + index[(iy + index[iz & 255]) & 255]) & 255]]


def interpolate(i: np.ndarray, t: np.ndarray, interpolation: str = "linear", seed: int = 0) -> np.ndarray:
    """Noise in cells ``i`` ``(n, 3)`` int64 at fractions ``t`` ``(n, 3)`` float64 in [0, 1].

    ``interpolation``: "linear" (the lecture's lerps) or "cubic" (Perlin's s-curve
    ``3t^2 - 2t^3`` on each fraction first).
    """
    i = np.asarray(i, dtype=np.int64)
    t = np.asarray(t, dtype=np.float64)
    if interpolation == "cubic":
        t = t * t * (3.0 - 2.0 * t)
    elif interpolation != "linear":
        raise ValueError(f"reference interpolation: 'linear' or 'cubic', got {interpolation!r}")

    def d(a, b, c):
        return lattice(i + np.array([a, b, c]), seed)

    tx, ty, tz = t.T

    def lerp(f, a, b):
        return a + f * (b - a)

    x0 = lerp(tx, d(0, 0, 0), d(1, 0, 0))
    x1 = lerp(tx, d(0, 1, 0), d(1, 1, 0))
    x2 = lerp(tx, d(0, 0, 1), d(1, 0, 1))
    x3 = lerp(tx, d(0, 1, 1), d(1, 1, 1))
    return lerp(tz, lerp(ty, x0, x1), lerp(ty, x2, x3))


def value_noise(p: np.ndarray, interpolation: str = "linear", seed: int = 0) -> np.ndarray:
    """The lecture's ``noise(p)`` in float64 with ``floor`` (not ``(int)``): ``(n,)`` in [0, 1]."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    f = np.floor(p)
    return interpolate(f.astype(np.int64), p - f, interpolation, seed)


def turbulence(p: np.ndarray, octaves: int, *, lacunarity: float = 2.0, gain: float = 0.5,
               interpolation: str = "linear", seed: int = 0) -> np.ndarray:
    """``sum_k gain^k noise(lacunarity^k p) / sum_k gain^k`` for ``k < octaves``, point-sampled."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    total = np.zeros(len(p))
    for k in range(octaves):
        total += gain**k * value_noise(p * lacunarity**k, interpolation, seed)
    return total / sum(gain**k for k in range(octaves))


def lecture_sample_code(p: np.ndarray, seed: int = 0) -> np.ndarray:
    """The lecture's sample ``noise()`` as written: float32, ``+10000``, ``(int)`` truncation.

    Wrong below -10000 (truncation towards zero picks the wrong cell) and far from the
    origin (float32 keeps no fraction past 2^24).
    """
    pp = np.asarray(p).astype(np.float32) + np.float32(10000)
    i = pp.astype(np.int64)  # (int) truncates towards zero
    return interpolate(i, (pp - i.astype(np.float32)).astype(np.float64), "linear", seed)
