"""Texel samples to surface samples: the texel lookup, the surface and the transfer
stages, chained over one batch type.

A :class:`Sampler` takes ``(m, 2)`` UV points (texel samples) to :class:`Samples`: the
atlas face under each (``texels.UVLookup``), the surface point, normal and footprint there
(``surface.SurfaceMap``), and, with a source mesh, the point on the source that rays along
the normal find (``transfer.SourceMesh``). The bake's tiles and the error estimate's
probe go through the same chain.
"""

from __future__ import annotations

import threading
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from .lookup import Tile, UVLookup, hits
from .surface import SurfaceMap

STEP_FACES = 1 << 20  # faces whose steps the sampler holds for the crease parts' test (48 MB at most); past them it is made in numpy


@dataclass
class Samples:
    """Surface samples of some of a batch's UV points; ``n`` rows each.

    ``index``: ``(n,)`` int64 position of each sample in the batch (a UV point that hit no
    face, or whose transfer ray missed, has no sample); ``points``, ``dpdx``, ``dpdy``:
    ``(n, 3)`` float64 object-space point and footprint (one texel right, one down; None
    when the sampler was made without footprints);
    ``normals``: ``(n, 3)`` float64 unit normals of the target surface, or None when the
    sampler was made without them; ``rays``: lookup rays cast for the batch;
    ``transfer_missed``: UV points whose transfer rays found no source; ``frame``: ``(n, 3, 3)`` float64 tangent frames (rows T, B, N) of the
    output mesh, or None when the sampler was made without one; ``coverage``: ``(n,)``
    float64 share of each sample's texel that its chart covers, where the footprints were
    cut to it (:meth:`Sampler.at_located`), else None; ``texel``: ``(n,)`` int64 the image
    texel (row-major) under each sample (what a material's ``mesh_map`` node reads);
    ``hull``: where footprints were cut, ``(rows (k,) int64, corners (k, HULL, 2))`` of the
    partly covered samples: the convex hull of the covered part of each one's texel in its
    cut footprint's frame (:meth:`UVLookup.footprint_hull`), else None.
    """

    index: np.ndarray
    points: np.ndarray
    normals: np.ndarray | None
    dpdx: np.ndarray | None
    dpdy: np.ndarray | None
    rays: int = 0
    transfer_missed: int = 0
    frame: np.ndarray | None = None
    coverage: np.ndarray | None = None
    texel: np.ndarray | None = None
    hull: tuple[np.ndarray, np.ndarray] | None = None


@dataclass
class Located:
    """Where a batch's UV points lie: ``count`` points, of which those at ``index`` (``(n,)``
    int64) hit a face: ``face`` ``(n,)``, ``bary`` ``(n, 3)`` float64; ``rays`` cast to
    find them; ``texel`` ``(n,)`` int64: the image texel (row-major) each lies in. It depends
    on the atlas and the points only: a later bake of the same atlas at the same size and
    samples may reuse it (``texbake.atlas.cache``)."""

    index: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    rays: int
    count: int
    texel: np.ndarray | None = None

    @property
    def nbytes(self) -> int:
        return self.index.nbytes + self.face.nbytes + self.bary.nbytes + (0 if self.texel is None else self.texel.nbytes)


