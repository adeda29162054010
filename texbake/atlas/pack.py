"""The unwrap in xatlas' worker processes: charting, then one packing of all charts.

xatlas hangs on some inputs (an infinite vertex, a mesh 1e20 units across), returns NaN
UVs on others and segfaults on some (``trimesh.creation.icosphere(6)`` in one piece). So
it only ever runs in worker processes (:mod:`texbake.atlas.packworker`, fresh
interpreters, from ``WORKER``) under a deadline counted in their own CPU time
(:class:`texbake.workers.Pool`), on a copy of the mesh normalised to a unit box in
float64 before the cast to float32, and whatever comes back is checked
(:func:`texbake.atlas.uvcheck.unwrap_problem`). The workers are started once per process
and kept for its later unwraps (:func:`start_workers`); one that crashed or was ended at
the deadline is replaced.

Charting, one of two ways: planar charts (:mod:`texbake.atlas.charts`), or xatlas' own
(the mesh cut into spatially coherent patches of about ``PATCH_FACES`` faces that the
workers chart in parallel, each patch brought to one texel density). Packing: faces whose
chart collapsed or that were left out, and charts under ``MIN_EXTENT`` texels across, get
a small chart per face (laid flat as in :mod:`texbake.atlas.fallback`), and all charts
are packed together in a single xatlas packing pass at the texture's resolution and
padding (one ``add_uv_mesh`` per mesh of charts; its texel density searched on every
worker at once, and planar charts it leaves far emptier than their boxes need looked at
again by brute force). Large charts are packed by a proxy,
the triangulation of their outline, and refitted to where the packer placed it
(:func:`_place`). A chart the packing distorts, or a face it collapses, is packed again
(by its own triangles; as a face of its own), the charting kept; each such pass is
recorded in the atlas' ``packing`` list. Any failure raises :class:`XatlasFailed`,
saying what failed.
"""

from __future__ import annotations

import atexit
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import NamedTuple, cast

import numpy as np

from ..mesh import areas, label_boxes, unique_inverse, uv_areas
from ..workers import Pool
from .charts import outlines_triangles, planar_charts
from .fallback import flat_triangles, normalised
from .uvcheck import chart_labels, packing_estimate

SWAP_FACES = 20_000  # meshes packed once more with u and v swapped (xatlas' greedy packer then often fills more), up to this many triangles
PROXY_FACES = 32  # charts of more faces are packed by the triangulation of their outline
MIN_PROXY_AREA = 1e-4  # texels: an outline triangulated with a smaller triangle is not packed by it
MIN_EXTENT = 1.0  # texels: charts smaller across are packed as faces of their own, two texels wide
BRUTE_CHARTS = 24  # packings of at most this many charts and ...
BRUTE_TRIANGLES = 200  # ... proxy triangles place each chart by brute force (long strips fill more; larger ones take seconds)
# A packing of one layout (no u-v swapped twin) searches its density on all the workers at
# once: two densities a round (the first two below; xatlas' side for the first, at half the
# square filled, came to 0.83-1.27 of the texture's on the bench's meshes), then the one the
# packings so far put at 99 % of the side, and that one shrunk by SEARCH_HEDGE (the side
# comes out within about 4 % of the aim). The fullest that fits is kept: the utilisation
# goes as (density / side)^2, and xatlas' greedy side is not monotone in the density
# (counter.unitsmm.STL: 0.390-0.411 over densities 0.84-0.89).
FIRST_DENSITIES = (1.0, 0.9)
SEARCH_HEDGE = 0.985
SEARCH_ROUNDS = 3
# A second look by brute force (xatlas tries every position, at half the resolution) at the
# density found, for planar charts (boxes: CAD faces) that the greedy packing left far
# emptier than their boxes need: trimesh's boolean.glb, 200 charts, 0.706 -> 0.774, for one
# pass at about the cost of one greedy pass there; brute force on hundreds of curved charts takes
# seconds (gear_cad.stl, 928 charts: 0.2 s a pass), so at most LOOK_CHARTS charts.
LOOK_SHARE = 0.9
LOOK_CHARTS = 256
LOOK_DENSER = 1.02
PACKINGS = 3  # packing passes at most: the first, and again for what it distorted or collapsed
WARM_BYTES = 256 << 20  # a worker holding more memory after an unwrap is ended, not kept warm
# Faces per patch of the parallel unwrap: a patch of 1000 faces takes xatlas about 0.03 s of
# CPU time, and xatlas' charting grows faster than its faces (quadknot.obj's 2,880 in one
# piece: 0.43 s; in patches of 1000: 0.14 s), so meshes of more than 2000 faces are charted in
# patches on every worker. Of the bench's seven such meshes, utilisation went up on four
# (quadknot 0.346 -> 0.504, busted 0.563 -> 0.631, beetle 0.456 -> 0.510, ballA) and down by
# under 0.02 on three (spot, cow, Duck).
PATCH_FACES = 1000
# What charting one patch may take before it is ended and charted again by a fresh worker
# (once): a patch of 2000 faces took xatlas about 0.05 s of CPU time, and one such
# patch in a CI run sat 120 s without an answer (it charted at once in every other run).
PATCH_JOB_SECONDS = 20.0
CHART_ITERATIONS = 1  # xatlas ChartOptions.max_iterations: more iterations take longer for no better atlas on the meshes here


