"""Surface samples: the point, normal and texel footprint under each texel sample.

A texel sample (face, barycentric coordinates) becomes a surface point in object space
(float64), a unit normal, and the footprint of one texel on the surface: ``dpdx`` and
``dpdy``, the change of the surface point when the sample moves one texel right or one
texel down. They are the columns of the per-face UV-to-surface Jacobian divided by the
image size. A face whose UV triangle is degenerate gets a zero (finite) footprint.
Where a normal map is baked, each sample also gets the output mesh's tangent frame
(``texbake.mesh.tangents``), interpolated as a glTF viewer does. The per-sample pass is
compiled (``native/surface.cpp``; no GIL: the tile threads overlap it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _native
from ..mesh import edges, group_rows, sample_frames, uv_jacobian

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


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted ``(n, 3)`` unit vertex normals, shared by coincident vertices.

    Vertices split at UV seams still get one normal per position, so normals (and the
    transfer rays cast along them) do not break at seams.
    """
    key = group_rows(vertices)[1]
    tri = vertices[faces]
    area_normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    acc = np.zeros((key.max() + 1, 3))
    for corner in range(3):
        np.add.at(acc, key[faces[:, corner]], area_normal)
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    acc = np.divide(acc, length, out=np.zeros_like(acc), where=length > 0)
    return acc[key]


class SurfaceMap:
    """Maps texel samples of an atlas to surface samples.

    ``vertices``: ``(n, 3)`` float64 object-space positions; ``faces``: ``(m, 3)`` int
    indices into ``vertices``; ``uv_faces``: ``(m, 3)`` indices into ``uv`` (``(k, 2)``)
    for the same faces; ``width``, ``height``: image size in texels; ``normals``: also
    interpolate normals: True for smooth ones (:func:`vertex_normals`), or ``(m, 3, 3)``
    corner normals to interpolate (the output mesh's, split at hard edges); ``frame``: ``(corner normals (m, 3, 3), corner tangents
    (m, 3, 4))`` of the output mesh's faces (the same faces, row for row), to interpolate
    its tangent frame.
    """

    def __init__(self, vertices, faces, uv, uv_faces, width: int, height: int, normals: bool | np.ndarray = False,
                 frame: tuple[np.ndarray, np.ndarray] | None = None):
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        self._p0, self._e1, self._e2 = (np.ascontiguousarray(a) for a in edges(vertices, faces))
        dpdu, dpdv, _ = uv_jacobian(vertices, faces, uv, uv_faces)
        # One texel right is du = 1/width; one texel down is dv = -1/height (in place: these
        # are (m, 3) arrays of millions of rows)
        dpdu /= width
        self._dpdx = np.clip(dpdu, -_MAX_FOOTPRINT, _MAX_FOOTPRINT, out=dpdu)
        np.negative(dpdv, out=dpdv)
        dpdv /= height
        self._dpdy = np.clip(dpdv, -_MAX_FOOTPRINT, _MAX_FOOTPRINT, out=dpdv)
        # (m, 3, 3) corner normals, only when asked for (shading and transfer rays need them)
        self._vn: np.ndarray | None = None
        if isinstance(normals, np.ndarray):
            self._vn = np.ascontiguousarray(normals, dtype=np.float64).reshape(len(faces), 3, 3)
        elif normals:
            self._vn = vertex_normals(vertices, faces)[faces]
        self._frame = frame

    def samples(self, face: np.ndarray, bary: np.ndarray, footprints: bool = True) -> SurfaceSamples:
        """Surface samples for ``(n,)`` faces and ``(n, 3)`` barycentric coordinates.

        ``normals`` are interpolated unit normals, or None if the map was made
        without them; ``frame`` likewise; ``dpdx``, ``dpdy`` None unless ``footprints``.
        """
        n = len(face)
        points = np.empty((n, 3))
        dpdx, dpdy = (np.empty((n, 3)), np.empty((n, 3))) if footprints else (None, None)
        normals = None if self._vn is None else np.empty((n, 3))
        _native.interpolate(np.ascontiguousarray(face, dtype=np.int64), np.ascontiguousarray(bary, dtype=np.float64), self._p0,
                            self._e1, self._e2, self._dpdx, self._dpdy, self._vn if self._vn is not None else _NO_NORMALS,
                            points, _NO_SAMPLES if dpdx is None else dpdx, _NO_SAMPLES if dpdy is None else dpdy,
                            normals if normals is not None else _NO_SAMPLES)
        frame = None if self._frame is None else sample_frames(self._frame[0][face], self._frame[1][face], bary)
        return SurfaceSamples(points, normals, dpdx, dpdy, frame)


_NO_NORMALS = np.zeros((0, 3, 3))  # stand-ins for the arrays of a map without normals
_NO_SAMPLES = np.zeros((0, 3))