class Sampler:
    """The lookup, surface and transfer stages for one mesh and its atlas.

    ``vertices`` ``(n, 3)`` and ``faces`` ``(m, 3)`` of the mesh; ``uv`` ``(k, 2)`` and
    ``uv_faces`` ``(m, 3)`` of its atlas; ``width``, ``height``: the image size;
    ``normals``: also interpolate normals, True (smooth) or corner normals, ``(m, 3, 3)`` or
    ``(normals (q, 3), faces (m, 3) into them)`` (``surface.SurfaceMap``; a transfer always
    interpolates smooth ones: its rays must
    not part at hard edges); ``source``: a
    ``(vertices, faces)`` pair to transfer from, with rays of at most ``reach``; ``frame``:
    corner normals and tangents of the output mesh (``surface.SurfaceMap``);
    ``footprints``: the samples' ``dpdx``, ``dpdy`` (False: None, for a bake that
    point-samples and needs no bump).
    """

    def __init__(self, vertices, faces, uv, uv_faces, width: int, height: int, *,
                 normals: bool | np.ndarray | tuple[np.ndarray, np.ndarray] = False,
                 source: tuple[np.ndarray, np.ndarray] | None = None, reach: float = 0.0,
                 frame: tuple[np.ndarray, np.ndarray] | None = None, footprints: bool = True):
        self.width, self.height, self.footprints = width, height, footprints
        self.lookup = UVLookup(uv, uv_faces)
        self.surface = SurfaceMap(vertices, faces, uv, uv_faces, width, height, normals=True if source is not None else normals,
                                  frame=frame)
        self.caster = None
        if source is not None:
            from .transfer import SourceMesh

            self.caster = SourceMesh(*source)
        self.reach = reach
        self._bends: dict[float, np.ndarray] = {}
        self._steps: np.ndarray | None = None
        self._face_count = len(faces)
        self._lock = threading.Lock()  # the tile threads ask for bends and steps together

    def bends(self, kink: float) -> np.ndarray:
        """``(m,)`` bool: the faces whose steps on the surface differ from those of a face
        sharing a UV corner by more than ``kink`` (``SurfaceMap.bends``: where the surface
        bends, or its UVs change scale). Made once a ``kink``."""
        with self._lock:
            found = self._bends.get(kink)
            if found is None:
                found = self._bends[kink] = self.surface.bends(kink)
            return found

    def steps(self) -> np.ndarray | None:
        """``(m, 6)`` each face's ``dpdx``, ``dpdy`` (``SurfaceMap.steps``), made once; None
        past ``STEP_FACES`` faces (48 bytes a face)."""
        if self._face_count > STEP_FACES:
            return None
        with self._lock:
            if self._steps is None:
                self._steps = self.surface.steps()
            return self._steps

    def candidates(self, tile: Tile) -> np.ndarray:
        """``(t,)`` indices of the texels of ``tile`` that some face can cover."""
        return self.lookup.candidates(tile, self.width, self.height)

    def locate(self, uvs: np.ndarray, samples: int = 1) -> Located:
        """The faces under ``(m, 2)`` UV points, ``samples`` a texel in ``sample_uv``'s order
        (``texels.UVLookup.locate``)."""
        face, bary, rays = self.lookup.locate(uvs, samples)
        index, face, bary = hits(face, bary)
        return Located(index, face, bary, rays, len(uvs), self._texels(uvs[index]))

    def _texels(self, uvs: np.ndarray) -> np.ndarray:
        """``(n,)`` int64 row-major texel of each of ``(n, 2)`` UV points (v up, row 0 at the top)."""
        col = np.clip(np.floor(uvs[:, 0] * self.width), 0, self.width - 1).astype(np.int64)
        row = np.clip(np.floor((1.0 - uvs[:, 1]) * self.height), 0, self.height - 1).astype(np.int64)
        return row * self.width + col

    def at(self, uvs: np.ndarray, timer=None, samples: int = 1) -> Samples:
        """Surface samples at ``(m, 2)`` UV points (:meth:`locate`, :meth:`at_located`);
        ``timer.stage(name)`` times each stage."""
        with (timer.stage("lookup") if timer is not None else nullcontext()):
            located = self.locate(uvs, samples)
        return self.at_located(located, timer)

    def at_located(self, located: Located, timer=None, cut: bool = False, hull: bool = False) -> Samples:
        """Surface samples (and, with a source, transferred ones) where ``located`` says.

        ``cut`` (one sample a texel, with footprints): each footprint is the part of its
        texel that its chart covers (:meth:`UVLookup.footprint_clip`: the point moves to
        that part's centre, ``dpdx``, ``dpdy`` shrink to its extent), so that a filter at
        a chart's edge averages only where the surface is; ``hull``: and the partly
        covered ones' hulls (``Samples.hull``), for a texture that reads them.
        """
        stage = timer.stage if timer is not None else (lambda name: nullcontext())
        index, rays = located.index, located.rays
        with stage("surface"):
            s = self.surface.samples(located.face, located.bary, self.footprints)
            coverage, hulls = self._cut(located, s, hull) if cut and s.dpdx is not None else (None, None)
        found = Samples(index, s.points, s.normals, s.dpdx, s.dpdy, rays=rays, frame=s.frame, coverage=coverage, texel=located.texel,
                        hull=hulls)
        if self.caster is None:
            return found
        with stage("transfer"):
            assert s.normals is not None  # a transfer's surface map has normals
            points, hit = self.caster.project(s.points, s.normals, self.reach)
            return Samples(index[hit], points[hit], s.normals[hit], None if s.dpdx is None else s.dpdx[hit],
                           None if s.dpdy is None else s.dpdy[hit], rays=rays,
                           transfer_missed=int((~hit).sum()), frame=None if s.frame is None else s.frame[hit],
                           coverage=None if coverage is None else coverage[hit],
                           texel=None if located.texel is None else located.texel[hit], hull=_kept_rows(hulls, hit))

    def _cut(self, located: Located, s, hull: bool) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """Cut the footprints of ``s`` (surface samples of ``located``, one a texel) to the
        part of each texel its chart covers, in place; returns ``(n,)`` the covered shares
        and, if ``hull``, the partly covered samples' hulls (``Samples.hull``; else None)."""
        shift, edges, area, partial = self.lookup.footprint_clip(located.face, located.bary, self.width, self.height)
        if not partial:
            return area, None
        part = np.flatnonzero(area < 1.0)
        dx, dy, e, d = s.dpdx[part], s.dpdy[part], edges[part], shift[part]
        s.points[part] += d[:, :1] * dx + d[:, 1:] * dy
        s.dpdx[part] = e[:, 0, :1] * dx + e[:, 1, :1] * dy
        s.dpdy[part] = e[:, 0, 1:] * dx + e[:, 1, 1:] * dy
        if not hull:
            return area, None
        return area, (part, self.lookup.footprint_hull(located.face[part], located.bary[part], self.width, self.height, d, e))


def _kept_rows(hull: tuple[np.ndarray, np.ndarray] | None, kept: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``hull`` (``Samples.hull``) of the samples ``kept`` ``(n,)`` bool leaves, its rows renumbered."""
    if hull is None:
        return None
    rows, corners = hull
    stays = kept[rows]
    return (np.cumsum(kept)[rows[stays]] - 1, corners[stays])
