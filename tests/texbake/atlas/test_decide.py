"""UV atlas: reuse, unwrap, xatlas' hangs and crashes, and the parallel patch unwrap.

Crashes and hangs are tested with injected workers (``texbake.atlas.pack.WORKER`` pointed at a
script that wraps the real worker and crashes, hangs or fails on the jobs it is told
to); one test, marked ``xatlas_failure``, checks a real xatlas failure."""

import os
import re
import signal
import sys
import time

import numpy as np
import pytest
import trimesh
from conftest import MESHES

from texbake.atlas import atlas_stats, make_atlas, run_xatlas_in_child, uv_problem
from texbake.atlas import pack as atlas_pack
from texbake.atlas.fallback import grid_atlas
from texbake.atlas.pack import PATCH_FACES
from texbake.errors import AtlasError, ParameterError
from texbake.workers import Pool


def load(name):
    m = trimesh.load(MESHES / name, force="mesh", process=False)
    uv = getattr(m.visual, "uv", None)
    return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64), None if uv is None else np.asarray(uv, float)


def uv_area(uv, faces):
    t = uv[faces]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    return 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])


def check_atlas(a, vertices, faces):
    """Invariants of every atlas: same faces, UVs in the unit square, no lost face."""
    assert a.faces.shape == faces.shape and a.faces.dtype == np.int64 and a.vmapping.dtype == np.int64
    assert a.vmapping.min() >= 0 and a.vmapping.max() < len(vertices) and len(a.vmapping) == len(a.uv)
    assert np.array_equal(vertices[a.vmapping[a.faces]], vertices[faces])
    assert np.isfinite(a.uv).all() and a.uv.min() >= -1e-6 and a.uv.max() <= 1 + 1e-6
    assert (uv_area(a.uv, a.faces) > 0).all()
    if a.method != "kept":  # a mesh's own UVs may overlap (mirrored halves)
        assert 0 < a.stats["utilisation"] < 1
    assert a.stats["charts"] >= 1 and a.stats["stretch"] >= 1 - 1e-9
    assert uv_problem(vertices[a.vmapping], a.faces, a.uv) is None


