import numpy as np

from texbake.maps.bump import normal_map


def frame(n):
    p = np.zeros((n, 3))
    dpdx = np.tile([1e-3, 0, 0], (n, 1))  # +u along +x
    dpdy = np.tile([0, -1e-3, 0], (n, 1))  # one texel down is -y: +v along +y
    normals = np.tile([0, 0, 1.0], (n, 1))
    return p, dpdx, dpdy, normals


def test_flat_height_gives_the_unbent_normal():
    p, dx, dy, n = frame(10)
    out = normal_map(lambda q: np.zeros(len(q)), p, dx, dy, n)
    assert np.allclose(out, [0.5, 0.5, 1.0], rtol=0, atol=1e-13)  # float64 round-off: measured 0


def test_slope_tilts_against_the_gradient():
    # h = 0.5 x on the plane z = 0: n' = normalize(0 - 0.5, 0, 1) in tangent space
    p, dx, dy, n = frame(5)
    p[:, 0] = np.linspace(-1, 1, 5)
    out = normal_map(lambda q: 0.5 * q[:, 0], p, dx, dy, n, strength=1.0)
    expect = np.array([-0.5, 0.0, 1.0]) / np.sqrt(1.25)
    assert np.allclose(out, 0.5 + 0.5 * expect, rtol=0, atol=1e-13)  # float64 round-off: measured 2e-14
    # a slope along y shows in the second (v) component, with the right sign
    out = normal_map(lambda q: 0.5 * q[:, 1], p, dx, dy, n, strength=1.0)
    assert np.allclose(out, 0.5 + 0.5 * np.array([0.0, -0.5, 1.0]) / np.sqrt(1.25), rtol=0, atol=1e-13)
