"""A texture without a mesh: a small image of it on a sphere, or a slice through it.

The swatch stands in for a bake of a sphere: the sphere fills the unit texture space (the
box [0, 1]^3, as a bake scales a mesh's bounding box), and each pixel's point and its
footprint (the change of the point over one pixel, dp/dx and dp/dy) go through the bake's
own :class:`~texbake.textures.mapping.TextureMapping`, so a swatch is filtered as a bake is.
The sphere is lit as a ``lit`` map is (``texbake.maps.shading``), except for textures that emit
light (the flame); a slice is the plane z = 0.5, unlit.

:func:`material_swatch` is one channel of a material on the same sphere (or slice), unlit:
the channel's own values, as its map of a bake holds them, which the page's PBR-lit
sphere takes as its textures.
"""

from __future__ import annotations

import numpy as np

from .errors import ParameterError
from .maps import lit
from .textures import parse_spec
from .textures.mapping import TextureMapping

VIEWS = ("sphere", "slice")
MIN_SIZE, MAX_SIZE = 16, 1024
_GRAZING = 0.05  # z of the sphere's normal is clamped to this at the rim (the footprint stays finite)


def _sphere(size: int):
    """The pixels on the sphere ``(size, size)`` bool, their coverage, points, footprints and
    normals (``(n,)`` and ``(n, 3)`` each, for the n pixels on it)."""
    c = (np.arange(size) + 0.5) / size * 2 - 1  # pixel centres in [-1, 1]
    u, v = np.meshgrid(c, -c)  # row 0 at the top
    r = np.hypot(u, v)
    inside = r < 1.0 + 1.0 / size  # pixels the disk covers at least in part
    r = r[inside]
    coverage = np.clip((1.0 - r) * size / 2 + 0.5, 0.0, 1.0)  # the rim antialiased
    rim = np.maximum(r, 1.0)  # a pixel centre just off the disk takes the rim's point
    u, v = u[inside] / rim, v[inside] / rim
    z = np.sqrt(np.maximum(1.0 - u * u - v * v, 0.0))
    normals = np.column_stack([u, v, z])
    zc = np.maximum(z, _GRAZING)
    step = 0.5 * 2.0 / size  # the sphere's radius 0.5 over one pixel of [-1, 1]
    zero = np.zeros_like(u)
    dpdx = step * np.column_stack([np.ones_like(u), zero, -u / zc])
    dpdy = -step * np.column_stack([zero, np.ones_like(u), -v / zc])
    return inside, coverage, 0.5 + 0.5 * normals, dpdx, dpdy, normals


def _slice(size: int):
    c = (np.arange(size) + 0.5) / size
    x, y = np.meshgrid(c, 1.0 - c)
    n = size * size
    points = np.column_stack([x.ravel(), y.ravel(), np.full(n, 0.5)])
    dpdx = np.tile([1.0 / size, 0.0, 0.0], (n, 1))
    dpdy = np.tile([0.0, -1.0 / size, 0.0], (n, 1))
    return np.ones((size, size), bool), 1.0, points, dpdx, dpdy, None


def _check(size, view) -> None:
    """A swatch's size and view, or the ParameterError naming the bad one."""
    if not isinstance(size, int) or not MIN_SIZE <= size <= MAX_SIZE:
        raise ParameterError("size", f"expected an integer from {MIN_SIZE} to {MAX_SIZE}, got {size!r}")
    if view not in VIEWS:
        raise ParameterError("view", f"expected one of {', '.join(VIEWS)}, got {view!r}")


def swatch(spec, size: int = 256, view: str = "sphere", *, light=(0.3, 0.5, 0.8)) -> np.ndarray:
    """``(size, size, 4)`` float32 image of a texture: linear RGB and alpha (0 off the sphere).

    ``spec``: a texture spec, dict, name or JSON (see :func:`texbake.textures.parse_spec`);
    ``view``: "sphere" or "slice"; ``light``: the direction lighting the sphere. Raises
    :class:`~texbake.errors.TextureError` for a bad spec and :class:`~texbake.errors.ParameterError`
    for a bad size or view.
    """
    _check(size, view)
    spec = parse_spec(spec)
    inside, coverage, points, dpdx, dpdy, normals = (_sphere if view == "sphere" else _slice)(size)
    mapping = TextureMapping.for_mesh(np.zeros(3), np.ones(3), "unit")
    colour = mapping.evaluate(spec, points, dpdx, dpdy)
    if normals is not None and not spec.emits:
        colour = lit(colour, normals, mode="ambient-diffuse", light=light)
    out = np.zeros((size, size, 4), np.float32)
    out[inside, :3] = colour
    out[inside, 3] = coverage
    return out


def material_swatch(material, channel: str, size: int = 256, view: str = "sphere") -> np.ndarray:
    """``(size, size, 4)`` float32 image of one channel of a material: its values (linear
    RGB for ``base_color``, ``emissive`` and ``normal``; a scalar channel grey) and alpha (0
    off the sphere), unlit, evaluated at the texture swatch's points and footprints.

    ``material``: a :class:`~texbake.materials.Material`, its object or JSON, or a built-in's
    name; ``channel``: one of :data:`~texbake.materials.CHANNELS` (one the material does not
    give is its default: what a bake's GLB takes for it). Raises
    :class:`~texbake.errors.MaterialError` for a bad material (naming the node) and
    :class:`~texbake.errors.ParameterError` for a bad channel, size or view.
    """
    from .materials import CHANNELS, DEFAULTS, evaluate_material, parse_material

    if channel not in CHANNELS:
        raise ParameterError("channel", f"expected one of {', '.join(CHANNELS)}, got {channel!r}")
    _check(size, view)
    material = parse_material(material)
    inside, coverage, points, dpdx, dpdy, normals = (_sphere if view == "sphere" else _slice)(size)
    if channel in material.graph.channels:
        footprint = np.stack([dpdx, dpdy], axis=1)
        if normals is None:  # the slice's plane faces +z
            normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
        values = evaluate_material(material, points, footprint, normals=normals, channels=[channel])[channel]
    else:
        default = np.atleast_1d(np.asarray(DEFAULTS[channel], dtype=np.float64))
        values = np.broadcast_to(default, (len(points), default.size))
    out = np.zeros((size, size, 4), np.float32)
    out[inside, :3] = values if values.shape[1] == 3 else np.repeat(values, 3, axis=1)
    out[inside, 3] = coverage
    return out
