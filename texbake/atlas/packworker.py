"""xatlas worker process: ``python -m texbake.atlas.packworker`` serves the unwrap's jobs
(``chart``, ``pack``) until stdin closes, a :mod:`texbake.workers` worker started by
:mod:`texbake.atlas.pack`. xatlas can hang or crash on bad input; here that only takes down this
process, which the parent kills at its deadline or sees die. Only numpy, xatlas and two
small modules of the package (:mod:`texbake.mesh.uvgeometry`, :mod:`texbake.workers`) are imported.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..mesh import uv_areas
from ..workers import serve


def _square(atlas, uv: np.ndarray) -> np.ndarray:
    """xatlas' UVs are divided by the atlas width and height: make them one square scale."""
    w, h = atlas.width, atlas.height
    return (uv.astype(np.float64) * [w, h] / max(w, h, 1)).astype(np.float64)


def chart(positions: np.ndarray, faces: np.ndarray, max_iterations: int):
    """Cut one patch into charts and parametrise them.

    Returns ``(vmapping, indices, uv)``: xatlas' packing here is only a cheap way to get
    the charts' UVs (all at one scale); the caller rescales and packs all patches again.
    """
    import xatlas

    atlas = xatlas.Atlas()
    atlas.add_mesh(positions, faces)
    co = xatlas.ChartOptions()
    co.max_iterations = max_iterations
    po = xatlas.PackOptions()
    po.resolution = 256
    po.padding = 1
    po.bilinear = False
    po.blockAlign = False
    po.bruteForce = False
    atlas.generate(co, po)
    vmapping, indices, uv = atlas[0]
    return vmapping, indices, _square(atlas, uv)


BRUTE_DIV = 2  # brute-force packings run at this fraction of the texture's resolution ...
BRUTE_DIV_SIZE = 512  # ... from this many texels up (below, the padding's rounding costs more than the time saved)


def pack(meshes: list, size: int, padding: int, brute: bool = False, at: float | None = None):
    """Pack the charts of UV meshes (``(uv, faces)`` pairs, one texel density) together.

    Each UV mesh is added on its own (``add_uv_mesh`` merges charts of one mesh that
    touch or overlap, so charts of different patches must not share one). The atlas is
    packed at an explicit texel density, the largest found (within 2 %, in at most three passes) that fits
    ``size`` texels, so that ``padding`` is at least that many texels of the texture; or,
    ``at`` given, in one pass at that density (relative to the one that would fill half
    the square: the parent's search, :func:`texbake.atlas.pack._searched`). Returns per mesh
    ``(vmapping, indices, uv)`` with ``uv`` in the unit square, and an info dict
    (``fill``: the atlas' larger side over the texture's, over 1 where nothing fitted;
    ``density``: the one packed at, as ``at`` takes it).
    ``brute``: xatlas' brute-force placement (every position tried for each chart), at
    1/``BRUTE_DIV`` of the resolution from ``BRUTE_DIV_SIZE`` texels up.
    """
    import xatlas

    def run(texels_per_unit: float):
        atlas = xatlas.Atlas()
        for uv, faces in meshes:
            atlas.add_uv_mesh(uv, faces)
        po = xatlas.PackOptions()
        po.resolution = 0  # one atlas, as large as the density needs
        po.texels_per_unit = texels_per_unit
        po.padding = pad
        # bilinear=True dilates each chart by a texel: far slower on sliver fans, and padding is already texels
        po.bilinear = False
        po.blockAlign = False
        po.bruteForce = brute  # fuller for a few long charts, but its time grows with the charts
        co = xatlas.ChartOptions()
        co.max_iterations = 1
        atlas.generate(co, po)
        return atlas

    # In texel units: xatlas takes faces under an absolute area as degenerate and then
    # re-parametrises the whole chart (a CAD cap's slivers scrambled it at unit scale).
    # Brute force at half the resolution (the padding rounded up, so never less): it tries
    # every position, a quarter of them there, for the same layout within a few thousandths.
    div = BRUTE_DIV if brute and size >= BRUTE_DIV_SIZE else 1
    size, pad = size // div, -(-padding // div)
    area = sum(float(uv_areas(uv, faces).sum()) for uv, faces in meshes)
    scale = size * np.sqrt(0.5 / max(area, 1e-30))
    meshes = [((uv.astype(np.float64) * scale).astype(np.float32), faces) for uv, faces in meshes]
    tpu, fits = 1.0 if at is None else at, None
    # Each pass costs the same (0.04-0.16 s on the bench meshes), but a looser window is not
    # free: within 10 % would save a quarter of the packing CPU and cost capsule.obj 0.059 of
    # utilisation, cow.obj 0.045 (xatlas' greedy layout moves with the density); a first pass at
    # half resolution to find the density, or rotate_charts off, did no better.
    passes = 3 if at is None else 1
    for i in range(passes):  # the largest density that fits, within 2 %
        atlas = run(tpu)
        side = max(atlas.width, atlas.height)
        if side <= size:
            fits = atlas, tpu
            if side >= 0.98 * size:
                break
        elif fits is not None:
            break
        if i + 1 < passes:
            tpu *= 0.99 * size / side
    atlas, tpu = fits or (atlas, tpu)
    if atlas.atlas_count != 1:
        raise RuntimeError(f"xatlas made {atlas.atlas_count} atlases, expected 1")
    out = []
    for i in range(len(meshes)):
        vmapping, indices, uv = atlas[i]
        out.append((vmapping, indices, _square(atlas, uv)))
    info = {"width": int(atlas.width), "height": int(atlas.height), "texels_per_unit": float(tpu * scale * div),
            "fill": max(int(atlas.width), int(atlas.height)) / size, "density": float(tpu)}
    return out, info


JOBS: dict[str, Callable[..., object]] = {"chart": chart, "pack": pack}


def main() -> None:
    serve(JOBS)


if __name__ == "__main__":
    main()
