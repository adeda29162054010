"""UVs kept in part (texbake.atlas.parts through make_atlas): a scene whose crate has UVs
and whose ball has none keeps the crate's layout, in place when the tile has room beside
it, else moved and scaled as one piece, and packs the ball's charts beside it."""

import numpy as np
import pytest
from conftest import mixed_uv_scene

from texbake.atlas import make_atlas
from texbake.atlas.uvcheck import overlap, unwrap_problem
from texbake.errors import AtlasError
from texbake.mesh import load_mesh, uv_areas


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    """The scene with the crate's layout over the whole tile (``full``) and in its lower
    left quarter (``corner``), loaded."""
    folder = tmp_path_factory.mktemp("scenes")
    mixed_uv_scene(folder / "full.glb", 1.0)
    mixed_uv_scene(folder / "corner.glb", 0.5)
    return {name: load_mesh(folder / f"{name}.glb") for name in ("full", "corner")}


def atlas_of(m, mode="auto", size=512, uv=None):
    return make_atlas(m.vertices, m.faces, m.uv if uv is None else uv, mode=mode, size=size, has_uv=m.has_uv, part=m.part,
                      part_names=m.part_names)


def similarity(src, dst):
    """The affine map from ``src`` to ``dst`` (k, 2) by least squares, its largest error,
    and its 2 x 2 part's singular values."""
    x = np.column_stack([src, np.ones(len(src))])
    fit, *_ = np.linalg.lstsq(x, dst, rcond=None)
    return np.abs(x @ fit - dst).max(), np.linalg.svd(fit[:2], compute_uv=False)


def check(a, m):
    """An atlas of the whole mesh: its faces, in the unit square, no face of zero UV area,
    the kept faces and the new charts not on one texel."""
    assert unwrap_problem(a.vmapping, a.faces, a.uv, m.faces, len(m.vertices)) is None
    assert overlap(a.uv, a.faces, 512)[0] == 0.0


@pytest.mark.parametrize("mode", ["auto", "keep"])
def test_a_layout_with_room_beside_it_is_kept_in_place(scenes, mode):
    m = scenes["corner"]
    a = atlas_of(m, mode)
    check(a, m)
    assert a.method.startswith("kept+") and a.stats["kept_scale"] == 1.0, a.reason
    assert np.array_equal(a.uv[a.faces[m.has_uv]], m.uv[m.faces[m.has_uv]])  # to the bit
    ball, crate = a.uv[a.faces[~m.has_uv]].reshape(-1, 2), m.uv[m.faces[m.has_uv]].reshape(-1, 2)
    assert (ball.min(axis=0) > crate.max(axis=0) + 2 / 512).any()  # in a strip beside the crate's layout, a padding away
    assert a.warnings[0] == ("unwrapped: part 'ball' (320 faces) has no UVs; the UVs of the other parts kept in place; "
                             "the other parts' charts packed beside them")


def test_a_layout_over_the_whole_tile_moves_and_scales_as_one_piece(scenes):
    m = scenes["full"]
    a = atlas_of(m)
    check(a, m)
    src, dst = m.uv[m.faces[m.has_uv]].reshape(-1, 2), a.uv[a.faces[m.has_uv]].reshape(-1, 2)
    error, singular = similarity(src, dst)
    assert error < 1e-6  # every island where the layout's one map puts it
    assert 0.3 < singular.min() and singular.max() / singular.min() < 1.01  # scaled evenly: shapes kept
    assert a.stats["kept_scale"] == pytest.approx(float(np.sqrt(singular.prod())), rel=1e-6) and a.stats["kept_scale"] < 1
    assert "moved as one piece" in a.warnings[0] and "'ball'" in a.warnings[0]
    # one texel density: the crate's texels per surface area within 25 % of the ball's
    kept, new = m.has_uv, ~m.has_uv
    from texbake.mesh import areas
    density = [uv_areas(a.uv, a.faces[s]).sum() / areas(m.vertices, m.faces[s]).sum() for s in (kept, new)]
    assert 0.75 < density[0] / density[1] < 1.25, density


def test_unusable_kept_uvs_are_replaced_in_auto_and_refused_by_keep(scenes):
    m = scenes["full"]
    uv = m.uv.copy()
    uv[np.unique(m.faces[m.has_uv])] *= 3.0  # the crate's layout leaves the tile
    a = atlas_of(m, size=256, uv=uv)
    assert not a.method.startswith("kept")
    assert a.warnings[0] == ("the mesh's UVs were replaced by an unwrap: part 'ball' (320 faces) has no UVs; "  # the largest first
                             "part 'crate' (12 faces): its UVs leave the unit square (range 0 to 2.91)")
    with pytest.raises(AtlasError, match=r"uv='keep' but part 'crate' \(12 faces\): its UVs leave the unit square"):
        atlas_of(m, "keep", 256, uv)


def test_unwrap_unwraps_every_part(scenes):
    m = scenes["corner"]
    a = atlas_of(m, "unwrap", 256)
    assert not a.method.startswith("kept") and a.warnings == []
    assert not np.array_equal(a.uv[a.faces[m.has_uv]], m.uv[m.faces[m.has_uv]])


def test_a_mask_of_the_wrong_shape_is_refused(scenes):
    m = scenes["corner"]
    with pytest.raises(AtlasError, match="has_uv of shape"):
        make_atlas(m.vertices, m.faces, m.uv, has_uv=m.has_uv[:-1])


def test_of_two_parts_sharing_one_layout_each_keeps_its_islands(tmp_path):
    """Two crates with the same UVs (a layout two parts share, as wheels do): "auto" packs
    both crates' islands anew, shape for shape (they overlap only by where they lie); where
    that cannot be, the first keeps the layout and the second is unwrapped; "keep" keeps
    both, warning of the overlap."""
    import trimesh

    mixed_uv_scene(tmp_path / "one.glb", 0.5)
    crate = trimesh.load(tmp_path / "one.glb").geometry["crate"]
    scene = trimesh.Scene()
    scene.add_geometry(crate, node_name="left", geom_name="left")
    scene.add_geometry(crate.copy().apply_translation((2, 0, 0)), node_name="right", geom_name="right")
    scene.export(tmp_path / "two.glb")
    m = load_mesh(tmp_path / "two.glb")
    assert m.has_uv is None and sorted(m.part_names) == ["left", "right"]
    a = atlas_of(m)
    assert a.method == "repacked" and a.stats["islands"] == 24 and "shape for shape" in a.warnings[0], a.reason
    check(a, m)
    from texbake.atlas import decide

    a = decide._keep_parts(decide.UnwrapRequest(m.vertices, m.faces, 512, 2), m.uv, None, m.part, m.part_names, mode="auto",
                           deadline=60.0, workers=2, charting="auto", patch_faces=None, start=0.0)[0]
    first = m.part == 0  # of parts of one size, the first in the file keeps the layout
    assert a.method.startswith("kept+") and np.array_equal(a.uv[a.faces[first]], m.uv[m.faces[first]])
    assert a.warnings[0].startswith(f"unwrapped: part {m.part_names[1]!r} (12 faces): 100.0% of its UVs' texels lie under two "
                                    "of its faces or under a part kept before it; the UVs of the other parts kept in place")
    check(a, m)
    both = atlas_of(m, "keep")
    assert both.method == "kept" and "overlap" in both.warnings[0]
