"""UV atlas: keep the mesh's own UVs when usable, or unwrap: charts, then xatlas' packer.

xatlas hangs on some inputs (an infinite vertex, a mesh 1e20 units across), returns NaN
UVs on others and segfaults on some (``trimesh.creation.icosphere(6)`` in one piece). So
it only ever runs in worker processes (``texbake.atlas.packworker``, fresh interpreters) under
one wall-clock deadline, on a copy of the mesh normalised to a unit box in float64 before
the cast to float32, and whatever comes back is checked.

The unwrap has two stages. Charting, one of two ways: planar charts (:mod:`texbake.atlas.charts`:
faces grouped by normal direction, each island projected onto its plane; CAD parts and
large meshes), or xatlas' own charts (small organic meshes: the mesh cut into spatially
coherent patches of about ``PATCH_FACES`` faces that the workers chart in parallel, each
patch brought to one texel density). Packing: faces whose chart collapsed or that were
left out get a small chart of their own, and all charts are packed together in a single
xatlas packing pass at the texture's resolution and padding (one ``add_uv_mesh`` per
mesh of charts). When one charting fails (crash, deadline, bad UVs) the other is tried;
only when both have does every triangle get its own cell of a grid ("fallback-grid");
``Atlas.reason`` says what failed.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import AtlasError, ParameterError
from ..mesh.components import connected_components
from ..mesh.uvgeometry import areas, uv_areas, uv_jacobian
from ..workers import Pool
from .charts import planar_charts, prefer_planar
from .uvcheck import coverage, covering_faces, overlap_of

MODES = ("auto", "unwrap", "keep")
CHARTINGS = ("auto", "xatlas", "planar")
OVERLAP_LIMIT = 0.01  # a mesh's UVs under which more of the covered texels overlap are not kept
OVERLAP_GRID = 2048  # overlap is measured on the bake's texel grid, at most this fine
PLANAR_GAIN = 1.3  # "auto" takes planar charts over xatlas' on a small organic mesh when they use this much more texture
SWAP_FACES = 20_000  # meshes packed once more with u and v swapped (xatlas' greedy packer then often fills more), up to this many triangles
PROXY_FACES = 32  # charts of more faces are packed by the triangulation of their outline
BARE_LIMIT = 0.01  # a warning when more of the surface lies on charts without a texel centre
PATCH_FACES = 2000  # faces per patch of the parallel unwrap
CHART_ITERATIONS = 1  # xatlas ChartOptions.max_iterations: half the time of 4, same quality here
UV_EPS = 1e-6  # tolerance of the unit-square test of UVs


@dataclass
class Atlas:
    """A UV layout for a mesh; the faces are the mesh's own, in the same order.

    ``vertices[vmapping][faces] == vertices[input_faces]`` exactly: atlas vertex ``i``
    is mesh vertex ``vmapping[i]`` (seams split mesh vertices into several).

    Attributes
    ----------
    vmapping : (k,) ndarray of int64
        The mesh vertex of each atlas vertex.
    faces : (m, 3) ndarray of int64
        The mesh's faces in atlas-vertex indices.
    uv : (k, 2) ndarray of float64
        In the unit square, OpenGL convention (v up); every face has a UV area above 0.
    method : {"kept", "planar", "xatlas", "xatlas-patches", "fallback-grid"}
    reason : str
        Why this method, and what failed before it.
    stats : dict
        ``charts``, ``utilisation``, ``stretch``, ``overlap``, ``bare_area``, ``seconds``
        (see :func:`make_atlas`).
    warnings : list of str
        What a user should know of this atlas.
    cached : bool
        Taken from the cache of an earlier bake (:mod:`texbake.atlas.cache`), not made now.
    """

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: faces in atlas-vertex indices, same order as the mesh's
    uv: np.ndarray  # (k, 2) float64 in [0, 1], OpenGL convention (v up)
    method: str  # "kept" | "planar" | "xatlas" | "xatlas-patches" | "fallback-grid"
    reason: str  # why this method (and what failed before it)
    stats: dict = field(default_factory=dict)  # charts, utilisation, stretch, overlap, seconds
    warnings: list[str] = field(default_factory=list)  # what a user should know of this atlas
    cached: bool = False  # taken from a cache of an earlier bake (texbake.atlas.cache), not made now


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


def chart_labels(uv_faces: np.ndarray, k: int) -> np.ndarray:
    """``(m,)`` int64 the chart of each face: connected pieces of the UV mesh (faces sharing
    one of the ``k`` UV vertices), numbered in the order of their first face."""
    m = len(uv_faces)
    rows = np.repeat(np.arange(m), 3)
    return connected_components(m + k, rows, np.asarray(uv_faces).ravel() + m)[:m]


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
    charts = len(np.unique(chart_labels(uv_faces, len(uv))))

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


# The command that starts an xatlas worker (``texbake.workers`` protocol; tests put in one
# that crashes or hangs).
WORKER = [sys.executable, "-m", "texbake.atlas.packworker"]


def _describe(why: str, deadline: float) -> str:
    if why == "timeout":
        return f"xatlas timed out after {deadline:.3g} s"
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


def _good_faces(pos: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Indices of the faces that keep an area in float32 (xatlas' precision); the rest
    would give NaNs or collapse, and get a small chart of their own (:func:`_pack`)."""
    return np.flatnonzero(areas(pos.astype(np.float32), faces) > 0)


