"""The output stage: image maps, the textured mesh and the report, written atomically.

What the rest of texbake uses is named here; the modules are this folder's own:

- ``images``: OpenImageIO maps in and out (:func:`write_image`, :func:`read_image`,
  :func:`encode_png_bytes`);
- ``export``: the GLB and OBJ + MTL (:func:`write_glb`, :func:`write_obj`, and of several
  materials :func:`write_glb_parts`, :func:`write_obj_parts`);
- ``report``: ``report.json`` (:func:`bake_report`);
- ``save``: a bake's files written together (:func:`save_result`);
- ``atomic``: a file under a temporary name, renamed when whole (:func:`write_bytes`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .atomic import remove_stale, replacing, write_bytes
    from .export import GlbPart, ObjPart, write_glb, write_glb_parts, write_obj, write_obj_parts
    from .images import encode_png_bytes, read_image, srgb_decode, srgb_encode, write_image
    from .report import BakeTally, bake_report, library_versions, write_json
    from .save import save_result

_HOMES = {name: module for module, names in {
    "images": ["write_image", "read_image", "encode_png_bytes", "srgb_encode", "srgb_decode"],
    "export": ["write_glb", "write_obj", "write_glb_parts", "write_obj_parts", "GlbPart", "ObjPart"],
    "report": ["bake_report", "BakeTally", "write_json", "library_versions"],
    "save": ["save_result"],
    "atomic": ["write_bytes", "replacing", "remove_stale"],
}.items() for name in names}

__all__ = ["write_image", "read_image", "encode_png_bytes", "srgb_encode", "srgb_decode", "write_glb", "write_obj", "write_glb_parts", "write_obj_parts", "GlbPart", "ObjPart", "bake_report", "BakeTally", "write_json", "library_versions", "save_result", "write_bytes", "replacing", "remove_stale"]
__getattr__ = lazy_names(__name__, _HOMES)
