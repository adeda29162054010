"""Unwrap benchmark: texbake's atlas beside Blender 4.5's Smart UV Project, mesh by mesh.

    .venv/bin/python bench/meshes.py                      # once: the public meshes into the cache
    .venv/bin/python bench/bench_unwrap.py [--blender PYTHON] [--runs N] [--size S] [--only NAME]
                                           [--max-faces F] [--cache DIR] [--charting C] [--markdown]

The meshes: every mesh of ``../shared/meshes`` that loads, the public meshes that
``bench/meshes.py`` gathered into its cache folder (trimesh's test models, Alec Jacobson's
common 3D test models: CAD parts, scans, game assets, a double-sided chair), the CAD-like
meshes of :mod:`texbake.checks.cad` (sliver fans, thousands of sections, mm units, 1e3-1e6
from the origin) and a building of boxes (each side two triangles); loaded as a bake loads
them (its UVs dropped), those over ``--max-faces`` faces left out. Each is unwrapped by
``make_atlas(mode="unwrap", charting=--charting)`` (default "auto") at ``--size`` with 2
workers, median of ``--runs`` wall times. Both atlases are scored by the same code:
utilisation (UV area in the unit square), density spread (area-weighted mean of max(d,
1/d), d a face's texel density over the mean; 1.0 is uniform), Sander's L2 stretch and the
share of covered texels under two faces. A back face (:class:`texbake.atlas.charts.Sides`)
whose corners have its front face's UVs is the same surface on the same texels: it is left
out of the scores (texbake maps double-sided faces so; Smart UV gives them charts of their
own, which count). The targets: utilisation >= 0.9x Smart UV's, spread <= Smart UV's +
0.02, overlap < 1 %, no grid fallback, and an atlas time <= 2x Smart UV's + 0.3 s (medians,
in a warm process: the packing workers started by an unwrap before the first timed one, as
in a service's bake process or a batch); each miss is named in the last column.

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
sys.path.insert(0, str(ROOT / "bench"))

from _rows import emit  # noqa: E402
from meshes import cache_dir, gathered  # noqa: E402

from texbake.atlas import atlas_stats, make_atlas, overlap  # noqa: E402
from texbake.atlas.charts import Sides, density_spread  # noqa: E402
from texbake.checks.cad import meshes as cad_meshes  # noqa: E402
from texbake.errors import BakeError  # noqa: E402
from texbake.mesh.load import _weld as weld  # noqa: E402
from texbake.mesh.load import load_mesh  # noqa: E402

SHARED = ROOT.parent / "shared" / "meshes"
BLENDER = ROOT / ".venv-blender" / "bin" / "python"
COLUMNS = ("mesh", "faces", "charting", "charts", "util", "spread", "overlap", "time s",
           "SUV charts", "SUV util", "SUV spread", "SUV overlap", "SUV s", "util ratio", "missed")


def building() -> tuple[np.ndarray, np.ndarray]:
    """Four storeys of boxes, each side two triangles: a boxy mesh (planar charts in "auto")."""
    import trimesh

    storeys = [trimesh.creation.box(extents=(10 - 2 * i, 8 - 2 * i, 3)) for i in range(4)]
    for i, b in enumerate(storeys):
        b.apply_translation((0, 0, 3 * i + 1.5))
    m = trimesh.util.concatenate(storeys)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def all_meshes(only: str | None, cache: Path, max_faces: int) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The benchmark's meshes by name (see the module), at most ``max_faces`` faces each."""
    out = {}
    for path in [*sorted(SHARED.iterdir()), *gathered(cache)]:
        try:
            m = load_mesh(path)
        except BakeError:
            continue  # not a mesh (textures, .mtl) or one that does not load
        # an OBJ with vt on some groups only (the chair) loaded without UVs before texture
        # sets; welded by position as then, its row stays comparable with the earlier ones
        partial = m.has_uv is not None and path.suffix.lower() == ".obj"
        out[path.name] = weld(m.vertices, m.faces, None)[:2] if partial else (m.vertices, m.faces)
    out.update(cad_meshes())
    out["building-of-boxes"] = building()
    return {k: v for k, v in out.items() if (only is None or only in k) and len(v[1]) <= max_faces}


