"""The bake, stage by stage: load, atlas, texel lookup, surface samples, (transfer),
texture evaluation, margin; then, on ``save``, images, textured mesh and report.

This module wires the stages together; each stage lives in its own module.
"""

from __future__ import annotations

import itertools
import threading
import time
import typing
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import estimate as estimate_stage
from . import margin as margin_stage
from .atlas import MODES, Atlas, make_atlas
from .bump import LUMINANCE, normal_map
from .errors import ParameterError
from .load import LoadedMesh, load_mesh, mesh_from_trimesh
from .quality import FROM_PRESET, PRECISIONS, _FromPreset, resolve
from .report import library_versions
from .shading import MODES as SHADING_MODES
from .shading import lit
from .surface import SurfaceMap
from .texels import UVLookup, sample_offsets, sample_uv, tiles
from .textures import evaluate, parse_spec

TEXTURE_SPACES = ("unit", "object")


@dataclass
class BakedMesh:
    """The mesh with its atlas: per-atlas-vertex arrays, faces index them."""

    vertices: np.ndarray  # (k, 3) float64
    faces: np.ndarray  # (m, 3) int64
    uv: np.ndarray  # (k, 2) float64, v up
    name: str


@dataclass
class BakeResult:
    """What a bake made: images as arrays, the mesh with its atlas, and the report."""

    images: dict[str, np.ndarray]  # name -> (h, w, 3) float32 linear, row 0 at the top:
    # albedo (or albedo_0000... and flipbook), lit, normal (encoded 0.5 + 0.5 n: data)
    coverage: np.ndarray  # (h, w) bool: texels covered by the atlas
    margin: np.ndarray  # (h, w) bool: texels filled by the margin
    mesh: BakedMesh
    report: dict = field(default_factory=dict)

    def save(self, folder, *, fmt: str = "png", bits: int | None = None, obj: bool = False):
        """Write the maps, ``<name>.glb`` (and OBJ+MTL if ``obj``) and ``report.json``."""
        from .save import save_result

        return save_result(self, Path(folder), fmt=fmt, bits=bits, obj=obj)


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


class _Timer:
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


def _check(name, value, ok, expected):
    if not ok:
        raise ParameterError(name, f"{expected}, got {value!r}")


def _as_mesh(mesh_or_path, max_faces: int, what: str) -> LoadedMesh:
    if isinstance(mesh_or_path, LoadedMesh):
        return mesh_or_path
    if isinstance(mesh_or_path, (str, Path)):
        return load_mesh(mesh_or_path, max_faces=max_faces)
    try:
        return mesh_from_trimesh(mesh_or_path, max_faces=max_faces)
    except TypeError:
        raise ParameterError(what, f"expected a path or a trimesh mesh, got {type(mesh_or_path).__name__}") from None