def _chart_xatlas(pos, faces, good, pool, deadline, patch_faces):
    """xatlas' charts of the ``good`` faces: ``(meshes, patch count)``, meshes as
    :func:`_pack` takes them (faces whose chart collapsed are left out); raises
    ``_XatlasFailed``.

    Meshes of more than ``2 * patch_faces`` faces are charted in spatial patches, in
    parallel; each patch's charts are brought to one texel density (world units of
    ``pos``).
    """
    pos32 = pos.astype(np.float32)
    if patch_faces is None or len(good) <= 2 * patch_faces:
        patches = [good] if len(good) else []
    else:
        patches = [good[p] for p in _patches(pos, faces[good], patch_faces)]
    jobs, used_of = [], []
    for p in patches:
        used, local = np.unique(faces[p], return_inverse=True)
        used_of.append(used)
        jobs.append(("chart", (pos32[used], local.reshape(-1, 3).astype(np.uint32), CHART_ITERATIONS)))
    done = pool.run(jobs)
    for (ok, value), p in zip(done, patches, strict=True):
        if not ok:
            what = _describe(value, deadline)
            raise _XatlasFailed(what if len(patches) == 1 else f"{what} on a patch of {len(p)} faces")
    meshes = []
    for (_, (vmap, idx, uv)), p, used in zip(done, patches, used_of, strict=True):
        idx = idx.astype(np.int64)
        if idx.shape != (len(p), 3) or not np.isfinite(uv).all():
            raise _XatlasFailed("xatlas returned bad UVs for a patch")
        a_uv = uv_areas(uv, idx)
        if not a_uv.sum() > 0:
            raise _XatlasFailed("xatlas returned UVs of zero area for a patch")
        keep = a_uv > 0
        if keep.any():
            scale = np.sqrt(areas(pos, faces[p]).sum() / a_uv.sum())
            meshes.append((p[keep], used[vmap.astype(np.int64)], uv * scale, idx[keep]))
    return meshes, len(patches)


def _chart_planar(pos, faces, good, size):
    """Planar charts (:mod:`texbake.atlas.charts`) of the ``good`` faces: ``(meshes, chart count,
    flat share)``, meshes as :func:`_pack` takes them, in world units of ``pos``.

    Slivers under a thousandth of a texel high (at the density a ``size``-texel atlas
    would have) are left out: xatlas' float32 UVs can collapse them, and they hold no
    texel centre anyway; they get charts of their own.
    """
    c = planar_charts(pos, faces[good], grid=size)
    a_uv = uv_areas(c.uv, c.faces)
    tri = c.uv[c.faces]
    longest = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    texel = np.sqrt(a_uv.sum() / 0.5) / size
    keep = 2 * a_uv > 1e-3 * texel * longest
    if not keep.any():
        return [], 0, c.flat
    used, local = np.unique(c.faces[keep], return_inverse=True)  # vertices of the faces kept
    return [(good[keep], c.vmapping[used], c.uv[used], local.reshape(-1, 3))], int(c.labels.max()) + 1, c.flat


