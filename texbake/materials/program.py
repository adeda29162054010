"""A material's graph as programs of the compiled node kernel (``native/materials.cpp``).

The leaves (textures, warps, position, normal) are evaluated in Python, each over the
whole batch of points with the texture kernels; the nodes between them and the channels
run as one program of the node kernel, a block of points at a time, every node once per
point. A warp needs its ``by`` before its texture can be evaluated: the program is cut
into segments, each run after the leaves it reads (``by`` exported from the segment
before). Most materials are one segment.

Slots: every leaf and exported node of earlier segments is a leaf slot (its arrays), each
constant a constant slot (its values in ``params``), each node of the segment a buffer
slot; buffers are reused once their node's last reader has run.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from .graph import Graph, Node
from .nodes import COLOUR, LEAVES

OPCODES = {"add": 1, "subtract": 2, "multiply": 3, "divide": 4, "power": 5, "invert": 6, "clamp": 7, "threshold": 8,
           "smoothstep": 9, "mix": 10, "screen": 11, "overlay": 12, "channel": 13, "combine": 14, "curve": 15, "colormap": 16}
LEAF, CONSTANT, BUFFER = 0, 1, 2
CHANNEL_INDEX = {"r": 0, "x": 0, "g": 1, "y": 1, "b": 2, "z": 2, "luminance": 3}


@dataclass
class Segment:
    """One run of the node kernel: ``leaves`` (node ids) evaluated before it, ``reads`` (the
    node ids of its leaf slots, in order), ``code`` ``(k, 7)`` int32, ``slots`` ``(s, 3)``
    int32, ``params`` and ``tables`` float64, ``temps`` buffers, and ``exports`` (node id ->
    first column of the ``(n, columns)`` output)."""

    leaves: list[str] = field(default_factory=list)
    reads: list[str] = field(default_factory=list)
    code: np.ndarray = field(default_factory=lambda: np.zeros((0, 8), np.int32))
    slots: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int32))
    params: np.ndarray = field(default_factory=lambda: np.zeros(1))
    tables: np.ndarray = field(default_factory=lambda: np.zeros(1))
    temps: int = 0
    exports: dict[str, int] = field(default_factory=dict)
    columns: int = 0
    spread_exports: dict[str, int] = field(default_factory=dict)
    spread_columns: int = 0


@dataclass
class Program:
    """The segments that give ``channels`` (channel -> node id) of a graph; ``nodes``: every
    node they evaluate, in order; ``spread``: the nodes whose spread over the texel some
    node's mean depends on (a leaf not among them is evaluated without it)."""

    graph: Graph
    channels: dict[str, str]
    nodes: list[str]
    segments: list[Segment]
    spread: set[str] = field(default_factory=set)


# the inputs whose spread an op's mean depends on (the others' it only carries on); a blend's: by its mode
MEAN_OF_SPREAD = {"divide": ("b",), "power": ("a",), "clamp": ("input",), "threshold": ("input",), "smoothstep": ("input",),
                  "remap": ("input",), "warp": ("by",), "overlay": ("a",)}


def spread_needed(graph: Graph, order: list[str]) -> set[str]:
    """The nodes of ``order`` whose spread is read: by a node whose mean depends on it, or by
    a node whose own spread is (every op carries its inputs' spreads on)."""
    needed: set[str] = set()
    for node_id in reversed(order):
        node = graph.nodes[node_id]
        op = node.params.mode if node.op == "blend" else node.op  # type: ignore[attr-defined]
        for name, source in node.inputs.items():
            if node_id in needed or name in MEAN_OF_SPREAD.get(op, ()):
                needed.add(source)
    return needed


def channels_of(node: Node) -> int:
    return 3 if node.kind == COLOUR else 1


