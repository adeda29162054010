"""`texbake batch --jobs 2` beside Blender 4.5 baking the same meshes in one looping process.

Run: scripts/run python bench/bench_batch.py [--runs 3] [--size 512] [--count 50]

``--count`` meshes of 5k-50k faces, written as plain OBJs (positions and faces, no UVs:
both tools unwrap): the public ones of that size among bench/bench_unwrap.py's (the shared
meshes, trimesh's and common-3d-test-models' gathered by bench/meshes.py, the generated CAD
parts), then the smaller public ones subdivided (midpoints: the same surface, 4x the
faces) until they have 5k, then generated shapes (spheres, tori, capsules, plates with
holes). texbake bakes them with ``texbake batch DIR --jobs 2 --no-cache --texture marble``
at ``--size``² (its default quality: one filtered sample a texel; it also writes each
GLB, coverage map and report); Blender (bench/blender_batch.py, one process) imports each,
Smart UV Projects it and bakes the same marble with Cycles at 1 sample, 2 threads. Whole
processes, the runs alternating between the tools; wall time and CPU time (user + system
of the process and every process it waited for). Target: texbake <= 0.6x Blender's wall
and CPU time.

Where the time goes, in the same runs: texbake's batch again with every atlas from a warm
cache (filled by one untimed batch first), that is the batch without its unwrap, at its
default quality and point-sampled (``--no-filtering``: one point sample a texel, as
Blender's one sample); and the CPU time of Blender's Smart UV Project, which its loop prints
for each mesh. Set side by side: texbake's unwrap a mesh (the batch less the cached one)
against Smart UV's, and what an unwrap a mesh may take for the whole batch to be 0.6x
Blender's CPU time, at each quality.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _rows import emit
from bench_unwrap import all_meshes
from meshes import cache_dir

ROOT = Path(__file__).resolve().parents[1]
BLENDER = ROOT / ".venv-blender" / "bin" / "python"
LOW, HIGH = 5_000, 50_000
MARK = "blender_batch:"  # bench/blender_batch.py's lines (it runs in Blender's venv: not imported here)


def subdivided(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    return trimesh.remesh.subdivide(v, f)


def generated() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    import trimesh

    from texbake.checks.cad import holed_plate

    out = {}
    for sub in (4, 5):
        s = trimesh.creation.icosphere(subdivisions=sub)
        out[f"icosphere-{sub}"] = (s.vertices, s.faces)
    for major, minor in ((64, 48), (96, 64), (128, 96), (200, 120)):
        t = trimesh.creation.torus(major_radius=1.0, minor_radius=0.3, major_sections=major, minor_sections=minor)
        out[f"torus-{major}x{minor}"] = (t.vertices, t.faces)
    for count in (48, 96, 160):
        c = trimesh.creation.capsule(height=2.0, radius=0.5, count=(count, count))
        out[f"capsule-{count}"] = (c.vertices, c.faces)
    for cells, segments in (((3, 2), 256), ((5, 4), 128), ((6, 5), 96), ((2, 2), 1024)):
        v, f = holed_plate(cells=cells, segments=segments)
        out[f"plate-{cells[0]}x{cells[1]}-{segments}"] = (v, f)
    return out


def gather(count: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``count`` meshes of LOW-HIGH faces, by name (see the module)."""
    public = all_meshes(None, cache_dir(), 10**7)
    chosen = {k: m for k, m in public.items() if LOW <= len(m[1]) <= HIGH}
    for name, (v, f) in sorted(public.items(), key=lambda kv: len(kv[1][1])):
        if len(f) >= LOW or len(f) < 200:
            continue
        while len(f) < LOW:
            v, f = subdivided(v, f)
        if len(f) <= HIGH:
            chosen[f"{name}-subdivided"] = (v, f)
    for name, m in generated().items():
        if LOW <= len(m[1]) <= HIGH:
            chosen[name] = m
    if len(chosen) < count:
        raise SystemExit(f"bench_batch: only {len(chosen)} meshes of {LOW}-{HIGH} faces (asked for {count})")
    return dict(sorted(chosen.items())[:count])


def write_objs(meshes: dict, folder: Path) -> None:
    folder.mkdir(parents=True)
    for k, (name, (v, f)) in enumerate(sorted(meshes.items())):
        safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in name)
        lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in np.asarray(v, dtype=np.float64)]
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(f)]
        (folder / f"{k:02d}_{safe}.obj").write_text("\n".join(lines) + "\n")


