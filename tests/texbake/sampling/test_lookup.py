import numpy as np
import pytest

import texbake
from texbake.errors import ParameterError
from texbake.sampling.lookup import MIN_TILES, Tile, UVLookup, sample_offsets, sample_uv, tiles, uv_neighbours


def test_one_sample_is_the_texel_centre():
    assert np.array_equal(sample_offsets(1), [[0.5, 0.5]])


@pytest.mark.parametrize("n", [4, 16, 64, 5])
def test_offsets_are_stratified(n):
    off = sample_offsets(n, seed=3)
    assert off.shape == (n, 2) and (off >= 0).all() and (off < 1).all()
    k = int(round(np.sqrt(n)))
    if k * k == n:  # one sample per cell of a k x k grid
        cells = np.floor(off * k).astype(int)
        assert len({tuple(c) for c in cells}) == n
    else:  # n-rooks: one sample per row and per column stratum
        for axis in range(2):
            assert sorted(np.floor(off[:, axis] * n).astype(int)) == list(range(n))
    assert np.array_equal(off, sample_offsets(n, seed=3))


def test_bad_sample_count():
    with pytest.raises(ParameterError, match="samples"):
        sample_offsets(0)


def test_tiles_cover_the_image_once():
    t = tiles(100, 37, 4, budget=1000)
    rows = np.concatenate([np.arange(x.start, x.stop) for x in t])
    assert np.array_equal(rows, np.arange(100))


def test_tiles_are_bounded_by_the_budget_and_enough_for_the_threads():
    assert max(x.stop - x.start for x in tiles(2048, 2048, 16)) == 32  # 1 << 20 samples
    one = tiles(2048, 2048, 1)  # the budget alone would give 4 tiles: one thread idle
    assert len(one) == MIN_TILES and {x.stop - x.start for x in one} == {2048 // MIN_TILES}
    assert len(tiles(3, 2048, 1)) == 3  # no empty tiles


def test_sample_uv_convention():
    uv = sample_uv(Tile(0, 2), np.arange(8), 4, 2, sample_offsets(1))
    # row 0 is the top of the image: v close to 1
    assert np.allclose(uv[0], [0.125, 0.75]) and np.allclose(uv[4], [0.125, 0.25])


def test_lookup_finds_faces_and_exact_barycentrics():
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    look = UVLookup(uv, faces)
    rng = np.random.default_rng(0)
    q = rng.random((1000, 2)) * 0.98 + 0.01
    f = look.faces_at(q)
    expect = np.where(q[:, 0] > q[:, 1], 0, 1)
    clear = np.abs(q[:, 0] - q[:, 1]) > 1e-5
    assert np.array_equal(f[clear], expect[clear])
    b = look.barycentric(q, f)
    back = np.einsum("ni,nij->nj", b, uv[faces[f]])
    assert np.abs(back - q).max() < 2e-15  # float64 round-off, not Embree's float32: measured 2.2e-16


def located_as_by_rays(look, uv, faces, size, seed, tolerance):
    """``(sample UVs, rays, face of each by its own ray)`` of 16 samples a texel of a
    ``size``² image, after checking that ``look.locate`` finds a face where a ray per
    sample does, one that holds the sample (within ``tolerance``), with its barycentrics."""
    tile = Tile(0, size)
    points = sample_uv(tile, look.candidates(tile, size, size), size, size, sample_offsets(16, seed=seed))
    face, bary, rays = look.locate(points, 16)
    each = look.faces_at(points)
    assert np.array_equal(face >= 0, each >= 0)
    hit = face >= 0
    back = np.einsum("ni,nij->nj", bary[hit], uv[faces[face[hit]]])
    assert np.abs(back - points[hit]).max() < tolerance  # the point lies in the face taken
    assert np.allclose(bary[hit], look.barycentric(points[hit], face[hit]))
    return points, rays, each


def test_the_samples_of_a_texel_inside_its_face_take_it_without_rays():
    # an 8x8 grid of UV triangles, some cells missing: 16 samples a texel of a 64² image;
    # each sample gets the face a ray per sample finds (or, on a shared edge, the other
    # face of that edge), misses where it does, and a fraction of the rays
    n = 8
    g = np.stack(np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij"), -1).reshape(-1, 2) / n
    i = np.arange(n * (n + 1)).reshape(n, n + 1)[:, :n].ravel()
    i = i[(i * 7919) % 5 != 0]  # holes
    faces = np.concatenate([np.stack([i, i + n + 1, i + n + 2], 1), np.stack([i, i + n + 2, i + 1], 1)])
    look = UVLookup(g, faces)
    uv, rays, _ = located_as_by_rays(look, g, faces, 64, seed=1, tolerance=1e-6)
    assert rays < 0.2 * len(uv)  # measured: 0.15 of the samples of the texels the faces touch (the holes' edges miss)
    assert look.locate(uv, 1)[2] == len(uv)


def test_neighbours_across_uv_edges_match_by_position_and_skip_degenerate_faces():
    # a unit square of two triangles whose shared edge repeats its vertices (a seam the
    # atlas does not cut), and a third face glued to the square's right edge with no area
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0], [1.0, 1.0], [2.0, 0.5]])
    faces = np.array([[0, 1, 2], [4, 5, 3], [1, 1, 2]])
    usable = np.array([True, True, False])
    across = uv_neighbours(uv, faces, usable)
    assert across.tolist() == [[-1, 1, -1], [-1, -1, 0], [-1, -1, -1]]
    assert uv_neighbours(uv, faces[:0], usable[:0]).shape == (0, 3)


