"""Lattice noise after Perlin and Peachey, Perlin's improved gradient noise, and their
octave sums (turbulence, fBm) filtered by the texel footprint.

Footprint filtering (:func:`octave_kernel`): every octave is evaluated at the point and
shrunk towards its mean by the share of it a box filter over the footprint keeps
(:func:`box_keep`, :func:`fade_factor`); octaves whose lattice cells are finer than
1/``DROP_CELLS`` (1/8) of the footprint are skipped and add their mean. The octave count
itself is the spec's (or ``max_octaves``), the same for every texel.

Lattice noise as the lecture describes it: a seeded ``noiseTable`` of 256 values in
[0, 1], an ``indexTable`` permutation of 0..255 (both pinned: ``tables.py``), ``PERM(x) = indexTable[x & 255]`` and
``INDEX(i, j, k) = PERM(i + PERM(j + PERM(k)))``; between lattice points, linear, cubic
(Perlin's s-curve ``3t^2 - 2t^3``) or Catmull-Rom (Peachey: a spline through four
lattice values per axis) interpolation.

Precision: a point is split in float64 into an int64 lattice cell (``floor``) and a
fraction, so there is no ``+10000`` offset and no ``(int)`` truncation: the result is
right for negative coordinates and keeps its precision far from the origin. The tables
have 256 entries, so the noise repeats every 256 cells in each axis.

Hot loops are numba kernels over flat arrays (compiled once, cached on disk).
"""

from __future__ import annotations

import functools
import logging

import numba as nb  # pip install numba
import numpy as np

logger = logging.getLogger(__name__)

# Kernels are module-level so that numba's on-disk cache finds them in a new process.
# The cache is the ``__pycache__`` folder beside this file where that is writable (an
# installed wheel in a user's venv), else numba's user-wide cache (``NUMBA_CACHE_DIR``,
# by default ``~/.cache/numba``).
jit = functools.partial(nb.njit, cache=True, fastmath=False, nogil=True)

INTERPOLATIONS = ("linear", "cubic", "catmull-rom")
BASES = ("value", "perlin")


