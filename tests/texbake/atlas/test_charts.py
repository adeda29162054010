"""Planar charts (texbake/atlas/charts.py) and the atlases made of them on CAD-like meshes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from conftest import MESHES

from texbake.atlas import atlas_stats, charts, make_atlas, overlap
from texbake.atlas.charts import ANGLE_LIMIT, Sides, density_spread, directions, planar_charts, prefer_planar
from texbake.checks.cad import fan_cylinder, holed_plate
from texbake.mesh.load import load_mesh
from texbake.mesh.uvgeometry import uv_areas


def unit_normals(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_directions_cover_every_normal_within_the_limit():
    rng = np.random.default_rng(3)
    normals = unit_normals(rng, 5000)
    d = directions(normals, rng.random(5000))
    assert np.allclose(np.linalg.norm(d, axis=1), 1)
    assert (np.max(normals @ d.T, axis=1) > np.cos(np.radians(ANGLE_LIMIT))).all()
    assert len(d) < 40  # a covering, not a direction a face
    # a cube's six faces: six directions, the axes
    box = trimesh.creation.box()
    cube = planar_charts(box.vertices, box.faces)
    assert len(cube.directions) == 6 and np.allclose(np.abs(cube.directions).max(axis=1), 1)
    assert cube.labels.max() + 1 == 6 and cube.flat == 1.0


def test_a_flat_region_is_one_chart_without_stretch_however_it_is_cut():
    # a plate's faces are fans of slivers (up to 64 a fan): each side is one chart, isometric
    v, f = holed_plate(cells=(2, 2), segments=256, offset=0.0)
    c = planar_charts(v, f)
    assert np.array_equal(c.vmapping[c.faces], f)
    assert c.labels.max() + 1 == 2 + 4 + 4 * 4  # top, bottom, 4 outer walls, 4 hole walls in 4 pieces each
    top = np.abs(v[f][:, :, 2] - 6).max(axis=1) < 1e-9
    s = atlas_stats(v, f[top], c.faces[top], c.uv)
    assert s["charts"] == 1 and abs(s["stretch"] - 1) < 1e-12
    assert abs(uv_areas(c.uv, c.faces[top]).sum() - trimesh.Trimesh(v, f[top], process=False).area) < 1e-9


def strip(length: float, width: float, nx: int, ny: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat ``length`` x ``width`` rectangle at z = 0 of ``nx`` x ``ny`` quads, two triangles each."""
    x, y = np.meshgrid(np.linspace(0, length, nx + 1), np.linspace(0, width, ny + 1), indexing="ij")
    v = np.stack([x, y, np.zeros_like(x)], axis=-1).reshape(-1, 3)
    idx = np.arange(len(v)).reshape(x.shape)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    return v, np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])


def test_a_long_strip_is_cut_straight_across_its_length_into_pieces_that_fill_the_tile(monkeypatch):
    # 30 x 4 in quads of a quarter: the tile is sqrt(2 x 120) = 15.5 across at half filled, the
    # strip twice that: cut into pieces of at most 7.75, four of 7.5, between two rows of quads
    v, f = strip(30.0, 4.0, 120, 16)
    c = planar_charts(v, f)
    assert np.array_equal(c.vmapping[c.faces], f)
    assert c.labels.max() + 1 == 4
    spans = sorted((float(x.min()), float(x.max())) for x in (v[f[c.labels == k]][:, :, 0] for k in range(4)))
    assert spans == [(0.0, 7.5), (7.5, 15.0), (15.0, 22.5), (22.5, 30.0)]
    cut = make_atlas(v, f, mode="unwrap", size=256, charting="planar").stats["utilisation"]
    monkeypatch.setattr(charts, "LONG_SHARE", np.inf)
    assert planar_charts(v, f).labels.max() + 1 == 1
    whole = make_atlas(v, f, mode="unwrap", size=256, charting="planar").stats["utilisation"]
    assert whole < 0.2 and cut > 0.6  # a 7.5:1 strip alone in a square tile, and the four pieces stacked


