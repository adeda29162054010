"""The compiled geometry and image kernels (``native/``: UV checks, margin, components,
texel lookup, surface samples, accumulation, the 8-bit encoder) on Suzanne's own UVs at
2048², beside SciPy where SciPy does the same thing.

Run: scripts/run python bench/bench_geometry.py [--runs 7] [--markdown]

Prints each kernel's best wall and CPU time of ``--runs`` (warm: a first call untimed).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _rows import emit

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "suzanne_blender_uv.obj"
SIZE = 2048


def best(function, runs: int) -> str:
    """``"wall ms / CPU ms"``: the best of ``runs`` calls after one untimed."""
    function()
    wall, cpu = [], []
    for _ in range(runs):
        t, c = time.perf_counter(), time.process_time()
        function()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return f"{min(wall) * 1e3:.1f} / {min(cpu) * 1e3:.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--markdown", action="store_true")
    args = parser.parse_args()

    import trimesh
    from scipy import ndimage
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components as scipy_components

    from texbake.atlas import uvcheck
    from texbake.maps import accumulate, margin
    from texbake.output import images
    from texbake.sampling import lookup, surface

    mesh = trimesh.load(MESH, process=False, force="mesh")
    uv, faces, runs = np.asarray(mesh.visual.uv, float), np.asarray(mesh.faces), args.runs
    covered = uvcheck.coverage_counts(uv, faces, SIZE) > 0
    image = np.random.default_rng(0).random((SIZE, SIZE, 3)).astype(np.float32) * covered[..., None]
    a, b = np.repeat(np.arange(len(faces)), 3), faces.ravel() + len(faces)
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(len(faces) + len(uv),) * 2)
    look, tile, offsets = lookup.UVLookup(uv, faces), lookup.Tile(0, SIZE // 16), lookup.sample_offsets(4)
    texels = look.candidates(tile, SIZE, SIZE)
    points = lookup.sample_uv(tile, texels, SIZE, SIZE, offsets)
    face, bary, _ = look.locate(points, 4)
    index, found, coords = lookup.hits(face, bary)
    surface_map = surface.SurfaceMap(mesh.vertices, faces, uv, faces, SIZE, SIZE, normals=True)
    texel, values = index // 4, np.random.default_rng(1).random((len(index), 3))
    rows = [
        ("UV coverage, 2048² (wall / CPU ms)", best(lambda: uvcheck.coverage(uv, faces, SIZE), runs), ""),
        ("UV overlapping faces, 2048²", best(lambda: uvcheck.overlapping_faces(uv, faces, SIZE), runs), ""),
        ("feature transform, 2048²", best(lambda: margin.feature_transform(covered), runs),
         f"SciPy's distance_transform_edt: {best(lambda: ndimage.distance_transform_edt(~covered, return_indices=True), runs)}"),
        ("margin extend, 16 texels", best(lambda: margin.extend(image.copy(), covered, 16), runs), ""),
        ("chart labels (connected components)", best(lambda: uvcheck.chart_labels(faces, len(uv)), runs),
         f"scipy.sparse.csgraph: {best(lambda: scipy_components(graph, directed=False), runs)}"),
        ("texel lookup of a 1/16 tile, 4 samples (Embree)", best(lambda: look.locate(points, 4), runs), ""),
        ("surface samples with normals", best(lambda: surface_map.samples(found, coords), runs), ""),
        ("accumulate: runs and means", best(lambda: accumulate._run_means(values, accumulate._runs(texel)[1]), runs), ""),
        ("8-bit sRGB encoding, 2048² RGB", best(lambda: images._encode(image, "png", 8, "linear"), runs), ""),
    ]
    emit(rows, args.markdown)


if __name__ == "__main__":
    main()
