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
    "description": "white Carrara-like marble, thin grey veins, polished (the veins a little rougher and lower)",
    "nodes": {
        "veins": {"op": "texture", "output": "value",
                  "texture": {"name": "marble", "frequency": 16.0, "amplitude": 7.0, "transform": {"rotate": [20.0, 35.0, 10.0]},
                              "turbulence": {"scale": 2.0, "octaves": 8, "gain": 0.58}}},
        "vein": {"op": "invert", "input": {"op": "smoothstep", "input": "veins", "edge0": 0.01, "edge1": 0.2}},
        "fine": {"op": "texture", "output": "value",  # fainter, finer veins across the main ones
                 "texture": {"name": "marble", "frequency": 34.0, "amplitude": 9.0, "transform": {"rotate": [-30.0, 70.0, 0.0]},
                             "turbulence": {"scale": 3.0, "octaves": 7, "gain": 0.6, "seed": 7}}},
    },
    "base_color": {"op": "multiply", "b": {"op": "mix", "a": 0.7, "b": 1.0, "mask": {
        "op": "smoothstep", "input": "fine", "edge0": 0.0, "edge1": 0.12}}, "a": {"op": "remap", "input": "veins",
                   "colormap": {"knots": [0.0, 0.04, 0.15, 0.4, 1.0],
                                "colours": [[0.06, 0.065, 0.07], [0.2, 0.21, 0.22], [0.47, 0.47, 0.47], [0.66, 0.65, 0.63],
                                            [0.72, 0.71, 0.69]]}}},
    "roughness": {"op": "mix", "a": 0.05, "b": 0.2, "mask": "vein"},
    "metallic": 0.0,
    "height": {"op": "invert", "input": "vein"},
    "height_scale": 0.0015,
}

OAK_PLANKS: dict[str, Any] = {
    "name": "oak_planks",
    "description": "oak boards in two tints, their grain lines warped by turbulence, the seams between them in relief",
    "nodes": {
        "boards": {"op": "texture", "output": "value",
                   "texture": {"name": "checker", "box": [0.8, 0.09, 0.09], "transform": {"translate": [0.13, 0.0, 0.0]}}},
        "wobble": {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 4.0, "octaves": 5}},
        "grain": {"op": "warp", "by": "wobble", "amount": 0.15, "axis": "y", "output": "value",
                  "texture": {"name": "wood", "ring_width": 0.005, "wobble": 0.05, "wobbles": 3.0, "twist": 0.5,
                              "tilt": [0.0, 90.0, 0.0], "transform": {"translate": [0.0, -1.7, -1.2]}}},
        "fibres": {"op": "texture", "output": "value",
                   "texture": {"name": "noise", "scale": 120.0, "transform": {"scale": [8.0, 1.0, 1.0]}}},
    },
    "base_color": {
        "op": "multiply",
        "a": {"op": "mix", "a": [0.36, 0.2, 0.08], "b": [0.27, 0.14, 0.05], "mask": "boards"},
        "b": {"op": "mix", "a": 1.0, "b": 0.68, "mask": {"op": "multiply", "a": "grain", "b": {"op": "add", "a": 0.55, "b": {
            "op": "multiply", "a": "fibres", "b": 0.6}}}},
    },
    "roughness": {"op": "mix", "a": 0.42, "b": 0.6, "mask": "grain"},
    "metallic": 0.0,
    "height": {"op": "add", "a": {"op": "multiply", "a": "boards", "b": 0.8}, "b": {"op": "multiply", "a": "grain", "b": 0.2}},
    "occlusion": {"op": "mix", "a": 0.88, "b": 1.0, "mask": "boards"},
    "height_scale": 0.0025,
}