@pytest.mark.parametrize("quads, why", [((1, 1), "two triangles across the whole strip"),
                                        ((8, 1), "faces half a piece long: the pieces would be combs"),
                                        ((32, 32), "as wide as long: not a strip")])
def test_a_chart_that_cannot_be_cut_cleanly_or_need_not_be_stays_whole(quads, why):
    v, f = strip(30.0, 4.0, *quads) if quads != (32, 32) else strip(8.0, 8.0, *quads)
    assert planar_charts(v, f).labels.max() + 1 == 1, why


def test_a_ramp_that_winds_over_itself_is_cut_until_it_does_not_overlap():
    # a helicoid of 1.5 turns, gently climbing: every normal within 10 degrees of +z, so one
    # direction; projected along z its second half lies on its first
    r, t = np.meshgrid(np.linspace(1, 2, 5), np.linspace(0, 3 * np.pi, 200), indexing="ij")
    v = np.stack([r * np.cos(t), r * np.sin(t), 0.1 * t], axis=-1).reshape(-1, 3)
    idx = np.arange(v.shape[0]).reshape(r.shape)
    a, b, c_, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f = np.concatenate([np.stack([a, b, c_], -1).reshape(-1, 3), np.stack([a, c_, d], -1).reshape(-1, 3)])
    c = planar_charts(v, f)
    # cut, and the pieces that need not be apart joined again: 1.5 turns are two charts
    # (bisection alone leaves three)
    assert len(c.directions) >= 2 and c.labels.max() + 1 == 2
    lo, hi = c.uv.min(axis=0), c.uv.max(axis=0)
    assert overlap((c.uv - lo) / (hi - lo).max(), c.faces, 1024) == (0.0, 1)


def test_a_part_cut_for_overlap_keeps_no_more_charts_than_it_needs():
    # featuretype.STL: bisection cut it into 146 charts, its pieces joined again make 103
    # (Smart UV: 124); each chart still lies flat without overlapping itself
    m = load_mesh(MESHES / "featuretype.STL")
    c = planar_charts(m.vertices, m.faces)
    assert c.labels.max() + 1 <= 110
    lo, hi = c.uv.min(axis=0), c.uv.max(axis=0)
    assert overlap((c.uv - lo) / (hi - lo).max(), c.faces, 1024)[0] == 0.0


def _merge_reference(vertices, faces, pairs, island, group, planes, scale, grid):
    """The cut pieces' merge as it was in Python before native/uvcheck.cpp's merged_islands:
    a pair at a time, each union projected, scaled to texels and rasterised anew."""
    from texbake.atlas.charts import MERGE_WORK
    from texbake.atlas.uvcheck import overlapping_faces
    from texbake.mesh import DisjointSets

    dirs, bases = planes
    a, b = pairs
    same = (island[a] != island[b]) & (dirs[group[a]] == dirs[group[b]]).all(axis=1)
    pairs = np.unique(np.sort(np.column_stack([island[a][same], island[b][same]]), axis=1), axis=0)
    n = int(island.max()) + 1
    order = np.argsort(island, kind="stable")
    members = dict(enumerate(np.split(order, np.searchsorted(island[order], np.arange(1, n)))))
    direction = np.zeros(n, dtype=np.int64)
    direction[island] = group
    count = np.bincount(island, minlength=n)
    sets = DisjointSets(n)
    budget = MERGE_WORK * len(faces)
    for x, y in pairs[np.argsort(count[pairs].sum(axis=1), kind="stable")]:
        rx, ry = sets.find(int(x)), sets.find(int(y))
        union = np.concatenate([members[rx], members[ry]])
        if rx == ry or len(union) > budget:
            continue
        budget -= len(union)
        p = vertices[faces[union]].reshape(-1, 3) @ bases[direction[rx]].T
        p = (p - p.min(axis=0)) * (grid / scale)
        side = int(np.ceil(p.max())) + 2
        if overlapping_faces(p / side, np.arange(len(p)).reshape(-1, 3), side).any():
            continue
        members[sets.join(rx, ry)] = union
    return sets.labels()[island]


