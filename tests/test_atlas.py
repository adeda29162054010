"""UV atlas: reuse, unwrap, xatlas' hangs and crashes, and the parallel patch unwrap."""

import time

import numpy as np
import pytest
import trimesh

from bake import atlas as atlas_module
from bake.atlas import atlas_stats, make_atlas, uv_problem
from bake.errors import AtlasError, ParameterError
from bake.load import load_mesh


def check_atlas(a, vertices, faces):
    """Invariants of every atlas: same faces, UVs in the unit square, no lost face."""
    assert a.faces.shape == faces.shape
    assert np.array_equal(vertices[a.vmapping][a.faces], vertices[faces])
    assert np.isfinite(a.uv).all() and a.uv.min() >= -1e-6 and a.uv.max() <= 1 + 1e-6
    assert a.stats["zero_area_faces"] <= max(1, len(faces) // 1000)
    assert 0 < a.stats["utilisation"] <= 1


def no_overlap(a):
    """Fraction of 4000 random UV points inside more than one UV triangle (should be ~0)."""

    rng = np.random.default_rng(0)
    q = rng.random((4000, 2))
    t = a.uv[a.faces]
    inside = np.zeros(len(q), int)
    for tri in np.array_split(np.arange(len(t)), max(1, len(t) // 500)):
        tt = t[tri]
        a0, b0, c0 = tt[:, 0], tt[:, 1], tt[:, 2]
        def side(p, x, y):
            return (y[:, 0] - x[:, 0]) * (p[:, None, 1] - x[:, 1]) - (y[:, 1] - x[:, 1]) * (p[:, None, 0] - x[:, 0])
        s1, s2, s3 = side(q, a0, b0), side(q, b0, c0), side(q, c0, a0)
        inside += (((s1 > 0) & (s2 > 0) & (s3 > 0)) | ((s1 < 0) & (s2 < 0) & (s3 < 0))).sum(axis=1)
    return (inside > 1).mean()


def test_uv_problem():
    f = np.array([[0, 1, 2]])
    assert uv_problem(np.array([[0, 0], [1, 0], [0, 1.0]]), f) is None
    assert "no UVs" in uv_problem(None, f)
    assert "not finite" in uv_problem(np.array([[0, 0], [1, 0], [0, np.nan]]), f)
    assert "unit square" in uv_problem(np.array([[0, 0], [2, 0], [0, 1.0]]), f)
    assert "zero UV area" in uv_problem(np.array([[0, 0], [1, 1], [0.5, 0.5]]), f)


def test_auto_keeps_usable_uvs(meshes):
    m = load_mesh(meshes / "Duck.glb")
    a = make_atlas(m.vertices, m.faces, m.uv)
    assert a.method == "kept" and np.array_equal(a.uv, m.uv) and np.array_equal(a.faces, m.faces)


def test_keep_without_uvs_is_an_error(meshes):
    m = load_mesh(meshes / "fandisk.obj")
    with pytest.raises(AtlasError, match="no UVs"):
        make_atlas(m.vertices, m.faces, None, mode="keep")
    with pytest.raises(ParameterError, match="uv"):
        make_atlas(m.vertices, m.faces, None, mode="sometimes")


def test_unwrap_a_mesh_without_uvs(meshes):
    m = load_mesh(meshes / "fandisk.obj")
    a = make_atlas(m.vertices, m.faces, None, size=512)
    assert a.method.startswith("xatlas") and "no UVs" in a.reason
    check_atlas(a, m.vertices, m.faces)
    assert a.stats["charts"] > 1 and 0.4 < a.stats["utilisation"] and a.stats["stretch"] < 1.2
    assert no_overlap(a) < 1e-3


@pytest.mark.parametrize("scale, offset", [(1e-6, 0.0), (1.0, 1e8), (1e6, 0.0)])
def test_tiny_huge_and_far_meshes(scale, offset):
    s = trimesh.creation.icosphere(3)
    v = s.vertices * scale + offset
    a = make_atlas(v, s.faces, mode="unwrap", size=256)
    assert a.method == "xatlas", a.reason
    check_atlas(a, v, s.faces)


def test_one_degenerate_triangle():
    s = trimesh.creation.icosphere(2)
    v = s.vertices.copy()
    v[s.faces[0, 1]] = v[s.faces[0, 0]]  # collapses one triangle (and bends its neighbours)
    a = make_atlas(v, s.faces, mode="unwrap", size=256)
    assert np.isfinite(a.uv).all() and a.faces.shape == s.faces.shape
    assert a.uv.min() >= 0 and a.uv.max() <= 1


def test_hang_is_stopped_at_the_deadline():
    # Without normalisation, an infinite vertex makes xatlas loop forever.
    s = trimesh.creation.icosphere(2)
    v = s.vertices.astype(np.float32)
    v[0] = np.inf
    start = time.monotonic()
    with pytest.raises(atlas_module._XatlasFailed, match="deadline"):
        atlas_module._run_children(atlas_module._chart_patches, [(v, [s.faces.astype(np.uint32)], 256, 2)], 3.0)
    assert time.monotonic() - start < 10


def test_crash_falls_back_to_a_grid_atlas():
    # xatlas segfaults packing icosphere(6) in one piece; the bake must go on.
    s = trimesh.creation.icosphere(6)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=1024, patch_faces=None)
    assert a.method == "fallback-grid" and "crashed" in a.reason
    check_atlas(a, s.vertices, s.faces)
    assert a.stats["charts"] == len(s.faces)


def test_patch_unwrap_of_the_crashing_mesh():
    s = trimesh.creation.icosphere(6)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=1024)
    assert a.method == "xatlas-patches", a.reason
    check_atlas(a, s.vertices, s.faces)
    assert a.stats["utilisation"] > 0.5 and a.stats["stretch"] < 1.2
    assert no_overlap(a) < 1e-3


def test_stats_of_an_isometric_layout():
    v = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0, 0], [0.5, 0], [0.5, 0.5], [0, 0.5]])
    s = atlas_stats(v, f, f, uv)
    assert s["charts"] == 1 and abs(s["utilisation"] - 0.25) < 1e-12 and abs(s["stretch"] - 1) < 1e-12
    s = atlas_stats(v, f, f, uv * [1, 0.5])  # squashed: stretch > 1
    assert s["stretch"] > 1.05
