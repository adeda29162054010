"""Blender 4.5 baking many meshes in one looping process; run by bench/bench_batch.py.

    BLENDER_PYTHON bench/blender_batch.py IN_FOLDER OUT_FOLDER --size 512 --samples 1

For every ``*.obj`` in ``IN_FOLDER`` (sorted), from Blender's factory settings: import it,
Smart UV Project it (angle limit 66 degrees, Blender's default; island margin 0.002), give
it bench/blender_bake.py's emission marble and bake the ``EMIT`` pass with Cycles (CPU, 2
threads, ``--samples``) into a ``--size`` square image saved as
``OUT_FOLDER/<name>.png``: what a user's Blender batch script does, in one process (bpy
imported once, Cycles started once). Prints a line a mesh, after ``MARK`` (Blender prints
lines of its own): its seconds, and the CPU seconds of its Smart UV Project (the process'
CPU time around the operator).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import bpy
from blender_bake import bake_emission

MARK = "blender_batch:"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--samples", type=int, default=1)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for mesh in sorted(Path(args.inp).glob("*.obj")):
        start = time.perf_counter()
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.wm.obj_import(filepath=str(mesh))
        obj = bpy.context.selected_objects[0]
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        unwrap = time.process_time()
        bpy.ops.uv.smart_project(angle_limit=math.radians(66.0), island_margin=0.002)
        bpy.ops.object.mode_set(mode="OBJECT")
        unwrap = time.process_time() - unwrap
        bake_emission(obj, args.size, args.samples, str(out / f"{mesh.stem}.png"))
        print(f"{MARK} {time.perf_counter() - start:.4f} {unwrap:.4f}", flush=True)


if __name__ == "__main__":
    main()
