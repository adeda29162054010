"""UV atlas: keep the mesh's own UVs when usable, or unwrap with xatlas.

xatlas hangs on some inputs (an infinite vertex, a mesh 1e20 units across), returns NaN
UVs on others and segfaults on some (``trimesh.creation.icosphere(6)`` in one piece). So
it only ever runs in worker processes (``bake._unwrap_worker``, fresh interpreters) under
one wall-clock deadline, on a copy of the mesh normalised to a unit box in float64 before
the cast to float32, and whatever comes back is checked.

The unwrap has two stages. Charting: the mesh is cut into spatially coherent patches of
about ``PATCH_FACES`` faces (one patch for small meshes) that the workers chart in
parallel. Packing: each patch's charts are brought to one texel density (scaled by
sqrt(3D area / UV area) of the patch), faces whose UV triangle collapsed get a small chart
of their own, and all charts are packed together in a single xatlas packing pass at the
texture's resolution and padding (one ``add_uv_mesh`` per patch). When that fails (crash, deadline, bad UVs) a one-piece
attempt is retried in patches, and as a last resort every triangle gets its own cell of a
grid ("fallback-grid"); ``Atlas.reason`` says what failed.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import numpy as np

from .errors import AtlasError, ParameterError
from .uvcoverage import overlap
from .uvgeometry import areas, uv_areas, uv_jacobian
from .workers import Pool

MODES = ("auto", "unwrap", "keep")
OVERLAP_LIMIT = 0.01  # a mesh's UVs under which more of the covered texels overlap are not kept
OVERLAP_GRID = 2048  # overlap is measured on the bake's texel grid, at most this fine
PATCH_FACES = 2000  # faces per patch of the parallel unwrap
CHART_ITERATIONS = 1  # xatlas ChartOptions.max_iterations: half the time of 4, same quality here
UV_EPS = 1e-6  # tolerance of the unit-square test of UVs


@dataclass
class Atlas:
    """A UV layout for a mesh; the faces are the mesh's own, in the same order.

    ``vertices[vmapping][faces] == vertices[input_faces]`` exactly: atlas vertex ``i``
    is mesh vertex ``vmapping[i]`` (seams split mesh vertices into several).
    """

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: faces in atlas-vertex indices, same order as the mesh's
    uv: np.ndarray  # (k, 2) float64 in [0, 1], OpenGL convention (v up)
    method: str  # "kept" | "xatlas" | "xatlas-patches" | "fallback-grid"
    reason: str  # why this method (and what failed before it)
    stats: dict = field(default_factory=dict)  # charts, utilisation, stretch, overlap, seconds
    warnings: list[str] = field(default_factory=list)  # what a user should know of this atlas


# -- checks and statistics ---------------------------------------------------------


def uv_problem(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray | None) -> str | None:
    """Why per-vertex UVs are not usable as an atlas of the mesh, or None if they are.

    Usable: given, one ``(u, v)`` row per vertex, finite, inside the unit square (within
    ``UV_EPS``: a repeating texture's UVs are not an atlas) and every face with a UV
    area above zero.
    """
    if uv is None:
        return "the mesh has no UVs"
    uv = np.asarray(uv, dtype=np.float64)
    n = len(vertices)
    if uv.ndim != 2 or uv.shape != (n, 2):
        return f"the mesh's UVs have shape {uv.shape}, expected ({n}, 2)"
    faces = np.asarray(faces)
    if len(faces) == 0:
        return "the mesh has no faces"
    used = uv[np.unique(faces)]
    if not np.isfinite(used).all():
        return "the mesh's UVs are not finite"
    lo, hi = used.min(), used.max()
    if lo < -UV_EPS or hi > 1 + UV_EPS:
        return f"the mesh's UVs leave the unit square (range {lo:.3g} to {hi:.3g})"
    zero = int((uv_areas(uv, faces) <= 0).sum())
    if zero:
        return f"{zero} faces have zero UV area"
    return None


def atlas_stats(vertices, faces, uv_faces, uv) -> dict:
    """Chart count, utilisation and stretch of an atlas (``uv_faces`` index ``uv``).

    ``charts``: connected pieces of the UV mesh (faces sharing atlas vertices).
    ``utilisation``: the UV area covered, as a fraction of the unit square.
    ``stretch``: Sander et al.'s L2 stretch of the map from UV to the surface,
    normalised so that 1.0 is an isometry up to one global scale. Per face,
    ``L2^2 = (|dP/du|^2 + |dP/dv|^2) / 2``; over the mesh,
    ``stretch = sqrt(sum(A3d * L2^2) / sum(A3d)) * sqrt(sum(Auv) / sum(A3d))``. It grows
    with anisotropic distortion and with uneven texel density between faces (faces with
    zero UV area are left out).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    k, m = len(uv), len(uv_faces)
    rows = np.repeat(np.arange(m), 3)
    graph = coo_matrix((np.ones(3 * m), (rows, uv_faces.ravel() + m)), shape=(m + k, m + k))
    _, labels = connected_components(graph, directed=False)
    charts = len(np.unique(labels[:m]))

    ps, pt, det = uv_jacobian(vertices, faces, uv, uv_faces)  # dP/du, dP/dv
    ok = np.abs(det) > 0  # faces of zero UV area are left out
    l2sq = 0.5 * (np.einsum("ij,ij->i", ps, ps) + np.einsum("ij,ij->i", pt, pt))
    a_uv = 0.5 * np.abs(det)
    a_3d = areas(vertices, faces)
    w3, wuv = a_3d[ok].sum(), a_uv[ok].sum()
    if w3 > 0 and wuv > 0:
        stretch = float(np.sqrt((a_3d[ok] * l2sq[ok]).sum() / w3 * wuv / w3))
    else:
        stretch = float("inf")
    return {"charts": int(charts), "utilisation": float(a_uv.sum()), "stretch": stretch}


def _problem(vmapping, faces, uv, n_faces: int, n_vertices: int, input_faces) -> str | None:
    """Why an unwrap result is unusable, or None."""
    if faces.shape != (n_faces, 3):
        return f"{len(faces)} faces came back for {n_faces}"
    if len(vmapping) != len(uv) or (len(vmapping) and (vmapping.min() < 0 or vmapping.max() >= n_vertices)):
        return "the vertex mapping is inconsistent"
    if len(faces) and (faces.min() < 0 or faces.max() >= len(uv)):
        return "the faces index missing UV vertices"
    if not np.array_equal(vmapping[faces], input_faces):
        return "the faces do not match the mesh's faces"
    if not np.isfinite(uv).all():
        return "the UVs are not finite"
    if uv.min() < -UV_EPS or uv.max() > 1 + UV_EPS:
        return f"the UVs leave the unit square ({uv.min():.3g} to {uv.max():.3g})"
    zero = int((uv_areas(uv, faces) <= 0).sum())
    if zero:
        return f"{zero} faces have zero UV area"
    return None


# -- xatlas workers ----------------------------------------------------------------


class _XatlasFailed(Exception):
    pass


# The command that starts an xatlas worker (``bake.workers`` protocol; tests put in one
# that crashes or hangs).
WORKER = [sys.executable, "-m", "bake._unwrap_worker"]


def _describe(why: str, deadline: float) -> str:
    if why == "timeout":
        return f"xatlas timed out after {deadline:g} s"
    if why.startswith("exit code"):
        return f"xatlas crashed ({why})"
    return f"xatlas failed ({why})"


def _run_xatlas_in_child(positions: np.ndarray, faces: np.ndarray, deadline: float, *, size: int = 1024,
                         padding: int = 2) -> tuple[bool, object]:
    """Chart and pack ``(n, 3)`` float32 positions, as given, in one worker; a test hook.

    Returns ``(True, (vmapping, faces, uv))`` or ``(False, why)`` once the worker is
    done, dead, or past ``deadline`` seconds (then it is killed).
    """
    start = time.monotonic()
    with Pool(WORKER, 1, start + deadline) as workers:
        ((ok, value),) = workers.run([("chart", (np.asarray(positions, np.float32), np.asarray(faces, np.uint32),
                                                 CHART_ITERATIONS))])
        if not ok:
            return False, _describe(value, deadline)
        vmap, idx, uv = value
        ((ok, value),) = workers.run([("pack", ([(uv.astype(np.float32), idx)], size, padding))])
        if not ok:
            return False, _describe(value, deadline)
        ((v2, idx2, uv2),), _ = value
        return True, (vmap[v2].astype(np.int64), idx2.astype(np.int64), uv2)


# -- the unwrap ----------------------------------------------------------------------


def _normalised(vertices: np.ndarray) -> np.ndarray:
    """``(n, 3)`` float64 copy of the vertices centred in a box of largest side 1."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    scale = float(np.max(hi - lo))
    if not scale > 0 or not np.isfinite(scale):
        scale = 1.0
    return (vertices - 0.5 * (lo + hi)) / scale


def _patches(vertices: np.ndarray, faces: np.ndarray, target: int) -> list[np.ndarray]:
    """Face index arrays of spatially coherent patches of at most ``target`` faces.

    Recursive bisection of the face centroids at the median of the longest axis.
    """
    centroids = vertices[faces].mean(axis=1)
    stack, out = [np.arange(len(faces))], []
    while stack:
        idx = stack.pop()
        if len(idx) <= target:
            if len(idx):
                out.append(idx)
            continue
        c = centroids[idx]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        order = idx[np.argsort(c[:, axis], kind="stable")]
        half = len(order) // 2
        stack += [order[half:], order[:half]]
    return out


def _flat_triangles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m, 3, 2)`` each triangle laid flat in 2D by its edge lengths (same size).

    A degenerate triangle becomes a unit right triangle (so it still has a UV area).
    """
    m = len(faces)
    t = vertices[faces]
    ab = np.linalg.norm(t[:, 1] - t[:, 0], axis=1)
    e2 = t[:, 2] - t[:, 0]
    cx = np.einsum("ij,ij->i", e2, t[:, 1] - t[:, 0]) / np.where(ab > 0, ab, 1)
    cy = np.sqrt(np.maximum(np.einsum("ij,ij->i", e2, e2) - cx**2, 0))
    flat = np.zeros((m, 3, 2))
    flat[:, 1, 0] = ab
    flat[:, 2, 0] = cx
    flat[:, 2, 1] = cy
    flat -= flat.min(axis=1, keepdims=True)
    area = 0.5 * np.abs(flat[:, 1, 0] * flat[:, 2, 1] - flat[:, 1, 1] * flat[:, 2, 0])
    extent = flat.max(axis=(1, 2))
    bad = ~(area > 1e-12 * np.maximum(extent, 1e-300) ** 2) | ~np.isfinite(flat).all(axis=(1, 2))
    flat[bad] = [[0, 0], [1, 0], [0, 1]]
    return flat


def _unwrap(vertices, faces, size, padding, end, deadline, workers, patch_faces):
    """xatlas atlas ``(vmapping, faces, uv, method, charting_patches)``; raises ``_XatlasFailed``."""
    pos = _normalised(vertices)
    pos32 = pos.astype(np.float32)
    m = len(faces)
    # Faces that are degenerate in float32 are kept away from xatlas (they give NaNs)
    # and get a small chart of their own below.
    area32 = areas(pos32, faces)  # in float64, of the float32 positions
    good = np.flatnonzero(area32 > 0)
    if patch_faces is None or len(good) <= 2 * patch_faces:
        patches = [good] if len(good) else []
    else:
        patches = [good[p] for p in _patches(pos, faces[good], patch_faces)]
    jobs, used_of = [], []
    for p in patches:
        used, local = np.unique(faces[p], return_inverse=True)
        used_of.append(used)
        jobs.append(("chart", (pos32[used], local.reshape(-1, 3).astype(np.uint32), CHART_ITERATIONS)))

    with Pool(WORKER, min(workers, max(1, len(jobs))), end) as pool:
        done = pool.run(jobs)
        for (ok, value), p in zip(done, patches, strict=True):
            if not ok:
                what = _describe(value, deadline)
                raise _XatlasFailed(what if len(patches) == 1 else f"{what} on a patch of {len(p)} faces")

        # Each patch's charts at one texel density (world units of ``pos``), one UV mesh
        # per patch: xatlas' add_uv_mesh merges touching or overlapping charts of one
        # mesh, so charts of different patches must not share a mesh.
        meshes = []  # (face ids, atlas vertex -> mesh vertex, uv, local faces)
        lost = [np.setdiff1d(np.arange(m), good)]
        for (_, (vmap, idx, uv)), p, used in zip(done, patches, used_of, strict=True):
            idx = idx.astype(np.int64)
            if idx.shape != (len(p), 3) or not np.isfinite(uv).all():
                raise _XatlasFailed("xatlas returned bad UVs for a patch")
            a_uv = uv_areas(uv, idx)
            if not a_uv.sum() > 0:
                raise _XatlasFailed("xatlas returned UVs of zero area for a patch")
            keep = a_uv > 0
            lost.append(p[~keep])
            if keep.any():
                scale = np.sqrt(areas(pos, faces[p]).sum() / a_uv.sum())
                meshes.append((p[keep], used[vmap.astype(np.int64)], uv * scale, idx[keep]))
        # Faces left out or collapsed to zero UV area: a chart each, about 2 texels wide.
        lost = np.concatenate(lost)
        if len(lost):
            total = max(areas(pos, faces).sum(), 1e-30)
            texel = np.sqrt(total / 0.7) / size  # world units per texel, roughly
            flat = _flat_triangles(pos, faces[lost])
            flat *= (2 * texel / flat.max(axis=(1, 2)))[:, None, None]
            flat[:, :, 0] += (np.arange(len(lost)) * 4 * texel)[:, None]
            meshes.append((lost, faces[lost].reshape(-1), flat.reshape(-1, 2), np.arange(3 * len(lost)).reshape(-1, 3)))

        pack_in = [(uv.astype(np.float32), idx.astype(np.uint32)) for _, _, uv, idx in meshes]
        ((ok, value),) = pool.run([("pack", (pack_in, size, padding))])
        if not ok:
            raise _XatlasFailed(f"{_describe(value, deadline)} while packing")
    packed, _info = value
    if len(packed) != len(meshes):
        raise _XatlasFailed("xatlas' packing lost meshes")
    maps, uvs, out_faces, offset = [], [], np.full((m, 3), -1, dtype=np.int64), 0
    for (face_ids, vmap, _, _), (vm2, idx2, uv2) in zip(meshes, packed, strict=True):
        if idx2.shape != (len(face_ids), 3):
            raise _XatlasFailed("xatlas' packing changed the faces")
        maps.append(vmap[vm2.astype(np.int64)])
        uvs.append(uv2)
        out_faces[face_ids] = idx2.astype(np.int64) + offset
        offset += len(uv2)
    vmapping = np.concatenate(maps)
    idx, uv = out_faces, np.concatenate(uvs)
    method = "xatlas-patches" if len(patches) > 1 else "xatlas"
    return vmapping, idx.astype(np.int64), uv.astype(np.float64), method, len(patches)


def _grid_atlas(vertices: np.ndarray, faces: np.ndarray, padding: float):
    """One chart per triangle, each in its own cell of a square grid: always works.

    Each triangle keeps its shape (laid flat by its edge lengths), scaled to fill its
    cell less ``padding`` (UV units, at most a quarter cell) on every side.
    """
    m = len(faces)
    g = int(np.ceil(np.sqrt(m)))
    flat = _flat_triangles(_normalised(vertices), faces)
    flat /= flat.max(axis=(1, 2))[:, None, None]
    cell = 1.0 / g
    pad = min(padding, cell / 4)
    inner = cell - 2 * pad
    origin = np.stack([np.arange(m) % g, np.arange(m) // g], axis=1) * cell + pad
    uv = (origin[:, None, :] + flat * inner).reshape(-1, 2)
    return faces.reshape(-1).astype(np.int64), np.arange(3 * m, dtype=np.int64).reshape(m, 3), uv


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
    _patch_faces: int | None = PATCH_FACES,
) -> Atlas:
    """A UV atlas for ``(n, 3)`` float64 vertices and ``(m, 3)`` int faces.

    ``uv``: ``(n, 2)`` per-vertex UVs or None. ``mode``: "auto" keeps usable UVs (see
    :func:`uv_problem`) that do not overlap (more than ``OVERLAP_LIMIT`` of the covered
    texel centres under two or more faces, measured on the bake's grid) and unwraps
    otherwise, saying why; "unwrap" always unwraps; "keep" requires usable UVs
    (:class:`AtlasError` otherwise) and keeps overlapping ones with a warning. ``size`` (texels of the square texture)
    and ``padding`` (texels between charts) set xatlas' packing; ``deadline`` bounds the
    wall time of all xatlas work, in ``workers`` processes. Meshes of more than
    ``2 * PATCH_FACES`` faces are charted in patches in parallel (``_patch_faces=None``:
    in one piece, for tests). If xatlas fails the result is a "fallback-grid" atlas and
    ``reason`` says what failed. ``stats``: see :func:`atlas_stats`, plus ``overlap`` (the
    share of covered texels under two or more faces) and ``seconds``. ``warnings``: what a
    user should know (overlapping UVs kept, the fallback grid).

    Long because it is the atlas stage's decision list (keep, unwrap whole, unwrap in
    patches, fall back), each step depending on why the one before failed.
    """
    start = time.perf_counter()
    if mode not in MODES:
        raise ParameterError("uv", f"expected one of {', '.join(MODES)}, got {mode!r}")
    for name, value, ok in (
        ("size", size, isinstance(size, (int, np.integer)) and 1 <= size <= 65536),
        ("padding", padding, isinstance(padding, (int, np.integer)) and 0 <= padding <= 64),
        ("deadline", deadline, isinstance(deadline, (int, float)) and deadline > 0),
        ("workers", workers, isinstance(workers, (int, np.integer)) and workers >= 1),
    ):
        if not ok:
            raise ParameterError(name, f"out of range or of the wrong type: {value!r}")
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

    def stats_of(vm, fa, u):
        s = atlas_stats(vertices, faces, fa, u)
        s["overlap"], _ = overlap(u, fa, min(size, OVERLAP_GRID))
        s["seconds"] = time.perf_counter() - start
        return s

    if mode != "unwrap":
        problem = uv_problem(vertices, faces, uv)
        overlapping = None
        if problem is None:  # inside the tile and not degenerate: do faces share texels?
            share, most = overlap(np.asarray(uv, dtype=np.float64), faces, min(size, OVERLAP_GRID))
            if share > OVERLAP_LIMIT:
                overlapping = (f"the mesh's UVs overlap: {share:.1%} of the covered texels lie under two or more "
                               f"faces (up to {most})")
        if problem is None and (overlapping is None or mode == "keep"):
            uv = np.asarray(uv, dtype=np.float64)
            vm = np.arange(len(vertices), dtype=np.int64)
            reason = "the mesh's UVs are usable" if overlapping is None else "uv='keep'"
            warnings = [] if overlapping is None else [f"{overlapping}: those texels show one face's texture on all of them"]
            return Atlas(vm, faces, uv, "kept", reason, stats_of(vm, faces, uv), warnings)
        if mode == "keep":
            raise AtlasError(f"uv='keep' but {problem}")
        why = problem or overlapping
    else:
        why = "uv='unwrap'"

    end = time.monotonic() + deadline
    failures = []
    attempts = [_patch_faces]
    if _patch_faces is None and len(faces) > 2 * PATCH_FACES:
        attempts.append(PATCH_FACES)  # e.g. icosphere(6) crashes xatlas in one piece
    elif _patch_faces is not None and len(faces) > 2 * _patch_faces:
        attempts.append(max(250, _patch_faces // 4))  # smaller patches may get through
    for patch_faces in attempts:
        if time.monotonic() >= end:
            break
        try:
            vm, fa, u, method, _ = _unwrap(vertices, faces, size, padding, end, deadline, workers, patch_faces)
        except _XatlasFailed as exc:
            failures.append(str(exc))
            if "timed out" in str(exc):
                break
            continue
        bad = _problem(vm, fa, u, len(faces), len(vertices), faces)
        if bad is None:
            retried = f" (after: {'; '.join(failures)})" if failures else ""
            return Atlas(vm, fa, u, method, f"{why}{retried}", stats_of(vm, fa, u))
        failures.append(f"xatlas returned an unusable atlas: {bad}")

    vm, fa, u = _grid_atlas(vertices, faces, padding / size)
    bad = _problem(vm, fa, u, len(faces), len(vertices), faces)
    if bad is not None:
        raise AtlasError(f"no atlas could be made ({'; '.join(failures)}; grid atlas: {bad})")
    reason = f"{why}; {'; '.join(failures) or 'xatlas was not run'}; used fallback"
    warning = f"fallback atlas: one chart per triangle ({reason}); texel density varies and charts are tiny"
    return Atlas(vm, fa, u, "fallback-grid", reason, stats_of(vm, fa, u), [warning])
