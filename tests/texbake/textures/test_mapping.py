"""texbake.textures.mapping: object-space samples to the bake's texture space, points and
footprints together, rounded to the bake's precision, then through the spec's placement."""

import numpy as np
import pytest

from texbake.textures import evaluate, parse_spec
from texbake.textures.mapping import TextureMapping, place_and_evaluate

POSITION = parse_spec("position")  # the point itself, normalised to the bounds: shows what a texture sees
FILTERED = parse_spec({"name": "checker", "box": [0.1, 0.1, 0.1]})  # its closed-form filter reads the footprint


def random_points(n=500, lo=(0.0, 0.0, 0.0), hi=(1.0, 1.0, 1.0), seed=0):
    return np.random.default_rng(seed).uniform(lo, hi, (n, 3))


def test_unit_space_starts_the_box_at_zero_with_its_longest_side_one():
    lo, hi = np.array([1e8, -2.0, 5.0]), np.array([1e8 + 4.0, 0.0, 6.0])
    m = TextureMapping.for_mesh(lo, hi, "unit")
    assert m.scale == 0.25 and np.array_equal(m.origin, lo)
    np.testing.assert_array_equal(m.bounds, [[0, 0, 0], [1.0, 0.5, 0.25]])
    p = random_points(lo=lo, hi=hi)
    q, _, _ = m.to_space(p)
    # (p - origin) first, then the scale: far from the origin the difference is exact
    np.testing.assert_array_equal(q, (p - lo) * 0.25)
    assert q.min() >= 0 and q.max() <= 1


def test_object_space_keeps_the_coordinates():
    lo, hi = np.array([-3.0, 1.0, 2.0]), np.array([5.0, 2.0, 9.0])
    m = TextureMapping.for_mesh(lo, hi, "object")
    p = random_points(lo=lo, hi=hi)
    dpdx, dpdy = np.full_like(p, 1e-3), np.full_like(p, -2e-3)
    q, dqdx, dqdy = m.to_space(p, dpdx, dpdy)
    assert np.array_equal(q, p) and np.array_equal(dqdx, dpdx) and np.array_equal(dqdy, dpdy)
    np.testing.assert_array_equal(m.bounds, [lo, hi])
    # the library's object-space evaluate and the bake's mapping are one path: the same bits
    footprint = np.stack([dpdx, dpdy], axis=1)
    np.testing.assert_array_equal(m.evaluate(FILTERED, p, dpdx, dpdy), evaluate(FILTERED, p, footprint, bounds=m.bounds))


def test_footprints_are_scaled_with_the_points_not_moved():
    lo, hi = np.array([10.0, 10.0, 10.0]), np.array([14.0, 12.0, 11.0])
    m = TextureMapping.for_mesh(lo, hi, "unit")
    p = random_points(lo=lo, hi=hi)
    dpdx, dpdy = np.tile([0.04, 0.0, 0.0], (len(p), 1)), np.tile([0.0, 0.0, -0.02], (len(p), 1))
    _, dqdx, dqdy = m.to_space(p, dpdx, dpdy)
    np.testing.assert_array_equal(dqdx, dpdx * 0.25)  # scaled, no origin subtracted
    np.testing.assert_array_equal(dqdy, dpdy * 0.25)


def test_a_filtered_texture_sees_the_same_footprint_however_the_mesh_is_scaled_and_placed():
    lo, hi = np.zeros(3), np.array([1.0, 0.7, 0.4])
    p = random_points(lo=lo + 0.1 * hi, hi=0.9 * hi)  # footprints within the box (the filter is cut to it)
    rng = np.random.default_rng(1)
    dpdx, dpdy = rng.normal(0, 0.01, p.shape), rng.normal(0, 0.01, p.shape)
    base = TextureMapping.for_mesh(lo, hi, "unit").evaluate(FILTERED, p, dpdx, dpdy)
    k, t = 8.0, np.array([-3.0, 100.0, 7.5])  # the same mesh 8 times larger, moved
    moved = TextureMapping.for_mesh(k * lo + t, k * hi + t, "unit")
    np.testing.assert_allclose(moved.evaluate(FILTERED, k * p + t, k * dpdx, k * dpdy), base, rtol=0, atol=1e-9)
    unscaled = moved.evaluate(FILTERED, k * p + t, dpdx, dpdy)  # footprints left as they were: a smaller filter
    assert np.abs(unscaled - base).max() > 0.05
    point = TextureMapping.for_mesh(lo, hi, "unit").evaluate(FILTERED, p, None, None)
    assert np.abs(point - base).max() > 0.05  # the footprint reaches the texture


