"""Connected components of an undirected graph given as a list of edges (union-find, numba).

The labels are SciPy's (``scipy.sparse.csgraph.connected_components(graph,
directed=False)``): components are numbered 0, 1, ... in the order of their smallest node.
The charts of an atlas and the fans of the shading normals are numbered so, and the output
mesh's vertex order follows from those numbers.
"""

from __future__ import annotations

import numba as nb  # pip install numba
import numpy as np


def connected_components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(n,)`` int64 component of each of ``n`` nodes joined by the edges ``(a[i], b[i])``.

    ``a``, ``b``: ``(e,)`` int node indices in ``[0, n)`` (either way round, repeats and
    self-loops allowed). Components are numbered from 0 in the order of their smallest
    node, so node 0 is in component 0.
    """
    a = np.ascontiguousarray(a, dtype=np.int64).ravel()
    b = np.ascontiguousarray(b, dtype=np.int64).ravel()
    if a.shape != b.shape:
        raise ValueError(f"edge ends of different lengths: {a.shape[0]} and {b.shape[0]}")
    if len(a) and (min(a.min(), b.min()) < 0 or max(a.max(), b.max()) >= n):
        raise ValueError(f"edge ends outside [0, {n}): {min(a.min(), b.min())} to {max(a.max(), b.max())}")
    return _labels(n, a, b)


@nb.njit(cache=True, nogil=True)
def _root(parent, i):  # pragma: no cover - compiled
    """The root of node ``i``, halving the path to it on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@nb.njit(cache=True, nogil=True)
def _labels(n, a, b):  # pragma: no cover - compiled
    """:func:`connected_components` for valid ``(e,)`` int64 ``a``, ``b``. No GIL."""
    parent = np.arange(n)
    for i in range(a.shape[0]):
        x, y = _root(parent, a[i]), _root(parent, b[i])
        if x != y:
            parent[max(x, y)] = min(x, y)  # the smaller node stays the root
    label = np.full(n, -1, dtype=np.int64)
    count = 0
    for i in range(n):  # in node order: a component's label is given at its smallest node
        r = _root(parent, i)
        if label[r] < 0:
            label[r] = count
            count += 1
        label[i] = label[r]
    return label
