"""The numba kernels of the noise and colour textures, and the threads that run them.

One file because numba's on-disk cache is checked against the source file of the kernel
it compiled, not against the files of the functions that kernel calls: a kernel here that
called a changed function in another file would be loaded stale from the cache.

Every kernel is serial (``nogil``, no ``parallel=True``) and works on whole arrays that
may be pieces of larger ones; :func:`in_pieces` runs the pieces on one thread a core.
numba's threading layer is never started and no parfor is compiled (both cost start-up
and compile time for nothing a thread pool cannot do over flat arrays), and two bake
tiles evaluating textures at once share the same threads instead of starting a team each.

The value-noise path (:func:`lattice_value`) reads two tables of a seed
(:func:`hash_tables`): ``hash4`` holds, for a lattice row ``(j, k)`` (``j * 256 + k``),
the four hashes ``PERM(j + PERM(k))``, ``PERM(j + 1 + PERM(k))``, ``PERM(j + PERM(k + 1))``
and ``PERM(j + 1 + PERM(k + 1))``, a byte each of one uint32: one load for the four rows
of a cell; ``noise2`` holds ``noiseTable[PERM(h)]`` twice over (512 entries), so a row's
corners ``i`` and ``i + 1`` are ``noise2[row + i]`` and ``noise2[row + i + 1]``
(``INDEX(i, j, k) = PERM(i + PERM(j + PERM(k)))``, the lecture's hash, exactly). Nine
loads a cell instead of twelve.

The octave sums go a block of BLOCK points at a time (:func:`octave_block`), an octave
at a time in stages over buffers that stay in the L1 cache: the arithmetic (floor,
fractions, s-curves, the lerps along y and z, the footprint's share, the sum) in loops
that LLVM vectorises (AVX-512: 8 points an instruction), the table loads and the lerps
along x in one scalar loop between them; the marble's colour likewise
(:func:`sine_block`). Vectorised loads (AVX-512 gathers, a point at a time through its
octaves) were tried: 0.6x the speed of scalar loads on the CPU measured (AMD Zen 4).
Per point the operations and their order are those of the one-point path
(:func:`octave_point`), and which path a point takes depends on the point alone, so its
value does not depend on the block it is in (FMA contraction may round the two paths
differently: by an ulp or so).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import numba as nb  # pip install numba
import numpy as np

from ..compiling import watch_compiles

watch_compiles()  # a texture evaluated on its own, outside a bake, says so too

# Kernels are module-level so that numba's on-disk cache finds them in a new process.
# The cache is the ``__pycache__`` folder beside this file where that is writable (an
# installed wheel in a user's venv), else numba's user-wide cache (``NUMBA_CACHE_DIR``,
# by default ``~/.cache/numba``).
F = TypeVar("F", bound=Callable[..., Any])


def _compiled(**options: Any) -> Callable[[F], F]:
    """``numba.njit`` with the kernels' options (cached, releasing the GIL); typed as the
    function it compiles."""
    return nb.njit(cache=True, nogil=True, **options)  # type: ignore[no-any-return]


jit = _compiled(fastmath=False)
# The hot loops: fused multiply-adds and reordering allowed; NaN and infinity kept
# (no "nnan"/"ninf": a NaN point must stay NaN).
FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}
fast = _compiled(fastmath=FAST)
# numba compiles each function on its own and does not inline across them: a call with
# arrays also costs their reference counts. The per-point steps are inlined (numba IR).
inline = _compiled(fastmath=FAST, inline="always")
# Called from Python too (exact there); inlined, they take the caller's flags.
exact_inline = _compiled(fastmath=False, inline="always")


# -- threads ---------------------------------------------------------------------------

MIN_PIECE = 32768  # points: below 2 x this, one call on the calling thread
_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()
_PREFIX = "texbake-kernel"


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def _forget_pool() -> None:
    """In a forked child: the parent's threads are not there."""
    global _pool
    _pool = None


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def in_pieces(n: int, run: Callable[[int, int], None]) -> None:
    """``run(lo, hi)`` over ``[0, n)`` in pieces, on a shared pool of one thread a core
    (the kernels release the GIL); on the calling thread when ``n`` is small or there is
    one core. Pieces are a few a thread, so that a thread slowed by another process does
    not hold up the rest."""
    global _pool
    cores = _cores()
    count = min(4 * cores, n // MIN_PIECE) if cores > 1 else 1
    if count <= 1 or threading.current_thread().name.startswith(_PREFIX):  # (a piece waiting for pieces would never end)
        run(0, n)
        return
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(cores, thread_name_prefix=_PREFIX)
        pool = _pool
    bounds = np.linspace(0, n, count + 1).astype(np.int64)
    for future in [pool.submit(run, int(lo), int(hi)) for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)]:
        future.result()


