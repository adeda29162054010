"""Lattice noise after Perlin and Peachey, Perlin's improved gradient noise, and their
octave sums (turbulence, fBm) filtered by the texel footprint.

Footprint filtering (``texbake._native.octave_sum``): every octave is evaluated at the point and
shrunk towards its mean by the share of it a box filter over the footprint keeps
(:func:`box_keep`, :func:`fade_factor`); octaves whose lattice cells are finer than
1/``DROP_CELLS`` (1/8) of the footprint are skipped and add their mean. The octave count
itself is the spec's (or ``max_octaves``), the same for every texel.

That damping is unbiased, but a single sample at the footprint's centre is the limit for
octaves whose cells are near the footprint's size: the octave varies inside the footprint in
a way one damped value cannot follow. :func:`quarter_octave_sums` evaluates the octaves
whose footprint spans ``QUAD_CELLS`` (1/20) of a lattice cell or more at the footprint's
four quarters (its parallelogram cut in 2x2, each filtered at half the width), the coarser
ones once at the centre, where a box filter of an octave that is about linear across the
footprint is its centre value.

Lattice noise as the lecture describes it: a seeded ``noiseTable`` of 256 values in
[0, 1], an ``indexTable`` permutation of 0..255 (both pinned: ``tables.py``), ``PERM(x) = indexTable[x & 255]`` and
``INDEX(i, j, k) = PERM(i + PERM(j + PERM(k)))``; between lattice points, linear, cubic
(Perlin's s-curve ``3t^2 - 2t^3``) or Catmull-Rom (Peachey: a spline through four
lattice values per axis) interpolation.

Precision: a point is split in float64 into an int64 lattice cell (``floor``) and a
fraction, so there is no ``+10000`` offset and no ``(int)`` truncation: the result is
right for negative coordinates and keeps its precision far from the origin. The tables
have 256 entries, so the noise repeats every 256 cells in each axis.

The octave sums are compiled C++ (``native/noise.hpp``, ``native/octaves.hpp``, bound as
``texbake._native``: the GIL released, one thread a core); this module holds the tables and
the calls.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from .. import _native
from .._native import DROP_CELLS, QUAD_CELLS, box_keep, fade_factor

__all__ = ["BASES", "DROP_CELLS", "INTERPOLATIONS", "QUAD_CELLS", "QUARTERS", "OctaveCount", "basis_mean", "box_keep", "fade_factor", "noise", "octave_count",
           "octave_sum", "quarter_octave_sums", "quarter_points", "tables"]

INTERPOLATIONS = ("linear", "cubic", "catmull-rom")
BASES = ("value", "perlin")


@functools.cache
def _derived_tables(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`hash_tables` of the seed's tables: ``(noise2 (512,), hash4 (65536,) uint32)``."""
    noise2, hash4 = hash_tables(*tables(seed))
    noise2.flags.writeable = hash4.flags.writeable = False  # cached: shared by every caller
    return noise2, hash4


