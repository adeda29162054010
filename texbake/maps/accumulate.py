"""The maps a bake makes: only those asked for, their values for a batch of samples, and
their images (the mean of each texel's samples).

``albedo`` (or ``albedo_0000``... for the frames of an animated texture), ``lit`` when
the shading is not "decal", ``normal`` when a bump texture is given; for a material, its
channels' maps instead of the albedo (``material.MaterialMaps``: ``base_color``,
``roughness``, ...; ``lit`` from the base colour). Images are ``(height, width, c)``
float32, c = 3 (1 for a material's scalar channels), linear, row 0 at the top; ``hits``
counts the samples that reached each texel (uint8 up to 255 samples a texel).

Images of more than ``HALF_TEXELS`` texels that are written as 8-bit integers (the
default PNG) are held as float16: half the memory (a 16384² albedo in 1.6 GB, not 3.2),
and the same file within one 8-bit step (float16 holds 11 bits; an 8-bit sRGB step is
at least 0.3 % of the value).
"""

from __future__ import annotations

from contextlib import nullcontext
from typing import TYPE_CHECKING

import numpy as np

from .. import _native
from ..formats import DEFAULT_BITS
from ..sampling import Samples, Tile
from ..settings import BakeSettings
from ..textures.mapping import TextureMapping
from .bump import LUMINANCE, normal_map
from .shading import lit

if TYPE_CHECKING:
    from .material import MaterialMaps

HALF_TEXELS = 8192 * 8192  # larger images written as 8 bits are held as float16


