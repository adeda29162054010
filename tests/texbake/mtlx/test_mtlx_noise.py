"""texbake.mtlx.noise against a literal, one-point-at-a-time transcription of MaterialX's
mx_noise.glsl (glsl_reference.py): 10,000 points per noise, to 1e-5 (float64 both; the
hashes are bit-exact, so the two agree to rounding, ~1e-15)."""

import glsl_reference as ref
import numpy as np
import pytest

from texbake.mtlx import noise

TOL = 1e-5  # the tolerance


def points(n: int, seed: int) -> np.ndarray:
    """Points over many cells, on both sides of 0 (negative cells hash through int -> uint)."""
    return np.random.default_rng(seed).uniform(-40.0, 40.0, (n, 3))


def test_perlin_float():
    p = points(10_000, 1)
    expected = np.array([ref.mx_perlin_noise_float(q) for q in p])
    np.testing.assert_allclose(noise.perlin_float(p), expected, rtol=0, atol=TOL)
    assert expected.std() > 0.1  # a noise, not a constant


def test_perlin_vec3():
    p = points(10_000, 2)
    expected = np.array([ref.mx_perlin_noise_vec3(q) for q in p])
    np.testing.assert_allclose(noise.perlin_vec3(p), expected, rtol=0, atol=TOL)


def test_cell_float_and_vec3():
    p = points(10_000, 3)
    np.testing.assert_allclose(noise.cell_float(p), [ref.mx_cell_noise_float(q) for q in p], rtol=0, atol=TOL)
    np.testing.assert_allclose(noise.cell_vec3(p), [ref.mx_cell_noise_vec3(q) for q in p], rtol=0, atol=TOL)


def test_cell_float2():
    p = points(10_000, 9)[:, :2]
    np.testing.assert_allclose(noise.cell_float2(p), [ref.mx_cell_noise_float2(q) for q in p], rtol=0, atol=TOL)


def test_fractal_float():
    p = points(10_000, 4) / 8.0
    expected = np.array([ref.mx_fractal3d_noise_float(q, 4, 2.0, 0.5) for q in p])
    np.testing.assert_allclose(noise.fractal_float(p, 4, 2.0, 0.5), expected, rtol=0, atol=TOL)


@pytest.mark.parametrize("style", [0, 1])
def test_worley_float_10000_points(style):
    p = points(10_000, 7 + style)
    expected = np.array([ref.mx_worley_noise_float(q, 1.0, style) for q in p])
    np.testing.assert_allclose(noise.worley(p, 1.0, style), expected, rtol=0, atol=TOL)
