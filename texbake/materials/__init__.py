"""Materials: a whole PBR texture set (base colour, roughness, metallic, normal, height,
occlusion, emissive, opacity) from one procedural description, its channels layered
from the lecture's textures through a small node graph.

What the rest of texbake uses is named here; the modules are this folder's own:

- ``model``: :class:`Material` (pydantic; JSON and YAML), :func:`parse_material`;
- ``nodes``: the ops of the graph and what each takes and gives (:data:`OPS`);
- ``graph``: the graph checked and resolved: references, cycles, kinds, shared nodes;
- ``builtins``: the built-in materials by name (:data:`BUILTINS`);
- ``program``: the graph as programs of the compiled node kernel (``native/materials.cpp``);
- ``leaves``: textures' colours and values (with their spread over a texel), position, normal, warps;
- ``evaluate``: a material at samples (:class:`Evaluator`, :func:`evaluate_material`);
- ``packing``: channels packed into one image by template (:func:`pack`: ORM, HDRP's mask map).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .builtins import BUILTINS
    from .evaluate import Evaluator, evaluate_material
    from .graph import CHANNELS
    from .model import DEFAULTS, Material, parse_material
    from .nodes import OPS
    from .packing import PACKINGS, PackTemplate, pack, parse_packing

_HOMES = {name: module for module, names in {
    "model": ["Material", "parse_material", "DEFAULTS"],
    "graph": ["CHANNELS"],
    "nodes": ["OPS"],
    "builtins": ["BUILTINS"],
    "evaluate": ["Evaluator", "evaluate_material"],
    "packing": ["PACKINGS", "PackTemplate", "pack", "parse_packing"],
}.items() for name in names}

__all__ = ["Material", "parse_material", "DEFAULTS", "CHANNELS", "OPS", "BUILTINS", "Evaluator", "evaluate_material", "PACKINGS",
           "PackTemplate", "pack", "parse_packing"]
__getattr__ = lazy_names(__name__, _HOMES)
