"""The mesh stage: a file read into one validated triangle mesh, and its geometry.

What the rest of texbake uses is named here; the modules are this folder's own:

- ``load``: :func:`load_mesh` and :func:`mesh_from_trimesh` -> :class:`LoadedMesh`
  (float64 vertices, int64 faces, UVs where usable), the formats and their checks;
- ``objfile``: the OBJ reader; ``components``: connected components (union-find);
- ``grouping``: equal keys grouped with one vectorised sort, equal rows with a compiled
  hash table;
- ``normals``: the output mesh's shading normals, split at hard edges;
- ``tangents``: tangent frames (the glTF attribute, the normal map's frame);
- ``uvgeometry``: triangle areas and edges, the UV Jacobian, charts' boxes (numpy only: the unwrap's
  worker process imports it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .components import DisjointSets, connected_components
    from .grouping import group_rows, groups, stable_order, unique_inverse
    from .load import FORMATS, LoadedMesh, check_file, load_mesh, mesh_from_trimesh
    from .normals import split_normals
    from .objfile import read_obj
    from .tangents import sample_frames, vertex_tangents
    from .uvgeometry import areas, edges, inverse_det, label_boxes, uv_areas, uv_dets, uv_edges, uv_inverse, uv_jacobian

_HOMES = {name: module for module, names in {
    "load": ["LoadedMesh", "load_mesh", "mesh_from_trimesh", "check_file", "FORMATS"],
    "objfile": ["read_obj"],
    "components": ["connected_components", "DisjointSets"],
    "grouping": ["group_rows", "groups", "stable_order", "unique_inverse"],
    "normals": ["split_normals"],
    "tangents": ["vertex_tangents", "sample_frames"],
    "uvgeometry": ["areas", "label_boxes", "uv_areas", "uv_dets", "edges", "uv_edges", "uv_inverse", "uv_jacobian", "inverse_det"],
}.items() for name in names}

__all__ = ["LoadedMesh", "load_mesh", "mesh_from_trimesh", "check_file", "FORMATS", "read_obj", "connected_components", "DisjointSets", "group_rows", "groups", "stable_order", "unique_inverse", "split_normals", "vertex_tangents", "sample_frames", "areas", "label_boxes", "uv_areas", "uv_dets", "edges", "uv_edges", "uv_inverse", "uv_jacobian", "inverse_det"]
__getattr__ = lazy_names(__name__, _HOMES)
