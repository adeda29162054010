"""The bake, as its list of stages: load, texture sets, and for each set its atlas, and for
each of its tiles the texel lookup, surface samples, (transfer), texture mapping and
evaluation, accumulation, error estimate, margin; then, on ``save``, images, textured mesh
and report.

Each stage lives in its own module; this one only chains them. What flows between them:
``BakeSettings`` (settings) and ``LoadedMesh`` (mesh.load) -> ``TextureSet`` (sets: a
material's faces and settings) -> ``Atlas`` (atlas) -> ``Tile`` (sets: a UDIM tile's, or
the set itself) -> UV points of texel samples (sampling.lookup) -> ``Samples``
(sampling.sampler: lookup, surface, transfer) -> values per map (maps.accumulate: texture
mapping, texture, shading, bump) -> images (maps.accumulate, maps.margin) -> ``BakedSet``
per set and tile -> ``BakeResult`` with its report (output.report).
"""

from __future__ import annotations

import ctypes
import hashlib
import itertools
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import meshmaps
from .atlas import Atlas, AtlasCache, Sides, atlas_key, make_atlas
from .errors import ParameterError
from .maps import Maps
from .maps import estimate as estimate_stage
from .maps import margin as margin_stage
from .memory import check_fits
from .mesh import LoadedMesh, load_mesh, mesh_from_trimesh, split_normals, vertex_tangents
from .meshmaps import Scenes
from .output import BakeTally, bake_report
from .sampling import Sampler, adaptive, creases, sample_offsets, sample_uv, tiles
from .sampling.lookup import Tile as Rows
from .sets import TextureSet, Tile, images_of, texture_sets
from .sets import tiles as set_tiles
from .settings import BakeSettings
from .textures.mapping import TextureMapping
from .version import __version__


@dataclass
class BakedMesh:
    """The mesh with its atlas: per-atlas-vertex arrays, faces index them."""

    vertices: np.ndarray  # (k, 3) float64
    faces: np.ndarray  # (m, 3) int64
    uv: np.ndarray  # (k, 2) float64, v up: in the unit square (a UDIM tile's: offset taken off)
    name: str
    normals: np.ndarray | None = None  # (k, 3) float64 unit shading normals, split at hard edges
    tangents: np.ndarray | None = None  # (k, 4) float64 tangents (xyz, w = +-1) the normal map was baked in, if one was
    offset: tuple[int, int] = (0, 0)  # the UDIM tile's corner (u, v): uv + offset is the asset's layout
    material: np.ndarray | None = None  # (m,) int: each face's material (into material_names), None for one
    material_names: list[str] = field(default_factory=list)  # the materials of the mesh's faces


@dataclass
class BakedSet:
    """What one texture set made, or one UDIM tile of it: its images and its mesh.

    Attributes
    ----------
    name : str
        The set's name (its material's; ``TextureSet.name``).
    tile : int or None
        The UDIM tile (1001 + u + 10 v), or None for a set baked in the unit square.
    images, coverage, margin : dict of str to (h, w, 3) ndarray, (h, w) bool, (h, w) bool
        As :class:`BakeResult` describes them, at the set's size.
    mesh : BakedMesh
        The set's faces (the tile's) with their UVs in the tile.
    settings : BakeSettings
        The set's settings (``BakeSettings.for_material``).
    materials : list of str
        The materials of the mesh whose faces it holds.
    atlas : texbake.atlas.Atlas
        The set's atlas (the whole set's, every tile).
    tally : texbake.output.BakeTally
        What this tile's stages counted (the report's figures).
    warnings : list of str
        What a user should know of the set besides its atlas' (``TextureSet.warnings``).
    """

    name: str
    tile: int | None
    images: dict[str, np.ndarray]
    coverage: np.ndarray
    margin: np.ndarray
    mesh: BakedMesh
    settings: BakeSettings
    materials: list[str]
    atlas: Atlas
    tally: BakeTally
    warnings: list[str] = field(default_factory=list)