@pytest.mark.parametrize("name", ["featuretype.STL", "fandisk.obj", "bunny.ply"])
def test_the_native_merge_of_cut_pieces_joins_what_the_python_one_joined(monkeypatch, name):
    # the same islands joined, pair for pair, as the loop it replaced (the atlas must not
    # change with the port); and some were cut and joined, so the comparison says something
    import texbake.atlas.charts as charts

    seen = []
    native = charts._merge_cuts

    def recorded(*args):
        seen.append((args, native(*args)))
        return seen[-1][1]

    monkeypatch.setattr(charts, "_merge_cuts", recorded)
    m = load_mesh(MESHES / name)
    planar_charts(m.vertices, m.faces)
    assert len(seen) == 1
    args, joined = seen[0]
    island = args[3]
    assert len(np.unique(joined)) < len(np.unique(island))  # pieces were joined
    # the reference looks only for overlaps: the native merge without its look for slits
    assert np.array_equal(native(*args[:-1], 0.0), _merge_reference(*args[:-1]))


def _slit_layout(depth: float):
    # one chart of two triangles on a line in UV, meeting at vertex 0 only: above the line
    # a top face, below it a face whose 3D points drop by ``depth`` times their distance
    # from vertex 0 (a box's side face, seen along its diagonal, for depth 1)
    uv = np.array([[0.0, 0], [10, 0], [0, 10], [10, 0], [0, -10]])
    points = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [10, 0, -10 * depth], [0, -10, -10 * depth]])
    faces = np.array([[0, 1, 2], [0, 4, 3]])
    return uv, points, faces


def test_a_slit_is_two_border_stretches_on_each_other_over_places_far_apart():
    from texbake import _native

    for depth, expected in ((1.0, [True, True]), (0.0, [False, False]), (0.1, [False, False])):
        uv, points, faces = _slit_layout(depth)
        flags = np.zeros(2, dtype=bool)
        _native.slit_faces(uv, points, faces, np.zeros(2, dtype=np.int64), 1.0, flags)
        # depth 0: a flat chart; 0.1: the stretch a slope gives (10 units at most 1 apart)
        assert flags.tolist() == expected, depth
    uv, points, faces = _slit_layout(1.0)
    flags = np.zeros(2, dtype=bool)
    _native.slit_faces(uv, points, faces, np.array([0, 1]), 1.0, flags)  # two charts: no slit
    assert not flags.any()
    _native.slit_faces(uv, points, faces, np.array([-1, -1]), 1.0, flags)  # charts not looked at
    assert not flags.any()
    # a lower face of its own vertices, 3 units below the line and 100 down: a slit 3 wide
    uv = np.array([[0.0, 0], [10, 0], [0, 10], [0, -3], [10, -3], [0, -13]])
    points = np.concatenate([points[:3], uv[3:] @ np.eye(2, 3) + [0, 0, -100]])
    faces = np.array([[0, 1, 2], [3, 5, 4]])
    _native.slit_faces(uv, points, faces, np.zeros(2, dtype=np.int64), 1.0, flags)  # narrower than r = 1
    assert not flags.any()
    _native.slit_faces(uv, points, faces, np.zeros(2, dtype=np.int64), 4.0, flags)
    assert flags.all()


def test_no_planar_chart_has_a_slit(monkeypatch):
    # featuretype.STL: a chart bent over a box's edge put a top face and a side face that meet
    # at one corner on the two sides of one line in UV (filtered marble at 512²: 98 % of its
    # squared error on about 100 texels there, 3.3x the RMSE of 16 point samples; 0.6x without)
    import texbake.atlas.charts as charts

    m = load_mesh(MESHES / "featuretype.STL")
    found = charts._slits
    c = planar_charts(m.vertices, m.faces)
    assert not found(m.vertices, c.vmapping, c.faces, c.uv, c.labels, 1024).any()
    assert c.labels.max() + 1 <= 110  # cut where the slits are, joined where they are not (103 before)
    monkeypatch.setattr(charts, "_slits", lambda vertices, vmapping, chart_faces, *_: np.zeros(len(chart_faces), dtype=bool))
    monkeypatch.setattr(charts, "SLIT_TEXELS", 0.0)  # nor in the joins
    blind = planar_charts(m.vertices, m.faces)
    monkeypatch.undo()
    assert found(m.vertices, blind.vmapping, blind.faces, blind.uv, blind.labels, 1024).sum() > 10


