"""The material: a whole PBR texture set from one procedural description.

A material is a JSON (or YAML) object: its channels, ``base_color``, ``roughness``,
``metallic``, ``normal``, ``height``, ``occlusion``, ``emissive`` and ``opacity`` (any of
them; ``base_color`` at least), each a constant, a texture or an expression of the node
graph (``texbake.materials.nodes``), and ``nodes``, named nodes the channels (and other
nodes) refer to by name. Built-in materials go by name (:data:`BUILTINS`). Parsed by
:func:`parse_material`; the graph is checked as the material is made
(``graph.build_graph``), so a bad material fails before any bake, naming the node.
"""

from __future__ import annotations

import copy
import functools
import json
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, model_validator

from ..errors import MaterialError
from ..validation import describe, did_you_mean, json_error_text, shown
from .graph import CHANNELS, Graph, build_graph

Expression = Annotated[Any, Field(None, description="a number, three numbers (linear RGB), a node's name, a node "
                                                    "({\"op\": ...}) or a texture spec ({\"name\": ...})")]

# what a channel is where the material does not give it (the GLB's factor, a packed map's value)
DEFAULTS: dict[str, float | tuple[float, float, float]] = {
    "base_color": (0.8, 0.8, 0.8), "roughness": 1.0, "metallic": 0.0, "normal": (0.5, 0.5, 1.0), "height": 0.0,
    "occlusion": 1.0, "emissive": (0.0, 0.0, 0.0), "opacity": 1.0}


class Material(BaseModel):
    """A material: its channels and named nodes (see the module), checked when made.

    ``height_scale``: the relief of ``height`` 0 to 1, in the bake's texture space (the
    mesh's longest side is 1 in the default "unit" space), for the normal map made from
    it. ``alpha_mode``: how a GLB reads a baked ``opacity`` (``blend``, or ``mask`` at
    ``alpha_cutoff``). :attr:`graph` is the checked graph.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field("", max_length=64, description="the material's name")
    description: str = Field("", max_length=1000)
    nodes: dict[str, Any] = Field(default_factory=dict, description="named nodes, by name: what channels and nodes refer to")
    base_color: Expression
    roughness: Expression
    metallic: Expression
    normal: Expression = Field(None, description="a tangent-space normal map, encoded 0.5 + 0.5 n, +Y up")
    height: Expression
    occlusion: Expression
    emissive: Expression
    opacity: Expression
    height_scale: float = Field(0.01, gt=0, le=10, description="the relief of height 0 to 1, in texture-space units")
    alpha_mode: Literal["blend", "mask"] = "blend"
    alpha_cutoff: float = Field(0.5, ge=0, le=1)
    _graph: Graph = PrivateAttr()

    @model_validator(mode="after")
    def _check_graph(self):
        if self.base_color is None:
            raise MaterialError("base_color", "a material needs a base_color")
        self._graph = build_graph(self.nodes, {c: getattr(self, c) for c in CHANNELS})
        return self

    @property
    def graph(self) -> Graph:
        return self._graph

    @property
    def channels(self) -> list[str]:
        """The channels it gives, in :data:`CHANNELS`' order."""
        return list(self._graph.channels)

    def constant(self, channel: str) -> float | tuple[float, ...] | None:
        """The channel's value where it is a constant, else None."""
        node = self._graph.nodes.get(self._graph.channels.get(channel, ""))
        return None if node is None or node.op != "constant" else node.params.value  # type: ignore[attr-defined]


def parse_material(value) -> Material:
    """A material from a :class:`Material`, a dict, a built-in material's name, JSON text
    or a MaterialX document's XML text (``texbake.mtlx``).

    Pure: a string is a name or JSON, never a path (only the command line reads material
    files: ``texbake.cli.read_material``). Raises :class:`MaterialError` naming the node
    (or the material's own field) and the problem.
    """
    if isinstance(value, Material):
        return value
    if isinstance(value, str) and value.lstrip().startswith("<"):  # a MaterialX document's XML (texbake.mtlx)
        from ..mtlx.material import material_from_mtlx

        return material_from_mtlx(value)
    if isinstance(value, str):
        value = _from_text(value)
    if not isinstance(value, dict):
        raise MaterialError("", f"expected a material's name or a material (a mapping of channels), got {type(value).__name__}")
    try:
        return Material.model_validate(value)
    except ValidationError as exc:
        raise _material_error(exc) from None


def _material_error(exc: ValidationError) -> MaterialError:
    """The first problem of a failed validation: the graph's own error as it was raised,
    else the material's field named."""
    errors = exc.errors(include_url=False)
    for error in errors:
        inner = (error.get("ctx") or {}).get("error")
        if isinstance(inner, MaterialError):
            return inner
    problems = describe(errors, _schema(), subject="material")
    field, problem = problems[0]
    return MaterialError("", f"{field}: {problem}" if field else problem)


@functools.cache
def _schema() -> dict:
    return Material.model_json_schema()


def _from_text(value: str) -> dict:
    from .builtins import BUILTINS

    text = value.strip()
    if text in BUILTINS:
        return copy.deepcopy(BUILTINS[text])  # the material holds what it is given: not the shared table's own
    if not text.startswith("{"):
        raise MaterialError("", f"unknown material {shown(text, 80)} ({did_you_mean(text, sorted(BUILTINS))}built in: "
                            f"{', '.join(sorted(BUILTINS))})")
    from ..textures.spec import MAX_NESTING, _nesting

    if _nesting(text) > MAX_NESTING:
        raise MaterialError("", f"JSON material nested deeper than {MAX_NESTING} levels")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MaterialError("", json_error_text(exc)) from None
    if not isinstance(data, dict):
        raise MaterialError("", f"expected a JSON object of channels, got a {type(data).__name__}")
    return data
