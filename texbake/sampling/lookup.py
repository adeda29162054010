"""Texel lookup: which atlas face lies under each texel sample, and where in it.

The UV triangles are laid flat at z = 0 in an Embree scene (:class:`texbake.sampling.rays.Scene`) and
one vertical ray is cast per texel; the texel's other samples walk from that face across
UV edges to the face that holds them, and only those the walk does not place are cast
(:meth:`UVLookup.locate`). Embree answers only the face; the
barycentric coordinates are then solved in float64 from the sample's UV position, so that
their precision does not depend on Embree's float32 arithmetic.

Image convention: texel ``(row, col)`` of an image of ``width x height`` texels has its
centre at ``u = (col + 0.5) / width``, ``v = 1 - (row + 0.5) / height`` (row 0 at the top,
``v`` up as in OpenGL and trimesh).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np

from ..errors import ParameterError
from ..mesh import group_rows, uv_inverse
from .rays import Scene

_DOWN = np.array([0.0, 0.0, -1.0], dtype=np.float32)  # the direction of every lookup ray


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
    _sample_uv(np.asarray(texels, dtype=np.int64), tile.start, width, height, np.asarray(offsets, dtype=np.float64), out)
    return out


@nb.njit(cache=True, nogil=True)
def _sample_uv(texels, start, width, height, offsets, out):  # pragma: no cover - compiled
    """``out[t * s + k]``: ``((col + dx_k) / width, 1 - (row + dy_k) / height)`` for texel
    ``t`` at ``(row, col)`` of the image (its tile's ``start`` row added). No GIL."""
    s = offsets.shape[0]
    for t in range(texels.shape[0]):
        row = float(texels[t] // width + start)
        col = float(texels[t] % width)
        for k in range(s):
            out[t * s + k, 0] = (col + offsets[k, 0]) / width
            out[t * s + k, 1] = 1.0 - (row + offsets[k, 1]) / height


class UVLookup:
    """Finds the atlas face under UV points with Embree.

    ``uv``: ``(k, 2)`` float UV of atlas vertices; ``faces``: ``(m, 3)`` int indices into
    ``uv``. Faces with zero UV area never match.
    """

    def __init__(self, uv: np.ndarray, faces: np.ndarray):
        uv = np.asarray(uv, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        flat = np.zeros((len(uv), 3), dtype=np.float32)
        flat[:, :2] = uv
        self._scene = Scene(flat, faces, recentre=False)  # UVs in [0, 1]: cast as they are

        # Per-face inverse of the UV edge matrix, for float64 barycentrics.
        self._origin, self._inv, ok = uv_inverse(uv, faces)  # (m, 2), (m, 2, 2), (m,)
        self.degenerate = ~ok
        self._any_degenerate = bool(self.degenerate.any())
        self._across = uv_neighbours(uv, faces, ok)  # (m, 3): the face across each edge
        self._tri = uv[faces][ok]  # (k, 3, 2): the UV triangles a point can lie in
        v = self._tri[:, :, 1]
        self._rows = np.stack([1.0 - v.max(axis=1), 1.0 - v.min(axis=1)], axis=1)  # (k, 2): top and bottom, in image heights

    def candidates(self, tile: Tile, width: int, height: int) -> np.ndarray:
        """Indices of the texels of ``tile`` whose square some face's UV triangle touches
        (:func:`_touched`: exactly, with a margin of ``TOUCH_MARGIN`` texels).

        Only their samples can be hit, so only their rays are cast. Returns ``(t,)``
        int64 texel indices within the tile (row-major).
        """
        rows = tile.stop - tile.start
        top = np.floor(self._rows[:, 0] * height - TOUCH_MARGIN)
        bottom = np.floor(self._rows[:, 1] * height + TOUCH_MARGIN)
        near = np.flatnonzero((bottom >= tile.start) & (top < tile.stop))
        touched = np.zeros(rows * width, dtype=np.bool_)
        _touched(self._tri, near, width, height, tile.start, rows, TOUCH_MARGIN, touched)
        return np.flatnonzero(touched)

    def faces_at(self, uv: np.ndarray) -> np.ndarray:
        """``(n,)`` int32 face under each ``(n, 2)`` UV point, -1 where no face is."""
        n = len(uv)
        origins = np.empty((n, 3), dtype=np.float32)
        origins[:, :2] = uv
        origins[:, 2] = 1.0
        face = self._scene.first_face(origins, _DOWN)
        if self._any_degenerate and face.size:
            face[(face >= 0) & self.degenerate[np.maximum(face, 0)]] = -1
        return face

    def locate(self, uv: np.ndarray, samples: int = 1) -> tuple[np.ndarray, np.ndarray, int]:
        """``(face (n,) int32, barycentric (n, 3) float64, rays cast)`` for ``(n, 2)`` UV
        points that come ``samples`` a texel, contiguous (``sample_uv``'s order); face -1
        (and coordinates 0) where no face is.

        Rays only where needed: one for each texel's first sample; its other samples take
        the face of that sample that contains them, found from it by a short walk across
        UV edges (:func:`_walk`: most lie inside it, the rest in a neighbour); only the
        samples the walk does not place (across a chart's border, or a miss) are cast.
        """
        uv = np.ascontiguousarray(uv, dtype=np.float64)
        bary = np.zeros((len(uv), 3))
        inside = np.zeros(len(uv), dtype=np.bool_)
        if samples == 1:
            face = self.faces_at(uv)
            _barycentric(uv, face, self._origin, self._inv, bary, inside)
            return face, bary, len(uv)
        if len(uv) % samples:
            raise ValueError(f"locate: {len(uv)} points are not whole texels of {samples} samples")
        first = self.faces_at(uv[::samples])
        face = np.repeat(first, samples)
        _walk(uv, face, self._origin, self._inv, self._across, WALK_STEPS, bary, inside)
        inside[::samples] = True  # cast already
        redo = np.flatnonzero(~inside)
        if len(redo):
            again = self.faces_at(uv[redo])
            face[redo] = again
            bary[redo] = self.barycentric(uv[redo], again)
        return face, bary, len(first) + len(redo)

    def barycentric(self, uv: np.ndarray, face: np.ndarray) -> np.ndarray:
        """``(n, 3)`` float64 barycentric coordinates of UV points in their faces.

        Clamped into the triangle (Embree may report a face for a point a rounding
        error outside it).
        """
        bary = np.zeros((len(uv), 3))
        _barycentric(np.ascontiguousarray(uv, dtype=np.float64), np.asarray(face), self._origin, self._inv, bary,
                     np.zeros(len(uv), dtype=np.bool_))
        return bary


def hits(face: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(index (k,) int64, face (k,) int32, bary (k, 3) float64)``: the points of
    :meth:`UVLookup.locate`'s ``(n,)`` ``face`` and ``(n, 3)`` ``bary`` that found a face
    (``face >= 0``), in order; one pass (numpy's ``face[index]``, ``bary[index]`` cost
    a third of a 16-sample lookup)."""
    face = np.ascontiguousarray(face, dtype=np.int32)
    bary = np.ascontiguousarray(bary, dtype=np.float64)
    k = int(np.count_nonzero(face >= 0))
    index, found, coords = np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int32), np.empty((k, 3))
    _hits(face, bary, index, found, coords)
    return index, found, coords


@nb.njit(cache=True, nogil=True)
def _hits(face, bary, index, found, coords):  # pragma: no cover - compiled
    j = 0
    for i in range(face.shape[0]):
        if face[i] >= 0:
            index[j], found[j] = i, face[i]
            coords[j, 0], coords[j, 1], coords[j, 2] = bary[i, 0], bary[i, 1], bary[i, 2]
            j += 1


TOUCH_MARGIN = 1e-3  # texels: a face touches a texel this close (Embree's float32 UVs: 1e-3 texels at 16384)


@nb.njit(cache=True, nogil=True)
def _touched(tri, near, width, height, start, rows, margin, touched):  # pragma: no cover - compiled
    """Set ``touched`` ``(rows * width,)`` where the square of texel ``(r, c)`` of the
    tile from image row ``start`` comes within ``margin`` texels of one of the UV
    triangles ``tri[near]`` (``tri`` ``(k, 3, 2)``, none degenerate). In texel units
    (``x = u * width``, ``y = (1 - v) * height``) a square misses a triangle when it lies
    wholly beyond one of the triangle's edges or outside its box (separating axes). No GIL."""
    xs, ys = np.empty(3), np.empty(3)
    for f in near:
        for k in range(3):
            xs[k] = tri[f, k, 0] * width
            ys[k] = (1.0 - tri[f, k, 1]) * height - start
        area = (xs[1] - xs[0]) * (ys[2] - ys[0]) - (ys[1] - ys[0]) * (xs[2] - xs[0])
        sign = 1.0 if area > 0 else -1.0
        # the box in texels, clamped to the tile as floats (a UV far outside [0, 1] is no integer)
        c0 = int(np.floor(min(max(min(xs[0], xs[1], xs[2]) - margin, 0.0), width - 1.0)))
        c1 = int(np.floor(min(max(max(xs[0], xs[1], xs[2]) + margin, -1.0), width - 1.0)))
        r0 = int(np.floor(min(max(min(ys[0], ys[1], ys[2]) - margin, 0.0), rows - 1.0)))
        r1 = int(np.floor(min(max(max(ys[0], ys[1], ys[2]) + margin, -1.0), rows - 1.0)))
        for r in range(r0, r1 + 1):
            for c in range(c0, c1 + 1):
                x, y = c + 0.5, r + 0.5
                inside = True
                for k in range(3):
                    ax, ay = xs[k], ys[k]
                    ex, ey = xs[(k + 1) % 3] - ax, ys[(k + 1) % 3] - ay
                    reach = 0.5 * (abs(ex) + abs(ey))  # the square's half-extent along the edge's normal
                    if sign * (ex * (y - ay) - ey * (x - ax)) + reach < -margin * 2.0 * reach:
                        inside = False
                        break
                if inside:
                    touched[r * width + c] = True


WALK_STEPS = 4  # faces a sample's walk visits past its texel's first face before a ray is cast


def uv_neighbours(uv: np.ndarray, faces: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """``(m, 3)`` int64: for each face and corner ``c``, the face across the UV edge
    opposite ``c`` (corners ``c + 1``, ``c + 2``), -1 where there is none.

    ``uv``: ``(k, 2)`` float; ``faces``: ``(m, 3)`` int into it; ``usable``: ``(m,)`` bool,
    faces that may be crossed into (not UV-degenerate). Corners are matched by their UV
    position, not their index (an atlas may repeat a vertex along a seam it does not cut);
    an edge of more than two faces (overlapping UVs) links one pair of them.
    """
    m = len(faces)
    across = np.full((m, 3), -1, dtype=np.int64)
    if m == 0:
        return across
    weld = group_rows(np.asarray(uv, dtype=np.float64))[1]  # one id per UV position
    corner = weld.ravel()[np.asarray(faces, dtype=np.int64)]  # (m, 3) welded corners
    a, b = corner[:, [1, 2, 0]].ravel(), corner[:, [2, 0, 1]].ravel()  # edge opposite corner c
    key = np.minimum(a, b) * (int(weld.max()) + 1) + np.maximum(a, b)
    half = np.arange(3 * m)[np.repeat(usable, 3) & (a != b)]
    half = half[np.argsort(key[half], kind="stable")]
    pair = np.flatnonzero(key[half[1:]] == key[half[:-1]])
    lo, hi = half[pair], half[pair + 1]
    across.ravel()[lo] = hi // 3
    across.ravel()[hi] = lo // 3
    return across


@nb.njit(cache=True, nogil=True)
def _walk(uv, face, origin, inv, across, steps, bary, inside):  # pragma: no cover - compiled
    """Each point ``i`` with ``face[i] >= 0``: its barycentrics in that face; if it lies
    outside, the walk steps to the face across the edge it is furthest beyond, at most
    ``steps`` times, and takes the first face that contains it (``face[i]``, ``bary[i]``,
    ``inside[i]`` True). A point the walk does not place keeps its face, clamped
    coordinates in it, and ``inside`` False. No GIL."""
    for i in range(face.shape[0]):
        f = face[i]
        if f < 0:
            continue
        for step in range(steps + 1):
            b0, b1, b2 = _coordinates(uv, i, f, origin, inv)
            if b0 >= 0.0 and b1 >= 0.0 and b2 >= 0.0:
                face[i] = f
                inside[i] = True
                bary[i, 0], bary[i, 1], bary[i, 2] = _clamped(b0, b1, b2)
                break
            if step == 0:  # the texel's face, clamped: what the point keeps if no face is found
                bary[i, 0], bary[i, 1], bary[i, 2] = _clamped(b0, b1, b2)
            c = 0 if b0 <= b1 and b0 <= b2 else (1 if b1 <= b2 else 2)
            f = across[f, c]
            if f < 0:
                break


@nb.njit(cache=True, nogil=True, inline="always")
def _coordinates(uv, i, f, origin, inv):  # pragma: no cover - compiled
    """``(b0, b1, b2)``: point ``i`` of ``uv`` in face ``f`` (:func:`uv_inverse`'s ``origin``, ``inv``), unclamped."""
    dx, dy = uv[i, 0] - origin[f, 0], uv[i, 1] - origin[f, 1]
    b1 = inv[f, 0, 0] * dx + inv[f, 0, 1] * dy
    b2 = inv[f, 1, 0] * dx + inv[f, 1, 1] * dy
    return 1.0 - b1 - b2, b1, b2


@nb.njit(cache=True, nogil=True, inline="always")
def _clamped(b0, b1, b2):  # pragma: no cover - compiled
    """Barycentrics clamped into the triangle and renormalised."""
    b0, b1, b2 = min(max(b0, 0.0), 1.0), min(max(b1, 0.0), 1.0), min(max(b2, 0.0), 1.0)
    total = b0 + b1 + b2
    return b0 / total, b1 / total, b2 / total


@nb.njit(cache=True, nogil=True)
def _barycentric(uv, face, origin, inv, bary, inside):  # pragma: no cover - compiled
    """Fill ``bary`` (n, 3) with each point's coordinates in its face, clamped into the
    triangle and renormalised, and ``inside`` (n,) with whether the point lies in it
    unclamped; rows of face -1 are left as they are. No GIL: tiles overlap."""
    for i in range(face.shape[0]):
        f = face[i]
        if f < 0:
            continue
        b0, b1, b2 = _coordinates(uv, i, f, origin, inv)
        inside[i] = b0 >= 0.0 and b1 >= 0.0 and b2 >= 0.0
        bary[i, 0], bary[i, 1], bary[i, 2] = _clamped(b0, b1, b2)