def test_auto_charting_picks_planar_for_cad_and_xatlas_for_small_organic_meshes():
    plate = holed_plate(cells=(2, 1), segments=256)
    assert prefer_planar(*plate) == (True, "CAD-like: 84% of the area on flat regions, 42% on slivers")
    sphere = trimesh.creation.icosphere(3)
    assert prefer_planar(sphere.vertices, sphere.faces) == (False, "organic: 0% of the area on flat regions, 0% on slivers")
    # flat regions by their area, however few their triangles: a building of boxes is
    # flat; Suzanne's planar quads are each far under a hundredth of her surface
    storeys = [trimesh.creation.box(extents=(10 - 2 * i, 8 - 2 * i, 3)) for i in range(4)]
    for i, b in enumerate(storeys):
        b.apply_translation((0, 0, 3 * i + 1.5))
    building = trimesh.util.concatenate(storeys)
    assert prefer_planar(building.vertices, building.faces) == (True, "CAD-like: 98% of the area on flat regions, 0% on slivers")
    suzanne = load_mesh(MESHES / "suzanne.ply")
    assert prefer_planar(suzanne.vertices, suzanne.faces) == (False, "organic: 2% of the area on flat regions, 0% on slivers")
    big = trimesh.creation.icosphere(5)
    assert prefer_planar(big.vertices, big.faces) == (True, "more than 6000 faces")


# Smart UV Project (Blender 4.5, angle limit 66, margin 0.002) on the same meshes at 1024,
# from bench/bench_unwrap.py: utilisation and density spread. The targets: utilisation
# at least 0.9x, spread no worse.
SMART_UV = {"gear": (0.57, 1.038), "plate": (0.57, 1.024), "cylinder": (0.01, 1.149)}


@pytest.mark.parametrize("name", list(SMART_UV))
def test_cad_meshes_get_a_sound_planar_atlas(name):
    if name == "gear":  # 240 teeth, two holes, far from the origin, fans of slivers
        m = load_mesh(MESHES / "gear_cad.stl")
        v, f = m.vertices, m.faces
    else:
        v, f = holed_plate() if name == "plate" else fan_cylinder()
    a = make_atlas(v, f, mode="unwrap", size=1024)
    assert a.method == "planar", a.reason
    assert a.warnings == []
    assert np.array_equal(v[a.vmapping][a.faces], v[f]) and (uv_areas(a.uv, a.faces) > 0).all()
    util, spread = SMART_UV[name]
    assert a.stats["utilisation"] >= 0.9 * util
    assert density_spread(v, f, a.uv, a.faces) <= spread
    assert a.stats["stretch"] < 1.02 and a.stats["overlap"] < 1e-4  # measured: 0 to 2e-6 (a texel), slivers


def test_the_outline_of_a_sliver_fan_is_a_few_well_shaped_triangles():
    from texbake.atlas.charts import outline_triangles

    v, f = fan_cylinder(sections=4000, offset=0.0)
    cap = f[np.abs(v[f][:, :, 2] - 120).max(axis=1) == 0]  # 3998 slivers from one rim vertex
    uv = v[:, :2]
    exact = outline_triangles(uv, cap)
    assert exact is not None and len(exact) == len(cap)  # the same disc, ear-cut
    assert abs(uv_areas(uv, exact).sum() - uv_areas(uv, cap).sum()) < 1e-9 * uv_areas(uv, cap).sum()
    coarse = outline_triangles(uv, cap, tolerance=0.01)  # a hundredth of a mm off the rim at most
    assert coarse is not None and len(coarse) < 300  # measured 254
    assert abs(uv_areas(uv, coarse).sum() / uv_areas(uv, cap).sum() - 1) < 1e-3
    # two squares touching at a corner: the border passes that vertex twice, not simple loops
    bow = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 1], [2, 2], [1, 2]], float)
    assert outline_triangles(bow, np.array([[0, 1, 2], [0, 2, 3], [2, 4, 5], [2, 5, 6]])) is None



