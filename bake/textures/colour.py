"""Colour maps: a spline colour curve tabulated once, looked up per point (numba); and
the mean colour of a filtered wave, tabulated against its phase spread.

A filtered texture gives the mean of its scalar over the texel; the colour map of that
mean is not the mean colour (a wide footprint would converge to colour(mean), not
mean(colour)). For the marble, whose scalar is ``0.5 + 0.5 sin(phase)``, the texel's
phase is taken as Gaussian about the filtered phase, with the footprint's spread, and
:func:`wave_table` holds the expected colour for every phase and spread (a circular
convolution of the colour of the sine with the wrapped Gaussian, by FFT).
"""

from __future__ import annotations

import functools

import numba as nb  # pip install numba
import numpy as np

from .solid import spline

SIZE = 4096  # samples of the curve; linear interpolation between them errs < 2e-5 (1.9e-5 on the marble map)
PHASES = 1024  # samples of a wave's period in its table
SPREADS = 160  # spreads from 0 to MAX_SPREAD in its table
MAX_SPREAD = 8.0  # radians: beyond it the wave's first harmonic keeps exp(-32) of itself: the plain mean


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


@nb.njit(cache=True, parallel=True, nogil=True)
def _wave_lookup(phase, spread, table, out):
    spreads, phases = table.shape[0], table.shape[1]
    for i in nb.prange(phase.shape[0]):
        x = phase[i] / (2.0 * np.pi)
        x = (x - np.floor(x)) * phases
        j = min(int(x), phases - 1)
        fx = x - j
        j1 = (j + 1) % phases
        y = min(max(spread[i] / MAX_SPREAD, 0.0), 1.0) * (spreads - 1)
        r = min(int(y), spreads - 2)
        fy = y - r
        for c in range(3):
            low = table[r, j, c] * (1.0 - fx) + table[r, j1, c] * fx
            high = table[r + 1, j, c] * (1.0 - fx) + table[r + 1, j1, c] * fx
            out[i, c] = low * (1.0 - fy) + high * fy


def wave_colours(knots, colour_list, phase: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """``(n, 3)`` mean colours of ``0.5 + 0.5 sin`` of a phase spread as a Gaussian with
    standard deviation ``spread`` about ``phase`` (both ``(n,)``), through the colour map
    (clamped to its knots, as :func:`colours`)."""
    table = wave_table(tuple(knots), tuple(tuple(c) for c in colour_list))
    out = np.empty((len(phase), 3))
    _wave_lookup(np.ascontiguousarray(phase, dtype=np.float64), np.ascontiguousarray(spread, dtype=np.float64), table, out)
    return out