# -- tables ----------------------------------------------------------------------------

def hash_tables(noise: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(noise2 (512,) float64, hash4 (65536,) uint32)`` of a seed's ``noiseTable`` and
    ``indexTable`` (see the module docstring)."""
    def perm(x):
        return index[x & 255]

    j, k = np.divmod(np.arange(65536), 256)
    rows = [perm(j + dj + perm(k + dk)) for dj, dk in ((0, 0), (1, 0), (0, 1), (1, 1))]
    hash4 = (rows[0] | rows[1] << 8 | rows[2] << 16 | rows[3] << 24).astype(np.uint32)
    noise2 = np.tile(noise[index], 2)
    return noise2, hash4


# -- lattice noise ---------------------------------------------------------------------

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

@jit
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
    """Value noise at any point (wrapped past 2^62), from the plain tables."""
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

@inline
def lattice_value(x, y, z, noise2, hash4, interp):
    """Linear (``interp`` 0) or cubic (1) value noise at a point within 4e18 of the
    origin, from :func:`hash_tables`: the same lattice values and lerps as
    :func:`value_noise`."""
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    ix, iy, iz = np.int64(fx) & 255, np.int64(fy) & 255, np.int64(fz) & 255
    tx, ty, tz = x - fx, y - fy, z - fz
    if interp == 1:
        tx = tx * tx * (3.0 - 2.0 * tx)
        ty = ty * ty * (3.0 - 2.0 * ty)
        tz = tz * tz * (3.0 - 2.0 * tz)
    rows = np.int64(hash4[iy * 256 + iz])  # the four rows' PERM(j + PERM(k)), a byte each
    p00 = (rows & 255) + ix
    p10 = ((rows >> 8) & 255) + ix
    p01 = ((rows >> 16) & 255) + ix
    p11 = (rows >> 24) + ix
    x0 = noise2[p00] + tx * (noise2[p00 + 1] - noise2[p00])
    x1 = noise2[p10] + tx * (noise2[p10 + 1] - noise2[p10])
    x2 = noise2[p01] + tx * (noise2[p01 + 1] - noise2[p01])
    x3 = noise2[p11] + tx * (noise2[p11 + 1] - noise2[p11])
    y0 = x0 + ty * (x1 - x0)
    y1 = x2 + ty * (x3 - x2)
    return y0 + tz * (y1 - y0)

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
    """One octave, about [0, 1] (Catmull-Rom: about [-0.10, 1.11]; mean: see ``noise.basis_mean``)."""
    if basis == 1:
        return 0.5 + 0.5 * perlin_noise(index, x, y, z)
    return value_noise(noise, index, x, y, z, interp)


# -- octaves and their footprint filter --------------------------------------------------

# Octaves whose lattice cells are smaller than 1/DROP_CELLS of the footprint are left out
# (their mean added): a box filter keeps less than 4% of them (box_keep(DROP_CELLS) < 0.04).
DROP_CELLS = 8.0


@exact_inline
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


@exact_inline
def fade_factor(s):
    """Weight of an octave whose lattice cell is ``1/s`` of the footprint: its box-filter
    share, or 0 once it is below 1/DROP_CELLS of it (or ``s`` is NaN)."""
    return box_keep(s) if s < DROP_CELLS else 0.0


@inline
def octave_point(x, y, z, w, big, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain, sign, mean):
    """One point's octave sum, octave by octave, each through the tables or (wrapped far
    out, or another basis) the plain ones: :func:`octave_kernel`'s sum for the points its
    blocks leave out."""
    tables = basis == 0 and interp < 2
    acc = 0.0
    amp = 1.0
    freq = 1.0
    for _ in range(count):
        f = 1.0 if w <= 0.0 else fade_factor(w * freq)
        if f == 0.0:
            acc += amp * mean
        else:
            if tables and big * freq < 4.0e18:  # no wrap needed
                v = lattice_value(x * freq, y * freq, z * freq, noise2, hash4, interp)
            else:
                v = basis_value(noise, index, x * freq, y * freq, z * freq, basis, interp)
            v = sign * v - (sign - 1.0)
            acc += amp * (v if f >= 1.0 else f * v + (1.0 - f) * mean)  # kept: v exactly
        amp *= gain
        freq *= lacunarity
    return acc


# Points a block of octave_block; its buffers (NBUF rows of BLOCK float64) stay in the L1 cache.
BLOCK = 128
NBUF = 14
_X, _Y, _Z, _W, _ACC, _TX, _TY, _TZ, _F, _X0, _X1, _X2, _X3, _P = range(NBUF)  # _P: marble_kernel's coordinate


@inline
def octave_block(buf, cells, noise2, hash4, interp, count, lacunarity, gain, sign, mean):
    """``buf[_ACC]``: the octave sums of a block's points ``buf[_X], buf[_Y], buf[_Z]``
    (footprints ``buf[_W]``) through the tables, an octave at a time in stages: the
    arithmetic of all the block's points in loops that LLVM vectorises (floor, fractions,
    s-curves, lerps, the footprint's share: skipped in a block without footprints, where
    it is 1), the table loads in one scalar loop between them (measured: two thirds of
    the time, some 37 instructions a point and octave; an octave that no point of the
    block keeps skips it). Per point, the same operations in the same order as
    :func:`octave_point`."""
    bx, by, bz, bw, acc = buf[_X], buf[_Y], buf[_Z], buf[_W], buf[_ACC]
    tx, ty, tz, fk = buf[_TX], buf[_TY], buf[_TZ], buf[_F]
    x0, x1, x2, x3 = buf[_X0], buf[_X1], buf[_X2], buf[_X3]
    filtered = False
    for i in range(BLOCK):
        acc[i] = 0.0
        fk[i] = 1.0
        filtered |= not bw[i] <= 0.0
    amp = 1.0
    freq = 1.0
    for _ in range(count):
        kept = BLOCK  # points that keep some of this octave
        if filtered:  # (else every point keeps every octave whole: fk is 1)
            kept = 0
            for i in range(BLOCK):
                w = bw[i]
                f = 1.0 if w <= 0.0 else fade_factor(w * freq)
                fk[i] = f
                kept += f != 0.0
        if kept > 0:
            for i in range(BLOCK):  # lattice cells and fractions
                x, y, z = bx[i] * freq, by[i] * freq, bz[i] * freq
                fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
                ix, iy, iz = np.int64(fx) & 255, np.int64(fy) & 255, np.int64(fz) & 255
                cells[i] = np.uint64((iy * 256 + iz) * 256 + ix)
                sx, sy, sz = x - fx, y - fy, z - fz
                if interp == 1:
                    sx = sx * sx * (3.0 - 2.0 * sx)
                    sy = sy * sy * (3.0 - 2.0 * sy)
                    sz = sz * sz * (3.0 - 2.0 * sz)
                tx[i], ty[i], tz[i] = sx, sy, sz
            for i in range(BLOCK):  # the table loads, and the lerps along x
                c = cells[i]
                rows = np.int64(hash4[c >> np.uint64(8)])  # the four rows' PERM(j + PERM(k)), a byte each
                ix = np.int64(c & np.uint64(255))
                p00 = (rows & 255) + ix
                p10 = ((rows >> 8) & 255) + ix
                p01 = ((rows >> 16) & 255) + ix
                p11 = (rows >> 24) + ix
                t = tx[i]
                x0[i] = noise2[p00] + t * (noise2[p00 + 1] - noise2[p00])
                x1[i] = noise2[p10] + t * (noise2[p10 + 1] - noise2[p10])
                x2[i] = noise2[p01] + t * (noise2[p01 + 1] - noise2[p01])
                x3[i] = noise2[p11] + t * (noise2[p11 + 1] - noise2[p11])
        for i in range(BLOCK):  # the lerps along y and z, and the sum (an octave no point keeps: its mean)
            y0 = x0[i] + ty[i] * (x1[i] - x0[i])
            y1 = x2[i] + ty[i] * (x3[i] - x2[i])
            v = sign * (y0 + tz[i] * (y1 - y0)) - (sign - 1.0)
            f = fk[i]
            acc[i] += amp * (mean if f == 0.0 else (v if f >= 1.0 else f * v + (1.0 - f) * mean))
        amp *= gain
        freq *= lacunarity


@inline
def load_block(points, width, start, scale, offset, wscale, top, buf):
    """The block of ``points`` from ``start`` into ``buf`` (scaled and offset; footprints
    scaled), padded with the origin; the count of points it holds and of those it leaves
    out (0 in their place): points whose top octave is past 4e18, wrapped far out by
    :func:`octave_point`."""
    m = min(BLOCK, points.shape[0] - start)
    out = 0
    for i in range(m):
        x = points[start + i, 0] * scale + offset
        y = points[start + i, 1] * scale + offset
        z = points[start + i, 2] * scale + offset
        big = max(abs(x), abs(y), abs(z))
        if not big * top < 4.0e18:
            x = y = z = 0.0
            out += 1
        buf[_X, i], buf[_Y, i], buf[_Z, i] = x, y, z
        buf[_W, i] = width[start + i] * wscale
    for i in range(m, BLOCK):
        buf[_X, i] = buf[_Y, i] = buf[_Z, i] = buf[_W, i] = 0.0
    return m, out


@fast
def block_sums(points, width, start, scale, offset, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain, sign,
               mean, top, buf, cells):
    """``buf[_ACC, :m]``: the octave sums of the ``m`` points from ``start`` (a block's, or
    fewer at the end); returns ``m``. Value noise (linear or cubic) goes through
    :func:`octave_block`, but a point whose octaves reach past 4e18 (and every point of
    another basis or interpolation) through :func:`point_sums`. Compiled once for both
    kernels, and called once a block (numba inlines by copying a function's IR for each
    call: the kernels' compile would take twice as long)."""
    tables = basis == 0 and interp < 2
    if tables:
        m, left = load_block(points, width, start, scale, offset, abs(scale), top, buf)
        octave_block(buf, cells, noise2, hash4, interp, count, lacunarity, gain, sign, mean)
    else:  # another basis or interpolation: every point by itself
        m, left = min(BLOCK, points.shape[0] - start), 1
    if left:
        point_sums(points, width, start, m, scale, offset, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain,
                   sign, mean, top, tables, buf[_ACC])
    return m


@fast
def point_sums(points, width, start, m, scale, offset, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain,
               sign, mean, top, far_only, acc):
    """``acc[i]``: :func:`octave_point` of point ``start + i`` for ``i < m`` (``far_only``:
    only of those whose top octave is past 4e18, which :func:`load_block` left out)."""
    wscale = abs(scale)
    for i in range(m):
        x, y, z = (points[start + i, 0] * scale + offset, points[start + i, 1] * scale + offset,
                   points[start + i, 2] * scale + offset)
        big = max(abs(x), abs(y), abs(z))
        if far_only and big * top < 4.0e18:
            continue
        acc[i] = octave_point(x, y, z, width[start + i] * wscale, big, noise, index, noise2, hash4, basis, interp, count,
                              lacunarity, gain, sign, mean)


@fast
def octave_kernel(points, width, scale, offset, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain, signed,
                  basis_mean, out):
    """``out[i]``: the sum of ``count`` octaves ``gain^k * n(lacunarity^k * q)`` at ``q =
    points[i] * scale + offset``, filtered by its footprint ``width[i] * |scale|``.

    ``n`` is the basis in [0, 1] (``signed``: ``2n - 1``), ``basis_mean`` its mean. Octave
    ``k`` is shrunk towards its mean by :func:`fade_factor` of ``s = lacunarity^k * w`` (the
    footprint in its lattice cells): what a box filter over the footprint keeps of it, and
    nothing (it is not evaluated: its mean is added) once ``s >= DROP_CELLS``; the sum
    neither aliases nor shifts in brightness. A point's value depends on nothing but the
    point: it goes through :func:`block_sums` in blocks of BLOCK points, and its path there
    is chosen by the point alone.
    """
    mean = 2.0 * basis_mean - 1.0 if signed else basis_mean
    sign = 2.0 if signed else 1.0
    top = block_top(count, lacunarity)
    buf = np.empty((NBUF, BLOCK))
    cells = np.empty(BLOCK, np.uint64)
    for start in range(0, points.shape[0], BLOCK):
        m = block_sums(points, width, start, scale, offset, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain,
                       sign, mean, top, buf, cells)
        for i in range(m):
            out[start + i] = buf[_ACC, i]


@jit
def block_top(count, lacunarity):
    """The highest of the octaves' frequencies (``lacunarity^k``, as the loops compute them)."""
    top = freq = 1.0
    for _ in range(count - 1):
        freq *= lacunarity
        top = max(top, freq)
    return top


# -- placement -------------------------------------------------------------------------

@jit
def affine_kernel(points, origin, scale, out):
    """``out[i] = (points[i] - origin) * scale`` (``mapping.to_space``)."""
    for i in range(points.shape[0]):
        for c in range(3):
            out[i, c] = (points[i, c] - origin[c]) * scale


# -- colour maps -------------------------------------------------------------------------

@inline
def map_colour(value, samples, lo, step, out, i):
    """``out[i]``: the tabulated colour curve ``samples`` ``(m, 3)`` at ``value``, its knots
    from ``lo`` with ``step`` samples a unit (linear between samples; clamped; NaN: the first)."""
    last = samples.shape[0] - 1
    x = (value - lo) * step
    x = min(max(x, 0.0), float(last))  # also maps NaN to 0
    j = min(int(x), last - 1)
    f = x - j
    for c in range(3):
        out[i, c] = samples[j, c] * (1.0 - f) + samples[j + 1, c] * f


@inline
def wave_colour(phase, spread, table, max_spread, out, i):
    """``out[i]``: ``table`` ``(spreads, phases, 3)`` (``colour.wave_table``) at ``phase``
    (wrapped to its period) and ``spread`` (clamped to ``[0, max_spread]``), bilinear."""
    spreads, phases = table.shape[0], table.shape[1]
    x = phase / (2.0 * np.pi)
    x = (x - np.floor(x)) * phases
    j = min(int(x), phases - 1)
    fx = x - j
    j1 = (j + 1) % phases
    y = min(max(spread / max_spread, 0.0), 1.0) * (spreads - 1)
    r = min(int(y), spreads - 2)
    fy = y - r
    for c in range(3):
        low = table[r, j, c] * (1.0 - fx) + table[r, j1, c] * fx
        high = table[r + 1, j, c] * (1.0 - fx) + table[r + 1, j1, c] * fx
        out[i, c] = low * (1.0 - fy) + high * fy


@inline
def sine_colour(phase, table, out, i):
    """``out[i]``: the colour of ``0.5 + 0.5 sin(phase)`` from ``table`` ``(m + 1, 3)``
    (``colour.sine_table``: a period in ``m`` samples, the first repeated), linear between
    samples; NaN for a phase that is not finite."""
    m = table.shape[0] - 1
    x = phase / (2.0 * np.pi)
    x = (x - np.floor(x)) * m  # in [0, m] (m: a tiny negative phase rounds up to the period)
    if not x <= m:  # NaN in, NaN out
        for c in range(3):
            out[i, c] = np.nan
        return
    j = min(int(x), m - 1)
    f = x - j
    for c in range(3):
        out[i, c] = table[j, c] * (1.0 - f) + table[j + 1, c] * f


@jit
def colour_kernel(values, samples, lo, step, out):
    for i in range(values.shape[0]):
        map_colour(values[i], samples, lo, step, out, i)


@jit
def wave_kernel(phase, spread, table, max_spread, out):
    for i in range(phase.shape[0]):
        wave_colour(phase[i], spread[i], table, max_spread, out, i)


@inline
def sine_block(buf, cells, points, start, m, spread_per_width, width, axis, frequency, amplitude, capped, norm, table, out):
    """:func:`sine_colour` of those of a block's ``m`` points from ``start`` whose phase has
    no spread, their turbulence in ``buf[_ACC]``: the phases and the table's rows in a loop that LLVM vectorises, the
    table's loads in a scalar one (a NaN phase: a NaN fraction, NaN colours)."""
    coordinate, turbulence, fraction = buf[_P], buf[_ACC], buf[_TX]
    for i in range(m):
        coordinate[i] = points[start + i, axis]
    for i in range(m, BLOCK):
        coordinate[i] = 0.0
    rows = table.shape[0] - 1
    for i in range(BLOCK):
        phase = frequency * coordinate[i] + amplitude * ((turbulence[i] + capped) / norm)
        x = phase / (2.0 * np.pi)
        x = (x - np.floor(x)) * rows  # in [0, rows] (rows: a tiny negative phase rounds up to the period)
        j = min(np.int64(x if x <= rows else 0.0), rows - 1)
        cells[i] = np.uint64(j)
        fraction[i] = x - j
    for i in range(m):
        if not spread_per_width * width[start + i] > 0.0:  # (the others have their wave_colour)
            j = cells[i]
            f = fraction[i]
            for c in range(3):
                out[start + i, c] = table[j, c] * (1.0 - f) + table[j + np.uint64(1), c] * f


@fast
def marble_kernel(points, width, axis, frequency, amplitude, scale, offset, noise, index, noise2, hash4, basis, interp, count,
                  lacunarity, gain, basis_mean, capped, norm, sines, table, max_spread, out):
    """Perlin's marble in one pass: ``out[i]`` the colour of ``0.5 + 0.5 sin(phase)``
    (:func:`sine_colour`),
    ``phase = frequency * p[axis] + amplitude * turbulence(p * scale + offset)`` (the
    :func:`octave_kernel` sum plus ``capped``, the mean of the octaves left out, over
    ``norm``), or with a footprint the mean colour over the phase's spread
    ``frequency * width / sqrt(12)`` (:func:`wave_colour`). The turbulence a block of
    points at a time (:func:`block_sums`), in buffers that stay in the L1 cache."""
    spread_per_width = frequency / np.sqrt(12.0)
    top = block_top(count, lacunarity)
    buf = np.empty((NBUF, BLOCK))
    cells = np.empty(BLOCK, np.uint64)
    for start in range(0, points.shape[0], BLOCK):
        m = block_sums(points, width, start, scale, offset, noise, index, noise2, hash4, basis, interp, count, lacunarity, gain,
                       1.0, basis_mean, top, buf, cells)
        sampled = 0  # points without a spread: the colour of their phase
        for i in range(start, start + m):
            spread = spread_per_width * width[i]
            if spread > 0.0:  # the mean colour over the texel, not the colour of the mean
                phase = frequency * points[i, axis] + amplitude * ((buf[_ACC, i - start] + capped) / norm)
                wave_colour(phase, spread, table, max_spread, out, i)
            else:
                sampled += 1
        if sampled:
            sine_block(buf, cells, points, start, m, spread_per_width, width, axis, frequency, amplitude, capped, norm, sines,
                       out)
