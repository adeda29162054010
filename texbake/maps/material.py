"""A material's maps: one per channel it gives, and the normal map from its ``height`` (or
its ``normal`` channel), all from one evaluation of the material a batch of samples.

Maps: ``base_color`` and ``emissive`` are colour (written sRGB), the rest data (linear):
``roughness``, ``metallic``, ``height``, ``occlusion``, ``opacity`` one channel each;
``normal`` three (``0.5 + 0.5 n``, tangent space, green up (+Y, OpenGL, glTF) or down
(-Y, DirectX) as ``normal_convention`` says). The normal map is the height's relief
(``bump.height_normal_map``, compiled: ``height_scale`` of the material), laid over the ``normal``
channel where there is one; a ``normal`` channel alone is that normal map, made unit.
"""

from __future__ import annotations

import numpy as np

from .. import _native
from ..materials import Evaluator
from ..materials.graph import CHANNELS
from ..materials.nodes import COLOUR
from ..settings import BakeSettings
from ..textures.mapping import TextureMapping

_NONE3, _NONE33 = np.zeros((0, 3)), np.zeros((0, 3, 3))  # stand-ins for arrays a kernel is given none of
COLOUR_MAPS = ("base_color", "emissive")  # written as sRGB colour; every other map of a material is data


class MaterialMaps:
    """The maps of a bake of ``settings.material``."""

    def __init__(self, settings: BakeSettings, mapping: TextureMapping):
        material = settings.material
        assert material is not None
        self.material, self.settings, self.mapping = material, settings, mapping
        given = material.channels
        self.evaluator = Evaluator(material, given)
        self.mesh_images: dict[str, np.ndarray] = {}  # the mesh maps its mesh_map nodes read, baked first (texbake.meshmaps)
        self.widths = {c: 3 if CHANNELS[c] == COLOUR else 1 for c in given if c != "normal"}
        if settings.normal_map:
            self.widths["normal"] = 3

    def values(self, s, *, exact: bool = False, count: bool = True) -> dict[str, np.ndarray]:
        """``map -> (n, width)`` float64 values at the samples ``s`` (``texbake.sampling.Samples``):
        filtered over their footprints as the settings say, or point-sampled in float64
        with every octave (``exact``: the error probe's reference, not counted)."""
        settings, mapping = self.settings, self.mapping
        q, dqdx, dqdy = mapping.to_space(s.points, s.dpdx, s.dpdy)
        filtered = settings.filtering and not exact and dqdx is not None
        octaves = None if exact else settings.max_octaves
        values = self.evaluator.values(mapping, q, dqdx if filtered else None, dqdy if filtered else None, s.normals,
                                       max_octaves=octaves, exact=exact, count=count, mesh_maps=self._mesh_maps_at(s))
        if "normal" in self.widths:
            values["normal"] = self._normal(values.get("normal"), values.get("height"), s, q, dqdx, dqdy, filtered, octaves, exact,
                                            count)
        return values

    def _mesh_maps_at(self, s):
        """A reader of the mesh maps' values at the samples ``s`` (their texels' in
        :attr:`mesh_images`), or None for a material that reads none."""
        if not self.evaluator.mesh_maps:
            return None

        def read(name: str) -> np.ndarray:
            image = self.mesh_images.get(name)
            if image is None or s.texel is None:
                raise ValueError(f"mesh map {name!r}: not baked before the material (or the samples have no texels)")
            return image.reshape(-1, image.shape[2])[s.texel].astype(np.float64)

        return read

    def _normal(self, given, centre, s, q, dqdx, dqdy, filtered: bool, octaves, exact: bool, count: bool) -> np.ndarray:
        """The encoded normal map: the height's relief over the ``normal`` channel (either alone)."""
        directx = self.settings.normal_convention == "directx"
        if "height" not in self.material.graph.channels:
            d = 2.0 * np.asarray(given, dtype=np.float64) - 1.0
            length = np.linalg.norm(d, axis=1, keepdims=True)
            encoded = 0.5 + 0.5 * np.divide(d, length, out=np.tile([0.0, 0.0, 1.0], (len(d), 1)), where=length > 0)
            if directx:
                encoded[:, 1] = 1.0 - encoded[:, 1]  # green down: -Y
            return encoded
        # bump.height_normal_map's forward differences (it is the reference), compiled
        fx, fy = np.concatenate([dqdx, dqdx]), np.concatenate([dqdy, dqdy])
        normals = None if s.normals is None or not self.evaluator.height_uses_normals else np.concatenate([s.normals, s.normals])
        at = self._mesh_maps_at(s)  # the offset points read their sample's texel: both halves the samples'
        twice = None if at is None else (lambda name: np.concatenate([at(name), at(name)]))
        shifted = self.evaluator.heights(self.mapping, np.concatenate([q + 0.5 * dqdx, q + 0.5 * dqdy]), fx if filtered else None,
                                         fy if filtered else None, normals, max_octaves=octaves, exact=exact, count=count,
                                         mesh_maps=twice)
        out = np.empty((len(q), 3))
        _native.height_normals(np.ascontiguousarray(centre[:, 0]), shifted, dqdx, dqdy, _NONE3 if s.frame is not None else s.normals,
                               _NONE33 if s.frame is None else s.frame, float(self.material.height_scale),
                               _NONE3 if given is None else np.ascontiguousarray(given), directx, out)
        return out

    def report(self) -> dict:
        """The report's ``material``: its name, the maps made, the channels that are constants,
        and each node's evaluations (``Evaluator.report``)."""
        constants = {c: self.material.constant(c) for c in self.material.channels if self.material.constant(c) is not None}
        return {"name": self.material.name, "maps": list(self.widths), "constants": constants, "nodes": self.evaluator.report(),
                "normal_convention": self.settings.normal_convention if "normal" in self.widths else None}
