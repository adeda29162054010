"""Evaluating a material at surface samples: its leaves, then its node program, every
node once per sample; the channels' values out.

:class:`Evaluator` is what a bake holds: the programs of the channels it bakes (and of
the height alone, for the normal map's finite differences), and how many samples each
node was evaluated at (the report's ``material.nodes``). :func:`evaluate_material` is the
library's call without a mesh, as ``texbake.textures.evaluate`` is a texture's.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable

import numpy as np

from .. import _native
from ..textures.mapping import TextureMapping
from . import leaves
from .graph import CHANNELS
from .model import Material, parse_material
from .nodes import COLOUR
from .program import Program, channels_of, compile_program

_NO_SPREAD = np.zeros(0)


MeshMaps = Callable[[str], np.ndarray]  # a mesh map's name -> its (n, c) float64 values at the samples


def run_in_space(program: Program, mapping: TextureMapping, q: np.ndarray, dqdx: np.ndarray | None, dqdy: np.ndarray | None,
                 normals: np.ndarray | None, *, max_octaves: int | None = None, exact: bool = False,
                 mesh_maps: MeshMaps | None = None) -> dict[str, np.ndarray]:
    """``channel -> (n, c)`` float64 (c = 3 for colours, 1 for scalars) at ``(n, 3)`` points
    ``q`` in the bake's texture space (rounded to its precision here unless ``exact``),
    with their footprints (None: point sampling) and ``(n, 3)`` unit ``normals`` (needed
    only by a material with a normal node); ``mesh_maps`` gives the mesh maps' values at
    the samples (needed only by a material with a mesh_map node)."""
    if mapping.precision == "float32" and not exact:
        q = q.astype(np.float32).astype(np.float64)
        if dqdx is not None and dqdy is not None:
            dqdx, dqdy = dqdx.astype(np.float32).astype(np.float64), dqdy.astype(np.float32).astype(np.float64)
    spread = dqdx is not None and dqdy is not None
    n, nodes = len(q), program.graph.nodes
    values: dict[str, leaves.Value] = {}
    for seg in program.segments:
        for leaf in seg.leaves:
            wide = spread and leaf in program.spread  # the leaf's spread is read: evaluated with it
            node = nodes[leaf]
            if node.op == "mesh_map":
                name = node.params.map  # type: ignore[attr-defined]
                if mesh_maps is None:
                    raise ValueError(f"node {node.id!r}: mesh map {name!r} asked for where there are none")
                values[leaf] = np.asarray(mesh_maps(name), dtype=np.float64), None
                continue
            values[leaf] = _leaf(node, mapping, q, dqdx, dqdy, normals, values, max_octaves, wide)
        if not len(seg.code):
            continue
        out_mean = np.empty((n, seg.columns))
        out_var = np.empty((n if spread else 0, seg.spread_columns if spread else 0))
        _native.material_program(seg.code, seg.slots, [np.ascontiguousarray(values[r][0]) for r in seg.reads],
                                 [_NO_SPREAD if values[r][1] is None or not spread else np.ascontiguousarray(values[r][1])
                                  for r in seg.reads], seg.params, seg.tables, seg.temps, spread, out_mean, out_var)
        for node_id, column in seg.exports.items():
            width = channels_of(nodes[node_id])
            at = seg.spread_exports.get(node_id)
            values[node_id] = (out_mean[:, column : column + width], None if at is None or not spread else out_var[:, at : at + width])
    return {channel: _channel(values, nodes[root], n, 3 if CHANNELS[channel] == COLOUR else 1)
            for channel, root in program.channels.items()}


def _channel(values: dict, node, n: int, width: int) -> np.ndarray:
    """A channel's ``(n, width)`` values: its node's (a scalar in a colour channel is grey)."""
    if node.op == "constant":
        return np.broadcast_to(np.atleast_1d(np.asarray(node.params.value, dtype=np.float64)), (n, width)).copy()
    mean = values[node.id][0]
    return np.repeat(mean, width, axis=1) if mean.shape[1] < width else mean


def _leaf(node, mapping: TextureMapping, q, dqdx, dqdy, normals, values: dict, max_octaves, spread: bool) -> leaves.Value:
    if node.op == "position":
        mean, var = leaves.position(q, dqdx, dqdy, mapping.bounds)
        return mean, var if spread else None
    if node.op == "normal":
        if normals is None:
            raise ValueError(f"node {node.id!r}: the samples have no normals")
        return np.asarray(normals, dtype=np.float64), None
    if node.op == "mtlx":
        from ..mtlx.material import channel_values

        scaled = [None if d is None else d / mapping.scale for d in (dqdx, dqdy)]  # the footprint in object space
        return channel_values(node.params, q / mapping.scale + mapping.origin, normals, *scaled, batch=q), None
    if node.op == "warp":
        p = node.params
        q, dqdx, dqdy = leaves.warped_points(q, dqdx, dqdy, values[node.inputs["by"]], p.amount, p.axis)
    if node.params.output == "value":
        return leaves.texture_value(node.spec, q, dqdx, dqdy, mapping.bounds, max_octaves, spread=spread)
    return leaves.texture_colour(node.spec, q, dqdx, dqdy, mapping.bounds, max_octaves)


class Evaluator:
    """A material's evaluation in a bake: ``channels`` (those baked) in one program, and
    the counts of each node's evaluations (thread-safe: the bake's tiles run in threads)."""

    def __init__(self, material: Material, channels: list[str]):
        self.material = material
        self.program = compile_program(material.graph, channels)
        self.counts = dict.fromkeys((n for n in self.program.nodes if material.graph.nodes[n].op != "constant"), 0)
        self.gradient_counts: dict[str, int] = {}
        self._lock = threading.Lock()

    @functools.cached_property
    def height_uses_normals(self) -> bool:
        return any(self.material.graph.nodes[n].op in ("normal", "mtlx") for n in self.height_program.nodes)

    @functools.cached_property
    def height_program(self) -> Program:
        """The height channel alone: what the normal map's offset points evaluate."""
        return compile_program(self.material.graph, ["height"])

    @functools.cached_property
    def mesh_maps(self) -> set[str]:
        """The mesh maps the material's nodes read (``mesh_map``)."""
        return {n.params.map for n in self.material.graph.nodes.values() if n.op == "mesh_map"}  # type: ignore[attr-defined]

    def values(self, mapping: TextureMapping, q, dqdx, dqdy, normals, *, max_octaves=None, exact=False, count=True,
               mesh_maps: MeshMaps | None = None) -> dict:
        """:func:`run_in_space` of the bake's channels, counted (unless ``count`` is False: the error probe)."""
        out = run_in_space(self.program, mapping, q, dqdx, dqdy, normals, max_octaves=max_octaves, exact=exact, mesh_maps=mesh_maps)
        if count:
            with self._lock:
                for node in self.counts:
                    self.counts[node] += len(q)
        return out

    def heights(self, mapping: TextureMapping, q, dqdx, dqdy, normals, *, max_octaves=None, exact=False, count=True,
                mesh_maps: MeshMaps | None = None) -> np.ndarray:
        """``(n,)`` the height channel at ``q`` (the normal map's offset points)."""
        h = run_in_space(self.height_program, mapping, q, dqdx, dqdy, normals, max_octaves=max_octaves, exact=exact,
                         mesh_maps=mesh_maps)["height"]
        if count:
            with self._lock:
                for node in self.height_program.nodes:
                    if node in self.counts:
                        self.gradient_counts[node] = self.gradient_counts.get(node, 0) + len(q)
        return h[:, 0]

    def report(self) -> dict:
        """The report's ``material.nodes``: each node evaluated, its op, the channels that
        use it, the samples it was evaluated at (once a sample however many channels use
        it) and, for the height's nodes, at the normal map's offset points."""
        graph = self.material.graph
        out = {}
        for node_id, count in self.counts.items():
            entry = {"op": graph.nodes[node_id].op, "channels": graph.users.get(node_id, []), "evaluations": count}
            if node_id in self.gradient_counts:
                entry["gradient_evaluations"] = self.gradient_counts[node_id]
            out[node_id] = entry
        return out


