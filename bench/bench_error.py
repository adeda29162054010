"""Error against run time: one filtered sample against 1, 4 and 16 point samples.

    scripts/run python bench/bench_error.py [--sizes 512,1024] [--repeats 3]
        [--textures checker,wood,marble,turbulence] [--meshes suzanne_blender_uv.obj,...]

Per mesh (in ``../shared/meshes``, their own UVs where usable) x texture x size: the RMSE
in linear colour of 1 filtered sample and of 1, 4 and 16 stratified point samples a texel
against a converged point-sampled reference (``texbake.checks.sweep``: 256 samples a texel
at the largest size, 1024 at half of it), all scored on the same texels (those the
reference and all four bakes cover); their times (median whole bakes with a pre-made
atlas, runs taking turns); and the ratio of each bake's own error estimate
(``report.json`` ``error_estimate``) to its measured RMSE. The aim from issue 12: one
filtered sample reaches the 16-point-sample RMSE (ratio <= 1.0) in <= 1/8 of its time.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from texbake.checks.sweep import Setting, run_sweep  # noqa: E402

MESHES = ROOT.parent / "shared" / "meshes"


def settings(size: int) -> dict[str, Setting]:
    return {"1 filtered": Setting(1, True, size=size), "1 point": Setting(1, False, size=size),
            "4 point": Setting(4, False, size=size), "16 point": Setting(16, False, size=size)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="512,1024")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--textures", default="checker,wood,marble,turbulence")
    parser.add_argument("--meshes", default="suzanne_blender_uv.obj")
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    for mesh in args.meshes.split(","):
        for texture in args.textures.split(","):
            grid = {size: settings(size) for size in sizes}
            measured, info = run_sweep(MESHES / mesh, texture, settings=[s for g in grid.values() for s in g.values()],
                                       repeats=args.repeats)
            by = {r.setting: r for r in measured}
            for size in sizes:
                r = {name: by[s] for name, s in grid[size].items()}
                one, sixteen = r["1 filtered"], r["16 point"]
                ratio, speed = one.rmse / sixteen.rmse, sixteen.seconds / one.seconds
                where = f"{Path(mesh).stem} {texture} {size}²"
                rows.append((
                    f"{where}: RMSE of 1 filtered / 1 / 4 / 16 point samples ({info[size]['texels']} texels, all four)",
                    " / ".join(f"{x.rmse:.2e}" for x in r.values()),
                    f"1 filtered = {ratio:.2f}x the 16-sample RMSE in 1/{speed:.1f} of its time "
                    f"(aim <= 1.0x in <= 1/8: {'met' if ratio <= 1.0 and speed >= 8 else 'not met'})",
                ))
                rows.append((
                    f"{where}: seconds of 1 filtered / 1 / 4 / 16 point samples",
                    " / ".join(f"{x.seconds:.2f}" for x in r.values()),
                    "estimate / RMSE " + " / ".join(f"{x.ratio:.2f} ({x.method})" for x in r.values()) + " (aim 0.5-2)",
                ))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