def _pack(pos, faces, meshes, size, padding, pool, deadline):
    """Pack charted UV meshes into one atlas ``(vmapping, faces, uv)`` of all ``faces``.

    ``meshes``: ``(face ids, chart vertex -> mesh vertex, uv, faces in chart vertices)``
    at one texel density. Faces in none of them get a chart each, about two
    texels wide. One xatlas packing pass at the texture's resolution and padding (one
    ``add_uv_mesh`` per mesh: xatlas merges touching or overlapping charts of one mesh);
    up to ``SWAP_FACES`` triangles a second at the same time with u and v swapped, the
    fuller one kept.
    """
    m = len(faces)
    charted = np.zeros(m, dtype=bool)
    for face_ids, *_ in meshes:
        charted[face_ids] = True
    lost = np.flatnonzero(~charted)
    if len(lost):
        total = max(areas(pos, faces).sum(), 1e-30)
        texel = np.sqrt(total / 0.7) / size  # world units per texel, roughly
        flat = _flat_triangles(pos, faces[lost])
        flat *= (2 * texel / flat.max(axis=(1, 2)))[:, None, None]
        flat[:, :, 0] += (np.arange(len(lost)) * 4 * texel)[:, None]
        meshes = [*meshes, (lost, faces[lost].reshape(-1), flat.reshape(-1, 2), np.arange(3 * len(lost)).reshape(-1, 3))]

    meshes = [_compact(*mesh) for mesh in meshes]
    texel = np.sqrt(sum(float(uv_areas(uv, idx).sum()) for _, _, uv, idx in meshes) / 0.5) / size  # UV units, roughly
    for outlines in (True, False):  # by the charts' outlines; by their own triangles if xatlas split an outline
        proxies = [_proxy(uv, idx, 0.25 * texel, outlines) for _, _, uv, idx in meshes]
        small = sum(len(tri) for _, tri, _ in proxies) <= SWAP_FACES
        best = None
        swaps = (False, True) if small else (False,)
        replies = pool.run([("pack", (_pack_input(meshes, proxies, swap), size, padding)) for swap in swaps])
        for ok, value in replies:
            if not ok:
                raise _XatlasFailed(f"{_describe(value, deadline)} while packing")
            uvs = _placed(meshes, proxies, value)
            if uvs is None:
                continue
            face_areas = [uv_areas(u, idx) for u, (_, _, _, idx) in zip(uvs, meshes, strict=True)]
            if any((a <= 0).any() for a in face_areas):
                continue  # a sliver collapsed in xatlas' float32 UVs
            used = sum(float(a.sum()) for a in face_areas)
            if best is None or used > best[0]:
                best = used, uvs
        if best is not None:
            uvs = best[1]
            break
        if not outlines:
            raise _XatlasFailed("xatlas' packing distorted a chart or collapsed a face")
    maps, out_faces, offset = [], np.full((m, 3), -1, dtype=np.int64), 0
    for face_ids, vmap, uv, idx in meshes:
        maps.append(vmap)
        out_faces[face_ids] = idx + offset
        offset += len(uv)
    return np.concatenate(maps), out_faces, np.concatenate(uvs)


def _pack_input(meshes, proxies, swap: bool) -> list[tuple[np.ndarray, np.ndarray]]:
    """What one xatlas packing gets: each mesh's proxy ``(uv (k, 2) float32, triangles
    (t, 3) uint32)``, u and v swapped if ``swap``."""
    out = []
    for (_, _, uv, _), (used, tri, _) in zip(meshes, proxies, strict=True):
        q = uv[used][:, ::-1] if swap else uv[used]
        out.append((np.ascontiguousarray(q, dtype=np.float32), np.ascontiguousarray(tri[:, ::-1] if swap else tri, dtype=np.uint32)))
    return out


def _placed(meshes, proxies, value) -> list[np.ndarray] | None:
    """Each mesh's UVs as the packing ``value`` placed its proxy, or None if a chart
    packed by its outline came back distorted."""
    packed, _info = value
    if len(packed) != len(meshes):
        raise _XatlasFailed("xatlas' packing lost meshes")
    try:
        return [_place(uv, chart, used[vm2.astype(np.int64)], uv2.astype(np.float64))
                for (_, _, uv, _), (used, _, chart), (vm2, _, uv2) in zip(meshes, proxies, packed, strict=True)]
    except _XatlasFailed:
        return None