def test_the_specs_placement_moves_points_and_turns_footprints():
    spec = parse_spec({"name": "checker", "box": [0.1, 0.1, 0.1], "transform": {"rotate": [0, 0, 90], "translate": [0.3, 0, 0]}})
    steps = spec.placement().steps
    assert steps  # the transform is a placement step
    p = random_points()
    dpdx = np.tile([0.01, 0.0, 0.0], (len(p), 1))
    q, dqdx, _ = spec.placement()(p, dpdx, dpdx)
    assert not np.allclose(q, p)
    # a differential turns with the points but does not move: the same change as of two points
    q2, _, _ = spec.placement()(p + dpdx, None, None)
    np.testing.assert_allclose(dqdx, q2 - q, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(place_and_evaluate(spec, p, dpdx, dpdx), evaluate(spec, p, np.stack([dpdx, dpdx], axis=1)))


def test_float32_precision_rounds_the_points_and_footprints_the_texture_sees():
    lo, hi = np.zeros(3), np.ones(3)  # unit space is the same box: ``position`` gives back the point
    p = random_points()
    f64 = TextureMapping.for_mesh(lo, hi, "unit", "float64")
    f32 = TextureMapping.for_mesh(lo, hi, "unit", "float32")
    np.testing.assert_array_equal(f64.evaluate(POSITION, p, None, None), p)
    rounded = f32.evaluate(POSITION, p, None, None)
    np.testing.assert_array_equal(rounded, p.astype(np.float32).astype(np.float64))
    assert not np.array_equal(rounded, p)
    np.testing.assert_array_equal(f32.evaluate(POSITION, p, None, None, exact=True), p)  # the error probe's reference
    # points given in texture space (the bump's offset points) are rounded the same way
    np.testing.assert_array_equal(f32.evaluate_in_space(POSITION, p), rounded)
    # and so are footprints: as if float64 were given the rounded ones
    rng = np.random.default_rng(2)
    dpdx, dpdy = rng.normal(0, 0.03, p.shape), rng.normal(0, 0.03, p.shape)
    r = lambda a: a.astype(np.float32).astype(np.float64)
    np.testing.assert_array_equal(f32.evaluate(FILTERED, p, dpdx, dpdy), f64.evaluate(FILTERED, r(p), r(dpdx), r(dpdy)))


@pytest.mark.parametrize("precision", ["float64", "float32"])
def test_the_mapping_passes_its_bounds_and_octave_cap_to_the_texture(precision):
    lo, hi = np.array([2.0, 2.0, 2.0]), np.array([4.0, 3.0, 2.5])
    m = TextureMapping.for_mesh(lo, hi, "unit", precision)
    p = np.array([hi, lo, (lo + hi) / 2])
    # the mesh's box in unit space is [0, 1] x [0, 0.5] x [0, 0.25]: position normalises to it
    np.testing.assert_allclose(m.evaluate(POSITION, p, None, None), [[1, 1, 1], [0, 0, 0], [0.5, 0.5, 0.5]], atol=1e-7)
    fbm = parse_spec({"name": "fbm", "octaves": 8})
    pts = random_points(200, lo=lo, hi=hi)
    full, capped = m.evaluate(fbm, pts, None, None), m.evaluate(fbm, pts, None, None, max_octaves=2)
    assert np.abs(full - capped).max() > 1e-3
    q, _, _ = m.to_space(pts)
    q = q.astype(np.float32).astype(np.float64) if precision == "float32" else q
    np.testing.assert_array_equal(capped, evaluate(fbm, q, bounds=m.bounds, max_octaves=2))