@dataclass(frozen=True)
class UnwrapRequest:
    """What an unwrap is asked for: a mesh and the texture its charts are packed into."""

    vertices: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64
    size: int  # texels of the square texture
    padding: int  # texels between charts


class Unwrapped(NamedTuple):
    """An unwrap's atlas, as :class:`texbake.atlas.decide.Atlas` holds it, and how it was made."""

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: the mesh's faces in atlas vertices
    uv: np.ndarray  # (k, 2) float64 in the unit square
    method: str  # "planar" | "xatlas" | "xatlas-patches"
    detail: dict  # for the atlas' stats: ``patches``, or ``planar_charts`` and ``flat_share``


class XatlasFailed(Exception):
    """An unwrap failed: xatlas crashed, hung, or gave UVs that cannot be used (the message says which)."""


# The command that starts an xatlas worker (``texbake.workers`` protocol; tests put in one
# that crashes or hangs).
WORKER = [sys.executable, "-m", "texbake.atlas.packworker"]


_warm: Pool | None = None  # this process's workers, kept between unwraps
_warm_lock = threading.Lock()


@contextmanager
def start_workers(count: int, deadline: float) -> Iterator[Pool]:
    """``count`` xatlas workers (``WORKER``) whose jobs must be done within ``deadline``
    seconds of each worker's CPU time (:class:`texbake.workers.Pool`).

    The workers are this process's warm ones, started by its first unwrap and kept for
    the next (their start-up is most of a small mesh's unwrap), unless one holds more
    than ``WARM_BYTES`` after it (a large mesh's heap); a worker that crashed or was
    ended at the deadline is replaced by a fresh one when next needed. A second
    unwrap at the same time (another thread) gets workers of its own, ended after it.
    """
    global _warm
    if not _warm_lock.acquire(blocking=False):
        with Pool(WORKER, count, deadline) as pool:
            yield pool
        return
    try:
        if _warm is not None and _warm.command != WORKER:  # another worker command (tests)
            _warm.close()
            _warm = None
        if _warm is None:
            _warm = Pool(WORKER, count, deadline)
            atexit.register(_warm.close)
        else:
            _warm.n = max(1, count)
            _warm.restart(deadline)
        yield _warm
    finally:
        if _warm is not None:
            _warm.end_larger_than(WARM_BYTES)
        _warm_lock.release()


def close_warm() -> None:
    """End this process's warm workers now, and wait for them (a process forked by
    ``multiprocessing`` leaves by ``os._exit``: its ``atexit`` handlers do not run)."""
    global _warm
    with _warm_lock:
        if _warm is not None:
            _warm.close()
            _warm = None


def _describe(why: str, deadline: float) -> str:
    """What a worker's failure ``why`` (``texbake.workers``: "timeout", "exit code N", or an error) means for the unwrap."""
    if why == "timeout":
        return f"xatlas timed out after {deadline:.3g} s"
    if why.startswith("exit code"):
        return f"xatlas crashed ({why})"
    return f"xatlas failed ({why})"


