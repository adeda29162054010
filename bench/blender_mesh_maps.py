"""Blender 4.5's Cycles bakes of mesh maps, run by bench/bench_mesh_maps.py as a whole process.

    BLENDER_PYTHON bench/blender_mesh_maps.py ao MESH.obj OUT.npy --size 2048 --rays 64 --distance D
    BLENDER_PYTHON bench/blender_mesh_maps.py normal LOW.obj HIGH.obj OUT.npy --size 1024 --extrusion E --reach R

``ao``: the ``AO`` pass of the OBJ into its own UVs, ``--rays`` Cycles samples a texel (one
AO ray each), the world's AO distance ``--distance``. ``normal``: "Selected to Active" from
HIGH onto LOW's UVs, tangent space (OpenGL: +Y), the cage extruded ``--extrusion`` and rays
``--reach`` long. Both shade smooth, bake on the CPU with 2 threads and fill a ``--margin``
texels wide (16: texbake's default, as bench/blender_bake.py's) into a float image, and save its pixels, ``(size, size, 4)`` float32, row 0 at the bottom, as .npy.
Prints the bake's seconds (import to saved image) on its last line.
"""

from __future__ import annotations

import argparse
import time

import bpy
import numpy as np


def imported(path: str):
    bpy.ops.wm.obj_import(filepath=path)
    obj = bpy.context.selected_objects[0]
    for poly in obj.data.polygons:
        poly.use_smooth = True
    return obj


def target_image(obj, size: int):
    """A float image as the active image node of ``obj``'s one material (the bake's target)."""
    mat = bpy.data.materials.new("bake")
    mat.use_nodes = True
    image = bpy.data.images.new("baked", size, size, float_buffer=True)
    node = mat.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    mat.node_tree.nodes.active = node
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    return image


def cycles(samples: int, margin: int) -> None:
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    scene.render.bake.margin = margin


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("kind", choices=["ao", "normal"])
    ap.add_argument("paths", nargs="+")
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--rays", type=int, default=64)
    ap.add_argument("--distance", type=float, default=1.0)
    ap.add_argument("--extrusion", type=float, default=0.05)
    ap.add_argument("--reach", type=float, default=0.1)
    ap.add_argument("--margin", type=int, default=16)
    args = ap.parse_args()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    start = time.perf_counter()
    if args.kind == "ao":
        mesh, out = args.paths
        obj = imported(mesh)
        bpy.context.view_layer.objects.active = obj
        image = target_image(obj, args.size)
        if bpy.context.scene.world is None:
            bpy.context.scene.world = bpy.data.worlds.new("world")
        bpy.context.scene.world.light_settings.distance = args.distance
        cycles(args.rays, args.margin)
        bpy.ops.object.bake(type="AO")
    else:
        low_path, high_path, out = args.paths
        high = imported(high_path)
        low = imported(low_path)
        image = target_image(low, args.size)
        bpy.ops.object.select_all(action="DESELECT")
        high.select_set(True)
        low.select_set(True)
        bpy.context.view_layer.objects.active = low
        cycles(1, args.margin)
        bake = bpy.context.scene.render.bake
        bake.use_selected_to_active, bake.cage_extrusion, bake.max_ray_distance = True, args.extrusion, args.reach
        bpy.ops.object.bake(type="NORMAL", normal_space="TANGENT", use_selected_to_active=True, cage_extrusion=args.extrusion,
                            max_ray_distance=args.reach)
    pixels = np.empty(args.size * args.size * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    np.save(out, pixels.reshape(args.size, args.size, 4))
    print(f"{time.perf_counter() - start:.4f}", flush=True)


if __name__ == "__main__":
    main()