def _compact(face_ids, vmap, uv, idx):
    """A UV mesh for :func:`_pack` without the vertices no face uses."""
    used, local = np.unique(idx, return_inverse=True)
    return face_ids, vmap[used], uv[used], local.reshape(-1, 3)


def _proxy(uv: np.ndarray, faces: np.ndarray, tolerance: float, outlines: bool = True):
    """What the packer gets for a UV mesh: ``(used (u,), triangles (t, 3) into used,
    chart (k,))``: each chart of more than ``PROXY_FACES`` faces as the ear-cut
    triangulation of its outline simplified within ``tolerance`` (a quarter texel:
    :func:`texbake.atlas.charts.outline_triangles`; xatlas rasterises each triangle over its
    bounding box, so a fan of 4000 slivers costs it seconds), the others (all, without
    ``outlines``) as they are; ``chart``: each vertex's chart."""
    from .charts import outline_triangles

    chart = np.zeros(len(uv), dtype=np.int64)
    face_chart = chart_labels(faces, len(uv))
    chart[faces] = face_chart[:, None]
    order = np.argsort(face_chart, kind="stable")
    starts = np.flatnonzero(np.r_[True, face_chart[order][1:] != face_chart[order][:-1]])
    parts = []
    for members in np.split(order, starts[1:]):
        tri = outline_triangles(uv, faces[members], tolerance) if outlines and len(members) > PROXY_FACES else None
        parts.append(faces[members] if tri is None else tri)
    tri = np.concatenate(parts)
    used, local = np.unique(tri, return_inverse=True)
    return used, local.reshape(-1, 3), chart


def _place(uv: np.ndarray, chart: np.ndarray, source: np.ndarray, placed: np.ndarray) -> np.ndarray:
    """``uv`` (k, 2) moved chart by chart as the packer moved the ``source`` vertices to
    ``placed``: a chart whose vertices were all placed as placed, the others (packed by
    their outline) by the affine map that fits the placed ones best by least squares
    (xatlas rotates, scales, and turns a chart a quarter by swapping u and v, a mirror);
    raises ``_XatlasFailed`` if that map does not fit."""
    k = int(chart.max()) + 1
    c = chart[source]
    n = np.bincount(c, minlength=k)
    if (n[np.unique(chart)] == 0).any():
        raise _XatlasFailed("xatlas' packing lost a chart")
    x = np.column_stack([uv[source], np.ones(len(source))])  # (s, 3)
    gram = np.zeros((k, 3, 3))
    rhs = np.zeros((k, 3, 2))
    np.add.at(gram, c, x[:, :, None] * x[:, None, :])
    np.add.at(rhs, c, x[:, :, None] * placed[:, None, :])
    maps = np.linalg.pinv(gram) @ rhs  # (k, 3, 2): each chart's affine map
    err = np.linalg.norm(np.einsum("si,sij->sj", x, maps[c]) - placed, axis=1)
    whole = n >= np.bincount(chart, minlength=k)  # every vertex placed: xatlas' own placement
    lo = np.full((k, 2), np.inf)
    hi = np.full((k, 2), -np.inf)
    np.minimum.at(lo, c, placed)
    np.maximum.at(hi, c, placed)
    extent = (hi - lo).max(axis=1)
    worst = np.zeros(k)
    np.maximum.at(worst, c, err)
    if (~whole & (worst > 1e-3 * extent + 1e-7)).any():
        raise _XatlasFailed("xatlas' packing distorted a chart")
    out = np.einsum("ki,kij->kj", np.column_stack([uv, np.ones(len(uv))]), maps[chart])
    direct = whole[c]
    out[source[direct]] = placed[direct]
    return out


