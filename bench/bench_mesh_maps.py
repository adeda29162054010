"""texbake's mesh maps beside Blender 4.5 (Cycles) on the same meshes, size and rays, in one run.

Run: scripts/run python bench/bench_mesh_maps.py [--size 2048] [--rays 64] [--distance 1.0] [--runs 1]

1. Ambient occlusion of the 63k-face Suzanne into its own UVs at ``--size``², ``--rays`` rays a
   texel (Cycles: as many samples, one AO ray each) and the same AO distance: texbake's and
   Blender's whole processes (import, bake, save), their times, and the RMSE of texbake's map
   against Blender's over the texels both cover (a texel in from the charts' edges, where
   the two sample a texel at different places). Targets: RMSE <= 0.03, time <= 0.5x.
2. High to low: a displaced, subdivided sphere (icosphere of 6 subdivisions, radius
   1 + 0.04 sin 6x sin 6y sin 6z, 82k faces) onto an icosphere of 3 (its UVs unwrapped by
   texbake first, the same OBJ for both), tangent-space normal map at ``--size``/2, texbake
   with ``--texture none`` (the normal map alone, as Blender bakes it):
   the mean angle between texbake's and Blender's "Selected to Active" normal over the
   texels both cover, and the times (targets: <= 2 degrees, <= 0.5x). The same for a second
   pair: a torus (radii 1 and 0.35, 384 x 192 sections, 147k faces) knurled with 24 x 6
   bumps of +-0.02 along its tube's normal, onto a torus of 64 x 32 sections (4.1k faces).

Both fill a margin of 16 texels round the charts (texbake's default; Blender's bake margin
set to it, as bench/bench_blender.py does). Blender runs from ``.venv-blender``
(``scripts/blender``; bench/blender_mesh_maps.py); without it only texbake's figures are
printed.
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
from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"
BLENDER = ROOT / ".venv-blender" / "bin" / "python"


def timed(cmd: list[str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{cmd[0]} failed ({done.returncode}): {done.stderr[-2000:]}")
    return time.perf_counter() - start


def read(path: Path) -> np.ndarray:
    """An image texbake wrote, ``(h, w, c)`` float32 0..1, row 0 at the top."""
    import OpenImageIO as oiio

    return np.asarray(oiio.ImageBuf(str(path)).get_pixels(oiio.FLOAT), dtype=np.float32)


def inner(covered: np.ndarray) -> np.ndarray:
    """The covered texels whose four neighbours are covered too."""
    c = covered.copy()
    c[1:] &= covered[:-1]
    c[:-1] &= covered[1:]
    c[:, 1:] &= covered[:, :-1]
    c[:, :-1] &= covered[:, 1:]
    return c


def median_time(cmd: list[str], runs: int) -> float:
    return statistics.median(timed(cmd) for _ in range(runs))


def ao_rows(args, tmp: Path, blender: Path | None) -> list[tuple[str, str, str]]:
    ours = [sys.executable, "-m", "texbake.cli", "bake", str(args.mesh), "--maps", "ao", "--map-rays", str(args.rays),
            "--map-distance", str(args.distance), "--size", str(args.size), "--bits", "16", "--out", str(tmp / "ao")]
    t_ours = median_time(ours, args.runs)
    ao, covered = read(tmp / "ao" / "ao.png")[..., 0], read(tmp / "ao" / "coverage.png")[..., 0] > 0.5
    figure = f"ambient occlusion, {args.mesh.name} {args.size}², {args.rays} rays a texel, distance {args.distance}, whole process"
    if blender is None:
        return [(figure, f"{t_ours:.2f} s", "Blender not installed (scripts/blender)")]
    theirs = [str(blender), str(ROOT / "bench" / "blender_mesh_maps.py"), "ao", str(args.mesh), str(tmp / "ao.npy"),
              "--size", str(args.size), "--rays", str(args.rays), "--distance", str(args.distance)]
    t_theirs = median_time(theirs, args.runs)
    reference = np.load(tmp / "ao.npy")[::-1, :, 0]  # Blender's rows bottom up
    both = inner(covered)
    rmse = float(np.sqrt(np.mean((ao[both] - reference[both]) ** 2)))
    bias = float(np.mean(ao[both] - reference[both]))
    return [(figure, f"{t_ours:.2f} s; {t_ours / t_theirs:.2f}x Blender's", f"Blender 4.5 Cycles {t_theirs:.2f} s (target <= 0.5x)"),
            (f"same, RMSE against Blender's AO over {int(both.sum())} texels", f"{rmse:.4f} (mean difference {bias:+.4f})",
             "target <= 0.03")]


def spheres(tmp: Path) -> tuple[str, Path, Path, float, float]:
    """The displaced high sphere and the low one, as OBJs (the low one with texbake's unwrap),
    the cage's extrusion and the rays' reach."""
    import trimesh

    high = trimesh.creation.icosphere(subdivisions=6)
    v = high.vertices
    high.vertices = v * (1 + 0.04 * np.sin(6 * v[:, 0]) * np.sin(6 * v[:, 1]) * np.sin(6 * v[:, 2]))[:, None]
    low = trimesh.creation.icosphere(subdivisions=3)
    return ("displaced icosphere (82k faces) onto 1.3k faces", *_pair(tmp, "sphere", high, low), 0.06, 0.12)


def knurled_ring(tmp: Path) -> tuple[str, Path, Path, float, float]:
    """A torus (radii 1 and 0.35, 384 x 192 sections) with a knurl of 24 x 6 bumps along its
    tube's normal, +-0.02, onto a torus of 64 x 32 sections; as :func:`spheres`."""
    import trimesh

    high = trimesh.creation.torus(1.0, 0.35, major_sections=384, minor_sections=192)
    v = high.vertices
    theta = np.arctan2(v[:, 1], v[:, 0])
    centre = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(len(v))])
    out = (v - centre) / np.linalg.norm(v - centre, axis=1, keepdims=True)
    phi = np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1]) - 1.0)
    high.vertices = v + (0.02 * np.sin(24 * theta) * np.sin(6 * phi))[:, None] * out
    low = trimesh.creation.torus(1.0, 0.35, major_sections=64, minor_sections=32)
    return (f"knurled torus ({len(high.faces) // 1000}k faces) onto {len(low.faces) / 1000:.1f}k faces", *_pair(tmp, "ring", high, low),
            0.04, 0.08)


