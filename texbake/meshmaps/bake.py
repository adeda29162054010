"""Every mesh map asked for, for one image: the texel centres row tile by row tile
(``texels``), each kind's values there, written into ``(h, w, c)`` float32 images.

What a kind needs comes in a :class:`MeshMapContext`, made by the pipeline for the image:
the ray scene (the whole mesh's, or the set's), the bounds, the image mesh's faces and each
face's material, part and chart. Rays go through the compiled hemisphere kernel, one
tile's texels at a time over every core; the tally counts them and their seconds.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from .. import _native
from ..errors import ParameterError
from ..sampling import Sampler, Scene, tiles, vertex_normals
from .curvature import curvature_values, vertex_curvature
from .highpoly import Rays, Source, match_parts, project
from .ids import charts, id_values
from .kinds import CHANNELS, RAY_KINDS, SOURCE_KINDS
from .normals import encoded_normals
from .occlusion import ambient_occlusion
from .position import position
from .texels import TexelPoints, texel_points
from .thickness import thickness

BIAS = 1e-4  # the rays' offset off the surface, a share of the bounding-box diagonal (float32's reach, with room)


class Scenes:
    """Ray scenes of a bake, each built on first use and kept for its other images; and a
    high-to-low bake's ``source`` (:class:`highpoly.Source`) and ``cage`` (``(n, 3)`` float64
    vertices, in the order of ``mesh``'s: the bake's mesh, ``(vertices, faces)``)."""

    def __init__(self, source: Source | None = None, cage: np.ndarray | None = None,
                 mesh: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self._made: dict[tuple[int, int], Scene] = {}
        self._lock = threading.Lock()
        self.source, self.cage, self.mesh = source, cage, mesh

    def get(self, vertices: np.ndarray, faces: np.ndarray) -> Callable[[], Scene]:
        """A callable giving the scene of ``vertices`` ``(n, 3)`` and ``faces`` ``(m, 3)``."""

        def scene() -> Scene:
            with self._lock:  # one build, whichever image asks first
                key = (id(vertices), id(faces))
                if key not in self._made:
                    self._made[key] = Scene(vertices, faces)
                return self._made[key]

        return scene


@dataclass
class HighContext:
    """A high-to-low image's: the ``source``, the ``rays`` (front, back, the image mesh's cage
    vertices or None), the image mesh's smooth vertex ``normals`` ``(n, 3)``, target part ->
    source parts ``matches`` and whether the normal map's green is DirectX's."""

    source: Source
    rays: Rays
    normals: np.ndarray
    matches: dict[int, np.ndarray]
    directx: bool = False

    @classmethod
    def for_image(cls, settings, tile_mesh, faces: np.ndarray, scenes: Scenes, diagonal: float) -> HighContext:
        if scenes.source is None:
            raise ParameterError("maps", "source_normal, source_height and source_missed need a source mesh (--source)")
        cage = None
        if scenes.cage is not None:
            assert scenes.mesh is not None
            if len(tile_mesh.vertices) != len(scenes.mesh[0]) or not np.array_equal(tile_mesh.faces, scenes.mesh[1]):
                raise ParameterError("cage_mesh", "a cage mesh needs one texture set of every face and no UDIM tiles "
                                     "(texture_set='single')")
            cage = scenes.cage
        front = settings.front_distance or settings.cage or 0.05 * diagonal
        back = settings.back_distance or front
        matches = match_parts(tile_mesh.part_names, scenes.source.part_names) if tile_mesh.part is not None else {}
        return cls(scenes.source, Rays(front, back, cage), vertex_normals(tile_mesh.vertices, faces), matches,
                   settings.normal_convention == "directx")


@dataclass
class MeshMapContext:
    """What one image's mesh maps read besides its texels.

    ``kinds``: the maps (``BakeSettings.maps``); ``rays``, ``distance``: rays a texel and
    their length; ``scale``: the curvature's; ``lo``, ``hi``: ``(3,)`` float64 bounds (the
    whole mesh's); ``scene``: a callable giving the occluders' :class:`Scene` (built on
    first use, shared by the images of a bake; thickness's rays hit it too);
    ``vertices`` ``(n, 3)``, ``faces`` ``(f, 3)``: the sampler's mesh (its faces as the
    sampler has them); ``material``, ``part``, ``chart``: ``(f,)`` int each face's IDs.
    """

    kinds: tuple[str, ...]
    rays: int
    distance: float
    scale: float
    lo: np.ndarray
    hi: np.ndarray
    scene: Callable[[], Scene]
    vertices: np.ndarray
    faces: np.ndarray
    material: np.ndarray
    part: np.ndarray
    chart: np.ndarray
    seed: int = 0
    high: HighContext | None = None
    _curvature: np.ndarray | None = field(default=None, repr=False)

    @classmethod
    def for_image(cls, settings, whole, tile_mesh, atlas, scenes: Scenes) -> MeshMapContext:
        """The context of the image of ``tile_mesh`` (a ``LoadedMesh``: a texture set's faces,
        or its UDIM tile's) and its ``atlas``, in a bake of ``whole`` with ``settings``
        (``BakeSettings``); its faces as the pipeline's sampler has them (a double-sided
        mesh's front faces)."""
        from ..atlas import Sides

        front = Sides.of(tile_mesh.faces).front if atlas.stats.get("double_sided_faces") else np.arange(len(tile_mesh.faces))
        lo, hi = whole.vertices.min(axis=0), whole.vertices.max(axis=0)
        diagonal = float(np.linalg.norm(hi - lo)) or 1.0
        occluders = whole if settings.occluders == "all" else tile_mesh
        zeros = np.zeros(len(front), dtype=np.int64)
        kinds = tuple(settings.maps or ())
        faces = tile_mesh.faces[front]
        high = HighContext.for_image(settings, tile_mesh, faces, scenes, diagonal) if set(kinds) & set(SOURCE_KINDS) else None
        return cls(kinds, settings.map_rays, settings.map_distance or diagonal,
                   settings.curvature_scale or 0.02 * diagonal, lo, hi, scenes.get(occluders.vertices, occluders.faces),
                   tile_mesh.vertices, faces, zeros if tile_mesh.material is None else tile_mesh.material[front],
                   zeros if tile_mesh.part is None else tile_mesh.part[front], charts(atlas.faces[front], len(atlas.uv)), settings.seed,
                   high)

    @property
    def bias(self) -> float:
        return BIAS * float(np.linalg.norm(self.hi - self.lo))

    def curvature(self) -> np.ndarray:
        if self._curvature is None:
            self._curvature = vertex_curvature(self.vertices, self.faces)
        return self._curvature


def bake_maps(context: MeshMapContext, sampler: Sampler, tile_texels: int = 1 << 18,
              workers: int = 1) -> tuple[dict[str, np.ndarray], np.ndarray, dict]:
    """``(images, covered, tally)``: ``kind -> (h, w, c)`` float32 image (zero where no face
    is), the ``(h, w)`` bool texels whose centre a face covers, and ``{"maps", "texels",
    "rays", "ray_seconds", "rays_per_second"}`` for the report. Row tiles run on ``workers``
    threads: the lookup, the rays and most of numpy release the GIL, and each tile writes
    its own rows."""
    width, height = sampler.width, sampler.height
    images = {kind: np.zeros((height, width, CHANNELS[kind]), dtype=np.float32) for kind in context.kinds}
    covered = np.zeros(height * width, dtype=bool)
    if "curvature" in context.kinds:
        context.curvature()  # made once, before the threads share the context

    def one(tile) -> tuple[int, int, float]:
        t = texel_points(sampler, tile)
        start = time.perf_counter()
        values = _values(context, t)
        seconds = time.perf_counter() - start if any(k in RAY_KINDS for k in context.kinds) else 0.0
        flags = values.get("source_missed")
        missed = int(np.sum(flags)) if flags is not None else 0
        covered[t.texel] = True
        for kind, v in values.items():
            if kind in context.kinds and v is not None:
                images[kind].reshape(height * width, CHANNELS[kind])[t.texel] = v
        return len(t.texel), missed, seconds

    row_tiles = list(tiles(height, width, 1, tile_texels))
    if any(k in RAY_KINDS for k in context.kinds):
        workers = 1  # the hemisphere kernel spreads each tile's rays over every core itself (and ray_seconds stays wall time)
    if workers > 1 and len(row_tiles) > 1:
        with ThreadPoolExecutor(min(workers, len(row_tiles))) as pool:
            done = list(pool.map(one, row_tiles))
    else:
        done = [one(tile) for tile in row_tiles]
    texels, missed = sum(d[0] for d in done), sum(d[1] for d in done)
    ray_seconds = sum(d[2] for d in done)
    per_texel = ("ao" in context.kinds or "bent_normal" in context.kinds) + ("thickness" in context.kinds)
    rays = texels * context.rays * per_texel
    tally = {"maps": list(context.kinds), "texels": texels, "rays": rays, "ray_seconds": round(ray_seconds, 4),
             "rays_per_second": round(rays / ray_seconds) if rays and ray_seconds > 0 else None,
             **({} if context.high is None else {"source_rays": texels, "source_missed": missed, "cage": context.high.rays.cage is not None,
                                                 "front_distance": context.high.rays.front, "back_distance": context.high.rays.back})}
    return images, covered.reshape(height, width), tally


def _high_values(c: MeshMapContext, h: HighContext, t: TexelPoints) -> dict[str, np.ndarray]:
    """The source_* maps at the texels ``t`` (``highpoly.project``)."""
    face = np.ascontiguousarray(t.face, dtype=np.int64)
    smooth = np.empty((len(face), 3))  # the unit interpolated normal, 0 where none (compiled: one pass)
    _native.interpolated_normals(face, np.ascontiguousarray(t.bary, dtype=np.float64), np.ascontiguousarray(c.faces, dtype=np.int64),
                                 np.ascontiguousarray(h.normals, dtype=np.float64), smooth)
    cage = None if h.rays.cage is None else np.einsum("ni,nij->nj", t.bary, h.rays.cage[c.faces[t.face]])
    hit, depth, normal = project(h.source, h.rays, t.points, smooth, cage, c.part[t.face] if h.matches else None, h.matches)
    out = {"source_missed": (~hit).astype(np.float64)[:, None],
           "source_height": np.where(hit, np.clip(0.5 + 0.5 * depth / max(h.rays.front, h.rays.back), 0.0, 1.0), 0.5)[:, None]}
    if "source_normal" in c.kinds:
        if t.frame is None:
            raise ValueError("source_normal: the sampler has no tangent frames (BakeSettings.tangents)")
        codes = np.empty((len(hit), 3))  # tangent_space where hit, else flat (0.5, 0.5, 1): compiled, one pass
        _native.tangent_codes(normal, np.ascontiguousarray(t.frame, dtype=np.float64), hit.view(np.uint8), h.directx, codes)
        out["source_normal"] = codes
    return out


def _values(c: MeshMapContext, t: TexelPoints) -> dict[str, np.ndarray | None]:
    """``kind -> (n, channels)`` float64 at the texels ``t``: those asked for, and what came
    with them (None: a kind not made)."""
    kinds: tuple[str, ...] = c.kinds
    out: dict[str, np.ndarray | None] = {}
    if "ao" in kinds or "bent_normal" in kinds:
        ao, bent = ambient_occlusion(c.scene(), t.points, t.normals, c.rays, c.distance, bias=c.bias, seed=c.seed,
                                     bent="bent_normal" in kinds)
        out.update({"ao": ao, "bent_normal": bent})
    if "thickness" in kinds:
        out["thickness"] = thickness(c.scene(), t.points, t.normals, c.rays, c.distance, bias=c.bias, seed=c.seed)
    if "curvature" in kinds:
        out["curvature"] = curvature_values(c.curvature(), c.faces, t.face, t.bary, c.scale)
    for space in ("object", "world"):
        if f"position_{space}" in kinds:
            out[f"position_{space}"] = position(t.points, c.lo, c.hi, space=space)
        if f"normal_{space}" in kinds:
            out[f"normal_{space}"] = encoded_normals(t.normals)
    for name, ids in (("material", c.material), ("part", c.part), ("chart", c.chart)):
        if f"id_{name}" in kinds:
            out[f"id_{name}"] = id_values(ids, t.face)
    if c.high is not None:
        out.update(_high_values(c, c.high, t))
    return out