@dataclass
class BakeResult:
    """What a bake made: per texture set (and UDIM tile) its images and its mesh, and the report.

    Attributes
    ----------
    sets : list of BakedSet
        One per texture set (``texbake.sets``: per material, or one), and per UDIM tile of
        a set baked in tiles, in order: the set's images (``images``), masks and mesh.
    report : dict
        The bake's report (``report.json``; ``texbake.output.report``): its ``sets`` lists
        each set and tile.
    settings : BakeSettings
        The settings it was baked with, preset resolved.
    warnings : list of str
        What a user should know of this bake, one line each: ``report["warnings"]``.

    A bake of one set and no tiles (a mesh of one material) also has, as before there
    were sets: ``images`` (dict of str to (h, w, 3) float32 ndarray: linear values, row 0
    at the top: ``albedo`` (or ``albedo_0000``... and ``flipbook`` for the frames of an
    animated texture), ``lit`` (shading other than "decal"), ``normal`` (a bump texture
    given; ``0.5 + 0.5 n``, data, not colour); float16 instead for images of over 8192²
    texels written as 8 bits, ``texbake.maps.accumulate``), ``coverage`` ((h, w) bool:
    texels some sample hit), ``margin`` ((h, w) bool: texels the margin filled) and
    ``mesh`` (the mesh with its atlas, as written): its one set's. A bake of several has
    them per set only (``sets``): asking the result for them raises ``AttributeError``.
    """

    sets: list[BakedSet]
    report: dict = field(default_factory=dict)
    settings: BakeSettings = field(default_factory=BakeSettings)

    def _one(self) -> BakedSet:
        if len(self.sets) != 1:
            named = ", ".join(s.name if s.tile is None else f"{s.name} {s.tile}" for s in self.sets)
            raise AttributeError(f"this bake made {len(self.sets)} texture sets and tiles ({named}): see result.sets")
        return self.sets[0]

    @property
    def images(self) -> dict[str, np.ndarray]:
        return self._one().images

    @property
    def coverage(self) -> np.ndarray:
        return self._one().coverage

    @property
    def margin(self) -> np.ndarray:
        return self._one().margin

    @property
    def mesh(self) -> BakedMesh:
        return self._one().mesh

    @property
    def warnings(self) -> list[str]:
        return self.report.get("warnings", [])

    def save(self, folder, *, fmt: str | None = None, bits: int | None = None, obj: bool | None = None):
        """Write the maps, ``<name>.glb`` (and OBJ+MTL if ``obj``) and ``report.json``;
        format, bits and OBJ default to the bake's settings."""
        from .output import save_result

        s = self.settings
        return save_result(self, Path(folder), fmt=s.format if fmt is None else fmt, bits=s.bits if bits is None else bits,
                           obj=s.obj if obj is None else obj)


