"""Colour maps: a spline colour curve tabulated once, looked up per point; and the mean
colour of a filtered wave, tabulated against its phase spread; and the marble's colour in
one pass (:func:`marble_colours`, :func:`quarter_marble_colours`). The tables are made
here, the lookups are compiled C++ (``native/colour.hpp``, bound as ``texbake._native``).

A filtered texture gives the mean of its scalar over the texel; the colour map of that
mean is not the mean colour (a wide footprint would converge to colour(mean), not
mean(colour)). For the marble, whose scalar is ``0.5 + 0.5 sin(phase)``, the texel's
phase is taken as Gaussian about the filtered phase, with the footprint's spread, and
:func:`wave_table` holds the expected colour for every phase and spread (a circular
convolution of the colour of the sine with the wrapped Gaussian, by FFT).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import _native
from .solid import spline

SIZE = 4096  # samples of the curve; linear interpolation between them errs < 2e-5 (1.9e-5 on the marble map)
PHASES = 1024  # samples of a wave's period in its table
SPREADS = 160  # spreads from 0 to MAX_SPREAD in its table
MAX_SPREAD = 8.0  # radians: beyond it the wave's first harmonic keeps exp(-32) of itself: the plain mean
SINE_SAMPLES = 16384  # a period of the point-sampled marble's colour: linear interpolation errs < 2e-5 (1.9e-5 on the marble map)


@functools.lru_cache(maxsize=64)
def table(knots: tuple[float, ...], colours: tuple[tuple[float, float, float], ...]) -> np.ndarray:
    """``(SIZE, 3)`` float64 samples of the Catmull-Rom curve through the colours."""
    k = np.asarray(knots, dtype=np.float64)
    return spline(np.linspace(k[0], k[-1], SIZE), k, np.asarray(colours, dtype=np.float64))


def colours(knots, colour_list, values: np.ndarray) -> np.ndarray:
    """``(n, 3)`` colours of ``(n,)`` values through the colour map."""
    samples = table(tuple(knots), tuple(tuple(c) for c in colour_list))
    v = np.ascontiguousarray(values, dtype=np.float64).reshape(-1)
    out = np.empty((len(v), 3))
    lo, step = _knot_steps(knots)
    _native.colour_map(v, samples, lo, step, out)
    return out


def _knot_steps(knots) -> tuple[float, float]:
    """``(first knot, table samples a unit)`` of a colour map's :func:`table`."""
    lo, hi = float(knots[0]), float(knots[-1])
    return lo, (SIZE - 1) / (hi - lo) if hi > lo else 0.0


@functools.lru_cache(maxsize=16)
def sine_table(knots: tuple[float, ...], colours: tuple[tuple[float, float, float], ...]) -> np.ndarray:
    """``(SINE_SAMPLES + 1, 3)`` float64: the colour of ``0.5 + 0.5 sin(phi)`` (the spline
    curve itself) at ``phi = 2 pi j / SINE_SAMPLES``, the first row repeated at the end: the
    marble's colour as a function of its phase, with no sine to evaluate per point."""
    phi = 2.0 * np.pi * np.arange(SINE_SAMPLES + 1) / SINE_SAMPLES
    colour = spline(0.5 + 0.5 * np.sin(phi), np.asarray(knots, dtype=np.float64), np.asarray(colours, dtype=np.float64))
    colour[-1] = colour[0]
    return colour


@functools.lru_cache(maxsize=16)
def wave_table(knots: tuple[float, ...], colours: tuple[tuple[float, float, float], ...]) -> np.ndarray:
    """``(SPREADS, PHASES, 3)`` float64: the mean colour of ``0.5 + 0.5 sin(phi + s Z)``
    (Z standard normal) at phases ``phi = 2 pi j / PHASES`` and spreads ``s = MAX_SPREAD i /
    (SPREADS - 1)``. Row 0 is the colour map itself; the last row its mean over the period."""
    phi = 2.0 * np.pi * np.arange(PHASES) / PHASES
    colour = spline(0.5 + 0.5 * np.sin(phi), np.asarray(knots, dtype=np.float64), np.asarray(colours, dtype=np.float64))
    spectrum = np.fft.rfft(colour, axis=0)  # (PHASES // 2 + 1, 3)
    harmonic = np.arange(spectrum.shape[0])
    spreads = MAX_SPREAD * np.arange(SPREADS) / (SPREADS - 1)
    keep = np.exp(-0.5 * np.outer(spreads, harmonic) ** 2)  # the wrapped Gaussian's Fourier series
    return np.fft.irfft(spectrum[None] * keep[:, :, None], n=PHASES, axis=1)