def overlap(a, n=4000):
    """Fraction of n random UV points inside more than one UV triangle (0 when packed)."""
    q = np.random.default_rng(0).random((n, 2))
    t = a.uv[a.faces]
    inside = np.zeros(len(q), int)

    def side(x, y):
        return (y[:, 0] - x[:, 0]) * (q[:, None, 1] - x[:, 1]) - (y[:, 1] - x[:, 1]) * (q[:, None, 0] - x[:, 0])

    for part in np.array_split(np.arange(len(t)), max(1, len(t) // 500)):
        a0, b0, c0 = t[part, 0], t[part, 1], t[part, 2]
        s1, s2, s3 = side(a0, b0), side(b0, c0), side(c0, a0)
        inside += (((s1 > 0) & (s2 > 0) & (s3 > 0)) | ((s1 < 0) & (s2 < 0) & (s3 < 0))).sum(axis=1)
    return (inside > 1).mean()


def test_uv_problem():
    v = np.zeros((3, 3))
    f = np.array([[0, 1, 2]])
    assert uv_problem(v, f, np.array([[0, 0], [1, 0], [0, 1.0]])) is None
    assert "no UVs" in uv_problem(v, f, None)
    assert "not finite" in uv_problem(v, f, np.array([[0, 0], [1, 0], [0, np.nan]]))
    assert "unit square" in uv_problem(v, f, np.array([[0, 0], [2, 0], [0, 1.0]]))
    assert "unit square" in uv_problem(v, f, np.array([[0, 0], [1, 0], [0, -0.01]]))
    assert uv_problem(v, f, np.array([[0, 0], [1 + 1e-9, 0], [0, 1.0]])) is None  # epsilon
    assert "zero UV area" in uv_problem(v, f, np.array([[0, 0], [1, 1], [0.5, 0.5]]))
    assert "shape" in uv_problem(v, f, np.zeros((2, 2)))


def test_auto_keeps_usable_uvs():
    v, f, uv = load("suzanne_blender_uv.obj")
    a = make_atlas(v, f, uv)
    assert a.method == "kept" and "usable" in a.reason and a.warnings == []
    assert np.array_equal(a.uv, uv) and np.array_equal(a.faces, f) and np.array_equal(a.vmapping, np.arange(len(v)))
    assert a.stats["overlap"] < 1e-4  # a handful of texels on seams: measured 4e-6
    check_atlas(a, v, f)


@pytest.mark.parametrize("mode", ["auto", "unwrap"])
def test_the_atlas_seconds_are_the_calls_own(mode):
    # from the call's start to its end: above 0 (an unwrap takes a worker's start at
    # least), within the wall time the caller sees
    v, f, uv = load("suzanne.ply")
    start = time.perf_counter()
    a = make_atlas(v, f, uv, mode=mode, size=256)
    took = time.perf_counter() - start
    assert a.method == ("kept" if mode == "auto" else "xatlas"), a.reason
    assert 0 < a.stats["seconds"] <= took
    if mode == "unwrap":
        assert a.stats["seconds"] > 0.5 * took  # the unwrap is most of it, not only its start


def test_overlapping_uvs_are_unwrapped_or_kept_with_a_warning():
    """The Duck's own UVs overlap (94 % of the covered texels lie under 2 to 6 faces):
    auto unwraps and says why; keep keeps them and warns."""
    v, f, uv = load("Duck.glb")
    a = make_atlas(v, f, uv, size=1024)
    assert a.method.startswith("xatlas") and a.reason.startswith("the mesh's UVs overlap: 94.4% of the covered texels")
    assert a.stats["overlap"] < 0.01
    assert a.warnings == [f"the mesh's UVs were replaced by an unwrap: {a.reason.split('; ')[0]}"]  # said where the user looks
    check_atlas(a, v, f)
    kept = make_atlas(v, f, uv, mode="keep", size=1024)
    assert kept.method == "kept" and kept.stats["overlap"] > 0.9
    assert len(kept.warnings) == 1 and "overlap" in kept.warnings[0]


def test_overlap_is_measured_on_the_texel_grid():
    from texbake.atlas.uvcheck import coverage_counts, overlap

    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]])
    halves = np.array([[0, 1, 2], [0, 2, 3]])
    assert np.array_equal(coverage_counts(square, halves, 64), np.ones((64, 64)))  # a shared edge counts once
    mirrored = np.concatenate([halves, halves[:, ::-1]])  # the same half twice, once mirrored
    assert overlap(square, mirrored, 64) == (1.0, 2)
    assert overlap(square * 0.5, halves, 64) == (0.0, 1)


def test_a_shared_edge_through_texel_centres_counts_once_from_either_end():
    # a plate's fans: the edge from a cell corner at (0, 30) along the diagonal passes
    # through texel centres of the 1024-grid, and its two faces compute the edge function
    # from different ends (computed from one end each, 76 centres counted twice)
    from texbake.atlas.uvcheck import coverage_counts, overlapping_faces
    from texbake.checks.cad import holed_plate

    v, f = holed_plate(cells=(2, 2), segments=256, offset=0.0)
    top = f[np.abs(v[f][:, :, 2] - 6).max(axis=1) == 0]
    uv = v[:, :2] / 60
    assert coverage_counts(uv, top, 1024).max() == 1
    assert not overlapping_faces(uv, top, 1024).any()


