"""Creases: a filtered texel whose surface bends, filtered a face at a time.

One filtered sample a texel takes its footprint from the face under the texel's centre:
the parallelogram of that face's steps along the texel's edges. Where the texel spans
faces that meet at an angle, or whose UVs stretch the surface otherwise, the texel's
surface is not that parallelogram: it reaches off the surface on one side and misses
surface on the other, and a filter that reads the footprint exactly (the checker's and
the wood's closed forms) averages the wrong place. Such a texel is filtered in parts, one
in each face (``UVLookup.texel_parts``: the part's box of the same mean and covariance,
in that face's own steps), and its value is the parts' mean weighted by their shares of
the texel. Only where the faces' steps differ by more than ``KINK`` of the sample's own:
faces that lie in one plane with one UV scale need no parts (a flat chart of a CAD part).

The parts' boxes stand in for polygons (a texel cut by an edge), so parts are only worth
it where the bend is large. Filtered RMSE against 256 point samples a texel at 512², one
filtered sample (``bench/bench_error.py``'s bake), in units of 1e-4:

============================  =======  =========  =====  =====  =====
KINK                          0        0.05       0.1    0.2    none
============================  =======  =========  =====  =====  =====
bunny.ply, wood               6.79     6.29       6.05   5.95   6.65
fandisk.obj, checker          21.9     16.6       16.1   15.6   16.7
featuretype.STL, checker               14.6       16.4   18.2   35.6
suzanne.ply, wood                      3.88       3.87   3.95   9.99
============================  =======  =========  =====  =====  =====

(0 and 0.05 before faces were flagged by their UV neighbours alone.) At 0.2, over the
bench's 13 meshes and 4 textures: every RMSE the same (within 1 %) or lower (suzanne.ply's wood 0.40x,
checker 0.55x, featuretype's checker 0.51x, gear_cad's 0.75x), 1.00-1.32 texture
evaluations a covered texel, and every estimate within 0.5-2 of the RMSE (without:
bunny's and suzanne.ply's wood 0.45 and 0.38). The cost: suzanne.ply's wood at 512², the
tile loop 0.056 -> 0.090 s (most of its faces bend); Suzanne's marble at 2048² (2 % of
its faces bend) 0.03 CPU-s.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .sampler import Located, Sampler, Samples

KINK = 0.2  # a part's steps differing from the sample's by more than this (relative): the texel is filtered in parts
LEAST = 0.01  # parts under this share of the texel are left out (the rest renormalised)
UNIT = ("normal",)  # maps of unit vectors stored as 0.5 + 0.5 n (either green convention): the parts' mean made unit again


def refine(sampler: Sampler, values_of: Callable[[Samples], dict[str, np.ndarray]], located: Located, s: Samples,
           values: dict[str, np.ndarray]) -> int:
    """Replace, in place, the values of the samples ``s`` (one a texel, ``located``'s, no
    transfer) whose texels bend (see the module) with the share-weighted mean of their
    parts' values (``values_of`` at the parts' surface samples). Returns the parts
    evaluated."""
    if s.dpdx is None or s.dpdy is None or sampler.caster is not None:
        return 0
    rows, face, share, uv, edges = sampler.lookup.texel_parts(located.face, located.bary, sampler.width, sampler.height, LEAST,
                                                              sampler.bends(KINK))
    if not len(rows):
        return 0
    part = sampler.surface.samples(face, sampler.lookup.barycentric(uv, face), True)
    assert part.dpdx is not None and part.dpdy is not None
    # how far each part's steps are from its sample's own: a bend, or another UV scale
    own_x, own_y = s.dpdx[rows], s.dpdy[rows]
    scale = np.linalg.norm(own_x, axis=1) + np.linalg.norm(own_y, axis=1)  # as Sampler.bends measures
    off = (np.linalg.norm(part.dpdx - own_x, axis=1) + np.linalg.norm(part.dpdy - own_y, axis=1)) / np.maximum(scale, 1e-300)
    bent = np.zeros(len(s.points), dtype=bool)
    bent[rows[off > KINK]] = True
    keep = bent[rows]
    if not keep.any():
        return 0
    rows, share, edges = rows[keep], share[keep], edges[keep]
    dx, dy = part.dpdx[keep], part.dpdy[keep]
    parts = Samples(np.arange(len(rows)), part.points[keep], None if part.normals is None else part.normals[keep],
                    edges[:, 0, :1] * dx + edges[:, 1, :1] * dy, edges[:, 0, 1:] * dx + edges[:, 1, 1:] * dy,
                    frame=None if part.frame is None else part.frame[keep],
                    texel=None if s.texel is None else s.texel[rows])
    found = values_of(parts)
    which = np.flatnonzero(bent)
    # a sample's parts are together, in the samples' order: each sample's sum over its run
    # (np.add.reduceat, not np.add.at's scattered adds)
    starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
    for name, v in found.items():
        total = np.add.reduceat(share[:, None] * v, starts, axis=0)
        if name in UNIT:
            n = 2.0 * total - 1.0
            total = 0.5 + 0.5 * n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        values[name][which] = total
    return len(rows)
