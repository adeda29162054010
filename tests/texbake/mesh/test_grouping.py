"""Grouping keys and rows (texbake.mesh.grouping) against numpy's own sorts."""

import numpy as np
import pytest

from texbake.mesh.grouping import group_rows, groups, stable_order, unique_inverse


@pytest.mark.parametrize("n", [0, 1, 2, 17, 5000])
def test_stable_order_is_lexsort(n):
    rng = np.random.default_rng(n)
    a, b = rng.integers(-5, 50, n), rng.integers(0, 7, n)  # many ties: their order is the test
    assert np.array_equal(stable_order(a, b), np.lexsort((b, a)))
    assert np.array_equal(stable_order(a), np.argsort(a, kind="stable"))


def test_stable_order_of_keys_too_wide_to_pack():
    a = np.random.default_rng(1).integers(-(2**62), 2**62, 1000)
    a[::7] = a[0]
    assert np.array_equal(stable_order(a), np.argsort(a, kind="stable"))


@pytest.mark.parametrize("wide", [False, True])
def test_groups_are_numpys_unique(wide):
    rng = np.random.default_rng(2)
    high = 2**52 if wide else 9  # wide: the keys do not fit one packed number (nor the first one alone)
    a, b = rng.integers(0, high, 3000), rng.integers(0, 9, 3000)
    a[::3] = a[1]
    first, inverse = groups(a, b)
    _, first_np, inverse_np = np.unique(a.astype(object) * 9 + b, return_index=True, return_inverse=True)
    assert np.array_equal(first, first_np) and np.array_equal(inverse, inverse_np.ravel().astype(np.int64))


@pytest.mark.parametrize("dtype", [np.float64, np.int64])
def test_group_rows_groups_equal_rows(dtype):
    rows = np.random.default_rng(3).integers(0, 3, (4000, 3)).astype(dtype)
    first, inverse = group_rows(rows)
    assert np.array_equal(rows[first[inverse]], rows)  # every row is its group's first
    assert len(first) == len(np.unique(rows, axis=0))  # and different rows are apart
    assert (np.diff(first) > 0).all()  # groups numbered in the order of their first row
    assert all(first[g] == np.flatnonzero(inverse == g)[0] for g in range(len(first)))  # the first member


def test_group_rows_takes_minus_zero_as_zero():
    rows = np.array([[0.0, 1.0], [-0.0, 1.0], [0.0, -1.0]])
    first, inverse = group_rows(rows)
    assert inverse[0] == inverse[1] != inverse[2] and len(first) == 2


@pytest.mark.parametrize("shape", [(0, 3), (1, 3), (500, 3), (4000,)])
def test_unique_inverse_is_numpys_unique(shape):
    # the unwrap's chart vertices (sparse indices, repeated) against np.unique's own
    values = np.random.default_rng(5).integers(0, 3000, size=shape) * 7
    used, inverse = unique_inverse(values)
    want_used, want_inverse = np.unique(values, return_inverse=True)
    assert used.dtype == np.int64 and inverse.dtype == np.int64
    assert np.array_equal(used, want_used)
    assert np.array_equal(inverse, want_inverse.reshape(-1))
    assert np.array_equal(used[inverse], values.reshape(-1))


def test_unique_inverse_refuses_values_outside_its_range():
    with pytest.raises(ValueError, match=r"outside \[0, 3\)"):
        unique_inverse(np.array([0, 3]), 3)
    with pytest.raises(ValueError, match="outside"):
        unique_inverse(np.array([-1, 2]))