def hash_tables(noise: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(noise2 (512,) float64, hash4 (65536,) uint32)`` of a seed's ``noiseTable`` and
    ``indexTable``, the tables value noise reads in the octave sums: ``hash4`` holds, for a
    lattice row ``(j, k)`` (``j * 256 + k``), the four hashes ``PERM(j + PERM(k))``,
    ``PERM(j + 1 + PERM(k))``, ``PERM(j + PERM(k + 1))`` and ``PERM(j + 1 + PERM(k + 1))``, a
    byte each of one uint32: one load for the four rows of a cell; ``noise2`` holds
    ``noiseTable[PERM(h)]`` twice over, so a row's corners ``i`` and ``i + 1`` are
    ``noise2[row + i]`` and ``noise2[row + i + 1]``. Nine loads a cell instead of twelve,
    the lecture's values exactly."""
    def perm(x):
        return index[x & 255]

    j, k = np.divmod(np.arange(65536), 256)
    rows = [perm(j + dj + perm(k + dk)) for dj, dk in ((0, 0), (1, 0), (0, 1), (1, 1))]
    hash4 = (rows[0] | rows[1] << 8 | rows[2] << 16 | rows[3] << 24).astype(np.uint32)
    noise2 = np.tile(noise[index], 2)
    return noise2, hash4


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
    scale: float = 1.0,
    offset: float = 0.0,
) -> np.ndarray:
    """``(n,)`` float64: ``sum_k gain^k * noise(lacunarity^k * q)`` for ``k < octaves``,
    ``q = scale * p + offset``.

    ``points``: ``(n, 3)`` points ``p``; ``width``: ``(n,)`` footprint width in the same
    units (None: point sampling, every octave), ``|scale| * width`` in noise space.
    ``noise`` is the basis in [0, 1], or ``2 * noise - 1`` if ``signed``. ``max_octaves``
    caps the octaves evaluated (a speed/quality knob): octaves ``k >= max_octaves`` add
    their mean (:func:`basis_mean`, or 0 if ``signed``), like octaves the footprint drops,
    so the brightness does not shift.
    """
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    w = None if width is None else np.ascontiguousarray(width, dtype=np.float64).reshape(-1)
    out = np.empty(len(p))
    cap = octave_count(octaves, gain, max_octaves, basis=basis, seed=seed)
    _native.octave_sum(p, w, *tables(seed), *_derived_tables(seed), BASES.index(basis), INTERPOLATIONS.index(interpolation),
                       cap.evaluated, float(lacunarity), float(gain), bool(signed), basis_mean(basis, seed), float(scale), float(offset),
                       out)
    if cap.evaluated < octaves and not signed:  # the capped octaves add their mean (signed octaves have mean 0)
        out += cap.capped
    return out


# QUAD_CELLS (1/20, native/noise.hpp): footprint width, in an octave's lattice cells, from which it is evaluated at the four quarters
QUARTERS = np.array([[-0.25, -0.25], [0.25, -0.25], [-0.25, 0.25], [0.25, 0.25]])  # the quarters' centres, in (dpdx, dpdy)


def quarter_points(points: np.ndarray, dpdx: np.ndarray, dpdy: np.ndarray) -> np.ndarray:
    """``(4, n, 3)`` float64: the centres of the four quarters of each footprint
    parallelogram ``p + a dpdx + b dpdy`` (``a``, ``b`` in [-1/2, 1/2]) cut in 2x2, in
    :data:`QUARTERS`' order; each quarter is the parallelogram of ``dpdx / 2``, ``dpdy / 2``
    (the arithmetic ``native/textures.cpp`` ``stage_quarters`` repeats)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    dx, dy = np.asarray(dpdx, dtype=np.float64).reshape(-1, 3), np.asarray(dpdy, dtype=np.float64).reshape(-1, 3)
    both, across = 0.25 * (dx + dy), 0.25 * (dx - dy)  # QUARTERS: -both, +across, -across, +both
    return np.stack([p - both, p + across, p - across, p + both])


def first_quarter_octave(width: np.ndarray, count: int, lacunarity: float, scale: float = 1.0) -> np.ndarray:
    """``(n,)`` int64: for ``(n,)`` footprint widths, the first of ``count`` octaves whose
    footprint spans :data:`QUAD_CELLS` of its lattice cell or more (``count`` where none
    does): the octaves before it are evaluated once, at the footprint's centre."""
    w = np.abs(float(scale)) * np.asarray(width, dtype=np.float64).reshape(-1)
    first = np.zeros(len(w), dtype=np.int64)
    freq = 1.0
    for _ in range(count):  # the frequencies as the kernel multiplies them out
        first += w * freq < QUAD_CELLS  # NaN widths: no octave is coarse
        freq *= lacunarity
    return first


