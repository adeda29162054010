"""Tangent frames of the output mesh: the glTF ``TANGENT`` attribute, and the frame a
tangent-space normal map is baked in.

glTF (as MikkTSpace) reconstructs a fragment's frame from interpolated vertex attributes:
``T`` the tangent (along +u), ``N`` the normal, ``B = w * N x T`` (``w`` = +-1, stored
as the tangent's 4th component). A normal map is right in a viewer only if it was baked
in that same frame, so the bake does not use a frame of its own: it interpolates the
output mesh's vertex normals and these tangents (:func:`sample_frames`), and the GLB
carries both. ``B`` points along +v (v up, OpenGL and trimesh): the normal map's green
channel is "+Y up", as glTF wants.

A vertex's tangent is MikkTSpace's: the mean of its faces' dP/du, each made orthogonal to the
vertex normal and unit, weighted by the face's angle at the vertex; ``w`` says whether
dP/dv lies on the side of ``N x T`` (+1) or not (-1, a mirrored layout). Faces with no UV area give no direction; a vertex left without one gets
any unit vector orthogonal to its normal.
"""

from __future__ import annotations

import numpy as np

from .uvgeometry import areas, uv_jacobian


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def _orthogonal_to(n: np.ndarray) -> np.ndarray:
    """``(k, 3)`` unit vectors orthogonal to the unit ``(k, 3)`` vectors ``n``."""
    axis = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    return _unit(np.cross(n, axis))


def vertex_tangents(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``(k, 4)`` float64 tangents: unit ``xyz`` orthogonal to each vertex normal, ``w`` = +-1.

    ``vertices`` ``(k, 3)``, ``uv`` ``(k, 2)`` (v up) and unit ``normals`` ``(k, 3)`` per
    vertex; ``faces`` ``(m, 3)`` int indices into them. As MikkTSpace weighs them: each
    face's dP/du made orthogonal to the corner's vertex normal, then unit, summed with the
    corner's angle (between its edges, laid in that normal's plane) as weight.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    normals = np.asarray(normals, dtype=np.float64)
    dpdu, dpdv, _ = uv_jacobian(vertices, faces, uv, faces)
    weight = areas(vertices, faces)
    face_normal = _unit(np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]]))
    handed = np.sign(np.einsum("ij,ij->i", np.cross(face_normal, dpdu), dpdv))  # (m,): -1 mirrored, 0 degenerate
    tangent, side = np.zeros_like(vertices), np.zeros(len(vertices))
    for corner in range(3):
        v = faces[:, corner]
        n = normals[v]
        along = _unit(dpdu - np.einsum("ij,ij->i", dpdu, n)[:, None] * n)  # in the corner normal's plane, then unit
        angle = _corner_angle(vertices, faces, corner, n)
        for axis in range(3):
            tangent[:, axis] += np.bincount(v, along[:, axis] * angle, len(vertices))
        side += np.bincount(v, handed * weight, len(vertices))
    tangent -= np.einsum("ij,ij->i", tangent, normals)[:, None] * normals
    tangent = _unit(tangent)
    none = ~(np.linalg.norm(tangent, axis=1) > 0.5)
    tangent[none] = _orthogonal_to(normals[none])
    return np.column_stack([tangent, np.where(side < 0, -1.0, 1.0)])


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