def test_the_walk_reaches_the_face_a_ray_finds():
    # a fan of thin slivers: samples far from their texel's face walk several faces over
    k = 24
    angle = np.linspace(0.0, np.pi / 2, k + 1)
    uv = np.concatenate([[[0.01, 0.01]], 0.01 + 0.95 * np.stack([np.cos(angle), np.sin(angle)], 1)])
    faces = np.stack([np.zeros(k, dtype=int), np.arange(1, k + 1), np.arange(2, k + 2)], 1)
    look = UVLookup(uv, faces)
    uvs, rays, each = located_as_by_rays(look, uv, faces, 32, seed=2, tolerance=1e-12)
    centre_missed = np.repeat(each[::16] < 0, 16)
    needed = len(uvs) // 16 + (centre_missed | (each < 0)).sum() - centre_missed[::16].sum()  # centres; all else near a miss
    assert rays <= needed + 0.02 * len(uvs)  # measured: needed + 0.3%


def test_lookup_misses_outside_and_on_degenerate_faces():
    uv = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.5], [0.6, 0.6], [0.9, 0.9], [0.75, 0.75]])
    look = UVLookup(uv, np.array([[0, 1, 2], [3, 4, 5]]))
    f = look.faces_at(np.array([[0.1, 0.1], [0.8, 0.1], [0.75, 0.75]]))
    assert f.tolist() == [0, -1, -1]


def test_candidates_cover_every_texel_a_face_can_hit():
    rng = np.random.default_rng(5)
    uv = (rng.random((100, 1, 2)) * 0.9 + rng.random((100, 3, 2)) * 0.1).reshape(-1, 2)  # small
    faces = np.arange(300).reshape(100, 3)
    look = UVLookup(uv, faces)
    width, height = 64, 48
    for tile in tiles(height, width, 4, budget=2000):
        cand = set(look.candidates(tile, width, height).tolist())
        texels = np.arange((tile.stop - tile.start) * width)
        q = sample_uv(tile, texels, width, height, sample_offsets(16, seed=1))
        hit = look.faces_at(q) >= 0
        assert set(np.unique(texels.repeat(16)[hit]).tolist()) <= cand
        assert len(cand) < len(texels)  # and leaves some out


