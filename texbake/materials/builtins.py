"""The built-in materials, by name: each a material as a JSON object would give it (and what
``texbake materials NAME`` prints). They show the range of the graph: a texture's value
through colour maps and masks, one noise shared by several channels, a warp, emission.

Colours are linear RGB. Sizes are in the bake's texture space (by default the mesh's
longest side is 1).
"""

from __future__ import annotations

from typing import Any

POLISHED_MARBLE: dict[str, Any] = {
    "name": "polished_marble",
    "description": "white Carrara-like marble, grey veins, polished (the veins a little rougher)",
    "nodes": {
        "veins": {"op": "texture", "output": "value",
                  "texture": {"name": "marble", "frequency": 9.0, "amplitude": 5.0,
                              "turbulence": {"scale": 3.0, "octaves": 7, "gain": 0.55}}},
        "vein": {"op": "smoothstep", "input": {"op": "invert", "input": "veins"}, "edge0": 0.55, "edge1": 0.97},
    },
    "base_color": {"op": "remap", "input": "veins",
                   "colormap": {"knots": [0.0, 0.12, 0.3, 0.6, 1.0],
                                "colours": [[0.13, 0.13, 0.14], [0.35, 0.35, 0.37], [0.68, 0.68, 0.68], [0.82, 0.81, 0.79],
                                            [0.86, 0.85, 0.83]]}},
    "roughness": {"op": "mix", "a": 0.06, "b": 0.22, "mask": "vein"},
    "metallic": 0.0,
    "height": {"op": "multiply", "a": "vein", "b": -1.0},
    "height_scale": 0.0015,
}

OAK_PLANKS: dict[str, Any] = {
    "name": "oak_planks",
    "description": "oak boards in two tints, their grain rings warped by turbulence, seams between them in relief",
    "nodes": {
        "boards": {"op": "texture", "output": "value",
                   "texture": {"name": "checker", "box": [0.8, 0.09, 0.09], "transform": {"translate": [0.13, 0.0, 0.0]}}},
        "wobble": {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 3.0, "octaves": 4}},
        "grain": {"op": "warp", "by": "wobble", "amount": 0.25, "axis": "x", "output": "value",
                  "texture": {"name": "wood", "ring_width": 0.012, "wobble": 0.15, "wobbles": 3.0, "twist": 1.0,
                              "tilt": [0.0, 90.0, 0.0], "transform": {"translate": [0.0, 0.45, 0.5]}}},
        "fibres": {"op": "texture", "output": "value",
                   "texture": {"name": "noise", "scale": 160.0, "transform": {"scale": [1.0, 0.03, 1.0]}}},
    },
    "base_color": {
        "op": "multiply",
        "a": {"op": "mix", "a": [0.42, 0.25, 0.11], "b": [0.33, 0.18, 0.07], "mask": "boards"},
        "b": {"op": "mix", "a": 1.0, "b": 0.72, "mask": {"op": "multiply", "a": "grain", "b": {"op": "add", "a": 0.6, "b": {
            "op": "multiply", "a": "fibres", "b": 0.6}}}},
    },
    "roughness": {"op": "mix", "a": 0.45, "b": 0.62, "mask": "grain"},
    "metallic": 0.0,
    "height": {"op": "add", "a": {"op": "multiply", "a": "boards", "b": 0.6}, "b": {"op": "multiply", "a": "grain", "b": 0.15}},
    "occlusion": {"op": "mix", "a": 0.85, "b": 1.0, "mask": "boards"},
    "height_scale": 0.002,
}

