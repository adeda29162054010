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
from .grouping import group_rows
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
    position = group_rows(vertices)[1][faces]  # (m, 3) position id of each corner (-0.0 is 0.0)
    _, e1, e2 = edges(vertices, faces)
    weighted = np.cross(e1, e2)  # (m, 3) normal times twice the area
    length = np.linalg.norm(weighted, axis=1, keepdims=True)
    unit = np.divide(weighted, length, out=np.zeros_like(weighted), where=length > 0)

    # Each face edge (from corner c to corner c + 1: half-edge c), keyed by its two
    # positions as one number, sorted; half-edges of one edge are then neighbours
    start, end = position.ravel(), np.roll(position, -1, axis=1).ravel()  # (3m,) positions
    key = np.minimum(start, end) * (int(start.max()) + 1) + np.maximum(start, end)
    order = np.argsort(key, kind="stable")
    key = key[order]
    same = np.flatnonzero(key[1:] == key[:-1])  # consecutive half-edges on one edge
    h, k = order[same], order[same + 1]
    soft = np.einsum("ij,ij->i", unit[h // 3], unit[k // 3]) >= np.cos(np.radians(angle))
    h, k = h[soft], k[soft]
    # the corners of the two faces at each end of a soft edge are in one fan (the
    # half-edges may run either way: match the corners by position)
    h_end, k_end = _next_corner(h), _next_corner(k)
    forward = start[k] == start[h]
    left = np.concatenate([h, h_end])
    right = np.concatenate([np.where(forward, k, k_end), np.where(forward, k_end, k)])
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


def _next_corner(corner: np.ndarray) -> np.ndarray:
    """The corner after each of ``corner`` (flat indices ``3 * face + c``) in its face."""
    return corner - corner % 3 + (corner % 3 + 1) % 3
