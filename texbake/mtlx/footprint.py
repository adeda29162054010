"""The texel footprint carried through a MaterialX graph, for the noises to filter by.

Each op's output gets its differentials ``(d/dx, d/dy)`` (each ``(n, k)`` float64, or the
float 0.0 for a constant) from its inputs' by the chain rule, for the ops whose rule is
here (:data:`RULES`: the position, the arithmetic, mix, dot and conversions, sin and cos,
the vector products); any other op's output has none (None), and a noise whose
``position`` has none is point-sampled. What a noise node reads is the footprint's width
in its own cells, ``sqrt(max(|dp/dx|^2, |dp/dy|^2))`` (texbake's, ``EvalContext.width``),
so a graph that scales the position scales the footprint with it (forward-mode
differentiation, as pbrt's ``TextureMapping3D`` carries ``dpdx``, ``dpdy``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Grad = tuple  # (d/dx, d/dy): each an (n, k) array or the float 0.0


def _fit(d, width: int):
    if isinstance(d, float) or d.shape[1] == width:
        return d
    return np.broadcast_to(d[:, :1], (len(d), width))


def _each(f: Callable) -> Callable:
    """A rule applied to d/dx and d/dy alike: ``f(values, d, w)`` with ``d`` the inputs' one differential."""
    return lambda v, g, w: tuple(_fit(f(v, {k: pair[axis] for k, pair in g.items()}, w), w) for axis in (0, 1))


def _dot(a, b, da, db):
    total = da * b + a * db
    return total if isinstance(total, float) else total.sum(axis=1, keepdims=True)


RULES: dict[str, Callable] = {
    "constant": lambda v, g, w: (0.0, 0.0),
    "add": _each(lambda v, d, w: d["in1"] + d["in2"]),
    "subtract": _each(lambda v, d, w: d["in1"] - d["in2"]),
    "multiply": _each(lambda v, d, w: d["in1"] * v["in2"] + v["in1"] * d["in2"]),
    "divide": _each(lambda v, d, w: np.divide(d["in1"] * v["in2"] - v["in1"] * d["in2"], v["in2"] ** 2,
                                              out=np.zeros((len(v["in1"]), w)), where=v["in2"] != 0)),
    "dot": _each(lambda v, d, w: d["in"]),
    "convert": _each(lambda v, d, w: d["in"] if isinstance(d["in"], float) or d["in"].shape[1] in (1, w) else d["in"][:, :w]),
    "sin": _each(lambda v, d, w: np.cos(v["in"]) * d["in"]),
    "cos": _each(lambda v, d, w: -np.sin(v["in"]) * d["in"]),
    "mix": _each(lambda v, d, w: d["bg"] * (1.0 - v["mix"]) + d["fg"] * v["mix"] + (v["fg"] - v["bg"]) * d["mix"]),
    "dotproduct": _each(lambda v, d, w: _dot(v["in1"], v["in2"], d["in1"], d["in2"])),
    "extract": _each(lambda v, d, w: d["in"] if isinstance(d["in"], float) else
                     np.take_along_axis(d["in"], v["index"][:, :1].astype(np.int64), axis=1)),
}


def _combine(v, g, w):
    out = []
    for axis in (0, 1):
        parts = [g[f"in{k}"][axis] for k in range(1, 5) if f"in{k}" in g]
        n = len(next(iter(v.values())))
        out.append(np.concatenate([np.zeros((n, 1)) if isinstance(p, float) else p for p in parts], axis=1))
    return tuple(out)


RULES.update(combine2=_combine, combine3=_combine, combine4=_combine)


def differentials(category: str, args: dict, grads: dict, width: int, ctx) -> Grad | None:
    """The op's output differentials from its inputs' (``grads``: input -> Grad or None), or None."""
    if category == "position":
        return None if ctx.dpdx is None or ctx.dpdy is None else (ctx.dpdx[:, :width], ctx.dpdy[:, :width])
    rule = RULES.get(category)
    numeric = {k: a for k, a in args.items() if not isinstance(a, str)}
    if rule is None or any(grads.get(k) is None for k in numeric):
        return None
    return rule(numeric, {k: grads[k] for k in numeric}, width)


def footprint_width(grad: Grad | None) -> np.ndarray | None:
    """``(n,)`` the footprint's width from a position's differentials (None: none known)."""
    if grad is None or isinstance(grad[0], float) or isinstance(grad[1], float):
        return None
    dx, dy = grad
    return np.sqrt(np.maximum(np.einsum("ij,ij->i", dx, dx), np.einsum("ij,ij->i", dy, dy)))