def test_auto_unwraps_repeating_uvs():
    # BoxTextured's UVs run from 0 to 6 (a repeating texture): not an atlas. Welded, as a
    # bake loads it, its sides join across the tiles' borders: not UDIM tiles either
    from texbake.mesh import load_mesh

    m = load_mesh(MESHES / "BoxTextured.glb")
    v, f, uv = m.vertices, m.faces, m.uv
    assert "unit square" in uv_problem(v, f, uv)
    a = make_atlas(v, f, uv, size=256)
    assert a.method == "planar" and "unit square" in a.reason and "CAD-like" in a.reason  # a box: flat sides
    assert "repeat a tiling texture" in a.warnings[0]
    check_atlas(a, v, f)
    with pytest.raises(AtlasError, match="unit square"):
        make_atlas(v, f, uv, mode="keep")


def test_keep_without_uvs_is_an_error_and_bad_mode():
    s = trimesh.creation.icosphere(1)
    with pytest.raises(AtlasError, match="no UVs"):
        make_atlas(s.vertices, s.faces, None, mode="keep")
    with pytest.raises(ParameterError, match="uv"):
        make_atlas(s.vertices, s.faces, None, mode="sometimes")
    with pytest.raises(ParameterError, match="size"):
        make_atlas(s.vertices, s.faces, None, size=0)
    with pytest.raises(AtlasError, match="no faces"):
        make_atlas(s.vertices, np.zeros((0, 3), int))


@pytest.mark.parametrize("charting, method", [("auto", "planar"), ("xatlas", "xatlas-patches")])
def test_unwrap_a_mesh_without_uvs(charting, method):
    v, f, _ = load("fandisk.obj")  # CAD: 52 % of its area on flat regions; 5750 faces: 4 patches for xatlas
    a = make_atlas(v, f, None, size=512, charting=charting)
    assert a.method == method and "no UVs" in a.reason
    assert "CAD-like" in a.reason if charting == "auto" else "charting='xatlas'" in a.reason
    check_atlas(a, v, f)
    assert a.stats["charts"] > 1 and 0.4 < a.stats["utilisation"] and a.stats["stretch"] < 1.2
    assert overlap(a) < 1e-3


@pytest.mark.parametrize("scale, offset", [(1e-6, 0.0), (1.0, 1e8), (1e6, 0.0), (1e20, 0.0)])
def test_tiny_huge_and_far_meshes(scale, offset):
    s = trimesh.creation.icosphere(3)
    v = s.vertices * scale + offset
    a = make_atlas(v, s.faces, mode="unwrap", size=256)
    assert a.method == "xatlas", a.reason
    check_atlas(a, v, s.faces)


@pytest.mark.parametrize("how", ["coincident", "collinear"])
def test_one_degenerate_triangle(how):
    s = trimesh.creation.icosphere(2)
    v = s.vertices.copy()
    a0, b0, c0 = s.faces[0]
    v[b0] = v[a0] if how == "coincident" else v[b0]
    if how == "collinear":
        v[c0] = 0.5 * (v[a0] + v[b0])
    a = make_atlas(v, s.faces, mode="unwrap", size=256)
    assert a.method == "xatlas", a.reason
    check_atlas(a, v, s.faces)


@pytest.mark.xatlas_failure
def test_real_xatlas_hang_is_stopped_at_the_deadline():
    # Without normalisation an infinite vertex (or a mesh 1e20 across) makes xatlas loop.
    # (If a new xatlas stops hanging here, the injected-worker tests below still cover
    # the deadline; this one only records the real failure.)
    s = trimesh.creation.icosphere(2)
    v = s.vertices.astype(np.float32)
    v[0] = np.inf
    start = time.monotonic()
    ok, why = run_xatlas_in_child(v, s.faces, deadline=2.0)
    assert not ok and "timed out after 2 s" in why
    # 2 s of the worker's CPU time (its start-up included): on a loaded machine more wall
    # time, never more than the wall-clock backstop
    assert time.monotonic() - start < Pool.WALL_FACTOR * 2 + 2
    # normalised first, the same xatlas call is fine
    ok, (vm, fa, uv) = run_xatlas_in_child(s.vertices.astype(np.float32), s.faces, deadline=30.0)
    assert ok and fa.shape == s.faces.shape and np.isfinite(uv).all()


