"""Tangent frames of the output mesh: the glTF ``TANGENT`` attribute, and the frame a
tangent-space normal map is baked in.

glTF (as MikkTSpace) reconstructs a fragment's frame from interpolated vertex attributes:
``T`` the tangent (along +u), ``N`` the normal, ``B = w * N x T`` (``w`` = +-1, stored
as the tangent's 4th component). A normal map is right in a viewer only if it was baked
in that same frame, so the bake does not use a frame of its own: it interpolates the
output mesh's vertex normals and these tangents (:func:`sample_frames`), and the GLB
carries both. ``B`` points along +v (v up, OpenGL and trimesh): the normal map's green
channel is "+Y up", as glTF wants.

A vertex's tangent is MikkTSpace's (Morten Mikkelsen's reference implementation, what
Blender's ``calc_tangents`` and glTF exporters run): the faces around a vertex fall into
groups, those joined through the edges they share (an edge of exactly two faces, which use it
in opposite directions) and wound the same way in UV space; each group's tangent is the mean of its
faces' dP/du, each made orthogonal to the vertex normal and unit, weighted by the face's
angle at the vertex; ``w`` is +1 where the group's UVs run counter-clockwise (as its
positions do), -1 where they are mirrored. A vertex with more than one group is split, one
vertex per group (a UV seam that touches itself at one vertex, a mirror line). Faces with
no UV area give no direction and take the winding of a neighbour; a group left without a
direction gets any unit vector orthogonal to its normal (MikkTSpace leaves it zero, which
glTF forbids); a face with two equal vertices takes the tangent of another face at the
same vertex.
"""

from __future__ import annotations

import numpy as np

from .components import connected_components
from .grouping import groups
from .uvgeometry import uv_jacobian


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def _orthogonal_to(n: np.ndarray) -> np.ndarray:
    """``(k, 3)`` unit vectors orthogonal to the unit ``(k, 3)`` vectors ``n``."""
    axis = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    return _unit(np.cross(n, axis))


