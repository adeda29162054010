"""A material's evaluation: the node kernel against plain NumPy references of each op, the
distribution approach against numerical integration over the Gaussian it assumes, and
against a supersampled texel mean; shared nodes evaluated once; NaN in, NaN out."""

import numpy as np
import pytest
from scipy import integrate

from texbake import _native
from texbake.materials import Evaluator, evaluate_material, parse_material
from texbake.materials.program import compile_program
from texbake.textures import evaluate
from texbake.textures.colour import colours
from texbake.textures.mapping import TextureMapping
from texbake.textures.solid import spline

RNG = np.random.default_rng(28)
P = RNG.uniform(0.0, 1.0, (4000, 3))
X, Y, Z = "x", "y", "z"


def channel(axis):
    return {"op": "channel", "input": {"op": "position"}, "channel": axis}


def smoothstep(x, e0, e1):
    u = np.clip((x - e0) / (e1 - e0), 0, 1)
    return u * u * (3 - 2 * u)


def overlay(a, b):
    return np.where(a < 0.5, 2 * a * b, 1 - 2 * (1 - a) * (1 - b))


# op -> (node, NumPy reference of x, y, z: the point's coordinates)
CASES = {
    "add": ({"op": "add", "a": channel(X), "b": channel(Y)}, lambda x, y, z: x + y),
    "subtract": ({"op": "subtract", "a": channel(X), "b": 0.25}, lambda x, y, z: x - 0.25),
    "multiply": ({"op": "multiply", "a": channel(X), "b": channel(Z)}, lambda x, y, z: x * z),
    "divide": ({"op": "divide", "a": channel(Y), "b": {"op": "threshold", "input": channel(X), "at": 0.5}},
               lambda x, y, z: np.where(x >= 0.5, y, 0.0)),  # 0 where dividing by 0
    "power": ({"op": "power", "a": {"op": "subtract", "a": channel(X), "b": 0.3}, "b": 2.5},
              lambda x, y, z: np.maximum(x - 0.3, 0) ** 2.5),
    "invert": ({"op": "invert", "input": channel(Y)}, lambda x, y, z: 1 - y),
    "clamp": ({"op": "clamp", "input": channel(X), "min": 0.2, "max": 0.7}, lambda x, y, z: np.clip(x, 0.2, 0.7)),
    "threshold": ({"op": "threshold", "input": channel(Z), "at": 0.4}, lambda x, y, z: (z >= 0.4).astype(float)),
    "smoothstep": ({"op": "smoothstep", "input": channel(X), "edge0": 0.3, "edge1": 0.6}, lambda x, y, z: smoothstep(x, 0.3, 0.6)),
    "mix": ({"op": "mix", "a": channel(X), "b": channel(Y), "mask": channel(Z)}, lambda x, y, z: x + z * (y - x)),
    "overlay": ({"op": "blend", "mode": "overlay", "a": channel(X), "b": channel(Y)}, lambda x, y, z: overlay(x, y)),
    "screen": ({"op": "blend", "mode": "screen", "a": channel(X), "b": channel(Y)}, lambda x, y, z: 1 - (1 - x) * (1 - y)),
    "blend multiply": ({"op": "blend", "mode": "multiply", "a": channel(X), "b": channel(Y)}, lambda x, y, z: x * y),
    "luminance": ({"op": "channel", "input": {"op": "position"}}, lambda x, y, z: 0.2126 * x + 0.7152 * y + 0.0722 * z),
    "curve": ({"op": "remap", "input": channel(X), "curve": {"knots": [0, 0.5, 1], "values": [0.1, 0.9, 0.3]}},
              lambda x, y, z: spline(x, np.array([0, 0.5, 1.0]), np.array([[0.1], [0.9], [0.3]]))[:, 0]),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_each_op_point_sampled_matches_numpy(name):
    node, reference = CASES[name]
    out = evaluate_material({"base_color": 0.5, "roughness": node}, P)["roughness"][:, 0]
    expected = reference(*P.T)
    tolerance = 2e-5 if name == "curve" else 1e-12  # the curve is tabulated as the colour maps are (4096 samples)
    np.testing.assert_allclose(out, expected, atol=tolerance, rtol=0)


def test_colour_ops_broadcast_scalars_and_remap_to_colours():
    cmap = {"knots": [0.0, 0.4, 1.0], "colours": [[0, 0, 0], [1, 0, 0], [1, 1, 0.5]]}
    out = evaluate_material({"base_color": {"op": "mix", "a": {"op": "remap", "input": channel(X), "colormap": cmap},
                                            "b": {"op": "combine", "r": channel(Z), "g": 0.5, "b": channel(Y)},
                                            "mask": channel(Y)}}, P)["base_color"]
    x, y, z = P.T
    a = colours(cmap["knots"], cmap["colours"], x)  # the textures' own colour map
    b = np.column_stack([z, np.full_like(z, 0.5), y])
    np.testing.assert_allclose(out, a + y[:, None] * (b - a), atol=1e-12)
    grey = evaluate_material({"base_color": channel(X)}, P)["base_color"]
    np.testing.assert_array_equal(grey, np.repeat(P[:, :1], 3, axis=1))


def test_textures_and_their_values_are_the_texture_kernels():
    out = evaluate_material({"base_color": {"name": "marble"}, "roughness": {"op": "texture", "texture": "wood", "output": "value"},
                             "metallic": {"op": "texture", "texture": "fbm", "output": "value"}}, P)
    np.testing.assert_array_equal(out["base_color"], evaluate("marble", P))
    rings = out["roughness"][:, 0]
    assert set(np.unique(rings)) <= {0.0, 1.0}  # point-sampled rings
    dark, light = evaluate({"name": "wood", "colormap": {"knots": [0, 1], "colours": [[0, 0, 0], [1, 1, 1]]}}, P)[:, 0], rings
    np.testing.assert_array_equal(dark > 0.5, light > 0.5)
    from texbake.textures.solid import turbulence

    np.testing.assert_allclose(out["metallic"][:, 0], 0.5 + 0.5 * turbulence(P, None, scale=4.0, signed=True), atol=1e-15)


def test_a_warp_is_the_texture_at_moved_points():
    by = {"op": "texture", "texture": "turbulence", "output": "value"}
    out = evaluate_material({"base_color": {"op": "warp", "texture": "checker", "by": by, "amount": 0.3, "axis": "y"}}, P)
    t = evaluate_material({"base_color": by}, P)["base_color"][:, 0]
    moved = P.copy()
    moved[:, 1] += 0.3 * t
    np.testing.assert_array_equal(out["base_color"], evaluate("checker", moved))
    vector = evaluate_material({"base_color": {"op": "warp", "texture": "marble", "by": {"op": "position"}, "amount": -0.5}}, P)
    np.testing.assert_array_equal(vector["base_color"], evaluate("marble", P - 0.5 * P))


def test_a_warp_of_a_kernel_node_runs_in_a_later_segment():
    by = {"op": "smoothstep", "input": {"op": "texture", "texture": "turbulence", "output": "value"}, "edge0": 0.3, "edge1": 0.7}
    material = parse_material({"nodes": {"by": by}, "base_color": {"op": "mix", "a": "by", "b": {
        "op": "warp", "texture": "marble", "by": "by", "amount": 0.2}, "mask": 0.5}})
    program = compile_program(material.graph, ["base_color"])
    assert len(program.segments) == 2 and "by" in program.segments[0].exports
    out = evaluate_material(material, P)["base_color"]
    s = evaluate_material({"base_color": by}, P)["base_color"]
    moved = P.copy()
    moved[:, 0] += 0.2 * s[:, 0]
    np.testing.assert_allclose(out, 0.5 * s + 0.5 * evaluate("marble", moved), atol=1e-15)


def spread_run(node, mu, sigma):
    """``(mean, variance)`` of ``node`` over ``channel(x)`` taken as N(mu, sigma^2): the
    position's x is mu and its footprint a box of that variance along x."""
    material = parse_material({"base_color": 0.5, "roughness": node})
    program = compile_program(material.graph, ["roughness"])
    n = len(mu)
    q = np.column_stack([mu, np.full(n, 0.5), np.full(n, 0.5)])
    dqdx = np.zeros((n, 3))
    dqdx[:, 0] = sigma * np.sqrt(12.0)
    from texbake.materials import leaves

    (position,) = [i for i in program.nodes if material.graph.nodes[i].op == "position"]
    values = {position: leaves.position(q, dqdx, np.zeros((n, 3)), np.array([[0.0] * 3, [1.0] * 3]))}
    (seg,) = program.segments
    code = seg.code.copy()
    root = program.channels["roughness"]
    code[code[:, 1] == seg.slots.shape[0] - 1, 7] = 0  # the root (the last slot made) exports its variance too
    out_m, out_v = np.empty((n, seg.columns)), np.empty((n, 1))
    _native.material_program(code, seg.slots, [np.ascontiguousarray(values[r][0]) for r in seg.reads],
                             [np.ascontiguousarray(values[r][1]) for r in seg.reads], seg.params, seg.tables, seg.temps, True,
                             out_m, out_v)
    return out_m[:, seg.exports[root]], out_v[:, 0]


def gaussian_moments(f, mu, sigma, kinks=()):
    """``(E f(X), Var f(X))`` for X ~ N(mu, sigma^2), by adaptive quadrature (SciPy)."""
    pdf = lambda x: np.exp(-0.5 * ((x - mu) / sigma) ** 2) / (sigma * np.sqrt(2 * np.pi))
    lo, hi = mu - 12 * sigma, mu + 12 * sigma
    points = [k for k in kinks if lo < k < hi]
    m = integrate.quad(lambda x: f(x) * pdf(x), lo, hi, points=points or None, limit=200)[0]
    m2 = integrate.quad(lambda x: f(x) ** 2 * pdf(x), lo, hi, points=points or None, limit=200)[0]
    return m, m2 - m * m


SPREAD_CASES = {  # op -> (node over channel(x), scalar function, kinks, tolerance of the mean)
    "threshold": ({"op": "threshold", "input": channel(X), "at": 0.5}, lambda x: float(x >= 0.5), [0.5], 1e-9),
    "clamp": ({"op": "clamp", "input": channel(X), "min": 0.4, "max": 0.6}, lambda x: min(max(x, 0.4), 0.6), [0.4, 0.6], 1e-9),
    "smoothstep": ({"op": "smoothstep", "input": channel(X), "edge0": 0.45, "edge1": 0.55}, lambda x: float(smoothstep(x, 0.45, 0.55)),
                   [0.45, 0.55], 1e-9),
    "overlay": ({"op": "blend", "mode": "overlay", "a": channel(X), "b": 0.8}, lambda x: float(overlay(x, 0.8)), [0.5], 1e-9),
    "power": ({"op": "power", "a": channel(X), "b": 3.0}, lambda x: max(x, 0.0) ** 3, [0.0], 2e-4),
    "curve": ({"op": "remap", "input": channel(X), "curve": {"knots": [0.3, 0.5, 0.7], "values": [0.0, 1.0, 0.2]}},
              lambda x: float(spline(np.array([x]), np.array([0.3, 0.5, 0.7]), np.array([[0.0], [1.0], [0.2]]))[0, 0]),
              [0.3, 0.5, 0.7], 5e-4),
}


@pytest.mark.parametrize("name", sorted(SPREAD_CASES))
def test_non_linear_ops_average_over_their_inputs_gaussian(name):
    node, f, kinks, tolerance = SPREAD_CASES[name]
    mu = np.array([0.35, 0.45, 0.5, 0.52, 0.6, 0.41, 0.55, 0.5])
    sigma = np.array([0.01, 0.05, 0.1, 0.002, 0.03, 0.2, 0.015, 0.0])
    mean, var = spread_run(node, mu, sigma)
    for i in range(len(mu)):
        if sigma[i] == 0:
            assert mean[i] == pytest.approx(f(mu[i]), abs=2e-5 if name == "curve" else 1e-12) and var[i] == 0
            continue
        m, v = gaussian_moments(f, mu[i], sigma[i], kinks)
        # power's quadrature is exact for polynomials only (12 points; 3 under a spread of 0.02), so
        # near its kink at 0 it errs more the wider the spread; the curve's smoothed table to its
        # interpolation; the closed forms to rounding
        allowed = tolerance * (4 if sigma[i] > 0.1 else 1)
        assert mean[i] == pytest.approx(m, abs=allowed), (i, mean[i], m)
        assert var[i] == pytest.approx(v, abs=max(allowed, 1e-8) * 3), (i, var[i], v)


def test_linear_ops_carry_means_and_add_variances():
    mu, sigma = np.array([0.2, 0.7]), np.array([0.05, 0.1])
    mean, var = spread_run({"op": "mix", "a": 0.2, "b": {"op": "multiply", "a": channel(X), "b": 3.0}, "mask": 0.25}, mu, sigma)
    np.testing.assert_allclose(mean, 0.75 * 0.2 + 0.25 * 3 * mu, atol=1e-14)
    np.testing.assert_allclose(var, (0.25 * 3 * sigma) ** 2, rtol=1e-12)


def test_a_threshold_of_fine_turbulence_is_its_texel_mean_not_an_aliased_step():
    # Footprints a few noise cells wide: the texel mean of threshold(turbulence) is the share
    # above the threshold. Point sampling the filtered mean steps to 0 or 1; the
    # distribution approach reads the share from the octaves' spread in the texel.
    n, side, width = 300, 48, 0.08
    centres = RNG.uniform(0.2, 0.8, (n, 3))
    dpdx, dpdy = np.tile([width, 0, 0], (n, 1)), np.tile([0, width, 0], (n, 1))
    node = {"op": "threshold", "input": {"op": "texture", "texture": {"name": "turbulence", "scale": 8.0}, "output": "value"},
            "at": 0.55}
    filtered = evaluate_material({"base_color": node}, centres, np.stack([dpdx, dpdy], axis=1))["base_color"][:, 0]
    from texbake.textures.solid import turbulence

    s = (np.arange(side) + 0.5) / side - 0.5
    a, b = (g.ravel() for g in np.meshgrid(s, s))
    grid = centres[:, None] + a[None, :, None] * dpdx[:, None] + b[None, :, None] * dpdy[:, None]
    truth = (turbulence(grid.reshape(-1, 3), None, scale=8.0) >= 0.55).reshape(n, -1).mean(axis=1)
    naive = (turbulence(centres, np.full(n, width), scale=8.0) >= 0.55).astype(float)
    rmse, naive_rmse = np.sqrt(np.mean((filtered - truth) ** 2)), np.sqrt(np.mean((naive - truth) ** 2))
    assert rmse < 0.5 * naive_rmse, (rmse, naive_rmse)


def test_a_shared_node_is_evaluated_once_a_sample_and_counted_once():
    turb = {"op": "texture", "texture": "turbulence", "output": "value"}
    material = parse_material({"nodes": {"t": turb}, "base_color": {"op": "remap", "input": "t", "colormap": {}},
                               "roughness": "t", "metallic": {"op": "threshold", "input": "t"},
                               "height": {"op": "invert", "input": "t"}, "occlusion": {"op": "mix", "a": 0.5, "b": 1, "mask": "t"},
                               "emissive": {"op": "multiply", "a": "t", "b": [1, 0.5, 0]}})
    evaluator = Evaluator(material, material.channels)
    mapping = TextureMapping.for_mesh(np.zeros(3), np.ones(3), "object")
    out = evaluator.values(mapping, P, None, None, None)
    assert set(out) == set(material.channels)
    textures = [n for n in evaluator.program.nodes if material.graph.nodes[n].op == "texture"]
    assert textures == ["t"] and evaluator.counts["t"] == len(P)  # six channels, one evaluation a sample
    report = evaluator.report()
    assert report["t"]["evaluations"] == len(P) and len(report["t"]["channels"]) == 6


def test_nan_points_give_nan_in_every_channel():
    points = P[:5].copy()
    points[2] = np.nan
    out = evaluate_material("rusted_iron", points)
    for name, values in out.items():
        if name == "metallic" or parse_material("rusted_iron").constant(name) is None:
            assert np.isnan(values[2]).all(), name
            assert np.isfinite(values[[0, 1, 3, 4]]).all(), name


def test_filtered_and_point_sampled_agree_where_footprints_are_tiny():
    fp = np.zeros((len(P), 2, 3))
    fp[:, 0, 0] = fp[:, 1, 1] = 1e-7
    for name in ("rusted_iron", "oak_planks", "lava"):
        a, b = evaluate_material(name, P), evaluate_material(name, P, fp)
        for channel_name in a:
            assert np.abs(a[channel_name] - b[channel_name]).mean() < 2e-3, (name, channel_name)