def bake_mesh(
    mesh_or_path,
    texture,
    *,
    size: int | tuple[int, int] = 1024,
    samples: int | _FromPreset = FROM_PRESET,
    margin: int = 16,
    uv: str = "auto",
    source=None,
    cage: float | None = None,
    texture_space: str = "unit",
    max_faces: int = 5_000_000,
    unwrap_deadline: float = 120.0,
    workers: int = 2,
    seed: int = 0,
    shading: str = "decal",
    light: tuple[float, float, float] = (0.3, 0.5, 0.8),
    bump=None,
    bump_strength: float = 1.0,
    frames=None,
    tile_samples: int = 1 << 20,
    quality: str | None = None,
    filtering: bool | _FromPreset = FROM_PRESET,
    precision: str | _FromPreset = FROM_PRESET,
    max_octaves: int | None | _FromPreset = FROM_PRESET,
    progress=None,
) -> BakeResult:
    """Bake a solid texture into the UV atlas of a mesh.

    Parameters
    ----------
    mesh_or_path : path, trimesh.Trimesh, trimesh.Scene or LoadedMesh
    texture : texture spec, dict, name or JSON (see ``bake.textures.parse_spec``)
    size : int or (width, height)
        Image size in texels.
    samples : int
        Samples per texel (stratified); 1 samples the texel centre. Default 1.
    margin : int
        Texels of "extend" margin around charts.
    uv : "auto" | "unwrap" | "keep"
        Keep the mesh's UVs when usable ("auto"), always unwrap, or require them.
    source : path or mesh, optional
        A second mesh to transfer the texture from (high poly to low poly): the texture
        is evaluated where rays along the target normal hit it.
    cage : float, optional
        Maximum transfer ray distance in object units; default 5% of the target's
        bounding-box diagonal.
    texture_space : "unit" | "object"
        "object" evaluates the texture at object coordinates; "unit" first scales and
        moves the object uniformly so that its bounding box starts at the origin and its
        longest side is 1 (texture parameters then do not depend on the mesh's size).
    max_faces : int
        Meshes with more faces are rejected.
    unwrap_deadline : float
        Seconds xatlas may take before it is stopped and a fallback atlas is used.
    shading : "decal" | "ambient-diffuse" | "full"
        "decal" bakes the texture colour only (``albedo``); the others also bake ``lit``,
        the colour modulating the local illumination from direction ``light``.
    bump : texture spec, optional
        Also bake ``normal``, a tangent-space normal map from the gradient of this
        texture's luminance, scaled by ``bump_strength``.
    frames : sequence of float, optional
        Times at which to bake a texture that has a ``time`` (the flame): maps
        ``albedo_0000``... and a ``flipbook`` of all frames in a grid.
    quality : "draft" | "default" | "final", optional
        A preset of ``samples``, ``filtering``, ``precision`` and ``max_octaves``
        (``bake.quality.PRESETS``); any of them given explicitly overrides the preset.
        None is "default": 1 sample, filtering, float64, every octave.
    filtering : bool
        Antialias by the texel footprint (default True): textures get each sample's
        footprint (checker box-filters it, noise-based textures shrink each octave by
        the share a box filter over it keeps). False point-samples the texture (footprint None).
    precision : "float64" | "float32"
        "float32" rounds the texture-space points and footprints to float32 before the
        texture is evaluated (as a float32 pipeline would hold them); the texture
        arithmetic itself stays float64. Default "float64".
    max_octaves : int or None
        Cap on the octaves of turbulence-based textures (turbulence, fbm, marble, flame;
        also the bump texture): octaves above it add their mean. None: the spec's count.
    progress : callable, optional
        Called with the fraction of the bake done, from 0 to 1 (after loading, the atlas,
        each tile and the margin), from the calling thread or a tile thread.

    The report's ``error_estimate`` estimates the RMSE of the colour map against the
    converged texel means (see ``bake.estimate``).
    """
    report_progress = progress or (lambda fraction: None)
    q_settings = resolve(quality, samples=samples, filtering=filtering, precision=precision, max_octaves=max_octaves)
    samples, filtering, precision, max_octaves = q_settings["samples"], q_settings["filtering"], q_settings["precision"], q_settings["max_octaves"]
    if np.isscalar(size):  # the casts: any scalar or pair is taken here, _check below rejects all but whole numbers
        width = height = typing.cast(int, size)
    else:
        width, height = tuple(typing.cast("Iterable[int]", size))
    _check("size", size, all(isinstance(s, (int, np.integer)) and 1 <= s <= 65536 for s in (width, height)), "expected whole numbers from 1 to 65536")
    _check("samples", samples, isinstance(samples, (int, np.integer)) and 1 <= samples <= 1024, "expected a whole number from 1 to 1024")
    _check("filtering", filtering, isinstance(filtering, (bool, np.bool_)), "expected True or False")
    _check("precision", precision, precision in PRECISIONS, f"expected one of {PRECISIONS}")
    _check("max_octaves", max_octaves, max_octaves is None or (isinstance(max_octaves, (int, np.integer)) and not isinstance(max_octaves, bool) and 1 <= max_octaves <= 30), "expected None or a whole number from 1 to 30")
    _check("margin", margin, isinstance(margin, (int, np.integer)) and 0 <= margin <= 4096, "expected a whole number from 0 to 4096")
    _check("texture_space", texture_space, texture_space in TEXTURE_SPACES, f"expected one of {TEXTURE_SPACES}")
    _check("uv", uv, uv in MODES, f"expected one of {MODES}")
    _check("cage", cage, cage is None or (np.isfinite(cage) and cage > 0), "expected a positive distance")
    _check("shading", shading, shading in SHADING_MODES, f"expected one of {SHADING_MODES}")
    spec = parse_spec(texture)
    bump_spec = None if bump is None else parse_spec(bump)
    if frames is not None:
        frames = [float(t) for t in frames]
        _check("frames", frames, 0 < len(frames) <= 1024 and all(np.isfinite(frames)), "expected 1 to 1024 finite times")
        _check("frames", frames, "time" in type(spec).model_fields, f"texture {spec.name!r} has no time to animate")
        specs = {f"albedo_{i:04d}": spec.model_copy(update={"time": t}) for i, t in enumerate(frames)}
    else:
        specs = {"albedo": spec}
    colour_name = next(iter(specs))
    timer = _Timer()
    skipped: list[dict] = []

    with timer.stage("load"):
        mesh = _as_mesh(mesh_or_path, max_faces, "mesh")
        src = None if source is None else _as_mesh(source, max_faces, "source")
    if src is None:
        skipped.append({"stage": "transfer", "why": "no source mesh given"})

    report_progress(0.05)
    with timer.stage("atlas"):
        atlas: Atlas = make_atlas(
            mesh.vertices, mesh.faces, mesh.uv, mode=uv, size=max(width, height),
            deadline=unwrap_deadline, workers=workers,
        )
    if atlas.method == "kept":
        skipped.append({"stage": "unwrap", "why": atlas.reason})

    # Texture space: object coordinates, or "unit": (p - origin) * scale, computed in
    # that order so that a mesh far from the origin keeps its precision.
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    if texture_space == "unit":
        origin, scale = lo, 1.0 / (float(np.max(hi - lo)) or 1.0)
    else:
        origin, scale = np.zeros(3), 1.0
    bounds = (np.array([lo, hi]) - origin) * scale

    with timer.stage("prepare"):
        lookup = UVLookup(atlas.uv, atlas.faces)
        need_normals = src is not None or shading != "decal" or bump_spec is not None
        surface = SurfaceMap(mesh.vertices, mesh.faces, atlas.uv, atlas.faces, width, height, normals=need_normals)
        caster = None
        if src is not None:
            from .transfer import SourceMesh

            caster = SourceMesh(src.vertices, src.faces)
            reach = cage if cage is not None else 0.05 * float(np.linalg.norm(hi - lo))

    offsets = sample_offsets(samples, seed)
    error_method = estimate_stage.method_for(samples, filtering, max_octaves)
    names = list(specs) + (["lit"] if shading != "decal" else []) + (["normal"] if bump_spec is not None else [])
    images = {name: np.zeros((height, width, 3), dtype=np.float32) for name in names}
    hits = np.zeros((height, width), dtype=np.uint16 if samples < 65536 else np.uint32)

    def bake_tile(tile) -> np.ndarray:
        """Bake the rows of one tile into ``image`` and ``hits``.

        Returns ``[rays cast, transfer rays that missed, *spread sums]`` (the sums of
        ``estimate.spread_sums`` for the ``spread`` error estimate, else zeros).
        """
        with timer.stage("lookup"):
            texels = lookup.candidates(tile, width, height)
            uvs = sample_uv(tile, texels, width, height, offsets)
            face = lookup.faces_at(uvs)
            hit = face >= 0
            face = face[hit]
            bary = lookup.barycentric(uvs[hit], face)
        with timer.stage("surface"):
            s = surface.samples(face, bary)
            points, dpdx, dpdy = s.points, s.dpdx, s.dpdy
        missed = 0
        if caster is not None:
            with timer.stage("transfer"):
                assert s.normals is not None  # need_normals: the surface map has them for a transfer
                points, found = caster.project(points, s.normals, reach)
                missed = int((~found).sum())
                hit[np.flatnonzero(hit)[~found]] = False
                points, dpdx, dpdy = points[found], dpdx[found], dpdy[found]
                normals = s.normals[found]
        else:
            normals = s.normals
        with timer.stage("texture"):
            q = (points - origin) * scale
            footprint = np.stack([dpdx, dpdy], axis=1) * scale
            qt, ft = (q, footprint) if precision == "float64" else (q.astype(np.float32), footprint.astype(np.float32))
            values = {name: evaluate(sp, qt, ft if filtering else None, bounds=bounds, max_octaves=max_octaves)
                      for name, sp in specs.items()}
        if shading != "decal":
            with timer.stage("shading"):
                values["lit"] = lit(values[colour_name], normals, mode=shading, light=light)
        if bump_spec is not None:
            with timer.stage("bump"):
                height_of = lambda x: evaluate(bump_spec, x, bounds=bounds, max_octaves=max_octaves) @ LUMINANCE
                values["normal"] = normal_map(height_of, q, footprint[:, 0], footprint[:, 1], normals, bump_strength)
        with timer.stage("accumulate"):
            rows = tile.stop - tile.start
            texel = texels[np.flatnonzero(hit) // samples]
            if samples == 1:  # one sample a texel: a hit is a count of one
                count = np.zeros(rows * width, dtype=hits.dtype)
                count[texel] = 1
            else:
                count = np.bincount(texel, minlength=rows * width)
            for name, v in values.items():
                if samples == 1:
                    block = np.zeros((rows * width, 3), dtype=np.float32)
                    block[texel] = v
                else:  # mean of the samples that hit each texel
                    block = np.zeros((rows * width, 3))
                    for c in range(3):
                        block[:, c] = np.bincount(texel, weights=v[:, c], minlength=rows * width)
                    nz = count > 0
                    block[nz] /= count[nz, None]
                images[name][tile.start : tile.stop] = block.reshape(rows, width, 3)
            hits[tile.start : tile.stop] = count.reshape(rows, width)
        spread = np.zeros(5)
        if error_method == "spread":
            with timer.stage("estimate"):
                sample = np.flatnonzero(hit) % samples
                spread = estimate_stage.spread_sums(values[colour_name], texel, sample, samples, rows * width)
        return np.array([len(uvs), missed, *spread])

    # Tiles run in threads: Embree holds the GIL, numpy mostly does not, so the stages
    # of two tiles overlap. Each tile writes its own rows.
    report_progress(0.3)
    tile_list = tiles(height, width, samples, tile_samples)
    finished = itertools.count(1)

    def bake_and_report(tile):
        result = bake_tile(tile)
        report_progress(0.3 + 0.6 * next(finished) / len(tile_list))
        return result

    with timer.stage("tiles (wall)"), ThreadPoolExecutor(max(1, workers)) as pool:
        cast, transfer_misses, *spread = sum(pool.map(bake_and_report, tile_list))
    cast, transfer_misses = int(cast), int(transfer_misses)

    covered = hits > 0
    with timer.stage("estimate"):
        if error_method == "spread":
            error_estimate = estimate_stage.spread_estimate(spread)
        else:
            def reference_at(uvs):
                """Point-sampled float64 colour, every octave, at ``(n, 2)`` UV points."""
                face = lookup.faces_at(uvs)
                hit = face >= 0
                s = surface.samples(face[hit], lookup.barycentric(uvs[hit], face[hit]))
                points = s.points
                if caster is not None:
                    points, found = caster.project(points, s.normals, reach)
                    hit[np.flatnonzero(hit)[~found]] = False
                    points = points[found]
                return hit, evaluate(specs[colour_name], (points - origin) * scale, bounds=bounds)

            error_estimate = estimate_stage.probe_estimate(reference_at, images[colour_name], covered, seed=seed)
        error_estimate["map"] = colour_name
    with timer.stage("margin"):
        filled = margin_stage.extend(list(images.values()), covered, margin, workers=workers)
    report_progress(0.95)
    if frames is not None:
        images["flipbook"] = flipbook([images[name] for name in specs])

    # Texels that no sample hit although their four neighbours are covered: cracks.
    inner = np.zeros_like(covered)
    inner[1:-1, 1:-1] = (
        ~covered[1:-1, 1:-1] & covered[:-2, 1:-1] & covered[2:, 1:-1] & covered[1:-1, :-2] & covered[1:-1, 2:]
    )
    report = {
        "mesh": {
            "name": mesh.name,
            "path": mesh.path,
            "sha256": mesh.sha256,
            "vertices": int(len(mesh.vertices)),
            "faces": int(len(mesh.faces)),
            "degenerate_faces_removed": int(mesh.removed_degenerate),
            "bounds": [lo.tolist(), hi.tolist()],
        },
        "source": None if src is None else {"path": src.path, "sha256": src.sha256, "faces": int(len(src.faces)), "cage": reach},
        "parameters": {
            "texture": spec.model_dump(mode="json"),
            "size": [width, height],
            "samples": samples,
            "quality": quality,
            "filtering": filtering,
            "precision": precision,
            "max_octaves": max_octaves,
            "margin": margin,
            "uv": uv,
            "texture_space": texture_space,
            "seed": seed,
            "shading": shading,
            "light": list(light) if shading != "decal" else None,
            "bump": None if bump_spec is None else {"texture": bump_spec.model_dump(mode="json"), "strength": bump_strength},
            "frames": frames,
        },
        "atlas": {"method": atlas.method, "reason": atlas.reason, **atlas.stats},
        "texels": {
            "total": width * height,
            "covered": int(covered.sum()),
            "margin": int(filled.sum()),
            "empty": int(width * height - covered.sum() - filled.sum()),
        },
        "rays": {
            "texel_samples": width * height * samples,
            "cast": cast,  # rays for the samples of texels that some face's UV box touches
            "missed": int(cast - hits.sum(dtype=np.int64) - transfer_misses),
            "missed_inside_atlas": int(inner.sum()),
            "transfer_missed": transfer_misses,
        },
        "error_estimate": error_estimate,
        "skipped": skipped,
        "seconds": {k: round(v, 4) for k, v in timer.seconds.items()},
        "versions": library_versions(),
    }
    baked = BakedMesh(mesh.vertices[atlas.vmapping], atlas.faces, atlas.uv, mesh.name)
    report_progress(1.0)
    return BakeResult(images, covered, filled, baked, report)
