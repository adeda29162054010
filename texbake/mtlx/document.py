"""A MaterialX document read into plain data: its surface shader's channels, each the
root of a flat graph of the standard library's primitive nodes.

:func:`read_document` loads a ``.mtlx`` (a file or its text) with the ``materialx``
package and the standard library it ships, validates it, finds the surface shader
(:data:`SHADERS`: ``standard_surface``, ``gltf_pbr``, ``open_pbr_surface``,
``UsdPreviewSurface``) and follows each of its inputs that texbake bakes (a channel of
``texbake.materials``) back through nodes and nodegraphs. A node the library defines as a
nodegraph (``range``, ``separate3``, ``ramp4``, the conversions, ``unifiednoise3d``...)
is expanded from that definition, its interface bound to the node's inputs, so its
semantics are MaterialX's own; the rest must be primitives texbake evaluates
(``nodes.PRIMITIVES``), else :class:`~texbake.errors.MtlxError` names the node, its
category and what is supported. An input left unset takes its node definition's default
(a value, or its ``defaultgeomprop``: the position, normal or texture coordinates).

What comes out (:class:`Document`) holds no MaterialX object: ``ops`` (:class:`Op`,
inputs first) and, per channel, the op and output it reads (or a constant).
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import MtlxError

# shader category -> texbake channel -> the shader's inputs whose product the channel is
SHADERS: dict[str, dict[str, tuple[str, ...]]] = {
    "standard_surface": {"base_color": ("base_color", "base"), "roughness": ("specular_roughness",), "metallic": ("metalness",),
                         "emissive": ("emission_color", "emission"), "opacity": ("opacity",), "normal": ("normal",)},
    "gltf_pbr": {"base_color": ("base_color",), "roughness": ("roughness",), "metallic": ("metallic",),
                 "occlusion": ("occlusion",), "emissive": ("emissive", "emissive_strength"), "opacity": ("alpha",),
                 "normal": ("normal",)},
    "open_pbr_surface": {"base_color": ("base_color", "base_weight"), "roughness": ("specular_roughness",),
                         "metallic": ("base_metalness",), "emissive": ("emission_color",), "opacity": ("geometry_opacity",),
                         "normal": ("geometry_normal",)},
    "UsdPreviewSurface": {"base_color": ("diffuseColor",), "roughness": ("roughness",), "metallic": ("metallic",),
                          "occlusion": ("occlusion",), "emissive": ("emissiveColor",), "opacity": ("opacity",),
                          "normal": ("normal",), "height": ("displacement",)},
}
WORKING_SPACE = "lin_rec709"  # texbake's: linear Rec.709 (its maps' colours)
WIDTHS = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4, "vector4": 4, "matrix33": 9,
          "matrix44": 16}
# the library's geometric properties (defaultgeomprop) -> the primitive that gives it
GEOMPROPS = {"Pobject": ("position", "object"), "Pworld": ("position", "world"), "Nobject": ("normal", "object"),
             "Nworld": ("normal", "world"), "UV0": ("texcoord", "0")}


@dataclass(frozen=True)
class Ref:
    """An op's output, read by another op: ``op`` (an :attr:`Op.id`) and ``output``."""

    op: str
    output: str = "out"


@dataclass(frozen=True)
class Op:
    """One primitive node: ``category`` (a key of ``nodes.PRIMITIVES``), ``type`` (its
    output's MaterialX type), ``inputs`` (name -> :class:`Ref`, a ``(k,)`` float64
    constant, or a string for string inputs such as ``space``) and ``where`` (its name
    path in the document, for messages)."""

    id: str
    category: str
    type: str
    inputs: dict[str, Any]
    where: str


