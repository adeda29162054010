"""A mesh's own UV islands packed anew into the tile, shape for shape (as Blender's Pack
Islands): for a layout whose islands are sound but lie outside the tile, or overlap one
another only by where they were placed (two parts sharing one layout, mirrored halves
laid on each other).

The islands are the connected pieces of the mesh's UV layout (faces sharing UV vertices).
A face of no UV area, or one that faces the other way to its island (a fold: the layers
of its island lie on each other there), holds no place of its own: such faces leave their
islands and are charted anew (planar charts, :mod:`texbake.atlas.charts`) beside them.
Every island keeps its shape and the islands their sizes relative to one another; xatlas
packs them (with the new charts, at one texel density: the islands' mean) in one pass
(:func:`texbake.atlas.pack._pack`), moving, turning and scaling each as a whole. A layout
whose island spans more than one tile repeats a tiling texture: it cannot hold a unique
bake, and is not repacked (:func:`repack_problem` says why).
"""

from __future__ import annotations

import numpy as np

from ..mesh import areas, uv_areas
from ..workers import Pool
from .fallback import normalised
from .pack import Unwrapped, UnwrapRequest, _chart_planar, _pack
from .uvcheck import UV_EPS, chart_labels, folded_faces, island_overlap

FOLDED_LIMIT = 0.25  # a layout whose folded faces (or faces without UV area) hold more of the surface is not repacked
GAP = 0.05  # tile units between islands laid out for the packer (xatlas merges charts of one mesh that touch or overlap)


def repack_problem(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, grid: int, limit: float) -> str | None:
    """Why the mesh's own islands cannot be repacked, or None: UVs not finite, folded
    faces over ``FOLDED_LIMIT`` of the surface, an island more than one tile across (a
    repeating texture's layout), or islands that, each alone, overlap themselves on more
    than ``limit`` of their texels (on a ``grid``-square raster)."""
    corners = uv[faces]
    if not np.isfinite(corners).all():
        return "its UVs are not finite"
    folded = folded_faces(uv, faces)
    a3 = areas(vertices, faces)
    share = float(a3[folded].sum() / max(a3.sum(), 1e-300))
    if share > FOLDED_LIMIT:
        return f"{share:.0%} of the surface lies on faces that fold over their UV island or have no UV area"
    sound = faces[~folded]
    label = chart_labels(sound, len(uv))
    k = int(label.max()) + 1
    lo, hi = np.full((k, 2), np.inf), np.full((k, 2), -np.inf)
    np.minimum.at(lo, label, uv[sound].min(axis=1))
    np.maximum.at(hi, label, uv[sound].max(axis=1))
    extent = (hi - lo).max(axis=1)
    wide = extent > 1 + UV_EPS
    if wide.any():
        return (f"they repeat a tiling texture: {int(wide.sum())} of its {k} UV islands {'spans' if wide.sum() == 1 else 'span'} more than one tile (up to "
                f"{extent.max():.3g} across), and a bake needs a place of its own for every point of the surface")
    over = island_overlap(uv, sound, grid)
    if over > limit:
        return f"its UV islands overlap themselves: {over:.1%} of their texels lie under two of their own faces"
    return None


def repack(request: UnwrapRequest, uv: np.ndarray, pool: Pool, deadline: float) -> tuple[Unwrapped, int, int]:
    """The atlas of ``request``'s mesh with its own UV islands (``uv`` (n, 2), usable by
    :func:`repack_problem`) packed anew by xatlas in ``pool``'s workers; ``(atlas, islands,
    faces charted anew)``. Raises :class:`texbake.atlas.pack.XatlasFailed`."""
    faces = request.faces
    pos = normalised(request.vertices)  # the unwrap's units: the new charts' texel density is the islands'
    folded = folded_faces(uv, faces)
    ids = np.flatnonzero(~folded)
    sound = faces[ids]
    density = np.sqrt(areas(pos, sound).sum() / max(uv_areas(uv, sound).sum(), 1e-300))  # world units a UV unit
    used, local = np.unique(sound, return_inverse=True)
    local = local.reshape(-1, 3)
    laid = _laid_apart(uv[used], local) * density
    meshes = [(ids, used, laid, local)]
    if folded.any():
        meshes += _chart_planar(pos, faces, np.flatnonzero(folded), request.size)[0]
    steps: list[str] = []
    vm, fa, out = _pack(pos, faces, meshes, request.size, request.padding, pool, deadline, steps)
    islands = int(chart_labels(local, len(used)).max()) + 1
    return Unwrapped(vm, fa, out, "repacked", {"islands": islands, **({"packing": steps} if steps else {})}), islands, int(folded.sum())


def _laid_apart(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``uv`` with each island (connected piece of ``faces``) moved to a cell of its own in
    a near-square grid, ``GAP`` apart, so that none touches another: the packer then sees
    them as separate charts. Shapes and sizes stay as they are."""
    label = chart_labels(faces, len(uv))
    k = int(label.max()) + 1
    vertex_island = np.zeros(len(uv), dtype=np.int64)
    vertex_island[faces] = label[:, None]
    lo, hi = np.full((k, 2), np.inf), np.full((k, 2), -np.inf)
    np.minimum.at(lo, vertex_island, uv)
    np.maximum.at(hi, vertex_island, uv)
    cell = float((hi - lo).max()) + GAP
    columns = int(np.ceil(np.sqrt(k)))
    corner = np.column_stack([np.arange(k) % columns, np.arange(k) // columns]) * cell
    return uv - lo[vertex_island] + corner[vertex_island]
