"""Connected components of an undirected graph (union-find, numba): of a list of edges at
once (:func:`connected_components`), or joined one pair at a time where each join is
decided on the sets so far (:class:`DisjointSets`). The one union-find of the package.

The labels are SciPy's (``scipy.sparse.csgraph.connected_components(graph,
directed=False)``): components are numbered 0, 1, ... in the order of their smallest node,
which is also each set's root. The charts of an atlas and the fans of the shading normals
are numbered so, and the output mesh's vertex order follows from those numbers.
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


class DisjointSets:
    """Nodes ``0 .. n-1`` in sets, joined one pair at a time (for joins that depend on the
    sets made so far); each set's root is its smallest node."""

    def __init__(self, n: int):
        self._parent = np.arange(n, dtype=np.int64)

    def find(self, i: int) -> int:
        """The root of node ``i``'s set."""
        return int(_root(self._parent, i))

    def join(self, i: int, j: int) -> int:
        """Join the sets of nodes ``i`` and ``j``; returns the root of the joined set."""
        return int(_join(self._parent, i, j))

    def labels(self) -> np.ndarray:
        """``(n,)`` int64 set of each node, numbered as :func:`connected_components` numbers them."""
        return _number(self._parent)


@nb.njit(cache=True, nogil=True)
def _root(parent, i):  # pragma: no cover - compiled
    """The root of node ``i``, halving the path to it on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@nb.njit(cache=True, nogil=True)
def _join(parent, i, j):  # pragma: no cover - compiled
    """Join the sets of ``i`` and ``j``; the smaller root stays the root, and is returned."""
    x, y = _root(parent, i), _root(parent, j)
    if x != y:
        parent[max(x, y)] = min(x, y)
    return min(x, y)


@nb.njit(cache=True, nogil=True)
def _number(parent):  # pragma: no cover - compiled
    """``(n,)`` int64 labels of the sets in ``parent``, in the order of their smallest node."""
    n = parent.shape[0]
    label = np.full(n, -1, dtype=np.int64)
    count = 0
    for i in range(n):  # in node order: a component's label is given at its smallest node
        r = _root(parent, i)
        if label[r] < 0:
            label[r] = count
            count += 1
        label[i] = label[r]
    return label


@nb.njit(cache=True, nogil=True)
def _labels(n, a, b):  # pragma: no cover - compiled
    """:func:`connected_components` for valid ``(e,)`` int64 ``a``, ``b``. No GIL."""
    parent = np.arange(n)
    for i in range(a.shape[0]):
        _join(parent, a[i], b[i])
    return _number(parent)
