"""Blender 4.5's MikkTSpace tangents of OBJ meshes, run by bench/bench_tangents.py.

    BLENDER_PYTHON bench/blender_tangents.py MESH.obj OUT.npz [MESH.obj OUT.npz ...]

Each OBJ is imported with its axes as they are (forward Y, up Z: no rotation) and its
normals as custom normals (the corner normals ``calc_tangents`` works in), then
``Mesh.calc_tangents()`` runs on its one UV map. OUT.npz holds, per loop (face corner, in
face order): ``vertex`` (the OBJ vertex it uses), ``tangent`` ``(l, 3)``, ``sign`` (the
bitangent sign), ``normal`` ``(l, 3)`` (the corner normal), and ``positions`` ``(k, 3)``,
the mesh's vertices (to check that they are the OBJ's, in its order).
"""

from __future__ import annotations

import sys

import bpy
import numpy as np


def tangents(path: str, out: str) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z", validate_meshes=False)
    obj = bpy.context.selected_objects[0]
    mesh = obj.data
    mesh.calc_tangents()
    loops = len(mesh.loops)
    vertex, sign = np.empty(loops, dtype=np.int64), np.empty(loops, dtype=np.float32)
    tangent, normal = np.empty(loops * 3, dtype=np.float32), np.empty(loops * 3, dtype=np.float32)
    mesh.loops.foreach_get("vertex_index", vertex)
    mesh.loops.foreach_get("bitangent_sign", sign)
    mesh.loops.foreach_get("tangent", tangent)
    mesh.corner_normals.foreach_get("vector", normal)
    positions = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    np.savez(out, vertex=vertex, sign=sign, tangent=tangent.reshape(-1, 3), normal=normal.reshape(-1, 3),
             positions=positions.reshape(-1, 3))


def main() -> None:
    paths = sys.argv[1:]
    if not paths or len(paths) % 2:
        raise SystemExit(__doc__)
    for path, out in zip(paths[::2], paths[1::2], strict=True):
        tangents(path, out)


if __name__ == "__main__":
    main()
