import numpy as np
import pytest
import trimesh

import texbake.sampling.creases as creases
from texbake import bake_mesh
from texbake.checks.sweep import compare
from texbake.sampling import Sampler, UVLookup


def test_a_texel_across_an_edge_has_a_part_in_each_face():
    # a quad over image coordinates [0.5, 2.5]^2 of a 4 x 4 image, cut along its diagonal:
    # texel (row 1, column 1) lies half in each triangle
    corners = np.array([[0.5, 0.5], [2.5, 0.5], [2.5, 2.5], [0.5, 2.5]])
    uv = np.column_stack([corners[:, 0] / 4, 1 - corners[:, 1] / 4])
    lookup = UVLookup(uv, np.array([[0, 1, 2], [0, 2, 3]]))
    face, bary, _ = lookup.locate(np.array([[1.4 / 4, 1 - 1.6 / 4]]))  # below the diagonal (y down): in face 1
    sample, part_face, share, centre, edges = lookup.texel_parts(face, bary, 4, 4, 0.01, np.ones(2, dtype=bool))
    assert sample.tolist() == [0, 0] and sorted(part_face.tolist()) == [0, 1]
    assert share.tolist() == pytest.approx([0.5, 0.5])
    # each half's centre: the centroid of its right triangle, a sixth of the texel off the diagonal
    local = np.column_stack([centre[:, 0] * 4 - 1.5, (1 - centre[:, 1]) * 4 - 1.5])
    got = {int(f): tuple(np.round(c, 12)) for f, c in zip(part_face, local, strict=True)}
    assert got == {0: pytest.approx((1 / 6, -1 / 6)), 1: pytest.approx((-1 / 6, 1 / 6))}
    # each half's box has the half's covariance: its edges E, E E^T = 12 cov
    for e in edges:
        assert np.trace(e @ e.T) == pytest.approx(12 * (2 * (1 / 18)), rel=1e-9)  # a right triangle of legs 1: var 1/18 a side
    # a face that does not bend, or a texel inside one face, has none
    assert len(lookup.texel_parts(face, bary, 4, 4, 0.01, np.zeros(2, dtype=bool))[0]) == 0
    inside, inside_bary, _ = lookup.locate(np.array([[2.3 / 4, 1 - 0.9 / 4]]))
    assert len(lookup.texel_parts(inside, inside_bary, 8, 8, 0.01, np.ones(2, dtype=bool))[0]) == 0


def _strip(fold_degrees: float) -> Sampler:
    # a strip of two unit squares along x, the second folded up about their shared edge (x = 1)
    # by fold_degrees, its UVs flat: a texel's step along x turns there, its step along y does not
    a = np.radians(fold_degrees)
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1 + np.cos(a), 0, np.sin(a)], [1 + np.cos(a), 1, np.sin(a)]])
    faces = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
    uv = np.array([[0, 0], [0.5, 0], [0.5, 1], [0, 1], [1, 0], [1, 1]], float)
    return Sampler(v, faces, uv, faces, 16, 8)


def test_faces_that_bend_are_those_whose_steps_differ_from_a_neighbours():
    # folded by 90 degrees: every face touches the fold (the two on it across an edge, the
    # other two at a corner) and bends; a flat strip's none
    assert _strip(90).bends(0.2).tolist() == [True, True, True, True]
    assert not _strip(0).bends(0.2).any()


def test_a_bend_that_turns_one_step_counts_in_full():
    # at a fold of t degrees the x step changes by 2 sin(t / 2) of its length and the y step
    # not at all: 15 degrees (a torus of 24 sections' crease) changes it by 0.26 > KINK, 10
    # degrees by 0.17. Measured against the two steps' lengths summed, 15 degrees read 0.13
    # and was filtered whole (the torus' wood 2.1x the error, bench_error 512²)
    assert _strip(15).bends(creases.KINK).all()
    assert not _strip(10).bends(creases.KINK).any()


def test_bent_texels_filtered_in_parts_come_closer_to_the_surface_mean(meshes, monkeypatch):
    # suzanne.ply's 968 faces meet at angles; at 256² many texels span two of them. Against 256
    # point samples a texel: measured 0.40 of the RMSE without parts (7.3e-4 against 1.8e-3)
    mesh = meshes / "suzanne.ply"
    reference = bake_mesh(mesh, "wood", size=256, samples=256, filtering=False, margin=0)
    parts = bake_mesh(mesh, "wood", size=256, samples=1, margin=0)
    monkeypatch.setattr(creases, "KINK", float("inf"))
    whole = bake_mesh(mesh, "wood", size=256, samples=1, margin=0)
    assert parts.report["rays"]["crease_parts"] > 0 and whole.report["rays"]["crease_parts"] == 0
    truth = (reference.images["albedo"], reference.coverage)
    assert compare(parts.images["albedo"], parts.coverage, *truth)[0] < 0.6 * compare(whole.images["albedo"], whole.coverage, *truth)[0]