@functools.cache
def _derived_tables(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``noise[index]`` (256,) and ``PERM(j + PERM(k))`` at ``j * 256 + k`` (65536,) int32 (cache-sized)."""
    noise, index = tables(seed)
    j, k = np.divmod(np.arange(65536), 256)
    return noise[index], index[(j + index[k]) & 255].astype(np.int32)


@functools.cache
def tables(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``(noiseTable (256,) float64 in [0, 1], indexTable (256,) int64 permutation)``,
    pinned by ``tables.derive`` (integer arithmetic of its own, not a library's stream)."""
    from .tables import derive

    noise, index = derive(seed)
    noise.flags.writeable = index.flags.writeable = False  # cached: shared by every caller
    return noise, index


def basis_mean(basis: str, seed: int = 0) -> float:
    """Mean of one octave over space: what a dropped octave is replaced by.

    Value noise (any interpolation) averages to the mean of its ``noiseTable`` (each
    entry is one lattice value per period, and the interpolation weights sum to 1),
    not to 0.5: 0.536 for seed 0. Perlin's gradient noise averages to 0 (0.5 in [0, 1]).
    """
    return 0.5 if basis == "perlin" else float(tables(seed)[0].mean())


@jit
def perm(table, x):
    return table[x & 255]

@jit
def wrap(x):
    """``x`` itself, or, past 2^62 (no fraction left), ``x mod 256`` (exact: the tables
    repeat every 256 cells); an overflow to infinity becomes lattice point 0."""
    if abs(x) < 4.0e18:
        return x
    return np.fmod(x, 256.0) if np.isfinite(x) else 0.0

@jit
def lattice(noise, index, i, j, k):
    return noise[perm(index, i + perm(index, j + perm(index, k)))]

@jit(inline="always")
def trilinear(tx, ty, tz, d000, d100, d010, d110, d001, d101, d011, d111):
    """The lecture's lerps: along x, then y, then z."""
    x0 = d000 + tx * (d100 - d000)
    x1 = d010 + tx * (d110 - d010)
    x2 = d001 + tx * (d101 - d001)
    x3 = d011 + tx * (d111 - d011)
    y0 = x0 + ty * (x1 - x0)
    y1 = x2 + ty * (x3 - x2)
    return y0 + tz * (y1 - y0)


@jit
def catmull_rom(t, a, b, c, d):
    return 0.5 * ((2.0 * b) + (c - a) * t + (2.0 * a - 5.0 * b + 4.0 * c - d) * t * t + (3.0 * b - a - 3.0 * c + d) * t * t * t)

@jit
def value_noise(noise, index, x, y, z, interp):
    x, y, z = wrap(x), wrap(y), wrap(z)
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    ix, iy, iz = np.int64(fx), np.int64(fy), np.int64(fz)
    tx, ty, tz = x - fx, y - fy, z - fz
    if interp == 2:  # Catmull-Rom through 4 x 4 x 4 lattice values
        planes = np.empty(4)
        rows = np.empty(4)
        for c in range(4):
            for b in range(4):
                rows[b] = catmull_rom(
                    tx,
                    lattice(noise, index, ix - 1, iy + b - 1, iz + c - 1),
                    lattice(noise, index, ix, iy + b - 1, iz + c - 1),
                    lattice(noise, index, ix + 1, iy + b - 1, iz + c - 1),
                    lattice(noise, index, ix + 2, iy + b - 1, iz + c - 1),
                )
            planes[c] = catmull_rom(ty, rows[0], rows[1], rows[2], rows[3])
        return catmull_rom(tz, planes[0], planes[1], planes[2], planes[3])
    if interp == 1:  # Perlin's s-curve
        tx = tx * tx * (3.0 - 2.0 * tx)
        ty = ty * ty * (3.0 - 2.0 * ty)
        tz = tz * tz * (3.0 - 2.0 * tz)
    # INDEX(i, j, k) = PERM(i + PERM(j + PERM(k))), sharing the inner PERMs
    pz0 = perm(index, iz)
    pz1 = perm(index, iz + 1)
    p00 = perm(index, iy + pz0) + ix
    p10 = perm(index, iy + 1 + pz0) + ix
    p01 = perm(index, iy + pz1) + ix
    p11 = perm(index, iy + 1 + pz1) + ix
    d000 = noise[perm(index, p00)]
    d100 = noise[perm(index, p00 + 1)]
    d010 = noise[perm(index, p10)]
    d110 = noise[perm(index, p10 + 1)]
    d001 = noise[perm(index, p01)]
    d101 = noise[perm(index, p01 + 1)]
    d011 = noise[perm(index, p11)]
    d111 = noise[perm(index, p11 + 1)]
    return trilinear(tx, ty, tz, d000, d100, d010, d110, d001, d101, d011, d111)

@jit
def grad(h, x, y, z):
    h = h & 15
    u = x if h < 8 else y
    v = y if h < 4 else (x if h == 12 or h == 14 else z)
    return (u if (h & 1) == 0 else -u) + (v if (h & 2) == 0 else -v)

@jit
def perlin_noise(index, x, y, z):
    """Perlin's improved noise (2002), in about [-1, 1]."""
    x, y, z = wrap(x), wrap(y), wrap(z)
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    ix, iy, iz = np.int64(fx), np.int64(fy), np.int64(fz)
    x, y, z = x - fx, y - fy, z - fz
    u = x * x * x * (x * (x * 6.0 - 15.0) + 10.0)
    v = y * y * y * (y * (y * 6.0 - 15.0) + 10.0)
    w = z * z * z * (z * (z * 6.0 - 15.0) + 10.0)
    a = perm(index, ix) + iy
    aa = perm(index, a) + iz
    ab = perm(index, a + 1) + iz
    b = perm(index, ix + 1) + iy
    ba = perm(index, b) + iz
    bb = perm(index, b + 1) + iz
    l0 = grad(perm(index, aa), x, y, z) + u * (grad(perm(index, ba), x - 1, y, z) - grad(perm(index, aa), x, y, z))
    l1 = grad(perm(index, ab), x, y - 1, z) + u * (grad(perm(index, bb), x - 1, y - 1, z) - grad(perm(index, ab), x, y - 1, z))
    l2 = grad(perm(index, aa + 1), x, y, z - 1) + u * (grad(perm(index, ba + 1), x - 1, y, z - 1) - grad(perm(index, aa + 1), x, y, z - 1))
    l3 = grad(perm(index, ab + 1), x, y - 1, z - 1) + u * (grad(perm(index, bb + 1), x - 1, y - 1, z - 1) - grad(perm(index, ab + 1), x, y - 1, z - 1))
    m0 = l0 + v * (l1 - l0)
    m1 = l2 + v * (l3 - l2)
    return m0 + w * (m1 - m0)

@jit
def basis_value(noise, index, x, y, z, basis, interp):
    """One octave, about [0, 1] (Catmull-Rom: about [-0.10, 1.11]; mean: see :func:`basis_mean`)."""
    if basis == 1:
        return 0.5 + 0.5 * perlin_noise(index, x, y, z)
    return value_noise(noise, index, x, y, z, interp)

# Octaves whose lattice cells are smaller than 1/DROP_CELLS of the footprint are left out
# (their mean added): a box filter keeps less than 4% of them (box_keep(DROP_CELLS) < 0.04).
DROP_CELLS = 8.0


@jit
def box_keep(s):
    """The share of an octave that survives a box filter ``s`` lattice cells wide.

    One sample cannot know an octave's average over the footprint; the best guess from
    it (least squares) is ``mean + rho * (v - mean)``, with ``rho`` the correlation
    coefficient of the box average with the centre value, as a share of the value's
    variance. For linearly interpolated lattice noise the autocorrelation along an axis
    is the cubic B-spline ``R`` (the tent's autocorrelation, ``R(0) = 2/3``), so along one
    axis ``rho1(s) = (1/s) * integral of R over [-s/2, s/2] / R(0) = 3 I(s/2) / s`` with
    ``I(a) = integral of R over [0, a]``; the footprint spans two axes: ``rho1(s)^2``.
    1 at ``s = 0``, 0.944 at 1/2, 0.81 at 1, 0.47 at 2, ``(1.5 / s)^2`` from 4 on.
    """
    if s <= 0.0:
        return 1.0
    a = 0.5 * s
    if a < 1.0:
        integral = a * (2.0 / 3.0) - a * a * a / 3.0 + a * a * a * a / 8.0
    elif a < 2.0:
        b = 2.0 - a
        integral = 11.0 / 24.0 + (1.0 - b * b * b * b) / 24.0
    else:
        integral = 0.5
    rho = 3.0 * integral / s
    return rho * rho


@jit
def fade_factor(s):
    """Weight of an octave whose lattice cell is ``1/s`` of the footprint: its box-filter
    share, or 0 once it is below 1/DROP_CELLS of it."""
    return box_keep(s) if s < DROP_CELLS else 0.0

@nb.njit(cache=True, parallel=True, nogil=True, fastmath={"nsz", "arcp", "contract", "afn", "reassoc"})
def octave_kernel(points, width, noise, index, noise_perm, perm_yz, basis, interp, count, lacunarity, gain, signed, basis_mean, out):
    """Sum of ``count`` octaves ``gain^k * n(lacunarity^k * p)``, filtered by the footprint.

    ``n`` is the basis in [0, 1] (``signed``: ``2n - 1``), ``basis_mean`` its mean. Octave ``k``
    is shrunk towards its mean by :func:`fade_factor` of ``s = lacunarity^k * width`` (the
    footprint in its lattice cells): what a box filter over the footprint keeps of it, and
    nothing once ``s >= DROP_CELLS``; the sum neither aliases nor shifts in brightness.
    Points go in chunks, octaves in the outer loop, so that the value-noise loop is
    branch-free and vectorises, and a chunk skips the octaves all its points drop.
    """
    n = points.shape[0]
    chunk = 2048
    mean = 2.0 * basis_mean - 1.0 if signed else basis_mean
    scale = 2.0 if signed else 1.0
    for c in nb.prange((n + chunk - 1) // chunk):
        lo = c * chunk
        m = min(n, lo + chunk) - lo
        acc = np.zeros(m)
        narrowest = np.inf
        big = 0.0
        for i in range(m):
            narrowest = min(narrowest, width[lo + i])
            big = max(big, abs(points[lo + i, 0]), abs(points[lo + i, 1]), abs(points[lo + i, 2]))
        amp = 1.0
        freq = 1.0
        for _ in range(count):
            if narrowest * freq >= DROP_CELLS:  # every point of the chunk drops this octave
                for i in range(m):
                    acc[i] += amp * mean
            elif basis == 0 and interp < 2 and big * freq < 4.0e18:  # no wrap needed
                for i in range(m):
                    x = points[lo + i, 0] * freq
                    y = points[lo + i, 1] * freq
                    z = points[lo + i, 2] * freq
                    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
                    ix, iy, iz = np.int64(fx) & 255, np.int64(fy) & 255, np.int64(fz) & 255
                    tx, ty, tz = x - fx, y - fy, z - fz
                    if interp == 1:
                        tx = tx * tx * (3.0 - 2.0 * tx)
                        ty = ty * ty * (3.0 - 2.0 * ty)
                        tz = tz * tz * (3.0 - 2.0 * tz)
                    iy1 = (iy + 1) & 255
                    iz1 = (iz + 1) & 255
                    p00 = perm_yz[iy * 256 + iz] + ix
                    p10 = perm_yz[iy1 * 256 + iz] + ix
                    p01 = perm_yz[iy * 256 + iz1] + ix
                    p11 = perm_yz[iy1 * 256 + iz1] + ix
                    d000 = noise_perm[p00 & 255]
                    d100 = noise_perm[(p00 + 1) & 255]
                    d010 = noise_perm[p10 & 255]
                    d110 = noise_perm[(p10 + 1) & 255]
                    d001 = noise_perm[p01 & 255]
                    d101 = noise_perm[(p01 + 1) & 255]
                    d011 = noise_perm[p11 & 255]
                    d111 = noise_perm[(p11 + 1) & 255]
                    v = trilinear(tx, ty, tz, d000, d100, d010, d110, d001, d101, d011, d111)
                    v = scale * v - (scale - 1.0)
                    f = fade_factor(width[lo + i] * freq)
                    acc[i] += amp * (v if f >= 1.0 else f * v + (1.0 - f) * mean)  # kept: v exactly
            else:
                for i in range(m):
                    v = basis_value(noise, index, points[lo + i, 0] * freq, points[lo + i, 1] * freq, points[lo + i, 2] * freq, basis, interp)
                    v = scale * v - (scale - 1.0)
                    f = fade_factor(width[lo + i] * freq)
                    acc[i] += amp * (v if f >= 1.0 else f * v + (1.0 - f) * mean)  # kept: v exactly
            amp *= gain
            freq *= lacunarity
        for i in range(m):
            out[lo + i] = acc[i]


def octave_sum(
    points: np.ndarray,
    width: np.ndarray | None,
    *,
    octaves: int,
    basis: str = "value",
    interpolation: str = "linear",
    lacunarity: float = 2.0,
    gain: float = 0.5,
    signed: bool = False,
    seed: int = 0,
    max_octaves: int | None = None,
) -> np.ndarray:
    """``(n,)`` float64: ``sum_k gain^k * noise(lacunarity^k * p)`` for ``k < octaves``.

    ``points``: ``(n, 3)`` noise-space points; ``width``: ``(n,)`` footprint width in
    noise-space units (None: point sampling, every octave). ``noise`` is the basis in
    [0, 1], or ``2 * noise - 1`` if ``signed``. ``max_octaves`` caps the octaves
    evaluated (a speed/quality knob): octaves ``k >= max_octaves`` add their mean
    (:func:`basis_mean`, or 0 if ``signed``), like octaves the footprint drops, so the brightness
    does not shift.
    """
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    w = np.zeros(len(p)) if width is None else np.ascontiguousarray(width, dtype=np.float64).reshape(-1)
    noise_table, index_table = tables(seed)
    out = np.empty(len(p))
    noise_perm, perm_yz = _derived_tables(seed)
    count = int(octaves) if max_octaves is None else min(int(octaves), int(max_octaves))
    mean = basis_mean(basis, seed)
    _announce_compile()
    octave_kernel(p, w, noise_table, index_table, noise_perm, perm_yz, BASES.index(basis), INTERPOLATIONS.index(interpolation),
               count, float(lacunarity), float(gain), bool(signed), mean, out)
    if count < octaves and not signed:  # the capped octaves add their mean
        out += mean * sum(gain**k for k in range(count, int(octaves)))
    return out


def noise(points: np.ndarray, *, basis: str = "value", interpolation: str = "linear", seed: int = 0) -> np.ndarray:
    """``(n,)`` float64 noise at ``(n, 3)`` points (one octave, point-sampled): in [0, 1]
    for linear and cubic value noise and for Perlin's; Catmull-Rom value noise overshoots
    its lattice values, to about [-0.10, 1.11]."""
    return octave_sum(points, None, octaves=1, basis=basis, interpolation=interpolation, seed=seed)


_announced = False


def _announce_compile() -> None:
    """Say once per process when the kernels are about to be compiled (numba's cache has
    none for this code yet: the first bake after an install), so a pause is explained."""
    global _announced
    if _announced:
        return
    _announced = True
    try:  # numba's cache index for this source file (empty when missing or out of date)
        cache = octave_kernel._cache  # type: ignore[attr-defined]  # numba's dispatcher internals
        cached, where = bool(cache._cache_file._load_index()), cache._cache_path
    except (AttributeError, OSError):  # another numba: nothing to say
        return
    if not cached:
        logger.warning("texbake: compiling the texture kernels (once after an install: a few seconds); cached in %s", where)