class Maps:
    """The maps of one bake of ``width x height`` texels."""

    def __init__(self, settings: BakeSettings, mapping: TextureMapping):
        spec, (width, height) = settings.texture, settings.width_height
        self.material: MaterialMaps | None = None
        if settings.material is not None:
            from .material import MaterialMaps  # the material model: only a material's bake imports it

            self.material = MaterialMaps(settings, mapping)
        if self.material is not None:
            self.colours: dict = {}
            widths = dict(self.material.widths)
            self.colour_name: str | None = "base_color"
        elif spec is None:  # texture none: the mesh maps alone (texbake.settings)
            self.colours, widths = {}, {}
            self.colour_name = None
        else:
            if settings.frames is None:
                self.colours = {"albedo": spec}
            else:
                self.colours = {f"albedo_{i:04d}": spec.model_copy(update={"time": t}) for i, t in enumerate(settings.frames)}
            widths = dict.fromkeys([*self.colours, *(["normal"] if settings.bump is not None else [])], 3)
            self.colour_name = next(iter(self.colours))  # the map the error estimate and the GLB use
        if settings.shading != "decal":
            widths["lit"] = 3
        # the cut footprints' hulls (texbake.sampling.Samples.hull) are made only for a texture that reads them
        self.reads_hull = settings.filtering and any(spec.reads_hull() for spec in self.colours.values())
        self.settings, self.mapping = settings, mapping
        self.width, self.height, self.samples = width, height, settings.samples
        eight_bit = (settings.bits or DEFAULT_BITS[settings.format]) == 8
        dtype = np.float16 if eight_bit and width * height > HALF_TEXELS else np.float32
        self.images = {name: np.zeros((height, width, c), dtype=dtype) for name, c in widths.items()}
        self.hits = np.zeros((height, width), dtype=np.uint8 if self.samples < 256 else np.uint16 if self.samples < 65536 else np.uint32)

    def add_mesh_maps(self, images: dict[str, np.ndarray]) -> None:
        """Take the mesh maps' finished images (``texbake.meshmaps``): written and margin-filled
        with the rest, and read by a material's ``mesh_map`` nodes."""
        self.images.update(images)
        if self.material is not None:
            self.material.mesh_images = images

    @property
    def per_sample(self) -> bool:
        """Whether any map is made of the bake's own samples (a texture's, a material's):
        without one (texture none) the mesh maps' texels are the whole bake."""
        return bool(self.colours) or self.material is not None

    @property
    def needs_normals(self) -> bool:
        uses_normal = self.material is not None and any(n.op in ("normal", "mtlx") for n in self.material.material.graph.nodes.values())
        return self.settings.shading != "decal" or self.settings.normal_map or uses_normal

    @property
    def estimated(self) -> list[str]:
        """The maps the error estimate covers: the colour map, and a material's every map."""
        if self.material is not None:
            return list(self.material.widths)
        return [] if self.colour_name is None else [self.colour_name]

    def reference(self, s: Samples) -> dict[str, np.ndarray]:
        """``map -> (n, c)`` the error probe's reference of each of :attr:`estimated` at the
        samples ``s``: point-sampled, float64, every octave."""
        if self.material is not None:
            return self.material.values(s, exact=True, count=False)
        name = self.colour_name
        assert name is not None  # only the maps of a texture are estimated
        return {name: self.mapping.evaluate(self.colours[name], s.points, None, None, exact=True)}

    def packs(self, images: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """The packed maps of a material's ``packing`` templates, from its finished ``images``."""
        if self.material is None or not self.settings.packing:
            return {}
        from ..materials import DEFAULTS, pack

        return {t.name: pack(t, images, DEFAULTS) for t in self.settings.packing}

    def values(self, s: Samples, timer=None) -> dict[str, np.ndarray]:
        """``(n, 3)`` float64 values of every map at the samples ``s``."""
        stage = timer.stage if timer is not None else (lambda name: nullcontext())
        settings, mapping, octaves = self.settings, self.mapping, self.settings.max_octaves
        with stage("texture" if self.material is None else "material"):
            dpdx, dpdy = (s.dpdx, s.dpdy) if settings.filtering else (None, None)
            hull = s.hull if settings.filtering else None
            values = {name: mapping.evaluate(spec, s.points, dpdx, dpdy, max_octaves=octaves, hull=hull)
                      for name, spec in self.colours.items()}
            if self.material is not None:
                values.update(self.material.values(s))
        if settings.shading != "decal":
            with stage("shading"):
                values["lit"] = lit(values[self.colour_name], s.normals, mode=settings.shading, light=settings.light)
        if settings.bump is not None and self.material is None:
            with stage("bump"):
                q, dqdx, dqdy = mapping.to_space(s.points, s.dpdx, s.dpdy)
                height_of = lambda x: mapping.evaluate_in_space(settings.bump, x, max_octaves=octaves) @ LUMINANCE
                values["normal"] = normal_map(height_of, q, dqdx, dqdy, s.normals, settings.bump_strength, frame=s.frame)
                if settings.normal_convention == "directx":
                    values["normal"][:, 1] = 1.0 - values["normal"][:, 1]  # green down: -Y
        return values

    def accumulate(self, tile: Tile, texel: np.ndarray, values: dict[str, np.ndarray]) -> None:
        """Write the rows of ``tile``: ``texel`` ``(n,)`` is each sample's texel index
        within the tile (row-major, non-decreasing: a texel's samples are contiguous);
        each texel gets the mean of its samples."""
        rows, width = tile.stop - tile.start, self.width
        texel = np.asarray(texel, dtype=np.int64)
        where, count = (texel, 1) if self.samples == 1 else _runs(texel)  # one sample a texel: a hit is a count of one
        for name, v in values.items():
            image = self.images[name]
            block = image[tile.start : tile.stop].reshape(rows * width, image.shape[2])
            block[:] = 0
            block[where] = v if self.samples == 1 else _run_means(v, np.asarray(count))
        hits = self.hits[tile.start : tile.stop].reshape(rows * width)
        hits[:] = 0
        hits[where] = count


def _runs(texel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(texels (k,) int64, counts (k,) int64)``: the texel and the length of each of the
    ``k`` runs of equal values of a non-decreasing ``texel`` ``(n,)`` int64 (compiled: no GIL)."""
    where, count = np.empty(len(texel), dtype=np.int64), np.empty(len(texel), dtype=np.int64)
    k = _native.runs(np.ascontiguousarray(texel, dtype=np.int64), where, count)
    return where[:k], count[:k]


def _run_means(v: np.ndarray, count: np.ndarray) -> np.ndarray:
    """``(k, c)`` float64: the mean of ``v`` ``(n, c)`` float64 over each run of
    :func:`_runs`' ``count`` samples, summed in order (as ``np.bincount`` sums; compiled: no GIL,
    for c = 3; NumPy's ``add.reduceat`` for a material's one-channel maps)."""
    if v.shape[1] != 3:
        if not len(count):
            return np.zeros((0, v.shape[1]))
        starts = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
        return np.add.reduceat(np.asarray(v, dtype=np.float64), starts, axis=0) / np.asarray(count)[:, None]
    out = np.empty((len(count), 3))
    _native.run_means(np.ascontiguousarray(v, dtype=np.float64), np.ascontiguousarray(count), out)
    return out
