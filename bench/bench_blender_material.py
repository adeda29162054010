"""Blender's glTF import of each built-in material's GLB: is every map wired into its
Principled BSDF?

    scripts/run python bench/bench_blender_material.py [--blender PATH] [--size 256] [--mesh PATH]

Bakes each built-in material (and one with an opacity channel) onto suzanne.ply, imports
the GLB with Blender 4.5's own glTF importer (``bench/blender_gltf_material.py``, in the
Blender venv: ``scripts/blender`` makes it) and follows each Principled BSDF input back
to its image. Expected: Base Color from the base colour map (sRGB); Roughness and
Metallic from the ORM map's green and blue (Non-Color, through Separate Color); Normal
from the normal map through a Normal Map node (Non-Color); Emission Color from the
emissive map where there is one; the occlusion (Blender keeps it in its glTF output
group: it does not shade with it) from the ORM map's red; Alpha from the base colour
map's alpha where the material has an opacity.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from pathlib import Path

from _rows import emit

import texbake
from texbake.materials import BUILTINS

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne.ply"
BLENDER = ROOT / ".venv-blender" / "bin" / "python"  # scripts/blender makes it
OPACITY = {"name": "opacity_checker", "base_color": [0.7, 0.3, 0.1],
           "opacity": {"op": "texture", "texture": "checker", "output": "value"}, "roughness": 0.4}


def expected(maps: set[str]) -> dict[str, tuple[str, str | None]]:
    """Principled BSDF input -> (the map, the image's output it comes from) a whole import wires."""
    want = {"Base Color": ("base_color", "Color")}
    if {"roughness", "metallic", "occlusion"} & maps:
        want.update({"Roughness": ("orm", "Green"), "Metallic": ("orm", "Blue")})
    if "normal" in maps:
        want["Normal"] = ("normal", "Normal")
    if "emissive" in maps:
        want["Emission Color"] = ("emissive", "Color")
    if "opacity" in maps:
        want["Alpha"] = ("base_color", "Alpha")
    return want


def check(blender: Path, glb: Path, maps: set[str]) -> tuple[list[str], list[str]]:
    """``(wired, missing)``: the inputs wired as :func:`expected` says, and those that are not."""
    out = subprocess.run([str(blender), str(ROOT / "bench" / "blender_gltf_material.py"), str(glb)], capture_output=True, text=True,
                         timeout=300, check=True).stdout
    (material,) = json.loads(next(line for line in out.splitlines() if line.startswith("MATERIALS "))[10:]).values()
    wired, missing = [], []
    for name, (map_name, output) in expected(maps).items():
        got = material["inputs"].get(name)
        colour_space = "sRGB" if map_name in ("base_color", "emissive") else "Non-Color"
        if name == "Alpha":
            ok = got is not None and got["output"] == "Alpha"
        elif name == "Normal":
            ok = got is not None and "NORMAL_MAP" in got["through"] and got["colorspace"] == colour_space
        else:
            ok = got is not None and got["colorspace"] == colour_space and (output in ("Color", None) or got["output"] == output)
        (wired if ok else missing).append(name if output in ("Color", "Normal", None) else f"{name} ({output})")
    if "occlusion" in maps:
        ok = material["occlusion"] is not None and material["occlusion"]["output"] == "Red"
        (wired if ok else missing).append("occlusion (Red)")
    return wired, missing


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blender", type=Path, default=BLENDER)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--mesh", type=Path, default=MESH)
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, material in [*BUILTINS.items(), (OPACITY["name"], OPACITY)]:
            result = texbake.bake_mesh(args.mesh, material=material, size=args.size)
            result.save(Path(tmp) / name)
            figure = f"Blender 4.5 glTF import of {name}'s GLB: Principled BSDF inputs wired"
            if not args.blender.exists():
                rows.append((figure, "-", "Blender not installed (scripts/blender)"))
                continue
            wired, missing = check(args.blender, Path(tmp) / name / f"{result.mesh.name}.glb", set(result.images))
            rows.append((figure, f"{len(wired)} of {len(wired) + len(missing)}: {', '.join(wired)}",
                         "every map wired" if not missing else f"NOT wired: {', '.join(missing)}"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
