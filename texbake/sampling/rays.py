"""Ray casting with Embree (embreex): one wrapper for the texel lookup and the transfer.

Embree works in float32. :class:`Scene` keeps that in one place, in the manner of
trimesh's ``_EmbreeWrap``: the vertices are re-centred on their bounding box and scaled
to a largest side of 1 in float64 before the cast to float32, the ray origins go through
the same map, and distances come back in the caller's units, as float64. A scene whose
coordinates are already of order one (the UV triangles laid flat) can skip the map
(``recentre=False``): its vertices and origins are then only cast.

The scene is built and the rays are cast by the compiled kernels (``native/embree.cpp``)
through the Embree 4 library that embreex ships: embreex's own binding copies a scene into
Embree one element at a time through Python (about 1.3 s a million faces). They set the
scene and the rays up as embreex does (the same faces for the same rays), release the GIL
(the bake's tile threads cast at once) and commit the scene when it is made. Where that
library is not found beside embreex (another layout of its wheel), embreex's binding is used.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from .. import _native


def _embree():
    try:
        from embreex import mesh_construction, rtcore_scene
    except ImportError as exc:  # a dependency of texbake: only a broken install lacks it
        raise ImportError(f"texbake casts rays with Embree: pip install embreex ({exc})") from exc
    return mesh_construction, rtcore_scene


@functools.cache
def compiled() -> bool:
    """Whether the compiled kernels cast (they found and opened embreex's Embree 4 library)."""
    _, rtcore_scene = _embree()  # loads the library (and its threading library) into the process
    folder = Path(rtcore_scene.__file__).resolve().parent.parent / "embreex.libs"
    found = sorted(folder.glob("libembree4*.so*"))
    if not found:
        return False
    try:
        _native.embree_open(str(found[0]))
    except RuntimeError:
        return False
    return True


class Scene:
    """A triangle mesh in Embree, for first-hit ray queries.

    ``vertices``: ``(n, 3)`` float (object space); ``faces``: ``(m, 3)`` int indices into
    them. ``recentre``: map the vertices (and every query's origins) to the unit box
    before the float32 cast; False: cast them as they are.
    """

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, *, recentre: bool = True):
        self._centre: np.ndarray | None = None
        self._scale = 1.0
        if recentre:
            vertices = np.asarray(vertices, dtype=np.float64)
            lo, hi = vertices.min(axis=0), vertices.max(axis=0)
            self._centre = 0.5 * (lo + hi)
            self._scale = float(np.max(hi - lo)) or 1.0
            vertices = (vertices - self._centre) / self._scale
        vertices = np.ascontiguousarray(vertices, dtype=np.float32)
        if compiled():
            self._compiled = _native.EmbreeScene(vertices, np.ascontiguousarray(faces, dtype=np.int64))
            return
        mesh_construction, rtcore_scene = _embree()
        self._compiled = None
        self._scene = rtcore_scene.EmbreeScene()
        mesh_construction.TriangleMesh(self._scene, vertices, np.asarray(faces, dtype=np.int32))

    def _cast(self, origins: np.ndarray, directions: np.ndarray, tfar: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """``(face (n,) int32, tfar (n,) float32)`` of the rays (embreex's ``run``: -1 and the
        bound where nothing is hit; the bound 1e37 where ``tfar`` is None)."""
        o, d = self._origins(origins), self._directions(directions)
        tfar = np.full(len(o), 1e37, dtype=np.float32) if tfar is None else tfar
        if self._compiled is not None:
            face = np.empty(len(o), dtype=np.int32)
            self._compiled.cast(np.ascontiguousarray(o), np.ascontiguousarray(d), face, tfar)
            return face, tfar
        res = self._scene.run(o, d, dists=tfar, output=1)
        return res["primID"], res["tfar"]

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
        direction shared by all rays.
        """
        return self._cast(origins, directions, None)[0]

    def first_hit(self, origins: np.ndarray, directions: np.ndarray,
                  max_distance: float | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(face (n,) int32, distance (n,) float64)`` of the first hit of each ray.

        ``origins``: ``(n, 3)`` float; ``directions``: ``(n, 3)``, or ``(3,)`` for all
        rays; ``max_distance``: a scalar or ``(n,)`` bound on the distance (None: none).
        ``distance`` is the ray parameter of the hit in the caller's units (the hit is
        ``origin + distance * direction``; a length for unit directions); where a ray
        hits nothing ``face`` is -1 and ``distance`` is infinite.
        """
        n = len(origins)
        bound = None
        if max_distance is not None:
            reach = np.asarray(max_distance, dtype=np.float64) / self._scale
            bound = np.ascontiguousarray(np.broadcast_to(reach, n), dtype=np.float32)  # Embree writes into it
        face, tfar = self._cast(origins, directions, bound)
        distance = np.where(face >= 0, tfar.astype(np.float64) * self._scale, np.inf)
        return face, distance

    def first_hit_bary(self, origins: np.ndarray, directions: np.ndarray,
                       max_distance: float | np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`first_hit` with each hit's barycentric coordinates: ``(face (n,) int32,
        distance (n,) float64, bary (n, 3) float64)``, the hit ``bary @ triangle`` (Embree's
        float32 ``u, v`` of corners 1 and 2; 0 where nothing is hit). Compiled: every core."""
        n = len(origins)
        reach = np.inf if max_distance is None else np.asarray(max_distance, dtype=np.float64) / self._scale
        tfar = np.ascontiguousarray(np.broadcast_to(np.minimum(reach, 1e37), n), dtype=np.float32)
        o, d = self._origins(origins), self._directions(directions)
        if self._compiled is not None:
            face, uv = np.empty(n, dtype=np.int32), np.empty((n, 2), dtype=np.float32)
            self._compiled.cast_uv(np.ascontiguousarray(o), np.ascontiguousarray(d), face, tfar, uv)
        else:
            res = self._scene.run(o, d, dists=tfar, output=1)
            face, tfar = res["primID"], res["tfar"]
            uv = np.column_stack([res["u"], res["v"]]) * (face >= 0)[:, None]
        u, v = uv[:, 0].astype(np.float64), uv[:, 1].astype(np.float64)
        distance = np.where(face >= 0, tfar.astype(np.float64) * self._scale, np.inf)
        return face, distance, np.column_stack([1.0 - u - v, u, v])

    def project(self, points: np.ndarray, normals: np.ndarray, cage: np.ndarray | None, front: float, back: float,
                vertex_normals: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """High to low onto this scene (``texbake.meshmaps.highpoly``): ``(hit (n,) bool,
        depth (n,) float64, normal (n, 3) float64)`` of the ray of each target point.

        ``points``, ``normals``: ``(n, 3)`` float64, unit smooth normals; ``cage``: ``(n, 3)``
        the cage's points there (the ray goes from it towards the point and ``back`` past
        it), or None (from ``point + front * normal`` along ``-normal``, ``front + back``
        long). ``vertex_normals`` ``(k, 3)`` and ``faces`` ``(m, 3)``: the scene's faces, in
        its order, and their smooth normals, interpolated at the hit (unit; 0 where none).
        ``depth``: the hit's signed distance from the point along its normal (0 where none).
        Compiled: every core, one pass; else numpy through :meth:`first_hit_bary`.
        """
        points, normals = np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(normals, dtype=np.float64)
        n = len(points)
        if self._compiled is not None:
            hit, depth, normal = np.empty(n, dtype=np.uint8), np.empty(n), np.empty((n, 3))
            centre = np.zeros(3) if self._centre is None else self._centre
            self._compiled.project(points, normals, np.zeros((0, 3)) if cage is None else np.ascontiguousarray(cage, dtype=np.float64),
                                   float(front), float(back), np.ascontiguousarray(centre, dtype=np.float64), float(self._scale),
                                   np.ascontiguousarray(vertex_normals, dtype=np.float64), np.ascontiguousarray(faces, dtype=np.int64),
                                   hit, depth, normal)
            return hit.astype(bool), depth, normal
        if cage is not None:
            towards = points - cage
            length = np.linalg.norm(towards, axis=1)
            direction = np.divide(towards, length[:, None], out=-normals.copy(), where=length[:, None] > 0)
            origin, reach = np.asarray(cage, dtype=np.float64), length + back
        else:
            origin, direction, reach = points + front * normals, -normals, np.full(n, front + back)
        face, distance, bary = self.first_hit_bary(origin, direction, reach)
        found = face >= 0
        normal = np.zeros((n, 3))
        corners = np.asarray(faces, dtype=np.int64)[face[found]]
        smooth = np.einsum("ni,nij->nj", bary[found], np.asarray(vertex_normals, dtype=np.float64)[corners])
        length = np.linalg.norm(smooth, axis=1, keepdims=True)
        normal[found] = np.divide(smooth, length, out=np.zeros_like(smooth), where=length > 0)
        t = np.where(found, distance, 0.0)
        depth = np.where(found, np.einsum("ij,ij->i", origin + t[:, None] * direction - points, normals), 0.0)
        return found, depth, normal

    def hemisphere(self, points: np.ndarray, normals: np.ndarray, rays: int, distance: float, *, inward: bool = False,
                   bent: bool = False, bias: float = 1e-4, seed: int = 0) -> tuple[np.ndarray, np.ndarray | None]:
        """Cosine-weighted hemisphere rays from each point (compiled: packets of 8, every core).

        ``points``, ``normals``: ``(n, 3)`` float (unit normals); ``rays`` a point, at most
        ``distance`` long (caller's units); ``bias``: the origins' offset along the normal,
        caller's units. Outward: ``(open (n,) float64, the share of rays that hit nothing;
        bent (n, 3) float64 unit mean open direction, or None unless ``bent``)``. ``inward``
        (about ``-normal``): ``(mean distance (n,) float64 to the first hit, each capped at
        ``distance``, None)``.
        """
        if self._compiled is None:
            raise RuntimeError("hemisphere rays need texbake's compiled Embree kernels (embreex's Embree 4 library was not found)")
        n = len(points)
        value = np.empty(n, dtype=np.float32)
        out = np.empty((n if bent else 0, 3), dtype=np.float32)
        unit = np.ascontiguousarray(normals, dtype=np.float32)
        self._compiled.hemisphere(np.ascontiguousarray(self._origins(points)), unit, int(rays), float(distance / self._scale),
                                  float(bias / self._scale), int(seed) & 0xFFFFFFFF, bool(inward), value, out)
        scale = self._scale if inward else 1.0
        return value.astype(np.float64) * scale, out.astype(np.float64) if bent else None
