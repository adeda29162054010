"""One tile for a mesh whose parts bring UVs only in part: the UVs of the parts that have
them kept, the other parts' unwrap put beside them.

The kept layout moves only as one piece: every island keeps its shape and its place
relative to the others (the kept UVs become ``s * uv + t``, or that turned a quarter).
It stays exactly where it is when the largest strip of the tile beside its bounding box
holds the new charts at ``IN_PLACE_DENSITY`` or more of its texel density (the charts are
packed again into a square of that strip, at the texture's padding). Otherwise its
bounding box is packed by xatlas as one rigid rectangle together with the new charts,
both at one texel density, and the layout is scaled and moved with its rectangle.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..mesh import areas, uv_areas
from ..workers import Pool
from .pack import Unwrapped, UnwrapRequest, XatlasFailed, _pack

IN_PLACE_DENSITY = 0.5  # the kept layout stays put when the new charts get this share of its texel density (by area)


class Combined(NamedTuple):
    """The whole mesh's atlas, as :class:`texbake.atlas.decide.Atlas` holds it."""

    vmapping: np.ndarray  # (k,) int64: atlas vertex -> mesh vertex
    faces: np.ndarray  # (m, 3) int64: the mesh's faces in atlas vertices
    uv: np.ndarray  # (k, 2) float64 in the unit square
    scale: float  # of the kept layout: 1.0 where it stayed in place
    how: str  # what was done with the kept layout, in words


def combine(request: UnwrapRequest, has_uv: np.ndarray, uv: np.ndarray, new: Unwrapped, used: np.ndarray,
            pool: Pool, deadline: float) -> Combined:
    """The atlas of ``request``'s mesh from the UVs ``uv`` (n, 2) of the faces ``has_uv``
    (m,) bool and ``new``, the unwrap of the other faces (in their order) as a mesh whose
    vertex ``i`` is mesh vertex ``used[i]``; packing in ``pool``'s workers. Raises
    :class:`texbake.atlas.pack.XatlasFailed`."""
    vertices, faces = request.vertices, request.faces
    kv, local = np.unique(faces[has_uv], return_inverse=True)
    kuv, kf = np.asarray(uv, dtype=np.float64)[kv], local.reshape(-1, 3)
    nvm, nf, nuv = used[new.vmapping], new.faces, new.uv
    kept_density = uv_areas(kuv, kf).sum() / areas(vertices, faces[has_uv]).sum()  # tile area per surface area
    new_area = float(areas(vertices, faces[~has_uv]).sum())
    placed = _in_place(request, kuv, nf, nuv, kept_density, new_area, pool, deadline)
    if placed is not None:
        vm2, nf, nuv = placed
        nvm, scale, how = nvm[vm2], 1.0, "kept in place; the other parts' charts packed beside them"
    else:
        vm2, nf, nuv, kuv, scale, turned = _together(request, kuv, nf, nuv, kept_density, new_area, pool, deadline)
        nvm = nvm[vm2]
        how = (f"moved as one piece{', turned' if turned else ''} and scaled by {scale:.3g} (each island's shape and "
               "place in the layout kept), packed together with the other parts' charts")
    out_faces = np.empty_like(faces)
    out_faces[has_uv] = kf
    out_faces[~has_uv] = nf + len(kv)
    return Combined(np.concatenate([kv, nvm]).astype(np.int64), out_faces, np.concatenate([kuv, nuv]), scale, how)


def _in_place(request, kuv, nf, nuv, kept_density, new_area, pool, deadline):
    """``(vmapping into nuv, faces, uv)`` of the new charts packed again into a square of the
    largest strip beside the kept layout's bounding box, or None when that square gives
    them less than ``IN_PLACE_DENSITY`` of ``kept_density``."""
    size, pad = request.size, request.padding / request.size
    lo, hi = kuv.min(axis=0), kuv.max(axis=0)
    strips = [  # (x, y, width, height) beside the layout, a padding away
        (hi[0] + pad, 0.0, 1.0 - hi[0] - pad, 1.0), (0.0, 0.0, lo[0] - pad, 1.0),
        (0.0, hi[1] + pad, 1.0, 1.0 - hi[1] - pad), (0.0, 0.0, 1.0, lo[1] - pad),
    ]
    x, y, w, h = max(strips, key=lambda s: min(s[2], s[3]))
    new_use = float(uv_areas(nuv, nf).sum())  # of the whole tile, as unwrapped
    equal = np.sqrt(kept_density * new_area / new_use)  # the square's side at the layout's density
    side = min(w, h, equal)
    if side <= 0 or side < np.sqrt(IN_PLACE_DENSITY) * equal or side * size < 8:
        return None
    texels = int(side * size)
    vm2, f2, uv2 = _pack(None, nf, [(np.arange(len(nf)), np.arange(len(nuv)), nuv, nf)], texels, request.padding, pool,
                         deadline, [])
    return vm2, f2, uv2 * (texels / size) + [x, y]


def _together(request, kuv, nf, nuv, kept_density, new_area, pool, deadline):
    """``(vmapping into nuv, faces, uv, kept uv, kept scale, turned)``: the kept layout's
    bounding box packed as one rectangle with the new charts, at one density (xatlas may
    turn it: ``turned``)."""
    lo, hi = kuv.min(axis=0), kuv.max(axis=0)
    corners = np.array([lo, [hi[0], lo[1]], hi, [lo[0], hi[1]]])
    new_density = float(uv_areas(nuv, nf).sum()) / new_area
    rect = (corners - lo) * np.sqrt(new_density / kept_density)  # at the new charts' density
    n = len(nf)
    meshes = [(np.arange(n), np.arange(len(nuv)), nuv, nf),
              (np.array([n, n + 1]), np.zeros(4, dtype=np.int64), rect, np.array([[0, 1, 2], [0, 2, 3]]))]
    vm2, f2, uv2 = _pack(None, np.vstack([nf, np.zeros((2, 3), dtype=np.int64)]), meshes, request.size, request.padding,
                         pool, deadline, [])
    placed = uv2[-4:]  # the rectangle's corners, in their order (the last mesh)
    x = np.column_stack([corners, np.ones(4)])
    fit, *_ = np.linalg.lstsq(x, placed, rcond=None)  # (3, 2): the layout's affine map
    if np.abs(x @ fit - placed).max() > 1e-4 * max(np.ptp(placed), 1e-12):
        raise XatlasFailed("xatlas' packing distorted the kept UV layout")
    scale = float(np.sqrt(abs(np.linalg.det(fit[:2]))))
    turned = not np.allclose(fit[:2], scale * np.eye(2), atol=1e-3 * scale)
    return vm2[:-4], f2[:n], uv2[:-4], np.column_stack([kuv, np.ones(len(kuv))]) @ fit, scale, turned
