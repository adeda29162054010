"""The filtered turbulence and marble at a footprint's four quarters (issue 27):
``noise.quarter_octave_sums``, the mean of the quarters' colours, against point samples;
the compiled quarter kernels against the numpy versions they replaced."""

import itertools

import numpy as np
import pytest

from texbake import _native
from texbake.textures import evaluate, parse_spec
from texbake.textures import noise as N
from texbake.textures.colour import marble_colours, quarter_marble_colours, wave_colours
from texbake.textures.solid import quarter_turbulence, turbulence
from texbake.textures.spec import MARBLE_COLOURS, WOOD_COLOURS, filtered_colours, turbulence_args


def _patch(texels: int, width: float, tilt: float = 0.0):
    """A square of ``texels x texels`` texels of side ``width`` (turned by ``tilt`` in the
    x-y plane, lifted off the lattice's planes), its centres ``(n, 3)`` and footprints
    ``(n, 2, 3)``: the texels tile the square, so that the mean over them of each texel's
    point-sampled mean colour is the square's mean colour."""
    c, s = np.cos(tilt), np.sin(tilt)
    dx, dy = width * np.array([c, s, 0.1]), width * np.array([-s, c, 0.2])
    i, j = np.meshgrid(np.arange(texels), np.arange(texels))
    centres = np.array([0.31, 0.17, 0.43]) + (i.ravel()[:, None] + 0.5) * dx + (j.ravel()[:, None] + 0.5) * dy
    return centres, np.broadcast_to(np.stack([dx, dy]), (len(centres), 2, 3)), dx, dy


def _point_means(spec, centres, dx, dy, side: int) -> np.ndarray:
    """``(n, 3)`` each texel's mean of ``side x side`` point samples at the midpoints of its sub-squares."""
    total = np.zeros((len(centres), 3))
    offsets = (np.arange(side) + 0.5) / side - 0.5
    for a in offsets:
        for b in offsets:
            total += evaluate(spec, centres + a * dx + b * dy)
    return total / side**2


def test_quarter_points_cut_the_footprint_in_four():
    p = np.array([[1.0, 2.0, 3.0]])
    dx, dy = np.array([[0.4, 0.0, 0.0]]), np.array([[0.0, 0.8, 0.0]])
    q = N.quarter_points(p, dx, dy)[:, 0]
    assert q.tolist() == [[0.9, 1.8, 3.0], [1.1, 1.8, 3.0], [0.9, 2.2, 3.0], [1.1, 2.2, 3.0]]
    assert np.allclose(q.mean(axis=0), p[0], rtol=0, atol=1e-15)


def test_only_octaves_near_the_footprints_size_go_to_the_quarters():
    # footprint widths in lattice cells at octave 0: 1/20 is the first octave's threshold
    w = np.array([0.0, 1.0 / 40, 1.0 / 20, 1.0, 100.0, np.nan])
    first = N.first_quarter_octave(w, 8, 2.0)
    assert first.tolist() == [8, 1, 0, 0, 0, 0]


def test_quarters_with_every_octave_coarse_are_the_centres_sum():
    # a footprint too small for any octave to span 1/20 of a cell: all of them at the centre,
    # the plain filtered sum in each quarter (the same calls: equal to round-off, measured 0)
    p = np.random.default_rng(4).random((300, 3)) * 3
    dx = np.tile([[1e-9, 0.0, 0.0]], (300, 1))
    dy = np.tile([[0.0, 1e-9, 0.0]], (300, 1))
    w = np.full(300, 1e-9)
    q = N.quarter_octave_sums(p, dx, dy, w, octaves=8, scale=4.0)
    assert np.allclose(q, N.octave_sum(p, w, octaves=8, scale=4.0), rtol=0, atol=1e-15)