# A worker that runs the real one but fails on the ``job`` jobs ("chart" or "pack") of at
# least ``min_faces`` faces: it segfaults, aborts, hangs (asleep, or spinning), raises, or
# ("fold") packs them folded at u = 0.5, the right half's charts onto the left half's.
FAILING_WORKER = """
import os, signal, sys, time
import numpy as np
from texbake.atlas import packworker as worker

how, job, min_faces = sys.argv[1], sys.argv[2], int(sys.argv[3])
real = worker.JOBS[job]


def failing(*args):
    faces = len(args[1]) if job == "chart" else sum(len(f) for _, f in args[0])
    if faces >= min_faces:
        if how == "segfault":
            os.kill(os.getpid(), signal.SIGSEGV)
        elif how == "abort":
            os.abort()
        elif how == "hang":
            time.sleep(600)
        elif how == "spin":
            while True:
                pass
        elif how == "raise":
            raise RuntimeError("injected failure")
        elif how == "fold":
            out, info = real(*args)
            return [(vm, idx, np.column_stack([0.5 - abs(uv[:, 0] - 0.5), uv[:, 1]])) for vm, idx, uv in out], info
    return real(*args)


worker.JOBS[job] = failing
worker.main()
"""


@pytest.fixture
def failing_worker(tmp_path, monkeypatch):
    """``failing_worker(how, job="chart", min_faces=0)``: from then on make_atlas' workers fail so."""
    script = tmp_path / "failing_worker.py"
    script.write_text(FAILING_WORKER)

    def inject(how, job="chart", min_faces=0):
        monkeypatch.setattr(atlas_pack, "WORKER", [sys.executable, str(script), how, job, str(min_faces)])

    return inject


def test_the_injected_worker_is_the_real_one_until_it_fails(failing_worker):
    failing_worker("segfault", min_faces=10**9)  # never
    s = trimesh.creation.icosphere(2)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256)
    assert a.method == "xatlas" and a.reason.startswith("uv='unwrap'; xatlas charts: organic") and "after" not in a.reason
    check_atlas(a, s.vertices, s.faces)


@pytest.mark.parametrize("how, code", [("segfault", -11), ("abort", -6)])
def test_a_crashing_xatlas_charting_gives_planar_charts(failing_worker, how, code):
    failing_worker(how)
    s = trimesh.creation.icosphere(2)  # 320 faces: one piece, no retry in patches
    start = time.monotonic()
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256)
    assert time.monotonic() - start < 10
    assert a.method == "planar"
    assert a.reason.endswith(f"(after: xatlas crashed (exit code {code}))")
    assert a.warnings == [f"the first unwrap failed (xatlas crashed (exit code {code})): planar charts used instead"]
    check_atlas(a, s.vertices, s.faces)
    assert overlap(a) == 0
    ok, why = run_xatlas_in_child(s.vertices.astype(np.float32), s.faces, deadline=30.0)
    assert not ok and why == f"xatlas crashed (exit code {code})"


def test_a_crashing_packer_gives_the_fallback_grid(failing_worker):
    failing_worker("segfault", "pack")  # both chartings end in xatlas' packer
    s = trimesh.creation.icosphere(2)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256)
    assert a.method == "fallback-grid"
    assert a.reason == ("uv='unwrap'; xatlas crashed (exit code -11) while packing; "
                        "xatlas crashed (exit code -11) while packing; used fallback")
    assert a.warnings and a.warnings[0].startswith("fallback atlas: one chart per triangle")
    check_atlas(a, s.vertices, s.faces)


def test_a_crash_in_one_piece_is_retried_in_patches(failing_worker):
    # What icosphere(6) does to the real xatlas: it crashes on the whole mesh, not on patches.
    failing_worker("segfault", min_faces=2 * PATCH_FACES + 1)
    s = trimesh.creation.icosphere(4)  # 5120 faces: 4 patches of 1280
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=512, _patch_faces=None)
    assert a.method == "xatlas-patches"
    assert a.reason.startswith("uv='unwrap'; xatlas charts") and a.reason.endswith(" (after: xatlas crashed (exit code -11))")
    check_atlas(a, s.vertices, s.faces)
    assert a.stats["utilisation"] > 0.5 and a.stats["stretch"] < 1.05
    assert overlap(a) < 1e-3


