"""fem2tmm.arrays: the sort-based unique / unique_rows give exactly np.unique's values, inverse and counts (the
reference is numpy itself), for every integer dtype, empty and one-element inputs, values whose packed key would
overflow int64 (the argsort path) and non-integer input (passed through)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fem2tmm.arrays import unique, unique_rows


def _same(got, want):
    got = got if isinstance(got, tuple) else (got,)
    want = want if isinstance(want, tuple) else (want,)
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.shape == w.shape and np.array_equal(g, w)


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.uint32, np.int8, np.uint64, np.float64])
@pytest.mark.parametrize("n, high", [(0, 5), (1, 5), (2000, 10), (2000, 2**40), (300, 2**62)])
def test_unique_is_np_unique(dtype, n, high):
    rng = np.random.default_rng(n + high % 97)
    low = 0 if np.dtype(dtype).kind == "u" else -3
    a = rng.integers(low, high, n).astype(dtype)
    for inverse, counts in itertools.product([False, True], repeat=2):
        _same(unique(a, return_inverse=inverse, return_counts=counts),
              np.unique(a, return_inverse=inverse, return_counts=counts))


def test_unique_inverse_keeps_the_input_shape():
    a = np.random.default_rng(1).integers(0, 7, (40, 3))
    _same(unique(a, return_inverse=True), np.unique(a, return_inverse=True))


@pytest.mark.parametrize("m, k, high", [(0, 3, 4), (1, 3, 4), (1000, 3, 5), (1000, 4, 2**20), (50, 2, 2**62)])
def test_unique_rows_is_np_unique_axis0(m, k, high):
    rng = np.random.default_rng(m + k)
    a = rng.integers(0, high, (m, k))
    a = np.concatenate([a, a[: m // 2]])  # repeated rows
    for inverse, counts in itertools.product([False, True], repeat=2):
        _same(unique_rows(a, return_inverse=inverse, return_counts=counts),
              np.unique(a, axis=0, return_inverse=inverse, return_counts=counts))


@pytest.mark.parametrize("m, k, levels", [(1, 3, 4), (5000, 6, 3), (5000, 2, 50), (2000, 4, 2000)])
def test_unique_rows_of_floats_is_np_unique_axis0(m, k, levels):
    """Float rows (the model's element attributes: part, k, ρc, t, area, tensor): ranked column by column, then
    the integer path; values, inverse and counts exactly np.unique(axis=0)'s, -0.0 equal to 0.0 as numpy has it."""
    rng = np.random.default_rng(m * k + levels)
    values = np.concatenate([rng.normal(size=levels - 1) * 10.0 ** rng.integers(-8, 8, levels - 1), [0.0]])
    a = values[rng.integers(0, levels, (m, k))]
    a[rng.random((m, k)) < 0.05] = -0.0
    for inverse, counts in itertools.product([False, True], repeat=2):
        got = unique_rows(a, return_inverse=inverse, return_counts=counts)
        want = np.unique(a, axis=0, return_inverse=inverse, return_counts=counts)
        got = got if isinstance(got, tuple) else (got,)
        want = want if isinstance(want, tuple) else (want,)
        assert len(got) == len(want)
        for g, w in zip(got, want):  # -0.0 == 0.0: the rows compare equal (np.array_equal), as in numpy's own test
            assert g.dtype == w.dtype and g.shape == w.shape and np.array_equal(g, w)
    nan = a.copy()
    nan[0, 0] = np.nan  # NaN goes to numpy as it is
    for g, w in zip(unique_rows(nan, return_inverse=True), np.unique(nan, axis=0, return_inverse=True)):
        assert g.shape == w.shape and np.array_equal(g, w, equal_nan=True)
