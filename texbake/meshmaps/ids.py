"""ID maps: a flat colour per material, part or UV chart.

Colours are spread around the hue circle by the golden ratio (ID ``i`` at hue ``0.618 i``),
so that neighbouring IDs differ most, at full saturation and value; the same ID gets the
same colour in every bake. Charts are the atlas' faces joined by shared atlas (UV) vertices.
"""

from __future__ import annotations

import colorsys

import numpy as np

from ..mesh.components import connected_components

_GOLDEN = 0.6180339887498949


def id_colours(count: int) -> np.ndarray:
    """``(count, 3)`` float64 colours of IDs ``0 .. count-1``."""
    return np.array([colorsys.hsv_to_rgb((i * _GOLDEN) % 1.0, 0.85, 0.95) for i in range(max(count, 1))])


def charts(uv_faces: np.ndarray, uv_vertices: int) -> np.ndarray:
    """``(m,)`` int64 chart of each face of ``uv_faces`` ``(m, 3)`` (atlas-vertex indices of
    ``uv_vertices`` vertices), numbered from 0 in order of first face."""
    f = np.asarray(uv_faces, dtype=np.int64)
    a = np.concatenate([f[:, 0], f[:, 1]])
    b = np.concatenate([f[:, 1], f[:, 2]])
    component = connected_components(uv_vertices, a, b)[f[:, 0]]
    _, first, numbered = np.unique(component, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))  # number charts by their first face
    return order[numbered.reshape(-1)]


def id_values(ids: np.ndarray, face: np.ndarray) -> np.ndarray:
    """``(n, 3)`` float64 colours at texels on ``face`` ``(n,)``, from each face's ``ids`` ``(m,)`` int."""
    ids = np.asarray(ids, dtype=np.int64)
    return id_colours(int(ids.max()) + 1 if len(ids) else 1)[ids[face]]