def test_candidates_are_the_texels_a_triangle_touches():
    # a right triangle on texel corners, (0, 0), (4, 0), (0, 4) in texels from the top left:
    # it touches texel (r, c) where c + r <= 3, and at a corner only where c + r == 4
    width, height = 16, 8
    corners = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 4.0]])
    uv = np.stack([corners[:, 0] / width, 1.0 - corners[:, 1] / height], axis=1)
    look = UVLookup(uv, np.array([[0, 1, 2]]))
    r, c = np.divmod(look.candidates(Tile(0, height), width, height), width)
    assert sorted(zip(r.tolist(), c.tolist(), strict=True)) == sorted((r, c) for r in range(5) for c in range(5) if r + c <= 4)
    r, c = np.divmod(look.candidates(Tile(2, 3), width, height), width)  # one row of it, from its tile's top
    assert (r == 0).all() and c.tolist() == [0, 1, 2]
    # a triangle reaching 1e30 texels out still covers the image where it lies
    huge = UVLookup(np.array([[-1e30, -1e30], [1e30, 0.0], [0.0, 1e30]]), np.array([[0, 1, 2]]))
    assert len(huge.candidates(Tile(0, height), width, height)) == width * height



def _sliver_fan(k: int) -> tuple[np.ndarray, np.ndarray]:
    # a disc of k slivers around one UV vertex (a cylinder's cap): each sliver's box spans
    # up to half the disc, its triangle a line of cells or texels from the centre out
    a = np.linspace(0, 2 * np.pi, k, endpoint=False)
    uv = np.vstack([[0.5, 0.5], np.column_stack([0.5 + 0.45 * np.cos(a), 0.5 + 0.45 * np.sin(a)])])
    return uv, np.column_stack([np.zeros(k, dtype=np.int64), 1 + np.arange(k), 1 + (np.arange(k) + 1) % k])


@pytest.mark.parametrize("entries", [None, 8])
def test_a_fan_of_slivers_is_listed_along_them_and_found_exactly(entries, monkeypatch):
    # 4000 slivers: listed by their boxes' cells the grid held 1.45M entries (a 200k-sliver
    # cap: 8.8e9, 32 GiB); by the cells each triangle touches, 169k, 42 a face. Every
    # point's face is still the first one (by index) holding it, as a search of all faces finds
    # (entries 8: past that many a face the grid's cells are made larger, coarser, until under)
    uv, faces = _sliver_fan(4000)
    if entries is not None:
        monkeypatch.setattr(texbake.sampling.lookup, "GRID_ENTRIES", entries)
        monkeypatch.setattr(texbake.sampling.lookup, "GRID_ENTRIES_FREE", 0)
    look = UVLookup(uv, faces)
    _chart, _box, nx, ny, _start, listed = look._cells()
    assert len(listed) < (64 if entries is None else entries) * len(faces)
    assert (nx * ny > len(faces) / 2) == (entries is None)  # one cell a face, or coarser
    rng = np.random.default_rng(2)
    points = 0.5 + (rng.random((3000, 2)) - 0.5) * 0.95
    t = uv[faces]
    side = lambda a, b: (b[:, None, 0] - a[:, None, 0]) * (points[None, :, 1] - a[:, None, 1]) - (
        b[:, None, 1] - a[:, None, 1]) * (points[None, :, 0] - a[:, None, 0])
    s0, s1, s2 = side(t[:, 0], t[:, 1]), side(t[:, 1], t[:, 2]), side(t[:, 2], t[:, 0])
    holds = ((s0 >= 0) & (s1 >= 0) & (s2 >= 0)) | ((s0 <= 0) & (s1 <= 0) & (s2 <= 0))  # (faces, points)
    want = np.where(holds.any(axis=0), holds.argmax(axis=0), -1)
    assert (want >= 0).sum() > 1800  # most points lie on the disc (0.70 of the square)
    assert look.faces_at(points).tolist() == want.tolist()


def test_a_fan_of_slivers_touches_the_texels_its_triangles_do():
    # the candidates of a sliver fan, row by row along each sliver, against every texel's
    # square tested against every triangle (separating axes, the same margin)
    uv, faces = _sliver_fan(300)
    width = height = 48
    look = UVLookup(uv, faces)
    got = np.sort(look.candidates(Tile(0, height), width, height))
    t = uv[faces] * [width, height]
    t[:, :, 1] = height - t[:, :, 1]  # texel rows down
    r, c = np.divmod(np.arange(width * height), width)
    x, y = c + 0.5, r + 0.5
    touched = np.zeros(width * height, dtype=bool)
    margin = texbake.sampling.lookup.TOUCH_MARGIN
    for tri in t:
        box = (x + 0.5 + margin >= tri[:, 0].min()) & (x - 0.5 - margin <= tri[:, 0].max())
        box &= (y + 0.5 + margin >= tri[:, 1].min()) & (y - 0.5 - margin <= tri[:, 1].max())
        orient = np.sign((tri[1, 0] - tri[0, 0]) * (tri[2, 1] - tri[0, 1]) - (tri[1, 1] - tri[0, 1]) * (tri[2, 0] - tri[0, 0]))
        for e in range(3):
            (ax, ay), (bx, by) = tri[e], tri[(e + 1) % 3]
            ex, ey = bx - ax, by - ay
            reach = 0.5 * (abs(ex) + abs(ey))
            box &= ~(orient * (ex * (y - ay) - ey * (x - ax)) + reach < -margin * 2.0 * reach)
        touched |= box
    assert got.tolist() == np.flatnonzero(touched).tolist()