def run_xatlas_in_child(positions: np.ndarray, faces: np.ndarray, deadline: float, *, size: int = 1024,
                        padding: int = 2) -> tuple[bool, object]:
    """Chart and pack ``(n, 3)`` float32 positions, as given, in one worker: how xatlas
    itself fares on a mesh (the stability checks and the tests).

    Returns ``(True, (vmapping, faces, uv))`` or ``(False, why)`` once the worker is
    done, dead, or past ``deadline`` seconds (then it is killed).
    """
    with Pool(WORKER, 1, deadline) as workers:  # its own: a hang must not cost the warm workers
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


def unwrap(request: UnwrapRequest, pool: Pool, deadline: float, patch_faces: int | None, charting: str) -> Unwrapped:
    """The atlas of ``request`` charted by ``charting`` ("xatlas", in patches of
    ``patch_faces`` faces or, None, in one piece; or "planar") and packed by xatlas in
    ``pool``'s workers by its end (``deadline`` seconds from now, for the messages);
    raises :class:`XatlasFailed`."""
    faces, size, padding = request.faces, request.size, request.padding
    pos = normalised(request.vertices)
    good = _good_faces(pos, faces)
    steps: list[str] = []
    if charting == "planar":
        meshes, charts, flat = _chart_planar(pos, faces, good, size)
        detail: dict = {"planar_charts": charts, "flat_share": round(flat, 4)}
        method = "planar"
    else:
        meshes, n_patches = _chart_xatlas(pos, faces, good, pool, deadline, patch_faces)
        detail, method = {"patches": n_patches}, "xatlas-patches" if n_patches > 1 else "xatlas"
    vm, fa, uv = _pack(pos, faces, meshes, size, padding, pool, deadline, steps, boxy=charting == "planar")
    if steps:
        detail["packing"] = steps
    return Unwrapped(vm, fa, uv, method, detail)


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


