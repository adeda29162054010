"""The UV atlas stage: a mesh's UVs kept, or unwrapped into charts packed by xatlas.

What the rest of texbake uses is named here; the modules are this folder's own:

- ``decide``: :func:`make_atlas`, the list of attempts (keep, unwrap one way, the other,
  fall back), and :class:`Atlas`, what it returns;
- ``uvcheck``: whether UVs are usable, texel coverage and overlap, UDIM tiles, an atlas's
  statistics;
- ``charts``: planar charts (faces grouped by normal direction, projected onto planes),
  and :class:`Sides`, a double-sided mesh's front and back faces;
- ``pack``: the unwrap in xatlas' worker processes (charting, packing, refitting), and
  ``packworker``, the worker process itself;
- ``parts``: one tile for UVs kept on some parts and the unwrap of the others;
- ``fallback``: the grid atlas, one cell per triangle;
- ``cache``: atlases kept on disk across bakes (:class:`AtlasCache`, :func:`atlas_key`).

The names are imported on first use: ``python -m texbake.atlas.packworker`` imports this
package too, and a worker needs numpy and xatlas only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .cache import AtlasCache, atlas_key
    from .charts import Sides
    from .decide import Atlas, make_atlas
    from .pack import run_xatlas_in_child
    from .uvcheck import atlas_stats, overlap, udim_offset, udim_tiles, uv_problem

_HOMES = {
    "Atlas": "decide", "make_atlas": "decide",
    "AtlasCache": "cache", "atlas_key": "cache",
    "uv_problem": "uvcheck", "atlas_stats": "uvcheck", "overlap": "uvcheck", "udim_tiles": "uvcheck", "udim_offset": "uvcheck",
    "run_xatlas_in_child": "pack",
    "Sides": "charts",
}

__all__ = ["Atlas", "make_atlas", "AtlasCache", "atlas_key", "uv_problem", "atlas_stats", "overlap", "udim_tiles", "udim_offset", "run_xatlas_in_child", "Sides"]
__getattr__ = lazy_names(__name__, _HOMES)
