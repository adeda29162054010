"""Surface samples: the point, normal and texel footprint under each texel sample.

A texel sample (face, barycentric coordinates) becomes a surface point in object space
(float64), a unit normal, and the footprint of one texel on the surface: ``dpdx`` and
``dpdy``, the change of the surface point when the sample moves one texel right or one
texel down. They are the columns of the per-face UV-to-surface Jacobian divided by the
image size. A face whose UV triangle is degenerate gets a zero (finite) footprint.
Where a normal map is baked, each sample also gets the output mesh's tangent frame
(``texbake.mesh.tangents``), interpolated as a glTF viewer does. The per-sample pass is
compiled (``native/surface.cpp``; no GIL: the tile threads overlap it); it reads each
sample's face from the mesh and its atlas and computes its edges and UV Jacobian there, as
:mod:`texbake.mesh.uvgeometry` does (the same bits), where per-face arrays of a mesh of
millions of faces would take hundreds of MB.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _native
from ..mesh import group_rows

# Footprints are clamped to this many object-space units per texel (finite, never NaN).
_MAX_FOOTPRINT = 1e30


@dataclass
class SurfaceSamples:
    """Surface samples; ``n`` rows each."""

    points: np.ndarray  # (n, 3) float64, object space
    normals: np.ndarray | None  # (n, 3) float64, unit length (zero for a degenerate face)
    dpdx: np.ndarray | None  # (n, 3) float64, one texel to the right (None: not asked for)
    dpdy: np.ndarray | None  # (n, 3) float64, one texel down
    frame: np.ndarray | None = None  # (n, 3, 3) float64 rows T, B, N of the output mesh's tangent frame

    def take(self, rows: np.ndarray) -> SurfaceSamples:
        """The samples at ``rows`` (an index or a mask)."""
        def of(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[rows]

        return SurfaceSamples(self.points[rows], of(self.normals), of(self.dpdx), of(self.dpdy), of(self.frame))


def vertex_normals(vertices: np.ndarray, faces: np.ndarray, *, weights: str = "area") -> np.ndarray:
    """``(n, 3)`` unit vertex normals, shared by coincident vertices: the sum of the faces'
    normals, each weighted by its area (``weights="area"``) or by its angle at the vertex
    (``"angle"``: what Blender and Maya give a smooth mesh, so a high-poly source's normals
    are the ones its author saw; on an irregular scan the two differ by degrees).

    Vertices split at UV seams still get one normal per position, so normals (and the
    transfer rays cast along them) do not break at seams.
    """
    key = group_rows(vertices)[1]
    if weights == "angle":  # compiled: in numpy (an angle a corner, three passes) it took 58 ms on 147k faces
        acc = np.empty((int(key.max()) + 1 if len(key) else 0, 3))
        _native.angle_normals(np.ascontiguousarray(vertices, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64),
                              np.ascontiguousarray(key, dtype=np.int64), acc)
        return acc[key]
    if weights != "area":
        raise ValueError(f"weights: expected 'area' or 'angle', got {weights!r}")
    tri = vertices[faces]
    area_normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    corners = key[faces.T.ravel()]  # corner 0 of every face, then 1, then 2: np.add.at's order, its sums
    acc = np.column_stack([np.bincount(corners, np.tile(area_normal[:, a], 3), key.max() + 1) for a in range(3)])
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    acc = np.divide(acc, length, out=np.zeros_like(acc), where=length > 0)
    return acc[key]


class SurfaceMap:
    """Maps texel samples of an atlas to surface samples.

    ``vertices``: ``(n, 3)`` float64 object-space positions; ``faces``: ``(m, 3)`` int
    indices into ``vertices``; ``uv_faces``: ``(m, 3)`` indices into ``uv`` (``(k, 2)``)
    for the same faces; ``width``, ``height``: image size in texels; ``normals``: also
    interpolate normals: True for smooth ones (:func:`vertex_normals`), or corner normals
    to interpolate (the output mesh's, split at hard edges): ``(m, 3, 3)``, or ``(normals
    (q, 3), faces (m, 3) into them)``; ``frame``: ``(corner normals (m, 3, 3), corner tangents
    (m, 3, 4))`` of the output mesh's faces (the same faces, row for row), to interpolate
    its tangent frame.
    """

    def __init__(self, vertices, faces, uv, uv_faces, width: int, height: int,
                 normals: bool | np.ndarray | tuple[np.ndarray, np.ndarray] = False,
                 frame: tuple[np.ndarray, np.ndarray] | None = None):
        # the mesh and its atlas as they are: each sample reads its face (per-face arrays of
        # millions of faces would cost hundreds of MB, and the time to fill them)
        self._vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self._faces = np.ascontiguousarray(faces, dtype=np.int64)
        self._uv = np.ascontiguousarray(uv, dtype=np.float64)
        self._uv_faces = np.ascontiguousarray(uv_faces, dtype=np.int64)
        if self._faces.shape != self._uv_faces.shape:
            raise ValueError(f"SurfaceMap: {len(self._faces)} faces but {len(self._uv_faces)} UV faces")
        self._width, self._height = float(width), float(height)
        # corner normals as (table (q, 3), faces (m, 3) into it), only when asked for
        # (shading and transfer rays need them)
        self._normals: tuple[np.ndarray, np.ndarray] | None = None
        if isinstance(normals, tuple):
            self._normals = (np.ascontiguousarray(normals[0], dtype=np.float64), np.ascontiguousarray(normals[1], dtype=np.int64))
        elif isinstance(normals, np.ndarray):
            table = np.ascontiguousarray(normals, dtype=np.float64).reshape(-1, 3)
            self._normals = (table, np.arange(len(table), dtype=np.int64).reshape(len(self._faces), 3))
        elif normals:
            self._normals = (vertex_normals(self._vertices, self._faces), self._faces)
        self._frame = None if frame is None else (np.ascontiguousarray(frame[0], dtype=np.float64),
                                                  np.ascontiguousarray(frame[1], dtype=np.float64))

    def bends(self, kink: float) -> np.ndarray:
        """``(m,)`` bool: the faces whose steps on the surface one texel right and one down
        (their samples' ``dpdx``, ``dpdy``, unclipped) differ from those of a face sharing a
        UV corner (in their chart: across an edge or a corner), either step by more than
        ``kink`` of the longer of their own: where the surface bends, or its UVs change
        scale. Compiled (``native/surface.cpp`` ``face_bends``): no per-face arrays."""
        out = np.empty(len(self._faces), dtype=bool)
        _native.face_bends(self._vertices, self._faces, self._uv, self._uv_faces, float(self._width), float(self._height),
                           float(kink), out)
        return out

    def steps(self) -> np.ndarray:
        """``(m, 6)`` float64: each face's steps one texel right and one down, its samples'
        ``dpdx`` then ``dpdy`` (the same bits as :meth:`samples` gives them; compiled,
        ``native/surface.cpp`` ``step_table``)."""
        out = np.empty((len(self._faces), 6))
        _native.step_table(self._vertices, self._faces, self._uv, self._uv_faces, self._width, self._height, _MAX_FOOTPRINT, out)
        return out

    def samples(self, face: np.ndarray, bary: np.ndarray, footprints: bool = True) -> SurfaceSamples:
        """Surface samples for ``(n,)`` faces and ``(n, 3)`` barycentric coordinates.

        ``normals`` are interpolated unit normals, or None if the map was made
        without them; ``frame`` likewise; ``dpdx``, ``dpdy`` None unless ``footprints``.
        """
        n = len(face)
        points = np.empty((n, 3))
        dpdx, dpdy = (np.empty((n, 3)), np.empty((n, 3))) if footprints else (None, None)
        normals = None if self._normals is None else np.empty((n, 3))
        table, corners = self._normals if self._normals is not None else (_NO_SAMPLES, _NO_FACES)
        _native.interpolate(np.ascontiguousarray(face, dtype=np.int64), np.ascontiguousarray(bary, dtype=np.float64),
                            self._vertices, self._faces, self._uv, self._uv_faces, self._width, self._height, _MAX_FOOTPRINT,
                            table, corners, points, _NO_SAMPLES if dpdx is None else dpdx,
                            _NO_SAMPLES if dpdy is None else dpdy, normals if normals is not None else _NO_SAMPLES)
        frame = None
        if self._frame is not None:  # mesh.tangents.sample_frames, compiled: no copies of each sample's corners
            frame = np.empty((n, 3, 3))
            _native.sample_frames(np.ascontiguousarray(face, dtype=np.int64), np.ascontiguousarray(bary, dtype=np.float64),
                                  *self._frame, frame)
        return SurfaceSamples(points, normals, dpdx, dpdy, frame)


_NO_FACES = np.zeros((0, 3), dtype=np.int64)  # stand-ins for the arrays of a map without normals
_NO_SAMPLES = np.zeros((0, 3))
