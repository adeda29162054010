"""Texture throughput against FastNoiseLite (pyfastnoiselite), in one run.

Run: scripts/run python bench/bench_textures.py [--points 4000000] [--runs 5]

Prints, on the same random points: 8-octave turbulence and marble (texbake's compiled
kernels, texbake._native: one thread a core) beside 8-octave value-noise fBm from
pyfastnoiselite (FastNoiseLite's C++ through Cython, one thread), in million samples per
second (medians of wall time, and per CPU-second: on a machine other processes load, the
CPU-seconds say more; the three run in turn, round after round), with the ratios to
FastNoiseLite; the targets are 60 M samples/s (turbulence) and 40 (marble) on two cores,
that is 30 and 20 per CPU-second. Also the first texture evaluation in a fresh
process (nothing is compiled at run time: the kernels come built in the wheel).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _rows import emit

ROOT = Path(__file__).resolve().parents[1]


def rates(functions: dict, n: int, runs: int) -> dict[str, tuple[float, float]]:
    """``{name: (wall, cpu)}``: million samples per second of wall time and per CPU-second
    (every thread of the process), medians of ``runs`` rounds that each run every function
    once, in turn, so that a change in the machine's load falls on all of them alike."""
    for function in functions.values():
        function()  # warm up
    wall: dict[str, list[float]] = {name: [] for name in functions}
    cpu: dict[str, list[float]] = {name: [] for name in functions}
    for _ in range(runs):
        for name, function in functions.items():
            start, start_cpu = time.perf_counter(), time.process_time()
            function()
            wall[name].append(time.perf_counter() - start)
            cpu[name].append(time.process_time() - start_cpu)
    return {name: (n / statistics.median(wall[name]) / 1e6, n / statistics.median(cpu[name]) / 1e6) for name in functions}


def first_call_seconds() -> float:
    """Seconds of the first texture evaluation in a fresh interpreter (imports done)."""
    code = (
        "import time, numpy as np\n"
        "from texbake.textures import evaluate\n"
        "t = time.perf_counter(); evaluate('turbulence', np.zeros((10, 3))); print(time.perf_counter() - t)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=ROOT)
    return float(out.stdout.split()[-1])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=4_000_000)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    from pyfastnoiselite.pyfastnoiselite import FastNoiseLite, FractalType, NoiseType

    from texbake import _native
    from texbake.textures import evaluate
    from texbake.textures.noise import octave_sum

    n = args.points
    points = np.random.default_rng(0).random((n, 3)) * 64
    fnl = FastNoiseLite(0)
    fnl.noise_type = NoiseType.NoiseType_Value
    fnl.fractal_type = FractalType.FractalType_FBm
    fnl.fractal_octaves = 8
    fnl.frequency = 1.0
    coords = np.ascontiguousarray(points.T, dtype=np.float32)

    first_s = statistics.median(first_call_seconds() for _ in range(3))
    measured = rates({"turbulence": lambda: octave_sum(points, None, octaves=8), "marble": lambda: evaluate("marble", points),
                      "reference": lambda: fnl.gen_from_coords(coords)}, n, args.runs)
    turbulence, marble, reference = measured["turbulence"], measured["marble"], measured["reference"]
    cores = _native.cores()
    fnl_row = f"pyfastnoiselite value fBm, 8 octaves, one thread: {reference[0]:.1f} M/s ({reference[1]:.1f} M per CPU-s)"
    rows = [
        (f"8-octave turbulence (value noise), {n / 1e6:g} M points, median", f"{turbulence[0]:.1f} M samples/s",
         f"target >= 60 on 2 cores; {turbulence[1]:.1f} M per CPU-s (target >= 30); {turbulence[0] / reference[0]:.2f}x, "
         f"{turbulence[1] / reference[1]:.2f}x per CPU-s {fnl_row}; {cores} threads"),
        ("marble texture (turbulence + colour map), median", f"{marble[0]:.1f} M samples/s",
         f"target >= 40 on 2 cores; {marble[1]:.1f} M per CPU-s (target >= 20); {marble[0] / reference[0]:.2f}x, "
         f"{marble[1] / reference[1]:.2f}x per CPU-s pyfastnoiselite"),
        ("first texture evaluation in a fresh process", f"{first_s:.3f} s",
         f"compiled ahead of time: no compile, no JIT start; the kernels ran on {_native.instruction_set()}"),
    ]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
