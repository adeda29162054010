"""The error estimate (texbake.maps.estimate) as a unit, on synthetic images whose true
RMSE is known: a smooth field baked exactly at texel centres, plus a known error.

The true RMSE is over every covered texel and the three channels, against the texel
means of the field (what :func:`probe_estimate` estimates). For a field linear across
each texel, the mean is the value at the centre, so an image of centre values plus noise
has exactly the noise as its error; for the curved field the texel means are in closed
form (a sine's box mean is the sine times ``sin(a) / a``).
"""

import numpy as np
import pytest
from scipy import ndimage

from texbake.maps import estimate


def linear(uv):
    """``(n, 3)`` float64: a colour linear in u and v (its texel means are its centre values)."""
    u, v = uv[:, 0], uv[:, 1]
    return np.stack([0.2 + 0.5 * u, 0.3 + 0.4 * v, 0.1 + 0.3 * u + 0.3 * v], axis=1)


def everywhere(field):
    """``reference_at`` of a texture that covers the whole unit square."""
    return lambda uv: (np.ones(len(uv), dtype=bool), field(uv))


def centres(height, width=None):
    """``(height, width, 2)`` float64 UV of the texel centres (row 0 at the top)."""
    width = width or height
    rows, cols = np.mgrid[0:height, 0:width]
    return np.stack([(cols + 0.5) / width, 1 - (rows + 0.5) / height], axis=2)


def noisy(height, sigma, seed, width=None):
    """A linear field at the texel centres plus Gaussian noise: ``(image, noise)``, and
    the true RMSE is that of the noise."""
    uv = centres(height, width)
    exact = linear(uv.reshape(-1, 2)).reshape(*uv.shape[:2], 3)
    noise = np.random.default_rng(seed).normal(0.0, sigma, exact.shape)
    return exact + noise, noise


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.mark.parametrize("sigma", [0.01, 0.05])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_known_noise_is_estimated_when_every_texel_is_probed(sigma, seed):
    # 64² texels: at most 4 * PROBE_TEXELS, so every one is probed and nothing is drawn;
    # what remains is the probe's own noise, subtracted without bias on a linear field:
    # a few percent of the error at these sigmas, inside the stated interval
    image, noise = noisy(64, sigma, seed)
    true = rms(noise)
    got = estimate.probe_estimate(everywhere(linear), image, np.ones((64, 64), dtype=bool), seed=seed)
    assert got["texels"] == 64 * 64 and got["method"] == "probe" and got["probe_grid"] == [4, 4]
    low, high = got["rmse_interval"]
    assert low <= true <= high, (low, true, high)
    assert got["rmse"] == pytest.approx(true, rel=0.02)


@pytest.mark.parametrize("precision", [0.0, estimate.PROBE_PRECISION])
def test_the_interval_holds_the_truth_about_95_percent_of_the_time_when_texels_are_drawn(precision):
    # 256 of 4096 texels drawn per estimate: the interval (MSE -+ 2 standard errors) must
    # cover the true RMSE about 95 % of the time; one half as wide would cover about 68 %.
    # 40 seeds: 34 or more inside (a 95 % interval falls below that with 1.5 % chance).
    # With the rounds (precision > 0) an even error stops at the first quarter: 64 texels,
    # whose standard error is already a tenth of the MSE; stopping early must not bias it.
    inside, ratios, probed = 0, [], []
    for seed in range(40):
        image, noise = noisy(64, 0.01, 100 + seed)
        true = rms(noise)
        got = estimate.probe_estimate(everywhere(linear), image, np.ones((64, 64), dtype=bool), seed=seed, texels=256,
                                      precision=precision)
        probed.append(got["texels"])
        low, high = got["rmse_interval"]
        inside += low <= true <= high
        ratios.append(got["rmse"] / true)
    assert inside >= 34, inside
    if precision == 0:
        assert set(probed) == {256}
        assert 0.85 < min(ratios) and max(ratios) < 1.15, (min(ratios), max(ratios))  # the estimate's own spread
    else:
        assert set(probed) <= {64, 128, 256} and np.mean(probed) < 100, probed
        assert 0.75 < min(ratios) and max(ratios) < 1.25, (min(ratios), max(ratios))
    assert 0.97 < np.mean(ratios) < 1.03, np.mean(ratios)  # stopping early must not bias it