def compile_program(graph: Graph, channels: list[str]) -> Program:
    """The program of ``channels`` (a subset of the graph's)."""
    order = graph.needed(channels)
    nodes = graph.nodes
    level: dict[str, int] = {}
    for node_id in order:  # a leaf's level: the segment before which it is evaluated
        node = nodes[node_id]
        ins = [level[i] for i in node.inputs.values()]
        if node.op == "warp":
            by = node.inputs["by"]
            level[node_id] = level[by] + (0 if nodes[by].op in LEAVES else 1)
        else:
            level[node_id] = max(ins, default=0)
    roots = {c: graph.channels[c] for c in channels}
    # kernel nodes read after their segment (by a warp, or by nodes after one) are exported, as are the channels'
    later = {i for n in order for i in nodes[n].inputs.values() if nodes[i].op not in LEAVES and level[i] < level[n]}
    wanted = set(roots.values()) | later
    segments = []
    done: set[str] = set()  # nodes whose arrays exist before the segment runs
    for s in range(max(level.values(), default=0) + 1):
        members = [i for i in order if level[i] == s]
        leaves = [i for i in members if nodes[i].op in ("texture", "warp", "position", "normal", "mtlx", "mesh_map")]
        ops = [i for i in members if nodes[i].op not in LEAVES]
        segments.append(_segment(nodes, leaves, ops, done, wanted, later))
        done |= set(leaves) | set(segments[-1].exports)
    return Program(graph, roots, order, segments, spread_needed(graph, order))


def _segment(nodes: dict[str, Node], leaves: list[str], ops: list[str], done: set[str], wanted: set[str], later: set[str]) -> Segment:
    seg = Segment(leaves=leaves)
    slot: dict[str, int] = {}
    slots, params = [], [0.0]
    tables: list[np.ndarray] = [np.zeros(1)]
    last_use = {i: k for k, op in enumerate(ops) for i in nodes[op].inputs.values()}

    def read(node_id: str) -> int:
        if node_id not in slot:
            node = nodes[node_id]
            if node.op == "constant":
                value = np.atleast_1d(np.asarray(node.params.value, dtype=np.float64))  # type: ignore[attr-defined]
                slots.append((CONSTANT, len(value), len(params)))
                params.extend(value.tolist())
            else:
                assert node_id in done or node_id in leaves, node_id
                slots.append((LEAF, channels_of(node), len(seg.reads)))
                seg.reads.append(node_id)
            slot[node_id] = len(slots) - 1
        return slot[node_id]

    free: list[int] = []
    buffer_of: dict[str, int] = {}
    code = []
    for k, node_id in enumerate(ops):
        node = nodes[node_id]
        ins = [read(i) for i in node.inputs.values()]
        buffer = free.pop() if free else seg.temps
        seg.temps = max(seg.temps, buffer + 1)
        for i in set(node.inputs.values()):  # after the destination is taken: no op writes over its own input
            if i in buffer_of and last_use.get(i) == k and i not in wanted:
                free.append(buffer_of.pop(i))
        slots.append((BUFFER, channels_of(node), buffer))
        slot[node_id] = len(slots) - 1
        buffer_of[node_id] = buffer
        column = spread_column = -1
        if node_id in wanted:
            column, seg.columns = seg.columns, seg.columns + channels_of(node)
            seg.exports[node_id] = column
        if node_id in later:  # read after this segment: its spread too
            spread_column, seg.spread_columns = seg.spread_columns, seg.spread_columns + channels_of(node)
            seg.spread_exports[node_id] = spread_column
        op, param = _op_and_params(node, params, tables)
        code.append([op, slot[node_id], *(ins + [-1, -1, -1])[:3], param, column, spread_column])
    seg.code = np.array(code, dtype=np.int32).reshape(-1, 8)
    seg.slots = np.array(slots, dtype=np.int32).reshape(-1, 3)
    seg.params, seg.tables = np.array(params, dtype=np.float64), np.concatenate(tables)
    return seg


def _op_and_params(node: Node, params: list[float], tables: list[np.ndarray]) -> tuple[int, int]:
    """The node's opcode and where its parameters start in ``params`` (-1: none)."""
    p = node.params
    if node.op == "blend":
        return OPCODES[{"multiply": "multiply", "screen": "screen", "overlay": "overlay"}[p.mode]], -1  # type: ignore[attr-defined]
    values: list[float] = {
        "clamp": lambda: [p.min, p.max], "threshold": lambda: [p.at], "smoothstep": lambda: [p.edge0, p.edge1],  # type: ignore[attr-defined]
        "channel": lambda: [float(CHANNEL_INDEX[p.channel])],  # type: ignore[attr-defined]
    }.get(node.op, lambda: [])()
    op = node.op
    if op == "remap":
        table, lo, step = remap_table(p)
        smooth, start, per_unit, top = smoothed_table(*_curve_key(p))
        at = sum(t.size for t in tables)
        values = [float(at), float(len(table)), lo, step, float(at + table.size), start, per_unit, top]
        tables += [table.ravel(), smooth.ravel()]
        op = "colormap" if p.colormap is not None else "curve"  # type: ignore[attr-defined]
    if not values:
        return OPCODES[op], -1
    params.extend(values)
    return OPCODES[op], len(params) - len(values)