def test_a_crash_on_a_patch_is_retried_with_smaller_patches(failing_worker):
    failing_worker("segfault", min_faces=1000)
    s = trimesh.creation.icosphere(4)  # 5120 faces: patches of 1280 crash, of 320 do not
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=512, _patch_faces=2000)
    assert a.method == "xatlas-patches"
    assert a.reason.endswith(" (after: xatlas crashed (exit code -11) on a patch of 1280 faces)")
    check_atlas(a, s.vertices, s.faces)
    assert overlap(a) < 1e-3


def test_a_worker_error_is_reported(failing_worker):
    failing_worker("raise")
    s = trimesh.creation.icosphere(2)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256)
    assert a.method == "planar"
    assert a.reason.endswith("(after: xatlas failed (RuntimeError: injected failure))")
    check_atlas(a, s.vertices, s.faces)


def test_an_overlapping_unwrap_is_passed_over_and_never_kept_silently(failing_worker):
    failing_worker("fold", "pack")  # every packing overlaps
    s = trimesh.creation.icosphere(2)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256)
    assert a.method in ("xatlas", "planar")
    assert re.search(r"\(after: xatlas charting's atlas overlaps on \d+\.\d% of its covered texels; planar charting's", a.reason)
    assert a.stats["overlap"] > 0.01
    assert any(w.startswith(f"the atlas' charts overlap on {a.stats['overlap']:.1%}") for w in a.warnings)
    check_atlas(a, s.vertices, s.faces)


@pytest.mark.parametrize("how", ["hang", "spin"])
@pytest.mark.parametrize("job, deadline", [("chart", 8), ("pack", 8)])
def test_a_hanging_worker_is_stopped_at_the_deadline(failing_worker, how, job, deadline):
    # xatlas' charting gets 3/4 of the deadline, the planar charts what is left; packing
    # hangs only after a real charting pass. The deadline is the workers' CPU time: a
    # spinning worker is ended when it has used it, a sleeping one (CPU time would never
    # end it) when as much wall time has passed; on a loaded machine either takes more
    # wall time, never more than the pool's wall-clock backstop.
    failing_worker(how, job)
    s = trimesh.creation.icosphere(4)  # 5120 faces: a timeout is not retried in patches
    start = time.monotonic()
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256, deadline=float(deadline), _patch_faces=None)
    assert time.monotonic() - start < Pool.WALL_FACTOR * deadline + 2
    if job == "chart":  # the planar charts' packing is fine
        assert a.method == "planar" and re.search(r"\(after: xatlas timed out after [0-9.]+ s\)$", a.reason), a.reason
    else:  # both hang in the packer
        assert a.method == "fallback-grid"
        assert re.fullmatch(r"uv='unwrap'; xatlas timed out after [0-9.]+ s while packing; "
                            r"xatlas timed out after [0-9.]+ s while packing; used fallback", a.reason), a.reason
    assert any(w.startswith(f"the unwrap deadline ({deadline} s of CPU time) passed: xatlas timed out") for w in a.warnings), \
        a.warnings
    check_atlas(a, s.vertices, s.faces)
    start = time.monotonic()
    ok, why = run_xatlas_in_child(s.vertices.astype(np.float32), s.faces, deadline=float(deadline))
    assert not ok and why == f"xatlas timed out after {deadline} s"
    assert time.monotonic() - start < Pool.WALL_FACTOR * deadline + 2


