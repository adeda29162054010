"""The bake report: what was done, how long it took, and with which libraries."""

from __future__ import annotations

import functools
import json
import platform
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .atomic import write_bytes

if TYPE_CHECKING:  # for the annotations only: the report reads these objects, it does not make them
    from ..atlas import Atlas
    from ..mesh import LoadedMesh
    from ..settings import BakeSettings

_LIBRARIES = ("texbake", "numpy", "trimesh", "xatlas", "embreex", "OpenImageIO", "mapbox_earcut", "pydantic")


def library_versions() -> dict[str, str | None]:
    """Installed versions of the libraries a bake uses (None where one is missing), and
    ``kernels``: how the compiled kernels were built (:func:`kernels_build`). Read once a
    process (the package metadata is a file read each: 10-20 ms a report in a batch)."""
    return dict(_library_versions())


@functools.cache
def _library_versions() -> dict[str, str | None]:
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    versions["kernels"] = kernels_build()
    return versions


def kernels_build() -> str:
    """The compiled kernels' (``texbake._native``) compiler, flags and build type, e.g.
    ``gcc 12.2.0, -O3 -ffp-contract=off -fno-math-errno -Wall -Wextra (Release, nanobind 3.1.0)``: the
    images depend on them."""
    from .. import _native

    info = _native.build_info()
    return f"{info['compiler']}, {info['flags']} ({info['build_type']}, nanobind {info['nanobind']})"


def write_json(path: Path, data: dict) -> None:
    """Write ``data`` as JSON to ``path`` atomically (temporary file, then rename)."""
    write_bytes(path, (json.dumps(data, indent=2) + "\n").encode())


@dataclass(frozen=True)
class BakeTally:
    """What a bake's stages counted and measured, for its report.

    Attributes
    ----------
    covered, filled : (h, w) bool ndarray
        Texels covered by the atlas (some sample hit them), and those the margin filled.
    cast : int
        Texel samples looked up (those of texels that some face's UV box touches).
    rays : int
        Lookup rays cast: a texel's first sample, and those off its face.
    transfer_missed : int
        Samples whose transfer ray found no source.
    hits : int
        Samples that reached a face.
    parts : int
        Texture evaluations of the parts of texels whose surface bends, beyond their first
        sample (``texbake.sampling.creases``; one filtered sample a texel only).
    lookup_reused : bool
        Whether the lookups were an earlier bake's, kept in memory (then no ray was cast).
    error_estimate : dict or None
        The colour map's error estimate (``texbake.maps.estimate``); None in a bake of mesh
        maps only (texture none), which has no colour map.
    seconds : dict of str to float
        Seconds per stage, summed over the tiles that ran it.
    material : dict or None
        A material's bake: its maps and each node's evaluations (``texbake.maps.material``).
    faces : int
        The faces of the image's mesh (its texture set's, or UDIM tile's).
    mesh_maps : dict or None
        The mesh maps baked (``texbake.meshmaps.bake_maps``' tally: maps, texels, rays,
        ray_seconds, rays_per_second), or None.
    """

    covered: np.ndarray
    filled: np.ndarray
    cast: int
    rays: int
    transfer_missed: int
    hits: int
    parts: int = 0
    lookup_reused: bool = False
    error_estimate: dict | None = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    material: dict | None = None
    faces: int = 0
    mesh_maps: dict | None = None