@dataclass
class Document:
    """``shader`` (its category and name), ``ops`` by id (inputs first), ``channels``
    (channel -> a :class:`Ref` or a ``(k,)`` constant, each the product of
    :data:`SHADERS`' inputs already applied), ``inputs`` (channel -> the shader's input
    names it came from) and the ``source`` text."""

    path: str
    shader_category: str
    shader_name: str
    material_name: str
    ops: dict[str, Op] = field(default_factory=dict)
    channels: dict[str, Any] = field(default_factory=dict)
    inputs: dict[str, tuple[str, ...]] = field(default_factory=dict)
    source: str = ""


@functools.cache
def standard_library():
    """The ``materialx`` package's own data libraries (stdlib, pbrlib, bxdf...), loaded once."""
    import MaterialX as mx  # the optional extra: pip install texbake[mtlx]

    lib = mx.createDocument()
    mx.loadLibraries(mx.getDefaultDataLibraryFolders(), mx.getDefaultDataSearchPath(), lib)
    return lib


_INCLUDE = re.compile(r"<\s*[\w.-]+:include\b[^>]*>?", re.I)  # an XInclude element (xi:include, whatever its prefix)


def load(source: str | Path, path: str = "<mtlx>"):
    """A MaterialX ``Document`` of a ``.mtlx`` file (a Path) or its XML text, with the
    standard library as its data library, validated. Raises :class:`MtlxError`; for XML
    text that includes another file (``xi:include``, which MaterialX would read from this
    machine's disk, whatever the path: the service's documents are given as text)."""
    try:
        import MaterialX as mx
    except ImportError:  # pragma: no cover - the extra is part of [test]
        raise MtlxError(path, "", "reading MaterialX needs the materialx package: pip install texbake[mtlx]") from None
    if isinstance(source, str) and (include := _INCLUDE.search(source)):  # MaterialX would read it from this machine's disk
        raise MtlxError(path, "", f"includes another file ({include.group(0)[:120]}): a document given as text reads no "
                        "other file; put what it includes into the document")
    doc = mx.createDocument()
    try:
        if isinstance(source, Path):
            mx.readFromXmlFile(doc, str(source))
        else:
            mx.readFromXmlString(doc, source)
    except Exception as exc:  # MaterialX raises its own ExceptionParseError/FileMissing
        raise MtlxError(path, "", f"not a readable MaterialX document: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    doc.setDataLibrary(standard_library())
    valid, message = doc.validate()
    if not valid:
        raise MtlxError(path, "", f"not a valid MaterialX document: {message.strip().splitlines()[0]}")
    return doc


def read_document(source: str | Path, *, path: str | None = None) -> Document:
    """The :class:`Document` of a ``.mtlx`` file (a Path) or XML text (``path``: its name
    in messages). Raises :class:`MtlxError` naming the node that cannot be baked."""
    where = str(source) if isinstance(source, Path) and path is None else (path or "<mtlx>")
    text = source.read_text(encoding="utf-8") if isinstance(source, Path) else source
    doc = load(text, where)
    shader, material_name = _surface_shader(doc, where)
    category = shader.getCategory()
    out = Document(where, category, shader.getName(), material_name, source=text)
    flat = _Flattener(doc, where, out.ops)
    for channel, names in SHADERS[category].items():
        given = [n for n in names if shader.getInput(n) is not None]
        if not given:
            continue
        if channel == "normal":
            value = flat.normal_input(shader, names[0])
        else:
            factors = [flat.shader_input(shader, n) for n in names]
            value = flat.product(factors, f"{shader.getName()}.{channel}")
        if value is not None:
            out.channels[channel] = value
            out.inputs[channel] = tuple(given)
    _fold_constants(out)
    if not out.channels:
        raise MtlxError(where, shader.getName(), f"{category}: none of its inputs is one texbake bakes "
                        f"({', '.join(n for ns in SHADERS[category].values() for n in ns)})")
    return out


def _fold_constants(document: Document) -> None:
    """A channel whose graph reads no geometry (a colour constant through its colour space's
    transform, say) is the constant it evaluates to."""
    from .evaluate import evaluate_document
    from .nodes import Context

    for channel, value in list(document.channels.items()):
        stack, seen, varies = [value], set(), False
        while stack and not varies:
            v = stack.pop()
            if isinstance(v, Ref) and v.op not in seen:
                seen.add(v.op)
                varies = document.ops[v.op].category in ("position", "normal", "texcoord")
                stack.extend(document.ops[v.op].inputs.values())
        if isinstance(value, Ref) and not varies:
            document.channels[channel] = evaluate_document(document, Context(np.zeros((1, 3))), [channel])[channel][0]


def _surface_shader(doc, where: str):
    """``(shader node, material's name)``: the first surface material's shader, or a bare shader node."""
    import MaterialX as mx

    for material in doc.getMaterialNodes():
        for shader in mx.getShaderNodes(material):
            if shader.getCategory() in SHADERS:
                return shader, material.getName()
            raise MtlxError(where, shader.getName(), f"{shader.getCategory()}: not a surface shader texbake reads "
                            f"(supported: {', '.join(SHADERS)})")
    for node in doc.getNodes():
        if node.getCategory() in SHADERS:
            return node, node.getName()
    raise MtlxError(where, "", f"no surface shader ({', '.join(SHADERS)}) in the document")


def value_array(value) -> np.ndarray:
    """A MaterialX value (float, int, bool, Color3, Vector3, a matrix...) as ``(k,)`` float64."""
    if hasattr(value, "asTuple"):
        return np.asarray(value.asTuple(), dtype=np.float64)
    if hasattr(value, "numRows"):  # a matrix: its rows one after another, as the document writes it
        return np.array([value[i, j] for i in range(value.numRows()) for j in range(value.numColumns())], dtype=np.float64)
    return np.atleast_1d(np.asarray(float(value), dtype=np.float64))


class _Scope(dict):
    """A definition graph's interface (name -> value), numbered: ops in it are its own."""

    def __init__(self, values: dict, number: int):
        super().__init__(values)
        self.number = number


class _Flattener:
    """Follows connections into :class:`Op` s, expanding nodegraph-defined nodes; an op
    per (scope, node), so a node read by several inputs is one op."""

    def __init__(self, doc, where: str, ops: dict[str, Op]):
        self.doc, self.where, self.ops = doc, where, ops
        self.done: dict[tuple, Ref] = {}
        self.scopes = 0
        self.expanding: list[str] = []  # the document's nodes being expanded from their definitions, outermost first

    def shader_input(self, shader, name: str):
        inp = shader.getInput(name)
        if inp is None:
            return _default(shader.getNodeDef(), name)
        return self.input(inp, shader, {})

    def normal_input(self, shader, name: str):
        """The tangent-space normal map under a ``normalmap`` node (its ``in``), encoded as texbake's."""
        inp = shader.getInput(name)
        node = inp.getConnectedNode()
        if node is None and not inp.getNodeGraphString():
            return None  # a constant normal: the geometry's own
        ref = self.input(inp, shader, {})
        op = self.ops[ref.op] if isinstance(ref, Ref) else None
        if op is None or op.category != "normalmap":
            raise MtlxError(self.where, op.where if op else shader.getName(),
                            f"{name}: texbake bakes a normal given through a normalmap node (a tangent-space map), "
                            f"got {op.category if op else 'a value'}")
        scale = op.inputs.get("scale", np.ones(1))
        if not isinstance(scale, Ref) and np.all(scale == 1.0):
            return op.inputs["in"]
        op_id = f"{op.id}#scaled"  # the map's xy scaled as normalmap does (texbake's encoding kept)
        self.ops[op_id] = Op(op_id, "texbake:normalmap_scale", "vector3", {"in": op.inputs["in"], "scale": scale}, op.where)
        return Ref(op_id)

    def product(self, factors: list, where: str):
        """The product of constants and refs (a ``multiply`` op where any is a ref)."""
        constants = [f for f in factors if not isinstance(f, Ref)]
        refs = [f for f in factors if isinstance(f, Ref)]
        scale = functools.reduce(np.multiply, constants, np.ones(1))
        if not refs:
            return scale
        value: Any = refs[0]
        for k, other in enumerate([*refs[1:], *([scale] if not np.all(scale == 1.0) else [])]):
            op_id = f"{where}#product{k}"
            width = max(self._width(value), self._width(other))
            self.ops[op_id] = Op(op_id, "multiply", _type_of(width), {"in1": value, "in2": other}, where)
            value = Ref(op_id)
        return value

    def _width(self, value) -> int:
        return WIDTHS[self.ops[value.op].type] if isinstance(value, Ref) else len(value)

    def input(self, inp, owner, scope: dict):
        """What an input reads: a :class:`Ref`, a constant or a string. ``owner``: its node
        (or graph output); ``scope``: a definition graph's interface (name -> value)."""
        if inp.getInterfaceName():
            name = inp.getInterfaceName()
            if name in scope:
                return scope[name]
            graph_input = owner.getParent().getInput(name)
            if graph_input is None:
                raise MtlxError(self.where, owner.getNamePath(), f"interface input {name!r} is not on its nodegraph")
            return self.input(graph_input, owner.getParent(), {})
        if inp.getNodeName() or inp.getNodeGraphString() or inp.getOutputString():
            return self._connection(inp, owner, scope)
        if inp.getType() in ("string", "filename"):
            return inp.getValueString()
        value = inp.getValue()
        if value is None:
            return _default(owner.getNodeDef() if hasattr(owner, "getNodeDef") else None, inp.getName())
        space = inp.getActiveColorSpace() if inp.getType() in ("color3", "color4") else ""
        if space and space != WORKING_SPACE:
            return self._to_working_space(value_array(value), space, inp.getType(), owner)
        return value_array(value)

    def _to_working_space(self, value: np.ndarray, space: str, type_: str, owner):
        """A colour constant in ``space`` through the library's own transform to lin_rec709
        (cmlib's ``<space>_to_lin_rec709`` nodegraph, expanded)."""
        nodedef = standard_library().getNodeDef(f"ND_{space}_to_{WORKING_SPACE}_{type_}")
        impl = None if nodedef is None else nodedef.getImplementation()
        if impl is None or not isinstance(impl, _node_graph_class()):
            known = sorted({d.getNodeString().removesuffix(f"_to_{WORKING_SPACE}") for d in standard_library().getNodeDefs()
                            if d.getNodeString().endswith(f"_to_{WORKING_SPACE}")})
            raise MtlxError(self.where, owner.getNamePath(), f"colour space {space!r} has no transform to {WORKING_SPACE} in the "
                            f"library (it has: {', '.join(known)})")
        self.scopes += 1
        return self.graph_output(impl.getOutput("out"), _Scope({"in": value}, self.scopes))

    def _connection(self, inp, owner, scope: dict):
        output = inp.getOutputString() or "out"
        if inp.getNodeGraphString():
            graph = self.doc.getNodeGraph(inp.getNodeGraphString())
            out = graph.getOutput(inp.getOutputString()) if inp.getOutputString() else graph.getOutputs()[0]
            return self.graph_output(out, {})
        parent = owner.getParent()
        if inp.getNodeName():
            node = parent.getNode(inp.getNodeName())
            if node is None:
                raise MtlxError(self.where, owner.getNamePath(), f"input {inp.getName()!r} reads a node not in its graph")
            return self.node(node, output, scope)
        out = parent.getOutput(inp.getOutputString())
        return self.graph_output(out, scope)

    def graph_output(self, out, scope: dict):
        """What a nodegraph's output reads (in the graph's ``scope``)."""
        if out.getInterfaceName():
            name = out.getInterfaceName()
            return scope[name] if name in scope else self.input(out, out, scope)
        if not out.getNodeName():
            return self.input(out, out, scope)
        node = out.getParent().getNode(out.getNodeName())
        return self.node(node, out.getOutputString() or "out", scope)

    def node(self, node, output: str, scope: dict):
        """The :class:`Ref` of ``node``'s ``output`` in ``scope``, its op (or expansion) made once."""
        from .nodes import PRIMITIVES, unsupported

        key = (getattr(scope, "number", 0), node.getNamePath(), output)
        if key in self.done:
            return self.done[key]
        category = node.getCategory()
        nodedef = node.getNodeDef()
        if nodedef is None:
            raise MtlxError(self.where, self._user_node(node), unsupported(category, "no node definition matches its inputs"))
        inputs = {}
        for definition in nodedef.getActiveInputs():
            name = definition.getName()
            if category == "normalmap" and name not in ("in", "scale"):
                continue  # the frame it decodes in is the renderer's: texbake bakes its tangent-space "in"
            given = node.getInput(name)
            inputs[name] = self.input(given, node, scope) if given is not None else self._geomprop_or_default(definition, node)
        impl = nodedef.getImplementation()
        if impl is not None and isinstance(impl, _node_graph_class()):  # the library's own definition, expanded
            self.scopes += 1
            inner = _Scope(inputs, self.scopes)  # its interface bound to this node's inputs
            self.expanding.append(f"{node.getNamePath()} ({category}, defined by the library's {impl.getName()})")
            try:
                ref = self.graph_output(impl.getOutput(output) or impl.getOutputs()[0], inner)
            finally:
                self.expanding.pop()
            self.done[key] = ref if isinstance(ref, Ref) else self._constant_op(ref, node, output)
            return self.done[key]
        if category not in PRIMITIVES or PRIMITIVES[category] is None and category != "normalmap":
            raise MtlxError(self.where, self._user_node(node), unsupported(category))
        op_id = f"{node.getNamePath()}@{key[0]}" if key[0] else node.getNamePath()
        outputs = nodedef.getActiveOutputs()
        self.ops[op_id] = Op(op_id, category, outputs[0].getType() if outputs else node.getType(), inputs, node.getNamePath())
        self.done[key] = Ref(op_id, output)
        return self.done[key]

    def _user_node(self, node) -> str:
        """The node a message names: the document's own (``node``, or the one whose library
        definition holds it, saying so)."""
        if not self.expanding:
            return node.getNamePath()
        return f"{self.expanding[0]}: its {node.getName()}"

    def _constant_op(self, value, node, output: str) -> Ref:
        op_id = f"{node.getNamePath()}#{output}"
        self.ops[op_id] = Op(op_id, "constant", _type_of(len(value)), {"value": value}, node.getNamePath())
        return Ref(op_id)

    def _geomprop_or_default(self, definition, node):
        prop = definition.getDefaultGeomPropString()
        if not prop:
            if definition.getType() in ("string", "filename"):
                return definition.getValueString()
            value = definition.getValue()
            return np.zeros(WIDTHS.get(definition.getType(), 1)) if value is None else value_array(value)
        if prop not in GEOMPROPS:
            raise MtlxError(self.where, node.getNamePath(), f"{node.getCategory()}: its input {definition.getName()!r} reads the "
                            f"geometric property {prop!r}, not one texbake gives (it gives: {', '.join(GEOMPROPS)})")
        category, arg = GEOMPROPS[prop]
        op_id = f"<{prop}>"
        if op_id not in self.ops:
            inputs = {"index": np.zeros(1)} if category == "texcoord" else {"space": arg}
            self.ops[op_id] = Op(op_id, category, "vector2" if category == "texcoord" else "vector3", inputs,
                                 self._user_node(node))
        return Ref(op_id)


@functools.cache
def _node_graph_class():
    import MaterialX as mx

    return mx.NodeGraph


def _type_of(width: int) -> str:
    return {1: "float", 2: "vector2", 3: "color3", 4: "color4"}[width]


def _default(nodedef, name: str):
    definition = None if nodedef is None else nodedef.getActiveInput(name)
    value = None if definition is None else definition.getValue()
    return np.ones(1) if value is None else value_array(value)