def test_deadline_gives_a_fallback_grid():
    s = trimesh.creation.icosphere(3)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256, deadline=1e-3)
    assert a.method == "fallback-grid" and ("timed out" in a.reason or "deadline of 0.001 s passed" in a.reason)
    check_atlas(a, s.vertices, s.faces)
    assert a.stats["charts"] == len(s.faces) and overlap(a) == 0


def test_grid_atlas_of_odd_triangles():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [1e-9, 1e-9, 0]], float)
    f = np.array([[0, 1, 2], [0, 1, 3], [0, 0, 1], [0, 1, 4]])  # ok, collinear, repeated, sliver
    vm, fa, uv = grid_atlas(v, f, 2 / 1024)
    assert np.array_equal(vm[fa], f) and (uv_area(uv, fa) > 0).all() and uv.min() >= 0 and uv.max() <= 1


def test_patch_unwrap_of_a_medium_mesh():
    s = trimesh.creation.icosphere(5)  # 20480 faces: 16 patches
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=1024, padding=2, charting="xatlas")
    assert a.method == "xatlas-patches", a.reason
    check_atlas(a, s.vertices, s.faces)
    assert 0.5 < a.stats["utilisation"] < 1 and a.stats["stretch"] < 1.05
    assert overlap(a) == 0
    # one texel density across patches: UV area / 3D area nearly the same on every face
    ratio = uv_area(a.uv, a.faces) / trimesh.triangles.area(s.vertices[s.faces])
    assert np.percentile(ratio, 95) / np.percentile(ratio, 5) < 1.5


def test_stats_of_an_isometric_layout():
    v = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0, 0], [0.5, 0], [0.5, 0.5], [0, 0.5]])
    s = atlas_stats(v, f, f, uv)
    # float64 round-off (measured 0 here and below)
    assert s["charts"] == 1 and abs(s["utilisation"] - 0.25) < 1e-14 and abs(s["stretch"] - 1) < 1e-14
    assert atlas_stats(v, f, f, uv * [1, 0.5])["stretch"] > 1.05  # squashed
    # isometric shapes at two densities (1/4 and 1/8 UV units per unit): not uniform
    uv2 = np.array([[0, 0], [0.5, 0], [0.5, 0.5], [0.6, 0.6], [0.85, 0.85], [0.6, 0.85]])
    s = atlas_stats(v, f, np.array([[0, 1, 2], [3, 4, 5]]), uv2)
    assert s["charts"] == 2 and abs(s["stretch"] - 1.25) < 1e-14


def test_a_double_sided_mesh_keeps_uvs_that_map_both_sides_to_the_same_texels():
    # Suzanne's own UVs, every face doubled on the same vertices in the opposite winding:
    # the two sides are one surface on the same texels, not overlapping UVs
    v, f, uv = load("suzanne.ply")
    doubled = np.concatenate([f, f[:, ::-1]])
    a = make_atlas(v, doubled, uv, size=256)
    assert a.method == "kept" and a.stats["double_sided_faces"] == len(f), a.reason
    assert a.reason == f"the mesh's UVs are usable; {len(f)} back faces share their front faces' texels"
    assert np.array_equal(v[a.vmapping][a.faces], v[doubled]) and np.array_equal(a.uv[a.faces[len(f):]], uv[doubled[len(f):]])


def test_kept_uvs_that_use_little_of_the_tile_are_kept_with_the_figure_an_unwrap_would_give():
    """Suzanne's own layout shrunk into a corner: kept (usable), with a warning giving its
    utilisation and the estimate of an unwrap's (its own layout, as it came, uses 0.441)."""
    from texbake.mesh import load_mesh

    m = load_mesh(MESHES / "suzanne_blender_uv.obj")  # welded: its 207 islands, not a triangle each
    a = make_atlas(m.vertices, m.faces, m.uv * 0.5, size=1024)
    assert a.method == "kept"
    assert len(a.warnings) == 1, a.warnings
    used, estimate = map(float, re.match(r"the kept UVs use ([\d.]+) of the tile; an unwrap would use about ([\d.]+)",
                                         a.warnings[0]).groups())
    assert used == pytest.approx(0.441 * 0.25, abs=1e-3) and 0.35 < estimate < 0.5  # measured: 0.43
    assert make_atlas(m.vertices, m.faces, m.uv, size=1024).warnings == []  # as it came: no warning


