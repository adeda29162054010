"""A material's node graph, checked and resolved: every node with its inputs, parameters
and kind, in an order where each comes after its inputs, and the node of each channel.

Built once per material (:func:`build_graph`), before any bake: a reference to a node
that is not there, an op that does not exist, a cycle, a colour where a scalar is taken,
a bad parameter or texture spec inside a node: each is a
:class:`~texbake.errors.MaterialError` naming the node (a named node by its name, a node
written in place by its path from the channel or node it is in: ``base_color.mask``).

Nodes that are the same (the same op, inputs and parameters: a named node used by several
channels, or the same texture written in two places) are one node, evaluated once per
sample.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any

from pydantic import BaseModel, ValidationError

from ..errors import MaterialError, TextureError
from ..meshmaps.kinds import CHANNELS as MESH_MAP_CHANNELS
from ..textures.spec import TEXTURES, parse_spec
from ..validation import describe, did_you_mean, shown
from .nodes import ANY, COLOUR, OPS, SCALAR, VALUED, ConstantParams, TextureParams

CHANNELS = {"base_color": COLOUR, "roughness": SCALAR, "metallic": SCALAR, "normal": COLOUR, "height": SCALAR,
            "occlusion": SCALAR, "emissive": COLOUR, "opacity": SCALAR}
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_-]{0,63}")


@dataclass(frozen=True)
class Node:
    """One node: ``op`` (a key of ``nodes.OPS``), ``inputs`` (input name -> node id),
    ``params`` (the op's parameter model), ``kind`` (``scalar`` or ``colour``) and, for a
    texture or warp, its parsed ``spec``."""

    id: str
    op: str
    inputs: dict[str, str]
    params: BaseModel
    kind: str
    spec: Any = None


@dataclass(frozen=True)
class Graph:
    """``nodes`` by id in evaluation order (inputs first); ``channels``: channel -> node id."""

    nodes: dict[str, Node]
    channels: dict[str, str]
    users: dict[str, list[str]] = field(default_factory=dict)  # node id -> the channels that use it

    def needed(self, channels) -> list[str]:
        """The ids of the nodes the ``channels`` need, in evaluation order."""
        wanted: set[str] = set()
        stack = [self.channels[c] for c in channels]
        while stack:
            node = stack.pop()
            if node not in wanted:
                wanted.add(node)
                stack.extend(self.nodes[node].inputs.values())
        return [n for n in self.nodes if n in wanted]


def build_graph(named: dict[str, Any], channels: dict[str, Any]) -> Graph:
    """The graph of a material's ``named`` nodes (name -> node) and ``channels`` (channel
    -> expression; None: not given). Raises :class:`MaterialError` naming the node."""
    for name in named:
        if not isinstance(name, str) or not NAME.fullmatch(name):
            raise MaterialError(str(name), "a node's name is a letter or _ then letters, digits, _ or - (at most 64)")
        if name in CHANNELS:
            raise MaterialError(name, f"a node may not be named after a channel ({', '.join(CHANNELS)})")
    builder = _Builder(named)
    roots = {}
    for channel, value in channels.items():
        if value is None:
            continue
        root = builder.expr(value, channel)
        if CHANNELS[channel] == SCALAR and builder.nodes[root].kind == COLOUR:
            raise MaterialError(channel, f"the {channel} channel takes a scalar, got a colour{_from(root, channel)} "
                                "(pick one with a channel node)")
        roots[channel] = root
    for name in named:  # nodes no channel uses are checked too
        builder.named_node(name, name)
    if not roots:
        raise MaterialError("", f"a material needs at least one channel ({', '.join(CHANNELS)})")
    users: dict[str, list[str]] = {}
    nodes = builder.nodes
    graph = Graph(nodes, roots, users)
    for channel in roots:
        for node in graph.needed([channel]):
            users.setdefault(node, []).append(channel)
    return graph


def _from(node: str, where: str) -> str:
    return "" if node == where else f" (node {node!r})"


class _Builder:
    """Resolves expressions into nodes, depth first (so inputs come first), merging equal ones."""

    def __init__(self, named: dict[str, Any]):
        self.named = named
        self.nodes: dict[str, Node] = {}
        self.keys: dict[str, str] = {}  # a node's canonical form -> its id
        self.alias: dict[str, str] = {}  # a named node -> the id it resolved to
        self.visiting: list[str] = []

    def named_node(self, name: str, path: str) -> str:
        if name in self.alias:
            return self.alias[name]
        if name not in self.named:
            known = sorted(self.named)
            listed = f"the nodes are: {', '.join(known)}" if known else "the material has no named nodes"
            texture = f"; a texture is written {{'name': {name!r}}}" if name in TEXTURES else ""
            raise MaterialError(path, f"unknown node {shown(name, 70)} ({did_you_mean(name, known)}{listed}{texture})")
        if name in self.visiting:
            cycle = [*self.visiting[self.visiting.index(name):], name]
            raise MaterialError(name, "a cycle: " + " -> ".join(cycle))
        self.visiting.append(name)
        try:
            resolved = self.expr(self.named[name], name)
        finally:
            self.visiting.pop()
        self.alias[name] = resolved
        return resolved

    def expr(self, value: Any, path: str) -> str:
        """The id of the node ``value`` is (see ``nodes``), at ``path``."""
        if isinstance(value, bool) or value is None:
            raise MaterialError(path, f"expected a number, three numbers, a node's name or a node, got {shown(value)}")
        if isinstance(value, (int, float)) or isinstance(value, (list, tuple)):
            return self.node(path, {"op": "constant", "value": value})
        if isinstance(value, str):
            return self.named_node(value, path)
        if not isinstance(value, dict):
            raise MaterialError(path, f"expected a number, three numbers, a node's name or a node, got {type(value).__name__}")
        if "op" not in value:
            if "name" in value:  # a texture spec in place of a node: its colour
                return self.node(path, {"op": "texture", "texture": value})
            raise MaterialError(path, f"a node needs an 'op' (one of {', '.join(OPS)}), or a texture spec its 'name', "
                                f"got the keys {', '.join(map(str, value)) or 'none'}")
        return self.node(path, value)

    def node(self, path: str, value: dict) -> str:
        op = value["op"]
        if not isinstance(op, str) or op not in OPS:
            raise MaterialError(path, f"unknown op {shown(op, 40)} ({did_you_mean(str(op), list(OPS))}the ops are: {', '.join(OPS)})")
        spec = OPS[op]
        missing = [name for name in spec.inputs if name not in value]
        if missing:
            raise MaterialError(path, f"{op} needs the input {missing[0]!r} (it takes {', '.join(spec.inputs)})")
        inputs = {name: self.expr(value[name], f"{path}.{name}") for name, kind in spec.inputs.items()}
        params = self._params(path, op, {k: v for k, v in value.items() if k != "op" and k not in spec.inputs})
        for name, wants in spec.inputs.items():
            got = self.nodes[inputs[name]].kind
            if wants != ANY and got != wants and not (wants == COLOUR and got == SCALAR and op != "channel"):
                raise MaterialError(path, f"input {name!r} takes a {wants}, got a {got}{_from(inputs[name], f'{path}.{name}')}")
        texture = self._texture(path, op, params) if isinstance(params, TextureParams) else None
        kind = self._kind(op, inputs, params, texture)
        key = json.dumps([op, inputs, params.model_dump(mode="json", exclude={"texture"}),
                          None if texture is None else texture.model_dump(mode="json")], sort_keys=True)
        if key in self.keys:
            return self.keys[key]
        if path in self.nodes:  # a path taken by a node merged away before: keep ids unique
            path = f"{path}#{len(self.nodes)}"
        self.nodes[path] = Node(path, op, inputs, params, kind, texture)
        self.keys[key] = path
        return path

    def _params(self, path: str, op: str, given: dict) -> BaseModel:
        model = OPS[op].params
        try:
            return model.model_validate(given)
        except ValidationError as exc:
            problems = describe(exc.errors(include_url=False), model.model_json_schema(), subject=op)
            text = "; ".join(f"{field}: {problem}" if field else problem for field, problem in problems)
            raise MaterialError(path, text.replace("has no parameter", "takes no", 1)) from None

    def _texture(self, path: str, op: str, params: TextureParams):
        try:
            texture = parse_spec(params.texture)
        except TextureError as exc:
            raise MaterialError(path, f"texture: {exc}") from None
        if params.output == "value" and texture.name not in VALUED:
            raise MaterialError(path, f"texture {texture.name!r} has no value, only a colour (a value: {', '.join(VALUED)}; "
                                f"the textures: {', '.join(TEXTURES)})")
        return texture

    def _kind(self, op: str, inputs: dict[str, str], params: BaseModel, texture) -> str:
        gives = OPS[op].gives
        if gives == "texture":
            return COLOUR if params.output == "colour" else SCALAR  # type: ignore[attr-defined]
        if gives == "constant":
            assert isinstance(params, ConstantParams)
            return SCALAR if isinstance(params.value, float) else COLOUR
        if gives == "remap":
            return COLOUR if params.colormap is not None else SCALAR  # type: ignore[attr-defined]
        if gives == "input":
            return self.nodes[inputs["input"]].kind
        if gives == "kind":
            return params.kind  # type: ignore[attr-defined]
        if gives == "mesh_map":
            return SCALAR if MESH_MAP_CHANNELS[params.map] == 1 else COLOUR  # type: ignore[attr-defined]
        if gives == "widest":
            return COLOUR if any(self.nodes[inputs[n]].kind == COLOUR for n in OPS[op].widest_of) else SCALAR
        return gives
