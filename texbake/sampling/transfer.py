"""Transfer from a second mesh: the "high poly to low poly" bake.

From each target surface point, rays go along the normal both ways, at most ``distance``
(the cage extrusion), against the source mesh; the nearer hit is where the texture is
evaluated. Embree works in float32, so the source is re-centred and scaled to a unit
box first (:class:`texbake.sampling.rays.Scene`), and the hit point is rebuilt in float64: the
target point moved the ray distance along its normal (against it for the backward ray).
The face hit is not used.
"""

from __future__ import annotations

import threading

import numpy as np

from .rays import Scene


class SourceMesh:
    """Ray caster against a source mesh.

    ``vertices``: ``(n, 3)`` float64; ``faces``: ``(m, 3)`` int.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        self._mesh = (vertices, faces)
        self._built: Scene | None = None
        self._lock = threading.Lock()  # tile threads cast at once

    @property
    def _scene(self) -> Scene:
        """Built at the first ray (a bake of the source_* mesh maps alone casts none here)."""
        with self._lock:
            if self._built is None:
                self._built = Scene(*self._mesh)  # re-centred and scaled to a unit box for float32
            return self._built

    def project(self, points: np.ndarray, normals: np.ndarray, distance: float):
        """Nearest source hit along ``+normal`` or ``-normal`` within ``distance``.

        Returns ``(hits (n, 3) float64, hit (n,) bool)``; where nothing is hit the
        target point itself is returned and ``hit`` is False.
        """
        n = len(points)
        best_t = np.full(n, np.inf)
        best_dir = np.zeros(n)
        for sign in (1.0, -1.0):
            _, t = self._scene.first_hit(points, sign * normals, max_distance=distance)
            better = t < best_t
            best_t[better] = t[better]
            best_dir[better] = sign
        hit = np.isfinite(best_t)
        out = points.copy()
        out[hit] += (best_dir[hit] * best_t[hit])[:, None] * normals[hit]
        return out, hit
