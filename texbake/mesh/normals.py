"""Shading normals of the output mesh: smooth across soft edges, split at hard edges.

As Blender's auto smooth: the faces around a position fall into fans joined across the
edges where they meet at less than ``angle`` degrees; each fan's corners share one normal,
the area-weighted mean of its faces' normals. Positions are matched exactly, so the
vertices an atlas splits at a UV seam stay smooth; a vertex is split where corners of
two fans (a hard edge) used it.
"""

from __future__ import annotations

import numpy as np

from .components import connected_components
from .uvgeometry import edges

HARD_EDGE_DEGREES = 60.0


def split_normals(vertices: np.ndarray, faces: np.ndarray, angle: float = HARD_EDGE_DEGREES):
    """Per-vertex normals, with vertices split at hard edges.

    ``vertices``: ``(k, 3)`` float; ``faces``: ``(m, 3)`` int indices into them. Returns
    ``(source (k2,) int64, faces (m, 3) int64, normals (k2, 3) float64)``: new vertex ``i``
    is old vertex ``source[i]`` (``k2 >= k``: a vertex on a hard edge is one per fan), the
    faces index the new vertices, and the normals are unit length (+z for a fan of
    zero-area faces only).
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    m = len(faces)
    rows = np.ascontiguousarray(vertices + 0.0).view(np.dtype((np.void, 24))).ravel()  # + 0.0: -0.0 is 0.0
    _, position = np.unique(rows, return_inverse=True)  # one id per position (a 1D sort of the rows' bytes)
    position = position.ravel()[faces]  # (m, 3) position id of each corner
    _, e1, e2 = edges(vertices, faces)
    weighted = np.cross(e1, e2)  # (m, 3) normal times twice the area
    length = np.linalg.norm(weighted, axis=1, keepdims=True)
    unit = np.divide(weighted, length, out=np.zeros_like(weighted), where=length > 0)

    # Each face edge (corner c to corner c + 1), keyed by its two positions, sorted
    a, b = position, np.roll(position, -1, axis=1)
    key = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=2).reshape(-1, 2)  # (3m, 2)
    corner_a = (np.arange(m)[:, None] * 3 + np.arange(3)).ravel()  # corner at a
    corner_b = (np.arange(m)[:, None] * 3 + (np.arange(3) + 1) % 3).ravel()  # corner at b
    order = np.argsort(key[:, 0] * (int(position.max()) + 1) + key[:, 1], kind="stable")
    key, corner_a, corner_b = key[order], corner_a[order], corner_b[order]
    same = np.flatnonzero((key[1:] == key[:-1]).all(axis=1))  # consecutive half-edges on one edge
    f, g = corner_a[same] // 3, corner_a[same + 1] // 3
    soft = np.einsum("ij,ij->i", unit[f], unit[g]) >= np.cos(np.radians(angle))
    # the corners of f and g at each end of a soft edge are in one fan (the edge's two
    # half-edges may run either way: match the corners by position)
    pa = position.ravel()[corner_a[same]]
    ga, gb = corner_a[same + 1], corner_b[same + 1]
    g_at_pa = np.where(position.ravel()[ga] == pa, ga, gb)
    g_at_pb = np.where(position.ravel()[ga] == pa, gb, ga)
    left = np.concatenate([corner_a[same][soft], corner_b[same][soft]])
    right = np.concatenate([g_at_pa[soft], g_at_pb[soft]])
    fan = connected_components(3 * m, left, right)  # (3m,) fan of each corner

    corner_weight = np.repeat(weighted, 3, axis=0)
    normal = np.stack([np.bincount(fan, weights=corner_weight[:, c], minlength=fan.max() + 1) for c in range(3)], axis=1)
    length = np.linalg.norm(normal, axis=1)
    ok = length > 0
    normal[ok] /= length[ok, None]
    normal[~ok] = (0.0, 0.0, 1.0)  # a fan of zero-area faces only

    # one new vertex per (old vertex, fan)
    fans = int(fan.max()) + 1
    unique, first, inverse = np.unique(faces.ravel() * fans + fan, return_index=True, return_inverse=True)
    return unique // fans, inverse.reshape(m, 3), normal[fan[first]]