def test_quarters_of_the_finest_octaves_are_the_octave_sum_there_at_half_the_width():
    # every octave spans at least 1/20 of a cell: each quarter is the filtered octave sum at
    # the quarter's centre with half the width (the kernel's frequencies rescaled: round-off, measured 4.4e-16)
    rng = np.random.default_rng(6)
    p, dx, dy = rng.random((200, 3)), rng.normal(size=(200, 3)) * 0.05, rng.normal(size=(200, 3)) * 0.05
    w = np.sqrt(np.maximum((dx * dx).sum(1), (dy * dy).sum(1)))
    w = np.maximum(w, 0.02)  # 0.02 x scale 4 = 0.08 cells at octave 0
    q = N.quarter_octave_sums(p, dx, dy, w, octaves=6, scale=4.0, offset=0.3)
    at = N.quarter_points(p, dx, dy)
    for k in range(4):
        assert np.allclose(q[k], N.octave_sum(at[k], 0.5 * w, octaves=6, scale=4.0, offset=0.3), rtol=0, atol=1e-12)


def test_the_octave_cap_and_signed_sums_carry_over_to_the_quarters():
    rng = np.random.default_rng(7)
    p = rng.random((100, 3))
    dx, dy = np.tile([[0.01, 0, 0]], (100, 1)), np.tile([[0, 0.01, 0]], (100, 1))
    w = np.full(100, 0.01)
    capped = N.quarter_octave_sums(p, dx, dy, w, octaves=8, max_octaves=3, scale=4.0)
    three = N.quarter_octave_sums(p, dx, dy, w, octaves=3, scale=4.0)
    assert np.allclose(capped, three + N.basis_mean("value") * sum(0.5**k for k in range(3, 8)), rtol=0, atol=1e-14)
    signed = N.quarter_octave_sums(p, dx, dy, w, octaves=8, signed=True, scale=4.0)
    assert signed.min() < 0 < signed.max()


def _quarter_sums_by_runs(points, dpdx, dpdy, width, *, octaves, basis, interpolation, lacunarity, gain, signed, seed,
                          max_octaves, scale, offset):
    """The numpy version the compiled ``quarter_octave_sums`` replaced, kept as its reference:
    the points sorted by their first quarter octave k0, one ``octave_sum`` call a run of one
    k0 for the coarse octaves at the centre, one for the fine ones at the quarters."""
    p = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    w = np.ascontiguousarray(width, dtype=np.float64).reshape(-1)
    cap = N.octave_count(octaves, gain, max_octaves, basis=basis, seed=seed)
    first = N.first_quarter_octave(w, cap.evaluated, lacunarity, scale)
    order = np.argsort(first, kind="stable")
    first, p, w = first[order], p[order], w[order]
    quarters = N.quarter_points(p, np.asarray(dpdx)[order], np.asarray(dpdy)[order]).transpose(1, 0, 2)
    runs = np.flatnonzero(np.diff(first)) + 1
    sums = dict(basis=basis, interpolation=interpolation, lacunarity=lacunarity, gain=gain, signed=signed, seed=seed)
    by_point = np.zeros((len(p), 4))
    for lo, hi in zip(np.concatenate([[0], runs]), np.concatenate([runs, [len(p)]]), strict=True):
        k0 = int(first[lo])
        if k0 > 0:
            by_point[lo:hi] = N.octave_sum(p[lo:hi], w[lo:hi], octaves=k0, scale=scale, offset=offset, **sums)[:, None]
        if k0 < cap.evaluated:
            shift = float(lacunarity) ** k0
            fine = N.octave_sum(quarters[lo:hi].reshape(-1, 3), np.repeat(0.5 * w[lo:hi], 4), octaves=cap.evaluated - k0,
                                scale=scale * shift, offset=offset * shift, **sums)
            by_point[lo:hi] += float(gain) ** k0 * fine.reshape(-1, 4)
    out = np.empty((4, len(p)))
    out[:, order] = by_point.T
    if cap.evaluated < octaves and not signed:
        out += cap.capped
    return out