def quarter_octave_sums(
    points: np.ndarray,
    dpdx: np.ndarray,
    dpdy: np.ndarray,
    width: np.ndarray,
    *,
    octaves: int,
    basis: str = "value",
    interpolation: str = "linear",
    lacunarity: float = 2.0,
    gain: float = 0.5,
    signed: bool = False,
    seed: int = 0,
    max_octaves: int | None = None,
    scale: float = 1.0,
    offset: float = 0.0,
) -> np.ndarray:
    """``(4, n)`` float64: :func:`octave_sum` at the four quarters of each footprint
    (:func:`quarter_points`), filtered by the quarter's width (``width / 2``) for the octaves
    whose footprint spans :data:`QUAD_CELLS` of a cell or more, and by the whole footprint,
    at its centre, for the coarser ones (the same value in every quarter).

    ``points``, ``dpdx``, ``dpdy``: ``(n, 3)`` the points and their footprints' edges;
    ``width``: ``(n,)`` the footprints' widths (``EvalContext.width``). The mean of the four,
    through a colour map, is the footprint's mean colour, closer than one filtered sample's
    where octaves near the footprint's size vary inside it.

    The octaves from ``k0`` on (:func:`first_quarter_octave`) are the sum ``gain^k0 sum_j
    gain^j noise(lacunarity^j (lacunarity^k0 (scale p + offset)))``: per point, one compiled
    pass (``native/textures.cpp`` ``quarter_octave_sums``) sums the octaves before ``k0`` at the
    centre and those from it at each quarter, as an :func:`octave_sum` of ``octaves - k0``
    octaves with scale and offset times ``lacunarity^k0``, times ``gain^k0``, added to the
    centre's: bit for bit the :func:`octave_sum` calls by runs of one ``k0`` it replaces
    (``tests/texbake/textures/test_quarters.py`` keeps them as its reference).
    """
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    dx = np.ascontiguousarray(dpdx, dtype=np.float64).reshape(-1, 3)
    dy = np.ascontiguousarray(dpdy, dtype=np.float64).reshape(-1, 3)
    w = np.ascontiguousarray(width, dtype=np.float64).reshape(-1)
    cap = octave_count(octaves, gain, max_octaves, basis=basis, seed=seed)
    capped = cap.capped if cap.evaluated < octaves and not signed else None  # signed octaves have mean 0
    out = np.empty((4, len(p)))
    _native.quarter_octave_sums(p, dx, dy, w, *tables(seed), *_derived_tables(seed), BASES.index(basis),
                                INTERPOLATIONS.index(interpolation), cap.evaluated, float(lacunarity), float(gain), bool(signed),
                                basis_mean(basis, seed), float(scale), float(offset), capped, out)
    return out


class OctaveCount(NamedTuple):
    """How an octave sum is evaluated under a cap on its octaves (``max_octaves``)."""

    evaluated: int  # the octaves evaluated
    capped: float  # what the octaves left out add: their unsigned mean (0.0 when none is left out)
    norm: float  # the weights of every octave summed, capped or not: the sum divided by it lies in [0, 1]


def octave_count(octaves: int, gain: float, max_octaves: int | None = None, *, basis: str = "value", seed: int = 0) -> OctaveCount:
    """The octave cap: of ``octaves`` (weights ``gain^k``), ``max_octaves`` at most are
    evaluated (None: all), and those left out add their mean (:func:`basis_mean`), so the
    brightness does not shift; the normalisation stays that of all ``octaves``."""
    octaves = int(octaves)
    count = octaves if max_octaves is None else min(octaves, int(max_octaves))
    capped = basis_mean(basis, seed) * sum(gain**k for k in range(count, octaves)) if count < octaves else 0.0
    return OctaveCount(count, capped, sum(gain**k for k in range(octaves)))


def noise(points: np.ndarray, *, basis: str = "value", interpolation: str = "linear", seed: int = 0) -> np.ndarray:
    """``(n,)`` float64 noise at ``(n, 3)`` points (one octave, point-sampled): in [0, 1]
    for linear and cubic value noise and for Perlin's; Catmull-Rom value noise overshoots
    its lattice values, to about [-0.10, 1.11]."""
    return octave_sum(points, None, octaves=1, basis=basis, interpolation=interpolation, seed=seed)


@functools.cache
def octave_variance(basis: str = "value", interpolation: str = "linear", seed: int = 0) -> float:
    """The variance over space of one octave of the basis in [0, 1] (:func:`noise`), from
    2^18 points drawn over its 256-cell period (a fixed draw: the same figure each run; its
    own error about 0.3 %)."""
    points = np.random.default_rng(12345).random((1 << 18, 3)) * 256.0
    return float(noise(points, basis=basis, interpolation=interpolation, seed=seed).var())