LAVA: dict[str, Any] = {
    "name": "lava",
    "description": "black crust cracked over glowing lava (the flame's light), rough where the crust is",
    "nodes": {
        "flow": {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 5.0, "octaves": 7, "gain": 0.55}},
        "cracks": {"op": "smoothstep", "input": "flow", "edge0": 0.47, "edge1": 0.58},
        "crust": {"op": "invert", "input": "cracks"},
    },
    "base_color": {"op": "mix", "a": [0.9, 0.25, 0.03], "b": {"op": "remap", "input": "flow", "colormap": {
        "knots": [0.0, 0.5, 1.0], "colours": [[0.06, 0.05, 0.05], [0.03, 0.025, 0.025], [0.09, 0.06, 0.05]]}}, "mask": "crust"},
    "emissive": {"op": "multiply", "a": {"name": "flame", "turbulence_amount": 0.4, "height": 1.6},
                 "b": {"op": "power", "a": "cracks", "b": 1.5}},
    "roughness": {"op": "mix", "a": 0.35, "b": {"op": "remap", "input": {"op": "texture", "output": "value", "texture": {
        "name": "turbulence", "scale": 24.0, "octaves": 5}}, "curve": {"knots": [0.2, 0.8], "values": [0.7, 1.0]}},
        "mask": "crust"},
    "metallic": 0.0,
    "height": "crust",
    "occlusion": {"op": "mix", "a": 0.6, "b": 1.0, "mask": "crust"},
    "height_scale": 0.006,
}

RUSTED_IRON: dict[str, Any] = {
    "name": "rusted_iron",
    "description": "bare iron, bright and smooth, under patches of rough orange-brown rust (a noise mask between them)",
    "nodes": {
        "patches": {"op": "texture", "output": "value", "texture": {"name": "fbm", "scale": 5.0, "octaves": 7, "gain": 0.6}},
        "rust": {"op": "smoothstep", "input": "patches", "edge0": 0.45, "edge1": 0.56},
        "grain": {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 40.0, "octaves": 4}},
        "brushed": {"op": "texture", "output": "value",
                    "texture": {"name": "noise", "scale": 90.0, "transform": {"scale": [1.0, 0.02, 1.0]}}},
    },
    "base_color": {"op": "mix", "mask": "rust",
                   "a": {"op": "mix", "a": [0.5, 0.5, 0.52], "b": [0.62, 0.62, 0.64], "mask": "brushed"},
                   "b": {"op": "remap", "input": "grain", "colormap": {
                       "knots": [0.2, 0.45, 0.7], "colours": [[0.18, 0.06, 0.02], [0.42, 0.15, 0.04], [0.6, 0.3, 0.09]]}}},
    "metallic": {"op": "mix", "a": 1.0, "b": 0.0, "mask": "rust"},
    "roughness": {"op": "mix", "a": {"op": "mix", "a": 0.22, "b": 0.34, "mask": "brushed"},
                  "b": {"op": "mix", "a": 0.75, "b": 0.95, "mask": "grain"}, "mask": "rust"},
    "height": {"op": "add", "a": "rust", "b": {"op": "multiply", "a": "rust", "b": {"op": "multiply", "a": "grain", "b": 0.5}}},
    "occlusion": {"op": "mix", "a": 1.0, "b": {"op": "mix", "a": 0.6, "b": 1.0, "mask": "grain"}, "mask": "rust"},
    "height_scale": 0.003,
}

GLAZED_CERAMIC_CHECKER: dict[str, Any] = {
    "name": "glazed_ceramic_checker",
    "description": "glazed tiles in cream and cobalt, a glossy glaze with a faint wave in it, the tiles' edges in relief",
    "nodes": {
        "tiles": {"op": "texture", "output": "value", "texture": {"name": "checker", "box": [0.125, 0.125, 0.125]}},
        "wave": {"op": "texture", "output": "value", "texture": {"name": "fbm", "scale": 12.0, "octaves": 4}},
    },
    "base_color": {"op": "multiply", "a": {"op": "mix", "a": [0.03, 0.09, 0.36], "b": [0.86, 0.82, 0.7], "mask": "tiles"},
                   "b": {"op": "mix", "a": 0.93, "b": 1.0, "mask": "wave"}},
    "roughness": {"op": "mix", "a": 0.03, "b": 0.1, "mask": "wave"},
    "metallic": 0.0,
    "height": {"op": "add", "a": {"op": "multiply", "a": "wave", "b": 0.2}, "b": "tiles"},
    "height_scale": 0.0008,
}

BUILTINS: dict[str, dict[str, Any]] = {m["name"]: m for m in (POLISHED_MARBLE, OAK_PLANKS, LAVA, RUSTED_IRON, GLAZED_CERAMIC_CHECKER)}
