"""Triangle geometry of a mesh and its UV atlas: edges, areas, the UV Jacobian.

One place for what the atlas checks, the unwrap worker, the texel lookup and the
surface map all need. Inputs are cast to float64 (points) and int64 (indices); every
array returned is float64 and has one row per face. For a face with corners ``p0, p1,
p2`` at UV corners ``t0, t1, t2`` the edges are ``e1 = p1 - p0``, ``e2 = p2 - p0`` and
``d1 = t1 - t0``, ``d2 = t2 - t0``; ``det = d1 x d2 = d1_u d2_v - d1_v d2_u`` is twice
the signed UV area (positive for a counter-clockwise UV triangle). A face is UV-degenerate
where ``det`` is zero (or NaN): its inverse and its Jacobian are zero there, never
infinite.

The per-face passes are compiled (``native/geometry.cpp``: one pass on the cores, no
``(m, 3, d)`` temporaries), with numpy's operations in numpy's order, so the arrays are
the bits the numpy expressions in the docstrings give. The unwrap worker process
(``texbake.atlas.packworker``) imports this module too: it loads the compiled kernels and
numpy, nothing heavier.
"""

from __future__ import annotations

import numpy as np

from .. import _native


def _faces(faces: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(faces, dtype=np.int64)


def _points(points: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(points, dtype=np.float64)


def edges(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(p0, e1, e2)``, each ``(m, d)`` float64: a face's first corner and its two edges
    from it, for ``(n, d)`` points (3D positions or 2D UVs) and ``(m, 3)`` int faces:
    ``points[faces[:, 0]]``, ``points[faces[:, 1]] - p0``, ``points[faces[:, 2]] - p0``."""
    points, faces = _points(points), _faces(faces)
    p0, e1, e2 = (np.empty((len(faces), points.shape[1])) for _ in range(3))
    _native.face_edges(points, faces, p0, e1, e2)
    return p0, e1, e2


def uv_edges(uv: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(d1 (m, 2), d2 (m, 2), det (m,))`` float64: the UV edge matrix ``[d1 d2]`` of
    each face and its determinant, for ``(k, 2)`` UVs and ``(m, 3)`` int faces into them."""
    _, d1, d2 = edges(uv, faces)
    return d1, d2, _cross2(d1, d2)


def _cross2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def uv_dets(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` float64 ``det`` of :func:`uv_edges` alone (twice the signed UV area)."""
    faces = _faces(faces)
    det = np.empty(len(faces))
    _native.uv_dets(_points(uv), faces, det)
    return det


def inverse_det(det: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(1 / det, ok)``, ``(m,)`` float64 and bool: ``ok`` where ``|det| > 0``, and 0
    instead of the reciprocal elsewhere."""
    ok = np.abs(det) > 0
    return np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0), ok


def uv_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` float64 unsigned UV area of each face (``|det| / 2``)."""
    return 0.5 * np.abs(uv_dets(uv, faces))


def label_boxes(uv: np.ndarray, faces: np.ndarray, label: np.ndarray, count: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)`` ``(count, 2)``: the bounding box of each label's faces' corners in ``uv``
    (``label`` ``(m,)`` int, one a face; ``count`` labels, by default ``label.max() + 1``;
    a label without faces gets ``inf`` and ``-inf``)."""
    label = np.ascontiguousarray(label, dtype=np.int64)
    k = (int(label.max()) + 1 if len(label) else 0) if count is None else count
    lo, hi = np.full((k, 2), np.inf), np.full((k, 2), -np.inf)
    _native.label_boxes(np.ascontiguousarray(uv, dtype=np.float64), _faces(faces), label, lo, hi)
    return lo, hi


def areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` float64 area of each triangle of ``(n, 3)`` vertices (``|e1 x e2| / 2``:
    ``0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)``)."""
    faces = _faces(faces)
    out = np.empty(len(faces))
    _native.face_areas(_points(vertices), faces, out)
    return out


def uv_inverse(uv: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t0 (m, 2), inv (m, 2, 2), ok (m,))``: each face's first UV corner and the
    inverse of its UV edge matrix ``[d1 d2]``, so that a UV point ``t`` of the face has
    barycentric coordinates ``(1 - b1 - b2, b1, b2)`` with ``(b1, b2) = inv @ (t - t0)``.
    ``inv`` is zero where ``ok`` is False (a UV-degenerate face)."""
    faces = _faces(faces)
    m = len(faces)
    t0, inv, ok = np.empty((m, 2)), np.empty((m, 2, 2)), np.empty(m, dtype=bool)
    _native.uv_inverse(_points(uv), faces, t0, inv, ok)
    return t0, inv, ok


def uv_jacobian(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray,
                uv_faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(dpdu (m, 3), dpdv (m, 3), det (m,))`` float64: the UV-to-surface Jacobian of
    each face, from ``[e1 e2] = [dP/du dP/dv] [d1 d2]``, and the UV determinant.

    ``vertices`` ``(n, 3)`` with ``faces`` ``(m, 3)`` and ``uv`` ``(k, 2)`` with
    ``uv_faces`` ``(m, 3)``: the same faces, row for row. Zero where the face is
    UV-degenerate.
    """
    faces, uv_faces = _faces(faces), _faces(uv_faces)
    m = len(faces)
    if len(uv_faces) != m:
        raise ValueError(f"uv_jacobian: {m} faces but {len(uv_faces)} UV faces")
    dpdu, dpdv, det = np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
    _native.uv_jacobian(_points(vertices), faces, _points(uv), uv_faces, dpdu, dpdv, det)
    return dpdu, dpdv, det
