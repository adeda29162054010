"""The maps stage: values per texel sample into images, and what is done to the images.

What the rest of texbake uses is named here; the modules are this folder's own:

- ``accumulate``: :class:`Maps`, only the maps asked for, each texel the mean of its samples;
- ``shading``: the lecture's decal and lit shading (:func:`lit`);
- ``bump``: a tangent-space normal map from a scalar texture (:func:`normal_map`);
- ``margin``: the "extend" fill around charts (:func:`extend`);
- ``estimate``: the error estimate made while baking (:func:`probe_estimate`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .accumulate import Maps
    from .bump import LUMINANCE, normal_map
    from .estimate import probe_estimate, probe_grid
    from .margin import extend
    from .shading import lit

_HOMES = {name: module for module, names in {
    "accumulate": ["Maps"],
    "shading": ["lit"],
    "bump": ["normal_map", "LUMINANCE"],
    "margin": ["extend"],
    "estimate": ["probe_estimate", "probe_grid"],
}.items() for name in names}

__all__ = ["Maps", "lit", "normal_map", "LUMINANCE", "extend", "probe_estimate", "probe_grid"]
__getattr__ = lazy_names(__name__, _HOMES)
