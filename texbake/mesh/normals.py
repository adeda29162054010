"""Shading normals of the output mesh: smooth across soft edges, split at hard edges.

As Blender's auto smooth: the faces around a position fall into fans joined across the
edges where they meet at less than ``angle`` degrees; each fan's corners share one normal,
the area-weighted mean of its faces' normals. Positions are matched exactly, so the
vertices an atlas splits at a UV seam stay smooth; a vertex is split where corners of
two fans (a hard edge) used it.

The pass is compiled (``native/normals.cpp``): linear time (hash tables, where sorts of
every corner would be n log n), its sums in corner order as numpy's ``bincount`` adds.
Edges are matched by their two positions; the half-edges of one edge pair in their order
(of more than two, each with the next); a pair is soft where the faces' unit normals
have a dot product of at least ``cos(angle)``.
"""

from __future__ import annotations

import numpy as np

from .. import _native

HARD_EDGE_DEGREES = 60.0


def split_normals(vertices: np.ndarray, faces: np.ndarray, angle: float = HARD_EDGE_DEGREES):
    """Per-vertex normals, with vertices split at hard edges.

    ``vertices``: ``(k, 3)`` float; ``faces``: ``(m, 3)`` int indices into them. Returns
    ``(source (k2,) int64, faces (m, 3) int64, normals (k2, 3) float64)``: new vertex ``i``
    is old vertex ``source[i]`` (``k2 >= k``: a vertex on a hard edge is one per fan), the
    faces index the new vertices, and the normals are unit length (+z for a fan of
    zero-area faces only).
    """
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    return _native.split_normals(vertices, faces, float(np.cos(np.radians(angle))))
