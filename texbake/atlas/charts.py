"""Planar charting: faces grouped by normal direction into islands, each island projected
onto its own plane (in the spirit of Blender's Smart UV Project).

A flat part of a mesh becomes one chart with zero stretch however it is triangulated (the
long sliver fans of tessellated CAD faces included); a curved part becomes a few charts
whose texel density falls off with the cosine of the angle to its projection direction,
at most ``ANGLE_LIMIT``. The charts are laid out side by side, apart, one UV mesh for
xatlas' packer (``texbake.atlas.packworker.pack``), which places them all at one density.

numpy and the compiled kernels (:mod:`texbake.mesh.components`, :mod:`texbake.atlas.uvcheck`, and
``native/charts.cpp``: the faces sharing an edge, the charts' outlines and their simplification).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _native
from ..mesh import areas, connected_components, group_rows, label_boxes, unique_inverse

ANGLE_LIMIT = 66.0  # degrees between a face's normal and its chart's direction, at most (Blender's default)
FLAT_COS = np.cos(np.radians(2.0))  # a face this close to its chart's direction counts as flat
COPLANAR_COS = np.cos(np.radians(0.05))  # neighbours this close are one flat face of a CAD model
SPLITS = 6  # rounds of cutting self-overlapping charts in two
MERGE_WORK = 8  # joining cut pieces again rasterises at most this many times the mesh's faces
CRUMB_FACES, CRUMB_LIMIT = 16, 55.0  # charts of fewer faces join a neighbour within this angle, on meshes
CRUMB_FLAT = 0.1  # with less of their area flat (within 2 degrees of its direction) than this
FLAT_REGION = 0.01  # a coplanar region of this share of the surface or more is flat ("auto" charting)
XATLAS_FACES = 6_000  # "auto" charting leaves meshes of more faces to planar charts
# An outline is simplified only where the area the simplification may change (its tolerance
# times the perimeter: the slack the area check then allows) is under this share of the
# chart's area, a width of eight tolerances: a thinner chart could lose its width and the
# check not see it. (A hundredth kept every chart under 12 texels wide whole: a CAD part's
# outlines of arcs, counter.unitsmm.STL's, then packed a fifth slower.)
SIMPLIFY_SLACK = 0.25
# Border stretches of one chart closer than this many texels (at a packing of half the
# square) over places of the surface far apart are a slit (:func:`_slits`): cut as overlaps are.
SLIT_TEXELS = 1.0
# Charts under this many of those texels across are not looked at: a screw's thread, a few
# texels wide and wound over itself in thousands of sub-texel faces, would be cut into
# hundreds of crumbs for texels that no cut mends (counter.unitsmm.STL: 1613 charts became
# 10,317, the utilisation 0.411 -> 0.186).
SLIT_CHART = 16.0
# A chart longer than LONG_SHARE of the tile's side (in mesh units at the density that
# fills half the square: sqrt(2 x the surface's area); 0.85 of it is the side at 0.7
# filled) and LONG_ASPECT times as long as it is wide holds the packing's density down on
# its own: a strip longer than the tile is across leaves the rest of it empty (a flat
# 1000 x 176 outline, common-3d-test-models' alligator.obj: utilisation 0.086). It is cut
# across its length into pieces of at most PIECE_SHARE of that side, along its faces' edges
# (each face to the piece of its lowest corner along the length, so a strip of quads is cut
# straight between two rows), where its faces are at most FACE_SHARE of a piece long (the
# two triangles across a CAD part's long face, or a capsule's side, cannot be cut so: the
# pieces would be combs). A solid texture has no seam to hide: a cut costs padding.
LONG_SHARE = 0.85
LONG_ASPECT = 2.0
PIECE_SHARE = 0.5
FACE_SHARE = 0.25


@dataclass
class Charts:
    """Charts of a mesh, as one UV mesh of separate pieces.

    ``vmapping[faces] == input faces``: chart vertex ``i`` is mesh vertex ``vmapping[i]``
    (a mesh vertex on the border of two charts is in both).
    """

    vmapping: np.ndarray  # (k,) int64: chart vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: the mesh's faces in chart vertices, same order
    uv: np.ndarray  # (k, 2) float64: charts at one texel density (mesh units), apart
    labels: np.ndarray  # (m,) int64: each face's chart (connected, one direction)
    directions: np.ndarray  # (d, 3) float64: the projection directions
    flat: float  # share of the surface area on faces within 2 degrees of their direction


@dataclass
class Sides:
    """The faces of a mesh split into front faces and back faces: a back face has the
    corners of an earlier face (its twin) in the opposite winding, the other side of one
    surface (a double-sided mesh). Charting the front faces alone and mapping each back
    face onto its twin's texels gives one chart per surface, not two overlapping ones."""

    faces: np.ndarray  # (m, 3) int64: the mesh's faces
    front: np.ndarray  # (f,) int64: the faces charted, ascending
    back: np.ndarray  # (b,) int64: the back faces, ascending
    twin: np.ndarray  # (b,) int64: each back face's twin, as a position in ``front``

    @classmethod
    def of(cls, faces: np.ndarray) -> Sides:
        """The sides of ``(m, 3)`` int faces: of the faces on one set of three vertices, those
        in the winding of the first are front faces, the others back faces of that first one."""
        faces = np.asarray(faces, dtype=np.int64)
        start = np.argmin(faces, axis=1)
        turned = np.take_along_axis(faces, (start[:, None] + np.arange(3)) % 3, axis=1)
        winding = turned[:, 1] < turned[:, 2]
        first, group = group_rows(np.sort(faces, axis=1))  # hashed: linear, where a lexsort sorted them
        twin = first[group]  # the first face on each face's corners
        is_back = winding != winding[twin]
        front = np.flatnonzero(~is_back)
        back = np.flatnonzero(is_back)
        return cls(faces, front, back, np.searchsorted(front, twin[back]))

    def restored(self, vmapping: np.ndarray, faces: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(vmapping, faces, uv)`` of an atlas of the front faces (``faces`` (f, 3) in their
        order) extended to every face: each back face gets new atlas vertices at its twin's
        corners' UVs (its own vertices, so its shading normals stay its own)."""
        tf = faces[self.twin]  # (b, 3) atlas vertices of each twin
        own = self.faces[self.back]  # (b, 3) mesh vertices of each back face
        corner = np.argmax(own[:, :, None] == vmapping[tf][:, None, :], axis=2)  # twin's corner of each back corner
        ids = np.take_along_axis(tf, corner, axis=1)
        new, inverse = unique_inverse(ids)
        out = np.empty((len(self.faces), 3), dtype=np.int64)
        out[self.front] = faces
        out[self.back] = len(vmapping) + inverse.reshape(-1, 3)
        return np.concatenate([vmapping, vmapping[new]]), out, np.concatenate([uv, uv[new]])


def directions(normals: np.ndarray, weights: np.ndarray, angle_limit: float = ANGLE_LIMIT) -> np.ndarray:
    """``(d, 3)`` unit projection directions covering ``(m, 3)`` unit face normals.

    Greedy, as Smart UV Project: from the largest face, the mean normal of the faces
    not yet taken within half ``angle_limit`` of it is a direction (those faces are
    taken); then again from the face farthest from every direction so far, until every
    face is within ``angle_limit`` of one. Zero normals (degenerate faces) are ignored.
    ``weights`` (face areas) only choose the first face.
    """
    cos_limit, cos_half = np.cos(np.radians(angle_limit)), np.cos(np.radians(angle_limit / 2))
    valid = np.einsum("ij,ij->i", normals, normals) > 0.5
    if not valid.any():
        return np.array([[0.0, 0.0, 1.0]])
    taken = ~valid
    best = np.where(valid, -np.inf, np.inf)  # each face's largest cosine to a direction
    seed = int(np.argmax(np.where(valid, weights, -1)))
    out = []
    while True:
        near = ~taken & (normals @ normals[seed] > cos_half)
        near[seed] = True
        taken |= near
        mean = normals[near].sum(axis=0)
        length = np.linalg.norm(mean)
        d = mean / length if length > 0 else normals[seed]
        out.append(d)
        best = np.maximum(best, normals @ d)
        seed = int(np.argmin(np.where(taken, np.inf, best)))
        if taken[seed] or best[seed] >= cos_limit:
            break
    # Faces taken by a direction's neighbourhood but outside the limit of every direction
    # (possible when the mean moved away from them) get their own normal as a direction.
    while (best < cos_limit).any():
        seed = int(np.argmin(best))
        out.append(normals[seed])
        best = np.maximum(best, normals @ normals[seed])
    return np.array(out)


def _face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(normals (m, 3), areas (m,))`` float64: unit face normals (zero for a face of no
    area) and face areas."""
    p0 = vertices[faces[:, 0]]
    cross = np.cross(vertices[faces[:, 1]] - p0, vertices[faces[:, 2]] - p0)
    length = np.linalg.norm(cross, axis=1)
    return np.where(length[:, None] > 0, cross / np.where(length > 0, length, 1)[:, None], 0.0), 0.5 * length


def _edge_pairs(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(a, b)`` (e,) int64: pairs of faces that share an edge (a non-manifold edge gives a
    chain), ordered by the edge's ends, then the half-edge (``native/charts.cpp``)."""
    return _native.edge_pairs(np.ascontiguousarray(faces, dtype=np.int64))


def _islands(pairs: tuple[np.ndarray, np.ndarray], labels: np.ndarray) -> np.ndarray:
    """``(m,)`` island id of each face: faces of one label joined across shared edges
    (``pairs``: :func:`_edge_pairs` of the faces, made once for every round)."""
    a, b = pairs
    keep = labels[a] == labels[b]
    return connected_components(len(labels), a[keep], b[keep])


def _basis(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``(u, v)`` with ``u x v = d`` for unit ``d`` (so projected faces facing ``d`` keep their winding)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(helper, d)
    u /= np.linalg.norm(u)
    return u, np.cross(d, u)


def _assign(normals: np.ndarray, weights: np.ndarray, dirs: np.ndarray, cos_limit: float, rounds: int = 2):
    """``(dirs, label (m,))``: each face to its nearest direction, then ``rounds`` of
    moving each direction to its faces' area-weighted mean normal (kept only while every
    face stays within the limit), which evens the texel density of the charts."""
    label = np.argmax(normals @ dirs.T, axis=1)
    for _ in range(rounds):
        sums = np.zeros_like(dirs)
        np.add.at(sums, label, normals * weights[:, None])
        length = np.linalg.norm(sums, axis=1, keepdims=True)
        moved = np.where(length > 0, sums / np.where(length > 0, length, 1), dirs)
        cos = normals @ moved.T
        new = np.argmax(cos, axis=1)
        valid = np.einsum("ij,ij->i", normals, normals) > 0.5
        if not (cos[np.arange(len(new)), new][valid] > cos_limit).all():
            break
        dirs, label = moved, new
    return dirs, label


def _absorb_crumbs(pairs, normals, weights, dirs, group, rounds: int = 3):
    """``group`` with the faces of crumbs (charts of under ``CRUMB_FACES`` faces, which a
    noisy scan scatters along every border between directions) moved to a neighbouring
    chart's direction, the one nearest their normal if within ``CRUMB_LIMIT`` degrees.
    Fewer, larger charts: far less padding, so far more texels, at low resolutions. Only
    for smooth meshes: a CAD part's small charts are its facets."""
    a, b = np.concatenate(pairs), np.concatenate(pairs[::-1])  # both ways: a takes from b
    cos_limit = np.cos(np.radians(CRUMB_LIMIT))
    for _ in range(rounds):
        island = _islands(pairs, group)
        small = np.bincount(island)[island] < CRUMB_FACES
        take = small[a] & (group[a] != group[b])
        if not take.any():
            break
        fa, cand = a[take], group[b[take]]
        fit = np.einsum("ij,ij->i", normals[fa], dirs[cand])
        ok = fit > cos_limit
        fa, cand, fit = fa[ok], cand[ok], fit[ok]
        order = np.lexsort((-fit, fa))  # per face, its best candidate first
        first = np.ones(len(order), dtype=bool)
        first[1:] = fa[order][1:] != fa[order][:-1]
        group = group.copy()
        group[fa[order][first]] = cand[order][first]
    return group


def planar_charts(vertices: np.ndarray, faces: np.ndarray, angle_limit: float = ANGLE_LIMIT, grid: int = 1024) -> Charts:
    """Planar charts of ``(n, 3)`` float64 vertices and ``(m, 3)`` int faces (see the module).

    Each face goes to the direction nearest its normal; faces of one direction joined by
    shared edges are one chart, projected onto the plane normal to the direction. A chart
    whose projection overlaps itself on a ``grid``-square raster of the layout (a curved
    region wrapping round, a ramp winding up) first loses its overlapping faces to a
    chart of their own (the layers of a fold, unconnected, come apart), then, if it still
    overlaps, is cut in two across its longest extent, up to ``SPLITS`` rounds in all; a
    chart with a slit (:func:`_slits`) loses the faces on the slit's sides, in any round.
    Then the pieces that need not be apart are joined again (:func:`_merge_cuts`), and a
    chart too long for the tile is cut across its length (:func:`_cut_long`). Faces
    of zero area have no normal and keep a UV area of zero: the caller gives them charts
    of their own.
    """
    from .uvcheck import overlapping_faces

    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    normals, weights = _face_normals(vertices, faces)

    dirs = directions(normals, weights, angle_limit)
    dirs, group = _assign(normals, weights, dirs, np.cos(np.radians(angle_limit)))  # each face's direction
    pairs = _edge_pairs(faces)
    total = weights.sum()
    if total > 0 and weights[np.einsum("ij,ij->i", normals, dirs[group]) > FLAT_COS].sum() < CRUMB_FLAT * total:
        group = _absorb_crumbs(pairs, normals, weights, dirs, group)
    centroids = vertices[faces].mean(axis=1)
    bases = np.array([np.stack(_basis(d)) for d in dirs])  # (d, 2, 3): each direction's plane, kept beside dirs
    look = np.ones(len(faces), dtype=bool)  # the faces of charts not yet looked at for slits (a chart not cut stays clean)
    for attempt in range(SPLITS + 1):
        island = _islands(pairs, group)
        vmapping, chart_faces, uv = _project(vertices, faces, island, group, bases)
        if attempt == SPLITS:
            break
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        slit = _slits(vertices, vmapping, chart_faces, uv, island, grid, look)
        bad = overlapping_faces((uv - lo) / max(float((hi - lo).max()), 1e-300), chart_faces, grid) | slit
        if not bad.any():
            break
        # the faces of each overlapping island, ascending, from one sort (not a scan of every
        # face per island: counter.unitsmm.STL has hundreds of them each round)
        hit = np.unique(island[bad])
        look = np.isin(island, hit)
        order = np.argsort(island, kind="stable")
        first = np.searchsorted(island[order], hit)
        last = np.searchsorted(island[order], hit, side="right")
        new_group = []  # each new chart's direction: a copy of its island's
        for lo_i, hi_i in zip(first.tolist(), last.tolist(), strict=True):
            members = order[lo_i:hi_i]
            cut = slit[members]
            if attempt == 0:  # first the overlapping faces alone: the layers of a fold come apart
                part = members[bad[members]]
            elif cut.any() and not cut.all():  # the faces on a slit's sides (bisection need not part them)
                part = members[cut]
            else:  # then the chart cut in two across its longest extent
                c = centroids[members]
                axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
                part = members[c[:, axis] > np.median(c[:, axis])]
            if len(part):
                new_group.append(int(group[part[0]]))
                group[part] = len(dirs) + len(new_group) - 1
        copied = np.asarray(new_group, dtype=np.int64)
        dirs = np.concatenate([dirs, dirs[copied]])
        bases = np.concatenate([bases, bases[copied]])
    if attempt:  # something was cut: join the pieces that need not be apart
        island, (vmapping, chart_faces, uv) = _rejoined(vertices, faces, pairs, island, group, (dirs, bases), uv, chart_faces, grid)
    long_cut = _cut_long(pairs, island, uv, chart_faces, weights)
    if long_cut is not None:
        island = long_cut
        vmapping, chart_faces, uv = _project(vertices, faces, island, group, bases)
    best = np.einsum("ij,ij->i", normals, dirs[group])
    flat = float(weights[best > FLAT_COS].sum() / total) if total > 0 else 0.0
    return Charts(vmapping, chart_faces, uv, island, dirs, flat)


def _rejoined(vertices, faces, pairs, island, group, planes, uv, chart_faces, grid):
    """``(island, (vmapping, chart faces, uv))`` of the cut pieces (``island``, projected as
    ``uv``, ``chart_faces``) joined again where they need not be apart (:func:`_merge_cuts`),
    except the joins that make a slit the joins' own look missed (its budget): those pieces
    stay apart. ``planes``: ``(dirs, bases)``."""
    bases = planes[1]
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    merged = _merge_cuts(vertices, faces, pairs, island, group, planes, float((hi - lo).max()), grid,
                         _slit_width(uv, chart_faces, grid))
    joined = _project(vertices, faces, merged, group, bases)
    pieces = np.unique(np.column_stack([merged, island]), axis=0)[:, 0]  # (merged, piece) pairs: joined ones repeat
    slit = _slits(vertices, joined[0], joined[1], joined[2], merged, grid, np.isin(merged, pieces[1:][pieces[1:] == pieces[:-1]]))
    if slit.any():
        apart = np.isin(merged, merged[slit])
        merged = np.unique(np.where(apart, island, merged + int(island.max()) + 1), return_inverse=True)[1].reshape(-1)
        joined = _project(vertices, faces, merged, group, bases)
    return merged, joined


def _slits(vertices, vmapping, chart_faces, uv, island, grid, look=None) -> np.ndarray:
    """``(m,)`` bool: the faces on either side of a slit in the layout ``uv`` (``_project``'s
    arrays, ``island`` each face's chart; only the charts of the faces ``look`` ((m,) bool),
    when given): two stretches of one chart's border that lie on
    each other (within ``SLIT_TEXELS`` of the texels a ``grid``-texel atlas would have) over
    places of the surface far apart (``native/charts.cpp`` ``slit_faces``). A chart bent over
    a box's edge can put the top face and the side face that meet at one corner on the two
    sides of one line: the texels across it would mix the two (featuretype.STL's filtered
    marble: 98 % of its squared error on about 100 such texels)."""
    flags = np.zeros(len(chart_faces), dtype=bool)
    r = _slit_width(uv, chart_faces, grid)
    sel = np.arange(len(chart_faces)) if look is None else np.flatnonzero(look)  # whole charts
    if not r > 0 or not len(sel):
        return flags
    tri, chart = chart_faces[sel], island[sel]
    points = vertices[vmapping]
    # A chart on one plane (within a quarter r) has no slit: its 3D distances are its UV
    # distances stretched by its slope. Only the others are looked at (a CAD part's facets
    # are most of its charts, and their fans of slivers most of its border), and of those
    # only the ones at least SLIT_CHART widths across.
    normals, weights = _face_normals(points, tri)
    k = int(chart.max()) + 1
    sums = np.stack([np.bincount(chart, normals[:, j] * weights, minlength=k) for j in range(3)], axis=1)
    mean = sums / np.maximum(np.linalg.norm(sums, axis=1, keepdims=True), 1e-300)
    offset = np.einsum("ij,ij->i", points[tri[:, 0]], mean[chart])
    count = np.bincount(chart, minlength=k)
    off = offset - (np.bincount(chart, offset, minlength=k) / np.maximum(count, 1))[chart]  # about each chart's mean plane
    spread = np.bincount(chart, off**2, minlength=k)
    tilted = np.bincount(chart, np.einsum("ij,ij->i", normals, mean[chart]) < COPLANAR_COS, minlength=k)
    flat = (tilted == 0) & (spread <= (0.25 * r) ** 2)
    lo, hi = label_boxes(uv, tri, chart, k)
    small = (hi - lo).max(axis=1) < SLIT_CHART * r
    found = np.zeros(len(sel), dtype=bool)
    _native.slit_faces(np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(points, dtype=np.float64),
                       np.ascontiguousarray(tri, dtype=np.int64), np.where((flat | small)[chart], -1, chart), r, found)
    flags[sel] = found
    return flags


def _slit_width(uv: np.ndarray, chart_faces: np.ndarray, grid: int) -> float:
    """What :func:`_slits` looks for in the charts ``uv`` (world units): ``SLIT_TEXELS`` of the
    texels they would have packed into half of a ``grid``-texel square (0: no area)."""
    from ..mesh import uv_areas

    area = float(uv_areas(uv, chart_faces).sum())
    return SLIT_TEXELS * float(np.sqrt(area / 0.5)) / grid if area > 0 else 0.0


def _merge_cuts(vertices, faces, pairs, island, group, planes, scale, grid, slit_r):
    """``island`` with neighbouring islands of one direction (pieces that cutting made)
    joined again wherever their union does not overlap itself on the texel raster
    (``scale`` mesh units to ``grid`` texels) and has no slit ``slit_r`` wide (mesh units,
    :func:`_slits`; not looked for in a union under ``SLIT_CHART`` such widths across), the
    smallest pairs first. Bisection cuts
    where the overlap is not, so without this a part keeps a fifth more charts than it
    needs (featuretype.STL: 146 against 103). The faces rasterised are bounded by
    ``MERGE_WORK`` times the mesh's. ``planes``: the directions and their :func:`_basis`."""
    dirs, bases = planes
    a, b = pairs
    same = (island[a] != island[b]) & (dirs[group[a]] == dirs[group[b]]).all(axis=1)
    pairs = np.unique(np.sort(np.column_stack([island[a][same], island[b][same]]), axis=1), axis=0)
    n = int(island.max()) + 1
    direction = np.zeros(n, dtype=np.int64)
    direction[island] = group
    count = np.bincount(island, minlength=n)
    order = pairs[np.argsort(count[pairs].sum(axis=1), kind="stable")]
    # the joins in native/uvcheck.cpp (merged_islands): a pair at a time from Python cost
    # 0.1 ms each, 0.17 s on counter.unitsmm.STL's 1,642 pairs
    labels = _native.merged_islands(vertices, np.ascontiguousarray(faces, dtype=np.int64), island, direction,
                                    np.ascontiguousarray(bases, dtype=np.float64), np.ascontiguousarray(order, dtype=np.int64),
                                    float(grid / scale), int(MERGE_WORK * len(faces)), float(slit_r), SLIT_CHART)
    return labels[island]


def _cut_long(pairs, island: np.ndarray, uv: np.ndarray, chart_faces: np.ndarray, weights: np.ndarray) -> np.ndarray | None:
    """``island`` with each long chart (``LONG_SHARE``, ``LONG_ASPECT``) cut across its
    length into pieces of at most ``PIECE_SHARE`` of the tile's side, each piece's
    connected parts a chart of their own; None where no chart is cut.

    ``uv``, ``chart_faces``: the charts projected (:func:`_project`); ``weights``: the
    faces' areas. A chart's length is along its principal axis in its plane (of its faces'
    centroids, weighted by area); a chart with a face longer than ``FACE_SHARE`` of a piece
    stays whole.
    """
    k = int(island.max()) + 1 if len(island) else 0
    total = float(weights.sum())
    if k == 0 or not total > 0:
        return None
    side = float(np.sqrt(2.0 * total))  # mesh units across the tile at half the square filled
    lo, hi = label_boxes(uv, chart_faces, island, k)
    if not (np.hypot(*(hi - lo).T) > LONG_SHARE * side).any():  # no chart's box is so long even across
        return None
    tri = uv[chart_faces]  # (m, 3, 2)
    c = tri.mean(axis=1)
    mass = np.bincount(island, weights, k)
    safe = np.where(mass > 0, mass, 1.0)
    mean = np.column_stack([np.bincount(island, weights * c[:, i], k) / safe for i in (0, 1)])
    d = c - mean[island]
    sxx, sxy, syy = (np.bincount(island, weights * a * b, k) for a, b in ((d[:, 0], d[:, 0]), (d[:, 0], d[:, 1]), (d[:, 1], d[:, 1])))
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # the principal axis of each chart
    axis = np.column_stack([np.cos(angle), np.sin(angle)])[island]  # (m, 2) per face
    along = np.einsum("mcj,mj->mc", tri, axis)  # (m, 3) corners along the axis
    across = np.einsum("mcj,mj->mc", tri, axis[:, ::-1] * [-1.0, 1.0])
    corners = np.stack([along, across], axis=2).reshape(-1, 2)  # each face's own corners, for one pass of boxes
    lo, hi = label_boxes(corners, np.arange(len(corners)).reshape(-1, 3), island, k)
    length, width = (hi - lo).T
    pieces = np.where(length > LONG_SHARE * side, np.ceil(length / (PIECE_SHARE * side)), 1.0).astype(np.int64)
    pieces[length < LONG_ASPECT * width] = 1
    if (pieces == 1).all():
        return None
    longest_face = np.zeros(k)
    some = pieces[island] > 1  # the faces of the charts still to cut (few)
    np.maximum.at(longest_face, island[some], np.ptp(along[some], axis=1))
    long = (pieces > 1) & (longest_face <= FACE_SHARE * length / pieces)
    if not long.any():
        return None
    pieces = np.where(long, pieces, 1)
    at = along.min(axis=1) - lo[island, 0]
    # a thousandth of a piece of slack: a corner on a cut is past it, though the chart's axis
    # leans off its rows of vertices (a strip of quads' centroids lean 2e-5 radians on
    # their diagonals), so a strip of quads is cut between two rows
    part = np.clip((at / np.where(long, length, 1.0)[island] * pieces[island] + 1e-3).astype(np.int64), 0, pieces[island] - 1)
    return _islands(pairs, island * int(pieces.max()) + part)


def _project(vertices, faces, island, group, bases):
    """``(vmapping, chart faces, uv)``: each island projected on the plane of its direction
    (``bases`` (d, 2, 3): :func:`_basis` of each) and moved apart from the others (:func:`_apart`)."""
    n = len(vertices)
    # np.unique(keys, return_inverse=True) by hashing the 3m corners, then sorting only the
    # distinct keys (a third of them): the same arrays, in half the time, every round
    corners = (island[:, None] * n + faces).reshape(-1, 1)
    first, grouped = group_rows(corners)
    distinct = corners[first, 0]
    by_key = np.argsort(distinct, kind="stable")
    keys = distinct[by_key]
    rank = np.empty(len(keys), dtype=np.int64)
    rank[by_key] = np.arange(len(keys))
    inverse = rank[grouped]
    vmapping = keys % n
    vertex_island = keys // n
    island_dir = np.zeros(int(island.max()) + 1, dtype=np.int64)
    island_dir[island] = group
    b = bases[island_dir[vertex_island]]  # (k, 2, 3)
    uv = np.einsum("kij,kj->ki", b, vertices[vmapping])
    return vmapping, inverse.reshape(-1, 3), _apart(uv, vertex_island)


def _apart(uv: np.ndarray, island: np.ndarray) -> np.ndarray:
    """``uv`` with each island (``(k,)`` id per vertex) moved to its own place on shelves.

    Islands are translated only (so their shape and density stay), into rows of about
    the square root of their total box area, a gap of a tenth of the largest box
    between any two: xatlas' packer merges charts of one UV mesh that touch or overlap.
    """
    count = int(island.max()) + 1
    lo = np.full((count, 2), np.inf)
    hi = np.full((count, 2), -np.inf)
    # the boxes by sorted runs (reduceat), not ufunc.at: a tenth of the time on thousands of
    # islands; _project's islands come sorted, so the sort is skipped there
    order = np.arange(len(island)) if (island[1:] >= island[:-1]).all() else np.argsort(island, kind="stable")
    ordered = island[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    ids = ordered[starts]
    lo[ids] = np.minimum.reduceat(uv[order], starts, axis=0)
    hi[ids] = np.maximum.reduceat(uv[order], starts, axis=0)
    size = hi - lo
    gap = 0.1 * float(size.max()) + 1e-12
    cell = size + gap
    row_width = max(float(np.sqrt((cell[:, 0] * cell[:, 1]).sum())), float(cell[:, 0].max()))
    shelves = np.argsort(-cell[:, 1], kind="stable").tolist()  # tallest first: shelves
    widths, heights = cell[:, 0].tolist(), cell[:, 1].tolist()  # Python floats: the loop is per island
    xs, ys = [0.0] * count, [0.0] * count
    x = y = shelf = 0.0
    for i in shelves:
        if x > 0 and x + widths[i] > row_width:
            x, y, shelf = 0.0, y + shelf, 0.0
        xs[i], ys[i] = x, y
        x += widths[i]
        shelf = max(shelf, heights[i])
    origin = np.column_stack([xs, ys])
    return uv - lo[island] + origin[island]


def density_spread(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, uv_faces: np.ndarray) -> float:
    """Area-weighted mean of ``max(d, 1/d)``, ``d`` a face's texel density over the mean.

    A face's density is ``sqrt(UV area / 3D area)``; the mean is ``sqrt(sum UV area /
    sum 3D area)``. 1.0 is a uniform density; faces of zero area on either side are
    left out.
    """
    from ..mesh import uv_areas

    a3, auv = areas(vertices, faces), uv_areas(uv, uv_faces)
    ok = (a3 > 0) & (auv > 0)
    if not ok.any():
        return float("inf")
    d = np.sqrt(auv[ok] / a3[ok]) / np.sqrt(auv[ok].sum() / a3[ok].sum())
    return float((a3[ok] * np.maximum(d, 1 / d)).sum() / a3[ok].sum())


def prefer_planar(vertices: np.ndarray, faces: np.ndarray) -> tuple[bool, str]:
    """Whether planar charts suit a mesh better than xatlas' own (the "auto" charting),
    and why.

    Planar for meshes of more than ``XATLAS_FACES`` faces (xatlas' charting then takes
    seconds where planar charts take a fraction of one, at a density spread and
    utilisation as good as Smart UV Project's) and for CAD-like ones: a fifth of the
    area on flat regions, or on slivers (longest edge squared over
    twice the area above 20), where xatlas cuts thousands of charts. A flat region is
    judged by its area alone, at least ``FLAT_REGION`` of the surface, however few its
    triangles (a box's side of two): on an organic mesh a planar quad is far smaller.
    xatlas for small organic meshes: fewer seams and less stretch.
    """
    if len(faces) > XATLAS_FACES:
        return True, f"more than {XATLAS_FACES} faces"
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    tri = vertices[faces]
    normals, area = _face_normals(vertices, faces)
    twice = 2 * area
    total = twice.sum()
    if not total > 0:
        return True, "no area"
    longest = (np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2) ** 2).max(axis=1)
    sliver = float(twice[longest > 20 * np.maximum(twice, 1e-300)].sum() / total)
    a, b = _edge_pairs(faces)
    same = np.einsum("ij,ij->i", normals[a], normals[b]) > COPLANAR_COS
    region = connected_components(len(faces), a[same], b[same])
    region_area = np.bincount(region, weights=twice)[region]
    flat = float(twice[region_area >= FLAT_REGION * total].sum() / total)
    if flat >= 0.2 or sliver >= 0.2:
        return True, f"CAD-like: {flat:.0%} of the area on flat regions, {sliver:.0%} on slivers"
    return False, f"organic: {flat:.0%} of the area on flat regions, {sliver:.0%} on slivers"


def _simplified(points: np.ndarray, tolerance: float) -> np.ndarray:
    """``(j,)`` int64 indices of a closed loop's ``(n, 2)`` points (n >= 3) kept by
    Douglas-Peucker at ``tolerance``, ascending (at least three; ``native/charts.cpp``)."""
    return _native.simplified(np.ascontiguousarray(points, dtype=np.float64), float(tolerance))


def outlines_triangles(uv: np.ndarray, faces: np.ndarray, starts: np.ndarray, tolerance: float,
                       want: np.ndarray) -> tuple[list[np.ndarray | None], list[np.ndarray | None]]:
    """:func:`outline_triangles` of many charts at once: chart ``c`` is ``faces[starts[c]:
    starts[c + 1]]`` (charts sharing no vertex), ``want[c]`` its faces' UV area. The loops are
    walked and simplified for all charts in two compiled calls, each chart's ear-cut alone:
    the same triangles, a tenth of the time on a CAD part's thousand charts. Returns each
    chart's triangles (or None) and their UV areas (or None)."""
    import mapbox_earcut

    from ..mesh import uv_areas

    k = len(starts) - 1
    tris: list[np.ndarray | None] = [None] * k
    got: list[np.ndarray | None] = [None] * k
    ring, lengths, loops = _native.outlines(np.ascontiguousarray(faces, dtype=np.int64),
                                            np.ascontiguousarray(starts, dtype=np.int64))
    if not len(ring):
        return tris, got
    simple = np.flatnonzero(loops >= 0)
    loop_chart = np.repeat(simple, loops[simple])
    loop_start = np.cumsum(lengths) - lengths
    p = uv[ring].astype(np.float64)
    after = np.arange(1, len(ring) + 1)
    after[loop_start + lengths - 1] = loop_start  # each loop's last point is followed by its first
    q = p[after]
    signed = 0.5 * np.add.reduceat(p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1], loop_start)
    d = p - q
    perimeter = np.bincount(loop_chart, np.add.reduceat(np.sqrt((d * d).sum(axis=1)), loop_start), minlength=k)
    want = np.asarray(want, dtype=np.float64)
    tol = np.where(tolerance * perimeter > SIMPLIFY_SLACK * want, 0.0, tolerance)  # a thin chart is kept whole
    kept, counts = _native.simplified_loops(p, lengths, tol[loop_chart])
    kept_start = (np.cumsum(counts) - counts).tolist()
    counts_list = counts.tolist()
    first_loop = np.cumsum(loops[simple]) - loops[simple]
    for c, first, n in zip(simple.tolist(), first_loop.tolist(), loops[simple].tolist(), strict=True):
        if n == 1:
            at = ring[kept[kept_start[first]:kept_start[first] + counts_list[first]]]
            ends = np.array([len(at)], dtype=np.uint32)
        else:  # the outer loop (counter-clockwise, largest) first
            order = (first + np.argsort(-signed[first:first + n], kind="stable")).tolist()
            at = ring[np.concatenate([kept[kept_start[i]:kept_start[i] + counts_list[i]] for i in order])]
            ends = np.cumsum([counts_list[i] for i in order]).astype(np.uint32)
        tri = mapbox_earcut.triangulate_float64(uv[at].astype(np.float64), ends)
        if len(tri):
            tris[c] = at[np.asarray(tri, dtype=np.int64).reshape(-1, 3)]
    made = [(c, t) for c, t in enumerate(tris) if t is not None]
    if not made:
        return tris, got
    areas_all = uv_areas(uv, np.concatenate([t for _, t in made]))
    sizes = np.array([len(t) for _, t in made], dtype=np.int64)
    total = np.add.reduceat(areas_all, np.cumsum(sizes) - sizes)
    faces_of = np.diff(starts)
    for (c, _), a, piece in zip(made, total.tolist(), np.split(areas_all, np.cumsum(sizes)[:-1]), strict=True):
        if abs(a - want[c]) > 1e-9 * max(want[c], 1e-300) * faces_of[c] + tol[c] * perimeter[c]:
            tris[c] = None  # the chart overlaps itself
        else:
            got[c] = piece
    return tris, got


def outline_triangles(uv: np.ndarray, faces: np.ndarray, tolerance: float = 0.0) -> np.ndarray | None:
    """``(t, 3)`` triangles of (nearly) the same region as one chart's ``(m, 3)`` faces into
    ``(k, 2)`` ``uv``, on vertices of its outline only, simplified within ``tolerance``
    (Douglas-Peucker; not for a thin chart: ``SIMPLIFY_SLACK``) and ear-cut
    (mapbox_earcut): a few well-shaped triangles for a region a fan of slivers covers. None
    when the outline is not simple loops (a vertex where the border touches itself) or the
    triangles' area differs from the chart's by more than the simplification allows (the
    chart overlaps itself). One chart of :func:`outlines_triangles`."""
    from ..mesh import uv_areas

    faces = np.asarray(faces, dtype=np.int64)
    want = np.array([uv_areas(uv, faces).sum()])
    return outlines_triangles(uv, faces, np.array([0, len(faces)]), tolerance, want)[0][0]
