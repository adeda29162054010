"""Ray casting with Embree (embreex): one wrapper for the texel lookup and the transfer.

Embree works in float32. :class:`Scene` keeps that in one place, in the manner of
trimesh's ``_EmbreeWrap``: the vertices are re-centred on their bounding box and scaled
to a largest side of 1 in float64 before the cast to float32, the ray origins go through
the same map, and distances come back in the caller's units, as float64. A scene whose
coordinates are already of order one (the UV triangles laid flat) can skip the map
(``recentre=False``): its vertices and origins are then only cast.

embreex releases the GIL for the cast (from 4.4.0): the bake's tile threads cast at once.
"""

from __future__ import annotations

import numpy as np


def _embree():
    try:
        from embreex import mesh_construction, rtcore_scene
    except ImportError as exc:  # a dependency of texbake: only a broken install lacks it
        raise ImportError(f"texbake casts rays with Embree: pip install embreex ({exc})") from exc
    return mesh_construction, rtcore_scene


class Scene:
    """A triangle mesh in Embree, for first-hit ray queries.

    ``vertices``: ``(n, 3)`` float (object space); ``faces``: ``(m, 3)`` int indices into
    them (cast to int32). ``recentre``: map the vertices (and every query's origins) to
    the unit box before the float32 cast; False: cast them as they are.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, recentre: bool = True):
        mesh_construction, rtcore_scene = _embree()
        self._centre: np.ndarray | None = None
        self._scale = 1.0
        if recentre:
            vertices = np.asarray(vertices, dtype=np.float64)
            lo, hi = vertices.min(axis=0), vertices.max(axis=0)
            self._centre = 0.5 * (lo + hi)
            self._scale = float(np.max(hi - lo)) or 1.0
            vertices = (vertices - self._centre) / self._scale
        self._scene = rtcore_scene.EmbreeScene()
        mesh_construction.TriangleMesh(self._scene, np.asarray(vertices, dtype=np.float32),
                                       np.asarray(faces, dtype=np.int32))

    def _origins(self, origins: np.ndarray) -> np.ndarray:
        if self._centre is None:
            return np.asarray(origins, dtype=np.float32)
        return ((np.asarray(origins, dtype=np.float64) - self._centre) / self._scale).astype(np.float32)

    @staticmethod
    def _directions(directions: np.ndarray) -> np.ndarray:
        return np.asarray(directions, dtype=np.float32).reshape(-1, 3)

    def first_face(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """``(n,)`` int32 face of the first hit of each ray, -1 where it hits nothing.

        ``origins``: ``(n, 3)`` float; ``directions``: ``(n, 3)``, or ``(3,)`` for one
        direction shared by all rays. No distances: cheaper than :meth:`first_hit`
        (Embree returns no hit record).
        """
        return self._scene.run(self._origins(origins), self._directions(directions))

    def first_hit(self, origins: np.ndarray, directions: np.ndarray,
                  max_distance: float | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(face (n,) int32, distance (n,) float64)`` of the first hit of each ray.

        ``origins``: ``(n, 3)`` float; ``directions``: ``(n, 3)``, or ``(3,)`` for all
        rays; ``max_distance``: a scalar or ``(n,)`` bound on the distance (None: none).
        ``distance`` is the ray parameter of the hit in the caller's units (the hit is
        ``origin + distance * direction``; a length for unit directions); where a ray
        hits nothing ``face`` is -1 and ``distance`` is infinite.
        """
        o = self._origins(origins)
        kwargs = {}
        if max_distance is not None:
            reach = np.asarray(max_distance, dtype=np.float64) / self._scale
            kwargs["dists"] = np.ascontiguousarray(np.broadcast_to(reach, len(o)), dtype=np.float32)  # Embree writes into it
        res = self._scene.run(o, self._directions(directions), output=1, **kwargs)
        face = res["primID"]
        distance = np.where(face >= 0, res["tfar"].astype(np.float64) * self._scale, np.inf)
        return face, distance
