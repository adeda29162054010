"""Curvature: the mean curvature ``H`` at each vertex (cotangent Laplacian over the
mixed Voronoi area, Meyer et al. 2003), interpolated to the texels and written as the bakers
write it: ``0.5 + 0.5 clip(H * scale, -1, 1)``, 0.5 flat, above convex, below concave.

``scale`` is a length: a sphere of radius ``r`` gets ``0.5 + 0.5 scale / r``. Vertices are
welded by position first, so that UV seams do not break the Laplacian.
"""

from __future__ import annotations

import numpy as np

from ..mesh import group_rows


def vertex_curvature(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(n,)`` float64 mean curvature (1 / length; positive convex) of each of ``vertices``
    ``(n, 3)``, from ``faces`` ``(m, 3)`` int; 0 where a vertex has no area."""
    vertices = np.asarray(vertices, dtype=np.float64)
    key = np.asarray(group_rows(vertices)[1], dtype=np.int64)
    count = int(key.max()) + 1
    pos = np.zeros((count, 3))
    pos[key] = vertices
    f = key[np.asarray(faces, dtype=np.int64)]
    tri = pos[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    laplacian, area, normal = np.zeros((count, 3)), np.zeros(count), np.zeros((count, 3))
    cot = np.empty((len(f), 3))  # at each corner
    for c in range(3):
        a, b = tri[:, (c + 1) % 3] - tri[:, c], tri[:, (c + 2) % 3] - tri[:, c]
        cot[:, c] = np.divide(np.einsum("ij,ij->i", a, b), double_area, out=np.zeros(len(f)), where=double_area > 0)
    for c in range(3):
        i, j, k = c, (c + 1) % 3, (c + 2) % 3
        edge = 0.5 * cot[:, k, None] * (tri[:, j] - tri[:, i])  # the edge i-j, opposite corner k
        for axis in range(3):
            laplacian[:, axis] += np.bincount(f[:, i], edge[:, axis], count) - np.bincount(f[:, j], edge[:, axis], count)
            normal[:, axis] += np.bincount(f[:, c], cross[:, axis], count)
        area += np.bincount(f[:, i], _mixed_area(tri, cot, double_area, i), count)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    mean = -0.5 * np.einsum("ij,ij->i", laplacian, normal)
    return np.divide(mean, area, out=np.zeros(count), where=area > 0)[key]


def _mixed_area(tri: np.ndarray, cot: np.ndarray, double_area: np.ndarray, i: int) -> np.ndarray:
    """``(m,)`` corner ``i``'s share of each face's area: its Voronoi region where the face
    has no obtuse angle, else half the face (obtuse at ``i``) or a quarter (Meyer et al.)."""
    j, k = (i + 1) % 3, (i + 2) % 3
    voronoi = 0.125 * (np.sum((tri[:, k] - tri[:, i]) ** 2, axis=1) * cot[:, j] + np.sum((tri[:, j] - tri[:, i]) ** 2, axis=1) * cot[:, k])
    obtuse = (cot < 0).any(axis=1)
    return np.where(~obtuse, voronoi, np.where(cot[:, i] < 0, 0.25, 0.125) * double_area)


def curvature_values(curvature: np.ndarray, faces: np.ndarray, face: np.ndarray, bary: np.ndarray, scale: float) -> np.ndarray:
    """``(n, 1)`` float64 map values at texels on ``face`` ``(n,)`` (into ``faces``) at
    ``bary`` ``(n, 3)``, from the per-vertex ``curvature`` (:func:`vertex_curvature`)."""
    h = np.einsum("ij,ij->i", curvature[faces[face]], bary)
    return (0.5 + 0.5 * np.clip(h * scale, -1.0, 1.0))[:, None]
