"""Texel lookup: which atlas face lies under each texel sample, and where in it.

Each texel's first sample is located through a uniform grid over the UV triangles (each
face listed in the cells its UV box overlaps; a point is in the first face of its cell
that holds it, by edge tests that leave no gap along a shared edge); the texel's other
samples walk from that face across UV edges to the face that holds them, and only those
the walk does not place are located through the grid again (:meth:`UVLookup.locate`).
The barycentric coordinates are solved in float64 from the sample's UV position. No ray
is cast: the grid is built in time linear in the faces (an Embree scene of the flat UV
layout, which this replaced, cost a BVH build that grew faster than the faces, and 80 ns
a ray). The per-sample loops are compiled (``native/lookup.cpp``; no GIL: the tile
threads overlap them).

Image convention: texel ``(row, col)`` of an image of ``width x height`` texels has its
centre at ``u = (col + 0.5) / width``, ``v = 1 - (row + 0.5) / height`` (row 0 at the top,
``v`` up as in OpenGL and trimesh).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from .. import _native
from ..errors import ParameterError
from ..mesh import uv_dets

HULL = 8  # corners of a cut texel's hull at most (native/lookup.cpp)
_NO_STEPS = np.zeros((0, 6))  # texel_parts without a face's steps: every part of a texel that bends is kept


def sample_offsets(samples: int, seed: int = 0) -> np.ndarray:
    """Stratified sample positions inside one texel.

    Returns ``(samples, 2)`` float64 offsets in ``[0, 1)`` from the texel's corner
    (x right, y down). One sample is the texel centre; a square count ``k * k`` is a
    jittered ``k x k`` grid; any other count is a jittered n-rooks (Latin hypercube) set.
    The same ``seed`` gives the same offsets for every texel (and every run).
    """
    if samples < 1:
        raise ParameterError("samples", f"must be at least 1, got {samples}")
    if samples == 1:
        return np.array([[0.5, 0.5]])
    rng = np.random.default_rng(seed)
    k = int(round(np.sqrt(samples)))
    if k * k == samples:
        gy, gx = np.mgrid[0:k, 0:k]
        cells = np.stack([gx.ravel(), gy.ravel()], axis=1).astype(np.float64)
        return (cells + rng.random((samples, 2))) / k
    rows = np.stack([rng.permutation(samples), rng.permutation(samples)], axis=1)
    return (rows + rng.random((samples, 2))) / samples


@dataclass
class Tile:
    """A block of whole image rows: ``rows`` is the half-open range ``[start, stop)``."""

    start: int
    stop: int


MIN_TILES = 16  # the tile threads share the work evenly: a chart-dense band is one of many


def tiles(height: int, width: int, samples: int, budget: int = 1 << 20) -> list[Tile]:
    """Split an image into row blocks of at most about ``budget`` samples each (bounded
    memory), and at least ``MIN_TILES`` of them where the image has the rows (4 tiles of a
    2048² 1-sample bake left one thread idle for a quarter of the tiles' time)."""
    rows = max(1, min(budget // max(1, width * samples), -(-height // MIN_TILES)))
    return [Tile(r, min(height, r + rows)) for r in range(0, height, rows)]


def sample_uv(tile: Tile, texels: np.ndarray, width: int, height: int, offsets: np.ndarray) -> np.ndarray:
    """UV positions of the samples of some texels of ``tile``.

    ``texels``: ``(t,)`` int indices of texels within the tile (row-major, ``width``
    per row); ``offsets``: ``(s, 2)`` float (:func:`sample_offsets`). Returns
    ``(t * s, 2)`` float64, texel-major: the ``s`` samples of a texel are contiguous.
    """
    out = np.empty((len(texels) * len(offsets), 2))
    _native.sample_uv(np.ascontiguousarray(texels, dtype=np.int64), tile.start, width, height,
                      np.ascontiguousarray(offsets, dtype=np.float64), out)
    return out


class UVLookup:
    """Finds the atlas face under UV points (a grid over the UV triangles: :class:`UVGrid`).

    ``uv``: ``(k, 2)`` float UV of atlas vertices; ``faces``: ``(m, 3)`` int indices into
    ``uv``. Faces with zero UV area never match.
    """

    def __init__(self, uv: np.ndarray, faces: np.ndarray):
        self._uv = np.ascontiguousarray(uv, dtype=np.float64)
        self._faces = np.ascontiguousarray(faces, dtype=np.int64)
        # The barycentrics are solved in float64 from each face's UV corners (the inverse of
        # its UV edge matrix, as uv_inverse has it), read where a sample needs them.
        ok = np.abs(uv_dets(self._uv, self._faces)) > 0  # (m,): not UV-degenerate
        self.degenerate = ~ok
        self._any_degenerate = bool(self.degenerate.any())
        self._usable = ok if self._any_degenerate else None  # faces a texel may be touched by
        self._across = uv_neighbours(self._uv, self._faces, ok)  # (m, 3): the face across each edge
        self._grid = UVGrid(self._uv, self._faces, ok)
        self._row_ranges: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._borders: dict[tuple[int, int], np.ndarray] = {}
        self._chart: np.ndarray | None = None  # (m,) int64 each face's chart (_cells), made on first use
        self._lock = threading.Lock()

    def candidates(self, tile: Tile, width: int, height: int) -> np.ndarray:
        """Indices of the texels of ``tile`` whose square some face's UV triangle touches
        (exactly, with a margin of ``TOUCH_MARGIN`` texels: in texel units a square misses
        a triangle when it lies wholly beyond one of the triangle's edges or outside its
        box, the separating axes).

        Only their samples can be hit, so only their rays are cast. Returns ``(t,)``
        int64 texel indices within the tile (row-major).
        """
        rows = tile.stop - tile.start
        top, bottom = self._row_range(height)
        near = (bottom >= tile.start) & (top < tile.stop)
        if self._usable is not None:
            near &= self._usable
        touched = np.zeros(rows * width, dtype=np.bool_)
        _native.touched(self._uv, self._faces, np.flatnonzero(near), width, height, tile.start, rows, TOUCH_MARGIN, touched)
        return np.flatnonzero(touched)

    def _row_range(self, height: int) -> tuple[np.ndarray, np.ndarray]:
        """``(top, bottom)``, ``(k,)`` float64: the first and last texel row each UV triangle
        touches in an image ``height`` rows high; made once a height (every tile reads them)."""
        with self._lock:
            found = self._row_ranges.get(height)
            if found is None:
                found = (np.empty(len(self._faces)), np.empty(len(self._faces)))
                _native.row_range(self._uv, self._faces, height, TOUCH_MARGIN, *found)
                self._row_ranges[height] = found
            return found

    def _border(self, width: int, height: int) -> np.ndarray:
        """``(k,)`` int64 sorted: the texels (row-major) of a ``width x height`` image that a
        chart's border (a UV edge with no face across it) touches; made once a size."""
        with self._lock:
            found = self._borders.get((width, height))
            if found is None:
                usable = ~self.degenerate
                found = _native.border_texels(self._uv, self._faces, self._across, usable, width, height)
                self._borders[(width, height)] = found
            return found

    @property
    def across(self) -> np.ndarray:
        """``(m, 3)`` int64: the face across each face's UV edges (:func:`uv_neighbours`)."""
        return self._across

    def _cells(self) -> tuple:
        """``(chart, box, nx, ny, start, listed)``: each face's chart (faces joined across UV
        edges; made once) and the UV grid's cells, for the footprint's cut
        (``native/lookup.cpp`` ``chart_part``)."""
        with self._lock:
            if self._chart is None:
                face, corner = np.nonzero(self._across >= 0)
                chart = np.empty(len(self._faces), dtype=np.int64)
                _native.labels(len(self._faces), face.astype(np.int64), self._across[face, corner], chart)
                self._chart = chart
        return (self._chart, *self._grid.cells())

    def faces_at(self, uv: np.ndarray) -> np.ndarray:
        """``(n,)`` int32 face under each ``(n, 2)`` UV point, -1 where no face is."""
        return self._grid.faces_at(uv)

    def locate(self, uv: np.ndarray, samples: int = 1) -> tuple[np.ndarray, np.ndarray, int]:
        """``(face (n,) int32, barycentric (n, 3) float64, searches)`` for ``(n, 2)`` UV
        points that come ``samples`` a texel, contiguous (``sample_uv``'s order); face -1
        (and coordinates 0) where no face is.

        Searches only where needed: one for each texel's first sample; its other samples take
        the face of that sample that contains them, found from it by a short walk across
        UV edges (most lie inside it, the rest in a neighbour: at each step the walk crosses
        the edge the sample is furthest beyond, at most ``WALK_STEPS`` times, and takes the
        first face that holds it); only the samples the walk does not place (across a
        chart's border, or a miss) are cast.
        """
        uv = np.ascontiguousarray(uv, dtype=np.float64)
        bary = np.zeros((len(uv), 3))
        inside = np.zeros(len(uv), dtype=np.bool_)
        if samples == 1:
            face = self.faces_at(uv)
            _native.barycentric(uv, face, self._uv, self._faces, bary, inside)
            return face, bary, len(uv)
        if len(uv) % samples:
            raise ValueError(f"locate: {len(uv)} points are not whole texels of {samples} samples")
        first = self.faces_at(uv[::samples])
        face = np.repeat(first, samples).astype(np.int32, copy=False)
        _native.walk(uv, face, self._uv, self._faces, self._across, WALK_STEPS, bary, inside)
        inside[::samples] = True  # cast already
        redo = np.flatnonzero(~inside)
        if len(redo):
            again = self.faces_at(uv[redo])
            face[redo] = again
            bary[redo] = self.barycentric(uv[redo], again)
        return face, bary, len(first) + len(redo)

    def footprint_clip(self, face: np.ndarray, bary: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """The part of each sample's texel that its chart covers, for samples one a texel.

        ``face`` ``(n,)`` int32 and ``bary`` ``(n, 3)`` float64 (:meth:`locate`'s, found
        faces only); ``width``, ``height``: the image. The faces of a sample's chart (faces
        joined across UV edges) that wind as its face does and overlap its texel are cut to
        the texel's square, also those of its chart not reached across the texel's own edges
        (a scan's crack, where a chart's two sides meet in one texel: bunny.ply at 512²
        has 164 such texels, the walk across edges took 63 % of one for a whole texel's
        part and 22 % of a filtered wood's squared error sat there); their union is replaced
        by the box of the same centre and covariance (exact for a rectangle, as where a
        chart's straight edge crosses the texel). Returns ``(shift (n, 2), edges (n, 2, 2),
        area (n,), partial)``, in texel units, x right and y down: the box's centre from the
        texel's centre, its edges as columns (the identity for a whole texel), the covered
        share (1 for a whole texel), and how many are partly covered (``native/lookup.cpp``
        ``footprint_clip``).
        """
        n = len(face)
        shift, edges, area = np.empty((n, 2)), np.empty((n, 4)), np.empty(n)
        partial = _native.footprint_clip(np.ascontiguousarray(face, dtype=np.int32), np.ascontiguousarray(bary, dtype=np.float64),
                                         self._uv, self._faces, *self._cells(), self._border(width, height), width, height,
                                         shift, edges, area)
        return shift, edges.reshape(n, 2, 2), area, int(partial)

    def texel_parts(self, face: np.ndarray, bary: np.ndarray, width: int, height: int, least: float, bends: np.ndarray,
                    steps: np.ndarray | None = None, kink: float = 0.0):
        """The part of each sample's texel in each face of its chart, for samples one a texel
        on a face that ``bends`` (``(m,)`` bool) whose texel the chart covers whole over two
        faces or more (``native/lookup.cpp``
        ``texel_parts``; parts under ``least`` of the texel left out, the others' shares
        renormalised); given ``steps`` (``(m, 6)``, each face's ``dpdx``, ``dpdy``:
        ``SurfaceMap.steps``), only for texels with a part whose face's steps differ from the
        sample's face's, either of them, by more than ``kink`` of its longer one. Returns
        ``(sample (k,) int64, face (k,) int32, share (k,), uv (k, 2), edges (k, 2, 2))``:
        each part's sample (a row of ``face``), face, share of the texel, centre, and its
        box's edges as columns, in texel units (as :meth:`footprint_clip`'s); a sample's
        parts together."""
        sample, part_face, share, uv, edges = _native.texel_parts(
            np.ascontiguousarray(face, dtype=np.int32), np.ascontiguousarray(bary, dtype=np.float64), self._uv, self._faces,
            *self._cells(), np.ascontiguousarray(bends, dtype=bool), width, height, float(least),
            _NO_STEPS if steps is None else np.ascontiguousarray(steps, dtype=np.float64), float(kink))
        return sample, part_face, share, uv, edges.reshape(-1, 2, 2)

    def footprint_hull(self, face: np.ndarray, bary: np.ndarray, width: int, height: int, shift: np.ndarray,
                       edges: np.ndarray) -> np.ndarray:
        """``(n, HULL, 2)`` float64: the convex hull of the part of each sample's texel that
        its chart covers, for samples that :meth:`footprint_clip` found partly covered
        (``shift``, ``edges``: its rows for them). Corners ``(a, b)`` in the frame of the
        cut footprint (its point plus ``a dpdx + b dpdy``, as cut), counter-clockwise,
        NaN after the last; a row all NaN where the hull has more than ``HULL`` corners
        (``native/lookup.cpp`` ``footprint_hull``). A filter that bounds its footprint by
        these corners averages nothing across the chart's border, where the box of the
        same centre and covariance reaches over it (a border slanting across the texel).
        """
        out = np.empty((len(face), HULL, 2))
        _native.footprint_hull(np.ascontiguousarray(face, dtype=np.int32), np.ascontiguousarray(bary, dtype=np.float64),
                               self._uv, self._faces, *self._cells(), width, height,
                               np.ascontiguousarray(shift, dtype=np.float64), np.ascontiguousarray(edges, dtype=np.float64).reshape(-1, 4),
                               out)
        return out

    def barycentric(self, uv: np.ndarray, face: np.ndarray) -> np.ndarray:
        """``(n, 3)`` float64 barycentric coordinates of UV points in their faces.

        Clamped into the triangle (a point on an edge may lie a rounding error outside
        it).
        """
        bary = np.zeros((len(uv), 3))
        _native.barycentric(np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(face, dtype=np.int32),
                            self._uv, self._faces, bary, np.zeros(len(uv), dtype=np.bool_))
        return bary


GRID_ENTRIES, GRID_ENTRIES_FREE = 64, 1 << 20  # entries a face (and in all) past which UVGrid's cells are made larger


class UVGrid:
    """A uniform grid over UV triangles for point location, built in time linear in the faces.

    ``uv``: ``(k, 2)`` float64; ``faces``: ``(m, 3)`` int64 into it; ``usable``: ``(m,)``
    bool, the faces that may hold a point (not UV-degenerate). About one cell a face, over
    the UVs' bounding box, in its aspect ratio; each usable face is listed in the cells its
    UV triangle touches (not its box's: a fan of slivers would list each in half its disc) (``native/lookup.cpp``: ``grid_count``, ``grid_fill``). A point is in
    the first listed face of its cell whose triangle holds it (on an edge: either face),
    -1 where none does (outside every triangle, or outside the box).
    """

    def __init__(self, uv: np.ndarray, faces: np.ndarray, usable: np.ndarray):
        self._uv, self._faces = uv, faces
        m = max(1, int(np.count_nonzero(usable)))
        finite = uv[np.isfinite(uv).all(axis=1)] if len(uv) else uv
        lo = finite.min(axis=0) if len(finite) else np.zeros(2)
        extent = np.maximum((finite.max(axis=0) if len(finite) else np.ones(2)) - lo, 1e-300)
        nx = int(np.clip(np.ceil(np.sqrt(m * extent[0] / extent[1])), 1, m))
        ny = int(np.clip(np.ceil(m / nx), 1, m))
        usable = np.ascontiguousarray(usable, dtype=bool)
        while True:
            self._box = (float(lo[0]), float(lo[1]), nx / float(extent[0]), ny / float(extent[1]), nx, ny)
            self._start = np.empty(nx * ny + 1, dtype=np.int64)
            _native.grid_count(uv, faces, usable, *self._box, self._start)
            # A mesh lists 2-5 entries a face; long slivers list one a cell along them (a
            # cylinder cap of 200k segments: 186M, 0.7 GB): cells twice as wide halve that
            if self._start[-1] <= GRID_ENTRIES * m + GRID_ENTRIES_FREE or nx * ny == 1:
                break
            nx, ny = max(1, nx // 2), max(1, ny // 2)
        self._listed = np.empty(int(self._start[-1]), dtype=np.int32)
        _native.grid_fill(uv, faces, usable, *self._box, self._start, self._listed)

    def cells(self) -> tuple:
        """``(box (4,) float64, nx, ny, start, listed)``: the grid as the compiled kernels read
        it (``native/lookup.cpp`` ``grid_of``): its origin and inverse cell sizes, its cells a
        side, each cell's start in ``listed`` and the faces listed."""
        return np.array(self._box[:4], dtype=np.float64), self._box[4], self._box[5], self._start, self._listed

    def faces_at(self, points: np.ndarray) -> np.ndarray:
        """``(n,)`` int32 face under each ``(n, 2)`` UV point, -1 where no face is."""
        face = np.empty(len(points), dtype=np.int32)
        _native.grid_locate(np.ascontiguousarray(points, dtype=np.float64), self._uv, self._faces, *self._box, self._start,
                            self._listed, face)
        return face


def hits(face: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(index (k,) int64, face (k,) int32, bary (k, 3) float64)``: the points of
    :meth:`UVLookup.locate`'s ``(n,)`` ``face`` and ``(n, 3)`` ``bary`` that found a face
    (``face >= 0``), in order; one pass (numpy's ``face[index]``, ``bary[index]`` cost
    a third of a 16-sample lookup)."""
    face = np.ascontiguousarray(face, dtype=np.int32)
    bary = np.ascontiguousarray(bary, dtype=np.float64)
    k = int(np.count_nonzero(face >= 0))
    index, found, coords = np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int32), np.empty((k, 3))
    _native.hits(face, bary, index, found, coords)
    return index, found, coords


TOUCH_MARGIN = 1e-3  # texels: a face touches a texel this close (a rounding error of the UVs at 16384 texels is far less)


WALK_STEPS = 4  # faces a sample's walk visits past its texel's first face before a ray is cast


def uv_neighbours(uv: np.ndarray, faces: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """``(m, 3)`` int64: for each face and corner ``c``, the face across the UV edge
    opposite ``c`` (corners ``c + 1``, ``c + 2``), -1 where there is none.

    ``uv``: ``(k, 2)`` float; ``faces``: ``(m, 3)`` int into it; ``usable``: ``(m,)`` bool,
    faces that may be crossed into (not UV-degenerate). Corners are matched by their UV
    position, not their index (an atlas may repeat a vertex along a seam it does not cut);
    an edge of more than two faces (overlapping UVs) links each with the next in their
    order. Compiled (``native/grouping.cpp``: linear).

    A fold is not crossed: two faces of opposite UV winding across an edge (one lies on
    the other, as a scan's folded or doubled faces do) are -1 to each other. Crossed, the
    filter's cut of a texel at the fold (``footprint_clip``) counted the covered part twice
    and took a texel the fold covers in half for a whole one, and no chart border was seen
    there (bunny.ply, 512², one filtered wood sample: 228 such texels, a tenth of the
    squared error). A chart mirrored whole keeps its edges: its faces wind alike.
    """
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    across = np.empty((len(faces), 3), dtype=np.int64)
    _native.uv_neighbours(uv, faces, np.ascontiguousarray(usable, dtype=bool), across)
    if len(faces):
        winding = np.sign(uv_dets(uv, faces))
        linked = across >= 0
        fold = linked & (winding[:, None] != winding[np.where(linked, across, 0)])
        across[fold] = -1
    return across
