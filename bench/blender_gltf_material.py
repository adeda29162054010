"""Run by Blender's Python (bpy): import a GLB with Blender's own glTF importer and print,
as JSON, what feeds each input of its Principled BSDF (bench/bench_blender_material.py).

    .venv-blender/bin/python bench/blender_gltf_material.py FILE.glb

For each material: ``inputs``, each linked Principled BSDF input and the image (and its
colour space) it comes from through the node tree (Normal Map and Separate Color nodes
followed back); ``occlusion``, the image the importer keeps for glTF's occlusion (its
"glTF Material Output" group, which Blender does not shade with); ``blend_method`` and
``alpha``: how it reads the alpha.
"""

from __future__ import annotations

import json
import sys

import bpy


def image_behind(socket):
    """``(image name, colour space, the node types on the way)`` feeding ``socket``, or None."""
    seen, first = [], socket.links[0].from_socket.name if socket.is_linked else None  # first: e.g. Separate Color's "Green"
    while socket.is_linked:
        node = socket.links[0].from_node
        seen.append(node.type)
        if node.type == "TEX_IMAGE":
            return {"image": node.image.name if node.image else None, "output": first,
                    "colorspace": node.image.colorspace_settings.name if node.image else None, "through": seen}
        inputs = [s for s in node.inputs if s.is_linked and s.type in ("RGBA", "VECTOR", "VALUE")]
        if not inputs:
            return {"image": None, "through": seen}
        socket = next((s for s in inputs if s.name in ("Color", "Image", "Base Color")), inputs[0])
    return None


def main() -> None:
    path = sys.argv[sys.argv.index("--") + 1] if "--" in sys.argv else sys.argv[-1]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    out = {}
    for material in bpy.data.materials:
        if not material.use_nodes:
            continue
        nodes = material.node_tree.nodes
        bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is None:
            continue
        linked = {s.name: image_behind(s) for s in bsdf.inputs if s.is_linked}
        group = next((n for n in nodes if n.type == "GROUP" and n.node_tree and "glTF" in n.node_tree.name), None)
        occlusion = None
        if group is not None:
            socket = next((s for s in group.inputs if s.name.lower().startswith("occlusion") and s.is_linked), None)
            occlusion = None if socket is None else image_behind(socket)
        out[material.name] = {"inputs": linked, "occlusion": occlusion,
                              "blend_method": getattr(material, "blend_method", None),
                              "values": {s.name: round(float(s.default_value), 4) for s in bsdf.inputs
                                         if not s.is_linked and s.name in ("Metallic", "Roughness", "Alpha")}}
    print("MATERIALS " + json.dumps(out))


main()
