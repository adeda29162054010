"""Unwrap benchmark: make_atlas(mode="unwrap") on Suzanne (63k faces) vs plain xatlas.

    .venv/bin/python bench/bench_unwrap.py [--quick] [--runs N] [--size S]

Loads ``../shared/meshes/suzanne_blender_uv.obj`` with trimesh (process=False), drops
its UVs and welds the vertices by exact position (the OBJ's corners are split by its
UV seams; without welding every triangle would be its own chart). ``--quick`` skips the
plain ``xatlas.parametrize`` reference run (about 12-19 s here).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _rows import emit  # noqa: E402

from bake.atlas import atlas_stats, make_atlas  # noqa: E402

MESH = Path("/work/shared/meshes/suzanne_blender_uv.obj")
TARGET = 2.5  # seconds on 2 cores


def load():
    import trimesh

    m = trimesh.load(MESH, process=False, skip_materials=True)
    v = np.asarray(m.vertices, dtype=np.float64)
    f = np.asarray(m.faces, dtype=np.int64)
    u, inverse = np.unique(v, axis=0, return_inverse=True)
    return u, inverse.reshape(-1)[f]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the plain xatlas.parametrize run")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = ap.parse_args()

    v, f = load()
    if not args.markdown:
        print(f"{MESH.name}: {len(v)} vertices, {len(f)} faces; size {args.size}, {args.runs} runs")
    times, atlas = [], None
    for _ in range(args.runs):
        t = time.perf_counter()
        atlas = make_atlas(v, f, mode="unwrap", size=args.size, workers=2)
        times.append(time.perf_counter() - t)
    ours = statistics.median(times)
    if not args.markdown:
        print(f"make_atlas: {atlas.method} ({atlas.reason}); runs {', '.join(f'{t:.2f}' for t in times)} s")

    ref = None
    if not args.quick:
        import xatlas

        t = time.perf_counter()
        vm, idx, uv = xatlas.parametrize(v.astype(np.float32), f.astype(np.uint32))
        seconds = time.perf_counter() - t
        ref = atlas_stats(v, f, idx.astype(np.int64), uv.astype(np.float64))
        ref["seconds"] = seconds

    def cell(x, fmt):
        return "-" if x is None else format(x, fmt)

    stats = atlas.stats
    rows = [(
        "unwrap of the same mesh, UVs dropped, median",
        f"{ours:.2f} s (utilisation {stats['utilisation']:.2f}, stretch {stats['stretch']:.3f})",
        f"target < {TARGET} s; plain xatlas.parametrize: {cell(ref and ref['seconds'], '.1f')} s "
        f"(utilisation {cell(ref and ref['utilisation'], '.2f')}, stretch {cell(ref and ref['stretch'], '.3f')})",
    )]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
