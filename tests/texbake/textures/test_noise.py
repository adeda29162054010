"""Lattice noise, Perlin noise and octave sums: exactness, precision, continuity, antialiasing."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from texbake.checks.reference import lecture_sample_code as lecture_noise_float32
from texbake.checks.reference import value_noise as reference_value_noise
from texbake.textures import noise as N

RNG = np.random.default_rng(11)


def test_tables_are_the_lectures():
    table, index = N.tables(3)
    assert table.shape == (256,) and table.min() >= 0 and table.max() <= 1
    assert sorted(index) == list(range(256))
    assert np.array_equal(N.tables(3)[1], index) and not np.array_equal(N.tables(4)[1], index)


def test_value_noise_is_the_lecture_formula():
    p = RNG.random((5000, 3)) * 40 - 20
    assert np.abs(N.noise(p) - reference_value_noise(p)).max() < 2e-15  # float64 round-off: measured 3.3e-16
    assert np.array_equal(N.noise(p[:1] * 0 + [[3, -4, 5]]), [N.tables(0)[0][N.tables(0)[1][(3 + N.tables(0)[1][(-4 + N.tables(0)[1][5]) & 255]) & 255]]])


@pytest.mark.parametrize("offset", [1e3, -1e3, 1e6, -1e6, 1e9, -1e9])
def test_far_from_the_origin_matches_float64_reference(offset):
    p = RNG.random((2000, 3)) * 10 + offset
    for interp in ("linear", "cubic"):
        ours = N.noise(p, interpolation=interp)
        # float64 round-off only (the fraction p - floor(p) is exact): measured 3.3e-16
        assert np.abs(ours - reference_value_noise(p, interp)).max() < 2e-15, interp
    # the lecture's float32 "+10000" scheme (its field is ours moved by 10000) does not hold there
    if abs(offset) >= 1e6:
        assert np.abs(lecture_noise_float32(p) - reference_value_noise(p + 10000)).max() > 1e-2


def test_lecture_scheme_breaks_below_minus_10000_and_ours_holds():
    p = RNG.random((2000, 3)) * 5 - 10010  # all coordinates below -10000
    assert np.abs(N.noise(p) - reference_value_noise(p)).max() < 2e-15  # float64 round-off: measured 2.2e-16
    # (int) truncates towards zero below -10000: the lattice cell is off by one
    assert np.abs(lecture_noise_float32(p) - reference_value_noise(p + 10000)).max() > 0.05


@pytest.mark.parametrize("basis", ["value", "perlin"])
def test_period_256(basis):
    p = RNG.random((1000, 3)) * 256
    k = RNG.integers(-4_000_000, 4_000_000, (1000, 3))
    # p + 256 k (up to 1e9) is rounded to half an ulp there (6e-8), times the noise's
    # slope: measured 9e-8
    assert np.abs(N.noise(p, basis=basis) - N.noise(p + 256.0 * k, basis=basis)).max() < 1e-6


@pytest.mark.parametrize("basis, interp", [("value", "linear"), ("value", "cubic"), ("value", "catmull-rom"), ("perlin", "linear")])
@pytest.mark.parametrize("boundary", [-10001.0, -1.0, 0.0, 1.0, 1e6])
def test_continuous_across_cell_boundaries(basis, interp, boundary):
    eps = 1e-7  # well above float64 spacing at 1e6 (1.2e-10)
    base = RNG.random((200, 3)) * 3
    for axis in range(3):
        a, b = base.copy(), base.copy()
        a[:, axis], b[:, axis] = boundary - eps, boundary + eps
        d = np.abs(N.noise(a, basis=basis, interpolation=interp) - N.noise(b, basis=basis, interpolation=interp))
        # slope times 2 eps (measured 1.0e-7); a jump would be ~0.1. The s-curve is flat
        # at the boundary, so the cubic changes by only ~eps^2 there (measured 2.8e-14).
        assert d.max() < (1e-12 if interp == "cubic" else 1e-6)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False, width=64), min_size=3, max_size=3))
def test_finite_for_every_finite_input(xyz):
    p = np.array([xyz])
    for basis in ("value", "perlin"):
        for octaves in (1, 30):
            v = N.octave_sum(p, None, octaves=octaves, basis=basis)
            assert np.isfinite(v).all()
    v = N.noise(p)
    assert 0.0 <= v[0] <= 1.0


def test_signed_zero_and_subnormals():
    p = np.array([[0.0, 0.0, 0.0], [-0.0, -0.0, -0.0], [5e-324, -5e-324, 1e-310]])
    v = N.noise(p)
    # -0.0 is in the same cell as 0.0, and fractions of 1e-310 move the value by far
    # less than an ulp: all three are the value at the origin, exactly
    assert np.isfinite(v).all() and v[0] == v[1] == v[2]


def test_deterministic_by_seed():
    p = RNG.random((500, 3)) * 10
    assert np.array_equal(N.octave_sum(p, None, octaves=5, seed=7), N.octave_sum(p, None, octaves=5, seed=7))
    assert not np.allclose(N.octave_sum(p, None, octaves=5, seed=7), N.octave_sum(p, None, octaves=5, seed=8))


@pytest.mark.parametrize("basis", ["value", "perlin"])
def test_octaves_finer_than_the_footprint_are_replaced_by_their_mean(basis):
    # Texels at 10, 100 and 1000 times the noise frequency: with the footprint the values
    # approach the mean (each octave is 0.5 on average) and their spread shrinks; point
    # sampling keeps the full spread (it aliases).
    n = 4000
    p = RNG.random((n, 3)) * 50
    norm = sum(0.5**k for k in range(8))
    point = N.octave_sum(p, None, octaves=8, basis=basis) / norm
    spreads = []
    for ratio in (10, 100, 1000):
        filtered = N.octave_sum(p, np.full(n, float(ratio)), octaves=8, basis=basis) / norm
        spreads.append(filtered.std())
        assert abs(filtered.mean() - N.basis_mean(basis)) < 0.5 / ratio + 1e-12
    assert spreads[0] < 0.2 * point.std() and spreads[2] <= spreads[1] <= spreads[0]
    assert point.std() > 0.05


def test_fading_is_continuous_in_the_footprint():
    p = RNG.random((300, 3)) * 20
    widths = np.geomspace(1e-4, 10, 400)
    values = np.array([N.octave_sum(p, np.full(len(p), w), octaves=12) for w in widths])
    assert np.abs(np.diff(values, axis=0)).max() < 0.05  # no jump as octaves drop out


@pytest.mark.parametrize("seed", [0, 3])
def test_dropped_octaves_add_the_true_mean_of_the_noise(seed):
    # Value noise averages to the mean of its noiseTable (0.536 for seed 0), not to 0.5:
    # a footprint wider than every octave must give that mean, not a shifted brightness.
    p = RNG.random((200_000, 3)) * 256
    sampled = N.noise(p, seed=seed).mean()  # standard error about 3e-4
    assert abs(sampled - N.tables(seed)[0].mean()) < 2e-3
    wide = N.octave_sum(p[:100], np.full(100, 1e3), octaves=4, seed=seed) / sum(0.5**k for k in range(4))
    assert np.allclose(wide, N.basis_mean("value", seed), rtol=0, atol=1e-15)  # round-off: measured 1.1e-16
    assert abs(N.basis_mean("perlin") - N.noise(p, basis="perlin").mean()) < 2e-3


def test_octave_cap_replaces_the_capped_octaves_by_their_mean():
    p = np.random.default_rng(3).random((500, 3)) * 10
    octave_sum = N.octave_sum
    full = octave_sum(p, None, octaves=3)
    capped = octave_sum(p, None, octaves=8, max_octaves=3)
    # float64 round-off of sums up to 2 (measured 0: the same additions)
    assert np.allclose(capped, full + N.basis_mean("value") * sum(0.5**k for k in range(3, 8)), rtol=0, atol=1e-14)
    signed = octave_sum(p, None, octaves=8, max_octaves=3, signed=True)
    assert np.allclose(signed, octave_sum(p, None, octaves=3, signed=True), rtol=0, atol=1e-14)  # signed octaves have mean 0
    assert np.array_equal(octave_sum(p, None, octaves=4, max_octaves=9), octave_sum(p, None, octaves=4))


def test_box_share_is_the_compiled_fade_factor():
    s = np.concatenate([[0.0, 1e-9, 2.0, 4.0, 7.999, 8.0, 50.0], np.random.default_rng(2).random(200) * 10])
    assert N.box_share(s).tolist() == pytest.approx([N.fade_factor(float(x)) for x in s], rel=1e-12, abs=1e-15)


def test_octave_spread_is_none_at_a_point_and_all_of_the_octaves_when_every_one_is_dropped():
    v = N.octave_variance()
    assert 0.01 < v < 0.05  # linear value noise: about (2/3)^3 of its table's variance
    whole = np.sqrt(v * sum(0.25**k for k in range(8)))
    spread = N.octave_spread(np.array([0.0, 1e-12, 1e3]), octaves=8, scale=4.0)
    assert spread[:2].tolist() == pytest.approx([0.0, 0.0], abs=1e-6) and spread[2] == pytest.approx(whole, rel=1e-12)
