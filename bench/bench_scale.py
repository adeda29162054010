"""How the per-face stages grow with the faces: bakes of meshes of 256k to 5M faces.

Run: scripts/run python bench/bench_scale.py [--faces 256k 1M 2M 5M] [--size 1024] [--runs 1]

Each mesh is a wavy height field over the unit square, two triangles a grid cell, with
its own UVs (the cell's position: usable, so the bake keeps them), written once as an
OBJ into ``$TMPDIR/texbake-scale`` and kept there. Each size is baked at ``--size``
with the default settings in its own process, after a small bake that loads the
compiled kernels (their start is not the stages' cost). Prints each stage's seconds
(the bake's report) and, between consecutive sizes, the slope ``k`` of log time against
log faces (1.0: linear), and from the first size to the last; the targets: ``k <= 1.05``
per stage between 1M and 5M faces, and 2M faces baked in 8 s or less.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
WARM_MESH = ROOT.parent / "shared" / "meshes" / "ico4uv.obj"
STAGES = ("load", "atlas", "normals", "prepare", "lookup", "tiles (wall)", "margin", "estimate")
COUNTS = {"256k": 256_000, "1M": 1_000_000, "2M": 2_000_000, "5M": 5_000_000}

# The child also takes each stage's process CPU time (the stages before the tiles run in
# one thread; on a loaded machine CPU time shows the work where wall time shows the load).
CHILD = """
import contextlib, json, sys, time
import texbake
from texbake import pipeline
cpu = {}
wall_stage = pipeline.Timer.stage

@contextlib.contextmanager
def stage(self, name):
    start = time.process_time()
    with wall_stage(self, name):
        yield
    cpu[name] = cpu.get(name, 0.0) + time.process_time() - start

pipeline.Timer.stage = stage
texbake.bake_mesh(sys.argv[2], size=16)  # the kernels loaded
cpu.clear()
start, start_cpu = time.perf_counter(), time.process_time()
result = texbake.bake_mesh(sys.argv[1], size=int(sys.argv[3]))
wall, total_cpu = time.perf_counter() - start, time.process_time() - start_cpu
print(json.dumps({"wall": wall, "cpu_total": total_cpu, "seconds": result.report["seconds"], "cpu": cpu,
                  "faces": int(len(result.mesh.faces)), "atlas": result.report["atlas"]["method"]}))
"""


def grid_obj(faces: int, folder: Path) -> Path:
    """An OBJ of about ``faces`` triangles (a square grid of cells), made once."""
    side = int(round(math.sqrt(faces / 2)))
    path = folder / f"grid_{side}.obj"
    if path.exists():
        return path
    t = np.linspace(0.0, 1.0, side + 1)
    x, y = np.meshgrid(t, t)
    z = 0.05 * np.sin(12.0 * x) * np.cos(9.0 * y)
    vertices = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    index = (np.arange(side)[:, None] * (side + 1) + np.arange(side)).ravel() + 1  # 1-based lower-left corners
    quads = np.stack([index, index + 1, index + side + 2, index + side + 1], axis=1)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    corners = np.repeat(tris, 2, axis=1)  # "v/vt": the UV of a vertex has its index
    tmp = path.with_suffix(".tmp")
    with open(tmp, "w") as f:
        f.write(("v %.7f %.7f %.7f\n" * len(vertices)) % tuple(vertices.ravel()))
        f.write(("vt %.7f %.7f\n" * len(vertices)) % tuple(vertices[:, :2].ravel()))
        f.write(("f %d/%d %d/%d %d/%d\n" * len(tris)) % tuple(corners.ravel().tolist()))
    tmp.rename(path)
    return path


def bake(path: Path, size: int) -> dict:
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", CHILD, str(path), str(WARM_MESH), str(size)], capture_output=True, text=True,
                          check=False)
    if done.returncode:
        raise SystemExit(f"bake of {path} failed:\n{done.stderr[-3000:]}")
    out = json.loads(done.stdout.splitlines()[-1])
    out["process"] = time.perf_counter() - start
    return out


def slope(a: dict, b: dict, stage: str, what: str = "seconds") -> float:
    ta, tb = a[what].get(stage, 0.0), b[what].get(stage, 0.0)
    if ta <= 0 or tb <= 0:
        return float("nan")
    return math.log(tb / ta) / math.log(b["faces"] / a["faces"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", nargs="+", default=list(COUNTS), choices=list(COUNTS))
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--runs", type=int, default=1, help="bakes of each size, alternating sizes: each figure their median")
    args = parser.parse_args()
    folder = Path(tempfile.gettempdir()) / "texbake-scale"
    folder.mkdir(exist_ok=True)
    paths = [grid_obj(COUNTS[name], folder) for name in args.faces]
    runs: list[list[dict]] = [[] for _ in paths]
    for _ in range(args.runs):  # the sizes in turn, so that a busy spell of a shared machine falls on all of them
        for path, done in zip(paths, runs, strict=True):
            done.append(bake(path, args.size))
            r = done[-1]
            print(f"{r['faces']:>9,} faces ({r['atlas']}): bake {r['wall']:.2f} s, process {r['process']:.2f} s", flush=True)
    results = [median_run(done) for done in runs]
    for what, title in (("seconds", "wall seconds"), ("cpu", "CPU seconds (the tiles': of every thread)")):
        table(results, what, title)


def median_run(done: list[dict]) -> dict:
    """One size's runs as one: the median of each figure."""
    out = dict(done[0])
    for key in ("wall", "cpu_total", "process"):
        out[key] = statistics.median(r[key] for r in done)
    for what in ("seconds", "cpu"):
        out[what] = {stage: statistics.median(r[what].get(stage, 0.0) for r in done) for stage in done[0][what]}
    return out


def table(results: list[dict], what: str, title: str) -> None:
    """Each stage's ``what`` (seconds or cpu) at each size, and the slopes between sizes."""
    pairs = list(zip(results, results[1:], strict=False))
    if len(results) > 2:  # and from the first size to the last (the target's 1M to 5M)
        pairs.append((results[0], results[-1]))
    print(f"\n{title}\n{'stage':<14}" + "".join(f"{r['faces'] / 1e6:>9.2f}M " for r in results)
          + "".join(f"  k {a['faces'] / 1e6:.2g}-{b['faces'] / 1e6:.2g}M" for a, b in pairs))
    total = "wall" if what == "seconds" else "cpu_total"
    for stage in [*STAGES, "bake"]:
        values = [{"bake": r[total]} if stage == "bake" else r[what] for r in results]
        row = "".join(f"{v.get(stage, float('nan')):>9.2f}s " for v in values)
        ends = list(zip(values, values[1:], strict=False)) + ([(values[0], values[-1])] if len(values) > 2 else [])
        ks = "".join(f"{slope({'faces': a['faces'], what: va}, {'faces': b['faces'], what: vb}, stage, what):>12.2f}"
                     for (a, b), (va, vb) in zip(pairs, ends, strict=True))
        print(f"{stage:<14}{row}{ks}")


if __name__ == "__main__":
    main()
