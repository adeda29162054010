import numpy as np
import pytest

from texbake.sampling.surface import SurfaceMap, vertex_normals


def test_points_normals_and_footprint_on_a_plane():
    # A 2 x 3 rectangle in the plane z = 5 mapped onto the whole UV square.
    v = np.array([[0, 0, 5], [2, 0, 5], [2, 3, 5], [0, 3, 5]], float)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    sm = SurfaceMap(v, f, uv, f, width=64, height=32, normals=True)
    b = np.array([[0.2, 0.3, 0.5], [1 / 3, 1 / 3, 1 / 3]])
    s = sm.samples(np.array([0, 1]), b)
    assert np.allclose(s.points, np.einsum("ni,nij->nj", b, v[f[[0, 1]]]), atol=1e-15)
    assert np.allclose(s.normals, [[0, 0, 1]] * 2)
    # one texel right: 2 / 64 in x; one texel down: -3 / 32 in y
    assert np.allclose(s.dpdx, [[2 / 64, 0, 0]] * 2)
    assert np.allclose(s.dpdy, [[0, -3 / 32, 0]] * 2)
    bare = sm.samples(np.array([0, 1]), b, footprints=False)  # a point-sampled bake needs none
    assert bare.dpdx is None and bare.dpdy is None
    np.testing.assert_array_equal(bare.points, s.points)
    np.testing.assert_array_equal(bare.normals, s.normals)


def test_degenerate_uv_face_gives_finite_zero_footprint():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    uv = np.array([[0.5, 0.5], [0.5, 0.5], [0.5, 0.5]])
    f = np.array([[0, 1, 2]])
    s = SurfaceMap(v, f, uv, f, 16, 16).samples(np.array([0]), np.array([[1.0, 0, 0]]))
    assert np.isfinite(s.dpdx).all() and np.isfinite(s.dpdy).all()
    assert not s.dpdx.any() and not s.dpdy.any()


def test_vertex_normals_are_shared_across_seams():
    # the same corner twice (split at a UV seam) gets one normal
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0]], float)
    f = np.array([[0, 1, 2], [4, 3, 1]])
    n = vertex_normals(v, f)
    assert np.allclose(n[0], n[4]) and np.allclose(np.linalg.norm(n, axis=1), 1)


def test_angle_weighted_normals_weigh_each_face_by_its_corner_angle():
    # a vertex at the origin with two faces: one in the plane z = 0 with a 90° corner there and a
    # large area, one in the plane x = 0 with a narrow corner (about 11°) and a small area
    v = np.array([[0, 0, 0], [4, 0, 0], [0, 4, 0], [0, 0.2, 1], [0, 0, 1]], float)
    f = np.array([[0, 1, 2], [0, 3, 4]])
    up, side = np.array([0, 0, 1.0]), np.array([1.0, 0, 0])  # the faces' unit normals (side: (0,.2,1)x(0,0,1) is +x)
    narrow = np.arctan2(0.2, 1.0)  # the angle between (0, 0.2, 1) and (0, 0, 1)
    want = (np.pi / 2 * up + narrow * side) / np.linalg.norm(np.pi / 2 * up + narrow * side)
    assert np.allclose(vertex_normals(v, f, weights="angle")[0], want, atol=1e-14)
    by_area = (8 * up + 0.1 * side) / np.linalg.norm(8 * up + 0.1 * side)  # twice the areas: 16 and 0.2
    assert np.allclose(vertex_normals(v, f)[0], by_area, atol=1e-14) and not np.allclose(by_area, want, atol=1e-2)
    with pytest.raises(ValueError, match="weights"):
        vertex_normals(v, f, weights="uniform")


def test_the_compiled_angle_weights_are_the_numpy_formula_with_seams_and_zero_area_faces():
    rng = np.random.default_rng(5)
    v = rng.normal(size=(60, 3))
    v[50:] = v[:10]  # ten positions twice (a seam): one normal each
    f = rng.integers(0, 60, size=(200, 3))
    f[:5, 2] = f[:5, 1]  # zero-area faces add nothing
    key = np.unique(v, axis=0, return_inverse=True)[1].ravel()
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    twice = np.linalg.norm(cross, axis=1)
    unit = np.divide(cross, twice[:, None], out=np.zeros_like(cross), where=twice[:, None] > 0)
    acc = np.zeros((key.max() + 1, 3))
    for c in range(3):
        angle = np.arctan2(twice, np.einsum("ij,ij->i", tri[:, (c + 1) % 3] - tri[:, c], tri[:, (c + 2) % 3] - tri[:, c]))
        np.add.at(acc, key[f[:, c]], unit * angle[:, None])
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    want = np.divide(acc, length, out=np.zeros_like(acc), where=length > 0)[key]
    got = vertex_normals(v, f, weights="angle")
    assert np.abs(got - want).max() < 1e-13
    assert np.array_equal(got[50:], got[:10]) and (np.linalg.norm(got, axis=1) > 0.99).sum() >= 50


def test_the_compiled_frames_are_the_tangents_modules_reference():
    # random corner normals and tangents, some faces with a zero normal or a zero tangent (then
    # any vector orthogonal to the normal), mirrored w: the kernel against sample_frames (a
    # tangent along the normal is left out: what rounding leaves of it is noise in either)
    from texbake import _native
    from texbake.mesh.tangents import sample_frames

    rng = np.random.default_rng(11)
    m, n = 40, 400
    normals = rng.normal(size=(m, 3, 3))
    tangents = np.concatenate([rng.normal(size=(m, 3, 3)), rng.choice([-1.0, 1.0], (m, 3, 1))], axis=2)
    tangents[:5, :, :3] = 0.0
    normals[5:7] = 0.0
    face = rng.integers(0, m, n)
    bary = rng.dirichlet([1, 1, 1], n)
    out = np.empty((n, 3, 3))
    _native.sample_frames(face, bary, normals, tangents, out)
    np.testing.assert_allclose(out, sample_frames(normals[face], tangents[face], bary), rtol=0, atol=1e-14)