def _good_faces(pos: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Indices of the faces that keep an area in float32 (xatlas' precision); the rest
    would give NaNs or collapse, and get a small chart of their own (:func:`_pack`)."""
    return np.flatnonzero(areas(pos.astype(np.float32), faces) > 0)


def _chart_xatlas(pos, faces, good, pool, deadline, patch_faces):
    """xatlas' charts of the ``good`` faces: ``(meshes, patch count)``, meshes as
    :func:`_pack` takes them (faces whose chart collapsed are left out); raises
    ``XatlasFailed``.

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
        used, local = unique_inverse(faces[p])
        used_of.append(used)
        jobs.append(("chart", (pos32[used], local.reshape(-1, 3).astype(np.uint32), CHART_ITERATIONS)))
    done = pool.run(jobs, job_seconds=PATCH_JOB_SECONDS, retries=1) if len(jobs) > 1 else pool.run(jobs)
    for (ok, value), p in zip(done, patches, strict=True):
        if not ok:
            what = _describe(value, deadline)
            raise XatlasFailed(what if len(patches) == 1 else f"{what} on a patch of {len(p)} faces")
    meshes = []
    for (_, (vmap, idx, uv)), p, used in zip(done, patches, used_of, strict=True):
        idx = idx.astype(np.int64)
        if idx.shape != (len(p), 3) or not np.isfinite(uv).all():
            raise XatlasFailed("xatlas returned bad UVs for a patch")
        a_uv = uv_areas(uv, idx)
        if not a_uv.sum() > 0:
            raise XatlasFailed("xatlas returned UVs of zero area for a patch")
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
    used, local = unique_inverse(c.faces[keep])  # vertices of the faces kept
    return [(good[keep], c.vmapping[used], c.uv[used], local.reshape(-1, 3))], int(c.labels.max()) + 1, c.flat


def _pack(pos, faces, meshes, size, padding, pool, deadline, steps: list[str], boxy: bool = False):
    """Pack charted UV meshes into one atlas ``(vmapping, faces, uv)`` of all ``faces``.

    ``meshes``: ``(face ids, chart vertex -> mesh vertex, uv, faces in chart vertices)``
    at one texel density. Faces in none of them, and charts under ``MIN_EXTENT`` texels
    across (xatlas' packer turns some of those into a point), get a chart of their own
    per face, two texels wide. One xatlas packing pass at the texture's resolution and
    padding (one ``add_uv_mesh`` per mesh: xatlas merges touching or overlapping charts
    of one mesh); up to ``SWAP_FACES`` triangles a second at the same time with u and v
    swapped, the fuller one kept. A chart that the packing distorts or a face that it
    collapses is packed again, only it changed (by its own triangles; as faces of their
    own), in up to ``PACKINGS`` passes in all; each such pass is added to ``steps``.
    ``boxy``: planar charts (:func:`_best_packing`'s second look).
    """
    meshes = [_compact(*mesh) for mesh in meshes]
    texel = np.sqrt(sum(float(uv_areas(uv, idx).sum()) for _, _, uv, idx in meshes) / 0.5) / size  # UV units, roughly
    m = len(faces)
    alone = np.ones(m, dtype=bool)  # faces packed as charts of their own
    for face_ids, _, uv, idx in meshes:
        alone[face_ids] = _tiny(uv, idx, texel)
    own = np.zeros(m, dtype=bool)  # faces whose chart is packed by its own triangles, not its outline
    for _ in range(PACKINGS):
        parts = _with_faces_alone(pos, faces, meshes, alone, size)
        proxies = [_proxy(uv, idx, 0.25 * texel, own[face_ids]) for face_ids, _, uv, idx in parts]
        uvs, distorted, collapsed = _best_packing(parts, proxies, size, padding, pool, deadline, boxy)
        if not (len(distorted) or len(collapsed)):
            break
        steps.append(_repacked(distorted, collapsed, parts))
        own[distorted] = True
        alone[collapsed] = True
    else:
        raise XatlasFailed(f"xatlas' packing still distorted a chart or collapsed a face after {PACKINGS} passes")
    maps, out_faces, offset = [], np.full((m, 3), -1, dtype=np.int64), 0
    for (face_ids, vmap, _, idx), placed in zip(parts, uvs, strict=True):
        maps.append(vmap)
        out_faces[face_ids] = idx + offset
        offset += len(placed)
    return np.concatenate(maps), out_faces, np.concatenate(uvs)


def _tiny(uv: np.ndarray, idx: np.ndarray, texel: float) -> np.ndarray:
    """``(f,)`` bool: the faces of charts under ``MIN_EXTENT`` texels (of ``texel`` UV units) across."""
    chart = chart_labels(idx, len(uv))
    lo, hi = label_boxes(uv, idx, chart)
    return ((hi - lo).max(axis=1) < MIN_EXTENT * texel)[chart]


def _with_faces_alone(pos, faces, meshes, alone, size):
    """``meshes`` without the faces marked ``alone``, and one more mesh of those faces,
    each laid flat (:func:`texbake.atlas.fallback.flat_triangles`) two texels wide and
    four apart."""
    out = []
    for face_ids, vmap, uv, idx in meshes:
        keep = ~alone[face_ids]
        if keep.all():
            out.append((face_ids, vmap, uv, idx))
        elif keep.any():
            out.append(_compact(face_ids[keep], vmap, uv, idx[keep]))
    lost = np.flatnonzero(alone)
    if len(lost):
        total = max(areas(pos, faces).sum(), 1e-30)
        texel = np.sqrt(total / 0.7) / size  # world units per texel, roughly
        flat = flat_triangles(pos, faces[lost])
        flat *= (2 * texel / flat.max(axis=(1, 2)))[:, None, None]
        flat[:, :, 0] += (np.arange(len(lost)) * 4 * texel)[:, None]
        out.append((lost, faces[lost].reshape(-1), flat.reshape(-1, 2), np.arange(3 * len(lost)).reshape(-1, 3)))
    return out


def _best_packing(meshes, proxies, size, padding, pool, deadline, boxy: bool = False):
    """One packing of ``meshes`` by their ``proxies`` (and one with u and v swapped, up to
    ``SWAP_FACES`` proxy triangles; by brute force up to ``BRUTE_CHARTS`` charts of
    ``BRUTE_TRIANGLES`` triangles): ``(uvs, distorted, collapsed)`` of the one with the
    fewest faces to pack again, then the fullest; ``distorted``, ``collapsed``: face ids
    of the charts it distorted and of the faces it collapsed.

    ``boxy`` (planar charts): where that packing fills under ``LOOK_SHARE`` of what the
    charts' boxes promise (:func:`_promise`) and there are at most ``LOOK_CHARTS`` charts,
    a second look by brute force at its density (and ``LOOK_DENSER`` times it), one pass
    each on the workers at once; kept where it fits and fills more."""
    triangles = sum(len(tri) for _, tri, _ in proxies)
    swaps = (False, True) if triangles <= SWAP_FACES else (False,)
    charts = sum(int(chart.max()) + 1 for _, _, chart in proxies)
    brute = triangles <= BRUTE_TRIANGLES and charts <= BRUTE_CHARTS
    if len(swaps) == 1 and pool.n > 1:  # one packing: its density searched on every worker at once
        replies = [_searched(pool, _pack_input(meshes, proxies, False), size, padding, brute, deadline)]
    else:
        replies = pool.run([("pack", (_pack_input(meshes, proxies, swap), size, padding, brute)) for swap in swaps])
    best = _ranked(meshes, proxies, zip(swaps, replies, strict=True), deadline)
    if boxy and not brute and charts <= LOOK_CHARTS and -best[0][1] < LOOK_SHARE * _promise(meshes, padding / size):
        swap, density = best[1], best[2][1]["density"]
        looks = [density * k for k in (1.0, LOOK_DENSER)[:pool.n]]
        replies = pool.run([("pack", (_pack_input(meshes, proxies, swap), size, padding, True, d)) for d in looks])
        fitted = [(swap, (ok, value)) for ok, value in replies if not ok or value[1]["fill"] <= 1]
        best = _ranked(meshes, proxies, fitted, deadline, best)
    return best[3]


def _ranked(meshes, proxies, replies, deadline, best=None):
    """The best of ``replies`` (``(swap, pool reply)`` pairs) and ``best`` (an earlier
    return): ``(rank, swap, value, (uvs, distorted, collapsed))``, ranked by the faces to
    pack again, then the area used (negated); raises ``XatlasFailed`` for a failed reply."""
    for swap, (ok, value) in replies:
        if not ok:
            raise XatlasFailed(f"{_describe(value, deadline)} while packing")
        uvs, bad = _placed(meshes, proxies, value)
        distorted, collapsed, used = [], [], 0.0
        for (face_ids, _, _, idx), u, (_, _, chart), b in zip(meshes, uvs, proxies, bad, strict=True):
            a = uv_areas(u, idx)
            distorted.append(face_ids[b[chart[idx[:, 0]]]])
            collapsed.append(face_ids[(a <= 0) & ~b[chart[idx[:, 0]]]])  # in float32 UVs
            used += float(a.sum())
        d, c = np.concatenate(distorted), np.concatenate(collapsed)
        rank = (len(d) + len(c), -used)
        if best is None or rank < best[0]:
            best = rank, swap, value, (uvs, d, c)
    assert best is not None
    return best


def _promise(meshes, padding: float) -> float:
    """The utilisation the charts of ``meshes`` (one density) promise: their boxes packed
    (:func:`texbake.atlas.uvcheck.packing_estimate`, ``padding`` in tile units)."""
    uv = np.concatenate([m[2] for m in meshes])
    offsets = np.cumsum([0] + [len(m[2]) for m in meshes[:-1]])
    idx = np.concatenate([m[3] + o for m, o in zip(meshes, offsets, strict=True)])
    flat = np.column_stack([uv, np.zeros(len(uv))])  # the charts' own area: one density already
    return packing_estimate(flat, idx, idx, uv, padding)


def _searched(pool: Pool, packed: list, size: int, padding: int, brute: bool, deadline: float) -> tuple[bool, object]:
    """One packing of ``packed`` (:func:`_pack_input`) that fits ``size`` texels, its
    density searched as the worker's own search does (until a packing that fits spans 98 %
    of the side, in at most ``SEARCH_ROUNDS`` rounds) but with one density a
    worker at each round: ``FIRST_DENSITIES``, then the density that the packings so far put
    at 99 % of the side (interpolated between the nearest that fitted and the nearest that
    did not, else scaled from the nearest) and ``SEARCH_HEDGE`` of it, for when xatlas'
    layout comes out larger than the density says. A reply as
    :func:`texbake.workers.Pool.run`'s: the fullest packing that fitted (the largest
    density over side), else the smallest; a worker's failure as it is."""
    tried: dict[float, float] = {}  # density -> fill (the atlas' side over the texture's)
    replies: dict[float, tuple] = {}
    densities = FIRST_DENSITIES[:pool.n]
    for _ in range(SEARCH_ROUNDS):
        for t, (ok, value) in zip(densities, pool.run([("pack", (packed, size, padding, brute, t)) for t in densities]),
                                  strict=True):
            if not ok:
                return ok, value
            reply = cast(tuple, value)  # (per mesh (vmapping, indices, uv), info)
            tried[t], replies[t] = reply[1]["fill"], reply
        if any(0.98 <= fill <= 1 for fill in tried.values()):
            break
        below = max((t for t in tried if tried[t] <= 1), default=None)
        above = min((t for t in tried if tried[t] > 1), default=None)
        if below is not None and above is not None and tried[above] > tried[below]:
            t = below + (above - below) * (0.99 - tried[below]) / (tried[above] - tried[below])
        else:
            near = below if below is not None else above
            assert near is not None
            t = near * 0.99 / tried[near]
        densities = tuple(d for d in (t, t * SEARCH_HEDGE)[:pool.n] if all(abs(d - e) > 1e-3 * e for e in tried))
        if not densities:
            break
    best = max((t for t in tried if tried[t] <= 1), key=lambda t: t / tried[t], default=min(tried))
    return True, replies[best]


def _repacked(distorted: np.ndarray, collapsed: np.ndarray, meshes) -> str:
    """What a packing pass that is redone for ``distorted`` and ``collapsed`` faces changes, in words."""
    said = []
    if len(distorted):
        chart_of = np.full(max(int(f.max()) for f, *_ in meshes) + 1, -1)
        offset = 0
        for face_ids, _, uv, idx in meshes:
            labels = chart_labels(idx, len(uv))
            chart_of[face_ids] = labels + offset
            offset += int(labels.max()) + 1
        sizes = np.bincount(chart_of[distorted])
        sizes = sizes[sizes > 0]
        said.append(f"{len(sizes)} charts of {sizes.min()}-{sizes.max()} faces came back distorted from packing by their "
                    "outline: packed again by their own triangles")
    if len(collapsed):
        said.append(f"{len(collapsed)} faces collapsed to a point in xatlas' float32 UVs: packed again as charts of their "
                    "own, two texels wide")
    return "; ".join(said)


def _pack_input(meshes, proxies, swap: bool) -> list[tuple[np.ndarray, np.ndarray]]:
    """What one xatlas packing gets: each mesh's proxy ``(uv (k, 2) float32, triangles
    (t, 3) uint32)``, u and v swapped if ``swap``."""
    out = []
    for (_, _, uv, _), (used, tri, _) in zip(meshes, proxies, strict=True):
        q = uv[used][:, ::-1] if swap else uv[used]
        out.append((np.ascontiguousarray(q, dtype=np.float32), np.ascontiguousarray(tri[:, ::-1] if swap else tri, dtype=np.uint32)))
    return out


def _placed(meshes, proxies, value) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Each mesh's UVs as the packing ``value`` placed its proxy, and which of its charts
    (``(charts,)`` bool, by the proxy's chart numbers) came back distorted."""
    packed, _info = value
    if len(packed) != len(meshes):
        raise XatlasFailed("xatlas' packing lost meshes")
    placed = [_place(uv, chart, used[vm2.astype(np.int64)], uv2.astype(np.float64))
              for (_, _, uv, _), (used, _, chart), (vm2, _, uv2) in zip(meshes, proxies, packed, strict=True)]
    return [p[0] for p in placed], [p[1] for p in placed]


def _compact(face_ids, vmap, uv, idx):
    """A UV mesh for :func:`_pack` without the vertices no face uses."""
    used, local = unique_inverse(idx)
    return face_ids, vmap[used], uv[used], local.reshape(-1, 3)


def _proxy(uv: np.ndarray, faces: np.ndarray, texel: float, own: np.ndarray | None = None):
    """What the packer gets for a UV mesh: ``(used (u,), triangles (t, 3) into used,
    chart (k,))``: each chart of more than ``PROXY_FACES`` faces as the ear-cut
    triangulation of its outline simplified within a quarter ``texel``
    (:func:`texbake.atlas.charts.outline_triangles`; xatlas rasterises each triangle over
    its bounding box, so a fan of 4000 slivers costs it seconds), the others as they
    are; ``chart``: each vertex's chart. A chart keeps its own triangles too where one
    of its faces is ``own`` (``(f,)`` bool), or where its outline's triangulation has one
    under ``MIN_PROXY_AREA`` texels (xatlas takes such a face as degenerate and then
    parametrises the chart anew: it comes back distorted)."""
    chart = np.zeros(len(uv), dtype=np.int64)
    face_chart = chart_labels(faces, len(uv))
    chart[faces] = face_chart[:, None]
    order = np.argsort(face_chart, kind="stable")
    k = int(face_chart.max()) + 1
    count = np.bincount(face_chart, minlength=k)
    starts = np.cumsum(count) - count
    sorted_faces = faces[order]
    outlined = count > PROXY_FACES
    if own is not None:
        outlined &= np.bincount(face_chart, own, minlength=k) == 0
    chosen = np.flatnonzero(outlined)
    tris: list = [None] * k
    if len(chosen):
        # the outlines of every chart chosen at once (charts.outlines_triangles): one pass over
        # their faces, each chart's faces in one run as a stable sort by chart puts them
        want = np.bincount(face_chart, uv_areas(uv, faces), minlength=k)[chosen]
        picked = sorted_faces[outlined[face_chart[order]]]
        made, got = outlines_triangles(uv, picked, np.r_[0, np.cumsum(count[chosen])], 0.25 * texel, want)
        for c, tri, a in zip(chosen.tolist(), made, got, strict=True):
            if tri is not None and a is not None and a.min() >= MIN_PROXY_AREA * texel**2:
                tris[c] = tri
    bounds = np.r_[starts, len(order)].tolist()
    parts = [sorted_faces[bounds[c]:bounds[c + 1]] if tris[c] is None else tris[c] for c in range(k)]
    tri = np.concatenate(parts)
    used, local = unique_inverse(tri)
    return used, local.reshape(-1, 3), chart


def _place(uv: np.ndarray, chart: np.ndarray, source: np.ndarray, placed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``uv`` (k, 2) moved chart by chart as the packer moved the ``source`` vertices to
    ``placed``: a chart whose vertices were all placed as placed, the others (packed by
    their outline) by the affine map that fits the placed ones best by least squares
    (xatlas rotates, scales, and turns a chart a quarter by swapping u and v, a mirror).
    Returns the UVs and ``(charts,)`` bool: the charts that map does not fit (distorted);
    raises ``XatlasFailed`` if a chart was lost."""
    k = int(chart.max()) + 1
    c = chart[source]
    n = np.bincount(c, minlength=k)
    if (n[np.unique(chart)] == 0).any():
        raise XatlasFailed("xatlas' packing lost a chart")
    x = np.column_stack([uv[source], np.ones(len(source))])  # (s, 3)
    # sums per chart by bincount, not ufunc.at: the same additions in the same order, and a
    # tenth of the time on the thousands of charts of a CAD part
    outer = np.concatenate([(x[:, :, None] * x[:, None, :]).reshape(-1, 9), (x[:, :, None] * placed[:, None, :]).reshape(-1, 6)], axis=1)
    sums = np.stack([np.bincount(c, outer[:, j], minlength=k) for j in range(15)], axis=1)
    gram, rhs = sums[:, :9].reshape(k, 3, 3), sums[:, 9:].reshape(k, 3, 2)
    maps = np.linalg.pinv(gram) @ rhs  # (k, 3, 2): each chart's affine map
    err = np.linalg.norm(np.einsum("si,sij->sj", x, maps[c]) - placed, axis=1)
    whole = n >= np.bincount(chart, minlength=k)  # every vertex placed: xatlas' own placement
    lo = np.full((k, 2), np.inf)
    hi = np.full((k, 2), -np.inf)
    worst = np.zeros(k)
    by = np.argsort(c, kind="stable")  # each chart's placed vertices in one run: min, max by reduceat
    starts = np.flatnonzero(np.r_[True, c[by][1:] != c[by][:-1]]) if len(by) else by
    if len(by):
        ids = c[by][starts]
        lo[ids] = np.minimum.reduceat(placed[by], starts, axis=0)
        hi[ids] = np.maximum.reduceat(placed[by], starts, axis=0)
        worst[ids] = np.maximum(0.0, np.maximum.reduceat(err[by], starts))
    extent = (hi - lo).max(axis=1)
    out = np.einsum("ki,kij->kj", np.column_stack([uv, np.ones(len(uv))]), maps[chart])
    direct = whole[c]
    out[source[direct]] = placed[direct]
    return out, ~whole & (worst > 1e-3 * extent + 1e-7)
