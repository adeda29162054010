"""A read MaterialX document evaluated at points: its ops in order, each over the whole
batch (numpy), the channels' values out.

:func:`evaluate_document` is the library's call; the bake's leaf (``texbake.materials``'
``mtlx`` op) calls :func:`evaluate_channel` with the samples' object-space points and
normals. Values are float64; a string input (``space``) is passed as it is.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import MtlxError
from .document import WIDTHS, Document, Ref
from .footprint import differentials, footprint_width
from .nodes import PRIMITIVES, Context, Unavailable, unsupported


def evaluate_ops(document: Document, wanted: list, ctx: Context, done: Evaluated | None = None) -> dict[str, np.ndarray]:
    """``op id -> (n, width)`` float64 for the ops ``wanted`` (:class:`Ref` s or constants)
    need; ``done``: what earlier calls at the same points evaluated (kept, added to)."""
    done = Evaluated() if done is None else done
    values, grads = done.values, done.grads
    needed: set[str] = set()
    stack = [w.op for w in wanted if isinstance(w, Ref)]
    while stack:
        op_id = stack.pop()
        if op_id not in needed and op_id not in values:
            needed.add(op_id)
            stack.extend(v.op for v in document.ops[op_id].inputs.values() if isinstance(v, Ref))
    n = len(ctx.position)
    filtering = ctx.dpdx is not None and ctx.dpdy is not None
    for op_id, op in document.ops.items():
        if op_id not in needed:
            continue
        args = {name: _value(v, values, n) for name, v in op.inputs.items()}
        if filtering:
            inputs = {name: (grads.get(v.op) if isinstance(v, Ref) else (0.0, 0.0)) for name, v in op.inputs.items()}
            if op.category in FILTERED:
                args["_width"] = footprint_width(inputs.get("position"))
        function = PRIMITIVES[op.category]
        if function is None:
            raise MtlxError(document.path, op.where, unsupported(op.category, "evaluated only where it feeds a shader's normal"))
        try:
            out = function(args, WIDTHS.get(op.type, 1), ctx)
        except Unavailable as exc:
            raise MtlxError(document.path, op.where, f"{op.category}: needs {exc}") from None
        out = np.asarray(out, dtype=np.float64)
        values[op_id] = out[:, None] if out.ndim == 1 else out
        if filtering:
            grads[op_id] = differentials(op.category, args, inputs, values[op_id].shape[1], ctx)
    return values


FILTERED = ("noise3d", "fractal3d")  # the nodes that read the footprint's width (in "_width")


@dataclass
class Evaluated:
    """The ops evaluated at one batch of points: ``values`` (op id -> ``(n, width)``) and
    ``grads`` (op id -> its differentials, ``footprint.py``; None where unknown)."""

    values: dict[str, np.ndarray] = field(default_factory=dict)
    grads: dict[str, Any] = field(default_factory=dict)


def _value(v, values: dict, n: int):
    if isinstance(v, Ref):
        return values[v.op]
    if isinstance(v, str):
        return v
    return np.broadcast_to(np.asarray(v, dtype=np.float64)[None, :], (n, len(v)))


def evaluate_channel(document: Document, channel: str, ctx: Context, done: Evaluated | None = None) -> np.ndarray:
    """``(n, k)`` float64: one channel of ``document`` (k its value's width); ``done``: the
    ops already evaluated at these points (by another channel: a shared node once)."""
    value = document.channels[channel]
    values = evaluate_ops(document, [value], ctx, done)
    return np.array(_value(value, values, len(ctx.position)), dtype=np.float64)


def evaluate_document(document: Document, ctx: Context, channels: list[str] | None = None) -> dict[str, np.ndarray]:
    """``channel -> (n, k)`` float64 at the context's points (default: every channel)."""
    wanted = list(document.channels) if channels is None else channels
    values = evaluate_ops(document, [document.channels[c] for c in wanted], ctx)
    return {c: np.array(_value(document.channels[c], values, len(ctx.position)), dtype=np.float64) for c in wanted}


def evaluate_mtlx(source, points, *, normals=None, texcoords=None, channels=None, footprint=None) -> dict[str, np.ndarray]:
    """Evaluate a ``.mtlx`` document's channels at object-space points, without a mesh.

    Parameters
    ----------
    source : str, Path or Document
        A ``.mtlx`` file (a Path), its XML text, or a read :class:`Document`.
    points : (n, 3) array_like of float
        Object-space points.
    normals : (n, 3) array_like of float, optional
        Unit normals (for a graph with a normal node).
    texcoords : (n, 2) array_like of float, optional
        Texture coordinates (for a graph with texcoord, ramps or splits).
    channels : list of str, optional
        Which channels (default: all the shader gives).
    footprint : (n, 2, 3) array_like of float, optional
        ``dpdx`` and ``dpdy`` of each point: noise3d and fractal3d filtered over it
        (``footprint.py``); None: point-sampled, as MaterialX's GLSL.

    Returns
    -------
    dict of str to (n, k) ndarray of float64
    """
    from .document import read_document

    document = source if isinstance(source, Document) else read_document(source)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = None if footprint is None else np.asarray(footprint, dtype=np.float64).reshape(-1, 2, 3)
    ctx = Context(p, None if normals is None else np.asarray(normals, dtype=np.float64).reshape(-1, 3),
                  None if texcoords is None else np.asarray(texcoords, dtype=np.float64).reshape(-1, 2),
                  None if f is None else f[:, 0], None if f is None else f[:, 1])
    return evaluate_document(document, ctx, channels)