def timed(cmd: list[str], **kw) -> tuple[float, float, str]:
    """``(wall seconds, CPU seconds, standard output)`` of one process and the processes it
    waited for."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=out, stderr=err, **kw)  # files: a full pipe would stall it
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        out.seek(0)
        err.seek(0)
        code = os.waitstatus_to_exitcode(status)
        if code != 0:
            raise SystemExit(f"{cmd[:3]} failed ({code}): {err.read().decode()[-3000:]}")
        return wall, usage.ru_utime + usage.ru_stime, out.read().decode()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--count", type=int, default=50)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    meshes = gather(args.count)
    faces = [len(f) for _, f in meshes.values()]
    with tempfile.TemporaryDirectory() as tmp:
        inp = Path(tmp) / "in"
        write_objs(meshes, inp)
        env = {**os.environ, "TEXBAKE_CACHE": str(Path(tmp) / "cache")}
        texbake = [str(Path(sys.executable).with_name("texbake")), "batch", str(inp), "--out", "OUT", "--jobs", "2",
                   "--no-cache", "--texture", "marble", "--size", str(args.size)]
        cached = [c for c in texbake if c != "--no-cache"]  # the atlases from the cache: the batch less its unwrap
        point = [*cached, "--no-filtering"]
        blender = [str(BLENDER), str(ROOT / "bench" / "blender_batch.py"), str(inp), "OUT", "--size", str(args.size),
                   "--samples", "1"]
        timed([c.replace("OUT", f"{tmp}/filling") for c in cached], env=env)
        ours, warm, points, theirs, smart = [], [], [], [], []
        for run in range(args.runs):
            ours.append(timed([c.replace("OUT", f"{tmp}/ours{run}") for c in texbake], env=env)[:2])
            warm.append(timed([c.replace("OUT", f"{tmp}/cached{run}") for c in cached], env=env)[:2])
            points.append(timed([c.replace("OUT", f"{tmp}/point{run}") for c in point], env=env)[:2])
            if BLENDER.exists():
                bwall, bcpu, printed = timed([c.replace("OUT", f"{tmp}/blender{run}") for c in blender],
                                             cwd=ROOT / "bench")
                theirs.append((bwall, bcpu))
                smart.append(sum(float(line.split()[2]) for line in printed.splitlines() if line.startswith(MARK)))
    n = len(meshes)
    wall, cpu = statistics.median(w for w, _ in ours), statistics.median(c for _, c in ours)
    cwall, ccpu = statistics.median(w for w, _ in warm), statistics.median(c for _, c in warm)
    pwall, pcpu = statistics.median(w for w, _ in points), statistics.median(c for _, c in points)
    what = f"`texbake batch --jobs 2`, {n} meshes of {min(faces)}-{max(faces)} faces, marble {args.size}², median of {args.runs}"
    less = "same, every atlas from a warm cache (the batch less its unwrap)"
    less_point = "same, point-sampled (`--no-filtering`), every atlas from the cache"
    unwrap = f"the unwrap a mesh: texbake's batch less the cached one, {n} meshes"
    spent = f"{1000 * (cpu - ccpu) / n:.0f} CPU-ms ({1000 * (wall - cwall) / n:.0f} ms of the batch's wall)"
    if theirs:
        bwall, bcpu = statistics.median(w for w, _ in theirs), statistics.median(c for _, c in theirs)
        sw = statistics.median(smart)
        allowed, allowed_point = (0.6 * bcpu - ccpu) / n, (0.6 * bcpu - pcpu) / n
        rows = [(what, f"{wall:.1f} s, {cpu:.1f} CPU-s; {wall / bwall:.2f}x wall, {cpu / bcpu:.2f}x CPU",
                 f"Blender 4.5 looping in one process (Smart UV, Cycles 1 sample): {bwall:.1f} s, {bcpu:.1f} CPU-s "
                 "(target <= 0.6x both)"),
                (less, f"{cwall:.1f} s, {ccpu:.1f} CPU-s; {cwall / bwall:.2f}x wall, {ccpu / bcpu:.2f}x CPU",
                 "Blender's loop as above"),
                (less_point, f"{pwall:.1f} s, {pcpu:.1f} CPU-s; {pwall / bwall:.2f}x wall, {pcpu / bcpu:.2f}x CPU",
                 "Blender's loop as above"),
                (unwrap, spent, f"Smart UV Project in Blender's loop: {1000 * sw / n:.0f} CPU-ms; 0.6x Blender's CPU leaves the unwrap "
                 f"{1000 * allowed:.0f} CPU-ms a mesh at the default quality, {1000 * allowed_point:.0f} point-sampled")]
    else:
        rows = [(what, f"{wall:.1f} s, {cpu:.1f} CPU-s", "Blender not set up (scripts/blender): target <= 0.6x its wall and CPU"),
                (less, f"{cwall:.1f} s, {ccpu:.1f} CPU-s", ""),
                (less_point, f"{pwall:.1f} s, {pcpu:.1f} CPU-s", ""),
                (unwrap, spent, "")]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
