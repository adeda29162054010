"""MaterialX: the ported noises' speed against the literal GLSL transcription (the test's
reference), and MaterialX's marble example baked against texbake's own marble material.

    scripts/run python bench/bench_mtlx.py [--size 1024] [--rounds 3] [--points 20000]

Noises: CPU seconds (``time.process_time``) per million points of each ``texbake.mtlx.noise``
function, vectorised (numpy), and of ``tests/texbake/mtlx/glsl_reference.py``, one point at
a time in Python, on the same points, with their largest difference. Bake: MaterialX's
``standard_surface_marble_solid.mtlx`` (a 3-octave fractal3d through sin and power, the
base colour) onto suzanne_blender_uv.obj, beside texbake's built-in ``polished_marble``
(compiled kernels, six channels), each the median over the rounds of the process's
CPU seconds; no target: the MaterialX evaluation is numpy, not compiled, in this version.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from _rows import emit

import texbake
from texbake.mtlx import noise
from texbake.mtlx.material import material_from_mtlx

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"
MARBLE = ROOT / "tests" / "data" / "mtlx" / "standard_surface_marble_solid.mtlx"
sys.path.insert(0, str(ROOT / "tests" / "texbake" / "mtlx"))
import glsl_reference as ref  # noqa: E402


def cpu(f, *args):
    start = time.process_time()
    out = f(*args)
    return time.process_time() - start, out


def noise_rows(n: int) -> list:
    p = np.random.default_rng(0).uniform(-40.0, 40.0, (n, 3))
    reference_points = p[: max(n // 10, 1)]  # the per-point reference is slow: a tenth, scaled
    cases = [("perlin float (noise3d)", lambda q: noise.perlin_float(q), ref.mx_perlin_noise_float),
             ("perlin vec3 (noise3d vector3)", lambda q: noise.perlin_vec3(q), ref.mx_perlin_noise_vec3),
             ("cell (cellnoise3d)", lambda q: noise.cell_float(q), ref.mx_cell_noise_float),
             ("fractal, 3 octaves (fractal3d)", lambda q: noise.fractal_float(q / 8, 3, 2.0, 0.5),
              lambda q: ref.mx_fractal3d_noise_float(q / 8, 3, 2.0, 0.5)),
             ("worley (worleynoise3d)", lambda q: noise.worley(q, 1.0, 0), lambda q: ref.mx_worley_noise_float(q, 1.0, 0))]
    rows = []
    for name, ours, theirs in cases:
        t_ours, got = cpu(ours, p)
        t_ref, expected = cpu(lambda q, f=theirs: np.array([f(x) for x in q]), reference_points)
        diff = float(np.abs(np.asarray(got)[: len(reference_points)] - expected).max())
        rows.append((f"mtlx noise {name}, CPU-s per million points ({n} points; the reference on {len(reference_points)})",
                     f"{t_ours / n * 1e6:.2f} s", f"literal GLSL in Python {t_ref / len(reference_points) * 1e6:.1f} s "
                     f"({t_ref / len(reference_points) / (t_ours / n):.0f}x); max |difference| {diff:.1e}"))
    return rows


def bake_rows(size: int, rounds: int) -> list:
    materials = {"MaterialX marble (numpy)": material_from_mtlx(MARBLE), "texbake polished_marble (compiled)": "polished_marble"}
    times: dict[str, list[float]] = {}
    for material in materials.values():  # warm-up: the atlas, tables
        texbake.bake_mesh(MESH, material=material, size=size)
    for _ in range(rounds):
        for name, material in materials.items():
            t, _ = cpu(texbake.bake_mesh, MESH, {"material": material, "size": size})
            times.setdefault(name, []).append(t)
    ours, theirs = (statistics.median(times[k]) for k in materials)
    return [(f"bake of MaterialX's standard_surface_marble_solid.mtlx, {size}², {MESH.name}, median of {rounds}",
             f"{ours:.2f} CPU-s", f"texbake's polished_marble {theirs:.2f} CPU-s ({ours / theirs:.2f}x)")]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--points", type=int, default=20_000)
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    emit(noise_rows(args.points) + bake_rows(args.size, args.rounds), args.markdown)


if __name__ == "__main__":
    main()
