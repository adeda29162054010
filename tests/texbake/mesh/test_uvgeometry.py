"""texbake.mesh.uvgeometry (compiled: native/geometry.cpp) against the numpy expressions its
docstrings give: the same bits (no FMA, numpy's order of operations)."""

import numpy as np
import pytest

from texbake.mesh import uvgeometry


def _mesh(seed: int, n: int = 500, m: int = 3000):
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-3, 4, (n, 1))
    uv = rng.random((n, 2))
    faces = rng.integers(0, n, (m, 3))
    uv[faces[::17, 1]] = uv[faces[::17, 0]]  # UV-degenerate faces
    faces[::23, 2] = faces[::23, 1]  # degenerate ones
    uv[::97] = np.nan  # and UVs that are not numbers
    return vertices, faces, uv


def _same(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_passes_give_numpys_bits(seed):
    vertices, faces, uv = _mesh(seed)
    tri = vertices[faces]
    p0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    assert all(_same(a, b) for a, b in zip(uvgeometry.edges(vertices, faces), (p0, e1, e2), strict=True))
    assert _same(uvgeometry.areas(vertices, faces), 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1))
    t = uv[faces]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    assert _same(uvgeometry.uv_dets(uv, faces), det)
    assert _same(uvgeometry.uv_areas(uv, faces), 0.5 * np.abs(det))
    ok = np.abs(det) > 0
    r = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    inv = np.stack([np.stack([d2[:, 1], -d2[:, 0]], axis=1) * r[:, None], np.stack([-d1[:, 1], d1[:, 0]], axis=1) * r[:, None]], axis=1)
    t0, inv_c, ok_c = uvgeometry.uv_inverse(uv, faces)
    assert _same(t0, t[:, 0]) and _same(inv_c, inv) and _same(ok_c, ok)
    dpdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r[:, None]
    dpdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r[:, None]
    assert all(_same(a, b) for a, b in zip(uvgeometry.uv_jacobian(vertices, faces, uv, faces), (dpdu, dpdv, det), strict=True))
    assert np.isnan(det).any() and (~ok).sum() > 100  # the odd faces were there


def test_a_face_index_out_of_range_is_an_index_error():
    vertices, faces, _ = _mesh(3, n=10, m=5)
    faces[2, 1] = 10
    with pytest.raises(IndexError, match="face index 10 outside"):
        uvgeometry.areas(vertices, faces)