def test_sides_pair_each_back_face_with_its_front_face():
    # faces 0-1 a quad, 2 the back of 0 (rotated), 3 the back of 1, 4 a face of its own
    faces = np.array([[0, 1, 2], [0, 2, 3], [2, 1, 0], [2, 0, 3], [1, 4, 2]])
    s = Sides.of(faces)
    assert s.front.tolist() == [0, 1, 4] and s.back.tolist() == [2, 3]
    assert s.front[s.twin].tolist() == [0, 1]
    # an atlas of the front faces, extended: each back corner at its twin's corner's UV
    vmapping, uv = np.array([0, 1, 2, 3, 4]), np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 1]], dtype=float)
    vm, f, u = s.restored(vmapping, faces[s.front], uv)
    assert np.array_equal(vm[f], faces)  # every face on its own mesh vertices, in its winding
    assert np.array_equal(u[f[2]], uv[[2, 1, 0]]) and np.array_equal(u[f[3]], uv[[2, 0, 3]])
    assert not np.isin(f[s.back], f[s.front]).any()  # the back faces' atlas vertices are their own


def test_a_double_sided_mesh_gets_one_chart_per_surface():
    # a box with every face doubled in the opposite winding: the back faces share texels
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    faces = np.concatenate([box.faces, box.faces[:, ::-1]])
    one = make_atlas(box.vertices, box.faces, mode="unwrap", size=256, charting="planar")
    two = make_atlas(box.vertices, faces, mode="unwrap", size=256, charting="planar")
    assert np.array_equal(box.vertices[two.vmapping][two.faces], box.vertices[faces])
    assert np.allclose(two.uv[two.faces[12:]], two.uv[two.faces[:12]][:, ::-1])
    assert two.stats["double_sided_faces"] == 12 and "12 back faces" in two.reason
    assert two.stats["charts"] == 6 and two.stats["utilisation"] == pytest.approx(one.stats["utilisation"], rel=0.01)


# -- the compiled loops (native/charts.cpp) against the numpy they replaced ----------


def _edge_pairs_reference(faces):
    """The numpy of texbake before native/charts.cpp: a stable argsort of the edges' keys."""
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1).astype(np.int64)
    key = e[:, 0] * (int(faces.max()) + 1) + e[:, 1]
    owner = np.repeat(np.arange(len(faces)), 3)
    order = np.argsort(key, kind="stable")
    same = key[order][1:] == key[order][:-1]
    return owner[order][:-1][same], owner[order][1:][same]


def _simplified_reference(points, tolerance):
    """Douglas-Peucker as texbake's numpy did it, the chains in a Python loop."""
    n = len(points)
    far = int(np.argmax(np.linalg.norm(points - points[0], axis=1)))
    keep = np.zeros(n, dtype=bool)
    keep[[0, far]] = True
    stack = [(0, far), (far, n)]
    while stack:
        i, j = stack.pop()
        if j - i < 2:
            continue
        a = points[i]
        inner, d = points[i + 1:j], points[j % n] - a
        length = np.hypot(*d)
        dist = (np.abs(d[0] * (inner[:, 1] - a[1]) - d[1] * (inner[:, 0] - a[0])) / length if length > 0
                else np.linalg.norm(inner - a, axis=1))
        worst = int(np.argmax(dist))
        if dist[worst] > tolerance:
            keep[i + 1 + worst] = True
            stack += [(i, i + 1 + worst), (i + 1 + worst, j)]
    if keep.sum() < 3:
        keep[np.linspace(0, n - 1, 3).astype(int)] = True
    return np.flatnonzero(keep)


def test_edge_pairs_are_the_sorted_half_edges_pairs_in_their_order():
    from texbake.atlas.charts import _edge_pairs

    rng = np.random.default_rng(5)
    for _ in range(100):  # soups with repeated, non-manifold and degenerate edges
        faces = rng.integers(0, rng.integers(3, 50), size=(rng.integers(1, 200), 3))
        got, want = _edge_pairs(faces), _edge_pairs_reference(faces)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    faces = trimesh.creation.icosphere(2).faces
    a, b = _edge_pairs(faces)
    assert len(a) == 3 * len(faces) // 2  # closed manifold: one pair an edge


