"""The sampling stage: texel samples to surface samples.

What the rest of texbake uses is named here; the modules are this folder's own:

- ``lookup``: the texel lookup (stratified samples, the faces under them): :class:`Tile`,
  :func:`tiles`, :func:`sample_offsets`, :func:`sample_uv`, :class:`UVLookup`;
- ``rays``: Embree (:class:`Scene`), the one place embreex is imported;
- ``surface``: point, normal and texel footprint under each sample (:class:`SurfaceMap`);
- ``transfer``: rays onto a second (high-poly) mesh;
- ``sampler``: the three chained, :class:`Sampler` -> :class:`Samples`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .lookup import Tile, UVLookup, sample_offsets, sample_uv, tiles
    from .rays import Scene
    from .sampler import Sampler, Samples
    from .surface import SurfaceMap, vertex_normals
    from .transfer import SourceMesh

_HOMES = {name: module for module, names in {
    "lookup": ["Tile", "tiles", "sample_offsets", "sample_uv", "UVLookup"],
    "rays": ["Scene"],
    "surface": ["SurfaceMap", "vertex_normals"],
    "transfer": ["SourceMesh"],
    "sampler": ["Sampler", "Samples"],
}.items() for name in names}

__all__ = ["Tile", "tiles", "sample_offsets", "sample_uv", "UVLookup", "Scene", "SurfaceMap", "vertex_normals", "SourceMesh", "Sampler", "Samples"]
__getattr__ = lazy_names(__name__, _HOMES)
