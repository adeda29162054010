"""A material of six channels sharing one turbulence, against its base colour alone.

    scripts/run python bench/bench_material.py [--size 1024] [--rounds 5] [--mesh PATH]

The material: ``t``, one turbulence's value, and from it the base colour (a colour map),
roughness (a curve), metallic (a smoothstep), occlusion (a mix), emissive (a power times a
colour) and opacity (a clamp); the second, the same with height (``t`` itself) in place
of the opacity, from which the normal map is made too (its forward differences evaluate
the height at two more points a sample, and the normal map needs the output mesh's
tangent frames). The same material with its base colour only is the reference. Each is
baked (``texbake.bake_mesh``, the default quality: one filtered sample a texel) onto
suzanne_blender_uv.obj (its own UVs) in one process, taking turns round after round,
after one warm-up bake of each; each figure is the median over the rounds of the
process's CPU seconds (``time.process_time``: every thread) and of the wall seconds, for
the bake and for the bake and its save. Target: the six channels' bake in at most 1.5
times the base colour's. The report's ``material.nodes`` must count the shared turbulence
once a sample: its evaluations equal the samples that reached a face (``rays`` ``cast``
less ``missed``).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from _rows import emit

import texbake

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"
TARGET = 1.5

TURBULENCE = {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 6.0, "octaves": 8}}
SIX = {
    "name": "six_on_one_turbulence",
    "nodes": {"t": TURBULENCE},
    "base_color": {"op": "remap", "input": "t", "colormap": {"knots": [0.2, 0.5, 0.8],
                                                             "colours": [[0.1, 0.05, 0.02], [0.6, 0.3, 0.1], [0.9, 0.8, 0.6]]}},
    "roughness": {"op": "remap", "input": "t", "curve": {"knots": [0.2, 0.8], "values": [0.9, 0.2]}},
    "metallic": {"op": "smoothstep", "input": "t", "edge0": 0.55, "edge1": 0.65},
    "occlusion": {"op": "mix", "a": 0.6, "b": 1.0, "mask": "t"},
    "emissive": {"op": "multiply", "a": [1.0, 0.4, 0.1], "b": {"op": "power", "a": "t", "b": 6.0}},
    "opacity": {"op": "clamp", "input": {"op": "multiply", "a": "t", "b": 2.0}, "min": 0.3, "max": 1.0},
}
SIX_HEIGHT = {**{k: v for k, v in SIX.items() if k != "opacity"}, "name": "six_with_height", "height": "t"}
BASE = {"name": "base_colour_alone", "nodes": SIX["nodes"], "base_color": SIX["base_color"]}
MATERIALS = {"six": SIX, "six with height": SIX_HEIGHT, "base": BASE}


def bake(mesh: Path, material: dict, size: int, folder: Path | None) -> tuple[float, float, dict]:
    """``(CPU seconds, wall seconds, report)`` of one bake (and its save into ``folder``)."""
    cpu, wall = time.process_time(), time.perf_counter()
    result = texbake.bake_mesh(mesh, material=material, size=size)
    if folder is not None:
        result.save(folder)
    return time.process_time() - cpu, time.perf_counter() - wall, result.report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--mesh", type=Path, default=MESH)
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    times: dict[tuple[str, bool], list[tuple[float, float]]] = {}
    reports = {}
    with tempfile.TemporaryDirectory() as tmp:
        for material in MATERIALS.values():  # warm-up: tables, the atlas cache of the process
            bake(args.mesh, material, args.size, None)
        for _ in range(args.rounds):
            for saving in (False, True):
                for name, material in MATERIALS.items():
                    cpu, wall, reports[name] = bake(args.mesh, material, args.size, Path(tmp) / name if saving else None)
                    times.setdefault((name, saving), []).append((cpu, wall))
    median = {key: (statistics.median(c for c, _ in v), statistics.median(w for _, w in v)) for key, v in times.items()}
    rows = []
    for name, what in (("six", "base colour, roughness, metallic, occlusion, emissive, opacity"),
                       ("six with height", "height (and the normal map from it) in place of opacity")):
        for saving in (False, True):
            (six_cpu, six_wall), (base_cpu, base_wall) = median[(name, saving)], median[("base", saving)]
            met = "met" if six_cpu / base_cpu <= TARGET else "not met"
            rows.append((f"material {name} ({what}) on one turbulence vs its base colour alone, {args.size}², {args.mesh.name}, "
                         f"{'bake + save' if saving else 'bake'}, median of {args.rounds}",
                         f"{six_cpu / base_cpu:.2f}x CPU ({six_cpu:.2f} / {base_cpu:.2f} s), {six_wall / base_wall:.2f}x wall",
                         f"base colour alone {base_cpu:.2f} CPU-s, {base_wall:.2f} s" + ("" if saving else f"; target <= {TARGET}x: {met}")))
    for name in ("six", "six with height"):
        rays = reports[name]["rays"]
        samples = rays["cast"] - rays["missed"]
        node = reports[name]["material"]["nodes"]["t"]
        extra = f" (+{node['gradient_evaluations']} at the normal map's offsets)" if "gradient_evaluations" in node else ""
        rows.append((f"material {name}: the shared turbulence's evaluations ({samples} samples on the surface)",
                     f"{node['evaluations']}{extra}",
                     f"once a sample: {'yes' if node['evaluations'] == samples else 'NO'}; by {', '.join(node['channels'])}"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