def test_utilisation_far_below_the_charts_promise_is_warned_of():
    from texbake.atlas.decide import _promise_warning
    from texbake.atlas.pack import Unwrapped, UnwrapRequest

    s = trimesh.creation.icosphere(2)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256)
    request = UnwrapRequest(np.asarray(s.vertices, float), np.asarray(s.faces, np.int64), 256, 2)
    packed = Unwrapped(a.vmapping, a.faces, a.uv, a.method, {})
    assert _promise_warning(request, packed, a.stats) == []
    shrunk = Unwrapped(a.vmapping, a.faces, a.uv * 0.4, a.method, {})  # a packer that left most of the tile empty
    (warning,) = _promise_warning(request, shrunk, {**a.stats, "utilisation": a.stats["utilisation"] * 0.16})
    assert warning.startswith(f"utilisation {a.stats['utilisation'] * 0.16:.3f} is far below the ")
    assert warning.endswith("the packing left most of the tile empty")


def test_a_chart_laid_across_the_tile_as_a_strip_is_named_as_the_cause():
    # a CAD beam, two triangles a side: planar charts cannot cut its 100:1 sides between faces
    b = trimesh.creation.box(extents=(1000.0, 10.0, 10.0))
    a = make_atlas(b.vertices, b.faces, mode="unwrap", size=512)
    (warning,) = a.warnings
    assert a.method == "planar" and a.stats["utilisation"] < 0.1
    assert re.search(r": its longest chart runs across the tile at \d+:1, and its faces run along it too far to cut it "
                     r"between them: more edges across it", warning), warning
    # with edges across it every unit the sides are cut into pieces that fill the tile: no warning
    v, f = trimesh.remesh.subdivide_to_size(b.vertices, b.faces, 5.0)
    cut = make_atlas(v, f, mode="unwrap", size=512)
    assert cut.warnings == [] and cut.stats["utilisation"] > 0.5


def test_an_explicit_charting_is_honoured_or_the_atlas_fails(failing_worker):
    s = trimesh.creation.icosphere(2)
    failing_worker("segfault")  # xatlas' charting crashes: not planar charts instead
    with pytest.raises(AtlasError, match=r"^charting='xatlas' cannot be honoured: xatlas crashed \(exit code -11\)$"):
        make_atlas(s.vertices, s.faces, mode="unwrap", size=256, charting="xatlas")
    failing_worker("segfault", "pack")  # no packing: not the grid instead
    with pytest.raises(AtlasError, match=r"^charting='planar' cannot be honoured: xatlas crashed \(exit code -11\) while packing$"):
        make_atlas(s.vertices, s.faces, mode="unwrap", size=256, charting="planar")


def test_the_workers_are_kept_warm_and_a_dead_one_replaced():
    s = trimesh.creation.icosphere(2)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256, charting="planar")
    warm = atlas_pack._warm
    assert warm is not None and a.method == "planar"
    pids = [w.pid for w in warm.all]
    assert 1 <= len(pids) <= 2 and all(w.process.poll() is None for w in warm.all)
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256, charting="planar")
    assert atlas_pack._warm is warm and [w.pid for w in warm.all] == pids  # the same processes, no start-up
    os.kill(pids[0], signal.SIGKILL)  # as a crash, or the end of the thread that started it, would
    warm.all[0].process.wait()
    a = make_atlas(s.vertices, s.faces, mode="unwrap", size=256, charting="planar")
    assert a.method == "planar" and "after" not in a.reason  # not taken for a failure of this unwrap
    assert pids[0] not in [w.pid for w in warm.all] and all(w.process.poll() is None for w in warm.all)
    check_atlas(a, s.vertices, s.faces)
