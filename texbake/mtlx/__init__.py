"""MaterialX in and out: a ``.mtlx`` document's surface shader baked as a texbake material.

- ``document``: the document read (the ``materialx`` package, its standard library),
  its shader's channels as flat graphs of primitive nodes (:func:`read_document`);
- ``nodes``: the primitives, evaluated with numpy (:data:`PRIMITIVES`);
- ``noise``: MaterialX's ``mx_noise`` ported (Perlin, cell, fractal, Worley);
- ``evaluate``: a document at points (:func:`evaluate_mtlx`);
- ``material``: a document as a :class:`texbake.materials.Material` (:func:`material_from_mtlx`);
- ``write``: the baked document, its inputs ``image`` nodes on the maps (:func:`write_mtlx`).

Needs the optional extra: ``pip install texbake[mtlx]``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._lazy import lazy_names

if TYPE_CHECKING:
    from .document import Document, read_document
    from .evaluate import evaluate_mtlx
    from .nodes import PRIMITIVES

_HOMES = {name: module for module, names in {
    "document": ["Document", "read_document"],
    "evaluate": ["evaluate_mtlx"],
    "nodes": ["PRIMITIVES"],
}.items() for name in names}

__all__ = ["Document", "read_document", "evaluate_mtlx", "PRIMITIVES"]
__getattr__ = lazy_names(__name__, _HOMES)
