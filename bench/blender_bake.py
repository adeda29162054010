"""Blender 4.5's Cycles bake of a turbulence marble into a mesh's own UVs; run by
bench/bench_blender.py as a whole process, as a user would run it.

    BLENDER_PYTHON bench/blender_bake.py MESH.obj OUT.png --size 2048 --samples 1 [--repeat N]

Imports the OBJ (its UVs), gives it an emission material whose colour is a marble: a
Wave texture (bands along x) distorted by 8-octave noise (``Detail`` 8, Blender's fBm
turbulence), through a colour ramp, and bakes the ``EMIT`` pass into a ``--size``
square image with ``--samples`` Cycles samples a texel (CPU, 2 threads), then saves it
as PNG. Runs in its own interpreter (``bpy`` pins numpy 1.26; ``scripts/blender``).
``--repeat N`` does all of it N times in the one process (a warm Blender: bpy imported,
Cycles started) and prints each time's seconds, one a line.
"""

from __future__ import annotations

import argparse
import time

import bpy


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("out")
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--samples", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    for _ in range(args.repeat):
        start = time.perf_counter()
        bake(args)
        print(f"{time.perf_counter() - start:.4f}", flush=True)


def bake(args) -> None:
    """Import, set up, bake and save, from Blender's factory settings."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.obj_import(filepath=args.mesh)
    obj = bpy.context.selected_objects[0]
    bpy.context.view_layer.objects.active = obj
    bake_emission(obj, args.size, args.samples, args.out)


def bake_emission(obj, size: int, samples: int, out: str) -> None:
    """Give ``obj`` the marble emission material and bake its ``EMIT`` pass into a ``size``
    square image with ``samples`` Cycles samples (CPU, 2 threads), saved as PNG at ``out``."""
    mat = bpy.data.materials.new("marble")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    coord = nodes.new("ShaderNodeTexCoord")
    wave = nodes.new("ShaderNodeTexWave")
    wave.wave_type, wave.bands_direction = "BANDS", "X"
    wave.inputs["Scale"].default_value = 2.0
    wave.inputs["Distortion"].default_value = 8.0
    wave.inputs["Detail"].default_value = 8.0
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.25, 0.22, 0.2, 1.0)
    ramp.color_ramp.elements[1].color = (0.95, 0.93, 0.9, 1.0)
    emit = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(coord.outputs["Object"], wave.inputs["Vector"])
    links.new(wave.outputs["Fac"], ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], emit.inputs["Color"])
    links.new(emit.outputs["Emission"], output.inputs["Surface"])
    image = bpy.data.images.new("baked", size, size)
    target = nodes.new("ShaderNodeTexImage")
    target.image = image
    nodes.active = target  # the bake writes into the active image node
    obj.data.materials.clear()
    obj.data.materials.append(mat)

    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2
    scene.render.bake.margin = 16
    bpy.ops.object.bake(type="EMIT")
    image.filepath_raw = out
    image.file_format = "PNG"
    image.save()


if __name__ == "__main__":
    main()
