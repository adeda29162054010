"""Position maps: the surface point in the mesh's bounding box.

``object``: each axis from its own bounds to 0..1 (the whole range of each channel used);
``world``: one scale for every axis, the box's largest side, from its low corner (the
proportions kept: a point's channels compare across axes).
"""

from __future__ import annotations

import numpy as np


def position(points: np.ndarray, lo: np.ndarray, hi: np.ndarray, *, space: str) -> np.ndarray:
    """``(n, 3)`` float64 in [0, 1] of ``(n, 3)`` points in the box ``lo``, ``hi`` ``(3,)``."""
    side = np.asarray(hi, dtype=np.float64) - np.asarray(lo, dtype=np.float64)
    if space == "world":
        side = np.full(3, float(side.max()))
    side = np.where(side > 0, side, 1.0)  # a flat axis: its one value at 0
    return np.clip((points - lo) / side, 0.0, 1.0)