def wave_colours(knots, colour_list, phase: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """``(n, 3)`` mean colours of ``0.5 + 0.5 sin`` of a phase spread as a Gaussian with
    standard deviation ``spread`` about ``phase`` (both ``(n,)``), through the colour map
    (clamped to its knots, as :func:`colours`)."""
    waves = wave_table(tuple(knots), tuple(tuple(c) for c in colour_list))
    ph = np.ascontiguousarray(phase, dtype=np.float64).reshape(-1)
    sp = np.ascontiguousarray(spread, dtype=np.float64).reshape(-1)
    out = np.empty((len(ph), 3))
    _native.wave_colours(ph, sp, waves, MAX_SPREAD, out)
    return out


SPREAD_VALUES = 8192  # samples of a colour map's value range (padded) in its spread table: linear interpolation errs < 1e-4 at a knot's kink
SPREAD_ROWS = 64  # spreads from 0 to the table's largest


@functools.lru_cache(maxsize=16)
def spread_table(knots: tuple[float, ...], colours: tuple[tuple[float, float, float], ...],
                 max_spread: float) -> tuple[np.ndarray, float, float]:
    """``(table (SPREAD_ROWS, SPREAD_VALUES, 3), lo, hi)``: the mean colour of ``t + s Z`` (Z
    standard normal) through the colour map (clamped to its knots), at values ``t = lo + (hi
    - lo) j / SPREAD_VALUES`` and spreads ``s = max_spread i / (SPREAD_ROWS - 1)``; the knots'
    range padded by ``4 max_spread`` each side (the Gaussian's reach). Each row is the curve
    convolved with its Gaussian on the table's own grid (by FFT, every row at once)."""
    k = np.asarray(knots, dtype=np.float64)
    pad = 4.0 * max_spread + 1e-9
    lo, hi = float(k[0]) - pad, float(k[-1]) + pad
    step = (hi - lo) / SPREAD_VALUES
    reach = int(np.ceil(5.0 * max_spread / step)) + 1
    t = lo + step * np.arange(-reach, SPREAD_VALUES + reach)  # the curve, clamped past the knots, beyond the table
    curve = spline(t, k, np.asarray(colours, dtype=np.float64))
    x = np.arange(-reach, reach + 1) * step
    spreads = max_spread * np.arange(SPREAD_ROWS) / (SPREAD_ROWS - 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        kernel = np.exp(-0.5 * (x[None] / spreads[:, None]) ** 2)
    kernel[0] = (x == 0)  # spread 0: the curve itself
    kernel /= kernel.sum(axis=1, keepdims=True)
    n = _smooth(len(t) + len(x) - 1)  # zero-padded past the linear convolution's length: the same rows
    full = np.fft.irfft(np.fft.rfft(curve, n, axis=0)[None] * np.fft.rfft(kernel, n, axis=1)[:, :, None], n, axis=1)
    out = full[:, 2 * reach : 2 * reach + SPREAD_VALUES]  # the rows at the table's values
    out[0] = curve[reach : reach + SPREAD_VALUES]
    return np.ascontiguousarray(out), lo, hi


def _smooth(n: int) -> int:
    """The least length ``>= n`` with no prime factor above 5: pocketfft's FFT of a length with
    a large prime factor is many times slower (turbulence's default table: 17016 = 24 x 709
    took 0.36 s, the first filtered turbulence a process bakes; 17280 takes a tenth)."""
    m = n
    while True:
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        if k == 1:
            return m
        m += 1


def spread_colours(knots, colour_list, values: np.ndarray, spread: np.ndarray, max_spread: float) -> np.ndarray:
    """``(n, 3)`` mean colours of ``(n,)`` values spread as Gaussians of standard deviation
    ``spread`` ``(n,)`` (at most ``max_spread``) about them, through the colour map: a
    filtered scalar's mean colour, not the colour of its mean (:func:`spread_table`; looked
    up by the compiled wave lookup, its value range one period that no lookup wraps)."""
    table_, lo, hi = spread_table(tuple(knots), tuple(tuple(c) for c in colour_list), float(max_spread))
    v = np.clip(np.ascontiguousarray(values, dtype=np.float64).reshape(-1), lo, hi - (hi - lo) / SPREAD_VALUES)
    phase = 2.0 * np.pi * (v - lo) / (hi - lo)
    out = np.empty((len(v), 3))
    _native.wave_colours(phase, np.ascontiguousarray(spread, dtype=np.float64).reshape(-1), table_, float(max_spread), out)
    return out


def marble_colours(points, width, knots, colour_list, *, axis=0, frequency=6.0, amplitude=4.0, scale=1.0, offset=0.0,
                   octaves=8, lacunarity=2.0, gain=0.5, basis="value", interpolation="linear", seed=0,
                   max_octaves=None) -> np.ndarray:
    """``(n, 3)`` marble colours at ``(n, 3)`` points, in one pass: the colour map of
    ``0.5 + 0.5 sin(phase)`` (``solid.marble_phase``: ``frequency * x + amplitude *
    turbulence``) as :func:`sine_table` holds it, or with a footprint ``width`` ``(n,)``
    (None: point sampling) the mean colour over the phase's spread (:func:`wave_colours`).
    Those functions in turn, without their temporaries.
    """
    from .noise import BASES, INTERPOLATIONS, _derived_tables, basis_mean, octave_count, tables

    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    w = None if width is None else np.ascontiguousarray(width, dtype=np.float64).reshape(-1)
    key = (tuple(knots), tuple(tuple(c) for c in colour_list))
    sines, waves = sine_table(*key), wave_table(*key)
    cap = octave_count(octaves, gain, max_octaves, basis=basis, seed=seed)
    out = np.empty((len(p), 3))
    _native.marble(p, w, *tables(seed), *_derived_tables(seed), BASES.index(basis), INTERPOLATIONS.index(interpolation), cap.evaluated,
                   float(lacunarity), float(gain), basis_mean(basis, seed), float(scale), float(offset), int(axis), float(frequency),
                   float(amplitude), float(cap.capped), float(cap.norm), sines, waves, MAX_SPREAD, out)
    return out


def quarter_marble_colours(points, dpdx, dpdy, width, knots, colour_list, *, axis=0, frequency=6.0, amplitude=4.0, scale=1.0,
                           offset=0.0, octaves=8, lacunarity=2.0, gain=0.5, basis="value", interpolation="linear", seed=0,
                           max_octaves=None) -> np.ndarray:
    """``(n, 3)`` filtered marble colours at ``(n, 3)`` points with footprints ``p + a dpdx +
    b dpdy`` (``a``, ``b`` in [-1/2, 1/2]; ``width`` ``(n,)``): the mean of the four
    quarters' colours, each :func:`wave_colours` of the quarter's phase (its centre's
    ``frequency * x`` and turbulence, ``solid.quarter_turbulence``) and its phase spread:
    the box of ``frequency * x`` over half the width, ``(frequency width / 2)^2 / 12``,
    and the turbulence's own spread inside the quarter (``noise.octave_spread``) times
    ``amplitude``, as independent variances. The mean of the colours, not the colour of the
    mean: the veins near a texel's size part the quarters. A footprint with no spread (no
    width) has the point-sampled colour (:func:`marble_colours`).

    In one compiled pass (``native/textures.cpp`` ``quarter_marble``: the quarters' octave
    sums, the spread's table looked up as ``np.interp`` does, the wave colours and their
    mean), the numpy version's arithmetic (``tests/texbake/textures/test_quarters.py``
    keeps it as the reference).
    """
    from .noise import BASES, INTERPOLATIONS, _derived_tables, _spread_table, basis_mean, octave_count, tables

    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    dx = np.ascontiguousarray(dpdx, dtype=np.float64).reshape(-1, 3)
    dy = np.ascontiguousarray(dpdy, dtype=np.float64).reshape(-1, 3)
    w = np.ascontiguousarray(width, dtype=np.float64).reshape(-1)
    key = (tuple(knots), tuple(tuple(c) for c in colour_list))
    sines, waves = sine_table(*key), wave_table(*key)
    cap = octave_count(octaves, gain, max_octaves, basis=basis, seed=seed)
    lo, hi, log_widths, spreads = _spread_table(int(octaves), basis, interpolation, float(lacunarity), float(gain), int(seed),
                                                max_octaves, True)
    out = np.empty((len(p), 3))
    _native.quarter_marble(p, dx, dy, w, *tables(seed), *_derived_tables(seed), BASES.index(basis), INTERPOLATIONS.index(interpolation),
                           cap.evaluated, float(lacunarity), float(gain), basis_mean(basis, seed), float(scale), float(offset),
                           cap.capped if cap.evaluated < octaves else None, int(axis), float(frequency), float(amplitude),
                           float(cap.norm), log_widths, spreads, float(lo), float(hi), sines, waves, MAX_SPREAD, out)
    return out