def flipbook(frames: list[np.ndarray]) -> np.ndarray:
    """Frames ``(h, w, c)`` laid out left to right, top to bottom in a near-square grid."""
    h, w, c = frames[0].shape
    cols = int(np.ceil(np.sqrt(len(frames))))
    rows = -(-len(frames) // cols)
    out = np.zeros((rows * h, cols * w, c), dtype=frames[0].dtype)
    for i, frame in enumerate(frames):
        r, k = divmod(i, cols)
        out[r * h : (r + 1) * h, k * w : (k + 1) * w] = frame
    return out


class Timer:
    """Seconds per stage, summed over the tiles (and threads) that ran it."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._lock = threading.Lock()

    @contextmanager
    def stage(self, name: str):
        start = time.perf_counter()
        try:
            yield
        finally:
            with self._lock:
                self.seconds[name] = self.seconds.get(name, 0.0) + time.perf_counter() - start


# glibc's mallopt parameters, and their defaults
_M_TRIM_THRESHOLD, _M_MMAP_MAX = -1, -4
_DEFAULT_TRIM_THRESHOLD, _DEFAULT_MMAP_MAX = 128 * 1024, 65536
_heap_lock = threading.Lock()
_heap_bakes = [0]  # bakes running in this process under _reusing_heap


@contextmanager
def _reusing_heap():
    """While bakes run, glibc's malloc serves large blocks from its heap and keeps what is
    freed there (``mallopt``: no mmap, no trimming), so that an array of millions of rows
    reuses the memory of one freed before it: above 32 MB malloc would map fresh pages,
    which the kernel zeroes (at 5M faces, 40 % of the per-face stages' time went to that).
    After the last bake the defaults are set again and the heap trimmed. Elsewhere than
    glibc a no-op. Also a decorator (``contextlib``)."""
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        yield
        return
    with _heap_lock:
        _heap_bakes[0] += 1
        if _heap_bakes[0] == 1:
            mallopt(_M_MMAP_MAX, 0)
            mallopt(_M_TRIM_THRESHOLD, 2**31 - 1)
    try:
        yield
    finally:
        with _heap_lock:
            _heap_bakes[0] -= 1
            if _heap_bakes[0] == 0:
                mallopt(_M_MMAP_MAX, _DEFAULT_MMAP_MAX)
                mallopt(_M_TRIM_THRESHOLD, _DEFAULT_TRIM_THRESHOLD)
                _trim_heap()


def as_mesh(mesh_or_path, max_faces: int, what: str) -> LoadedMesh:
    """A ``LoadedMesh`` from a path, a trimesh mesh or scene, or a ``LoadedMesh``."""
    if isinstance(mesh_or_path, LoadedMesh):
        return mesh_or_path
    if isinstance(mesh_or_path, (str, Path)):
        return load_mesh(mesh_or_path, max_faces=max_faces)
    try:
        return mesh_from_trimesh(mesh_or_path, max_faces=max_faces)
    except TypeError:
        raise ParameterError(what, f"expected a path or a trimesh mesh, got {type(mesh_or_path).__name__}") from None


@_reusing_heap()
def bake_mesh(mesh_or_path, settings: BakeSettings | dict | str | None = None, *, source=None, workers: int = 2,
              progress: Callable[[float], None] | None = None, tile_samples: int = 1 << 20,
              cache: str | Path | AtlasCache | None = None, memory_limit: int | None = None, cage_mesh=None, **options) -> BakeResult:
    """Bake a solid texture into the UV atlas of a mesh.

    Parameters
    ----------
    mesh_or_path : str, pathlib.Path, trimesh.Trimesh, trimesh.Scene or LoadedMesh
        The mesh: a file (OBJ, PLY, STL, OFF, glTF, GLB) or one in memory.
    settings : BakeSettings, dict, or a texture (name, JSON text, spec or spec dict), optional
        What to bake and how (:class:`texbake.settings.BakeSettings`); keyword ``options``
        are settings too and override it: ``bake_mesh("bunny.ply", "marble", size=2048)``.
    source : str, pathlib.Path or mesh, optional
        A second mesh to transfer the texture from (high poly to low poly): the texture
        is evaluated where rays along the target normal, at most ``settings.cage`` long
        (default 5% of the target's bounding-box diagonal), hit it.
    workers : int
        Threads for the tiles, the margin and the unwrap.
    progress : callable, optional
        Called with the fraction of the bake done, a float from 0 to 1 (after loading, the
        atlas, each tile and the margin), from the calling thread or a tile thread.
    tile_samples : int
        Samples a tile: bounds the memory of the lookup.
    cache : str, pathlib.Path or AtlasCache, optional
        Where atlases are kept for later bakes: the same mesh at the same atlas settings
        (``uv``, size, ``charting``) then skips the unwrap (``report["atlas"]["cached"]``).
        An ``AtlasCache`` also keeps its latest lookups in memory: the next bake of the
        atlas at the same size, samples and seed casts no ray (``report["rays"]["lookup_reused"]``).
    cage_mesh : str, pathlib.Path or mesh, optional
        The cage of a high-to-low bake (the ``source_*`` mesh maps): the target's topology
        (the same faces), its vertices moved out; rays go from it inward onto ``source``.
    memory_limit : int, optional
        Bytes the bake may take at most (a server's limit a bake); None: the memory
        available. Checked against the estimate of every texture set and tile before the
        atlas is made (``texbake.memory.check_fits``).

    Returns
    -------
    BakeResult
        The maps as ``(h, w, 3)`` float32 images, the ``(h, w)`` bool coverage and margin
        masks, the mesh with its atlas, the report (``report["settings"]`` is
        ``settings.model_dump(mode="json")``; ``report["error_estimate"]`` estimates the
        colour map's RMSE against the converged texel means, ``texbake.maps.estimate``)
        and the settings.

    Raises
    ------
    ParameterError, MeshError, AtlasError, TextureError
        A bad setting or argument (named), a mesh that cannot be read or is rejected, an
        atlas that cannot be made, a bad texture spec.
    """
    settings = _settings(settings, options)
    timer, say = Timer(), progress or (lambda fraction: None)
    with timer.stage("load"):
        mesh = as_mesh(mesh_or_path, settings.max_faces, "mesh")
        src = None if source is None else as_mesh(source, settings.max_faces, "source")
    sets = texture_sets(mesh, settings)
    check_fits(settings, len(mesh.faces) + (0 if src is None else len(src.faces)), workers, tile_samples,  # before the unwrap
               limit=memory_limit, sets=[(s.settings, images_of(s)) for s in sets])
    say(0.05)
    store = None if cache is None else cache if isinstance(cache, AtlasCache) else AtlasCache(cache)
    baked: list[BakedSet] = []
    scenes = _scenes(mesh, src, None if cage_mesh is None else as_mesh(cage_mesh, settings.max_faces, "cage_mesh"))
    for i, texture_set in enumerate(sets):  # set i's share of the progress after loading
        baked += _bake_set(texture_set, (mesh, scenes), src, timer, workers, tile_samples, store, _share(say, i, len(sets)))
    report = bake_report(settings, mesh, baked, source=src, cage=_reach(mesh, settings), seconds=timer.seconds)
    say(1.0)
    return BakeResult(baked, report, settings)


def texel_means(mesh_or_path, settings: BakeSettings | dict | str | None, texels: np.ndarray, samples: int, *, seed: int = 0,
                workers: int = 2, chunk_samples: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """For checks (``texbake.checks.sweep``): the colour map's means over ``samples``
    point samples (``sample_offsets(samples, seed)``) in each of ``texels``, evaluated as
    the error probe's reference is (``Maps.reference``: float64, every octave), in the
    first texture set's first image. A converged reference on a few texels of a large
    image, where a whole bake of as many samples would take hours.

    ``texels``: ``(t,)`` int row-major flat indices of the image. Returns ``(means (t, c)
    float64, hits (t,) int64)``: the mean of the samples on the surface (as a
    point-sampled bake's texel holds it; 0 where none is) and their count.
    """
    settings = _settings(settings, {})
    mesh = as_mesh(mesh_or_path, settings.max_faces, "mesh")
    texture_set = texture_sets(mesh, settings)[0]
    s, bounds = texture_set.settings, _bounds(mesh)
    atlas, _ = _atlas(texture_set.mesh, s, workers, None)
    tile = set_tiles(texture_set.mesh, atlas, _output_mesh(texture_set.mesh, atlas, tangents=s.tangents))[0]
    assert isinstance(tile.baked, BakedMesh)
    maps = Maps(s, TextureMapping.for_mesh(*bounds, s.texture_space, s.precision))
    name = maps.colour_name
    if name is None:
        raise ParameterError("settings", "texel_means needs a texture's colour map")
    sampler = _sampler(tile.mesh, tile.atlas, tile.baked, None, s, maps.needs_normals, _reach(None, s, bounds))
    (width, height), offsets = s.width_height, sample_offsets(samples, seed)
    texels = np.asarray(texels, dtype=np.int64)
    if texels.ndim != 1 or (len(texels) and not 0 <= texels.min() <= texels.max() < width * height):
        raise ParameterError("texels", f"expected (t,) flat indices of the {width} x {height} image")
    step = max(1, chunk_samples // samples)

    def chunk(start: int) -> tuple[np.ndarray, np.ndarray]:
        ours = texels[start:start + step]
        at = sampler.at(sample_uv(Rows(0, height), ours, width, height, offsets))
        values = maps.reference(at)[name]
        hits, sums = estimate_stage.texel_sums(at.index // samples, values, len(ours))
        return sums, hits

    with ThreadPoolExecutor(max(1, workers)) as pool:
        parts = list(pool.map(chunk, range(0, len(texels), step)))
    if not parts:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    sums, hits = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    return sums / np.maximum(hits, 1)[:, None], hits


def _bake_set(texture_set: TextureSet, whole: tuple[LoadedMesh, Scenes], src: LoadedMesh | None, timer: Timer, workers: int,
              tile_samples: int, store: AtlasCache | None, say: Callable[[float], None]) -> list[BakedSet]:
    """One texture set's bake: its atlas, its output mesh, and each of its tiles' maps
    (``whole``: the bake's mesh and its mesh maps' ray scenes)."""
    mesh, settings, bounds = texture_set.mesh, texture_set.settings, _bounds(whole[0])
    with timer.stage("atlas"):
        atlas, key = _atlas(mesh, settings, workers, store)
    mapping = TextureMapping.for_mesh(*bounds, settings.texture_space, settings.precision)  # the whole mesh's: one field
    with timer.stage("normals"):  # of the output mesh; a normal map is baked in its tangent frame
        baked = _output_mesh(mesh, atlas, tangents=settings.tangents)
    out = []
    parts = set_tiles(mesh, atlas, baked)
    for i, tile in enumerate(parts):
        images, covered, filled, tally = _bake_tile(tile, whole, mapping, src, settings, timer, workers, tile_samples,
                                                    None if store is None else (store, key), _share(say, i, len(parts)))
        out.append(BakedSet(texture_set.name, tile.number, images, covered, filled, tile.baked, settings,  # type: ignore[arg-type]
                            texture_set.materials, atlas, tally, texture_set.warnings))
    return out


def _bake_tile(tile: Tile, whole: tuple[LoadedMesh, Scenes], mapping: TextureMapping, src: LoadedMesh | None,
               settings: BakeSettings, timer: Timer, workers: int, tile_samples: int, store: tuple[AtlasCache, str] | None,
               say: Callable[[float], None]) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, BakeTally]:
    """One image's bake (a set's, or one UDIM tile's): ``(images, covered, margin, tally)``."""
    mesh, atlas, baked, bounds = tile.mesh, tile.atlas, tile.baked, _bounds(whole[0])
    assert isinstance(baked, BakedMesh)
    with timer.stage("prepare"):
        maps = Maps(settings, mapping)
        sampler = _sampler(mesh, atlas, baked, src, settings, maps.needs_normals or bool(settings.maps), _reach(None, settings, bounds))
    mesh_maps = None
    if settings.maps:  # before the tiles: a material may read them (mesh_map nodes)
        with timer.stage("mesh maps"):
            made, mesh_covered, mesh_maps = meshmaps.bake_maps(meshmaps.MeshMapContext.for_image(settings, whole[0], mesh, atlas, whole[1]),
                                                               sampler, workers=workers)
        maps.add_mesh_maps(made)
    say(0.3)
    if maps.per_sample:
        lookups = None if store is None else (store[0], (store[1], *settings.width_height, settings.samples, settings.seed, tile_samples,
                                                         *([] if tile.number is None else [tile.number])))
        (cast, rays, missed, parts), reused = _bake_tiles(sampler, maps, settings, timer, workers, tile_samples,
                                                   lambda done: say(0.3 + 0.6 * done), lookups)
        covered, hits = _coverage(maps)
        with timer.stage("estimate"):
            error_estimate = _estimate(sampler, maps, covered, settings, workers)
    else:  # texture none: the mesh maps' texel centres are the bake's samples, and nothing is estimated
        covered, hits = mesh_covered, int(mesh_covered.sum())
        cast, rays, missed, parts, reused, error_estimate = hits, hits, 0, 0, False, None
    with timer.stage("margin"):
        filled = margin_stage.extend(list(maps.images.values()), covered, settings.margin, workers=workers)
    say(0.95)
    tally = BakeTally(covered, filled, cast=int(cast), rays=int(rays), transfer_missed=int(missed), hits=hits, parts=int(parts),
                      lookup_reused=reused,
                      error_estimate=error_estimate, seconds=timer.seconds, faces=len(mesh.faces),
                      material=None if maps.material is None else maps.material.report(), mesh_maps=mesh_maps)
    return _images(maps, settings), covered, filled, tally


def _scenes(mesh: LoadedMesh, src: LoadedMesh | None, cage: LoadedMesh | None) -> Scenes:
    """The mesh maps' ray scenes (built once a bake) and a high-to-low bake's source and cage."""
    if cage is not None and not np.array_equal(cage.faces, mesh.faces):
        raise ParameterError("cage_mesh", f"{cage.path}: expected the mesh's topology ({len(mesh.faces)} faces, the same corners), "
                             f"got {len(cage.faces)} faces" + (" with other corners" if len(cage.faces) == len(mesh.faces) else ""))
    source = None if src is None else meshmaps.Source(src.vertices, src.faces, src.part, list(src.part_names))
    return Scenes(source, None if cage is None else cage.vertices, (mesh.vertices, mesh.faces))


def _share(say: Callable[[float], None], i: int, n: int) -> Callable[[float], None]:
    """``say`` for the ``i``-th of ``n`` parts (sets, tiles) of what follows the loading:
    the part's fractions, 0.05 to 1 as a whole bake's, within its share."""
    return lambda fraction: say(0.05 + (i + (fraction - 0.05) / 0.95) * 0.95 / n)


def _reach(mesh: LoadedMesh | None, settings: BakeSettings, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> float:
    """The transfer rays' reach: ``cage``, else 5% of the whole mesh's bounding-box diagonal."""
    lo, hi = _bounds(mesh) if bounds is None else bounds  # type: ignore[arg-type]
    return settings.cage if settings.cage is not None else 0.05 * float(np.linalg.norm(hi - lo))


def _settings(settings, options: dict) -> BakeSettings:
    """The bake's settings from ``bake_mesh``'s ``settings`` and ``options``: ``settings``
    given as a texture (a name, JSON text, spec or spec dict) is the ``texture``."""
    if settings is not None and not isinstance(settings, BakeSettings) and not (isinstance(settings, dict) and "name" not in settings):
        settings, options = None, {"texture": settings, **options}
    return BakeSettings.build(settings, **options)


def _bounds(mesh: LoadedMesh) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)``: the ``(3,)`` float64 corners of the mesh's bounding box."""
    return mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)


def _output_mesh(mesh: LoadedMesh, atlas: Atlas, *, tangents: bool) -> BakedMesh:
    """The mesh as it is written: atlas vertices split again at hard edges, with shading
    normals and, for a normal map, the tangents it is baked in."""
    atlas_vertices = mesh.vertices[atlas.vmapping]
    source_vertex, faces, normals = split_normals(atlas_vertices, atlas.faces)
    vertices, uv = atlas_vertices[source_vertex], atlas.uv[source_vertex]
    frame = None
    if tangents:  # MikkTSpace's groups split a vertex more where a UV seam or mirror meets itself
        split, faces, frame = vertex_tangents(vertices, faces, uv, normals)
        vertices, uv, normals = vertices[split], uv[split], normals[split]
    return BakedMesh(vertices, faces, uv, mesh.name, normals, frame, material=mesh.material, material_names=list(mesh.material_names))


def _sampler(mesh: LoadedMesh, atlas: Atlas, baked: BakedMesh, src: LoadedMesh | None, settings: BakeSettings,
             needs_normals: bool, reach: float) -> Sampler:
    """The sampler of the bake's texels on ``mesh`` (and ``src``, to transfer from)."""
    assert baked.normals is not None  # _output_mesh gives normals
    # a double-sided mesh's back faces lie on their front faces' texels: those hold the front side
    front = Sides.of(mesh.faces).front if atlas.stats.get("double_sided_faces") else slice(None)
    corner_normals = (baked.normals, baked.faces[front])  # shading (the lit map) sees the GLB's normals
    return Sampler(mesh.vertices, mesh.faces[front], atlas.uv, atlas.faces[front], *settings.width_height,
                   normals=corner_normals if needs_normals else False,
                   source=None if src is None else (src.vertices, src.faces), reach=reach,
                   frame=None if baked.tangents is None else (baked.normals[baked.faces][front], baked.tangents[baked.faces][front]),
                   footprints=settings.filtering or settings.normal_map)


def _coverage(maps: Maps) -> tuple[np.ndarray, int]:
    """``(covered (h, w) bool, samples that hit)`` from the maps' counts, which are then
    freed: the tiles' memory goes back to the system before the stages after them."""
    covered, hits = maps.hits > 0, int(maps.hits.sum(dtype=np.int64))
    del maps.hits
    _trim_heap()
    return covered, hits


def _images(maps: Maps, settings: BakeSettings) -> dict[str, np.ndarray]:
    """The maps' images, and the flipbook of the frames of an animated texture."""
    images = dict(maps.images)
    if settings.frames is not None:
        images["flipbook"] = flipbook([images[name] for name in maps.colours])
    images.update(maps.packs(images))  # a material's channels packed by template (ORM...)
    return images


def _trim_heap() -> None:
    """Give the heap's free memory back to the system (glibc's ``malloc_trim``): the
    tiles' temporaries, freed but kept by malloc, would otherwise add to the peak of the
    stages after them (16384²: 0.6 GB). Elsewhere a no-op."""
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):
        pass


def _atlas(mesh: LoadedMesh, settings: BakeSettings, workers: int, store: AtlasCache | None) -> tuple[Atlas, str]:
    """``(atlas, its cache key)``: from ``store`` when an earlier bake left it there, else
    made (and left there)."""
    size = max(settings.width_height)
    key = atlas_key(mesh.sha256, settings.uv, size, settings.charting, __version__)
    found = None if store is None else store.get(key)
    if found is not None and found.faces.shape == mesh.faces.shape and found.vmapping.max() < len(mesh.vertices):
        return found, key
    atlas = make_atlas(mesh.vertices, mesh.faces, mesh.uv, mode=settings.uv, size=size, deadline=settings.unwrap_deadline,
                       workers=workers, charting=settings.charting, has_uv=mesh.has_uv, part=mesh.part,
                       part_names=mesh.part_names)
    if store is not None:
        store.put(key, atlas)
    return atlas, key


def _bake_tiles(sampler: Sampler, maps: Maps, settings: BakeSettings, timer: Timer, workers: int, tile_samples: int,
                progress: Callable[[float], None], lookups: tuple[AtlasCache, tuple] | None = None) -> tuple[np.ndarray, bool]:
    """Bake the image in row tiles of about ``tile_samples`` samples into ``maps``.

    Returns ``[samples looked up, lookup rays cast, transfer rays that missed, crease parts
    evaluated]`` summed
    over the tiles, and whether the lookups came from ``lookups`` (a cache and the key
    of this bake's lookups; kept there otherwise; then no ray is cast). Tiles run in threads:
    the ray casts (texbake.sampling.rays) and the compiled kernels release the GIL, numpy mostly does,
    so the stages of two tiles overlap; each tile writes its own rows.
    """
    (width, height), samples = settings.width_height, settings.samples
    offsets = sample_offsets(samples, settings.seed)
    tile_list = tiles(height, width, samples, tile_samples)
    finished = itertools.count(1)
    known = None if lookups is None else lookups[0].lookups(lookups[1])
    made: list | None = None if lookups is None or known is not None else [None] * len(tile_list)
    kept = [0]  # bytes of the lookups recorded so far: past the cache's budget, none are
    lock = threading.Lock()

    def bake_tile(i: int) -> np.ndarray:
        nonlocal made
        if known is not None:
            texels, located = known[i]
        else:
            with timer.stage("lookup"):
                texels = sampler.candidates(tile_list[i])
                located = sampler.locate(sample_uv(tile_list[i], texels, width, height, offsets), samples)
            with lock:
                if made is not None and lookups is not None:
                    kept[0] += texels.nbytes + located.nbytes
                    if kept[0] > lookups[0].max_lookup_bytes:
                        made = None  # too large to keep: not held meanwhile either
                    else:
                        made[i] = texels, located
        s = sampler.at_located(located, timer, cut=settings.filtering and samples == 1, hull=maps.reads_hull)
        values = maps.values(s, timer)
        texel = texels[s.index // samples]
        refined = parts = 0
        if settings.filtering and samples == 1:  # a texel whose surface bends: filtered a face at a time
            with timer.stage("creases"):
                parts = creases.refine(sampler, maps.values, located, s, values)
        if settings.adaptive and settings.filtering and samples == 1 and maps.colour_name is not None:
            with timer.stage("adaptive"):
                refined = adaptive.refine(sampler, maps.values, tile_list[i], texel, values, maps.colour_name, settings.adaptive,
                                          s.coverage)
        with timer.stage("accumulate"):
            maps.accumulate(tile_list[i], texel, values)
        progress(next(finished) / len(tile_list))
        return np.array([located.count + refined, 0 if known is not None else located.rays, s.transfer_missed, parts])

    with timer.stage("tiles (wall)"), ThreadPoolExecutor(max(1, workers)) as pool:
        counts = sum(pool.map(bake_tile, range(len(tile_list))), np.zeros(4))
    if lookups is not None and made is not None:
        lookups[0].keep_lookups(lookups[1], made)
    return counts, known is not None


PROBE_SPLIT = 1 << 14  # probe points from which the estimate's reference is evaluated in parts, one a thread


def _estimate(sampler: Sampler, maps: Maps, covered: np.ndarray, settings: BakeSettings, workers: int = 1) -> dict:
    """The error estimate of the colour map (``texbake.maps.estimate``): a probe that sends UV
    points through the same chain, point-sampled in float64; for a material, of each of its
    maps too (``channels``), from one probe (the same texels and points for each map). The
    probe's points are evaluated in ``workers`` threads, in parts (each point's value is its
    own, so the same values): the tiles are done, and the cores free."""
    probed: dict[bytes, tuple] = {}  # the probe's UV points (a stratum's) -> every map's values there, from one evaluation

    def evaluate(uvs: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        s = sampler.at(uvs)
        hit = np.zeros(len(uvs), dtype=bool)
        hit[s.index] = True
        return hit, maps.reference(s)

    def reference_at(name: str):
        def at(uvs: np.ndarray):
            key = hashlib.blake2b(np.ascontiguousarray(uvs).tobytes(), digest_size=16).digest()
            if key not in probed:
                if pool is None or len(uvs) < 2 * PROBE_SPLIT:
                    probed[key] = evaluate(uvs)
                else:
                    parts = list(pool.map(evaluate, np.array_split(uvs, workers)))
                    probed[key] = (np.concatenate([hit for hit, _ in parts]),
                                   {k: np.concatenate([values[k] for _, values in parts]) for k in parts[0][1]})
            hit, values = probed[key]
            return hit, values[name]
        return at

    grid = estimate_stage.probe_grid(settings.samples)
    edge_grid = grid if settings.samples == 1 else min(16, 2 * grid)
    # reference_at's calls read pool: made here, before the first of them
    with ThreadPoolExecutor(workers) if workers > 1 else nullcontext() as pool:
        estimates = {name: estimate_stage.probe_estimate(reference_at(name), maps.images[name], covered, seed=settings.seed,
                                                         grid=grid, edge_grid=edge_grid) for name in maps.estimated}
    assert maps.colour_name is not None  # the tiles run for a texture's or a material's maps only
    estimate = estimates[maps.colour_name]
    estimate["map"] = maps.colour_name
    if len(estimates) > 1:
        estimate["channels"] = {name: {k: e[k] for k in ("rmse", "rmse_interval", "texels")} for name, e in estimates.items()}
    return estimate
