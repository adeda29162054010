"""UV checks: whether a mesh's own UVs (or an unwrap's) make a usable atlas, how many faces
cover each texel centre of a layout, and the statistics an atlas is reported with.

Overlap is measured on the texel grid the bake uses (a mirrored half mapped onto the other
half is overlap too). A texel centre lies in a face when it is inside the face's UV
triangle or on an edge that the top-left rule gives it (as GPUs rasterise), so two faces
that share an edge never both count a centre on that edge. The rasteriser is compiled
(``native/uvcheck.cpp``: row bands on the cores, no GIL).
"""

from __future__ import annotations

import numpy as np

from .. import _native
from ..mesh import areas, label_boxes, uv_areas, uv_jacobian

UV_EPS = 1e-6  # tolerance of the unit-square test of UVs
OVERLAP_GRID = 2048  # overlap is measured on the bake's texel grid, at most this fine
BARE_LIMIT = 0.01  # a warning when more of the surface lies on charts without a texel centre


def _counts(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    uv = np.ascontiguousarray(uv, dtype=np.float64).reshape(-1, 2)
    faces = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    counts = np.zeros((size, size), dtype=np.uint16)
    covering = np.zeros(len(faces), dtype=np.bool_)
    _native.raster(uv, faces, int(size), counts, covering, True)
    return uv, faces, counts, covering


def coverage_counts(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(size, size)`` uint16: how many faces cover each texel centre (row 0 at the top).

    ``uv``: ``(k, 2)`` float in the unit square (v up); ``faces``: ``(m, 3)`` int into it.
    """
    return _counts(uv, faces, size)[2]


def covering_faces(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(m,)`` bool: the faces that hold at least one texel centre."""
    return _counts(uv, faces, size)[3]


def overlapping_faces(uv: np.ndarray, faces: np.ndarray, size: int) -> np.ndarray:
    """``(m,)`` bool: the faces that cover a texel centre another face covers too."""
    uv, faces, counts, _ = _counts(uv, faces, size)
    flags = np.zeros(len(faces), dtype=np.bool_)
    _native.raster(uv, faces, int(size), counts, flags, False)
    return flags


def coverage(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``(counts (size, size) uint16, covering (m,) bool)``: :func:`coverage_counts` and
    :func:`covering_faces` of one rasterisation."""
    return _counts(uv, faces, size)[2:]


def overlap(uv: np.ndarray, faces: np.ndarray, size: int) -> tuple[float, int]:
    """``(share, most)``: the share of covered texel centres that two or more faces cover,
    and the most faces over one centre."""
    return overlap_of(coverage_counts(uv, faces, size))


def overlap_of(counts: np.ndarray) -> tuple[float, int]:
    """:func:`overlap` from :func:`coverage_counts`."""
    covered = int((counts > 0).sum())
    return (float((counts > 1).sum()) / covered if covered else 0.0), int(counts.max())


# -- usable UVs ----------------------------------------------------------------------


def uv_problem(vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray | None) -> str | None:
    """Why per-vertex UVs are not usable as an atlas of the mesh, or None if they are.

    Usable: given, one ``(u, v)`` row per vertex, finite, inside the unit square (within
    ``UV_EPS``: a repeating texture's UVs are not an atlas) and every face with a UV
    area above zero.
    """
    if uv is None:
        return "the mesh has no UVs"
    uv = np.asarray(uv, dtype=np.float64)
    n = len(vertices)
    if uv.ndim != 2 or uv.shape != (n, 2):
        return f"the mesh's UVs have shape {uv.shape}, expected ({n}, 2)"
    faces = np.asarray(faces)
    if len(faces) == 0:
        return "the mesh has no faces"
    mask = np.zeros(n, dtype=bool)
    mask[faces] = True  # the UVs faces use: linear, where np.unique would sort every corner
    used = uv[mask]
    if not np.isfinite(used).all():
        return "the mesh's UVs are not finite"
    lo, hi = used.min(), used.max()
    if lo < -UV_EPS or hi > 1 + UV_EPS:
        return f"the mesh's UVs leave the unit square (range {lo:.3g} to {hi:.3g})"
    zero = int((uv_areas(uv, faces) <= 0).sum())
    if zero:
        return f"{zero} faces have zero UV area"
    return None


def unwrap_problem(vmapping: np.ndarray, faces: np.ndarray, uv: np.ndarray, mesh_faces: np.ndarray, n_vertices: int) -> str | None:
    """Why an atlas ``(vmapping, faces, uv)`` made for a mesh of ``n_vertices`` vertices and
    ``mesh_faces`` is unusable, or None: it must have the mesh's faces, in order, and
    finite UVs of faces with an area, in the unit square."""
    n_faces = len(mesh_faces)
    if faces.shape != (n_faces, 3):
        return f"{len(faces)} faces came back for {n_faces}"
    if len(vmapping) != len(uv) or (len(vmapping) and (vmapping.min() < 0 or vmapping.max() >= n_vertices)):
        return "the vertex mapping is inconsistent"
    if len(faces) and (faces.min() < 0 or faces.max() >= len(uv)):
        return "the faces index missing UV vertices"
    if not np.array_equal(vmapping[faces], mesh_faces):
        return "the faces do not match the mesh's faces"
    if not np.isfinite(uv).all():
        return "the UVs are not finite"
    if uv.min() < -UV_EPS or uv.max() > 1 + UV_EPS:
        return f"the UVs leave the unit square ({uv.min():.3g} to {uv.max():.3g})"
    zero = int((uv_areas(uv, faces) <= 0).sum())
    if zero:
        return f"{zero} faces have zero UV area"
    return None


# -- UDIM tiles ----------------------------------------------------------------------

UDIM_COLUMNS = 10  # tiles a row: u in [0, 10)


def udim_tiles(uv: np.ndarray, faces: np.ndarray) -> np.ndarray | None:
    """``(m,)`` int64 the UDIM tile of each face (``1001 + u + 10 v`` of the integer tile
    ``(u, v)`` its UV triangle lies in, within ``UV_EPS`` of the tile's edges), or None
    when some face leaves its tile, lies left of 0, right of 10 or below 0, or an island
    (a connected piece of the layout) lies in two tiles: a layout that runs on across
    tiles repeats a tiling texture, it is not in tiles."""
    uv = np.asarray(uv, dtype=np.float64)
    # three gathers and np.minimum, not (m, 3, 2).min(axis=1): numpy's reduce over a short
    # axis is 4x slower, and this runs twice a bake. A NaN or infinite corner needs no
    # check of its own: np.minimum and np.maximum carry it, and it fails `inside` or `low`.
    a, b, c = uv[faces[:, 0]], uv[faces[:, 1]], uv[faces[:, 2]]
    low = np.floor(np.minimum(np.minimum(a, b), c) + UV_EPS)  # (m, 2): the tile of a face's lowest corner
    inside = (np.maximum(np.maximum(a, b), c) <= low + 1 + UV_EPS).all(axis=1)
    if not inside.all() or low.min() < 0 or low[:, 0].max() >= UDIM_COLUMNS:
        return None
    tile = (1001 + low[:, 0] + UDIM_COLUMNS * low[:, 1]).astype(np.int64)
    label = chart_labels(faces, len(uv))
    first = np.zeros(int(label.max()) + 1, dtype=np.int64)
    first[label[::-1]] = tile[::-1]  # each island's tile (of its first face)
    return tile if np.array_equal(first[label], tile) else None


def udim_overlap(uv: np.ndarray, faces: np.ndarray, tiles: np.ndarray, grid: int) -> tuple[float, int]:
    """:func:`overlap` of a UDIM layout (``tiles``: :func:`udim_tiles`), each tile on its own
    ``grid``-square raster: the share of covered texel centres under two or more faces."""
    covered = over = most = 0
    for tile in np.unique(tiles).tolist():
        counts = coverage_counts(np.asarray(uv, dtype=np.float64) - udim_offset(tile), faces[tiles == tile], grid)
        covered, over, most = covered + int((counts > 0).sum()), over + int((counts > 1).sum()), max(most, int(counts.max()))
    return (over / covered if covered else 0.0), most


def udim_offset(tile: int) -> tuple[int, int]:
    """The corner ``(u, v)`` of UDIM tile ``tile`` (1001 -> (0, 0), 1012 -> (1, 1))."""
    v, u = divmod(int(tile) - 1001, UDIM_COLUMNS)
    return u, v


# -- islands -------------------------------------------------------------------------


def folded_faces(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` bool: the faces of no UV area, and those whose UV triangle turns the other
    way to the most of their island's (by area): where an island folds over itself."""
    uv = np.asarray(uv, dtype=np.float64)
    t = uv[faces]
    signed = 0.5 * ((t[:, 1, 0] - t[:, 0, 0]) * (t[:, 2, 1] - t[:, 0, 1]) - (t[:, 2, 0] - t[:, 0, 0]) * (t[:, 1, 1] - t[:, 0, 1]))
    label = chart_labels(faces, len(uv))
    way = np.sign(np.bincount(label, signed))[label]  # each island's way round
    return (signed * way <= 0) | (uv_areas(uv, faces) <= 0)


def island_overlap(uv: np.ndarray, faces: np.ndarray, grid: int) -> float:
    """The share of texel centres that two faces of one island cover, each island (a
    connected piece of the layout) rasterised alone at the texel size of a ``grid``-square
    tile: how much the islands overlap themselves, wherever they lie."""
    label = chart_labels(faces, len(uv))
    order = np.argsort(label, kind="stable")
    cuts = np.flatnonzero(np.diff(label[order])) + 1
    texel = 1.0 / grid
    covered = over = 0
    for members in np.split(order, cuts):
        used, local = np.unique(faces[members], return_inverse=True)
        part = np.asarray(uv, dtype=np.float64)[used]
        lo = part.min(axis=0)
        n = int(np.ceil(float((part.max(axis=0) - lo).max()) / texel)) + 2
        counts = coverage_counts((part - lo + texel) / (n * texel), local.reshape(-1, 3), n)
        covered, over = covered + int((counts > 0).sum()), over + int((counts > 1).sum())
    return over / covered if covered else 0.0


# -- statistics ----------------------------------------------------------------------


def chart_labels(uv_faces: np.ndarray, k: int) -> np.ndarray:
    """``(m,)`` int64 the chart of each face: connected pieces of the UV mesh (faces sharing
    one of the ``k`` UV vertices), numbered in the order of their first face."""
    uv_faces = np.ascontiguousarray(uv_faces, dtype=np.int64)
    labels = np.empty(len(uv_faces), dtype=np.int64)
    _native.face_components(uv_faces, k, labels)  # connected_components of the m + k nodes, without their edge arrays
    return labels


def atlas_stats(vertices, faces, uv_faces, uv) -> dict:
    """Chart count, utilisation and stretch of an atlas (``uv_faces`` index ``uv``).

    ``charts``: connected pieces of the UV mesh (faces sharing atlas vertices).
    ``utilisation``: the UV area covered, as a fraction of the unit square.
    ``stretch``: Sander et al.'s L2 stretch of the map from UV to the surface,
    normalised so that 1.0 is an isometry up to one global scale. Per face,
    ``L2^2 = (|dP/du|^2 + |dP/dv|^2) / 2``; over the mesh,
    ``stretch = sqrt(sum(A3d * L2^2) / sum(A3d)) * sqrt(sum(Auv) / sum(A3d))``. It grows
    with anisotropic distortion and with uneven texel density between faces (faces with
    zero UV area are left out).
    """
    return _stats_and_parts(vertices, faces, uv_faces, uv)[0]


def _stats_and_parts(vertices, faces, uv_faces, uv) -> tuple[dict, np.ndarray, np.ndarray]:
    """``(atlas_stats, (m,) 3D areas, (m,) chart of each face)``: the parts :func:`measure` uses again."""
    chart = chart_labels(uv_faces, len(uv))
    charts = int(chart.max()) + 1  # numbered 0, 1, ... (each one's first node is a face)

    ps, pt, det = uv_jacobian(vertices, faces, uv, uv_faces)  # dP/du, dP/dv
    ok = np.abs(det) > 0  # faces of zero UV area are left out
    l2sq = 0.5 * (np.einsum("ij,ij->i", ps, ps) + np.einsum("ij,ij->i", pt, pt))
    a_uv = 0.5 * np.abs(det)
    a_3d = areas(vertices, faces)
    w3, wuv = a_3d[ok].sum(), a_uv[ok].sum()
    if w3 > 0 and wuv > 0:
        stretch = float(np.sqrt((a_3d[ok] * l2sq[ok]).sum() / w3 * wuv / w3))
    else:
        stretch = float("inf")
    return {"charts": charts, "utilisation": float(a_uv.sum()), "stretch": stretch}, a_3d, chart


def measure(vertices: np.ndarray, faces: np.ndarray, uv_faces: np.ndarray, uv: np.ndarray, size: int,
            raster: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """:func:`atlas_stats` of an atlas for a ``size``-texel texture, plus ``overlap`` (the
    share of covered texel centres under two or more faces, on a grid of at most
    ``OVERLAP_GRID``) and ``bare_area`` (the share of the surface on charts that hold no
    texel centre at ``size``: their texels are all margin; None above 8192). ``raster``:
    :func:`coverage` of the layout on that grid, when already made."""
    grid = min(size, OVERLAP_GRID)
    stats, a3, chart = _stats_and_parts(vertices, faces, uv_faces, uv)
    counts, covering = raster if raster is not None else coverage(uv, uv_faces, grid)
    stats["overlap"], _ = overlap_of(counts)
    stats["bare_area"] = None
    if size <= 8192:
        held = np.zeros(chart.max() + 1, dtype=bool)
        held[chart[covering if grid == size else covering_faces(uv, uv_faces, size)]] = True
        stats["bare_area"] = float(a3[~held[chart]].sum() / max(a3.sum(), 1e-300))
    return stats


def bare_warning(stats: dict, size: int) -> list[str]:
    """A warning when more than ``BARE_LIMIT`` of the surface lies on charts without a texel
    centre (``stats["bare_area"]``, see :func:`measure`)."""
    share = stats["bare_area"]
    if share is None or share <= BARE_LIMIT:
        return []
    return [f"{share:.0%} of the surface lies on charts that hold no texel centre at {size}x{size}: they show "
            "only the margin's colours (bake larger, or unwrap)"]


BOX_PACKING = 0.9  # the share of the tile a packer fills with boxes (estimates; xatlas packs the charts' shapes)


def packing_estimate(vertices: np.ndarray, faces: np.ndarray, uv_faces: np.ndarray, uv: np.ndarray,
                     padding: float) -> float:
    """The utilisation a packing of a layout's islands (charts) would reach, estimated
    without packing: each island brought to one texel density (UV area = surface area),
    its axis-aligned bounding box grown by ``padding`` (tile units), the boxes scaled
    together until they fill ``BOX_PACKING`` of the tile; the islands' area at that scale.

    For an unwrap (islands at one density already) it says what its charts promise; for
    kept UVs, what repacking or unwrapping would give (an unwrap cuts other charts, but of
    like shapes). Rotated islands' boxes are larger than a packer's, so it errs low.
    """
    label = chart_labels(uv_faces, len(uv))
    k = int(label.max()) + 1
    a3 = np.bincount(label, areas(vertices, faces), minlength=k)
    auv = np.bincount(label, uv_areas(uv, uv_faces), minlength=k)
    lo, hi = label_boxes(uv, uv_faces, label, k)
    ok = (auv > 0) & (a3 > 0)
    if not ok.any():
        return 0.0
    grow = np.sqrt(a3[ok] / auv[ok])  # each island to one density
    w, h = (hi - lo)[ok, 0] * grow, (hi - lo)[ok, 1] * grow
    # boxes at scale g: sum((g w + p)(g h + p)) = BOX_PACKING, a quadratic in g
    qa, qb, qc = float((w * h).sum()), padding * float((w + h).sum()), ok.sum() * padding**2 - BOX_PACKING
    if qc >= 0 or qa <= 0:
        return 0.0
    g = (-qb + np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
    return float(min(1.0, g * g * a3[ok].sum()))
