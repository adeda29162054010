"""Fans of slivers: `texbake bake` of cylinders and cones whose caps and apexes are fans of
thousands of slivers round one vertex (a turned part's faces, a drill point).

Run: scripts/run python bench/bench_fans.py [--size 1024] [--runs 1] [--shapes cylinder-20000 cone-20000 ...]

Each shape (trimesh's ``cylinder`` or ``cone`` of that many segments, written as an OBJ
without UVs) is baked by ``texbake bake --texture checker --no-cache`` in its own process:
wall time, the process' peak RSS, and the report's atlas and tile-loop seconds. Beside each,
stop 44's code (62d41b5) on the same command, measured once on this machine (2026-12-06):
there the UV grid listed each sliver in every cell of its box, and the outline walk scanned
a fan for each edge's reverse, both quadratic in the fan. Target: time and memory that grow
with the faces, not with the fan.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

from _rows import emit
from bench_blender import timed

# stop 44's figures (62d41b5, same command, 1024²): a MemoryError is a failed bake
BEFORE = {
    "cylinder-20000": "20.0-21.3 s, 546 MB",
    "cylinder-200000": "MemoryError after 80 s (a UV grid of 8.8e9 entries)",
    "cone-20000": "38.1 s, 562 MB",
}


def write_shape(name: str, path: Path) -> int:
    import trimesh

    kind, segments = name.rsplit("-", 1)
    make = {"cylinder": lambda n: trimesh.creation.cylinder(radius=1.0, height=0.5, sections=n),
            "cone": lambda n: trimesh.creation.cone(radius=1.0, height=2.0, sections=n)}[kind]
    mesh = make(int(segments))
    mesh.export(path)
    return len(mesh.faces)


def bake(path: Path, out: Path, size: int) -> tuple[float, float, dict]:
    """``(wall seconds, peak RSS in MB, report)`` of one ``texbake bake`` process."""
    cmd = [str(Path(sys.executable).with_name("texbake")), "bake", str(path), "--out", str(out), "--texture", "checker",
           "--size", str(size), "--no-cache"]
    wall, peak = timed(cmd)
    return wall, peak, json.loads((out / "report.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--shapes", nargs="+", default=["cylinder-20000", "cone-20000", "cylinder-200000"])
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.shapes:
            path = Path(tmp) / f"{name}.obj"
            faces = write_shape(name, path)
            runs = [bake(path, Path(tmp) / f"out-{name}-{i}", args.size) for i in range(args.runs)]
            wall = statistics.median(r[0] for r in runs)
            peak = max(r[1] for r in runs)
            seconds = runs[0][2]["seconds"]
            figure = f"`texbake bake` {name} ({faces} faces), checker {args.size}², no cache"
            ours = (f"{wall:.1f} s, {peak:.0f} MB (atlas {seconds['atlas']:.1f} s, "
                    f"tiles {seconds['tiles (wall)']:.1f} s)")
            before = BEFORE.get(name, "not measured") if args.size == 1024 else "not measured at this size"
            rows.append((figure, ours, f"stop 44 (62d41b5): {before}; target: linear in the faces"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