def bake_report(settings: BakeSettings, mesh: LoadedMesh, units: list, *, source: LoadedMesh | None = None,
                cage: float | None = None, seconds: dict | None = None) -> dict:
    """The report of one bake (``report.json``).

    Parameters
    ----------
    settings : BakeSettings
        What was baked; ``report["settings"]`` is ``settings.model_dump(mode="json")``.
    mesh : LoadedMesh
        The mesh baked.
    units : list of texbake.pipeline.BakedSet
        Each image baked: its texture set's ``name``, its UDIM ``tile`` (None: the set's one
        image), the set's ``materials``, ``settings``, ``atlas`` and ``warnings``, and its
        ``tally``, what its stages counted.
    source, cage : LoadedMesh and float, optional
        The mesh transferred from and the transfer rays' reach, or None.
    seconds : dict of str to float, optional
        Seconds per stage, summed over the sets and tiles.

    Returns
    -------
    dict
        JSON-ready: ``mesh``, ``source``, ``settings``, ``atlas``, ``texels``, ``rays``,
        ``error_estimate``, ``warnings``, ``skipped``, ``seconds``, ``versions``, and
        ``sets``: per texture set its ``name``, ``materials``, ``faces``, ``size``, its own
        ``settings`` where they differ from the bake's, ``atlas``, ``texels``, ``rays``,
        ``error_estimate``, a material's ``material`` (its maps and nodes' evaluations) and ``tiles`` (per UDIM tile the same figures; none without
        tiles). For one set the top-level figures are its own; for several, the atlas
        names each set's method, and the texels, rays and error are over every image.
    """
    sets = _sets(settings, units)
    one = len(sets) == 1
    atlases = {u.name: u.atlas for u in units}
    warnings = [*mesh.warnings]
    for u in {u.name: u for u in units}.values():  # each stage's, in their order
        warnings += [w if one else f"texture set {u.name!r}: {w}" for w in [*u.warnings, *u.atlas.warnings]]
    tallies = [u.tally for u in units]
    return {
        "mesh": _mesh(mesh),
        "source": None if source is None else {"path": source.path, "sha256": source.sha256, "faces": int(len(source.faces)),
                                               "cage": cage},
        "settings": settings.model_dump(mode="json"),
        "atlas": sets[0]["atlas"] if one else {"method": "; ".join(f"{n}: {a.method}" for n, a in atlases.items()),
                                                "reason": "; ".join(f"{n}: {a.reason}" for n, a in atlases.items()),
                                                "cached": all(a.cached for a in atlases.values())},
        "texels": sets[0]["texels"] if one else _sum([s["texels"] for s in sets]),
        "rays": sets[0]["rays"] if one else _sum([s["rays"] for s in sets]),
        "error_estimate": sets[0]["error_estimate"] if one else _combined([s["error_estimate"] for s in sets]),
        **({"material": sets[0]["material"]} if one and "material" in sets[0] else {}),  # several sets: each set's own
        **({"mesh_maps": sets[0]["mesh_maps"]} if one and "mesh_maps" in sets[0] else {}),
        "warnings": warnings + _transfer_warning(sum(t.cast for t in tallies), sum(t.transfer_missed for t in tallies)),
        "skipped": _skipped(source, list(atlases.values()), tallies, mesh_maps_only=settings.texture is None and settings.material is None),
        "seconds": {k: round(v, 4) for k, v in (seconds or {}).items()},
        "versions": library_versions(),
        "sets": sets,
    }


def _sets(settings: BakeSettings, units: list) -> list[dict]:
    """The report's ``sets``: each texture set's figures, with its tiles'."""
    out: dict[str, dict] = {}
    for u in units:
        name, tile, materials, own, atlas, tally = u.name, u.tile, u.materials, u.settings, u.atlas, u.tally
        figures = _figures(own, tally)
        if name not in out:
            out[name] = {"name": name, "materials": materials, "size": list(own.width_height),
                         **({} if own == settings.model_copy(update={"materials": None}) else {"settings": own.model_dump(mode="json")}),
                         "atlas": {"method": atlas.method, "reason": atlas.reason, "cached": atlas.cached, "udim": atlas.udim,
                                   **atlas.stats},
                         "faces": 0, "tiles": []}
        entry = out[name]
        entry["faces"] += int(tally.faces)
        if tile is not None:
            entry["tiles"].append({"tile": tile, "faces": int(tally.faces), **figures})
    for entry in out.values():
        tiles = entry["tiles"]
        if tiles:
            entry.update(texels=_sum([t["texels"] for t in tiles]), rays=_sum([t["rays"] for t in tiles]),
                         error_estimate=_combined([t["error_estimate"] for t in tiles]))
        else:
            entry.update(next(_figures(u.settings, u.tally) for u in units if u.name == entry["name"]))
    return list(out.values())


def _figures(settings: BakeSettings, tally: BakeTally) -> dict:
    """One image's ``texels``, ``rays`` and ``error_estimate``."""
    width, height = settings.width_height
    covered, filled = int(tally.covered.sum()), int(tally.filled.sum())
    return {
        "texels": {"total": width * height, "covered": covered, "margin": filled, "empty": width * height - covered - filled},
        "rays": {
            "texel_samples": width * height * settings.samples,
            "cast": tally.cast,  # samples of texels that some face's UV box touches, looked up
            "lookup_reused": tally.lookup_reused,
            "lookup_rays": tally.rays,  # of them: a texel's first sample, and those off its face
            "missed": tally.cast - tally.hits - tally.transfer_missed,
            "missed_inside_atlas": _cracks(tally.covered),
            "transfer_missed": tally.transfer_missed,
            "crease_parts": tally.parts,  # evaluations of bent texels' parts (texbake.sampling.creases), not looked up
        },
        "error_estimate": tally.error_estimate,
        **({} if tally.material is None else {"material": tally.material}),
        **({} if tally.mesh_maps is None else {"mesh_maps": tally.mesh_maps}),
    }


