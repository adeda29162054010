"""Does Blender 4.5 open a UDIM bake as it was laid out? Run in Blender's own interpreter
(``bpy`` is never a test dependency; ``scripts/blender`` makes the venv):

    BLENDER_PYTHON bench/blender_udim.py OUT_FOLDER [--layout MESH.obj] [--obj]

Imports ``OUT_FOLDER/<mesh>.usda`` (and, with ``--obj``, ``<mesh>.obj`` + MTL) from
Blender's factory settings and checks, for every mesh and material it brought in: the
material's base colour is an image texture whose image is tiled (``source == 'TILED'``)
with exactly the tiles the report lists, each tile's file there and read by Blender (its
size as the report's), and the mesh's UV layer holds the UVs the bake wrote, tile for
tile (every face in the tile its corners say; with ``--layout``, the OBJ that was baked, the
same UV coordinates as its ``vt`` lines, within float32). Prints one JSON object: per file,
per mesh, what was found; exits 1 if any check fails. (Blender 4.5's OBJ importer reads
``map_Kd albedo.<UDIM>.png`` as one plain image, not as tiles: ``--obj`` shows that.)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import bpy


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("--obj", action="store_true", help="also import the OBJ")
    ap.add_argument("--layout", help="the OBJ that was baked: its vt lines are the UVs to find")
    args = ap.parse_args(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else None)
    folder = Path(args.folder)
    report = json.loads((folder / "report.json").read_text())
    tiles = {s["name"]: sorted(t["tile"] for t in s["tiles"]) for s in report["sets"]}
    sizes = {s["name"]: tuple(s["size"]) for s in report["sets"]}
    files = [folder / report["outputs"]["usd"]["path"]]
    if args.obj:
        files.append(folder / report["outputs"]["obj"]["path"])
    found, ok = {}, True
    for path in files:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        if path.suffix == ".obj":
            bpy.ops.wm.obj_import(filepath=str(path))
        else:
            bpy.ops.wm.usd_import(filepath=str(path))
        meshes = [o for o in bpy.data.objects if o.type == "MESH"]
        found[path.name] = [check(o, tiles, sizes) for o in meshes]
        ok = ok and bool(meshes) and all(m["ok"] for m in found[path.name])
        if args.layout:
            same = _uvs(meshes) == _layout(Path(args.layout))
            found[path.name].append({"uvs_as_baked": same})
            ok = ok and same
    print(json.dumps({"ok": ok, "files": found}, indent=2))
    return 0 if ok else 1


def check(obj, tiles: dict, sizes: dict) -> dict:
    """One imported mesh: its material's image, the image's tiles, and its UVs' tiles."""
    material = obj.active_material
    name = _set_name(material.name if material else "", tiles)
    images = [n.image for n in material.node_tree.nodes if n.type == "TEX_IMAGE" and n.image] if material else []
    image = images[0] if images else None
    out = {"object": obj.name, "material": material.name if material else None, "set": name,
           "image": None if image is None else image.filepath, "source": None if image is None else image.source}
    want = tiles.get(name, [])
    have = sorted(t.number for t in image.tiles) if image is not None and image.source == "TILED" else []
    loaded = {}
    for t in have:  # each tile's pixels, read by Blender
        image.tiles.active = next(x for x in image.tiles if x.number == t)
        path = bpy.path.abspath(image.filepath_raw.replace("<UDIM>", str(t)))
        loaded[t] = Path(path).is_file() and tuple(image.tiles.active.size) == sizes.get(name)
    uv_tiles = _uv_tiles(obj)
    out.update(tiles_wanted=want, tiles_bound=have, tiles_loaded=all(loaded.values()) and bool(loaded),
               uv_tiles=sorted(uv_tiles) if uv_tiles is not None else None)
    out["ok"] = bool(want) and have == want and out["tiles_loaded"] and uv_tiles is not None and sorted(uv_tiles) == want
    return out


def _uvs(meshes) -> set[tuple[float, float]]:
    """Every UV coordinate of the meshes' active UV layers, rounded to float32's 1e-5."""
    return {(round(d.uv[0], 5), round(d.uv[1], 5)) for o in meshes for d in o.data.uv_layers.active.data}


def _layout(path: Path) -> set[tuple[float, float]]:
    """The ``vt`` coordinates of an OBJ, rounded as :func:`_uvs` rounds."""
    out = set()
    for line in path.read_text().splitlines():
        if line.startswith("vt "):
            u, v = map(float, line.split()[1:3])
            out.add((round(u, 5), round(v, 5)))
    return out


def _set_name(material: str, tiles: dict) -> str:
    """The texture set a material is (importers may add ``.001`` or change spaces)."""
    for name in tiles:
        if material == name or material.split(".")[0] == name.replace(" ", "_") or material.startswith(name):
            return name
    return material


def _uv_tiles(obj) -> set[int] | None:
    """The UDIM tiles of the mesh's faces by their UVs (1001 + u + 10 v), or None where a
    face's corners lie in two tiles."""
    mesh = obj.data
    layer = mesh.uv_layers.active
    if layer is None:
        return None
    out = set()
    for poly in mesh.polygons:
        corners = [layer.data[i].uv for i in poly.loop_indices]
        u = min(c[0] for c in corners)
        v = min(c[1] for c in corners)
        tu, tv = math.floor(u + 1e-6), math.floor(v + 1e-6)
        if any(c[0] > tu + 1 + 1e-6 or c[1] > tv + 1 + 1e-6 for c in corners):
            return None
        out.add(1001 + tu + 10 * tv)
    return out


if __name__ == "__main__":
    sys.exit(main())
