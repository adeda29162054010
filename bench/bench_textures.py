"""Texture throughput against FastNoiseLite (pyfastnoiselite), in one run.

Run: scripts/run python bench/bench_textures.py [--points 4000000] [--runs 5]

Prints, on the same random points: 8-octave turbulence and marble (texbake, numba
kernels, 2 threads) beside 8-octave value-noise fBm from pyfastnoiselite (FastNoiseLite's
C++ through Cython, one thread), in million samples per second (medians); the targets are
50 M samples/s (turbulence) and 40 (marble). Also the compile time of the kernels (cache
cleared), the start-up cost of a second process that loads them from the cache, and the
part of it that is numba's own (import and target set-up: the first call of any cached
kernel, however small).
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


def rate(function, n, runs):
    function()  # warm up (and compile)
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return n / statistics.median(times) / 1e6


def first_call_seconds(clear_cache: bool, floor: bool = False) -> float:
    """Seconds of the first texture evaluation in a fresh interpreter (``floor``: of the
    first call of a one-line cached kernel instead: numba's own start, which every
    cached kernel pays once a process)."""
    if clear_cache:
        for cache in (ROOT / "bake" / "textures" / "__pycache__").glob("*.nb*"):
            cache.unlink()
    call = ("from texbake.textures.kernels import box_keep; box_keep(0.5)" if floor  # numba imported in both
            else "evaluate('turbulence', np.zeros((10, 3)))")
    code = (
        "import time, numpy as np\n"
        "from texbake.textures import evaluate\n"
        f"t = time.perf_counter(); {call}; print(time.perf_counter() - t)\n"
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

    compile_s = first_call_seconds(clear_cache=True)
    cached_s = statistics.median(first_call_seconds(clear_cache=False) for _ in range(3))
    floor_s = statistics.median(first_call_seconds(clear_cache=False, floor=True) for _ in range(3))
    turbulence = rate(lambda: octave_sum(points, None, octaves=8), n, args.runs)
    marble = rate(lambda: evaluate("marble", points), n, args.runs)
    reference = rate(lambda: fnl.gen_from_coords(coords), n, args.runs)
    rows = [
        (f"8-octave turbulence (value noise), {n / 1e6:g} M points, median", f"{turbulence:.1f} M samples/s",
         f"target >= 50; pyfastnoiselite value fBm, 8 octaves: {reference:.1f} M samples/s"),
        ("marble texture (turbulence + colour map), median", f"{marble:.1f} M samples/s", "target >= 40 M samples/s"),
        ("noise kernels: compile / first call in a second process", f"{compile_s:.1f} s / {cached_s:.2f} s",
         f"cached on disk by numba; aim <= 0.15 s; numba's own start (a one-line cached kernel): {floor_s:.2f} s"),
    ]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