def _sum(dicts: list[dict]) -> dict:
    """The figures of several images added up (a flag: whether all are set)."""
    return {k: all(d[k] for d in dicts) if isinstance(v, bool) else sum(d[k] for d in dicts) for k, v in dicts[0].items()}


def _combined(estimates: list[dict | None]) -> dict | None:
    """Several images' error estimates as one over all their probed texels: the RMSE of
    their squared errors pooled, weighted by the texels each probed."""
    given = [e for e in estimates if e is not None]  # a bake of mesh maps only estimates nothing
    if not given:
        return None
    weights = [max(int(e.get("texels", 0)), 0) for e in given]
    total = sum(weights)
    if not total:
        return dict(given[0])
    pool = lambda key, i=None: float(np.sqrt(sum(w * (e[key] if i is None else e[key][i]) ** 2
                                                 for w, e in zip(weights, given, strict=True)) / total))
    return {**given[0], "rmse": pool("rmse"), "rmse_interval": [pool("rmse_interval", 0), pool("rmse_interval", 1)],
            "texels": total, "probe_rmse": pool("probe_rmse"), "probe_noise": pool("probe_noise"),
            "fine_texels": sum(int(e.get("fine_texels", 0)) for e in given)}


def _mesh(mesh: LoadedMesh) -> dict:
    """The report's ``mesh``: where it came from, its counts and its bounds."""
    return {
        "name": mesh.name,
        "path": mesh.path,
        "sha256": mesh.sha256,
        "vertices": int(len(mesh.vertices)),
        "faces": int(len(mesh.faces)),
        "degenerate_faces_removed": int(mesh.removed_degenerate),
        "duplicate_faces_removed": int(mesh.removed_duplicate),
        "bounds": [mesh.vertices.min(axis=0).tolist(), mesh.vertices.max(axis=0).tolist()],
    }


def _skipped(source: LoadedMesh | None, atlases: list[Atlas], tallies: list[BakeTally], mesh_maps_only: bool = False) -> list[dict]:
    """The stages a bake left out (for every texture set), and why."""
    skipped = []
    if mesh_maps_only:
        skipped.append({"stage": "texture", "why": "texture none: the mesh maps alone (no albedo, no samples or error estimate of its own)"})
    if source is None:
        skipped.append({"stage": "transfer", "why": "no source mesh given"})
    if all(a.cached for a in atlases):
        reason = "; ".join(dict.fromkeys(a.reason for a in atlases))
        skipped.append({"stage": "unwrap", "why": f"the atlas of an earlier bake of this mesh, from the cache ({reason})"})
    elif all(a.method == "kept" for a in atlases):
        skipped.append({"stage": "unwrap", "why": "; ".join(dict.fromkeys(a.reason for a in atlases))})
    if all(t.lookup_reused for t in tallies):
        skipped.append({"stage": "lookup", "why": "the texel lookup of an earlier bake of this atlas at this size, kept in memory"})
    return skipped


def _transfer_warning(cast: int, missed: int) -> list[str]:
    """A warning when more than 1 % of the transfer rays found no source."""
    if cast and missed > 0.01 * cast:
        return [f"transfer: {missed} of {cast} texel samples found no source within the cage; they keep the margin's colour"]
    return []


def _cracks(covered: np.ndarray, band: int = 1024) -> int:
    """Texels that no sample hit although their four neighbours are covered, counted in
    bands of rows (no full-size temporaries: a 16384² mask is 268 MB)."""
    h = covered.shape[0]
    total = 0
    for top in range(1, h - 1, band):
        rows = slice(top, min(h - 1, top + band))
        up, down = slice(top - 1, rows.stop - 1), slice(top + 1, rows.stop + 1)
        c = covered[rows, 1:-1]
        total += int((~c & covered[up, 1:-1] & covered[down, 1:-1] & covered[rows, :-2] & covered[rows, 2:]).sum())
    return total
