"""Blender 4.5's Smart UV Project on meshes given as arrays; run by bench/bench_unwrap.py.

    BLENDER_PYTHON bench/blender_smart_uv.py IN.npz OUT.npz

Runs in its own interpreter (Blender's ``bpy`` from PyPI pins numpy 1.26, which
texbake's OpenImageIO does not take): ``IN.npz`` holds ``names`` and, per name,
``<name>.vertices`` (n, 3) and ``<name>.faces`` (m, 3); ``OUT.npz`` gets per name
``<name>.uv`` (m, 3, 2), the UV of each face corner, and ``<name>.seconds``, the wall
time of ``bpy.ops.uv.smart_project`` (angle limit 66 degrees, Blender's default; island
margin ``--margin``) with the mode switches around it, median of ``--runs``.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import bpy
import numpy as np


def smart_uv(vertices: np.ndarray, faces: np.ndarray, margin: float, runs: int) -> tuple[np.ndarray, float]:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("m")
    mesh.from_pydata(vertices.tolist(), [], faces.tolist())
    mesh.update()
    obj = bpy.data.objects.new("m", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.uv.smart_project(angle_limit=math.radians(66.0), island_margin=margin)
        bpy.ops.object.mode_set(mode="OBJECT")
        times.append(time.perf_counter() - t)
    uv = np.zeros(len(mesh.loops) * 2)
    mesh.uv_layers.active.data.foreach_get("uv", uv)
    return uv.reshape(len(faces), 3, 2), statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("inp")
    ap.add_argument("out")
    ap.add_argument("--margin", type=float, default=0.002)
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    data = np.load(args.inp)
    out = {}
    for name in data["names"]:
        uv, seconds = smart_uv(data[f"{name}.vertices"], data[f"{name}.faces"], args.margin, args.runs)
        out[f"{name}.uv"] = uv
        out[f"{name}.seconds"] = np.float64(seconds)
    np.savez(args.out, **out)


if __name__ == "__main__":
    main()
