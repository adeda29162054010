"""Connected components of an undirected graph (union-find, compiled: ``native/components.cpp``): of a list of edges at
once (:func:`connected_components`), or joined one pair at a time where each join is
decided on the sets so far (:class:`DisjointSets`). The one union-find of the package.

The labels are SciPy's (``scipy.sparse.csgraph.connected_components(graph,
directed=False)``): components are numbered 0, 1, ... in the order of their smallest node,
which is also each set's root. The charts of an atlas and the fans of the shading normals
are numbered so, and the output mesh's vertex order follows from those numbers.
"""

from __future__ import annotations

import numpy as np

from .. import _native


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
    labels = np.empty(n, dtype=np.int64)
    _native.labels(n, a, b, labels)
    return labels


class DisjointSets:
    """Nodes ``0 .. n-1`` in sets, joined one pair at a time (for joins that depend on the
    sets made so far); each set's root is its smallest node."""

    def __init__(self, n: int):
        self._parent = np.arange(n, dtype=np.int64)

    def find(self, i: int) -> int:
        """The root of node ``i``'s set."""
        return int(_native.sets_root(self._parent, i))

    def join(self, i: int, j: int) -> int:
        """Join the sets of nodes ``i`` and ``j``; returns the root of the joined set."""
        return int(_native.sets_join(self._parent, i, j))

    def labels(self) -> np.ndarray:
        """``(n,)`` int64 set of each node, numbered as :func:`connected_components` numbers them."""
        labels = np.empty(len(self._parent), dtype=np.int64)
        _native.sets_labels(self._parent, labels)
        return labels