# -- no speckles: every texel of a checker bake holds the value of a face under its centre --

def texels_under_faces(uv, faces, width, height, tolerance=1e-6):
    """Every (texel, face) pair where the texel's centre lies in the face's UV triangle, in
    float64, independently of the bake's lookup: ``(texel (p,) int64 row-major, face (p,),
    barycentric (p, 3), deep (p,) bool)``. A centre within ``tolerance`` (UV units) outside
    a face counts as in it (the lookup casts UVs to float32: 6e-8 apart near 1); ``deep``:
    more than ``tolerance`` inside, where the bake must find a face. Barycentrics of a centre
    just outside are clamped into the face."""
    t = uv[faces]  # (m, 3, 2)
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    ok = np.flatnonzero(det != 0)
    lo = np.floor(t[ok].min(axis=1) * [width, height] - 0.5).astype(np.int64)
    hi = np.ceil(t[ok].max(axis=1) * [width, height] - 0.5).astype(np.int64)
    lo, hi = np.clip(lo, 0, [width - 1, height - 1]), np.clip(hi, 0, [width - 1, height - 1])
    n = (hi - lo + 1).prod(axis=1)
    face = np.repeat(ok, n)
    k = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)  # index within each face's box
    span = np.repeat(hi[:, 0] - lo[:, 0] + 1, n)
    col, vrow = np.repeat(lo[:, 0], n) + k % span, np.repeat(lo[:, 1], n) + k // span  # vrow counts up from v = 0
    u, v = (col + 0.5) / width, (vrow + 0.5) / height
    du, dv = u - t[face, 0, 0], v - t[face, 0, 1]
    b1 = (du * d2[face, 1] - dv * d2[face, 0]) / det[face]
    b2 = (d1[face, 0] * dv - d1[face, 1] * du) / det[face]
    bary = np.stack([1 - b1 - b2, b1, b2], axis=1)
    opposite = np.stack([np.linalg.norm(t[face, 2] - t[face, 1], axis=1), np.linalg.norm(d2[face], axis=1),
                         np.linalg.norm(d1[face], axis=1)], axis=1)
    distance = (bary * np.abs(det[face])[:, None] / opposite).min(axis=1)  # signed UV distance to the nearest edge
    keep = distance >= -tolerance
    texel = (height - 1 - vrow) * width + col  # row 0 at the top
    bary = np.clip(bary[keep], 0.0, 1.0)  # a centre just outside: the face's point beside it
    return texel[keep], face[keep], bary / bary.sum(axis=1, keepdims=True), (distance > tolerance)[keep]


SPECKLE_MESHES = ["suzanne_blender_uv.obj", "bunny.ply", "Duck.glb", "fandisk.obj", "gear_cad.stl", "capsule.obj",
                  "featuretype.STL", "busted.STL", "soup.stl", "ico4uv.obj", "suzanne.ply", "BoxTextured.glb"]