def octave_spread(width: np.ndarray, *, octaves: int, basis: str = "value", interpolation: str = "linear",
                  lacunarity: float = 2.0, gain: float = 0.5, seed: int = 0, max_octaves: int | None = None,
                  scale: float = 1.0, quarters: bool = False) -> np.ndarray:
    """``(n,)`` float64: the standard deviation, inside each footprint, of the unsigned
    octave sum :func:`octave_sum` gives for ``(n,)`` footprint widths ``width`` (the filtered
    sum is about the footprint's mean; what the filter took out is the spread about it).

    Octave ``k`` (weight ``gain^k``, variance :func:`octave_variance` over space) keeps
    ``f_k = fade_factor(|scale| width lacunarity^k)`` of itself about its mean, so ``1 -
    f_k^2`` of its variance lies inside the footprint; capped octaves (``max_octaves``) all
    of it; the octaves taken as independent. Multiply by 2 for the signed sum.

    ``quarters``: the spread inside one quarter of a :func:`quarter_octave_sums` footprint:
    the octaves it evaluates at the quarters filtered by half the width, the coarser ones
    (evaluated at the centre) by the whole of it."""
    w = np.abs(float(scale)) * np.asarray(width, dtype=np.float64).reshape(-1)
    lo, hi, log_widths, table = _spread_table(int(octaves), basis, interpolation, float(lacunarity), float(gain), int(seed), max_octaves,
                                              bool(quarters))
    at = np.log(np.clip(w, lo, hi))  # the table over log width (8 octaves a point otherwise: 6x the turbulence's own time)
    out = np.interp(at, log_widths, table)
    out = np.where(w < lo, table[0] * w / lo, out)  # the finest octave's spread, proportional to the width below the table
    return np.where(w > 0, out, np.where(np.isnan(w), np.nan, 0.0))


@functools.lru_cache(maxsize=64)
def _spread_table(octaves: int, basis: str, interpolation: str, lacunarity: float, gain: float, seed: int,
                  max_octaves: int | None, quarters: bool = False) -> tuple[float, float, np.ndarray, np.ndarray]:
    """``(lo, hi, log widths (SPREAD_WIDTHS,), spreads (SPREAD_WIDTHS,))``: :func:`octave_spread`
    at widths (lattice cells) spaced evenly in log from ``lo`` to ``hi`` (below: no octave is
    filtered; above: every one is dropped), and those widths' logs (what ``np.interp`` looks
    them up over, here and in ``native/textures.cpp``); ``quarters``: in a quarter (octaves
    from :data:`QUAD_CELLS` of a cell on at half the width)."""
    lo, hi = 1e-3 / lacunarity ** max(octaves - 1, 0), 8.0 * DROP_CELLS
    w = np.exp(np.linspace(np.log(lo), np.log(hi), SPREAD_WIDTHS))
    cap = octave_count(octaves, gain, max_octaves, basis=basis, seed=seed)
    variance = np.zeros(len(w))
    for k in range(octaves):
        s = w * lacunarity**k
        if quarters:
            s = np.where(s < QUAD_CELLS, s, 0.5 * s)
        share = box_share(s) if k < cap.evaluated else np.zeros(len(w))
        variance += gain ** (2 * k) * (1.0 - share * share)
    spreads = np.sqrt(np.maximum(variance, 0.0) * octave_variance(basis, interpolation, seed))
    return lo, hi, np.linspace(np.log(lo), np.log(hi), len(spreads)), spreads


SPREAD_WIDTHS = 4096  # widths in an octave spread's table: linear interpolation in log width errs < 1e-4 of the spread


def box_share(s: np.ndarray) -> np.ndarray:
    """:func:`fade_factor` of ``(n,)`` widths ``s`` in lattice cells, as ``native/octaves.hpp``
    ``block_fade`` computes it (vectorised)."""
    s = np.asarray(s, dtype=np.float64)
    a = 0.5 * s
    c = 2.0 - a
    low = a * (2.0 / 3.0) - a**3 / 3.0 + a**4 / 8.0
    mid = 11.0 / 24.0 + (1.0 - c**4) / 24.0
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = 3.0 * np.where(a < 1.0, low, np.where(a < 2.0, mid, 0.5)) / s
    return np.where(s <= 0.0, 1.0, np.where(s < DROP_CELLS, rho * rho, 0.0))
