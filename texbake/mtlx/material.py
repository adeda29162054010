"""A MaterialX document as a texbake material: each channel its shader gives is a
constant (a value the document sets) or an ``mtlx`` node of ``texbake.materials``, which
evaluates the document's graph for that channel at the bake's samples (object space).

:func:`material_from_mtlx` is what ``--material FILE.mtlx`` and a material given as XML
text (the service's ``material``) become; :func:`channel_values` is the ``mtlx`` node's
evaluation (``texbake.materials.evaluate``), the document read once per process.
"""

from __future__ import annotations

import functools
import threading
from pathlib import Path

import numpy as np

from ..errors import MtlxError
from .document import Document, Ref, read_document
from .nodes import Context

SCALARS = ("roughness", "metallic", "height", "occlusion", "opacity")


def material_from_mtlx(source: str | Path, *, path: str | None = None):
    """The :class:`texbake.materials.Material` of a ``.mtlx`` file (a Path) or its XML
    text. Raises :class:`MtlxError` (an unreadable document, no surface shader, a node
    texbake does not evaluate, a graph that reads the texture coordinates: a bake's
    samples have none)."""
    from ..materials import parse_material

    where = str(source) if isinstance(source, Path) and path is None else (path or "<mtlx>")
    if isinstance(source, Path):
        try:
            source = source.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise MtlxError(where, "", f"cannot read: {getattr(exc, 'strerror', None) or exc}") from None
    document = _document(source, where)
    _check_bakeable(document)
    spec: dict = {"name": document.material_name[:64], "description": f"MaterialX {document.shader_category} "
                  f"{document.shader_name!r} from {Path(where).name}"[:1000]}
    for channel, value in document.channels.items():
        kind = "scalar" if channel in SCALARS else "colour"
        if isinstance(value, Ref):
            spec[channel] = {"op": "mtlx", "document": source, "channel": channel, "kind": kind, "path": where}
        else:
            spec[channel] = float(np.mean(value)) if kind == "scalar" else [float(x) for x in _fit(value[None, :], 3)[0]]
    if "base_color" not in spec:
        spec["base_color"] = [0.8, 0.8, 0.8]  # the shader leaves it to its default
    return parse_material(spec)


@functools.lru_cache(maxsize=8)
def _document(text: str, where: str) -> Document:
    return read_document(text, path=where)


def _check_bakeable(document: Document) -> None:
    """Texture coordinates are not in a bake's samples: a graph that reads them is named here, before the bake."""
    for op in document.ops.values():
        if op.category == "texcoord" and any(_reads(document, document.channels[c], op.id) for c in document.channels):
            users = [o.where for o in document.ops.values() if any(isinstance(v, Ref) and v.op == op.id for v in o.inputs.values())]
            raise MtlxError(document.path, users[0] if users else op.where,
                            "reads the texture coordinates (texcoord, a ramp or split), which a bake onto the mesh's own "
                            "atlas does not give: texbake bakes 3D graphs (position, normal)")


def _reads(document: Document, value, op_id: str) -> bool:
    stack, seen = [value], set()
    while stack:
        v = stack.pop()
        if not isinstance(v, Ref) or v.op in seen:
            continue
        if v.op == op_id:
            return True
        seen.add(v.op)
        stack.extend(document.ops[v.op].inputs.values())
    return False


def _fit(values: np.ndarray, width: int) -> np.ndarray:
    """``(n, k)`` to ``(n, width)``: a scalar is grey, a colour4's alpha dropped, a colour
    in a scalar channel its mean (MaterialX's colour3 opacity)."""
    k = values.shape[1]
    if k == width:
        return values
    if width == 1:
        return values[:, :3].mean(axis=1, keepdims=True)
    return np.repeat(values[:, :1], 3, axis=1) if k == 1 else values[:, :3] if k >= 3 else np.pad(values, ((0, 0), (0, 3 - k)))


_BATCH = threading.local()  # per thread: the batch last evaluated (its points' array) and the ops done at it


def channel_values(params, points: np.ndarray, normals: np.ndarray | None, dpdx: np.ndarray | None = None,
                   dpdy: np.ndarray | None = None, *, batch: object = None) -> np.ndarray:
    """The ``mtlx`` node's ``(n, 1)`` or ``(n, 3)`` float64 values at ``(n, 3)`` object-space
    points, filtered over their footprints ``dpdx``, ``dpdy`` (None: point-sampled).
    ``batch``: the object that stands for these points (the bake's own array of them: the
    same object for every channel of one batch), so a node several channels read is
    evaluated once a batch (None: nothing shared)."""
    from .evaluate import Evaluated, evaluate_channel

    document = _document(params.document, params.path)
    done = None
    if batch is not None:
        key = (id(batch), id(document), dpdx is None)
        if getattr(_BATCH, "key", None) != key or getattr(_BATCH, "batch", None) is not batch:
            _BATCH.key, _BATCH.batch, _BATCH.done = key, batch, Evaluated()
        done = _BATCH.done
    values = evaluate_channel(document, params.channel, Context(points, normals, None, dpdx, dpdy), done)
    return np.ascontiguousarray(_fit(values, 1 if params.kind == "scalar" else 3))


def describe_mtlx(text: str, *, path: str = "<mtlx>") -> dict:
    """What an editor shows of a ``.mtlx`` document's XML ``text`` (``path``: its name in
    messages and in the material's nodes), before any bake:

    - ``material``: the :class:`texbake.materials.Material` as its JSON object (what the
      bake's ``material`` setting takes; each graph-driven channel an ``mtlx`` node);
    - ``shader``: ``{"category", "name"}`` of the surface shader read;
    - ``channels``: channel -> ``{"inputs": [the shader's inputs it is the product of],
      "graph": whether it is evaluated at each point (else a constant)}``;
    - ``warnings``: one line each: the document's other materials, the shader's inputs
      given but not baked, a base colour left to its default.

    Raises :class:`MtlxError` as :func:`material_from_mtlx` does."""
    from .document import SHADERS, load

    material = material_from_mtlx(text, path=path)
    document = _document(text, path)
    channels = {c: {"inputs": list(document.inputs[c]), "graph": isinstance(v, Ref)} for c, v in document.channels.items()}
    warnings = []
    doc = load(text, path)
    others = [m.getName() for m in doc.getMaterialNodes() if m.getName() != document.material_name]
    if others:
        warnings.append(f"the document has {len(others) + 1} materials: texbake reads {document.material_name!r}, "
                        f"not {', '.join(map(repr, others[:5]))}{' ...' if len(others) > 5 else ''}")
    shader = doc.getNode(document.shader_name)
    read = {name for names in SHADERS[document.shader_category].values() for name in names}
    unbaked = [i.getName() for i in (shader.getInputs() if shader is not None else []) if i.getName() not in read]
    if unbaked:
        warnings.append(f"{document.shader_category} inputs not baked (texbake bakes {', '.join(sorted(read))}): "
                        f"{', '.join(unbaked)}; the .mtlx a bake writes keeps them as they are")
    if "base_color" not in document.channels:
        warnings.append("the shader gives no base colour: the material's is 0.8 grey")
    return {"material": material.model_dump(mode="json"), "shader": {"category": document.shader_category,
            "name": document.shader_name}, "channels": channels, "warnings": warnings}