def _unwrap(vertices, faces, size, padding, pool, deadline, patch_faces, charting):
    """An atlas ``(vmapping, faces, uv, method, detail)`` charted by ``charting``
    ("xatlas" or "planar") and packed by xatlas in ``pool``'s workers by its end;
    raises ``_XatlasFailed``."""
    pos = _normalised(vertices)
    good = _good_faces(pos, faces)
    if charting == "planar":
        meshes, charts, flat = _chart_planar(pos, faces, good, size)
        vm, fa, uv = _pack(pos, faces, meshes, size, padding, pool, deadline)
        return vm, fa, uv, "planar", {"planar_charts": charts, "flat_share": round(flat, 4)}
    meshes, n_patches = _chart_xatlas(pos, faces, good, pool, deadline, patch_faces)
    vm, fa, uv = _pack(pos, faces, meshes, size, padding, pool, deadline)
    return vm, fa, uv, "xatlas-patches" if n_patches > 1 else "xatlas", {"patches": n_patches}


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


def _try_planar(vertices, faces, size, padding, pool):
    """A planar atlas ``(vmapping, faces, uv, method, detail)`` by ``pool``'s end, or None."""
    try:
        atlas = _unwrap(vertices, faces, size, padding, pool, pool.end - time.monotonic(), None, "planar")
    except _XatlasFailed:
        return None
    return atlas if _problem(*atlas[:3], len(faces), len(vertices), faces) is None else None


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
    if charting == "auto":
        planar_first, why = prefer_planar(vertices, faces)
    else:
        planar_first, why = charting == "planar", f"charting={charting!r}"
    return ([("planar", None), *xatlas] if planar_first else [*xatlas, ("planar", None)]), why


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
    size : int, optional
        Texels of the square texture, 1 to 65536: the packing's resolution.
    padding : int, optional
        Texels between charts, 0 to 64.
    deadline : float, optional
        Seconds for all xatlas work, in ``workers`` processes.
    workers : int, optional
        xatlas worker processes.
    charting : {"auto", "xatlas", "planar"}, optional
        "planar" (:mod:`texbake.atlas.charts`), "xatlas" (its own charts; meshes of more
        than ``2 * PATCH_FACES`` faces in patches, in parallel) or "auto"
        (:func:`texbake.atlas.charts.prefer_planar`). The other is tried when the first
        fails, and a "fallback-grid" atlas (a cell per triangle) only when both have.
    _patch_faces : int or None
        Faces per patch of the xatlas unwrap; None: the whole mesh in one piece (tests).

    Returns
    -------
    Atlas
        ``reason`` says why the UVs were not kept, which charting was used and why, and
        what failed. ``stats``: :func:`atlas_stats`, plus ``overlap`` (the share of
        covered texels under two or more faces), ``bare_area`` (the share of the surface
        on charts that hold no texel centre at ``size``; None above 8192), ``seconds``,
        and ``patches`` or ``planar_charts`` and ``flat_share``. ``warnings``: overlapping
        UVs kept, the fallback grid, over ``BARE_LIMIT`` of the surface on bare charts.

    Raises
    ------
    ParameterError
        A bad ``mode`` (named ``uv``), ``charting``, ``size``, ``padding``, ``deadline``
        or ``workers``.
    AtlasError
        Arrays of the wrong shape, no faces, faces that index missing vertices, vertices
        that are not finite, unusable UVs with ``mode="keep"``, or no atlas at all.

    Long because it is the atlas stage's decision list (keep, unwrap one way, the other
    way, fall back), each step depending on why the one before failed.
    """
    start = time.perf_counter()
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

    grid = min(size, OVERLAP_GRID)

    def stats_of(vm, fa, u, raster=None):  # raster: coverage(u, fa, grid), when known
        s = atlas_stats(vertices, faces, fa, u)
        counts, covering = raster if raster is not None else coverage(u, fa, grid)
        s["overlap"], _ = overlap_of(counts)
        s["bare_area"] = None
        if size <= 8192:  # the surface on charts that hold no texel centre: their texels are all margin
            a3, chart = areas(vertices, faces), chart_labels(fa, len(u))
            held = np.zeros(chart.max() + 1, dtype=bool)
            held[chart[covering if grid == size else covering_faces(u, fa, size)]] = True
            s["bare_area"] = float(a3[~held[chart]].sum() / max(a3.sum(), 1e-300))
        s["seconds"] = time.perf_counter() - start
        return s

    def bare_warning(stats) -> list[str]:
        share = stats["bare_area"]
        if share is None or share <= BARE_LIMIT:
            return []
        return [f"{share:.0%} of the surface lies on charts that hold no texel centre at {size}x{size}: they show "
                "only the margin's colours (bake larger, or unwrap)"]

    if mode != "unwrap":
        problem = uv_problem(vertices, faces, uv)
        overlapping = raster = None
        if problem is None:  # inside the tile and not degenerate: do faces share texels?
            raster = coverage(np.asarray(uv, dtype=np.float64), faces, grid)
            share, most = overlap_of(raster[0])
            if share > OVERLAP_LIMIT:
                overlapping = (f"the mesh's UVs overlap: {share:.1%} of the covered texels lie under two or more "
                               f"faces (up to {most})")
        if problem is None and (overlapping is None or mode == "keep"):
            uv = np.asarray(uv, dtype=np.float64)
            vm = np.arange(len(vertices), dtype=np.int64)
            reason = "the mesh's UVs are usable" if overlapping is None else "uv='keep'"
            warnings = [] if overlapping is None else [f"{overlapping}: those texels show one face's texture on all of them"]
            stats = stats_of(vm, faces, uv, raster)
            return Atlas(vm, faces, uv, "kept", reason, stats, warnings + bare_warning(stats))
        if mode == "keep":
            raise AtlasError(f"uv='keep' but {problem}")
        why = problem or overlapping
    else:
        why = "uv='unwrap'"

    end = time.monotonic() + deadline
    failures: list[str] = []
    attempts, order = _attempts(vertices, faces, charting, _patch_faces)
    with Pool(WORKER, workers, end) as pool:  # one set of workers for every attempt
        for i, (charting_i, patch_faces) in enumerate(attempts):
            now = time.monotonic()
            if now >= end or (charting_i == "xatlas" and any("timed out" in f for f in failures)):
                continue
            # xatlas' charting may take 3/4 of what is left when planar charts are still to come
            pool.end = now + 0.75 * (end - now) if ("planar", None) in attempts[i + 1:] else end
            try:
                vm, fa, u, method, detail = _unwrap(vertices, faces, size, padding, pool, pool.end - now,
                                                    patch_faces, charting_i)
            except _XatlasFailed as exc:
                failures.append(str(exc))
                continue
            bad = _problem(vm, fa, u, len(faces), len(vertices), faces)
            if bad is None:
                found = charting_i, (vm, fa, u, method, detail)
                break
            failures.append(f"{charting_i} charting gave an unusable atlas: {bad}")
        else:
            found = None
        if found is not None and charting == "auto" and found[0] == "xatlas" and time.monotonic() < end:
            # a small organic mesh: planar charts too, kept if they use the texture much better
            pool.end = end
            planar = _try_planar(vertices, faces, size, padding, pool)
            used = [float(uv_areas(c[2], c[1]).sum()) for c in (found[1], planar) if c is not None]
            if planar is not None and used[1] > PLANAR_GAIN * used[0]:
                order += f"; planar charts used instead: they cover {used[1]:.2f} of the texture, xatlas' {used[0]:.2f}"
                found = "planar", planar
    if found is not None:
        charting_i, (vm, fa, u, method, detail) = found
        retried = f" (after: {'; '.join(failures)})" if failures else ""
        stats = {**stats_of(vm, fa, u), **detail}
        return Atlas(vm, fa, u, method, f"{why}; {charting_i} charts: {order}{retried}", stats, bare_warning(stats))

    vm, fa, u = _grid_atlas(vertices, faces, padding / size)
    bad = _problem(vm, fa, u, len(faces), len(vertices), faces)
    if bad is not None:
        raise AtlasError(f"no atlas could be made ({'; '.join(failures)}; grid atlas: {bad})")
    reason = f"{why}; {'; '.join(failures) or f'the unwrap deadline of {deadline:g} s passed'}; used fallback"
    warning = f"fallback atlas: one chart per triangle ({reason}); texel density varies and charts are tiny"
    stats = stats_of(vm, fa, u)
    return Atlas(vm, fa, u, "fallback-grid", reason, stats, [warning, *bare_warning(stats)])