def _footprints(n=1200, seed=11):
    """``(points, dpdx, dpdy, width)``: points in [0, 1), near 1e6 and past the kernel's FAR at
    the top octaves, footprints from 1e-6 to 10 wide (every first quarter octave), zero,
    negative and NaN widths, NaN points and edges, the kinds mixed inside each block."""
    rng = np.random.default_rng(seed)
    p = rng.random((n, 3))
    p[n // 4 : n // 2] += 1e6 * rng.choice([-1.0, 1.0], size=(n // 2 - n // 4, 1))
    p[n // 2 : n // 2 + 30] *= 1e17
    p[-8:-4, 1] = np.nan
    size = 10.0 ** rng.uniform(-6, 1, size=n)
    dx, dy = rng.normal(size=(n, 3)) * size[:, None], rng.normal(size=(n, 3)) * size[:, None]
    w = np.sqrt(np.maximum((dx * dx).sum(1), (dy * dy).sum(1)))
    w[::97] = dx[::97] = dy[::97] = 0.0
    w[5::101] = np.nan
    w[9::89] *= -1.0
    dx[7::103, 2] = np.nan
    return p, dx, dy, w


@pytest.mark.parametrize("basis,interpolation", [("value", "linear"), ("value", "cubic"), ("value", "catmull-rom"), ("perlin", "linear")])
def test_the_compiled_quarters_are_the_numpy_versions_bits(basis, interpolation):
    # one pass a point, no sorting: the same operations per point as the octave_sum calls by
    # runs of one k0 (lacunarity^k0 and gain^k0 as Python's float ** int), on every
    # instruction set the kernels are built for
    p, dx, dy, w = _footprints()
    cases = list(itertools.product((False, True), (None, 3), ((2.0, 0.5), (1.9, 0.6), (2.37, 0.43)), ((1.0, 0.0), (4.0, 0.3))))
    isas = _native.instruction_sets()
    try:
        for signed, max_octaves, (lacunarity, gain), (scale, offset) in cases:
            args = dict(octaves=8, basis=basis, interpolation=interpolation, lacunarity=lacunarity, gain=gain, signed=signed,
                        seed=0, max_octaves=max_octaves, scale=scale, offset=offset)
            cap = N.octave_count(8, gain, max_octaves)
            assert set(N.first_quarter_octave(w, cap.evaluated, lacunarity, scale).tolist()) == set(range(cap.evaluated + 1))
            reference = _quarter_sums_by_runs(p, dx, dy, w, **args)
            for isa in isas:
                _native.use_instruction_set(isa)
                got = N.quarter_octave_sums(p, dx, dy, w, **args)
                assert np.array_equal(got.view(np.uint64), reference.view(np.uint64)), (isa, args)
    finally:
        _native.use_instruction_set(None)


def _quarter_marble_by_numpy(points, dpdx, dpdy, width, knots, colour_list, *, axis, frequency, amplitude, max_octaves,
                             **turbulence_args):
    """The numpy version the compiled ``quarter_marble`` replaced, kept as its reference: the
    quarters' phases and spreads in numpy, ``wave_colours`` on all four, their mean."""
    w = np.asarray(width, dtype=np.float64).reshape(-1)
    turb = quarter_turbulence(points, dpdx, dpdy, w, max_octaves=max_octaves, **turbulence_args)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    dx, dy = (np.asarray(d, dtype=np.float64).reshape(-1, 3)[:, axis] for d in (dpdx, dpdy))
    x = np.stack([p[:, axis] + a * dx + b * dy for a, b in N.QUARTERS])
    phase = frequency * x + amplitude * turb
    spread_args = {k: v for k, v in turbulence_args.items() if k != "offset"}
    norm = N.octave_count(turbulence_args["octaves"], turbulence_args["gain"]).norm
    turb_spread = N.octave_spread(w, max_octaves=max_octaves, quarters=True, **spread_args) / norm
    spread = np.sqrt((frequency * 0.5 * w) ** 2 / 12.0 + (amplitude * turb_spread) ** 2)
    out = wave_colours(knots, colour_list, phase.reshape(-1), np.tile(spread, 4)).reshape(4, -1, 3).mean(axis=0)
    point = spread == 0
    out[point] = marble_colours(p[point], None, knots, colour_list, axis=axis, frequency=frequency, amplitude=amplitude,
                                max_octaves=max_octaves, **turbulence_args)
    return out


@pytest.mark.parametrize("basis,interpolation", [("value", "linear"), ("value", "cubic"), ("value", "catmull-rom"), ("perlin", "linear")])
def test_the_compiled_quarter_marble_is_the_numpy_versions(basis, interpolation):
    # the spread's table looked up as np.interp does, np.log as std::log (numpy's own SIMD log
    # may differ from libm's by an ulp: hence 1e-15, not the bits; measured 0 on AVX2); the
    # point-sampled colour where the spread is 0 (no width, or one whose spread underflows)
    p, dx, dy, w = _footprints()
    w[11::113] = 1e-200
    cases = itertools.product((None, 3), ((2.0, 0.5), (1.9, 0.6)), ((4.0, 0.0), (1.0, 0.3)),
                              ((0, 12.0, 4.0), (2, 6.0, 0.0), (1, 0.0, 4.0)), (MARBLE_COLOURS, WOOD_COLOURS))
    isas = _native.instruction_sets()
    try:
        for max_octaves, (lacunarity, gain), (scale, offset), (axis, frequency, amplitude), colours in cases:
            args = dict(axis=axis, frequency=frequency, amplitude=amplitude, max_octaves=max_octaves, octaves=8, basis=basis,
                        interpolation=interpolation, lacunarity=lacunarity, gain=gain, scale=scale, offset=offset, seed=0)
            reference = _quarter_marble_by_numpy(p, dx, dy, w, colours.knots, colours.colours, **args)
            for isa in isas:
                _native.use_instruction_set(isa)
                got = quarter_marble_colours(p, dx, dy, w, colours.knots, colours.colours, **args)
                assert np.array_equal(np.isnan(got), np.isnan(reference)), (isa, args)
                assert np.nanmax(np.abs(got - reference)) <= 1e-15, (isa, args)
    finally:
        _native.use_instruction_set(None)


def test_the_quarters_spread_is_the_half_widths_for_the_fine_octaves():
    # below 1/20 of a cell every octave is coarse: the same spread; far above, every
    # octave is at half the width: the whole footprint's spread at half the width
    w = np.array([1e-6, 3.0, 40.0])
    quarter = N.octave_spread(w, octaves=8, quarters=True)
    assert quarter[0] == pytest.approx(N.octave_spread(w[:1], octaves=8)[0], rel=1e-3)
    assert quarter[1:].tolist() == pytest.approx(N.octave_spread(0.5 * w[1:], octaves=8).tolist(), rel=1e-3)


@pytest.mark.parametrize("width", [1 / 256, 1 / 64, 1 / 16])
def test_filtered_turbulence_converges_to_the_mean_colour(width):
    # Issue 27, item 3: over a square of texels, the mean of the filtered colours is the
    # square's mean colour (mean(colour), 16 x 16 point samples a texel), within 1e-4,
    # with a colour map whose curve makes colour(mean) differ from mean(colour).
    # Measured |bias| (max over channels): 2.4e-6, 5.6e-5, 4.4e-5 at these widths (the
    # reference's own error included); one filtered sample at the centre, as before the
    # quarters: 3.9e-5, 2.6e-4, 2.0e-4 (over 1e-4 at the two wider).
    spec = parse_spec({"name": "turbulence", "colormap": {"knots": [0.0, 0.45, 0.55, 1.0],
                                                          "colours": [[0, 0, 0], [0.1, 0.3, 0.9], [0.9, 0.6, 0.1], [1, 1, 1]]}})
    centres, fp, dx, dy = _patch(96, width, tilt=0.3)
    filtered = evaluate(spec, centres, fp)
    reference = _point_means(spec, centres, dx, dy, 16)
    bias = np.abs(filtered.mean(axis=0) - reference.mean(axis=0)).max()
    assert bias < 1e-4, bias
    # the texel-by-texel error is far larger than the bias: the test is of the mean
    assert np.sqrt(((filtered - reference) ** 2).mean()) > 5 * bias
    if width > 1 / 100:  # what one centre sample converged to
        width_ = np.full(len(centres), np.linalg.norm(dy))
        one = filtered_colours(spec.colormap, turbulence(centres, width_, **turbulence_args(spec)), width_, spec, None)
        assert np.abs(one.mean(axis=0) - reference.mean(axis=0)).max() > 1e-4


def test_quarters_are_closer_to_the_texel_mean_than_one_centre_sample():
    # The band the quarters are for (issue 27): octaves with cells from 1/12 to 3
    # footprints wide. Per texel RMSE against 16 x 16 point samples, turbulence's default
    # map (measured 5.9e-4 with the quarters against 1.93e-3 with one centre sample).
    spec = parse_spec("turbulence")
    centres, fp, dx, dy = _patch(48, 1 / 64, tilt=0.7)
    reference = _point_means(spec, centres, dx, dy, 16)
    quarters = evaluate(spec, centres, fp)
    width = np.full(len(centres), np.linalg.norm(dy))
    one = filtered_colours(spec.colormap, turbulence(centres, width, **turbulence_args(spec)), width, spec, None)
    rmse = [np.sqrt(((v - reference) ** 2).mean()) for v in (quarters, one)]
    assert rmse[0] < 0.5 * rmse[1], rmse


def test_quarter_turbulence_at_a_point_footprint_is_the_point_value():
    # a zero footprint: every octave is coarse, evaluated at the point unfiltered
    p = np.random.default_rng(8).random((50, 3))
    zero = np.zeros((50, 3))
    q = quarter_turbulence(p, zero, zero, np.zeros(50), scale=4.0)
    assert np.array_equal(q, np.broadcast_to(turbulence(p, None, scale=4.0), (4, 50)))
    spec = parse_spec("turbulence")
    assert np.allclose(evaluate(spec, p, np.zeros((50, 2, 3))), evaluate(spec, p), rtol=0, atol=1e-12)


def test_filtered_marble_in_the_band_is_closer_to_the_texel_mean():
    # marble's veins (frequency 12) a few texels wide: the mean of the quarters' colours
    # against 16 x 16 point samples a texel, and one sample at the centre as before the
    # quarters (the fused kernel with a width: measured RMSE 1.07e-3 against 3.32e-3)
    spec = parse_spec("marble")
    centres, fp, dx, dy = _patch(48, 1 / 48, tilt=0.2)
    reference = _point_means(spec, centres, dx, dy, 16)
    width = np.full(len(centres), np.linalg.norm(dy))
    one = marble_colours(centres, width, spec.colormap.knots, spec.colormap.colours, axis=0, frequency=spec.frequency,
                         amplitude=spec.amplitude, **turbulence_args(spec.turbulence))
    rmse = [np.sqrt(((v - reference) ** 2).mean()) for v in (evaluate(spec, centres, fp), one)]
    assert rmse[0] < 0.5 * rmse[1], rmse


@pytest.fixture(scope="module")
def suzanne_256(meshes):
    from texbake.checks.sweep import prepare_mesh

    return prepare_mesh(meshes / "suzanne_blender_uv.obj", size=256)


@pytest.mark.parametrize("name", ["marble", "turbulence"])
def test_one_filtered_sample_is_as_close_as_sixteen_point_samples_on_suzanne(suzanne_256, name):
    # Issue 27's aim for one sample a texel, on Suzanne's own UVs at 256^2 against a
    # converged reference (256 stratified point samples a texel) on the texels both cover:
    # the filtered RMSE at most the 16-point one. Measured ratios 0.86 (marble) and 0.81
    # (turbulence); one centre sample, before the quarters, 1.80 and 2.19.
    from texbake.checks.sweep import Setting, run_sweep

    settings = [Setting(1, True, size=256), Setting(16, False, size=256)]
    (filtered, sixteen), info = run_sweep(suzanne_256, name, settings=settings, repeats=1, reference_samples=256)
    assert info[256]["own_rmse"] < 0.5 * sixteen.rmse  # the reference is converged well past both
    assert filtered.rmse <= sixteen.rmse, (filtered.rmse, sixteen.rmse)
