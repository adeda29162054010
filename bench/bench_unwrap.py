"""Unwrap benchmark: texbake's patch-parallel xatlas unwrap against plain xatlas.

Run: scripts/run python bench/bench_unwrap.py [--runs 3] [--quick]

On suzanne_blender_uv.obj (63k faces) with its UVs dropped, prints the median wall time
of `make_atlas(mode="unwrap", size=2048)` beside the target (2.5 s) and beside one run of
plain `xatlas.parametrize` on the same mesh (about 19 s here; `--quick` skips it), with
chart count, utilisation and stretch for both.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from bake.atlas import _chart_patches, _run_children, atlas_stats, make_atlas, _normalised
from bake.load import load_mesh

MESH = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "suzanne_blender_uv.obj"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="skip plain xatlas (about 19 s)")
    args = parser.parse_args()
    mesh = load_mesh(MESH)
    times, atlas = [], None
    for _ in range(args.runs):
        start = time.perf_counter()
        atlas = make_atlas(mesh.vertices, mesh.faces, None, mode="unwrap", size=2048)
        times.append(time.perf_counter() - start)
    rows = [("texbake make_atlas (patches, 2 processes)", statistics.median(times), atlas.stats)]
    if not args.quick:
        start = time.perf_counter()
        (result,) = _run_children(_chart_patches, [(_normalised(mesh.vertices), [mesh.faces.astype(np.uint32)], 2048, 2)], 600)
        seconds = time.perf_counter() - start
        vmap, idx, texels, (w, h) = result[0]
        stats = atlas_stats(mesh.vertices, mesh.faces, idx.astype(np.int64), texels / max(w, h))
        rows.append(("plain xatlas, one process (reference)", seconds, stats))
    print(f"mesh: {MESH.name}, {len(mesh.faces)} faces; target: under 2.5 s")
    print(f"{'unwrap':<44} {'seconds':>8} {'charts':>7} {'utilisation':>12} {'stretch':>8}")
    for name, seconds, s in rows:
        print(f"{name:<44} {seconds:>8.2f} {s['charts']:>7} {s['utilisation']:>12.3f} {s['stretch']:>8.3f}")


if __name__ == "__main__":
    main()
