"""Ambient occlusion and bent normals: cosine-weighted hemisphere rays about each texel's
normal (``Scene.hemisphere``, compiled: packets of 8 rays on every core).

AO is the share of ``rays`` rays that hit nothing within ``distance`` (1 open, 0 shut in),
what Blender's and Substance's AO bakes write; the bent normal is the mean direction of
the rays that got out, 0.5 + 0.5 n in object space (the normal itself where none did).
"""

from __future__ import annotations

import numpy as np

from ..sampling import Scene


def ambient_occlusion(scene: Scene, points: np.ndarray, normals: np.ndarray, rays: int, distance: float, *, bias: float,
                      seed: int = 0, bent: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """``(ao (n, 1) float64, bent (n, 3) float64 encoded or None)`` at ``(n, 3)`` points with unit normals."""
    open_share, directions = scene.hemisphere(points, normals, rays, distance, bias=bias, seed=seed, bent=bent)
    return open_share[:, None], None if directions is None else 0.5 + 0.5 * directions