def test_rounds_go_on_while_a_few_texels_carry_the_error():
    # one texel in 32 off by 0.2, the rest exact but for a little noise: the first quarter
    # of the drawn texels holds too few of the far ones to know the MSE within
    # PROBE_PRECISION, so the rounds go on (the far texels are sharp: the later rounds go
    # mostly there, and stop at half); an even error of the same RMSE stops at a quarter.
    # (An error on far fewer texels than a quarter of those drawn may be missed by the
    # first round: the module says so.)
    size = 128
    image, noise = noisy(size, 1e-4, 5)
    rng = np.random.default_rng(6)
    far = rng.random((size, size)) < 1 / 32
    image[far] += 0.2
    covered = np.ones((size, size), dtype=bool)
    got = estimate.probe_estimate(everywhere(linear), image, covered, seed=1, texels=1024)
    assert got["texels"] > 256
    true = rms(noise + 0.2 * far[:, :, None])
    low, high = got["rmse_interval"]
    assert low <= true <= high, (low, true, high)
    even, _ = noisy(size, true, 7)
    assert estimate.probe_estimate(everywhere(linear), even, covered, seed=1, texels=1024)["texels"] == 256


def test_an_error_on_one_texel_in_a_hundred_is_found_by_its_contrast():
    # a far texel stands out from its neighbours, so it is sharp (its contrast among the
    # top SHARP), and sharp texels are drawn SHARP_WEIGHT times as often: 20 seeds, at
    # least 18 estimates within [0.75, 1.33] of the truth (19 are). Drawn without regard
    # to contrast (chart edges and inside alone), five of these read about 0.01: the first
    # quarter held no far texel and the rounds stopped there (one seed still does so now).
    size = 128
    ratios = []
    for seed in range(20):
        image, noise = noisy(size, 1e-4, 50 + seed)
        far = np.random.default_rng(60 + seed).random((size, size)) < 1 / 100
        image[far] += 0.2
        true = rms(noise + 0.2 * far[:, :, None])
        got = estimate.probe_estimate(everywhere(linear), image, np.ones((size, size), dtype=bool), seed=seed, texels=1024)
        ratios.append(got["rmse"] / true)
    assert sum(0.75 <= r <= 1.33 for r in ratios) >= 18, ratios


def test_contrast_against_a_plain_loop_and_by_bands():
    rng = np.random.default_rng(3)
    image = rng.random((9, 7, 3)).astype(np.float32)
    covered = rng.random((9, 7)) < 0.7
    want = np.zeros((9, 7), dtype=np.float32)
    for r in range(9):
        for c in range(7):
            if not covered[r, c]:
                continue
            for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
                rr, cc = r + dr, c + dc
                if 0 <= rr < 9 and 0 <= cc < 7 and covered[rr, cc]:
                    want[r, c] = max(want[r, c], np.abs(image[r, c] - image[rr, cc]).max())
    got = estimate.contrast(image, covered)
    assert np.array_equal(got, want)
    assert np.array_equal(np.concatenate([estimate.contrast(image, covered, slice(r, r + 2)) for r in range(0, 9, 2)]), want)


def curved(omega):
    """``(field, texel_means)`` of a colour that curves within a texel: ``0.5 + 0.4 sin(omega u)
    cos(0.7 omega v)`` in two channels, constant in the third."""
    def field(uv):
        s = 0.5 + 0.4 * np.sin(omega * uv[:, 0]) * np.cos(0.7 * omega * uv[:, 1])
        return np.stack([s, s, np.full_like(s, 0.5)], axis=1)

    def means(uv, h):
        a, b = omega * h / 2, 0.7 * omega * h / 2
        s = 0.5 + 0.4 * np.sin(omega * uv[:, 0]) * np.sin(a) / a * np.cos(0.7 * omega * uv[:, 1]) * np.sin(b) / b
        return np.stack([s, s, np.full_like(s, 0.5)], axis=1)

    return field, means


@pytest.mark.parametrize("radians_a_texel", [0.3, 1.0, 3.0])
def test_the_bias_of_a_point_sample_is_seen(radians_a_texel):
    """A bake that takes the value at each texel centre is off by the field's curvature
    within the texel (its texel mean differs): the probe of a several-sample bake
    (8 x 8) sees that error within 2 %; the 4 x 4 probe of a one-sample bake reads its
    checkerboard halves' difference from the curve as noise too, so it reads low, within
    the band the module states for real bakes (0.61 to 1.37 times the error)."""
    size = 64
    field, means = curved(radians_a_texel * size)
    uv = centres(size).reshape(-1, 2)
    image = field(uv).reshape(size, size, 3)
    true = float(np.sqrt(np.mean((image - means(uv, 1 / size).reshape(size, size, 3)) ** 2)))
    covered = np.ones((size, size), dtype=bool)
    fine = estimate.probe_estimate(everywhere(field), image, covered, grid=8, fine=0)
    assert fine["rmse"] == pytest.approx(true, rel=0.02)
    coarse = estimate.probe_estimate(everywhere(field), image, covered, grid=4, fine=0)  # the grids alone
    if radians_a_texel >= 1.0:  # an error well above the 4 x 4 probe's own noise
        assert 0.61 <= coarse["rmse"] / true <= 1.37, coarse["rmse"] / true
    assert coarse["probe_noise"] > fine["probe_noise"]  # a quarter of the samples: more noise


