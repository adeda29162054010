"""Thickness: cosine-weighted rays into the mesh (about ``-normal``) to its far side.

The value is the rays' mean distance to their first hit, each capped at ``distance`` (a
ray that leaves through a hole counts as ``distance``), over ``distance``: 0 thin, 1 at
least ``distance`` thick. For a slab of thickness ``t`` that is ``(2t - t²/d) / d`` where
``t <= d`` (the mean of ``min(t / cos, d)`` under the cosine weight).
"""

from __future__ import annotations

import numpy as np

from ..sampling import Scene


def thickness(scene: Scene, points: np.ndarray, normals: np.ndarray, rays: int, distance: float, *, bias: float,
              seed: int = 0) -> np.ndarray:
    """``(n, 1)`` float64 thickness at ``(n, 3)`` points with unit (outward) normals."""
    mean, _ = scene.hemisphere(points, normals, rays, distance, inward=True, bias=bias, seed=seed)
    return np.clip(mean / distance, 0.0, 1.0)[:, None]
