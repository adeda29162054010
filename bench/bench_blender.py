"""texbake beside Blender 4.5 (Cycles) on the same bake, whole processes, in one run.

Run: scripts/run python bench/bench_blender.py [--runs 5] [--size 2048] [--mesh PATH]

A turbulence marble baked into the own UVs of the 63k-face Suzanne at ``--size``², at
1 sample a texel (texbake's ``default``: one filtered sample; Cycles: 1 sample) and 16
(``--quality final``; Cycles: 16 samples). Each run starts a fresh process for each
tool, as a user does (start-up, mesh reading, baking, writing the PNG and, for texbake,
the GLB); the runs alternate between the tools so that a busy neighbour slows both
alike. Prints the median wall time and peak RSS of each, and texbake's time over
Blender's (the targets: <= 0.5 at 1 sample, <= 0.35 at 16). Blender runs from ``.venv-blender`` (``scripts/blender``
makes it; ``bpy`` is an optional bench extra, never a test dependency): without it only
texbake's column is printed.

Then the same bake warm, as a pipeline makes it: each tool repeats the whole bake (mesh
import, bake, save; Blender from its factory settings) ``--runs`` + 1 times in one
process, and the median of all but the first is compared (texbake through its library
call, without the atlas cache the command line uses; one process after the other).
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"
BLENDER = ROOT / ".venv-blender" / "bin" / "python"


def timed(cmd: list[str]) -> tuple[float, float]:
    """``(wall seconds, peak RSS in MB)`` of one process (``wait4``'s rusage: this child only)."""
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{cmd[0]} failed ({proc.returncode}): {proc.stderr.read().decode()[-2000:] if proc.stderr else ''}")
    return seconds, usage.ru_maxrss / 1024


# texbake's warm process: the same bake and save again in one interpreter, as a pipeline's
# library call makes it (each time's seconds, one a line)
WARM = """
import sys, time
from texbake import bake_mesh
mesh, size, quality, out, repeat = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], int(sys.argv[5])
for _ in range(repeat):
    start = time.perf_counter()
    bake_mesh(mesh, "marble", size=size, quality=quality).save(out)
    print(f"{time.perf_counter() - start:.4f}", flush=True)
"""


def warm(cmd: list[str]) -> float:
    """The median seconds of the second and later bakes that ``cmd`` prints, one a line
    (among whatever else it prints: Blender's importer reports its own time)."""
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.splitlines()
    seconds = [float(line) for line in out if re.fullmatch(r"\d+\.\d+", line.strip())]
    return statistics.median(seconds[1:])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--mesh", type=Path, default=MESH)
    ap.add_argument("--blender", type=Path, default=BLENDER)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    blender = args.blender if args.blender.exists() else None
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for samples, quality in ((1, "default"), (16, "final")):
            ours = [sys.executable, "-m", "texbake.cli", "bake", str(args.mesh), "--texture", "marble", "--size", str(args.size),
                    "--quality", quality, "--out", f"{tmp}/texbake"]
            theirs = None if blender is None else [str(blender), str(ROOT / "bench" / "blender_bake.py"), str(args.mesh),
                                                    f"{tmp}/blender.png", "--size", str(args.size), "--samples", str(samples)]
            t_ours, t_theirs = [], []
            timed(ours)  # warm the file cache and the kernel cache alike
            if theirs:
                timed(theirs)
            for _ in range(args.runs):
                t_ours.append(timed(ours))
                if theirs:
                    t_theirs.append(timed(theirs))
            s, mb = (statistics.median(x) for x in zip(*t_ours, strict=True))
            figure = f"whole process, marble {args.size}², {args.mesh.name}, {samples} sample{'s' if samples > 1 else ''} ({quality}), median of {args.runs}"
            if theirs:
                bs, bmb = (statistics.median(x) for x in zip(*t_theirs, strict=True))
                rows.append((figure, f"{s:.2f} s, {mb:.0f} MB; {s / bs:.2f}x Blender's",
                             f"Blender 4.5 Cycles {bs:.2f} s, {bmb:.0f} MB (target <= {0.5 if samples == 1 else 0.35}x)"))
            else:
                rows.append((figure, f"{s:.2f} s, {mb:.0f} MB", "Blender not installed (scripts/blender)"))
            # warm: both tools bake again in a process that has done it once (imports, kernels, Cycles loaded)
            repeat = str(args.runs + 1)
            w_ours = warm([sys.executable, "-c", WARM, str(args.mesh), str(args.size), quality, f"{tmp}/warm", repeat])
            figure = f"same, {samples} sample{'s' if samples > 1 else ''}, warm process (the bake again in one process: load, bake, save), median of {args.runs}"
            if theirs:
                w_theirs = warm([*theirs, "--repeat", repeat])
                rows.append((figure, f"{w_ours:.2f} s; {w_ours / w_theirs:.2f}x Blender's", f"Blender 4.5 Cycles {w_theirs:.2f} s, warm too"))
            else:
                rows.append((figure, f"{w_ours:.2f} s", "Blender not installed (scripts/blender)"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
