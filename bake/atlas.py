"""UV atlas: keep the mesh's own UVs when usable, or unwrap with xatlas.

xatlas can hang, return NaN UVs or crash on bad input, so it only ever runs in child
processes with a wall-clock deadline, on a copy of the mesh normalised to a unit box in
float64, and what comes back is checked. Large meshes are cut into spatially coherent
patches that are unwrapped in parallel; their charts, brought to one texel density, are
then packed together in a single xatlas packing pass. When xatlas fails, a simple atlas
with one chart per triangle is used instead and the report says why.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .errors import AtlasError, ParameterError

MODES = ("auto", "unwrap", "keep")
PATCH_FACES = 2000  # faces per patch of the parallel unwrap


@dataclass
class Atlas:
    """A UV layout for a mesh; the faces are the mesh's own, in the same order."""

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: faces in atlas-vertex indices
    uv: np.ndarray  # (k, 2) float64 in [0, 1], v up
    method: str  # "kept" | "xatlas" | "xatlas-patches" | "fallback-grid"
    reason: str
    stats: dict = field(default_factory=dict)  # charts, utilisation, stretch, seconds


# -- checks and statistics ---------------------------------------------------------


def _uv_area(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    t = uv[faces]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def _area(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    t = vertices[faces]
    return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)


def uv_problem(uv: np.ndarray | None, faces: np.ndarray) -> str | None:
    """Why per-vertex ``(n, 2)`` UVs are not usable for ``(m, 3)`` faces, or None if they are.

    Usable: present, finite, inside the unit square (within 1e-6), and no face with zero
    UV area.
    """
    if uv is None:
        return "the mesh has no UVs"
    uv = np.asarray(uv, dtype=np.float64)
    used = uv[np.unique(faces)]
    if not np.isfinite(used).all():
        return "the mesh's UVs are not finite"
    if used.min() < -1e-6 or used.max() > 1 + 1e-6:
        return f"the mesh's UVs leave the unit square (range {used.min():.3g} to {used.max():.3g})"
    zero = int((_uv_area(uv, faces) <= 0).sum())
    if zero:
        return f"{zero} faces have zero UV area"
    return None


def atlas_stats(vertices, faces, uv_faces, uv) -> dict:
    """Chart count, utilisation, stretch and zero-area faces of an atlas.

    ``utilisation`` is the UV area covered (of the unit square). ``stretch`` is Sander
    et al.'s L2 stretch normalised by the overall scale: 1.0 for a map that is an
    isometry up to scale, larger with more distortion.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    k = len(uv)
    m = len(uv_faces)
    rows = np.repeat(np.arange(m), 3)
    graph = coo_matrix((np.ones(3 * m), (rows, uv_faces.ravel() + m)), shape=(m + k, m + k))
    _, labels = connected_components(graph, directed=False)
    charts = len(np.unique(labels[:m]))

    t = uv[uv_faces]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    p = vertices[faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    ok = det != 0
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    ps = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv  # dP/du
    pt = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv  # dP/dv
    l2sq = 0.5 * (np.einsum("ij,ij->i", ps, ps) + np.einsum("ij,ij->i", pt, pt))
    a_uv = 0.5 * np.abs(det)
    a_3d = _area(vertices, faces)
    if a_uv.sum() > 0 and a_3d.sum() > 0:
        stretch = float(np.sqrt((a_uv * l2sq).sum() / a_uv.sum() * a_uv.sum() / a_3d.sum()))
    else:
        stretch = float("inf")
    return {
        "charts": int(charts),
        "utilisation": float(a_uv.sum()),
        "stretch": stretch,
        "zero_area_faces": int((~ok).sum()),
    }


def _valid(result, n_faces: int, n_vertices: int) -> str | None:
    """Why an xatlas result ``(vmapping, faces, uv)`` is unusable, or None."""
    vmapping, faces, uv = result
    if faces.shape != (n_faces, 3):
        return f"xatlas returned {len(faces)} faces for {n_faces}"
    if len(vmapping) != len(uv) or (len(vmapping) and (vmapping.max() >= n_vertices)):
        return "xatlas returned an inconsistent vertex mapping"
    if not np.isfinite(uv).all() or uv.min() < -1e-6 or uv.max() > 1 + 1e-6:
        return "xatlas returned UVs that are not finite or leave the unit square"
    # Tiny faces can round to zero UV area in float32: tolerate a few (they get no texel).
    zero = int((_uv_area(uv, faces) <= 0).sum())
    if zero > max(1, n_faces // 1000):
        return f"xatlas returned {zero} faces with zero UV area"
    return None


# -- xatlas in child processes -----------------------------------------------------


def _pack_options(size: int, padding: int, texels_per_unit: float = 0.0):
    import xatlas

    po = xatlas.PackOptions()
    po.resolution = size
    po.texels_per_unit = texels_per_unit
    po.padding = padding
    po.bilinear = True
    return po


def _chart_patches(positions, patches, size, padding, texels_per_unit=0.0):
    """Unwrap each patch (list of (m, 3) uint32 face arrays) with xatlas; child side.

    Returns per patch ``(vmapping, indices, uv)`` with ``uv`` in texels of a square
    atlas of ``size`` texels, or, when ``texels_per_unit`` is given, in texels at that
    density (the atlas as large as it needs to be: its charts are packed again later).
    """
    import xatlas

    out = []
    for faces in patches:
        used, local = np.unique(faces, return_inverse=True)
        atlas = xatlas.Atlas()
        atlas.add_mesh(positions[used], local.reshape(-1, 3).astype(np.uint32))
        if texels_per_unit:
            atlas.generate(pack_options=_pack_options(0, padding, texels_per_unit))
        else:
            atlas.generate(pack_options=_pack_options(size, padding))
            if atlas.atlas_count > 1:  # did not fit one page: let it grow, scale it down
                atlas.generate(pack_options=_pack_options(0, padding))
        if atlas.atlas_count != 1:
            raise RuntimeError(f"xatlas made {atlas.atlas_count} atlases, expected 1")
        vmapping, indices, uv = atlas[0]
        texels = uv.astype(np.float64) * [atlas.width, atlas.height]
        out.append((used[vmapping], indices, texels, (atlas.width, atlas.height)))
    return out


def _shelf_pack(sizes: np.ndarray) -> tuple[np.ndarray, float]:
    """Place ``(n, 2)`` rectangles (width, height) without overlap in a near-square.

    Shelves of decreasing height, several shelf widths tried (on these charts a
    skyline packer did no better). Returns ``(n, 2)`` lower left corners and the side
    of the square that holds them all.
    """
    order = np.argsort(-sizes[:, 1], kind="stable")
    best = None
    total = float((sizes[:, 0] * sizes[:, 1]).sum())
    for fill in (1.0, 0.95, 0.9, 0.85, 0.8, 0.75):
        width = max(np.sqrt(total / fill), sizes[:, 0].max())
        corners = np.zeros_like(sizes)
        x = y = shelf = 0.0
        for i in order:
            w, h = sizes[i]
            if x + w > width:
                x, y, shelf = 0.0, y + shelf, 0.0
            corners[i] = (x, y)
            x += w
            shelf = max(shelf, h)
        side = max((corners + sizes).max(axis=0))
        if best is None or side < best[1]:
            best = (corners, side)
    return best


def _run_children(function, jobs: list[tuple], deadline: float) -> list:
    """Run ``function(*args)`` for each args tuple in its own process, all at once.

    Returns the results in order. Raises ``_XatlasFailed`` when one raises, dies (a
    segfault) or is still running at the deadline (then all are killed).
    """
    import os
    import pickle
    import subprocess
    import sys
    import tempfile

    running = []
    with tempfile.TemporaryDirectory(prefix="texbake-xatlas-") as tmp:
        try:
            for i, args in enumerate(jobs):
                job = os.path.join(tmp, f"job{i}.pickle")
                with open(job, "wb") as f:
                    pickle.dump((__name__, function.__name__, args), f, protocol=pickle.HIGHEST_PROTOCOL)
                running.append(
                    subprocess.Popen(
                        [sys.executable, "-m", "bake._child", job],
                        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL,
                    )
                )
            end = time.monotonic() + deadline
            results = []
            for p in running:
                try:
                    out, _ = p.communicate(timeout=max(0.0, end - time.monotonic()))
                except subprocess.TimeoutExpired:
                    raise _XatlasFailed(f"xatlas took longer than the deadline of {deadline:g} s") from None
                if p.returncode != 0 or not out:
                    raise _XatlasFailed(f"xatlas crashed (exit code {p.returncode})")
                status, value = pickle.loads(out)
                if status != "ok":
                    raise _XatlasFailed(f"xatlas failed: {value}")
                results.append(value)
            return results
        finally:
            for p in running:
                if p.poll() is None:
                    p.kill()
                p.wait()
                if p.stdout:
                    p.stdout.close()


class _XatlasFailed(Exception):
    pass


def _normalised(vertices: np.ndarray) -> np.ndarray:
    """``(n, 3)`` float32 copy of the vertices in a unit box (computed in float64)."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    scale = float(np.max(hi - lo)) or 1.0
    return ((vertices - 0.5 * (lo + hi)) / scale).astype(np.float32)


def _patches(vertices: np.ndarray, faces: np.ndarray, target: int) -> list[np.ndarray]:
    """Face index arrays of spatially coherent patches of about ``target`` faces.

    Recursive bisection of face centroids at the median of the longest axis.
    """
    centroids = vertices[faces].mean(axis=1)
    stack, out = [np.arange(len(faces))], []
    while stack:
        idx = stack.pop()
        if len(idx) <= target:
            out.append(idx)
            continue
        c = centroids[idx]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        order = idx[np.argsort(c[:, axis], kind="stable")]
        half = len(order) // 2
        stack += [order[:half], order[half:]]
    return out


def _unwrap(vertices, faces, size, padding, deadline, workers, patch_faces):
    """xatlas atlas ``(vmapping, faces, uv, method)``; raises ``_XatlasFailed``."""
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    positions = _normalised(vertices)
    f32 = faces.astype(np.uint32)
    if patch_faces is None or len(faces) <= 2 * patch_faces:
        (result,) = _run_children(_chart_patches, [(positions, [f32], size, padding)], deadline)
        vmap, idx, texels, (w, h) = result[0]
        return vmap, idx, texels / max(w, h), "xatlas"

    # Patches are unwrapped in parallel at the texel density of the final atlas (about
    # 70 % of a size x size texture); then all their charts are packed together.
    density = size * np.sqrt(0.7 / _area(vertices, faces).sum())  # texels per unit
    density *= float(np.max(hi - lo)) or 1.0  # in the normalised positions' units
    patches = _patches(vertices, faces, patch_faces)
    shares = [patches[w::workers] for w in range(workers)]
    jobs = [(positions, [f32[p] for p in share], size, padding, density) for share in shares if share]
    done = [r for rs in _run_children(_chart_patches, jobs, deadline) for r in rs]
    order = [p for share in shares for p in share]
    texels, maps, all_faces, offset = [], [], np.empty((len(faces), 3), dtype=np.int64), 0
    for face_ids, (vmap, idx, uv, _) in zip(order, done):
        texels.append(uv)
        maps.append(vmap.astype(np.int64))
        all_faces[face_ids] = idx.astype(np.int64) + offset
        offset += len(uv)
    uv = _pack_charts(np.concatenate(texels), all_faces, padding)
    return np.concatenate(maps), all_faces, uv, "xatlas-patches"


def _chart_labels(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """``(n_vertices,)`` chart number of each atlas vertex (faces sharing vertices)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = len(faces)
    graph = coo_matrix((np.ones(3 * m), (np.repeat(np.arange(m), 3), faces.ravel() + m)), shape=(m + n_vertices,) * 2)
    return connected_components(graph, directed=False)[1][m:]


def _pack_charts(texels: np.ndarray, faces: np.ndarray, padding: int) -> np.ndarray:
    """Pack the charts of ``(k, 2)`` texel-space UVs into the unit square, ``padding``
    texels apart, keeping their scale; returns ``(k, 2)`` UVs."""
    label = _chart_labels(faces, len(texels))
    _, label = np.unique(label, return_inverse=True)
    n = label.max() + 1

    def boxes(t):
        lo, hi = np.full((n, 2), np.inf), np.full((n, 2), -np.inf)
        np.minimum.at(lo, label, t)
        np.maximum.at(hi, label, t)
        return lo, hi

    # Lay every chart on its long side (a quarter turn for tall ones): even shelves.
    lo, hi = boxes(texels)
    tall = (hi - lo)[:, 1] > (hi - lo)[:, 0]
    turn = tall[label]
    texels = np.where(turn[:, None], np.column_stack([texels[:, 1], -texels[:, 0]]), texels)
    lo, hi = boxes(texels)
    corners, side = _shelf_pack(hi - lo + padding)
    return (texels - lo[label] + corners[label] + 0.5 * padding) / side


def _grid_atlas(vertices: np.ndarray, faces: np.ndarray, padding: float):
    """One chart per triangle, each in its own cell of a square grid: always works.

    ``padding`` is the gap around each triangle in UV units (at most a quarter cell).

    Each triangle keeps its shape (laid flat by its edge lengths), scaled to its cell.
    """
    m = len(faces)
    g = int(np.ceil(np.sqrt(m)))
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
    extent = flat.max(axis=(1, 2))
    flat /= np.where(extent > 0, extent, 1)[:, None, None]
    degenerate = _uv_area(flat.reshape(-1, 2), np.arange(3 * m).reshape(m, 3)) <= 0
    flat[degenerate] = [[0, 0], [1, 0], [0, 1]]  # keep every face addressable
    cell = 1.0 / g
    pad = min(padding, cell / 4)  # in UV units
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
    patch_faces: int | None = PATCH_FACES,
) -> Atlas:
    """A UV atlas for ``(n, 3)`` float64 vertices and ``(m, 3)`` int faces.

    ``uv``: ``(n, 2)`` per-vertex UVs or None. ``mode``: "auto" keeps usable UVs and
    unwraps otherwise, "unwrap" always unwraps, "keep" requires usable UVs. ``size``
    and ``padding`` (texels) set xatlas' packing; ``deadline`` bounds its wall time;
    meshes of more than ``2 * patch_faces`` faces are unwrapped in patches of about
    ``patch_faces`` faces by ``workers`` processes (``patch_faces=None``: in one piece).
    """
    if mode not in MODES:
        raise ParameterError("uv", f"expected one of {', '.join(MODES)}, got {mode!r}")
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    start = time.perf_counter()
    if mode != "unwrap":
        problem = uv_problem(uv, faces)
        if problem is None:
            uv = np.asarray(uv, dtype=np.float64)
            stats = atlas_stats(vertices, faces, faces, uv)
            stats["seconds"] = time.perf_counter() - start
            return Atlas(np.arange(len(uv)), faces, uv, "kept", "the mesh's UVs are usable", stats)
        if mode == "keep":
            raise AtlasError(f"uv='keep' but {problem}")
        why = problem
    else:
        why = "uv='unwrap'"

    try:
        vmapping, afaces, auv, method = _unwrap(vertices, faces, size, padding, deadline, max(1, workers), patch_faces)
        result = (vmapping.astype(np.int64), afaces.astype(np.int64), auv.astype(np.float64))
        bad = _valid(result, len(faces), len(vertices))
        if bad:
            raise _XatlasFailed(bad)
        reason = f"unwrapped: {why}"
    except _XatlasFailed as exc:
        vmapping, afaces, auv = _grid_atlas(vertices, faces, padding / max(size, 1))
        result = (vmapping, afaces, auv)
        method, reason = "fallback-grid", f"unwrapped ({why}) with one chart per triangle: {exc}"
    stats = atlas_stats(vertices, faces, result[1], result[2])
    stats["seconds"] = time.perf_counter() - start
    return Atlas(*result, method, reason, stats)
