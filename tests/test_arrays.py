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