def step(uv):
    """``(n, 3)``: 1 beyond a slanted line across the square (u + 0.7 v > 0.6), else 0 (in
    the first two channels): an edge, as a filtered checker's or wood's error has."""
    v = (uv[:, 0] + 0.7 * uv[:, 1] > 0.6).astype(np.float64)
    return np.stack([v, 0.5 * v, np.full(len(v), 0.25)], axis=1)


def box_means(field, size: int, n: int = 100) -> np.ndarray:
    """``(size, size, 3)``: each texel's mean of ``field`` by an ``n x n`` midpoint rule."""
    g = (np.arange(n) + 0.5) / n
    u = np.repeat(((np.arange(size)[:, None] + g[None, :]) / size)[:, :, None], n, axis=2)  # (texel column, n, n)
    out = np.empty((size, size, 3))
    for row in range(size):
        v = np.broadcast_to((1 - (row + g[None, None, :]) / size), u.shape)
        out[row] = field(np.stack([u.ravel(), v.ravel()], axis=1)).reshape(size, n * n, 3).mean(axis=1)
    return out


def test_an_error_under_the_probes_noise_is_read_by_a_second_look():
    """A bake off by 0.01 on the 87 texels an edge crosses, exact elsewhere: the 8 x 8
    probe's own noise there is about twice that, so the MSE is not known within
    PROBE_PRECISION after every texel, and the texels are looked at again with two 17 x 17
    grids. Then the estimate is within 5 % and its interval holds the truth, every seed
    (measured 0.99-1.01). Without the second look the estimate read 0.64-1.38 of it, and
    three intervals of five lay wholly below the truth: across an edge the checkerboard
    halves of one grid have different means, and their difference reads the noise high."""
    size = 64
    means = box_means(step, size)
    edge = (means[..., 0] > 0) & (means[..., 0] < 1)
    image = means.copy()
    image[edge] += 0.01 * np.random.default_rng(3).choice([-1, 1], size=(int(edge.sum()), 3))
    true = rms(image - means)
    covered = np.ones((size, size), dtype=bool)
    missed = 0
    for seed in range(5):
        got = estimate.probe_estimate(everywhere(step), image, covered, seed=seed, grid=8)
        low, high = got["rmse_interval"]
        assert got["rmse"] == pytest.approx(true, rel=0.05) and low <= true <= high, (seed, got, true)
        assert got["fine_texels"] == edge.sum()  # the budget holds every texel with noise: each looked at
        coarse = estimate.probe_estimate(everywhere(step), image, covered, seed=seed, grid=8, fine=0)
        assert coarse["fine_texels"] == 0
        missed += not coarse["rmse_interval"][0] <= true <= coarse["rmse_interval"][1]
    assert missed >= 1


def test_chances_add_up_to_the_budget_the_largest_certain():
    chances = estimate.chances(np.array([8.0, 0.0, 1.0, 2.0, 1.0, 100.0]), 3)
    assert chances.sum() == pytest.approx(3) and chances[5] == 1.0 and chances[1] == 0.0
    # 100 certain, then 8 too (2 / 12 of it would be over 1), the rest in proportion: 1 / 4 a unit of score
    assert chances[0] == 1.0 and chances[[2, 3, 4]] == pytest.approx([0.25, 0.5, 0.25])
    assert estimate.chances(np.array([0.5, 0.0, 2.0]), 5).tolist() == [1.0, 0.0, 1.0]