def test_parts_tested_as_they_are_made_match_the_test_after(meshes, monkeypatch):
    # texel_parts given each face's steps keeps only the texels with a part that bends; past
    # STEP_FACES faces, every texel's parts on a face that bends are made and tested in numpy
    # afterwards. The bunny at 128²: the same parts, the same image, and fewer parts made (9.8k
    # of 10.3k; at 512², where a texel spans fewer faces, 63k of 172k)
    import texbake.sampling.sampler as sampler

    mesh = meshes / "bunny.ply"
    tested = bake_mesh(mesh, "wood", size=128, margin=0)
    monkeypatch.setattr(sampler, "STEP_FACES", 0)
    after = bake_mesh(mesh, "wood", size=128, margin=0)
    assert tested.report["rays"]["crease_parts"] == after.report["rays"]["crease_parts"] > 0
    assert np.array_equal(tested.images["albedo"], after.images["albedo"])

    out = tested.mesh
    s = Sampler(out.vertices, out.faces, out.uv, out.faces, 128, 128)
    row, col = np.divmod(np.arange(128 * 128), 128)
    located = s.locate(np.column_stack([(col + 0.5) / 128, 1 - (row + 0.5) / 128]))
    monkeypatch.setattr(sampler, "STEP_FACES", 1 << 20)
    made = [len(s.lookup.texel_parts(located.face, located.bary, 128, 128, creases.LEAST, s.bends(creases.KINK), steps,
                                     creases.KINK)[0]) for steps in (None, s.steps())]
    assert 0 < made[1] < made[0]


def test_a_flat_mesh_has_no_parts():
    # a flat grid, its own UVs uniform: no face bends, nothing is filtered in parts
    plane = trimesh.creation.box((1.0, 1.0, 1e-3)).subdivide().subdivide()
    plane = trimesh.Trimesh(plane.vertices, plane.faces[plane.face_normals[:, 2] > 0.99])
    plane.visual = trimesh.visual.TextureVisuals(uv=plane.vertices[:, :2] + 0.5)
    result = bake_mesh(plane, "checker", size=64, samples=1, margin=0)
    assert result.coverage.sum() > 0.9 * 64 * 64 and result.report["rays"]["crease_parts"] == 0


def test_faces_that_share_only_a_corner_are_compared_too():
    # two triangles of one chart that meet at a UV corner (no edge), the second's surface
    # three times as large as its UVs: a texel on that corner spans both, so both bend
    # (compared across edges only, neither had a neighbour); at one scale neither does
    def pair(stretch: float) -> Sampler:
        uv = np.array([[0, 0], [0.5, 0], [0, 0.5], [1, 0], [0.5, 0.5]], float)
        v = np.column_stack([uv, np.zeros(5)])
        v[3:] = v[1] + stretch * (v[3:] - v[1])
        faces = np.array([[0, 1, 2], [1, 3, 4]])
        return Sampler(v, faces, uv, faces, 16, 16)
    assert pair(3.0).bends(creases.KINK).tolist() == [True, True]
    assert not pair(1.0).bends(creases.KINK).any()


def _bends_by_pairs(v: np.ndarray, faces: np.ndarray, uv: np.ndarray, width: int, height: int, kink: float) -> np.ndarray:
    # the rule itself, every pair of faces sharing a UV corner compared (no fans' boxes)
    d1, d2 = uv[faces[:, 1]] - uv[faces[:, 0]], uv[faces[:, 2]] - uv[faces[:, 0]]
    e1, e2 = v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    dpdu = (e1 * d2[:, 1:] - e2 * d1[:, 1:]) / det[:, None]
    dpdv = (e2 * d1[:, :1] - e1 * d2[:, :1]) / det[:, None]
    dx, dy = dpdu / width, -dpdv / height
    scale = np.maximum(np.linalg.norm(dx, axis=1), np.linalg.norm(dy, axis=1))
    out = np.zeros(len(faces), dtype=bool)
    for f in range(len(faces)):
        others = np.flatnonzero(np.isin(faces, faces[f]).any(axis=1))
        off = np.maximum(np.linalg.norm(dx[others] - dx[f], axis=1), np.linalg.norm(dy[others] - dy[f], axis=1))
        out[f] = (off > kink * scale[f]).any()
    return out


@pytest.mark.parametrize("apex", [0.0, 0.02, 0.3])
@pytest.mark.parametrize("stretched", [False, True])
def test_a_large_fan_bends_as_its_faces_compared_pair_by_pair(apex, stretched):
    # a disc of 60 slivers around one UV vertex (a fan past the size at which face_bends
    # bounds it by its box of steps), its centre raised by apex (a flat disc, a cone that
    # bends by about 2 degrees between neighbours and one that bends more), one ring vertex
    # pulled out on the surface, not in UV: each face's answer is the pairwise rule's
    k = 60
    a = np.linspace(0, 2 * np.pi, k, endpoint=False)
    uv = np.vstack([[0.5, 0.5], np.column_stack([0.5 + 0.4 * np.cos(a), 0.5 + 0.4 * np.sin(a)])])
    v = np.column_stack([uv * 2.0, np.zeros(k + 1)])
    v[0, 2] = apex
    if stretched:
        v[17, :2] = 1.0 + 3.0 * (v[17, :2] - 1.0)
    faces = np.column_stack([np.zeros(k, dtype=np.int64), 1 + np.arange(k), 1 + (np.arange(k) + 1) % k])
    got = Sampler(v, faces, uv, faces, 64, 64).bends(creases.KINK)
    want = _bends_by_pairs(v, faces, uv, 64, 64, creases.KINK)
    assert got.tolist() == want.tolist()
    assert want.any() == (apex == 0.3 or stretched)  # the case is the one meant: some faces bend, or none
