"""Creases: a filtered texel whose surface bends, filtered a face at a time.

One filtered sample a texel takes its footprint from the face under the texel's centre:
the parallelogram of that face's steps along the texel's edges. Where the texel spans
faces that meet at an angle, or whose UVs stretch the surface otherwise, the texel's
surface is not that parallelogram: it reaches off the surface on one side and misses
surface on the other, and a filter that reads the footprint exactly (the checker's and
the wood's closed forms) averages the wrong place. Such a texel is filtered in parts, one
in each face (``UVLookup.texel_parts``: the part's box of the same mean and covariance,
in that face's own steps), and its value is the parts' mean weighted by their shares of
the texel. Only where either of a face's two steps differs from the same step of a face
sharing one of its UV corners by more than ``KINK`` of the longer of its steps: faces that
lie in one plane with one UV scale need no parts (a flat chart of a CAD part). Either step,
not the two summed: at a crease of a cylinder or a torus only the step across it turns,
and the sum read a 15 degree bend as 0.13. A corner, not only an edge: a texel on a
vertex spans the faces of its fan (featuretype.STL's checker at 512²: 0.84x the RMSE of
comparing across edges only; every other mesh's checker and wood within 0.5 %).

The parts' boxes stand in for polygons (a texel cut by an edge), so parts are only worth
it where the bend is large. Filtered RMSE (the point-sampled reference's own error taken
out, ``texbake.checks.sweep``) against 1058 point samples a texel at 512², one filtered
sample, in units of 1e-4, with the two criteria:

============================  ==========  ==========  ==========  ==========
criterion, KINK               sum, 0.2    either 0.15 either 0.2  either 0.3
============================  ==========  ==========  ==========  ==========
torus, wood                   3.90        1.86        1.86        3.90
torus, checker                12.3        11.5        11.5        12.3
bunny.ply, checker            21.9        20.2        20.4        21.8
fandisk.obj, checker          8.13        8.72        8.38        8.13
featuretype.STL, checker      14.3        12.0        14.0        14.3
featuretype.STL, wood         4.57        3.32        4.22        4.57
suzanne.ply, wood             2.62        2.51        2.53        4.06
============================  ==========  ==========  ==========  ==========

At either 0.2, over the bench's 13 meshes and 4 textures, every RMSE is within 1 % of the
sum's or lower but fandisk's checker (1.03x); the torus' wood estimate went from 0.33 to
0.85 of its RMSE (its error was on the ~300 crease texels a 4096-texel draw mostly missed).
The cost is the parts: 0 -> 34k on the torus, 2.6k -> 13k on suzanne_blender_uv.obj (20k
with the corners), 34k -> 57k on the bunny (63k). Before, with the sum: at 0.2 against no
parts, suzanne.ply's wood 0.40x, checker 0.55x, featuretype's checker 0.51x, gear_cad's
0.75x; the tile loop of suzanne.ply's wood at 512² 0.056 -> 0.090 s (most of its faces bend).

Which texels bend is tested as their parts are made (``texel_parts`` given each face's
steps, ``Sampler.steps``): a face that bends from some face of its fan has most of its
texels over faces it does not bend from. Made first and tested in numpy afterwards,
bunny.ply's parts at 512² were 172k for 63k kept, and its crease stage took 0.24 s of a
0.43 s tile loop (marble; now 0.13 s, the same image).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .sampler import Located, Sampler, Samples

KINK = 0.2  # a part's step differing from the sample's by more than this of its longer step: the texel is filtered in parts
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
    steps = sampler.steps()  # the parts' test made as the parts are (None: here, after)
    rows, face, share, uv, edges = sampler.lookup.texel_parts(located.face, located.bary, sampler.width, sampler.height, LEAST,
                                                              sampler.bends(KINK), steps, KINK)
    if not len(rows):
        return 0
    part = sampler.surface.samples(face, sampler.lookup.barycentric(uv, face), True)
    assert part.dpdx is not None and part.dpdy is not None
    bent = np.zeros(len(s.points), dtype=bool)
    if steps is None:
        # how far each part's steps are from its sample's own: a bend, or another UV scale
        # (a texel's samples are whole, not cut: its own steps are its face's, as texel_parts reads them)
        own_x, own_y = s.dpdx[rows], s.dpdy[rows]
        scale = np.maximum(np.linalg.norm(own_x, axis=1), np.linalg.norm(own_y, axis=1))  # as Sampler.bends measures
        off = np.maximum(np.linalg.norm(part.dpdx - own_x, axis=1), np.linalg.norm(part.dpdy - own_y, axis=1)) / np.maximum(scale, 1e-300)
        bent[rows[off > KINK]] = True
        keep = bent[rows]
        if not keep.any():
            return 0
        rows, share, edges = rows[keep], share[keep], edges[keep]
        part = part.take(keep)
    else:
        bent[rows] = True
    dx, dy = part.dpdx, part.dpdy
    assert dx is not None and dy is not None
    parts = Samples(np.arange(len(rows)), part.points, part.normals,
                    edges[:, 0, :1] * dx + edges[:, 1, :1] * dy, edges[:, 0, 1:] * dx + edges[:, 1, 1:] * dy,
                    frame=part.frame, texel=None if s.texel is None else s.texel[rows])
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