def test_zero_only_when_there_is_no_error():
    size = 32
    covered = np.ones((size, size), dtype=bool)
    grey = lambda uv: np.full((len(uv), 3), 0.25)
    exact = np.full((size, size, 3), 0.25)
    zero = estimate.probe_estimate(everywhere(grey), exact, covered)
    assert (zero["rmse"], zero["rmse_interval"], zero["probe_noise"], zero["probe_rmse"]) == (0.0, [0.0, 0.0], 0.0, 0.0)
    # one texel of 1024 off by 1e-3 in one channel: the MSE is known exactly (the probe of
    # a constant has no noise), and rmse is the larger of it and its standard error
    off = exact.copy()
    off[7, 11, 2] += 1e-3
    got = estimate.probe_estimate(everywhere(grey), off, covered)
    # (one texel's squared error e among the n inside: a stratum of weight n / N, so the
    # MSE is e / N and its standard error (n / N) sqrt(e^2 / n / n) is e / N as well)
    mse = (1e-3) ** 2 / 3 / (size * size)
    assert got["rmse"] == pytest.approx(np.sqrt(mse), rel=1e-9) and got["rmse"] > 0
    assert got["rmse_interval"] == pytest.approx([0.0, np.sqrt(3 * mse)], rel=1e-9)


def test_a_known_error_on_every_texel_of_a_constant_is_read_exactly():
    # 0.01 on one channel of every texel: the probe of a constant has no noise of its own
    size = 48
    grey = lambda uv: np.full((len(uv), 3), 0.5)
    image = np.full((size, size, 3), 0.5)
    image[..., 0] += 0.01
    got = estimate.probe_estimate(everywhere(grey), image, np.ones((size, size), dtype=bool))
    assert got["rmse"] == pytest.approx(0.01 / np.sqrt(3), rel=1e-9) and got["texels"] == size * size
    assert got["rmse_interval"] == pytest.approx([0.01 / np.sqrt(3)] * 2, rel=1e-9)  # every texel's error the same: se 0


def test_a_bake_exact_at_the_centres_of_a_linear_field_reads_near_zero_and_a_bias_above_the_probes_noise_is_read():
    # the jittered probe's mean of a linear field is the centre's value up to the probe's
    # own noise, which is subtracted. Its jitter is the same in every texel, so that
    # noise is one offset shared by all texels and a uniform bias much below it may read
    # as about 0; one of 7 times it (1e-3 here) is read within 10 % whatever its sign
    size = 64
    exact = linear(centres(size).reshape(-1, 2)).reshape(size, size, 3)
    covered = np.ones((size, size), dtype=bool)
    zero = estimate.probe_estimate(everywhere(linear), exact, covered)
    assert zero["rmse"] < 1e-3 / size and 0 < zero["probe_noise"] < 1.5e-4
    for bias in (1e-3, -1e-3):
        assert estimate.probe_estimate(everywhere(linear), exact + bias, covered)["rmse"] == pytest.approx(1e-3, rel=0.1)


def test_no_covered_texel_gives_zero_and_says_so():
    got = estimate.probe_estimate(everywhere(linear), np.ones((8, 8, 3)), np.zeros((8, 8), dtype=bool), grid=4, edge_grid=8)
    assert got == {"method": "probe", "how": estimate.HOW["probe"], "rmse": 0.0, "rmse_interval": [0.0, 0.0], "texels": 0,
                   "probe_grid": [4, 8], "probe_rmse": 0.0, "probe_noise": 0.0, "fine_texels": 0}


