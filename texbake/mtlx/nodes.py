"""The standard library's primitive nodes, evaluated with numpy over a batch of points.

Each entry of :data:`PRIMITIVES` takes the node's inputs as ``(n, k)`` float64 arrays
(``k`` its MaterialX type's width; a ``float`` input is ``(n, 1)`` and broadcasts over a
vector, as MaterialX's ``_FA`` variants do), its string inputs as strings, the output's
width and the :class:`Context` of the points, and gives ``(n, width)`` float64. The
formulas are those of the library's GLSL implementations (``genglsl``: the inline
expressions and ``mx_*.glsl``); the noises are ``noise.py``'s port of ``mx_noise.glsl``.
Nodes the library defines as nodegraphs are expanded into these (``document.py``), never
evaluated here. This first version is numpy, vectorised over points (not compiled); noise3d
and fractal3d are filtered over the footprint where one is given (``footprint.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import noise


@dataclass(frozen=True)
class Context:
    """The points a graph is evaluated at: ``position`` ``(n, 3)`` float64 in object
    space (world = object: a bake has no transform), ``normal`` ``(n, 3)`` unit (or None)
    ``texcoord`` ``(n, 2)`` (or None: a bake's samples carry no texture coordinates) and
    the footprint ``dpdx``, ``dpdy`` (``footprint.py``; None: point sampling)."""

    position: np.ndarray
    normal: np.ndarray | None = None
    texcoord: np.ndarray | None = None
    dpdx: np.ndarray | None = None  # (n, 3) the footprint in object space (None: point sampling)
    dpdy: np.ndarray | None = None


class Unavailable(Exception):
    """What a node needs that the context does not give (the normal, texture coordinates)."""


def _fit(a: np.ndarray, width: int) -> np.ndarray:
    return a if a.shape[1] == width else np.broadcast_to(a[:, :1], (len(a), width))


def _geom(v, width, ctx: Context, name: str) -> np.ndarray:
    value = getattr(ctx, name)
    if value is None:
        raise Unavailable(f"the {name} (the bake's samples give the position{', normal' if ctx.normal is not None else ''})")
    return np.asarray(value, dtype=np.float64)[:, :width]


def _divide(a, b):
    return np.divide(a, b, out=np.zeros(np.broadcast_shapes(a.shape, b.shape)), where=b != 0)


def _mod(a, b):
    return a - b * np.floor(_divide(a, b))


def _unary(f: Callable) -> Callable:
    return lambda v, w, ctx: _fit(f(v["in"]), w)


def _binary(f: Callable) -> Callable:
    return lambda v, w, ctx: _fit(f(v["in1"], v["in2"]), w)


def _smoothstep(v, w, ctx):
    x, lo, hi = v["in"], v["low"], v["high"]
    t = np.clip(_divide(x - lo, hi - lo), 0.0, 1.0)
    return np.where(x >= hi, 1.0, np.where(x <= lo, 0.0, t * t * (3.0 - 2.0 * t)))


def _remap(v, w, ctx):
    return v["outlow"] + (v["in"] - v["inlow"]) * _divide(v["outhigh"] - v["outlow"], v["inhigh"] - v["inlow"])


def _luminance(v, w, ctx):
    c = v["in"]
    lum = np.einsum("ij,ij->i", c[:, :3], np.broadcast_to(v["lumacoeffs"][:, :3], (len(c), 3)))[:, None]
    return np.concatenate([np.repeat(lum, 3, axis=1), c[:, 3:]], axis=1)


def hsv_to_rgb(hsv: np.ndarray) -> np.ndarray:
    """``mx_hsvtorgb`` over ``(n, 3)``."""
    h, s, v = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    h6 = 6.0 * (h - np.floor(h))
    hi = np.trunc(h6).astype(np.int64)
    f = h6 - hi
    p, q, t = v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f))
    table = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)]
    out = np.stack(table[5], axis=1)
    for k in range(4, -1, -1):
        out = np.where((hi == k)[:, None], np.stack(table[k], axis=1), out)
    return np.where((s < 0.0001)[:, None], np.stack([v, v, v], axis=1), out)


def rgb_to_hsv(c: np.ndarray) -> np.ndarray:
    """``mx_rgbtohsv`` over ``(n, 3)``."""
    r, g, b = c[:, 0], c[:, 1], c[:, 2]
    top, delta = c.max(axis=1), c.max(axis=1) - c.min(axis=1)
    s = np.where(top > 0.0, _divide(delta, top), 0.0)
    h = np.where(r >= top, _divide(g - b, delta), np.where(g >= top, 2.0 + _divide(b - r, delta), 4.0 + _divide(r - g, delta)))
    h = h / 6.0
    h = np.where(h < 0.0, h + 1.0, h)
    return np.stack([np.where(s <= 0.0, 0.0, h), s, top], axis=1)


def _colour(f: Callable) -> Callable:
    return lambda v, w, ctx: np.concatenate([f(v["in"][:, :3]), v["in"][:, 3:]], axis=1)


def _combine(v, w, ctx):
    return np.concatenate([v[f"in{k}"] for k in range(1, 5) if f"in{k}" in v], axis=1)


def _extract(v, w, ctx):
    index = v["index"][:, 0].astype(np.int64)
    return np.take_along_axis(v["in"], index[:, None], axis=1)


def _convert(v, w, ctx):
    x = v["in"]
    if x.shape[1] == 1 or x.shape[1] == w:
        return _fit(x, w)
    if x.shape[1] < w:  # color3 -> color4, vector2 -> vector3...: 1 alpha, 0 else
        return np.concatenate([x, np.full((len(x), w - x.shape[1]), 1.0 if w == 4 else 0.0)], axis=1)
    return x[:, :w]


def _dot(v, w, ctx):
    return np.einsum("ij,ij->i", *np.broadcast_arrays(v["in1"], v["in2"]))[:, None]


def _ifelse(compare: Callable) -> Callable:
    return lambda v, w, ctx: np.where(compare(v["value1"][:, :1], v["value2"][:, :1]), _fit(v["in1"], w), _fit(v["in2"], w))


def _noise3d(v, w, ctx):
    p = v["position"]
    value = noise.perlin_float(p)[:, None] if w == 1 else noise.perlin_vec3(p)[:, :w]
    return noise.filtered(value, v.get("_width")) * v["amplitude"] + v["pivot"]


def _fractal3d(v, w, ctx):
    p, octaves, lac, dim = v["position"], v["octaves"][:, 0], v["lacunarity"][:, 0], v["diminish"][:, 0]
    width = v.get("_width")
    value = (noise.fractal_float(p, octaves, lac, dim, width)[:, None] if w == 1 else
             noise.fractal_vec3(p, octaves, lac, dim, width)[:, :w])
    return value * v["amplitude"]


def _cellnoise3d(v, w, ctx):
    return noise.cell_float(v["position"])[:, None]


def _worleynoise3d(v, w, ctx):
    style = np.unique(v["style"][:, 0])
    if len(style) != 1:
        raise Unavailable("a style that varies over the surface")
    out = noise.worley(v["position"], v["jitter"][:, 0], int(style[0]), components=w)
    return out[:, None] if w == 1 else out


def _ramp(axis: int, first: str, second: str) -> Callable:
    def ramp(v, w, ctx):
        t = np.clip(v["texcoord"][:, axis : axis + 1], 0.0, 1.0)
        return v[first] * (1.0 - t) + v[second] * t
    return ramp


def _split(axis: int, first: str, second: str) -> Callable:
    def split(v, w, ctx):  # mx_aastep without derivatives: a step at the centre
        t = (v["texcoord"][:, axis : axis + 1] >= v["center"]).astype(np.float64)
        return v[first] * (1.0 - t) + v[second] * t
    return split


def _cross(v, w, ctx):
    a, b = np.broadcast_arrays(v["in1"], v["in2"])
    return np.cross(a, b)


def _rotate3d(v, w, ctx):
    """``mx_rotate_vector3``: Rodrigues' rotation of ``in`` about ``axis`` by ``amount`` degrees (v' = v M)."""
    x, axis = v["in"], _normalize(v["axis"])
    angle = np.radians(v["amount"])
    s, c = np.sin(angle), np.cos(angle)
    return x * c + np.cross(x, axis) * s + axis * np.einsum("ij,ij->i", axis, x)[:, None] * (1.0 - c)


def _transformmatrix(v, w, ctx):
    """``mx_matrix_mul(mat, in)`` as MaterialX's GLSL has it: ``in`` (with 1 appended where
    the matrix is one wider) times the matrix, the document's rows being GLSL's columns (v' = v M)."""
    x, m = v["in"], v["mat"]
    k = int(round(np.sqrt(m.shape[1])))
    if x.shape[1] < k:
        x = np.concatenate([x, np.ones((len(x), k - x.shape[1]))], axis=1)
    return np.einsum("ni,nij->nj", x, m.reshape(len(m), k, k))[:, :w]


def _normalmap_scale(v, w, ctx):
    """mx_normalmap's tangent-space part, re-encoded: ``n = 2 in - 1``, ``n.xy *= scale``,
    normalised, ``0.5 + 0.5 n`` (texbake's normal channel)."""
    n = 2.0 * v["in"] - 1.0
    n = np.concatenate([n[:, :2] * v["scale"], n[:, 2:]], axis=1)
    return 0.5 + 0.5 * _normalize(n)


def _normalize(a):
    length = np.linalg.norm(a, axis=1, keepdims=True)
    return _divide(a, length)


PRIMITIVES: dict[str, Callable | None] = {
    "constant": lambda v, w, ctx: _fit(v["value"], w),
    "position": lambda v, w, ctx: _geom(v, w, ctx, "position"),
    "normal": lambda v, w, ctx: _geom(v, w, ctx, "normal"),
    "texcoord": lambda v, w, ctx: _geom(v, w, ctx, "texcoord"),
    "dot": lambda v, w, ctx: _fit(v["in"], w),
    "add": _binary(np.add), "subtract": _binary(np.subtract), "multiply": _binary(np.multiply), "divide": _binary(_divide),
    "modulo": _binary(_mod), "power": _binary(np.power), "min": _binary(np.minimum), "max": _binary(np.maximum),
    "atan2": lambda v, w, ctx: _fit(np.arctan2(v["iny"], v["inx"]), w),
    "absval": _unary(np.abs), "sign": _unary(np.sign), "floor": _unary(np.floor), "ceil": _unary(np.ceil),
    "round": _unary(np.round), "fract": _unary(lambda x: x - np.floor(x)), "sin": _unary(np.sin), "cos": _unary(np.cos),
    "tan": _unary(np.tan), "asin": _unary(np.arcsin), "acos": _unary(np.arccos), "sqrt": _unary(np.sqrt),
    "ln": _unary(np.log), "exp": _unary(np.exp), "normalize": _unary(_normalize),
    "magnitude": lambda v, w, ctx: np.linalg.norm(v["in"], axis=1, keepdims=True),
    "invert": lambda v, w, ctx: _fit(v["amount"] - v["in"], w),
    "clamp": lambda v, w, ctx: _fit(np.minimum(np.maximum(v["in"], v["low"]), v["high"]), w),
    "smoothstep": _smoothstep, "remap": lambda v, w, ctx: _fit(_remap(v, w, ctx), w),
    "mix": lambda v, w, ctx: _fit(v["bg"] * (1.0 - v["mix"]) + v["fg"] * v["mix"], w),
    "ifgreater": _ifelse(np.greater), "ifgreatereq": _ifelse(np.greater_equal), "ifequal": _ifelse(np.equal),
    "luminance": _luminance, "hsvtorgb": _colour(hsv_to_rgb), "rgbtohsv": _colour(rgb_to_hsv),
    "combine2": _combine, "combine3": _combine, "combine4": _combine, "extract": _extract, "convert": _convert,
    "dotproduct": _dot, "crossproduct": _cross,
    "ramplr": _ramp(0, "valuel", "valuer"), "ramptb": _ramp(1, "valueb", "valuet"),
    "splitlr": _split(0, "valuel", "valuer"), "splittb": _split(1, "valueb", "valuet"),
    "rotate3d": _rotate3d, "transformmatrix": _transformmatrix,
    "noise3d": _noise3d, "fractal3d": _fractal3d, "cellnoise3d": _cellnoise3d, "worleynoise3d": _worleynoise3d,
    "cellnoise2d": lambda v, w, ctx: noise.cell_float2(v["texcoord"])[:, None],
    "normalmap": None,  # read where it feeds a shader's normal (document.py), never evaluated
    "texbake:normalmap_scale": _normalmap_scale,  # a normalmap's scale, where it is not 1 (document.py)
}

_IMAGES = ("image", "tiledimage", "hextiledimage", "latlongimage", "triplanarprojection", "gltf_image", "gltf_colorimage",
           "UsdUVTexture")


def unsupported(category: str, why: str = "") -> str:
    """The one line for a node texbake does not evaluate: its category, why, what is supported."""
    if not why:
        why = ("an image node reads a file, and texbake bakes procedural graphs" if category in _IMAGES else
               "a shading node (it needs a light or the view)" if category.endswith(("_bsdf", "_edf", "_vdf", "light"))
               or category in ("surface", "viewdirection", "facingratio", "layer", "mix_bsdf") else
               "not a node texbake evaluates")
    supported = sorted(c for c in PRIMITIVES if PRIMITIVES[c] is not None and ":" not in c)
    return (f"{category}: {why} (supported: {', '.join(supported)}, and the library's nodes defined as nodegraphs "
            "of them)")
