"""Error against run time: footprint filtering against supersampling, and the presets.

    scripts/run python bench/bench_error.py [--size 1024] [--repeats 3] [--textures marble,checker]

On ``../shared/meshes/suzanne_blender_uv.obj`` (its own UVs), for each texture: the quality
presets (``draft``, ``default`` = 1 filtered sample, ``final`` = 16 point samples) and 4
point samples, timed as whole bakes with a pre-made atlas (medians, runs taking turns),
their RMSE in linear colour against a converged 256-sample point-sampled reference, and
the error estimate each bake puts in its report. The aim from the issue: one filtered
sample reaches the error of 16-sample supersampling in at most 1/8 of its time.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bake.checks.sweep import Setting, run_sweep  # noqa: E402
from bake.quality import PRESETS  # noqa: E402

MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=1024)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--textures", default="marble,checker")
    parser.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = parser.parse_args()
    presets = {name: Setting(size=args.size, **vars(q)) for name, q in PRESETS.items()}
    four = Setting(4, False, size=args.size)
    rows = []
    for texture in args.textures.split(","):
        measured, _ = run_sweep(MESH, texture, size=args.size, settings=[*presets.values(), four], repeats=args.repeats)
        by = {r.setting: r for r in measured}
        one, sixteen = by[presets["default"]], by[presets["final"]]
        ratio = sixteen.seconds / one.seconds
        met = one.rmse <= sixteen.rmse and ratio >= 8
        rows.append((
            f"{texture} {args.size}²: 1 filtered sample against 16 point samples",
            f"RMSE {one.rmse:.1e} vs {sixteen.rmse:.1e}, 1/{ratio:.1f} of the time",
            f"aim: the same RMSE in <= 1/8 of the time ({'met' if met else 'not met'})",
        ))
        for name, setting in [*presets.items(), ("4 point samples", four)]:
            r = by[setting]
            rows.append((f"{texture} {args.size}², {name} ({setting.name})", f"{r.seconds:.2f} s, RMSE {r.rmse:.1e}",
                         f"estimate in report.json {r.estimate:.1e} ({r.method}, x{r.ratio:.2f})"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
