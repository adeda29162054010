"""Footprint filtering of MaterialX's noise3d and fractal3d: the footprint carried through
the graph (chain rule), each Perlin octave shrunk by the share a box over it keeps."""

from pathlib import Path

import numpy as np
import pytest

from texbake.mtlx import evaluate_mtlx

MARBLE = Path(__file__).resolve().parents[2] / "data" / "mtlx" / "standard_surface_marble_solid.mtlx"
FRACTAL = """<?xml version="1.0"?>
<materialx version="1.39">
  <position name="p" type="vector3" />
  <multiply name="p8" type="vector3"><input name="in1" type="vector3" nodename="p" /><input name="in2" type="float" value="8" /></multiply>
  <fractal3d name="f" type="float"><input name="position" type="vector3" nodename="p8" /><input name="octaves" type="integer" value="6" /></fractal3d>
  <standard_surface name="SR" type="surfaceshader"><input name="specular_roughness" type="float" nodename="f" /></standard_surface>
  <surfacematerial name="M" type="material"><input name="surfaceshader" type="surfaceshader" nodename="SR" /></surfacematerial>
</materialx>"""


def footprint(n: int, width: float, seed: int = 0) -> np.ndarray:
    """``(n, 2, 3)``: two random orthogonal edges of length ``width``."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(a, rng.normal(size=(n, 3)))
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    return np.stack([a * width, b * width], axis=1)


def test_zero_footprint_is_the_point_sample():
    p = np.random.default_rng(1).uniform(-1, 1, (2000, 3))
    point = evaluate_mtlx(MARBLE, p)["base_color"]
    np.testing.assert_array_equal(evaluate_mtlx(MARBLE, p, footprint=footprint(2000, 0.0))["base_color"], point)


def test_footprint_scales_with_the_graphs_position():
    """The chain rule: the fractal of 8 x position with footprint w is the fractal of the
    position itself at 8 p with footprint 8 w (the width the noise sees, in its cells)."""
    unscaled = FRACTAL.replace('nodename="p8"', 'nodename="p"')
    rng = np.random.default_rng(2)
    p, f = rng.uniform(-1, 1, (1000, 3)), footprint(1000, 0.03, 3)
    scaled = evaluate_mtlx(FRACTAL, p, footprint=f)["roughness"]
    np.testing.assert_allclose(scaled, evaluate_mtlx(unscaled, 8.0 * p, footprint=8.0 * f)["roughness"], rtol=0, atol=1e-12)
    assert not np.allclose(scaled, evaluate_mtlx(unscaled, 8.0 * p, footprint=f)["roughness"], atol=1e-3)


@pytest.mark.parametrize("width", [0.05, 0.2])
def test_filtering_brings_the_fractal_closer_to_its_mean_over_the_footprint(width):
    """Against the supersampled mean over each footprint (256 points in its parallelogram),
    the filtered fractal is nearer than the point sample (fractal at 8x the position:
    footprints of 0.4 and 1.6 of its cells)."""
    n = 400
    rng = np.random.default_rng(5)
    p, f = rng.uniform(-1, 1, (n, 3)), footprint(n, width, 6)
    filtered = evaluate_mtlx(FRACTAL, p, footprint=f)["roughness"][:, 0]
    point = evaluate_mtlx(FRACTAL, p)["roughness"][:, 0]
    st = rng.uniform(-0.5, 0.5, (256, 2))
    spread = p[:, None, :] + st[None, :, :1] * f[:, None, 0] + st[None, :, 1:] * f[:, None, 1]
    mean = evaluate_mtlx(FRACTAL, spread.reshape(-1, 3))["roughness"][:, 0].reshape(n, 256).mean(axis=1)
    rmse_filtered, rmse_point = np.sqrt(np.mean((filtered - mean) ** 2)), np.sqrt(np.mean((point - mean) ** 2))
    assert rmse_filtered < 0.8 * rmse_point, (rmse_filtered, rmse_point)