SPREAD_ROWS = 64  # spreads from 0 to MAX_SPREAD (times the knots' range) in a remap's smoothed table
SMOOTH_VALUES = 1024  # values a row, over the knots' range widened by 4 MAX_SPREAD on each side
FINE = 8192  # samples of the curve convolved (0.005 of its range apart)
MAX_SPREAD = 2.0  # past twice the knots' range a remap's mean barely changes with the spread: its last row


def remap_table(params) -> tuple[np.ndarray, float, float]:
    """``(table (SIZE, c), first knot, samples a unit)`` of a remap's colour map (c = 3) or
    curve (c = 1): the Catmull-Rom curve tabulated as the textures' colour maps are
    (``texbake.textures.colour``)."""
    from ..textures import colour

    curve = params.colormap if params.colormap is not None else params.curve
    table = _curve_table(*_curve_key(params))
    lo, step = colour._knot_steps(curve.knots)
    return table, lo, step


def _curve_key(params) -> tuple[tuple[float, ...], tuple[tuple[float, ...], ...]]:
    curve = params.colormap if params.colormap is not None else params.curve
    values = curve.colours if params.colormap is not None else tuple((v,) for v in curve.values)
    return tuple(curve.knots), tuple(tuple(v) for v in values)


@functools.lru_cache(maxsize=64)
def _curve_table(knots: tuple[float, ...], values: tuple[tuple[float, ...], ...]) -> np.ndarray:
    from ..textures import colour
    from ..textures.solid import spline

    k = np.asarray(knots, dtype=np.float64)
    return spline(np.linspace(k[0], k[-1], colour.SIZE), k, np.asarray(values, dtype=np.float64))


@functools.lru_cache(maxsize=64)
def smoothed_table(knots: tuple[float, ...], values: tuple[tuple[float, ...], ...]) -> tuple[np.ndarray, float, float, float]:
    """``(table (2, SPREAD_ROWS, SMOOTH_VALUES, c), first value, values a unit, largest
    spread)``: the curve's mean (``[0]``) and the mean of its square (``[1]``) over a
    Gaussian of each spread about each value: the curve (clamped to its ends) convolved
    with the Gaussian, as the marble's wave table is its colour map's
    (``textures.colour.wave_table``); row 0 is the curve itself."""
    from ..textures.solid import spline

    k, v = np.asarray(knots, dtype=np.float64), np.asarray(values, dtype=np.float64)
    span = float(k[-1] - k[0]) or 1.0
    top = MAX_SPREAD * span
    lo, hi = k[0] - 4 * top, k[-1] + 4 * top
    # the curve on a fine grid reaching 6 of the widest spreads past [lo, hi]: the circular
    # convolution's wrap stays out there
    fine = np.linspace(lo - 6 * top, hi + 6 * top, FINE)
    curve = spline(fine, k, v)  # (FINE, c), clamped to its ends
    frequency = np.fft.rfftfreq(FINE, fine[1] - fine[0])
    spectra = np.fft.rfft(curve, axis=0), np.fft.rfft(curve**2, axis=0)
    x = np.linspace(lo, hi, SMOOTH_VALUES)
    out = np.empty((2, SPREAD_ROWS, SMOOTH_VALUES, curve.shape[1]))
    for i, sigma in enumerate(top * np.arange(SPREAD_ROWS) / (SPREAD_ROWS - 1)):
        keep = np.exp(-0.5 * (2 * np.pi * frequency * sigma) ** 2)[:, None]
        for j, spectrum in enumerate(spectra):
            smooth = np.fft.irfft(spectrum * keep, n=FINE, axis=0)
            out[j, i] = np.column_stack([np.interp(x, fine, smooth[:, c]) for c in range(curve.shape[1])])
    out[0, 0], out[1, 0] = spline(x, k, v), spline(x, k, v) ** 2  # the curve itself, not its fine samples
    return out, float(lo), (SMOOTH_VALUES - 1) / (hi - lo), top