LAVA: dict[str, Any] = {
    "name": "lava",
    "description": "black crust over glowing lava (the flame's light) in cracks and pools, rough where the crust is",
    "nodes": {
        "flow": {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 4.0, "octaves": 7, "gain": 0.55}},
        "off": {"op": "subtract", "a": "flow", "b": 0.55},  # the cracks run where the flow is at its median
        "cracks": {"op": "blend", "mode": "screen",
                   "a": {"op": "invert", "input": {"op": "smoothstep", "input": {"op": "power", "a": {
                       "op": "multiply", "a": "off", "b": "off"}, "b": 0.5}, "edge0": 0.0, "edge1": 0.03}},
                   "b": {"op": "smoothstep", "input": "flow", "edge0": 0.66, "edge1": 0.72}},
        "crust": {"op": "invert", "input": "cracks"},
    },
    "base_color": {"op": "mix", "a": [0.8, 0.22, 0.03], "b": {"op": "remap", "input": {
        "op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 30.0, "octaves": 4}},
        "colormap": {"knots": [0.3, 0.55, 0.8], "colours": [[0.02, 0.018, 0.018], [0.045, 0.04, 0.038], [0.09, 0.075, 0.065]]}},
        "mask": "crust"},
    "emissive": {"op": "multiply", "a": {"name": "flame", "turbulence_amount": 0.4, "height": 1.6}, "b": "cracks"},
    "roughness": {"op": "mix", "a": 0.3, "b": {"op": "remap", "input": {"op": "texture", "output": "value", "texture": {
        "name": "turbulence", "scale": 24.0, "octaves": 5}}, "curve": {"knots": [0.3, 0.8], "values": [0.72, 1.0]}},
        "mask": "crust"},
    "metallic": 0.0,
    "height": "crust",
    "occlusion": {"op": "mix", "a": 0.55, "b": 1.0, "mask": "crust"},
    "height_scale": 0.004,
}

RUSTED_IRON: dict[str, Any] = {
    "name": "rusted_iron",
    "description": "bare iron, brushed and smooth, under patches of rough brown rust (a noise mask between them)",
    "nodes": {
        "patches": {"op": "texture", "output": "value", "texture": {"name": "fbm", "scale": 4.0, "octaves": 7, "gain": 0.6}},
        "rust": {"op": "smoothstep", "input": "patches", "edge0": 0.57, "edge1": 0.63},
        "grain": {"op": "texture", "output": "value", "texture": {"name": "turbulence", "scale": 40.0, "octaves": 4}},
        "brushed": {"op": "texture", "output": "value",
                    "texture": {"name": "noise", "scale": 90.0, "transform": {"scale": [12.0, 1.0, 1.0]}}},
    },
    "base_color": {"op": "mix", "mask": "rust",
                   "a": {"op": "mix", "a": [0.45, 0.45, 0.47], "b": [0.58, 0.58, 0.6], "mask": "brushed"},
                   "b": {"op": "remap", "input": "grain", "colormap": {
                       "knots": [0.35, 0.55, 0.75], "colours": [[0.07, 0.025, 0.01], [0.22, 0.075, 0.02], [0.4, 0.17, 0.05]]}}},
    "metallic": {"op": "invert", "input": "rust"},
    "roughness": {"op": "mix", "a": {"op": "mix", "a": 0.22, "b": 0.36, "mask": "brushed"},
                  "b": {"op": "mix", "a": 0.78, "b": 0.97, "mask": "grain"}, "mask": "rust"},
    "height": {"op": "multiply", "a": "rust", "b": {"op": "mix", "a": 0.6, "b": 1.0, "mask": "grain"}},
    "occlusion": {"op": "mix", "a": 1.0, "b": {"op": "mix", "a": 0.65, "b": 1.0, "mask": "grain"}, "mask": "rust"},
    "height_scale": 0.003,
}

GLAZED_CERAMIC_CHECKER: dict[str, Any] = {
    "name": "glazed_ceramic_checker",
    "description": "glazed tiles in cream and cobalt, a glossy glaze with a faint wave in it, the tiles' edges in relief",
    "nodes": {
        "tiles": {"op": "texture", "output": "value", "texture": {"name": "checker", "box": [0.125, 0.125, 0.125]}},
        "wave": {"op": "texture", "output": "value", "texture": {"name": "fbm", "scale": 12.0, "octaves": 4}},
    },
    "base_color": {"op": "multiply", "a": {"op": "mix", "a": [0.04, 0.1, 0.38], "b": [0.78, 0.7, 0.52], "mask": "tiles"},
                   "b": {"op": "mix", "a": 0.92, "b": 1.0, "mask": "wave"}},
    "roughness": {"op": "mix", "a": 0.03, "b": 0.1, "mask": "wave"},
    "metallic": 0.0,
    "height": {"op": "add", "a": {"op": "multiply", "a": "wave", "b": 0.15}, "b": {"op": "multiply", "a": "tiles", "b": 0.85}},
    "height_scale": 0.0008,
}

BUILTINS: dict[str, dict[str, Any]] = {m["name"]: m for m in (POLISHED_MARBLE, OAK_PLANKS, LAVA, RUSTED_IRON, GLAZED_CERAMIC_CHECKER)}
