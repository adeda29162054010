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
(:mod:`texbake.atlas.fallback`, "fallback-grid"). A charting asked for by name is the only
one tried. ``Atlas.reason`` says what was chosen, why, and what failed before it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import AtlasError, ParameterError
from ..workers import Pool
from .charts import prefer_planar
from .fallback import grid_atlas
from .pack import PATCH_FACES, Unwrapped, UnwrapRequest, XatlasFailed, start_workers, unwrap
from .uvcheck import OVERLAP_GRID, bare_warning, coverage, measure, overlap_of, unwrap_problem, uv_problem

MODES = ("auto", "unwrap", "keep")
CHARTINGS = ("auto", "xatlas", "planar")
OVERLAP_LIMIT = 0.01  # a mesh's UVs under which more of the covered texels overlap are not kept


@dataclass
class Atlas:
    """A UV layout for a mesh; the faces are the mesh's own, in the same order.

    ``vertices[vmapping][faces] == vertices[input_faces]`` exactly: atlas vertex ``i``
    is mesh vertex ``vmapping[i]`` (seams split mesh vertices into several).
    """

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: faces in atlas-vertex indices, same order as the mesh's
    uv: np.ndarray  # (k, 2) float64 in [0, 1], OpenGL convention (v up)
    method: str  # "kept" | "planar" | "xatlas" | "xatlas-patches" | "fallback-grid"
    reason: str  # why this method (and what failed before it)
    stats: dict = field(default_factory=dict)  # charts, utilisation, stretch, overlap, seconds
    warnings: list[str] = field(default_factory=list)  # what a user should know of this atlas
    cached: bool = False  # taken from a cache of an earlier bake (texbake.atlas.cache), not made now


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
        The mesh's per-vertex UVs, or None.
    mode : {"auto", "unwrap", "keep"}, optional
        "auto" keeps usable UVs (:func:`uv_problem`) that do not overlap (more than
        ``OVERLAP_LIMIT`` of the covered texel centres under two or more faces, on the
        bake's grid) and unwraps otherwise, saying why; "unwrap" always unwraps; "keep"
        requires usable UVs and keeps overlapping ones with a warning.
    size, padding : int, optional
        Texels of the square texture (1 to 65536) and between charts (0 to 64).
    deadline, workers : float, int, optional
        Seconds of CPU time each xatlas worker may use for the unwrap (a busy machine takes
        longer, not another atlas), and the workers (this process's, kept warm).
    charting : {"auto", "xatlas", "planar"}, optional
        "planar" (:mod:`texbake.atlas.charts`), "xatlas" (its own charts; meshes of more
        than ``2 * PATCH_FACES`` faces in patches, in parallel) or "auto"
        (:func:`texbake.atlas.charts.prefer_planar`). With "auto" the other is tried when
        the first fails, and a "fallback-grid" atlas (a cell per triangle) only when both
        have; a charting asked for is the only one tried (:class:`AtlasError` if it fails).
    _patch_faces : int or None
        Faces per patch of the xatlas unwrap; None: the whole mesh in one piece (tests).

    Returns
    -------
    Atlas
        ``reason``: why the UVs were not kept, the charting used and why, what failed.
        ``stats``: :func:`texbake.atlas.uvcheck.measure`'s, ``seconds``, ``patches``
        or ``planar_charts`` and ``flat_share``, ``packing`` (packing passes redone, why).
        ``warnings``: overlapping UVs kept, the fallback grid, a deadline that passed,
        over ``BARE_LIMIT`` of the surface on charts with no texel centre.

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
    why = "uv='unwrap'"
    if mode != "unwrap":
        kept, why = _keep(request, uv, mode, start)
        if kept is not None:
            return kept
    attempts, order = _attempts(request.vertices, request.faces, charting, _patch_faces)
    failures: list[str] = []
    with start_workers(workers, deadline) as pool:  # one set of workers for every attempt
        found = _first_usable(request, pool, attempts, failures)
    if found is None:
        return _fallback(request, deadline, why, failures, start, charting)
    charted, atlas = found
    retried = f" (after: {'; '.join(failures)})" if failures else ""
    stats = {**_stats(request, atlas.faces, atlas.uv, start), **atlas.detail}
    return Atlas(atlas.vmapping, atlas.faces, atlas.uv, atlas.method, f"{why}; {charted} charts: {order}{retried}", stats,
                 _deadline_warning(failures, deadline) + bare_warning(stats, size))


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
    if not np.isfinite(vertices[np.unique(faces)]).all():
        raise AtlasError("the mesh's vertices are not finite")
    return vertices, faces


def _stats(request: UnwrapRequest, faces: np.ndarray, uv: np.ndarray, start: float, raster=None) -> dict:
    """:func:`texbake.atlas.uvcheck.measure` of an atlas of ``request``'s mesh, and the
    ``seconds`` since ``start`` (``time.perf_counter()``)."""
    stats = measure(request.vertices, request.faces, faces, uv, request.size, raster)
    stats["seconds"] = time.perf_counter() - start
    return stats


def _keep(request: UnwrapRequest, uv, mode: str, start: float) -> tuple[Atlas | None, str]:
    """``(the atlas of the mesh's own UVs, why)`` when ``mode`` keeps them, else ``(None, why
    they are not kept)``; :class:`AtlasError` when ``mode`` is "keep" and they are not usable."""
    vertices, faces = request.vertices, request.faces
    problem = uv_problem(vertices, faces, uv)
    overlapping = raster = None
    if problem is None:  # inside the tile and not degenerate: do faces share texels?
        raster = coverage(np.asarray(uv, dtype=np.float64), faces, min(request.size, OVERLAP_GRID))
        share, most = overlap_of(raster[0])
        if share > OVERLAP_LIMIT:
            overlapping = (f"the mesh's UVs overlap: {share:.1%} of the covered texels lie under two or more "
                           f"faces (up to {most})")
    if problem is None and (overlapping is None or mode == "keep"):
        uv = np.asarray(uv, dtype=np.float64)
        vm = np.arange(len(vertices), dtype=np.int64)
        reason = "the mesh's UVs are usable" if overlapping is None else "uv='keep'"
        warnings = [] if overlapping is None else [f"{overlapping}: those texels show one face's texture on all of them"]
        stats = _stats(request, faces, uv, start, raster)
        return Atlas(vm, faces, uv, "kept", reason, stats, warnings + bare_warning(stats, request.size)), reason
    if mode == "keep":
        raise AtlasError(f"uv='keep' but {problem}")
    return None, problem or overlapping or ""


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
                  failures: list[str]) -> tuple[str, Unwrapped] | None:
    """``(charting, atlas)`` of the first of ``attempts`` that gives a usable atlas within
    ``pool``'s deadline, or None; what failed is added to ``failures``. xatlas is not
    tried again once it has timed out."""
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
        if bad is None:
            return charting, atlas
        failures.append(f"{charting} charting gave an unusable atlas: {bad}")
    return None


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
