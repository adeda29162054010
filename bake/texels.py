"""Texel lookup: which atlas face lies under each texel sample, and where in it.

The UV triangles are laid flat at z = 0 in an Embree scene (:class:`bake.rays.Scene`) and
one vertical ray is cast per texel, and for the samples of a texel that lie outside its
first sample's face (:meth:`UVLookup.locate`). Embree answers only the face; the
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

from .errors import ParameterError
from .rays import Scene
from .uvgeometry import uv_inverse

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


def tiles(height: int, width: int, samples: int, budget: int = 1 << 20) -> list[Tile]:
    """Split an image into row blocks of about ``budget`` samples each (bounded memory)."""
    rows = max(1, budget // max(1, width * samples))
    return [Tile(r, min(height, r + rows)) for r in range(0, height, rows)]


def sample_uv(tile: Tile, texels: np.ndarray, width: int, height: int, offsets: np.ndarray) -> np.ndarray:
    """UV positions of the samples of some texels of ``tile``.

    ``texels``: ``(t,)`` int indices of texels within the tile (row-major, ``width``
    per row). Returns ``(t * s, 2)`` float64, texel-major: the ``s`` samples of a texel
    are contiguous.
    """
    row = (texels // width + tile.start).astype(np.float64)
    col = (texels % width).astype(np.float64)
    x = (col[:, None] + offsets[None, :, 0]).ravel()
    y = (row[:, None] + offsets[None, :, 1]).ravel()
    return np.stack([x / width, 1.0 - y / height], axis=1)


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
        t = uv[faces]  # (m, 3, 2)
        lo, hi = t.min(axis=1), t.max(axis=1)
        self._box = np.stack([lo[:, 0], hi[:, 0], 1.0 - hi[:, 1], 1.0 - lo[:, 1]], axis=1)[ok]

    def candidates(self, tile: Tile, width: int, height: int) -> np.ndarray:
        """Indices of the texels of ``tile`` that some face's UV bounding box touches.

        Only these can be hit, so only their rays are cast. Returns ``(t,)`` int64
        texel indices within the tile (row-major).
        """
        rows = tile.stop - tile.start
        x0, x1, y0, y1 = self._box.T
        r0 = np.floor(y0 * height).astype(np.int64) - tile.start
        r1 = np.floor(y1 * height).astype(np.int64) - tile.start
        near = (r1 >= 0) & (r0 < rows)
        r0, r1 = np.clip(r0[near], 0, rows - 1), np.clip(r1[near], 0, rows - 1)
        c0 = np.clip(np.floor(x0[near] * width).astype(np.int64), 0, width - 1)
        c1 = np.clip(np.floor(x1[near] * width).astype(np.int64), 0, width - 1)
        # 2D difference array of the boxes, summed up: > 0 where any box lies
        diff = np.zeros((rows + 1) * (width + 1), dtype=np.int32)
        stride = width + 1
        for r, c, sign in ((r0, c0, 1), (r0, c1 + 1, -1), (r1 + 1, c0, -1), (r1 + 1, c1 + 1, 1)):
            np.add.at(diff, r * stride + c, sign)
        cover = diff.reshape(rows + 1, stride).cumsum(axis=0).cumsum(axis=1)[:rows, :width]
        return np.flatnonzero(cover > 0)

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

        Rays only where needed: one for each texel's first sample; its other samples that
        lie inside that face (by their float64 barycentrics: most of them) take it without
        a ray, and only the rest are cast.
        """
        uv = np.ascontiguousarray(uv, dtype=np.float64)
        bary = np.zeros((len(uv), 3))
        inside = np.zeros(len(uv), dtype=np.bool_)
        if samples == 1:
            face = self.faces_at(uv)
            _barycentric(uv, face, self._origin, self._inv, bary, inside)
            return face, bary, len(uv)
        first = self.faces_at(uv[::samples])
        face = np.repeat(first, samples)
        _barycentric(uv, face, self._origin, self._inv, bary, inside)
        inside[::samples] = True  # cast already
        redo = np.flatnonzero(~inside)
        if len(redo):
            again = self.faces_at(uv[redo])
            face[redo] = again
            b = np.zeros((len(redo), 3))
            _barycentric(uv[redo], again, self._origin, self._inv, b, np.zeros(len(redo), dtype=np.bool_))
            bary[redo] = b
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


@nb.njit(cache=True, nogil=True)
def _barycentric(uv, face, origin, inv, bary, inside):  # pragma: no cover - compiled
    """Fill ``bary`` (n, 3) with each point's coordinates in its face, clamped into the
    triangle and renormalised, and ``inside`` (n,) with whether the point lies in it
    unclamped; rows of face -1 are left as they are. No GIL: tiles overlap."""
    for i in range(face.shape[0]):
        f = face[i]
        if f < 0:
            continue
        dx, dy = uv[i, 0] - origin[f, 0], uv[i, 1] - origin[f, 1]
        b1 = inv[f, 0, 0] * dx + inv[f, 0, 1] * dy
        b2 = inv[f, 1, 0] * dx + inv[f, 1, 1] * dy
        b0 = 1.0 - b1 - b2
        inside[i] = b0 >= 0.0 and b1 >= 0.0 and b2 >= 0.0
        b0, b1, b2 = min(max(b0, 0.0), 1.0), min(max(b1, 0.0), 1.0), min(max(b2, 0.0), 1.0)
        total = b0 + b1 + b2
        bary[i, 0], bary[i, 1], bary[i, 2] = b0 / total, b1 / total, b2 / total
