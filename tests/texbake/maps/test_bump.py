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


def native_height_normals(centre, shifted, dx, dy, normals, scale, frame=None, detail=None, directx=False):
    from texbake import _native

    out = np.empty((len(centre), 3))
    _native.height_normals(centre, shifted, dx, dy, np.zeros((0, 3)) if frame is not None else normals,
                           np.zeros((0, 3, 3)) if frame is None else frame, scale, np.zeros((0, 3)) if detail is None else detail,
                           directx, out)
    return out


def test_a_height_slope_tilts_the_normal_by_forward_differences():
    # h = 0.5 x + 0.25 y, linear: forward differences are exact
    from texbake.maps.bump import height_normal_map

    p, dx, dy, n = frame(6)
    p[:, 0], p[:, 1] = np.linspace(-1, 1, 6), np.linspace(2, 0, 6)
    height = lambda q: 0.5 * q[:, 0] + 0.25 * q[:, 1]
    calls = []

    def heights(q, fx, fy):
        calls.append(len(q))
        return height(q)

    out = height_normal_map(heights, height(p), p, dx, dy, n, 2.0)
    assert calls == [12]  # two points a sample, once
    expect = np.array([-1.0, -0.5, 1.0]) / np.sqrt(2.25)  # n - 2 grad h, in the frame T = +x, B = +y
    assert np.allclose(out, 0.5 + 0.5 * expect, rtol=0, atol=1e-9)  # float64 round-off over a 1e-3 step: measured 4e-12
    shifted = height(np.concatenate([p + 0.5 * dx, p + 0.5 * dy]))
    np.testing.assert_allclose(native_height_normals(height(p), shifted, dx, dy, n, 2.0), out, rtol=0, atol=1e-15)


def test_the_compiled_height_normals_are_the_reference_everywhere():
    # random edges, normals, frames and details: the kernel against bump.height_normal_map
    from texbake.maps.bump import height_normal_map

    rng = np.random.default_rng(5)
    k = 500
    p, dx, dy = rng.normal(size=(k, 3)), rng.normal(size=(k, 3)) * 1e-3, rng.normal(size=(k, 3)) * 1e-3
    dy[:5] = 2 * dx[:5]  # degenerate edges: no gradient
    n = rng.normal(size=(k, 3))
    t = np.cross(n, rng.normal(size=(k, 3)))
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    unit_n = n / np.linalg.norm(n, axis=1, keepdims=True)
    tangent_frame = np.stack([t, np.cross(unit_n, t), unit_n], axis=1)
    detail = rng.uniform(0.2, 1.0, (k, 3))
    height = lambda q: np.sin(3 * q[:, 0]) * np.cos(2 * q[:, 1]) + q[:, 2] ** 2
    shifted = height(np.concatenate([p + 0.5 * dx, p + 0.5 * dy]))
    for kwargs in ({}, {"frame": tangent_frame}, {"detail": detail}, {"frame": tangent_frame, "detail": detail}):
        ref = height_normal_map(lambda q, fx, fy: height(q), height(p), p, dx, dy, n, 0.3, **kwargs)
        got = native_height_normals(height(p), shifted, dx, dy, n, 0.3, **kwargs)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)  # the same operations in another order
        flipped = native_height_normals(height(p), shifted, dx, dy, n, 0.3, directx=True, **kwargs)
        np.testing.assert_array_equal(flipped[:, [0, 2]], got[:, [0, 2]])
        np.testing.assert_allclose(flipped[:, 1], 1.0 - got[:, 1], rtol=0, atol=2e-16)
