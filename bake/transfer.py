"""Transfer from a second mesh: the "high poly to low poly" bake.

From each target surface point, rays go along the normal both ways, at most ``distance``
(the cage extrusion), against the source mesh; the nearer hit is where the texture is
evaluated. Embree works in float32, so the source is re-centred and scaled to a unit
box first and the hit point is rebuilt in float64 from the face and the ray distance.
"""

from __future__ import annotations

import numpy as np


class SourceMesh:
    """Ray caster against a source mesh.

    ``vertices``: ``(n, 3)`` float64; ``faces``: ``(m, 3)`` int.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        from embreex import mesh_construction, rtcore_scene  # pip install embreex

        vertices = np.asarray(vertices, dtype=np.float64)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        self._centre = 0.5 * (lo + hi)
        self._scale = float(np.max(hi - lo)) or 1.0
        local = ((vertices - self._centre) / self._scale).astype(np.float32)
        self._scene = rtcore_scene.EmbreeScene()
        mesh_construction.TriangleMesh(self._scene, local, np.asarray(faces, dtype=np.int32))

    def project(self, points: np.ndarray, normals: np.ndarray, distance: float):
        """Nearest source hit along ``+normal`` or ``-normal`` within ``distance``.

        Returns ``(hits (n, 3) float64, hit (n,) bool)``; where nothing is hit the
        target point itself is returned and ``hit`` is False.
        """
        n = len(points)
        origins = ((points - self._centre) / self._scale).astype(np.float32)
        reach = np.full(n, distance / self._scale, dtype=np.float32)
        best_t = np.full(n, np.inf)
        best_dir = np.zeros(n)
        for sign in (1.0, -1.0):
            dirs = (sign * normals).astype(np.float32)
            res = self._scene.run(origins, dirs, dists=reach.copy(), output=1)
            t = np.where(res["primID"] >= 0, res["tfar"].astype(np.float64), np.inf)
            better = t < best_t
            best_t[better] = t[better]
            best_dir[better] = sign
        hit = np.isfinite(best_t)
        out = points.copy()
        out[hit] += (best_dir[hit] * best_t[hit] * self._scale)[:, None] * normals[hit]
        return out, hit