def evaluate_material(material, points, footprint=None, *, normals=None, bounds=None, channels=None,
                      max_octaves=None, mesh_maps: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Evaluate a material's channels at object-space points, without a mesh.

    Parameters
    ----------
    material : Material, dict or str
        A material, its JSON object or text, or a built-in material's name.
    points : (n, 3) array_like of float
        Object-space points (with ``bounds`` None: the unit cube's texture space).
    footprint : (n, 2, 3) array_like of float, optional
        ``dpdx`` and ``dpdy`` of each point (None: point sampling).
    normals : (n, 3) array_like of float, optional
        Unit normals, for a material with a ``normal`` node.
    bounds : (2, 3) array_like of float, optional
        The object's bounding box (None: the unit cube), as ``texbake.textures.evaluate``.
    channels : list of str, optional
        Which channels (default: all the material gives; ``normal`` is the channel as
        given, not a normal made from ``height``).
    mesh_maps : dict of str to (n, c) array_like of float, optional
        The mesh maps' values at the points, for a material with ``mesh_map`` nodes.

    Returns
    -------
    dict of str to (n, c) ndarray of float64
        Each channel's values: c = 3 for ``base_color``, ``emissive``, ``normal``, else 1.
    """
    material = parse_material(material)
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    f = None if footprint is None else np.asarray(footprint, dtype=np.float64).reshape(-1, 2, 3)
    box = np.array([[0.0] * 3, [1.0] * 3]) if bounds is None else np.asarray(bounds, dtype=np.float64)
    mapping = TextureMapping.for_mesh(box[0], box[1], "object")
    wanted = [c for c in CHANNELS if c in material.graph.channels] if channels is None else list(channels)
    program = compile_program(material.graph, wanted)
    n = None if normals is None else np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    given = None if mesh_maps is None else {k: np.asarray(v, dtype=np.float64).reshape(len(p), -1) for k, v in mesh_maps.items()}
    reader = None if given is None else given.__getitem__
    return run_in_space(program, mapping, p, None if f is None else f[:, 0], None if f is None else f[:, 1], n,
                        max_octaves=max_octaves, mesh_maps=reader)