def _pair(tmp: Path, name: str, high, low) -> tuple[Path, Path]:
    """``(low OBJ with texbake's unwrap, high OBJ)`` written under ``tmp``."""
    import texbake

    high.export(tmp / f"{name}_high.obj")
    low.export(tmp / f"{name}_low.obj")
    texbake.bake_mesh(tmp / f"{name}_low.obj", size=512, uv="unwrap", margin=2).save(tmp / f"{name}_unwrapped", obj=True)
    return tmp / f"{name}_unwrapped" / f"{name}_low.obj", tmp / f"{name}_high.obj"


def high_to_low_rows(args, tmp: Path, blender: Path | None) -> list[tuple[str, str, str]]:
    rows = []
    for label, low, high, extrusion, reach in (spheres(tmp), knurled_ring(tmp)):
        rows += _high_to_low(args, tmp, blender, label, low, high, extrusion, reach)
    return rows


def _high_to_low(args, tmp: Path, blender: Path | None, label: str, low: Path, high: Path, extrusion: float,
                 reach: float) -> list[tuple[str, str, str]]:
    size, out = args.size // 2, tmp / f"{high.stem}_normal"
    ours = [sys.executable, "-m", "texbake.cli", "bake", str(low), "--source", str(high), "--maps", "source_normal",
            "--front-distance", str(extrusion), "--back-distance", str(reach - extrusion), "--uv", "keep", "--texture", "none", "--size", str(size),
            "--bits", "16", "--out", str(out)]
    t_ours = median_time(ours, args.runs)
    figure = f"high to low normal map, {label}, {size}², whole process"
    if blender is None:
        return [(figure, f"{t_ours:.2f} s", "Blender not installed (scripts/blender)")]
    theirs = [str(blender), str(ROOT / "bench" / "blender_mesh_maps.py"), "normal", str(low), str(high), str(out) + ".npy",
              "--size", str(size), "--extrusion", str(extrusion), "--reach", str(reach)]
    t_theirs = median_time(theirs, args.runs)
    n = 2.0 * read(out / "source_normal.png")[..., :3] - 1.0
    m = 2.0 * np.load(str(out) + ".npy")[::-1, :, :3] - 1.0
    covered = read(out / "coverage.png")[..., 0] > 0.5
    both = inner(covered) & (np.linalg.norm(m, axis=2) > 0.5)
    a, b = n[both], m[both]
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    return [(figure, f"{t_ours:.2f} s; {t_ours / t_theirs:.2f}x Blender's", f"Blender 4.5 Cycles {t_theirs:.2f} s (target <= 0.5x)"),
            (f"same, angle to Blender's Selected to Active normal over {int(both.sum())} texels",
             f"mean {angle.mean():.2f}°, p95 {np.percentile(angle, 95):.2f}°", "target mean <= 2°")]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--rays", type=int, default=64)
    ap.add_argument("--distance", type=float, default=1.0)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--mesh", type=Path, default=MESH)
    ap.add_argument("--blender", type=Path, default=BLENDER)
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--only", choices=["ao", "high-to-low"], default=None)
    args = ap.parse_args()
    blender = args.blender if args.blender.exists() else None
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        if args.only in (None, "ao"):
            rows += ao_rows(args, tmp, blender)
        if args.only in (None, "high-to-low"):
            rows += high_to_low_rows(args, tmp, blender)
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
