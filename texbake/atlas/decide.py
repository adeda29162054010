"""The atlas stage's decision: keep the mesh's own UVs when usable, or unwrap one way, then
the other, and fall back to a grid when both fail.

:func:`make_atlas` is that list of attempts. The UVs a mesh brings are checked first
(:mod:`texbake.atlas.uvcheck`: inside the unit square, no face of zero area, not
overlapping on the bake's texel grid). An unwrap charts the mesh one of two ways, planar
charts (:mod:`texbake.atlas.charts`: CAD parts and large meshes) or xatlas' own charts
(small organic meshes), in the order :func:`texbake.atlas.charts.prefer_planar` chooses,
and packs the charts with xatlas in worker processes under one deadline of their CPU time
(:mod:`texbake.atlas.pack`). When one charting fails (crash, deadline, bad UVs) the other
is tried; only when both have does every triangle get its own cell of a grid
(:mod:`texbake.atlas.fallback`, "fallback-grid"); a charting asked for by name is the only
one tried. A mesh whose parts have UVs only in part
keeps those and unwraps the rest (:func:`_keep_parts`, :mod:`texbake.atlas.parts`).
``Atlas.reason`` says what was chosen, why, and what failed before it; ``Atlas.warnings``
what a user should know, one line each (the report, the command line, the service and
the page show them).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import AtlasError, ParameterError
from ..mesh import areas, label_boxes, uv_areas
from ..workers import Pool
from .charts import Sides, prefer_planar
from .fallback import grid_atlas
from .pack import PATCH_FACES, Unwrapped, UnwrapRequest, XatlasFailed, start_workers, unwrap
from .parts import combine
from .repack import repack, repack_problem
from .uvcheck import (
    OVERLAP_GRID,
    bare_warning,
    chart_labels,
    coverage,
    coverage_counts,
    measure,
    overlap_of,
    packing_estimate,
    udim_offset,
    udim_overlap,
    udim_tiles,
    unwrap_problem,
    uv_problem,
)

MODES = ("auto", "unwrap", "keep")
CHARTINGS = ("auto", "xatlas", "planar")
OVERLAP_LIMIT = 0.01  # a mesh's UVs under which more of the covered texels overlap are not kept
SPARSE_SHARE = 0.5  # a warning when kept UVs use less than this share of the tile an unwrap would use
PROMISE_SHARE = 0.4  # a warning when an unwrap's utilisation is under this share of what its charts promise
# ... which names a chart this much of the tile's side long, at least STRIP_ASPECT times as long
# as it is wide, as the cause: a strip the packing must lay across the tile
ACROSS_SHARE = 0.9
STRIP_ASPECT = 4.0


@dataclass
class Atlas:
    """A UV layout for a mesh; the faces are the mesh's own, in the same order.

    ``vertices[vmapping][faces] == vertices[input_faces]`` exactly: atlas vertex ``i``
    is mesh vertex ``vmapping[i]`` (seams split mesh vertices into several).
    """

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: faces in atlas-vertex indices, same order as the mesh's
    uv: np.ndarray  # (k, 2) float64 in [0, 1], OpenGL convention (v up); in UDIM tiles where ``udim``
    method: str  # "kept" | "planar" | "xatlas" | "xatlas-patches" | "fallback-grid", or "kept+" one of those (UVs kept in part)
    reason: str  # why this method (and what failed before it)
    stats: dict = field(default_factory=dict)  # charts, utilisation, stretch, overlap, seconds
    warnings: list[str] = field(default_factory=list)  # what a user should know of this atlas
    cached: bool = False  # taken from a cache of an earlier bake (texbake.atlas.cache), not made now
    udim: bool = False  # the UVs lie in UDIM tiles (u in [0, 10), v >= 0, each face in one: uvcheck.udim_tiles), kept as they are


def make_atlas(
    vertices: np.ndarray,
    faces: np.ndarray,
    uv: np.ndarray | None = None,
    *,
    mode: str = "auto",
    size: int = 1024,
    padding: int = 2,
    deadline: float = 120.0,
    workers: int = 2,
    charting: str = "auto",
    has_uv: np.ndarray | None = None,
    part: np.ndarray | None = None,
    part_names: list[str] | tuple[str, ...] = (),
    _patch_faces: int | None = PATCH_FACES,
) -> Atlas:
    """A UV atlas for a triangle mesh: its own UVs kept, or an unwrap.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
        Positions, finite where a face uses them; cast to float64.
    faces : (m, 3) array_like of int
        Triangles, indices in ``[0, n)``, m >= 1; cast to int64.
    uv : (n, 2) array_like of float, optional
        The mesh's per-vertex UVs, or None (NaN on the vertices of faces that have none).
    has_uv, part, part_names : (m,) bool, (m,) int and list of str, optional
        ``LoadedMesh``'s: which faces have UVs when only some do, each face's part and the
        parts' names. UVs are then kept part by part (:func:`_usable_parts`, :mod:`.parts`).
    mode : {"auto", "unwrap", "keep"}, optional
        "auto" keeps usable UVs (:func:`uv_problem`) overlapping on at most ``OVERLAP_LIMIT``
        of their texels, else unwraps; "unwrap" always unwraps; "keep" requires usable UVs.
    size, padding : int, optional
        Texels of the square texture (1 to 65536) and between charts (0 to 64).
    deadline, workers : float, int, optional
        Seconds of CPU time each xatlas worker may use for the unwrap (a busy machine takes
        longer, not another atlas), and the workers (this process's, kept warm).
    charting : {"auto", "xatlas", "planar"}, optional
        "planar", "xatlas" (in patches above ``2 * PATCH_FACES`` faces) or "auto"
        (:func:`texbake.atlas.charts.prefer_planar`; the other when the first fails, then
        the "fallback-grid"); one asked for is the only one tried.
    _patch_faces : int or None
        Faces per patch of the xatlas unwrap; None: the whole mesh in one piece (tests).

    Returns
    -------
    Atlas
        ``reason``: why the UVs were not kept, the charting used and why, what failed.
        ``stats``: :func:`texbake.atlas.uvcheck.measure`'s, ``seconds``, ``patches`` or
        ``planar_charts``, ``flat_share``, ``double_sided_faces``, ``packing`` (passes
        redone, why). ``warnings``: one line each, what a user should know (UVs replaced
        or sparse, parts unwrapped, retries, fallbacks, deadlines; see the helpers below).

    Raises
    ------
    ParameterError
        A bad ``mode`` (named ``uv``), ``charting``, ``size``, ``padding``, ``deadline``
        or ``workers``.
    AtlasError
        Arrays of the wrong shape, no faces, faces that index missing vertices, vertices
        that are not finite, unusable UVs with ``mode="keep"``, a ``charting`` asked for
        that failed, or no atlas at all.
    """
    start = time.perf_counter()
    _check_settings(mode=mode, charting=charting, size=size, padding=padding, deadline=deadline, workers=workers)
    request = UnwrapRequest(*_checked_mesh(vertices, faces), size, padding)
    if len((sides := Sides.of(request.faces)).back):  # double-sided: one side is mapped, the other shares its texels
        f = sides.front
        return _both_sides(sides, make_atlas(request.vertices, request.faces[f], uv, mode=mode, size=size, padding=padding,
                                             deadline=deadline, workers=workers, charting=charting, part_names=part_names,
                                             has_uv=None if has_uv is None else np.asarray(has_uv)[f],
                                             part=None if part is None else np.asarray(part)[f], _patch_faces=_patch_faces))
    kept, why = _kept(request, uv, has_uv, part, part_names, mode=mode, deadline=deadline, workers=workers,
                      charting=charting, patch_faces=_patch_faces, start=start)
    if kept is not None:
        return kept
    replaced = [f"the mesh's UVs were replaced by an unwrap: {why}"] if uv is not None and mode == "auto" else []
    return _unwrap(request, why, replaced, deadline=deadline, workers=workers, charting=charting,
                   patch_faces=_patch_faces, start=start)


def _kept(request: UnwrapRequest, uv, has_uv, part, part_names, *, mode: str, **by_part: Any) -> tuple[Atlas | None, str]:
    """``(the atlas keeping the mesh's UVs, why)``, whole or part by part, or ``(None, why
    they are not kept)``."""
    mixed = _mixed(has_uv, uv, len(request.faces))
    several = part is not None and uv is not None and len(np.unique(part)) > 1
    if mode == "unwrap":
        return None, "uv='unwrap'"
    if mixed is None and not (several and mode == "keep"):
        kept, why = _keep(request, uv, mode, by_part["start"])
        if kept is None and mode == "auto" and uv is not None:
            kept, why = _repacked(request, np.asarray(uv, dtype=np.float64), why, **by_part)
        if kept is not None or not several:
            return kept, why
    return _keep_parts(request, uv, mixed, part, part_names, mode=mode, **by_part)


def _unwrap(request: UnwrapRequest, why: str, warnings: list[str], *, deadline: float, workers: int, charting: str,
            patch_faces: int | None, start: float) -> Atlas:
    """The atlas of an unwrap (or the fallback grid), its reason starting with ``why`` (the
    UVs not kept) and its warnings with ``warnings``."""
    with start_workers(workers, deadline) as pool:  # one set of workers for every attempt
        found, order, failures = _unwrapped(request, pool, charting, patch_faces)
    if found is None:
        grid = _fallback(request, deadline, why, failures, start, charting)
        grid.warnings[:0] = warnings
        return grid
    charted, atlas, raster = found
    retried = f" (after: {'; '.join(failures)})" if failures else ""
    stats = {**_stats(request, atlas.faces, atlas.uv, start, raster), **atlas.detail}
    warnings = (warnings + _retry_warning(charting, charted, failures) + _promise_warning(request, atlas, stats)
                + _overlap_warning(stats))
    return Atlas(atlas.vmapping, atlas.faces, atlas.uv, atlas.method, f"{why}; {charted} charts: {order}{retried}", stats,
                 warnings + _deadline_warning(failures, deadline) + bare_warning(stats, request.size))


def _unwrapped(request: UnwrapRequest, pool: Pool, charting: str,
               patch_faces: int | None) -> tuple[tuple[str, Unwrapped, tuple | None] | None, str, list[str]]:
    """``((charting used, atlas, its raster) or None, why that charting, what failed)``: the
    unwrap's attempts in ``pool`` within its deadline; the raster is :func:`coverage` of the
    atlas on the overlap grid, made once for the choice and the stats."""
    attempts, order = _attempts(request.vertices, request.faces, charting, patch_faces)
    failures: list[str] = []
    found = _first_usable(request, pool, attempts, failures)
    return found, order, failures


def _retry_warning(charting: str, charted: str, failures: list[str]) -> list[str]:
    """A warning when the atlas' charting is not the first tried: what failed, what was used."""
    if not failures:
        return []
    asked = f"charting={charting!r} was asked for, but " if charting not in ("auto", charted) else ""
    return [f"{asked}the first unwrap failed ({'; '.join(failures)}): {charted} charts used instead"]


def _promise_warning(request: UnwrapRequest, atlas: Unwrapped, stats: dict) -> list[str]:
    """A warning when the packing left far more of the tile empty than its charts need
    (:func:`texbake.atlas.uvcheck.packing_estimate` with the padding), naming a planar
    chart laid across the whole tile as a strip (``ACROSS_SHARE``, ``STRIP_ASPECT``) as
    the cause, and what would let it be cut."""
    promised = packing_estimate(request.vertices, request.faces, atlas.faces, atlas.uv, request.padding / request.size)
    used = stats["utilisation"]
    if used >= PROMISE_SHARE * promised:
        return []
    why = "the packing left most of the tile empty"
    lo, hi = label_boxes(atlas.uv, atlas.faces, chart_labels(atlas.faces, len(atlas.uv)))
    extent = hi - lo
    longest = int(np.argmax(extent.max(axis=1)))
    span, width = float(extent[longest].max()), float(extent[longest].min())
    if atlas.method == "planar" and span >= ACROSS_SHARE and span >= STRIP_ASPECT * width:
        # planar charts cut a chart this long between its faces (texbake.atlas.charts._cut_long): these are too long
        why = (f"its longest chart runs across the tile at {span / max(width, 1e-12):.0f}:1, and its faces run along "
               "it too far to cut it between them: more edges across it (an edge loop every so often) would let the "
               "unwrap cut it into pieces that fill the tile")
    return [f"utilisation {used:.3f} is far below the {promised:.2f} its {stats['charts']} charts promise (their area "
            f"over their padded bounding boxes): {why}"]


def _both_sides(sides: Sides, atlas: Atlas) -> Atlas:
    """The atlas of a mesh's front faces (:class:`texbake.atlas.charts.Sides`: their own UVs
    kept, or unwrapped) with its back faces on their twins' texels, counted in
    ``stats["double_sided_faces"]``."""
    vmapping, faces, uv = sides.restored(atlas.vmapping, atlas.faces, atlas.uv)
    reason = f"{atlas.reason}; {len(sides.back)} back faces share their front faces' texels"
    stats = {**atlas.stats, "double_sided_faces": len(sides.back)}
    return Atlas(vmapping, faces, uv, atlas.method, reason, stats, atlas.warnings, udim=atlas.udim)


def _passed(deadline: float) -> str:
    return f"the unwrap deadline of {deadline:g} s passed"


def _deadline_warning(failures: list[str], deadline: float) -> list[str]:
    """A warning when an unwrap was cut short by the deadline (its atlas is then not the one
    that a longer deadline would give)."""
    late = [f for f in failures if "timed out" in f]
    if not late:
        return []
    return [f"the unwrap deadline ({deadline:g} s of CPU time) passed: {'; '.join(late)}; "
            "a longer unwrap_deadline gives the usual atlas"]


def _check_settings(*, mode, charting, size, padding, deadline, workers) -> None:
    """:class:`ParameterError` naming the first of :func:`make_atlas`' settings out of range."""
    if mode not in MODES:
        raise ParameterError("uv", f"expected one of {', '.join(MODES)}, got {mode!r}")
    if charting not in CHARTINGS:
        raise ParameterError("charting", f"expected one of {', '.join(CHARTINGS)}, got {charting!r}")
    for name, value, ok in (
        ("size", size, isinstance(size, (int, np.integer)) and 1 <= size <= 65536),
        ("padding", padding, isinstance(padding, (int, np.integer)) and 0 <= padding <= 64),
        ("deadline", deadline, isinstance(deadline, (int, float)) and deadline > 0),
        ("workers", workers, isinstance(workers, (int, np.integer)) and workers >= 1),
    ):
        if not ok:
            raise ParameterError(name, f"out of range or of the wrong type: {value!r}")


def _checked_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """``(n, 3)`` float64 vertices and ``(m, 3)`` int64 faces, or :class:`AtlasError`
    unless there are faces, indexing vertices that are finite."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise AtlasError(f"expected (n, 3) vertices and (m, 3) faces, got {vertices.shape} and {faces.shape}")
    if len(faces) == 0:
        raise AtlasError("the mesh has no faces")
    if faces.min() < 0 or faces.max() >= len(vertices):
        raise AtlasError("the mesh's faces index missing vertices")
    used = np.zeros(len(vertices), dtype=bool)
    used[faces] = True  # linear, where np.unique would sort every corner
    if not np.isfinite(vertices[used]).all():
        raise AtlasError("the mesh's vertices are not finite")
    return vertices, faces


def _stats(request: UnwrapRequest, faces: np.ndarray, uv: np.ndarray, start: float, raster=None) -> dict:
    """:func:`texbake.atlas.uvcheck.measure` of an atlas of ``request``'s mesh, and the
    ``seconds`` since ``start`` (``time.perf_counter()``)."""
    stats = measure(request.vertices, request.faces, faces, uv, request.size, raster)
    stats["seconds"] = time.perf_counter() - start
    return stats


def _keep(request: UnwrapRequest, uv, mode: str, start: float) -> tuple[Atlas | None, str]:
    """``(the atlas of the mesh's own UVs, why)`` when ``mode`` keeps them (in the unit
    square, or in UDIM tiles: :func:`_keep_udim`), else ``(None, why they are not kept)``;
    :class:`AtlasError` when ``mode`` is "keep" and they are not usable."""
    tiles = None if uv is None else udim_tiles(uv, request.faces)
    if tiles is not None and (tiles != 1001).any():
        return _keep_udim(request, np.asarray(uv, dtype=np.float64), tiles, mode, start)
    problem, warnings, raster = _kept_problem(request, uv, mode)
    if problem is not None:
        return None, problem
    uv = np.asarray(uv, dtype=np.float64)
    vm = np.arange(len(request.vertices), dtype=np.int64)
    reason = "the mesh's UVs are usable" if not warnings else "uv='keep'"
    stats = _stats(request, request.faces, uv, start, raster)
    warnings += _sparse_warning(request, request.faces, uv, stats)
    return Atlas(vm, request.faces, uv, "kept", reason, stats, warnings + bare_warning(stats, request.size)), reason


def _keep_udim(request: UnwrapRequest, uv: np.ndarray, tiles: np.ndarray, mode: str, start: float) -> tuple[Atlas | None, str]:
    """``(the atlas keeping UVs laid out in UDIM tiles (``tiles``: each face's), why)``, or
    ``(None, why not)``: no face of zero UV area and, unless ``mode`` is "keep", under
    ``OVERLAP_LIMIT`` of the covered texels of the tiles, each on its own grid, under two
    faces. Each tile is baked as its own image (``texbake.sets.tiles``)."""
    numbers = np.unique(tiles).tolist()
    named = f"{len(numbers)} UDIM tiles ({', '.join(map(str, numbers[:8]))}{', ...' if len(numbers) > 8 else ''})"
    zero = int((uv_areas(uv, request.faces) <= 0).sum())
    if zero:
        if mode == "keep":
            raise AtlasError(f"uv='keep' but {zero} faces have zero UV area")
        return None, f"the mesh's UVs lie in {named} but {zero} faces have zero UV area"
    share, most = udim_overlap(uv, request.faces, tiles, min(request.size, OVERLAP_GRID))
    warnings = []
    if share > OVERLAP_LIMIT:
        overlapping = f"the mesh's UVs overlap: {share:.1%} of the covered texels of its {named} lie under two or more faces (up to {most})"
        if mode != "keep":
            return None, overlapping
        warnings.append(f"{overlapping}: those texels show one face's texture on all of them")
    stats = _udim_stats(request, uv, tiles, start)
    stats["overlap"] = share
    reason = f"the mesh's UVs lie in {named}: each tile is baked as its own image"
    vm = np.arange(len(request.vertices), dtype=np.int64)
    return Atlas(vm, request.faces, uv, "kept", reason, stats, warnings + bare_warning(stats, request.size), udim=True), reason


def _udim_stats(request: UnwrapRequest, uv: np.ndarray, tiles: np.ndarray, start: float) -> dict:
    """:func:`_stats` of a UDIM layout, tile by tile: charts added up, utilisation the
    tiles' mean, stretch and bare area weighted by the surface; ``tiles``, the tiles used."""
    per, weights = [], []
    for tile in np.unique(tiles).tolist():
        faces = request.faces[tiles == tile]
        per.append(measure(request.vertices, faces, faces, uv - udim_offset(tile), request.size))
        weights.append(float(areas(request.vertices, faces).sum()))
    w = np.asarray(weights) / max(sum(weights), 1e-300)
    bare = None if any(p["bare_area"] is None for p in per) else float(sum(wi * p["bare_area"] for wi, p in zip(w, per, strict=True)))
    return {"charts": sum(p["charts"] for p in per), "utilisation": float(np.mean([p["utilisation"] for p in per])),
            "stretch": float(sum(wi * p["stretch"] for wi, p in zip(w, per, strict=True))), "bare_area": bare,
            "tiles": np.unique(tiles).tolist(), "seconds": time.perf_counter() - start}


def _repacked(request: UnwrapRequest, uv: np.ndarray, why: str, *, deadline: float, workers: int, charting: str,
              patch_faces: int | None, start: float) -> tuple[Atlas | None, str]:
    """``(the atlas of the mesh's own UV islands packed anew, why)`` (:mod:`texbake.atlas.repack`)
    for UVs not kept as they are (``why``), or ``(None, why not)``: where the islands are
    not sound (:func:`texbake.atlas.repack.repack_problem`; a repeating layout is said in
    the reason), or their packing fails or overlaps."""
    grid = min(request.size, OVERLAP_GRID)
    problem = repack_problem(request.vertices, request.faces, uv, grid, OVERLAP_LIMIT)
    if problem is not None:
        return None, f"{why}; {problem}" if "repeat" in problem else why
    with start_workers(workers, deadline) as pool:
        try:
            found, islands, anew = repack(request, uv, pool, pool.left())
            bad = unwrap_problem(found.vmapping, found.faces, found.uv, request.faces, len(request.vertices))
        except XatlasFailed as exc:
            bad = str(exc)
    if bad is None and overlap_of(coverage_counts(found.uv, found.faces, grid))[0] > OVERLAP_LIMIT:
        bad = "the islands packed overlap"
    if bad is not None:
        return None, f"{why}; packing its UV islands anew failed: {bad}"
    charted = f"; {anew:,} faces that fold over their island or have no UV area charted anew" if anew else ""
    reason = f"{why}: its {islands:,} UV islands packed anew into the tile, shape for shape{charted}"
    stats = {**_stats(request, found.faces, found.uv, start), **found.detail, "charted_anew": anew}
    warnings = [f"the mesh's UV islands were packed anew into the tile, each kept shape for shape ({why}){charted}"]
    return Atlas(found.vmapping, found.faces, found.uv, found.method, reason, stats, warnings + bare_warning(stats, request.size)), reason


def _kept_problem(request: UnwrapRequest, uv, mode: str) -> tuple[str | None, list[str], tuple | None]:
    """``(why the UVs of ``request``'s faces are not kept or None, warnings, their raster)``:
    usable (:func:`uv_problem`) and, unless ``mode`` is "keep", not overlapping more than
    ``OVERLAP_LIMIT`` on the bake's grid; :class:`AtlasError` when "keep" cannot keep them."""
    problem = uv_problem(request.vertices, request.faces, uv)
    if problem is not None:
        if mode == "keep":
            raise AtlasError(f"uv='keep' but {problem}")
        return problem, [], None
    raster = coverage(np.asarray(uv, dtype=np.float64), request.faces, min(request.size, OVERLAP_GRID))
    share, most = overlap_of(raster[0])
    if share <= OVERLAP_LIMIT:
        return None, [], raster
    overlapping = f"the mesh's UVs overlap: {share:.1%} of the covered texels lie under two or more faces (up to {most})"
    if mode != "keep":
        return overlapping, [], None
    return None, [f"{overlapping}: those texels show one face's texture on all of them"], raster


def _sparse_warning(request: UnwrapRequest, uv_faces: np.ndarray, uv: np.ndarray, stats: dict) -> list[str]:
    """A warning when kept UVs use under ``SPARSE_SHARE`` of the tile an unwrap would
    (estimated: :func:`texbake.atlas.uvcheck.packing_estimate` of their own islands)."""
    estimate = packing_estimate(request.vertices, request.faces, uv_faces, uv, request.padding / request.size)
    used = stats["utilisation"]
    if used >= SPARSE_SHARE * estimate:
        return []
    return [f"the kept UVs use {used:.3f} of the tile; an unwrap would use about {estimate:.2f} (estimated from "
            f"their islands packed at one texel density): uv='unwrap' gives {estimate / max(used, 1e-9):.1f}x the texels"]


def _mixed(has_uv, uv, m: int) -> np.ndarray | None:
    """``has_uv`` as an (m,) bool array when some faces have UVs and others not, else None."""
    if has_uv is None or uv is None:
        return None
    has_uv = np.asarray(has_uv, dtype=bool)
    if has_uv.shape != (m,):
        raise AtlasError(f"expected has_uv of shape ({m},), one per face, got {has_uv.shape}")
    return has_uv if has_uv.any() and not has_uv.all() else None


def _keep_parts(request: UnwrapRequest, uv, has_uv: np.ndarray | None, part: np.ndarray | None, part_names, *,
                mode: str, deadline: float, workers: int, charting: str, patch_faces: int | None,
                start: float) -> tuple[Atlas | None, str]:
    """UVs part by part: ``(the atlas keeping the UVs of the parts :func:`_usable_parts`
    keeps and unwrapping the others, why)``, or ``(None, why not)`` when no part's are
    kept. :mod:`texbake.atlas.parts` puts the two into one tile."""
    uv = np.asarray(uv, dtype=np.float64)
    keep, unwrapped, warnings = _usable_parts(request, uv, has_uv, part, part_names, mode)
    if keep.all():
        return _keep(request, uv, mode, start)
    if not keep.any():
        return None, "; ".join(unwrapped)
    used, local = np.unique(request.faces[~keep], return_inverse=True)
    sub = UnwrapRequest(request.vertices[used], local.reshape(-1, 3), request.size, request.padding)
    with start_workers(workers, deadline) as pool:
        found, order, failures = _unwrapped(sub, pool, charting, patch_faces)
        if found is None and charting != "auto":
            raise AtlasError(f"charting={charting!r} cannot be honoured: {'; '.join(failures) or _passed(deadline)}")
        if found is None:
            vm, fa, u = grid_atlas(sub.vertices, sub.faces, sub.padding / sub.size)
            found, order = ("grid", Unwrapped(vm, fa, u, "fallback-grid", {}), None), "both chartings failed"
        try:
            out = combine(request, keep, uv, found[1], used, pool, pool.left())
            bad = unwrap_problem(out.vmapping, out.faces, out.uv, request.faces, len(request.vertices))
        except XatlasFailed as exc:
            bad = str(exc)
    if bad is not None:
        if mode == "keep":
            raise AtlasError(f"uv='keep' but the kept UVs and the other parts' charts cannot share the tile: {bad}")
        return None, f"the kept UVs and the other parts' charts cannot share the tile: {bad}"
    named = "; ".join(unwrapped)
    reason = f"the UVs of the parts that have usable ones, {out.how}; unwrapped: {named}: {found[0]} charts: {order}"
    stats = {**_stats(request, out.faces, out.uv, start), **found[1].detail, "kept_scale": out.scale,
             "kept_faces": int(keep.sum())}
    kept = UnwrapRequest(request.vertices, request.faces[keep], request.size, request.padding)
    as_they_came = {"utilisation": float(uv_areas(uv, kept.faces).sum())}  # before any scaling
    warnings = [f"unwrapped: {named}; the UVs of the other parts {out.how}", *warnings,
                *_retry_warning(charting, found[0], failures), *_sparse_warning(kept, kept.faces, uv, as_they_came)]
    return Atlas(out.vmapping, out.faces, out.uv, "kept+" + found[1].method, reason, stats,
                 warnings + bare_warning(stats, request.size)), reason


def _usable_parts(request: UnwrapRequest, uv: np.ndarray, has_uv: np.ndarray | None, part: np.ndarray | None,
                  names, mode: str) -> tuple[np.ndarray, list[str], list[str]]:
    """``(the faces whose UVs are kept (m,) bool, each part not kept and why, warnings)``.

    Part by part, the largest first: a part's UVs are kept when usable (:func:`uv_problem`)
    and, unless ``mode`` is "keep", when under ``OVERLAP_LIMIT`` of their texel centres lie
    under two of its faces or under a part kept before it (two parts sharing one layout:
    the first keeps it). :class:`AtlasError` when "keep" meets UVs that are not usable.
    """
    m = len(request.faces)
    has = np.ones(m, dtype=bool) if has_uv is None else has_uv
    group = 2 * (np.zeros(m, dtype=np.int64) if part is None else np.asarray(part, dtype=np.int64)) + has
    ids, sizes = np.unique(group, return_counts=True)
    grid = min(request.size, OVERLAP_GRID)
    taken, keep = np.zeros((grid, grid), dtype=bool), np.zeros(m, dtype=bool)
    unwrapped: list[str] = []
    warnings: list[str] = []
    for g in ids[np.argsort(-sizes, kind="stable")]:
        faces = group == g
        named = _named(names, int(g) // 2, int(faces.sum()))
        if g % 2 == 0:
            unwrapped.append(f"{named} {'has' if g // 2 < len(names) else 'have'} no UVs")
            continue
        problem = uv_problem(request.vertices, request.faces[faces], uv)
        if problem is not None:
            problem = problem.replace("the mesh's", "its")
            if mode == "keep":
                raise AtlasError(f"uv='keep' but {named}: {problem}")
            unwrapped.append(f"{named}: {problem}")
            continue
        counts = coverage_counts(uv, request.faces[faces], grid)
        covered = counts > 0
        share = float(((counts > 1) | (covered & taken)).sum() / max(int(covered.sum()), 1))
        if share > OVERLAP_LIMIT:
            what = f"{named}: {share:.1%} of its UVs' texels lie under two of its faces or under a part kept before it"
            if mode != "keep":
                unwrapped.append(what)
                continue
            warnings.append(f"{what}: those texels show one face's texture on all of them")
        taken |= covered
        keep[faces] = True
    return keep, unwrapped, warnings


def _named(names, index: int, faces: int) -> str:
    """A part in words: ``part 'wheel' (120 faces)``."""
    return f"part {names[index]!r} ({faces:,} faces)" if index < len(names) else f"{faces:,} faces"


def _attempts(vertices, faces, charting: str, patch_faces: int | None) -> tuple[list[tuple[str, int | None]], str]:
    """The unwraps to try in turn, ``(charting, faces per patch)``, and why that order.

    xatlas in one piece or in patches, then in smaller patches (icosphere(6) crashes it
    in one piece; smaller patches may get through), and planar charts, first or last
    as ``charting`` asks ("auto": see :func:`texbake.atlas.charts.prefer_planar`).
    """
    xatlas = [("xatlas", patch_faces)]
    if patch_faces is None and len(faces) > 2 * PATCH_FACES:
        xatlas.append(("xatlas", PATCH_FACES))
    elif patch_faces is not None and len(faces) > 2 * patch_faces:
        xatlas.append(("xatlas", max(250, patch_faces // 4)))
    if charting != "auto":  # asked for: that charting only
        return (xatlas if charting == "xatlas" else [("planar", None)]), f"charting={charting!r}"
    planar_first, why = prefer_planar(vertices, faces)
    return ([("planar", None), *xatlas] if planar_first else [*xatlas, ("planar", None)]), why


def _first_usable(request: UnwrapRequest, pool: Pool, attempts: list[tuple[str, int | None]],
                  failures: list[str]) -> tuple[str, Unwrapped, tuple] | None:
    """``(charting, atlas, raster)`` of the first of ``attempts`` that gives a usable atlas within
    ``pool``'s deadline, or None; what failed is added to ``failures``. xatlas is not
    tried again once it has timed out. An atlas whose charts overlap on more than
    ``OVERLAP_LIMIT`` of the covered texels (on the bake's grid) is passed over for the
    next attempt; when none does better, the least overlapping is used (and
    :func:`_overlap_warning` says so)."""
    overlapping: tuple[float, str, Unwrapped, tuple] | None = None
    for i, (charting, patch_faces) in enumerate(attempts):
        left = pool.left()
        if left <= 0 or (charting == "xatlas" and any("timed out" in f for f in failures)):
            continue
        # xatlas' charting may take 3/4 of what is left when planar charts are still to come
        share = 0.75 * left if ("planar", None) in attempts[i + 1:] else left
        pool.cap = pool.seconds - left + share
        try:
            atlas = unwrap(request, pool, share, patch_faces, charting)
        except XatlasFailed as exc:
            failures.append(str(exc))
            continue
        bad = unwrap_problem(atlas.vmapping, atlas.faces, atlas.uv, request.faces, len(request.vertices))
        if bad is not None:
            failures.append(f"{charting} charting gave an unusable atlas: {bad}")
            continue
        raster = coverage(atlas.uv, atlas.faces, min(request.size, OVERLAP_GRID))  # kept for the stats: one rasterisation
        over, _ = overlap_of(raster[0])
        if over <= OVERLAP_LIMIT:
            return charting, atlas, raster
        failures.append(f"{charting} charting's atlas overlaps on {over:.1%} of its covered texels")
        if overlapping is None or over < overlapping[0]:
            overlapping = over, charting, atlas, raster
    return None if overlapping is None else overlapping[1:]


def _overlap_warning(stats: dict) -> list[str]:
    """A warning when an unwrap's atlas overlaps on more than ``OVERLAP_LIMIT`` of its
    covered texels (no charting tried did better)."""
    if stats["overlap"] <= OVERLAP_LIMIT:
        return []
    return [f"the atlas' charts overlap on {stats['overlap']:.1%} of the covered texels (no charting tried did better): "
            "those texels show one face's texture on all of them"]


def _fallback(request: UnwrapRequest, deadline: float, why: str, failures: list[str], start: float,
              charting: str) -> Atlas:
    """The grid atlas (:mod:`texbake.atlas.fallback`), its reason naming what failed before it;
    :class:`AtlasError` instead where a ``charting`` was asked for by name."""
    if charting != "auto":
        raise AtlasError(f"charting={charting!r} cannot be honoured: {'; '.join(failures) or _passed(deadline)}")
    vm, fa, u = grid_atlas(request.vertices, request.faces, request.padding / request.size)
    bad = unwrap_problem(vm, fa, u, request.faces, len(request.vertices))
    if bad is not None:
        raise AtlasError(f"no atlas could be made ({'; '.join(failures)}; grid atlas: {bad})")
    reason = f"{why}; {'; '.join(failures) or _passed(deadline)}; used fallback"
    warning = f"fallback atlas: one chart per triangle ({reason}); texel density varies and charts are tiny"
    stats = _stats(request, fa, u, start)
    return Atlas(vm, fa, u, "fallback-grid", reason, stats, [warning, *_deadline_warning(failures, deadline),
                                                               *bare_warning(stats, request.size)])
