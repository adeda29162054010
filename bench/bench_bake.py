"""End-to-end bake benchmark against the references of the baking-core issue.

Run: scripts/run python bench/bench_bake.py [--runs 5] [--skip-8k]

Prints, side by side with their targets and references:
- whole process `texbake bake suzanne_blender_uv.obj --texture checker --size 2048`
  (1 sample per texel, its own UVs), median wall time; Blender 4.5 bakes a noise-marble
  emission map of the same size on the same mesh in 3.5 s (target: under 1.5 s);
- texel lookup throughput (texel centres located per second, one thread: the grid's
  searches, once Embree's rays) on the same mesh (target: 15 M/s);
- peak resident memory of an 8192 x 8192 bake and of a 16384 x 16384 one, each in its own
  process (target: under 3 GB; ``--skip-8k`` skips both).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"


def whole_process(runs: int) -> float:
    times = []
    with tempfile.TemporaryDirectory() as out:
        for _ in range(runs):
            start = time.perf_counter()
            subprocess.run(
                [sys.executable, "-m", "texbake.cli", "bake", str(MESH), "--texture", "checker", "--size", "2048", "--out", out],
                check=True, capture_output=True,
            )
            times.append(time.perf_counter() - start)
    return statistics.median(times)


def lookup_rate(runs: int) -> float:
    from texbake.mesh.load import load_mesh
    from texbake.sampling.lookup import Tile, UVLookup, sample_offsets, sample_uv

    mesh = load_mesh(MESH)
    lookup = UVLookup(mesh.uv, mesh.faces)
    uv = sample_uv(Tile(0, 2048), np.arange(2048 * 2048), 2048, 2048, sample_offsets(1))
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        lookup.faces_at(uv)
        times.append(time.perf_counter() - start)
    return len(uv) / statistics.median(times)


def peak_memory(size: int) -> float:
    code = (
        "import resource, sys, tempfile\n"
        "from bake import bake_mesh\n"
        f"r = bake_mesh({str(MESH)!r}, 'checker', size={size})\n"
        "with tempfile.TemporaryDirectory() as d: r.save(d)\n"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return int(out.stdout.split()[-1]) * 1024 / 1e9


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--skip-8k", action="store_true")
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    rows = [
        ("whole process, checker 2048², suzanne_blender_uv.obj (own UVs), median", f"{whole_process(args.runs):.2f} s",
         "target < 1.5 s; Blender 4.5 noise-marble bake: 3.5 s"),
        ("texel lookup (grid search, one thread), median", f"{lookup_rate(args.runs) / 1e6:.1f} M points/s", "target > 15 M/s (Embree rays: 11.5 M/s)"),
    ]
    if not args.skip_8k:
        for size in (8192, 16384):
            rows.append((f"{size}² bake + save, peak RSS", f"{peak_memory(size):.2f} GB", "target < 3 GB"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