@pytest.mark.parametrize("name", SPECKLE_MESHES)
def test_no_speckles_on_checker_bakes(meshes, name, monkeypatch):
    """0 wrong texels on checker bakes, point-sampled and filtered (one sample a texel).

    A texel is wrong when it is covered and its value differs (by more than 1e-5, float32
    storage) from the checker evaluated, independently of the bake's lookup, at the
    surface point of every face whose UV triangle holds the texel centre (any of them
    will do: a centre on a shared edge may go to either face), or when it is not covered
    though its centre lies more than 1e-6 inside a face. A texel on an internal edge that
    took another face's value (a speckle) is such a texel. Sizes alternate per mesh
    (256 and 512) to keep the test fast; filtering too. Texels whose surface bends are
    filtered in one footprint here (``texbake.sampling.creases`` off: its parts are
    tested in ``test_creases.py``), so that each texel is one face's.
    """
    from texbake.mesh.uvgeometry import uv_jacobian
    from texbake.textures.mapping import TextureMapping

    index = SPECKLE_MESHES.index(name)
    size, filtering = 512 if name == "gear_cad.stl" or index % 2 else 256, index % 4 < 2  # gear_cad: 1663 texels at 256
    monkeypatch.setattr("texbake.sampling.creases.KINK", float("inf"))
    result = texbake.bake_mesh(meshes / name, "checker", size=size, filtering=filtering, samples=1, margin=0)
    m = result.mesh
    texel, face, bary, deep = texels_under_faces(m.uv, m.faces, size, size)
    points = np.einsum("pi,pij->pj", bary, m.vertices[m.faces[face]])
    mapping = TextureMapping.for_mesh(m.vertices.min(axis=0), m.vertices.max(axis=0), result.settings.texture_space)
    dpdx = dpdy = None
    if filtering:
        dpdu, dpdv, _ = uv_jacobian(m.vertices, m.faces, m.uv, m.faces)
        dpdx, dpdy = dpdu[face] / size, -dpdv[face] / size
        # a texel a chart's border cuts filters the part its chart covers: that box in each face's plane
        # (over the charted faces: a double-sided mesh's back face lies on its twin's UV triangle)
        corners = np.sort(m.uv[m.faces].reshape(len(m.faces), 6).view([("", float)] * 2).reshape(len(m.faces), 3), axis=1)
        _, first, twin = np.unique(corners.view(np.dtype((np.void, 48))).ravel(), return_index=True, return_inverse=True)
        charted = np.sort(first)
        at = np.searchsorted(charted, first[twin.ravel()][face])
        lookup = UVLookup(m.uv, m.faces[charted])
        uv = np.einsum("pi,pij->pj", bary, m.uv[m.faces[face]])
        inside = lookup.barycentric(uv, at)
        shift, edges, area, _ = lookup.footprint_clip(at, inside, size, size)
        points = points + shift[:, :1] * dpdx + shift[:, 1:] * dpdy
        dpdx, dpdy = edges[:, 0, :1] * dpdx + edges[:, 1, :1] * dpdy, edges[:, 0, 1:] * dpdx + edges[:, 1, 1:] * dpdy
        part = np.flatnonzero(area < 1)  # and the covered part's hull bounds the filter (EvalContext.hull)
        hull = (part, lookup.footprint_hull(at[part], inside[part], size, size, shift[part], edges[part]))
    expect = mapping.evaluate(result.settings.texture, points, dpdx, dpdy, exact=True, hull=hull if filtering else None)
    got = result.images["albedo"].reshape(-1, 3)[texel]
    right = np.zeros(size * size, bool)
    np.logical_or.at(right, texel, np.abs(got - expect).max(axis=1) < 1e-5)
    covered = result.coverage.ravel()
    must = np.zeros(size * size, bool)
    must[texel[deep]] = True
    wrong = covered & ~right
    holes = must & ~covered
    assert covered.sum() > 0.2 * size * size  # gear_cad: 0.26 at 512
    assert wrong.sum() == 0 and holes.sum() == 0, (np.argwhere(wrong.reshape(size, size))[:5], np.argwhere(holes.reshape(size, size))[:5])


