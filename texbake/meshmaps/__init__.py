"""Mesh maps: maps of the geometry itself, beside the texture's (``BakeSettings.maps``).

What the rest of texbake uses is named here; the modules are this folder's own, one a kind:

- ``kinds``: the names, channels and needs of the kinds (:data:`KINDS`);
- ``texels``: the surface point, normal and face under each texel centre (:class:`TexelPoints`);
- ``occlusion``: ambient occlusion and bent normals (hemisphere rays, compiled);
- ``thickness``: rays into the mesh;
- ``curvature``: mean curvature per vertex (cotangent Laplacian), around 0.5;
- ``position``, ``normals``, ``ids``: the point, the normal and flat ID colours;
- ``highpoly``: high to low, a source mesh's normal and height through a cage (:class:`Source`);
- ``bake``: every kind asked for, for one image (:func:`bake_maps`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .bake import MeshMapContext, Scenes, bake_maps
    from .curvature import vertex_curvature
    from .highpoly import Source
    from .kinds import CHANNELS, KINDS, RAY_KINDS
    from .texels import TexelPoints, texel_points

_HOMES = {name: module for module, names in {
    "kinds": ["CHANNELS", "KINDS", "RAY_KINDS"],
    "texels": ["TexelPoints", "texel_points"],
    "curvature": ["vertex_curvature"],
    "highpoly": ["Source"],
    "bake": ["MeshMapContext", "Scenes", "bake_maps"],
}.items() for name in names}

__all__ = ["CHANNELS", "KINDS", "RAY_KINDS", "TexelPoints", "texel_points", "vertex_curvature", "Source", "MeshMapContext", "Scenes", "bake_maps"]
__getattr__ = lazy_names(__name__, _HOMES)