def vertex_tangents(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray,
                    normals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MikkTSpace's tangents, one per vertex, with vertices split where its groups split them.

    ``vertices`` ``(k, 3)``, ``uv`` ``(k, 2)`` (v up) and unit ``normals`` ``(k, 3)`` per
    vertex; ``faces`` ``(m, 3)`` int indices into them. Returns ``(source (k2,) int64,
    faces (m, 3) int64, tangents (k2, 4) float64)``: new vertex ``i`` is old vertex
    ``source[i]`` (``k2 >= k``), the faces (in their order) index the new vertices, and
    each tangent's ``xyz`` is unit and orthogonal to its normal, ``w`` = +-1.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    normals = np.asarray(normals, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    m = len(faces)
    corners = faces.reshape(-1)
    if m == 0:
        return np.arange(len(vertices), dtype=np.int64), faces.reshape(0, 3), np.column_stack([_orthogonal_to(normals), np.ones(len(vertices))])
    wf = faces
    degenerate = (wf[:, 0] == wf[:, 1]) | (wf[:, 1] == wf[:, 2]) | (wf[:, 2] == wf[:, 0])
    dpdu, _, det = uv_jacobian(vertices, faces, uv, faces)
    first, second = _neighbours(wf, ~degenerate)
    orient = _windings(det, first // 3, second // 3)
    # corners at one vertex are one group where an edge pair joins their faces, wound alike
    same = orient[first // 3] == orient[second // 3]
    a, b = first[same], second[same]
    # half-edge 3f + c runs from corner c to corner c + 1; its pair runs the other way
    a_next, b_next = a - a % 3 + (a % 3 + 1) % 3, b - b % 3 + (b % 3 + 1) % 3
    group = connected_components(3 * m, np.concatenate([a, a_next]), np.concatenate([b_next, b]))
    # a degenerate face's corners join a group of another face at the vertex, where one is
    lone = np.repeat(degenerate, 3)
    if lone.any():
        at = np.full(len(vertices), -1, dtype=np.int64)
        kept = np.flatnonzero(~lone)
        at[corners[kept[::-1]]] = group[kept[::-1]]  # the first such corner's group
        borrowed = at[corners[lone]]
        group[np.flatnonzero(lone)[borrowed >= 0]] = borrowed[borrowed >= 0]
    # each group's tangent: the faces' unit dP/du in the normal's plane, by their corner angles
    n = normals[corners]
    along = np.repeat(dpdu, 3, axis=0)
    along = _unit(along - np.einsum("ij,ij->i", along, n)[:, None] * n)
    weight = np.column_stack([_corner_angle(vertices, faces, c, normals[faces[:, c]]) for c in range(3)]).reshape(-1)
    weight[lone] = 0.0
    sums = np.zeros((3 * m, 3))
    for axis in range(3):
        sums[:, axis] = np.bincount(group, along[:, axis] * weight, 3 * m)
    winding = np.repeat(orient, 3)
    group_winding = np.zeros(3 * m, dtype=bool)
    group_winding[group[lone]] = winding[lone]  # a lone corner's own, unless it joined a group
    group_winding[group[~lone]] = winding[~lone]
    # one vertex per (old vertex, group) pair: a vertex's first group keeps its index, the
    # others are added after the old vertices
    k = len(vertices)
    firsts, new = groups(corners, group)
    held = corners[firsts]
    keeps = np.ones(len(firsts), dtype=bool)
    keeps[1:] = held[1:] != held[:-1]
    index = held.copy()
    added = np.flatnonzero(~keeps)
    index[added] = k + np.arange(len(added))
    source = np.concatenate([np.arange(k, dtype=np.int64), held[added]])
    tangent, w = np.zeros((len(source), 3)), np.ones(len(source))
    tangent[index] = sums[group[firsts]]
    w[index] = np.where(group_winding[group[firsts]], 1.0, -1.0)
    nrm = normals[source]
    tangent = _unit(tangent - np.einsum("ij,ij->i", tangent, nrm)[:, None] * nrm)
    none = ~(np.linalg.norm(tangent, axis=1) > 0.5)  # also the vertices no face uses
    tangent[none] = _orthogonal_to(nrm[none])
    return source, index[new].reshape(m, 3), np.column_stack([tangent, w])


def _neighbours(faces: np.ndarray, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first (p,), second (p,))`` int64 half-edges (``3 f + c``: face ``f``'s edge from
    corner ``c`` to ``c + 1``) of the ``kept`` faces paired: the two of each edge that two
    faces use, in opposite directions. An edge of more than two faces pairs none: Blender's
    corner normals part there (a fan of faces around a vertex ends at such an edge), so the
    vertices ``calc_tangents`` sees do too (the reference MikkTSpace would pair some)."""
    half = np.flatnonzero(np.repeat(kept, 3))
    a = faces.reshape(-1)[half]
    b = faces[:, [1, 2, 0]].reshape(-1)[half]
    key = np.minimum(a, b) * (int(faces.max()) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    key = key[order]
    # runs of exactly two equal keys whose half-edges run opposite ways
    same = key[1:] == key[:-1]
    two = same.copy()
    two[1:] &= ~same[:-1]
    two[:-1] &= ~same[1:]
    i = np.flatnonzero(two)
    i = i[(a[order[i]] < b[order[i]]) != (a[order[i + 1]] < b[order[i + 1]])]
    return half[order[i]], half[order[i + 1]]


def _windings(det: np.ndarray, first_face: np.ndarray, second_face: np.ndarray) -> np.ndarray:
    """``(m,)`` bool: each face's UVs counter-clockwise. A face of no UV area (MikkTSpace's
    GROUP_WITH_ANY) takes a paired neighbour's winding, through chains of such faces too,
    else counter-clockwise."""
    orient = det > 0
    known = det != 0
    for _ in range(64):  # a chain of faces without UV area is rarely long
        spread = (known[first_face] != known[second_face])
        if not spread.any():
            break
        to = np.where(known[first_face[spread]], second_face[spread], first_face[spread])
        src = np.where(known[first_face[spread]], first_face[spread], second_face[spread])
        orient[to[::-1]] = orient[src[::-1]]  # the first pair's, where several reach a face
        known[to] = True
    return orient


def _corner_angle(vertices: np.ndarray, faces: np.ndarray, corner: int, normals: np.ndarray) -> np.ndarray:
    """``(m,)`` the angle at ``corner`` of each face between its two edges, both laid in the
    plane of the corner's unit ``normals`` ``(m, 3)`` first (MikkTSpace's ``fAngle``)."""
    here = vertices[faces[:, corner]]
    edges = [vertices[faces[:, (corner + k) % 3]] - here for k in (1, 2)]
    a, b = (_unit(e - np.einsum("ij,ij->i", e, normals)[:, None] * normals) for e in edges)
    return np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0))


def sample_frames(corner_normals: np.ndarray, corner_tangents: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` float64 frames, rows ``T, B, N``, at ``(n, 3)`` barycentric points.

    ``corner_normals`` ``(n, 3, 3)`` and ``corner_tangents`` ``(n, 3, 4)``: the vertex
    normals and tangents at the three corners of each point's face. ``N`` is the unit
    interpolated normal, ``T`` the interpolated tangent made orthogonal to it, ``B = w N x T``
    with ``w`` the sign of the interpolated ``w`` (as glTF viewers rebuild it per fragment).
    """
    n = _unit(np.einsum("ni,nij->nj", bary, corner_normals))
    t = np.einsum("ni,nij->nj", bary, corner_tangents)
    w = np.where(t[:, 3] < 0, -1.0, 1.0)[:, None]
    t = t[:, :3] - np.einsum("ij,ij->i", t[:, :3], n)[:, None] * n
    t = _unit(t)
    none = ~(np.linalg.norm(t, axis=1) > 0.5) & (np.linalg.norm(n, axis=1) > 0.5)
    t[none] = _orthogonal_to(n[none])
    return np.stack([t, w * np.cross(n, t), n], axis=1)
