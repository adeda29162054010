"""Unwrap benchmark: texbake's atlas beside Blender 4.5's Smart UV Project, mesh by mesh.

    .venv/bin/python bench/bench_unwrap.py [--blender PYTHON] [--runs N] [--size S] [--only NAME]

Every mesh of ``../shared/meshes`` that loads (its UVs dropped) and the CAD-like meshes
of :mod:`texbake.checks.cad` (sliver fans, thousands of sections, mm units, 1e3-1e6 from
the origin), unwrapped by ``make_atlas(mode="unwrap", charting=--charting)`` (default "auto") at ``--size``
with 2 workers, median of ``--runs`` wall times. Both atlases are scored by the same
code: utilisation (UV area in the unit square), density spread (area-weighted mean of
max(d, 1/d), d a face's texel density over the mean; 1.0 is uniform), Sander's L2
stretch and the share of covered texels under two faces. The targets (issue 11):
utilisation >= 0.9x Smart UV's, spread no worse, time <= 2x Smart UV's + 1 s, no grid.

Blender runs in its own venv (``bpy`` pins numpy 1.26, OpenImageIO needs numpy 2):
``--blender`` names its Python, by default ``.venv-blender/bin/python`` when it exists
(``scripts/blender`` makes it). Without it only texbake's columns are printed.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _rows import emit  # noqa: E402

from texbake.atlas import atlas_stats, make_atlas, overlap  # noqa: E402
from texbake.atlas.charts import density_spread  # noqa: E402
from texbake.checks.cad import meshes as cad_meshes  # noqa: E402
from texbake.errors import BakeError  # noqa: E402
from texbake.mesh.load import load_mesh  # noqa: E402

SHARED = ROOT.parent / "shared" / "meshes"
BLENDER = ROOT / ".venv-blender" / "bin" / "python"


def all_meshes(only: str | None) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    out = {}
    for path in sorted(SHARED.iterdir()):
        try:
            m = load_mesh(path)
        except BakeError:
            continue  # not a mesh (textures, .mtl) or one that does not load
        out[path.name] = (m.vertices, m.faces)
    out.update(cad_meshes())
    return {k: v for k, v in out.items() if only is None or only in k}


def scores(v, f, uv_faces, uv, size) -> dict:
    s = atlas_stats(v, f, uv_faces, uv)
    s["spread"] = density_spread(v, f, uv, uv_faces)
    s["overlap"], _ = overlap(uv, uv_faces, size)
    return s


def welded(faces: np.ndarray, corner_uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(uv_faces (m, 3), uv (k, 2))`` from ``(m, 3, 2)`` corner UVs: corners of one
    vertex at one UV are one UV vertex (so charts are counted as connected pieces)."""
    keys = np.column_stack([faces.reshape(-1), corner_uv.reshape(-1, 2).view(np.int64) if corner_uv.dtype == np.float64
                            else corner_uv.reshape(-1, 2).astype(np.float64).view(np.int64)])
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return inverse.reshape(-1, 3), corner_uv.reshape(-1, 2)[first].astype(np.float64)


def smart_uv(blender: Path, meshes: dict, runs: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        inp, out = Path(tmp) / "in.npz", Path(tmp) / "out.npz"
        arrays = {f"{k}.{part}": a for k, (v, f) in meshes.items() for part, a in (("vertices", v), ("faces", f))}
        np.savez(inp, names=np.array(list(meshes)), **arrays)
        subprocess.run([str(blender), str(ROOT / "bench" / "blender_smart_uv.py"), str(inp), str(out), "--runs", str(runs)],
                       check=True, stdout=subprocess.DEVNULL)
        data = np.load(out)
        return {k: (data[f"{k}.uv"], float(data[f"{k}.seconds"])) for k in meshes}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--blender", type=Path, default=BLENDER if BLENDER.exists() else None)
    ap.add_argument("--only", help="only meshes whose name contains this")
    ap.add_argument("--charting", default="auto", choices=("auto", "xatlas", "planar"))
    ap.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = ap.parse_args()

    meshes = all_meshes(args.only)
    blender = smart_uv(args.blender, meshes, args.runs) if args.blender else {}
    rows, failed = [], []
    for name, (v, f) in meshes.items():
        times = []
        for _ in range(args.runs):
            t = time.perf_counter()
            atlas = make_atlas(v, f, mode="unwrap", size=args.size, workers=2, charting=args.charting)
            times.append(time.perf_counter() - t)
        ours = scores(v, f, atlas.faces, atlas.uv, args.size)
        ours_s = statistics.median(times)
        cell = (f"{atlas.method} {ours_s:.2f} s, util {ours['utilisation']:.2f}, spread {ours['spread']:.3f}, "
                f"stretch {ours['stretch']:.3f}, {ours['charts']} charts, overlap {ours['overlap']:.1%}")
        ref = "Blender not run"
        ok = atlas.method != "fallback-grid" and ours["overlap"] < 0.01
        if name in blender:
            uv, seconds = blender[name]
            b = scores(v, f, *welded(f, uv), args.size)
            ref = (f"Smart UV {seconds:.2f} s, util {b['utilisation']:.2f}, spread {b['spread']:.3f}, "
                   f"stretch {b['stretch']:.3f}, {b['charts']} charts, overlap {b['overlap']:.1%}")
            ok = ok and ours["utilisation"] >= 0.9 * b["utilisation"] and ours["spread"] <= b["spread"] * 1.001 \
                and ours_s <= 2 * seconds + 1
        rows.append((f"unwrap at {args.size}², {name} ({len(f)} faces){'' if ok else ' (target MISSED)'}", cell, ref))
        if not ok:
            failed.append(name)
    if not args.markdown:
        print(f"unwrap at {args.size}^2, median of {args.runs}; targets: util >= 0.9x, spread <= Smart UV's, "
              "time <= 2x + 1 s, no grid, overlap < 1 %")
    emit(rows, args.markdown)
    if not args.markdown:
        print(f"{len(rows) - len(failed)} of {len(rows)} meshes meet the targets" + (f"; missed: {', '.join(failed)}" if failed else ""))


if __name__ == "__main__":
    main()