def test_texels_the_probe_cannot_see_are_left_out():
    # the texture is there only for u < 0.5: the right half's texels get no probe sample
    size = 32
    image, noise = noisy(size, 0.01, 5)

    def left_only(uv):
        hit = uv[:, 0] < 0.5
        return hit, linear(uv[hit])

    got = estimate.probe_estimate(left_only, image, np.ones((size, size), dtype=bool))
    assert got["texels"] == size * size // 2
    assert got["rmse"] == pytest.approx(rms(noise[:, : size // 2]), rel=0.05)  # the error of the left half


def test_the_strata_take_chart_edges_up_to_half_of_the_drawn_texels():
    # a disc of covered texels in a 96² image; 200 texels drawn: 100 on the disc's edge
    # (it has more), 100 inside; recorded from the probe's own sample positions
    size, grid = 96, 4
    rows, cols = np.mgrid[0:size, 0:size]
    covered = (rows - 47.5) ** 2 + (cols - 47.5) ** 2 < 40**2
    edge = covered & ~ndimage.binary_erosion(covered, np.ones((3, 3)), border_value=0)
    assert edge.sum() > 100 and (covered & ~edge).sum() > 100
    seen = []

    def recording(uv):
        seen.append(uv)
        return np.ones(len(uv), dtype=bool), linear(uv)

    image, _ = noisy(size, 0.01, 3)
    got = estimate.probe_estimate(recording, image, covered, texels=200, grid=grid, precision=0)
    assert got["texels"] == 200
    uv = np.concatenate(seen)
    col = np.floor(uv[:, 0] * size).astype(int)
    row = np.floor((1 - uv[:, 1]) * size).astype(int)
    texel = np.unique(row * size + col)
    assert len(texel) == 200 and covered.ravel()[texel].all()
    assert edge.ravel()[texel].sum() == 100
    assert len(uv) == 200 * grid * grid  # every probed texel got its whole grid


def test_the_same_seed_gives_the_same_estimate_and_another_seed_other_texels():
    image, _ = noisy(64, 0.01, 9)
    covered = np.ones((64, 64), dtype=bool)
    a = estimate.probe_estimate(everywhere(linear), image, covered, seed=4, texels=128)
    assert a == estimate.probe_estimate(everywhere(linear), image, covered, seed=4, texels=128)
    assert a["rmse"] != estimate.probe_estimate(everywhere(linear), image, covered, seed=5, texels=128)["rmse"]


@pytest.mark.parametrize("dtype", [np.float16, np.float32])
def test_an_image_of_any_float_dtype_is_read_as_float64_of_its_values(dtype):
    # maps are float32, and float16 at 8192² and more: the estimate is that of their values
    image, _ = noisy(48, 0.02, 2)
    stored = image.astype(dtype)
    covered = np.ones((48, 48), dtype=bool)
    got = estimate.probe_estimate(everywhere(linear), stored, covered)
    assert got == estimate.probe_estimate(everywhere(linear), stored.astype(np.float64), covered)


def test_bands_of_rows_give_the_same_estimate_as_one_band(monkeypatch):
    rng = np.random.default_rng(8)
    covered = ndimage.binary_opening(rng.random((150, 40)) < 0.7)
    image, _ = noisy(150, 0.01, 1, width=40)
    whole = estimate.probe_estimate(everywhere(linear), image, covered, texels=300)
    monkeypatch.setattr(estimate, "BAND", 7)  # bands that do not divide the image
    assert estimate.probe_estimate(everywhere(linear), image, covered, texels=300) == whole


def test_chart_edges_are_covered_texels_with_an_uncovered_neighbour_or_the_border():
    rng = np.random.default_rng(2)
    for shape in [(1, 1), (5, 9), (40, 33)]:
        covered = rng.random(shape) < 0.8
        expect = covered & ~ndimage.binary_erosion(covered, np.ones((3, 3)), border_value=0)
        edges = estimate.chart_edges(covered)
        assert np.array_equal(edges, expect), shape
        for r0, r1 in [(0, 1), (shape[0] // 2, shape[0] // 2 + 2), (shape[0] - 1, shape[0] + 3)]:  # past the end: cut
            assert np.array_equal(estimate.chart_edges(covered, slice(r0, r1)), expect[max(r0, 0):r1]), (shape, r0, r1)


def test_chart_edges_of_a_square():
    covered = np.zeros((6, 6), dtype=bool)
    covered[1:5, 1:5] = True
    edges = estimate.chart_edges(covered)
    assert edges.sum() == 12 and not edges[2:4, 2:4].any() and edges[1, 1:5].all()


def test_checker_halves_and_half_means_against_a_plain_loop():
    k = 4
    halves = estimate.checker_halves(k * k).reshape(k, k)
    assert halves[0, 0] and not halves[0, 1] and np.array_equal(halves, (np.add.outer(np.arange(k), np.arange(k)) % 2 == 0))
    rng = np.random.default_rng(6)
    count, samples = 5, k * k
    texel = rng.integers(0, count, 300)
    sample = rng.integers(0, samples, 300)
    values = rng.random((300, 3))
    a, b, na, nb, squares = estimate.half_means(values, texel, sample, samples, count)
    black = estimate.checker_halves(samples)[sample]
    for t in range(count):
        for mean, n, which in ((a, na, black), (b, nb, ~black)):
            mine = (texel == t) & which
            assert n[t] == mine.sum()
            assert np.allclose(mean[t], values[mine].mean(axis=0) if mine.any() else 0.0, rtol=0, atol=1e-15)
        assert np.allclose(squares[t], (values[texel == t] ** 2).sum(axis=0), rtol=0, atol=1e-14)


def test_probe_grid_follows_the_samples():
    assert [estimate.probe_grid(n) for n in (1, 4, 9, 16, 64, 256)] == [8, 8, 8, 8, 16, 16]
