"""Colour tables (texbake.textures.colour): the spread table's FFT length and its rows."""

import numpy as np
import pytest

from texbake.textures import colour
from texbake.textures.solid import spline
from texbake.textures.spec import MARBLE_COLOURS, ColourMap


def five_smooth(m: int) -> bool:
    for p in (2, 3, 5):
        while m % p == 0:
            m //= p
    return m == 1


def test_fft_lengths_are_the_least_five_smooth_at_or_above():
    for n in [*range(1, 400), 17016, 709 * 24 + 1, 65537]:
        m = colour._smooth(n)
        assert m >= n and five_smooth(m), (n, m)
        assert not any(five_smooth(k) for k in range(n, m)), (n, m)
    assert colour._smooth(17016) == 17280  # turbulence's default table: 24 x 709 before


@pytest.mark.parametrize("colormap", [ColourMap(), MARBLE_COLOURS], ids=["default", "marble"])
@pytest.mark.parametrize("max_spread", [0.02, 0.0945])
def test_spread_table_rows_are_the_curve_convolved_with_their_gaussian(colormap, max_spread):
    # the definition, by direct convolution on the table's grid: the clamped colour curve
    # against each row's normalised Gaussian (row 0: the curve itself); the FFT, its length
    # padded to a fast one, must give the same rows to rounding
    knots, colours = tuple(colormap.knots), tuple(tuple(c) for c in colormap.colours)
    table, lo, hi = colour.spread_table(knots, colours, max_spread)
    step = (hi - lo) / colour.SPREAD_VALUES
    reach = int(np.ceil(5.0 * max_spread / step)) + 1
    curve = spline(lo + step * np.arange(-reach, colour.SPREAD_VALUES + reach), np.asarray(knots), np.asarray(colours))
    x = np.arange(-reach, reach + 1) * step
    assert np.array_equal(table[0], curve[reach:reach + colour.SPREAD_VALUES])
    for row in (1, colour.SPREAD_ROWS // 2, colour.SPREAD_ROWS - 1):
        s = max_spread * row / (colour.SPREAD_ROWS - 1)
        kernel = np.exp(-0.5 * (x / s) ** 2)
        kernel /= kernel.sum()
        direct = np.stack([np.convolve(curve[:, c], kernel, mode="valid") for c in range(3)], axis=1)
        assert direct.shape == table[row].shape
        assert np.abs(table[row] - direct).max() < 1e-13, row
    # and the spread blurs: a wide row differs from the curve where the colour map bends
    assert np.abs(table[-1] - table[0]).max() > 1e-3
