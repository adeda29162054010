"""High to low: the source (high-poly) mesh's surface as the target sees it, through a cage.

From each target texel a ray is cast inward, onto the source: from the cage mesh's point at
the same face and barycentric coordinates (``cage``: the target's topology, its vertices
moved out) towards the target point and on past it by ``back``; without a cage, from the
point moved ``front`` along the target's smooth normal, along ``-normal``, ``front + back``
long (Blender's "extrusion" and "max ray distance", Substance's frontal and rear
distances). The first hit is the source surface seen from outside. Normals for the rays are
the target's smooth (welded) ones, so that rays do not part at hard edges.

Parts are matched by name as Substance and Marmoset do: a target part ``X_low`` sees only
the source parts ``X_high`` (case-insensitive suffixes), so that one part never projects
onto another; a target part without a match sees the whole source.

Maps: ``source_normal`` the source's smooth normal in the target's tangent frame (the
output mesh's, as a MikkTSpace viewer rebuilds it: ``texbake.mesh.tangents``), 0.5 + 0.5 n;
``source_height`` the hit's signed distance along the normal, 0.5 + 0.5 h / max(front,
back); ``source_missed`` 1 where the ray found nothing (then the normal is flat and the
height 0.5).
"""

from __future__ import annotations

import re
import threading
from dataclasses import dataclass, field

import numpy as np

from ..sampling import Scene, vertex_normals

_SUFFIX = re.compile(r"[_.\-](low|high)$", re.IGNORECASE)


def part_key(name: str) -> tuple[str, str | None]:
    """``(base, "low" | "high" | None)`` of a part name: ``"bolt_high"`` -> ``("bolt", "high")``."""
    found = _SUFFIX.search(name)
    if found is None:
        return name.lower(), None
    return name[: found.start()].lower(), found.group(1).lower()


def match_parts(target_names: list[str], source_names: list[str]) -> dict[int, np.ndarray]:
    """``target part -> (k,) int64 source parts`` for each target ``X_low`` with source ``X_high``s."""
    highs: dict[str, list[int]] = {}
    for i, name in enumerate(source_names):
        base, kind = part_key(name)
        if kind == "high":
            highs.setdefault(base, []).append(i)
    out = {}
    for i, name in enumerate(target_names):
        base, kind = part_key(name)
        if kind == "low" and base in highs:
            out[i] = np.array(highs[base], dtype=np.int64)
    return out


@dataclass
class Source:
    """The source mesh of a high-to-low bake: ``vertices`` ``(n, 3)``, ``faces`` ``(m, 3)``,
    ``part`` ``(m,)`` int or None and ``part_names``; scenes (the whole, and a part group's)
    are built on first use."""

    vertices: np.ndarray
    faces: np.ndarray
    part: np.ndarray | None = None
    part_names: list[str] = field(default_factory=list)
    _scenes: dict = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __post_init__(self) -> None:
        # weighted by corner angle, as the DCC tools (Blender, Maya) shade a smooth mesh: on an
        # irregular scan (an ogre of 124k faces onto 3.7k) the median angle to Blender's normal
        # map went from 0.39° with area weights to 0.08°
        self.normals = vertex_normals(np.asarray(self.vertices, dtype=np.float64), np.asarray(self.faces, dtype=np.int64), weights="angle")

    def scene(self, parts: tuple[int, ...] | None) -> tuple[Scene, np.ndarray]:
        """``(scene, corners (k, 3) int64 of the source faces it holds, in its order)``: of
        the source parts ``parts``, or all."""
        with self._lock:
            if parts not in self._scenes:
                chosen = np.arange(len(self.faces)) if parts is None or self.part is None else np.flatnonzero(np.isin(self.part, parts))
                corners = np.ascontiguousarray(np.asarray(self.faces, dtype=np.int64)[chosen])
                self._scenes[parts] = Scene(self.vertices, corners), corners
            return self._scenes[parts]


@dataclass
class Rays:
    """Where the rays start and how far they go: ``front``, ``back`` (lengths), ``cage``
    ``(n, 3)`` float64 cage vertices in the target mesh's vertex order, or None."""

    front: float
    back: float
    cage: np.ndarray | None = None


def project(source: Source, rays: Rays, points: np.ndarray, normals: np.ndarray, cage_points: np.ndarray | None,
            groups: np.ndarray | None, matches: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(hit (n,) bool, distance (n,) float64 signed along the normal, source normal (n, 3))``
    of the rays from ``points`` with unit smooth ``normals`` (``(n, 3)`` each; ``cage_points``
    the cage's points there, or None), a target part each (``groups`` ``(n,)`` or None);
    cast, hit and interpolated in one compiled pass (``Scene.project``)."""
    n = len(points)
    if groups is None or not matches:  # every texel sees the whole source: no gathering of rows
        scene, corners = source.scene(None)
        return scene.project(points, normals, cage_points, rays.front, rays.back, source.normals, corners)
    hit, depth, normal = np.zeros(n, dtype=bool), np.zeros(n), np.zeros((n, 3))
    for parts, rows in _groups(groups, matches, n):
        scene, corners = source.scene(parts)
        hit[rows], depth[rows], normal[rows] = scene.project(points[rows], normals[rows], None if cage_points is None else cage_points[rows],
                                                             rays.front, rays.back, source.normals, corners)
    return hit, depth, normal


def _groups(groups: np.ndarray | None, matches: dict[int, np.ndarray], n: int):
    """``(source parts or None, rows)`` of the texels that see each set of source parts."""
    if groups is None or not matches:
        yield None, np.arange(n)
        return
    matched = np.isin(groups, list(matches))
    if (~matched).any():
        yield None, np.flatnonzero(~matched)
    for target, parts in matches.items():
        rows = np.flatnonzero(groups == target)
        if len(rows):
            yield tuple(int(p) for p in parts), rows


def tangent_space(normals: np.ndarray, frame: np.ndarray, directx: bool = False) -> np.ndarray:
    """``(n, 3)`` float64 ``0.5 + 0.5 c``: unit ``normals`` ``(n, 3)`` as the coefficients ``c``
    a viewer multiplies its frame by (rows ``T, B, N`` of ``frame`` ``(n, 3, 3)``:
    ``normalize(c_x T + c_y B + c_z N)`` gives the normal back), made unit."""
    coefficients = np.einsum("nij,nj->ni", frame, normals)  # the frame is orthonormal (sample_frames): its inverse its transpose
    length = np.linalg.norm(coefficients, axis=1, keepdims=True)
    c = np.divide(coefficients, length, out=np.tile([0.0, 0.0, 1.0], (len(normals), 1)), where=length > 0)
    encoded = 0.5 + 0.5 * c
    if directx:
        encoded[:, 1] = 1.0 - encoded[:, 1]
    return encoded