def test_simplified_keeps_the_points_douglas_peucker_keeps():
    from texbake.atlas.charts import _simplified

    rng = np.random.default_rng(6)
    for trial in range(100):
        points = rng.normal(size=(rng.integers(3, 120), 2))
        if trial % 3 == 0:
            points = np.round(points, 1)  # repeated points: chords of no length
        for tolerance in (0.0, 0.05, 0.5, 5.0):
            assert np.array_equal(_simplified(points, tolerance), _simplified_reference(points, tolerance))
    square = np.array([[0, 0], [0.5, 1e-9], [1, 0], [1, 1], [0, 1]], dtype=float)
    assert _simplified(square, 1e-6).tolist() == [0, 2, 3, 4]  # the point on an edge goes


def test_an_outline_that_touches_itself_is_refused():
    from texbake.atlas.charts import outline_triangles

    uv = np.array([[0, 0], [1, 0], [0, 1], [-1, 0], [0, -1]], dtype=float)
    bowtie = np.array([[0, 1, 2], [0, 3, 4]])  # two triangles meeting at vertex 0
    assert outline_triangles(uv, bowtie) is None
    square = np.array([[0, 1, 2], [1, 3, 2]])
    tri = outline_triangles(np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=float), square)
    assert tri is not None and len(tri) == 2


def _outline_reference(faces):
    """The walk of texbake's one-chart kernel before the batched one (a hash set of the
    directed edges), in Python: ``(ring, lengths)`` or None."""
    turns = ((0, 1), (1, 2), (2, 0))
    directed = {(int(f[a]), int(f[b])) for f in faces for a, b in turns}
    after, starts = {}, []
    for f in faces:
        for a, b in turns:
            x, y = int(f[a]), int(f[b])
            if (y, x) in directed:
                continue
            if x in after:
                return None
            after[x] = y
            starts.append(x)
    if not starts:
        return None
    seen, ring, lengths = set(), [], []
    for s in starts:
        if s in seen:
            continue
        v, n = s, 0
        while v not in seen:
            seen.add(v)
            ring.append(v)
            n += 1
            if v not in after:
                return None
            v = after[v]
        if v != s:
            return None
        lengths.append(n)
    return ring, lengths


def _patch(rng, offset):
    """A grid of quads (two triangles each) on its own vertices from ``offset``, a cell left
    out now and then (a hole, or a notch on the border), its faces shuffled."""
    w, h = rng.integers(1, 6, size=2)
    ids = offset + np.arange((w + 1) * (h + 1)).reshape(h + 1, w + 1)
    quads = [(ids[r, c], ids[r, c + 1], ids[r + 1, c + 1], ids[r + 1, c]) for r in range(h) for c in range(w)]
    if len(quads) > 2 and rng.random() < 0.5:
        quads.pop(int(rng.integers(len(quads))))
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    return faces[rng.permutation(len(faces))], offset + (w + 1) * (h + 1)


def test_outlines_walk_each_chart_as_it_is_walked_alone():
    from texbake import _native

    rng = np.random.default_rng(8)
    kinds = set()
    for _ in range(200):
        charts, offset = [], 0
        for _ in range(rng.integers(1, 6)):
            if rng.random() < 0.7:
                faces, offset = _patch(rng, offset)
            else:  # a soup: repeated, reversed and non-manifold edges, seldom simple loops
                n = int(rng.integers(3, 12))
                faces, offset = offset + rng.integers(0, n, size=(rng.integers(1, 10), 3)), offset + n
            charts.append(faces.astype(np.int64))
        ring, lengths, loops = _native.outlines(np.concatenate(charts), np.cumsum([0] + [len(c) for c in charts]))
        at = first = 0
        for c, faces in enumerate(charts):
            want, alone = _outline_reference(faces), _native.outline_loops(faces)
            kinds.add(want is None)
            if want is None:
                assert loops[c] == -1 and alone is None
                continue
            assert loops[c] == len(want[1]) and alone is not None
            got_lengths = lengths[first:first + loops[c]].tolist()
            assert got_lengths == want[1] == alone[1].tolist()
            assert ring[at:at + sum(got_lengths)].tolist() == want[0] == alone[0].tolist()
            at, first = at + sum(got_lengths), first + loops[c]
        assert at == len(ring) and first == len(lengths)
    assert kinds == {True, False}  # simple outlines and refused ones both met


