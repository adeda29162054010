"""A mesh's own UV layout: kept in UDIM tiles, its islands packed anew shape for shape
(out of the tile, or overlapping only by where they lie), or, repeating a tiling texture,
unwrapped with a warning."""

import numpy as np
import pytest
from conftest import udim_boxes

from texbake.atlas import make_atlas, udim_tiles
from texbake.atlas.uvcheck import chart_labels, coverage_counts, folded_faces, island_overlap, overlap_of
from texbake.errors import AtlasError
from texbake.mesh import load_mesh


def quads(n: int, uv_of) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` unit squares side by side on z = 0 (two triangles each, vertices their own),
    square ``k``'s corner UVs ``uv_of(k)`` (4, 2)."""
    v, f, uv = [], [], []
    for k in range(n):
        v += [[2 * k, 0, 0], [2 * k + 1, 0, 0], [2 * k + 1, 1, 0], [2 * k, 1, 0]]
        f += [[4 * k, 4 * k + 1, 4 * k + 2], [4 * k, 4 * k + 2, 4 * k + 3]]
        uv += list(uv_of(k))
    return np.array(v, dtype=np.float64), np.array(f), np.array(uv, dtype=np.float64)


def test_a_udim_layout_is_kept_tile_by_tile(tmp_path):
    udim_boxes(tmp_path / "boxes.obj")
    m = load_mesh(tmp_path / "boxes.obj")
    a = make_atlas(m.vertices, m.faces, m.uv, size=256)
    assert a.method == "kept" and a.udim and a.stats["tiles"] == [1001, 1002, 1003, 1004], a.reason
    assert np.array_equal(a.uv[a.faces], m.uv[m.faces]) and a.stats["overlap"] == 0 and a.warnings == []
    assert "4 UDIM tiles (1001, 1002, 1003, 1004)" in a.reason
    assert make_atlas(m.vertices, m.faces, m.uv, size=256, mode="keep").udim


def test_udim_tiles_are_integer_tiles_each_island_in_one():
    _, f, uv = quads(2, lambda k: [[k + 0.1, 0.1], [k + 0.9, 0.1], [k + 0.9, 0.9], [k + 0.1, 0.9]])
    assert udim_tiles(uv, f).tolist() == [1001, 1001, 1002, 1002]
    assert udim_tiles(uv + [0, 1], f).tolist() == [1011, 1011, 1012, 1012]
    assert udim_tiles(uv - [0.5, 0], f) is None  # a face across the tiles' border
    assert udim_tiles(uv - [0, 1], f) is None and udim_tiles(uv + [9, 0], f) is None  # below v = 0, right of u = 10
    one = np.array([[0.5, 0.1], [1.0, 0.1], [1.0, 0.9], [0.5, 0.9], [1.5, 0.1], [1.5, 0.9]])
    across = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])  # one island, its faces in two tiles
    assert udim_tiles(one, across) is None
    for bad in (np.nan, np.inf, -np.inf):  # a corner that is not a number has no tile
        broken = uv.copy()
        broken[f[3, 1]] = bad
        assert udim_tiles(broken, f) is None


def test_islands_overlapping_by_where_they_lie_are_packed_anew_shape_for_shape():
    """Three squares on one UV layout (as two parts sharing their UVs): each island comes
    back the same shape at one scale for all, moved and perhaps turned, none overlapping."""
    layout = np.array([[0.1, 0.1], [0.6, 0.1], [0.6, 0.4], [0.1, 0.4]])
    v, f, uv = quads(3, lambda k: layout * (1.0 if k < 2 else 0.5))
    a = make_atlas(v, f, uv, size=256)
    assert a.method == "repacked" and a.stats["islands"] == 3, a.reason
    assert "overlap" in a.warnings[0] and "shape for shape" in a.warnings[0]
    assert overlap_of(coverage_counts(a.uv, a.faces, 256))[0] == 0
    scales = []
    for k in range(3):  # the affine map from the old corners to the new is a similarity
        old, new = uv[f[2 * k : 2 * k + 2]].reshape(-1, 2), a.uv[a.faces[2 * k : 2 * k + 2]].reshape(-1, 2)
        fit, *_ = np.linalg.lstsq(np.column_stack([old, np.ones(len(old))]), new, rcond=None)
        assert np.abs(np.column_stack([old, np.ones(len(old))]) @ fit - new).max() < 1e-5
        singular = np.linalg.svd(fit[:2], compute_uv=False)
        # xatlas' UVs are the atlas' texels over its width and height: an axis may come back
        # scaled a texel in the tile's size more than the other (0.5 % at 256)
        assert singular[0] == pytest.approx(singular[1], rel=0.01)  # no shear, no stretch beyond that
        scales.append(singular.mean())
    assert scales[0] == pytest.approx(scales[1], rel=0.01) and scales[2] == pytest.approx(scales[0], rel=0.01)  # sizes kept


def test_islands_outside_the_tiles_are_packed_anew():
    v, f, uv = quads(2, lambda k: [[-7.9 + k, 3.1], [-7.2 + k, 3.1], [-7.2 + k, 3.8], [-7.9 + k, 3.8]])
    a = make_atlas(v, f, uv, size=128)
    assert a.method == "repacked" and "leave the unit square" in a.reason and a.uv.min() >= 0 and a.uv.max() <= 1


def test_a_repeating_layout_is_unwrapped_and_said_so():
    v, f, uv = quads(2, lambda k: [[0, 0], [3, 0], [3, 3], [0, 3]])  # a tiling texture, three times across
    a = make_atlas(v, f, uv, size=128)
    assert a.method not in ("kept", "repacked") and "repeat a tiling texture" in a.warnings[0]
    assert a.warnings[0].startswith("the mesh's UVs were replaced by an unwrap: ")
    with pytest.raises(AtlasError, match="leave the unit square"):
        make_atlas(v, f, uv, size=128, mode="keep")


def test_faces_that_fold_over_their_island_are_charted_anew():
    """One island, a strip of four quads whose last (14 % of the surface) is folded back over
    the third: its two faces alone leave the island; the others keep their shape."""
    x, u = [0, 1, 2, 3, 3.5], [0.1, 0.3, 0.5, 0.7, 0.6]
    v = np.array([[xi, y, 0] for xi in x for y in (0, 1)], dtype=np.float64)
    uv = np.array([[ui, y] for ui in u for y in (0.1, 0.3)])
    f = np.array([face for i in range(4) for face in ([2 * i, 2 * i + 2, 2 * i + 3], [2 * i, 2 * i + 3, 2 * i + 1])])
    assert folded_faces(uv, f).tolist() == [False] * 6 + [True] * 2
    assert island_overlap(uv, f[:6], 256) == 0 and island_overlap(uv, f, 256) > 0.1
    a = make_atlas(v, f, uv, size=256)
    assert a.method == "repacked" and a.stats["charted_anew"] == 2, a.reason
    assert "2 faces that fold over their island" in a.warnings[0]
    assert overlap_of(coverage_counts(a.uv, a.faces, 256))[0] == 0
    assert len(set(chart_labels(a.faces, len(a.uv))[:6].tolist())) == 1  # the six that did not fold stay one island
