"""Connected components (texbake/mesh/components.py): SciPy's labels, exactly, of edges at once or joined one by one."""

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components as scipy_components

from texbake.mesh.components import DisjointSets, connected_components


def scipy_labels(n, a, b):
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    return scipy_components(graph, directed=False)[1]


@pytest.mark.parametrize("edges_per_node", [0.0, 0.1, 0.5, 0.9, 1.5, 4.0])
def test_labels_are_scipys_on_random_graphs(edges_per_node):
    # identical labels, not only the same partition: the baked mesh's vertex order follows them
    rng = np.random.default_rng(int(edges_per_node * 10))
    for n in [1, 2, 7, 100, 5000]:
        e = int(edges_per_node * n)
        a, b = rng.integers(0, n, e), rng.integers(0, n, e)  # repeats and self-loops included
        got = connected_components(n, a, b)
        assert got.dtype == np.int64 and got.shape == (n,)
        assert np.array_equal(got, scipy_labels(n, a, b)), (n, e)


def test_labels_follow_the_smallest_node():
    # a chain joined from its far end first, so that no union meets the smallest node early
    n = 50
    perm = np.random.default_rng(3).permutation(n)
    a, b = perm[:-1], perm[1:]
    assert not connected_components(n, a[::-1], b[::-1]).any()
    label = connected_components(6, np.array([5, 4]), np.array([3, 1]))  # {0} {1, 4} {2} {3, 5}
    assert label.tolist() == [0, 1, 2, 3, 1, 3]


def test_bad_edges():
    with pytest.raises(ValueError, match="different lengths"):
        connected_components(3, np.array([0, 1]), np.array([1]))
    with pytest.raises(ValueError, match=r"outside \[0, 3\)"):
        connected_components(3, np.array([0]), np.array([3]))
    assert connected_components(0, np.array([], int), np.array([], int)).shape == (0,)


def test_sets_joined_one_at_a_time_are_labelled_as_the_edges_at_once():
    rng = np.random.default_rng(11)
    n = 300
    sets = DisjointSets(n)
    joined_a, joined_b = [], []
    for x, y in rng.integers(0, n, (400, 2)):
        rx, ry = sets.find(int(x)), sets.find(int(y))
        if (rx + ry) % 3 == 0:  # a join decided on the sets so far, as the planar charts decide theirs
            continue
        root = sets.join(rx, ry)
        joined_a.append(x)
        joined_b.append(y)
        assert root == min(rx, ry) == sets.find(int(x)) == sets.find(int(y))  # the smaller root stays the root
    labels = sets.labels()
    assert labels.dtype == np.int64 and 1 < labels.max() < n - 1
    assert np.array_equal(labels, scipy_labels(n, np.array(joined_a), np.array(joined_b)))
    members = np.flatnonzero(labels == labels[17])
    assert sets.find(17) == members.min()  # a set's root is its smallest node