def one_surface(faces: np.ndarray, uv_faces: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``(m,)`` bool: the faces scored; a back face on its front face's UVs (one surface on
    the same texels) is not."""
    sides = Sides.of(faces)
    keep = np.ones(len(faces), dtype=bool)
    if len(sides.back):
        front = sides.front[sides.twin]
        mine = uv[uv_faces[sides.back]]  # (b, 3, 2)
        corner = np.argmax(faces[sides.back][:, :, None] == faces[front][:, None, :], axis=2)
        theirs = np.take_along_axis(uv[uv_faces[front]], corner[:, :, None], axis=1)
        keep[sides.back[(mine == theirs).all(axis=(1, 2))]] = False
    return keep


def scores(v, f, uv_faces, uv, size) -> dict:
    keep = one_surface(f, uv_faces, uv)
    f, uv_faces = f[keep], uv_faces[keep]
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


def ours(v, f, args) -> tuple[dict, str, float]:
    """``(scores, charting, median seconds)`` of texbake's unwrap of one mesh."""
    times = []
    for _ in range(args.runs):
        t = time.perf_counter()
        atlas = make_atlas(v, f, mode="unwrap", size=args.size, workers=2, charting=args.charting)
        times.append(time.perf_counter() - t)
    return scores(v, f, atlas.faces, atlas.uv, args.size), atlas.method, statistics.median(times)


def row(name: str, f: np.ndarray, args, reference) -> tuple[list[str], list[str]]:
    """One table row of a mesh, and the targets it misses."""
    s, method, seconds = ours(*f, args)
    cells = [name, str(len(f[1])), method, str(s["charts"]), f"{s['utilisation']:.3f}", f"{s['spread']:.3f}",
             f"{s['overlap']:.2%}", f"{seconds:.2f}"]
    missed = []
    if method == "fallback-grid":
        missed.append("grid fallback")
    if s["overlap"] >= 0.01:
        missed.append(f"overlap {s['overlap']:.1%}")
    if reference is None:
        return cells + ["-"] * 6, missed
    uv, suv_seconds = reference
    b = scores(f[0], f[1], *welded(f[1], uv), args.size)
    ratio = s["utilisation"] / b["utilisation"] if b["utilisation"] > 0 else float("inf")
    if ratio < 0.9:
        missed.append(f"util {ratio:.2f}x")
    if s["spread"] > b["spread"] + 0.02:
        missed.append(f"spread +{s['spread'] - b['spread']:.3f}")
    if seconds > 2 * suv_seconds + 0.3:
        missed.append(f"time {seconds:.2f} s > {2 * suv_seconds + 0.3:.2f} s")
    cells += [str(b["charts"]), f"{b['utilisation']:.3f}", f"{b['spread']:.3f}", f"{b['overlap']:.2%}",
              f"{suv_seconds:.2f}", f"{ratio:.2f}"]
    return cells, missed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--blender", type=Path, default=BLENDER if BLENDER.exists() else None)
    ap.add_argument("--only", help="only meshes whose name contains this")
    ap.add_argument("--max-faces", type=int, default=150_000, help="meshes of more faces are left out")
    ap.add_argument("--cache", help="the folder of bench/meshes.py's meshes")
    ap.add_argument("--charting", default="auto", choices=("auto", "xatlas", "planar"))
    ap.add_argument("--markdown", action="store_true", help="print only markdown table rows")
    args = ap.parse_args()

    meshes = all_meshes(args.only, cache_dir(args.cache), args.max_faces)
    blender = smart_uv(args.blender, meshes, args.runs) if args.blender else {}
    warm = building()  # a warm process: the packing workers started, as in a service's bake process
    make_atlas(*warm, mode="unwrap", size=args.size, workers=2, charting=args.charting)
    rows, failed = [], []
    for name, mesh in meshes.items():
        cells, missed = row(name, mesh, args, blender.get(name))
        rows.append([*cells, "; ".join(missed) or "-"])
        if missed:
            failed.append(name)
        if not args.markdown:
            print("  ".join(rows[-1]), flush=True)
    if args.markdown:  # bench/readme.py's three columns: figure, texbake, Smart UV
        emit([(f"unwrap at {args.size}², {r[0]} ({r[1]} faces)" + ("" if r[-1] == "-" else f" (missed: {r[-1]})"),
               f"{r[2]} {r[7]} s, util {r[4]}, spread {r[5]}, {r[3]} charts, overlap {r[6]}",
               f"Smart UV {r[12]} s, util {r[9]}, spread {r[10]}, {r[8]} charts, overlap {r[11]}") for r in rows], True)
        return
    print("\n| " + " | ".join(COLUMNS) + " |\n|" + "---|" * len(COLUMNS))
    for r in rows:
        print("| " + " | ".join(c.replace("|", "/") for c in r) + " |")
    print(f"\nunwrap at {args.size}^2, median of {args.runs}, charting {args.charting}; {len(rows) - len(failed)} of "
          f"{len(rows)} meshes meet the targets (util >= 0.9x Smart UV's, spread <= Smart UV's + 0.02, overlap < 1 %, "
          "no grid, time <= 2x Smart UV's + 0.3 s)" + (f"; missed: {', '.join(failed)}" if failed else ""))

if __name__ == "__main__":
    main()