def test_simplified_loops_simplify_each_loop_as_it_is_simplified_alone():
    from texbake import _native

    rng = np.random.default_rng(9)
    for _ in range(50):
        loops = [rng.normal(size=(rng.integers(3, 60), 2)) for _ in range(rng.integers(1, 8))]
        tolerances = rng.choice([0.0, 0.05, 0.5], size=len(loops))
        kept, counts = _native.simplified_loops(np.concatenate(loops), np.array([len(p) for p in loops]), tolerances)
        offset = at = 0
        for p, tol, count in zip(loops, tolerances, counts.tolist(), strict=True):
            want = _simplified_reference(p, tol) if tol > 0 else np.arange(len(p))  # no tolerance: the loop whole
            assert kept[at:at + count].tolist() == (offset + want).tolist()
            offset, at = offset + len(p), at + count
        assert at == len(kept)


def test_the_outlines_of_many_charts_are_each_chart_s_own():
    from texbake.atlas.charts import outline_triangles, outlines_triangles
    from texbake.atlas.uvcheck import chart_labels

    v, f = load_mesh(MESHES / "gear_cad.stl").vertices, load_mesh(MESHES / "gear_cad.stl").faces
    c = planar_charts(v, f)
    label = chart_labels(c.faces, len(c.uv))
    order = np.argsort(label, kind="stable")
    count = np.bincount(label)
    starts = np.r_[0, np.cumsum(count)]
    want = np.bincount(label, uv_areas(c.uv, c.faces))
    for tolerance in (0.0, 0.01):
        tris, areas = outlines_triangles(c.uv, c.faces[order], starts, tolerance, want)
        made = 0
        for k in range(len(count)):
            alone = outline_triangles(c.uv, c.faces[order][starts[k]:starts[k + 1]], tolerance)
            assert (tris[k] is None) == (alone is None) == (areas[k] is None)
            if alone is not None:
                made += 1
                assert np.array_equal(tris[k], alone) and np.array_equal(areas[k], uv_areas(c.uv, alone))
        assert made > 0.5 * len(count)  # most charts outlined (measured: all but the ones touching themselves)


def test_a_small_wound_chart_is_not_cut_into_crumbs_for_its_slits(monkeypatch):
    # a screw's thread (6 turns of 2400 faces, 0.4 across) beside a plate 20 across: its charts
    # are a few texels wide, wound over themselves in sub-texel faces; looking for slits in
    # them cut the thread into 868 charts (179 without: the overlap cuts alone)
    import texbake.atlas.charts as charts

    r, t = np.meshgrid(np.linspace(0.1, 0.2, 3), np.linspace(0, 12 * np.pi, 2400), indexing="ij")
    v = np.stack([r * np.cos(t), r * np.sin(t), 0.03 * t / (2 * np.pi) + 0.5 * (r - 0.1)], axis=-1).reshape(-1, 3)
    idx = np.arange(len(v)).reshape(r.shape)
    a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    plate = trimesh.creation.box((20, 20, 0.2), trimesh.transformations.translation_matrix((15, 0, -1)))
    vertices, faces = np.concatenate([v, plate.vertices]), np.concatenate([f, plate.faces + len(v)])
    kept = planar_charts(vertices, faces)
    monkeypatch.setattr(charts, "SLIT_CHART", 0.0)
    cut = planar_charts(vertices, faces)
    thread_charts = [len(np.unique(x.labels[:len(f)])) for x in (kept, cut)]
    assert thread_charts[0] < 250 and thread_charts[1] > 2 * thread_charts[0], thread_charts