def test_a_texel_cut_by_a_straight_chart_edge_is_the_covered_rectangle():
    # a chart covering u < 2.6 / 4 of a 4 x 4 image: texel column 2 is 0.6 covered
    lookup = UVLookup(np.array([[0, 0], [0.65, 0], [0.65, 1], [0, 1]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    face, bary, _ = lookup.locate(np.array([[2.5 / 4, 1 - 1.5 / 4], [0.5 / 4, 1 - 1.5 / 4]]))
    shift, edges, area, partial = lookup.footprint_clip(face, bary, 4, 4)
    assert partial == 1 and area.tolist() == pytest.approx([0.6, 1.0])
    assert shift[0].tolist() == pytest.approx([-0.2, 0.0]) and edges[0].ravel().tolist() == pytest.approx([0.6, 0, 0, 1])
    assert shift[1].tolist() == [0, 0] and edges[1].tolist() == [[1, 0], [0, 1]]  # a whole texel: as it was


def _image_faces(corners, size: int = 4):
    """UVs and faces of triangles given in image coordinates (column, row down) of a
    ``size`` x ``size`` image, each wound counter-clockwise in UV."""
    uv, faces = [], []
    for tri in corners:
        t = np.array([[x / size, 1 - y / size] for x, y in tri])
        if (t[1, 0] - t[0, 0]) * (t[2, 1] - t[0, 1]) - (t[1, 1] - t[0, 1]) * (t[2, 0] - t[0, 0]) < 0:
            t = t[[0, 2, 1]]
        faces.append([len(uv), len(uv) + 1, len(uv) + 2])
        uv.extend(t.tolist())
    return np.array(uv), np.array(faces)


def test_a_fold_is_not_crossed_and_its_texel_is_cut_to_the_part_it_covers():
    # a scan's folded pair: the same UV triangle twice, wound both ways, over half of texel
    # (row 1, column 1); crossed, the two halves added up to a whole texel
    uv, faces = _image_faces([[(1, 1), (2, 1), (1, 2)]])
    uv, faces = np.concatenate([uv, uv]), np.array([[0, 1, 2], [3, 5, 4]])
    assert uv_neighbours(uv, faces, np.ones(2, dtype=bool)).tolist() == [[-1, -1, -1], [-1, -1, -1]]
    lookup = UVLookup(uv, faces)
    face, bary, _ = lookup.locate(np.array([[1.4 / 4, 1 - 1.4 / 4]]))
    shift, edges, area, partial = lookup.footprint_clip(face, bary, 4, 4)
    assert partial == 1 and area[0] == pytest.approx(0.5)


def test_a_cracks_two_sides_in_one_texel_are_both_its_charts_part():
    # texel (row 1, column 1) is covered by two faces of one chart, A (lower left half) and
    # B (upper right), whose hypotenuses lie 1e-4 apart (a crack: no UV edge between them);
    # they are joined by faces outside the texel (D, E, H, G, F). The cut takes both.
    e = 1e-4
    A, B = [(1, 1), (2, 1), (1, 2)], [(2, 1 + e), (2, 2), (1 + e, 2)]
    D, E = [(1, 1), (2, 1), (1.5, 0)], [(2, 1), (1.5, 0), (3, 0.5)]
    H, G, F = [(2, 1), (3, 0.5), (2, 1 + e)], [(2, 1 + e), (3, 1.5), (3, 0.5)], [(2, 1 + e), (2, 2), (3, 1.5)]
    uv, faces = _image_faces([A, B, D, E, H, G, F])
    lookup = UVLookup(uv, faces)
    face, bary, _ = lookup.locate(np.array([[1.3 / 4, 1 - 1.3 / 4], [1.8 / 4, 1 - 1.8 / 4]]))
    assert face.tolist() == [0, 1]
    shift, edges, area, partial = lookup.footprint_clip(face, bary, 4, 4)
    assert area.tolist() == pytest.approx([1 - e + e * e / 2] * 2)  # all but the crack's sliver
    assert np.abs(shift).max() < 1e-4 and np.abs(edges - np.eye(2)).max() < 1e-4
    # a face of another chart in the texel is not taken
    uv2, faces2 = _image_faces([A, [(2, 1), (2, 2), (1, 2)]])
    uv2[3:, 0] += 1e-9  # B' apart from A: its own chart (no corners shared by position)
    face, bary, _ = UVLookup(uv2, faces2).locate(np.array([[1.3 / 4, 1 - 1.3 / 4]]))
    assert UVLookup(uv2, faces2).footprint_clip(face, bary, 4, 4)[2][0] == pytest.approx(0.5)


def test_the_hull_of_a_texel_cut_by_a_straight_chart_edge_is_the_boxs_own_square():
    # the texel above, 0.6 covered: the box is that rectangle, so the hull in its frame is [-1/2, 1/2]^2
    lookup = UVLookup(np.array([[0, 0], [0.65, 0], [0.65, 1], [0, 1]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    face, bary, _ = lookup.locate(np.array([[2.5 / 4, 1 - 1.5 / 4]]))
    shift, edges, area, _ = lookup.footprint_clip(face, bary, 4, 4)
    hull = lookup.footprint_hull(face, bary, 4, 4, shift, edges)
    assert hull.shape == (1, 8, 2) and np.isnan(hull[0, 4:]).all()
    assert sorted(map(tuple, np.round(hull[0, :4], 12).tolist())) == [(-0.5, -0.5), (-0.5, 0.5), (0.5, -0.5), (0.5, 0.5)]


def test_the_hull_of_a_slanted_cut_is_the_covered_part():
    # one triangle whose hypotenuse slants across texel (row 1, column 0) of a 4 x 4 image: the covered
    # part is convex, so its hull, taken back to texel-local coordinates, has its area and
    # lies in the texel and on the triangle
    uv = np.array([[0.0, 0.0], [0.6, 0.0], [0.0, 1.0]])  # v up; the hypotenuse u / 0.6 + v = 1
    lookup = UVLookup(uv, np.array([[0, 1, 2]]))
    face, bary, _ = lookup.locate(np.array([[0.5 / 4, 1 - 1.5 / 4]]))
    shift, edges, area, partial = lookup.footprint_clip(face, bary, 4, 4)
    assert partial == 1 and 0 < area[0] < 1
    hull = lookup.footprint_hull(face, bary, 4, 4, shift, edges)[0]
    corners = hull[~np.isnan(hull[:, 0])]
    local = shift[0] + corners @ edges[0].T  # local = shift + E (a, b)
    x, y = local[:, 0], local[:, 1]
    assert 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) == pytest.approx(area[0], abs=1e-12)  # counter-clockwise
    assert (np.abs(local) <= 0.5 + 1e-12).all()
    u, v = (0.5 + x) / 4, 1 - (1 + 0.5 + y) / 4
    assert (u / 0.6 + v <= 1 + 1e-12).all()


def test_the_cut_matches_the_covered_parts_mean_and_covariance():
    # a fan of triangles (one chart) whose rim cuts texels: the cut's area, centre and
    # covariance against a 400 x 400 midpoint grid over each texel (error about 1/400 per
    # unit of edge: 5e-3 on the area, looser on the covariance's edges)
    rng = np.random.default_rng(5)
    size, k = 16, 7
    angle = np.sort(rng.random(k)) * 2 * np.pi
    rim = 0.5 + (0.25 + 0.1 * rng.random(k))[:, None] * np.column_stack([np.cos(angle), np.sin(angle)])
    uv = np.vstack([[0.5, 0.5], rim])
    faces = np.array([[0, 1 + i, 1 + (i + 1) % k] for i in range(k)])
    lookup = UVLookup(uv, faces)
    texels = np.arange(size * size)
    face, bary, _ = lookup.locate(sample_uv(Tile(0, size), texels, size, size, sample_offsets(1)))
    hit = face >= 0
    shift, edges, area, partial = lookup.footprint_clip(face[hit], bary[hit], size, size)
    assert partial > 10
    g = (np.arange(400) + 0.5) / 400 - 0.5
    gx, gy = (a.ravel() for a in np.meshgrid(g, g))
    for t in np.flatnonzero(area < 1)[:12]:
        row, col = divmod(int(texels[hit][t]), size)
        inside = lookup.faces_at(np.column_stack([(col + 0.5 + gx) / size, 1 - (row + 0.5 + gy) / size])) >= 0
        assert area[t] == pytest.approx(inside.mean(), abs=5e-3)
        x, y = gx[inside], gy[inside]
        assert shift[t].tolist() == pytest.approx([x.mean(), y.mean()], abs=5e-3)
        box = edges[t] @ edges[t].T / 12  # the box's covariance is the cut's
        assert box.ravel().tolist() == pytest.approx(np.cov(np.vstack([x, y]), bias=True).ravel().tolist(), abs=2e-3)
