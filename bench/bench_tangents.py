"""texbake's tangents beside Blender 4.5's MikkTSpace (``Mesh.calc_tangents``) on the shared meshes.

Run: scripts/run python bench/bench_tangents.py [--meshes DIR] [--markdown]

Each mesh of ``../shared/meshes`` is baked as a user bakes a normal map (``--bump noise``,
64², the default atlas: the mesh's own UVs where usable, texbake's unwrap otherwise); the
output mesh (the one the GLB carries: vertices split at UV seams and normal creases, their
normals, and the tangents the normal map was baked in) is written to an OBJ, and Blender
imports that OBJ unchanged (no axis rotation, the normals as custom normals) and computes
MikkTSpace's tangents on it (bench/blender_tangents.py, one Blender process for all
meshes). On every face corner: the angle between texbake's tangent of the corner's vertex
and Blender's tangent of the corner, and whether the bitangent signs agree. Target
(issue 29): within 0.5°. Blender's corner normals are checked to be texbake's (the angle
between them is printed too): the two frames are built on the same normals. Blender's
tangent is zero (and left out, counted) at a vertex whose faces all meet it at under about
0.02°: its float32 cosine of the corner angle, MikkTSpace's weight, rounds to 1 (the gear's
sliver fans); texbake's float64 gives those a tangent.

Blender runs from ``.venv-blender`` (``scripts/blender``); without it only the meshes are
prepared.
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESHES = ROOT.parent / "shared" / "meshes"
BLENDER = ROOT / ".venv-blender" / "bin" / "python"
SUFFIXES = {".obj", ".ply", ".stl", ".off", ".glb", ".gltf"}
TARGET_DEG = 0.5


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, normals: np.ndarray) -> None:
    """An OBJ whose vertex k has position, UV and normal k (``f a/a/a``): Blender's mesh then
    has texbake's vertices, in texbake's order."""
    with open(path, "w") as f:
        f.writelines(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in vertices)
        f.writelines(f"vt {u:.9g} {v:.9g}\n" for u, v in uv)
        f.writelines(f"vn {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in normals)
        f.writelines(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n" for a, b, c in faces + 1)


def angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(n,)`` degrees between the rows of ``a`` and ``b``."""
    cos = np.einsum("ij,ij->i", a, b) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def main() -> None:
    import texbake

    ap = argparse.ArgumentParser()
    ap.add_argument("--meshes", type=Path, default=MESHES)
    ap.add_argument("--blender", type=Path, default=BLENDER)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    paths = sorted(p for p in args.meshes.iterdir() if p.suffix.lower() in SUFFIXES)
    rows: list[tuple[str, str, str]] = []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        baked = {}
        for path in paths:
            result = texbake.bake_mesh(path, "checker", bump="noise", size=64)
            m = result.mesh
            obj = tmp / f"{path.stem}.obj"
            write_obj(obj, m.vertices, m.faces, m.uv, m.normals)
            baked[path.name] = (m, obj, tmp / f"{path.stem}.npz", result.report["atlas"]["method"])
        if not args.blender.exists():
            emit([(f"{len(baked)} meshes baked", "", "Blender not installed (scripts/blender)")], args.markdown)
            return
        cmd = [str(args.blender), str(ROOT / "bench" / "blender_tangents.py")]
        for _, obj, out, _ in baked.values():
            cmd += [str(obj), str(out)]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"Blender failed ({done.returncode}): {done.stderr[-2000:]}")
        worst, corners_all, zero = 0.0, 0, 0
        for name, (m, _, out, atlas) in baked.items():
            theirs = np.load(out)
            if not np.allclose(theirs["positions"], m.vertices, rtol=0, atol=1e-4 * np.ptp(m.vertices, axis=0).max()):
                raise SystemExit(f"{name}: Blender's vertices are not the OBJ's, in its order")
            # Blender's tangent is zero where all of a vertex's faces meet it at angles whose
            # float32 cosine is 1 (under about 0.02°: the weights are 0): those corners are counted
            has = np.linalg.norm(theirs["tangent"], axis=1) > 0.5
            v = theirs["vertex"][has]
            ours = m.tangents[v]
            angle = angle_deg(ours[:, :3], theirs["tangent"][has].astype(np.float64))
            normal = angle_deg(m.normals[v], theirs["normal"][has].astype(np.float64))
            flipped = float(np.mean(np.sign(ours[:, 3]) != np.sign(theirs["sign"][has])))
            worst, corners_all, zero = max(worst, float(angle.max())), corners_all + len(v), zero + int((~has).sum())
            rows.append((f"{name} ({len(m.faces)} faces, atlas: {atlas}), {len(v)} corners"
                         + ("" if has.all() else f" (+{int((~has).sum())} where Blender's is zero)"),
                         f"mean {angle.mean():.4f}°, p99 {np.percentile(angle, 99):.4f}°, max {angle.max():.4f}°",
                         f"signs differ on {100 * flipped:.2f} %; normals apart: max {normal.max():.4f}°"))
        rows.append((f"all {len(baked)} meshes, {corners_all} corners (and {zero} where Blender's tangent is zero): "
                     "the largest angle to Blender's tangent", f"{worst:.4f}°", f"target <= {TARGET_DEG}°"))
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
