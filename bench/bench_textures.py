"""Texture throughput against FastNoiseLite (pyfastnoiselite), in one run.

Run: scripts/run python bench/bench_textures.py [--points 4000000] [--runs 5]

Prints, on the same random points: 8-octave turbulence and marble (texbake, numba
kernels, 2 threads) beside 8-octave value-noise fBm from pyfastnoiselite (FastNoiseLite's
C++ through Cython, one thread), in million samples per second (medians); the target is
50 M samples/s. Also the compile time of the kernels (cache cleared) and the start-up cost
of a second process that loads them from the cache.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def rate(function, n, runs):
    function()  # warm up (and compile)
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return n / statistics.median(times) / 1e6


def first_call_seconds(clear_cache: bool) -> float:
    """Seconds of the first texture evaluation in a fresh interpreter."""
    if clear_cache:
        for cache in (ROOT / "bake" / "textures" / "__pycache__").glob("noise.*.nb*"):
            cache.unlink()
    code = (
        "import time, numpy as np\n"
        "from bake.textures import evaluate\n"
        "t = time.perf_counter(); evaluate('turbulence', np.zeros((10, 3))); print(time.perf_counter() - t)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=ROOT)
    return float(out.stdout.split()[-1])


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=4_000_000)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    from pyfastnoiselite.pyfastnoiselite import FastNoiseLite, FractalType, NoiseType

    from bake.textures import evaluate
    from bake.textures.noise import octave_sum

    n = args.points
    points = np.random.default_rng(0).random((n, 3)) * 64
    fnl = FastNoiseLite(0)
    fnl.noise_type = NoiseType.NoiseType_Value
    fnl.fractal_type = FractalType.FractalType_FBm
    fnl.fractal_octaves = 8
    fnl.frequency = 1.0
    coords = np.ascontiguousarray(points.T, dtype=np.float32)

    compile_s = first_call_seconds(clear_cache=True)
    cached_s = first_call_seconds(clear_cache=False)
    rows = [
        ("texbake turbulence, 8 octaves (value noise)", rate(lambda: octave_sum(points, None, octaves=8), n, args.runs)),
        ("texbake marble texture (turbulence + colour map)", rate(lambda: evaluate("marble", points), n, args.runs)),
        ("pyfastnoiselite value fBm, 8 octaves (reference)", rate(lambda: fnl.gen_from_coords(coords), n, args.runs)),
    ]
    print(f"{n} points, medians of {args.runs} runs; target: 50 M samples/s on 2 cores")
    for name, r in rows:
        print(f"{name:<52} {r:8.1f} M samples/s")
    print(f"{'kernel compile, first call with the cache cleared':<52} {compile_s:8.2f} s")
    print(f"{'first call in a second process (cache loaded)':<52} {cached_s:8.2f} s")


if __name__ == "__main__":
    main()
