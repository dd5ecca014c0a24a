"""Compiled book-keeping kernels of the ray tracer against straightforward scipy/numpy formulations of the same
operations (the physics of the bounce loop is checked end to end in test_radiation_exchange.py)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from fem2tmm.radiation.sampling import ScrambledHalton
from fem2tmm.radiation.smoothing import enforce_reciprocity, smooth
from fem2tmm.radiation.tracer import _batch_tally, _first_hit_numbers, runs_to_csr


def test_runs_to_csr_merges_the_runs_of_rows_that_straddle_batches():
    # batch tallies: each batch gives sorted, distinct columns per row; consecutive batches share the row between
    # them, and a long row may span several batches
    rng = np.random.default_rng(0)
    g, ncol = 50, 53
    groups, lengths, cols, vals = [], [], [], []
    row_runs = [(r, 1) for r in range(0, 20)] + [(20, 3)] + [(r, 2 if r % 7 == 0 else 1) for r in range(23, 50, 2)]
    for row, n_runs in row_runs:  # rows 21, 22 and the even rows above 22 stay empty
        for _ in range(n_runs):
            c = np.unique(rng.integers(0, ncol, rng.integers(1, 30)))
            groups.append(row)
            lengths.append(c.size)
            cols.append(c)
            vals.append(rng.random(c.size))
    rows = np.repeat(groups, lengths)
    cols, vals = np.concatenate(cols).astype(np.int32), np.concatenate(vals)
    ref = sp.coo_matrix((vals, (rows, cols)), shape=(g, ncol)).tocsr()  # scipy sums duplicates
    indptr, c, data = runs_to_csr(np.array(groups), np.array(lengths), cols.copy(), vals.copy(), g,
                                  np.empty(0, np.int32))
    got = sp.csr_matrix((data, c, indptr), shape=(g, ncol))
    assert got.has_sorted_indices
    np.testing.assert_allclose(got.toarray(), ref.toarray(), rtol=1e-15)
    assert got.nnz == ref.nnz


def test_batch_tally_matches_numpy_unique():
    rng = np.random.default_rng(1)
    r, f, g = 5000, 40, 30
    grp = np.sort(rng.integers(3, 3 + 25, r))
    ends = rng.integers(-3, 2 * f, r)  # sides, or space (-1) / blocked (-2) / capped (-3)
    side_col = rng.integers(0, g + 2, 2 * f)  # a group, or the "blocked" column g + 1
    ncol = g + 3
    dest = np.where(ends >= 0, side_col[np.maximum(ends, 0)], g - 1 - ends)
    ref_keys, inv = np.unique(grp * ncol + dest, return_inverse=True)
    for w in (None, rng.random(r)):
        groups, lengths, cols, counts = _batch_tally(grp, ends, side_col, ncol, np.ones(0) if w is None else w,
                                                     np.empty(0, np.int32))
        np.testing.assert_array_equal(groups, np.unique(grp))
        np.testing.assert_array_equal(np.repeat(groups, lengths) * ncol + cols, ref_keys)
        np.testing.assert_allclose(counts, np.bincount(inv.ravel(), weights=w, minlength=ref_keys.size), rtol=1e-13)


def test_linear_reciprocity_against_its_formula():
    # GR = M + Mᵀ, M_ij = w_ij S_ij, w_ij = ½(1 + sign(X)|X|^0.4), X = (a_j - a_i)/(a_j + a_i), a = εA/n (thesis
    # eq. 2.45-2.46); a group that traced no ray has X = ∓1 (its estimates get no weight)
    rng = np.random.default_rng(2)
    g = 120
    S = sp.random(g, g, density=0.08, random_state=3, format="csr")
    ea = rng.random(g) + 0.1
    n = rng.integers(0, 40, g).astype(float)
    n[:5] = 0
    a = ea / np.maximum(n, 1)
    rows, cols = S.nonzero()
    ai, aj = a[rows], a[cols]
    X = (aj - ai) / (aj + ai)
    X = np.where((n[rows] == 0) & (n[cols] > 0), -1.0, np.where((n[cols] == 0) & (n[rows] > 0), 1.0, X))
    X = np.where((n[rows] == 0) & (n[cols] == 0), 0.0, X)
    M = sp.csr_matrix((np.asarray(S[rows, cols]).ravel() * (0.5 + 0.5 * np.sign(X) * np.abs(X) ** 0.4),
                       (rows, cols)), shape=(g, g))
    ref = (M + M.T).toarray()
    GR = enforce_reciprocity(S, ea, n).toarray()
    np.testing.assert_allclose(GR, ref, rtol=1e-13, atol=1e-300)
    assert np.array_equal(GR, GR.T)  # symmetric to the last bit


def test_smooth_closes_rows_through_space():
    # closure: every row of F sums to 1 - blocked; the line-sum error is what the space column absorbed
    rng = np.random.default_rng(4)
    g = 60
    raw = sp.random(g, g + 1, density=0.2, random_state=5, format="csr")
    raw = sp.csr_matrix(raw.multiply(1.0 / (1.2 * np.asarray(raw.sum(axis=1)).ravel()[:, None] + 1e-300)))
    ea, n = rng.random(g) + 0.1, np.full(g, 100.0)
    blocked = rng.random(g) * 0.1
    F, GR, lse = smooth(raw, ea, n, blocked)
    np.testing.assert_allclose(np.asarray(F.sum(axis=1)).ravel(), 1 - blocked, atol=1e-13)
    np.testing.assert_allclose(GR.toarray(), ea[:, None] * F.toarray(), rtol=1e-12, atol=1e-300)
    assert np.array_equal(GR[:, :g].toarray(), GR[:, :g].toarray().T)
    space_raw = raw[:, g].toarray().ravel()
    np.testing.assert_allclose(F[:, g].toarray().ravel(), space_raw + lse, atol=1e-15)


def test_first_hit_numbers_are_stratified_within_each_group_and_side():
    # per (group, side) pair with m hits: sorted u x m - rank is one phase in [0, 1) (systematic sampling); misses
    # (side -1) get 0
    rng = np.random.default_rng(6)
    major = np.sort(rng.integers(0, 200, 20_000))
    side = rng.integers(-1, 7, major.size)
    u = _first_hit_numbers(side, major, 7, np.random.default_rng(7))
    assert np.all(u[side < 0] == 0.0)
    hit = side >= 0
    keys = major[hit] * 7 + side[hit]
    uh = u[hit]
    assert uh.min() >= 0 and uh.max() < 1
    for k in np.unique(keys)[:300]:
        v = np.sort(uh[keys == k]) * np.count_nonzero(keys == k)
        phase = v - np.arange(v.size)
        assert np.ptp(phase) < 1e-12 and 0 <= phase[0] < 1


def test_halton_runs_of_consecutive_indices_equal_single_evaluations():
    # the compiled generator steps runs of consecutive indices; every point must equal its own evaluation
    h = ScrambledHalton(np.random.default_rng(8))
    rng = np.random.default_rng(9)
    idx = np.concatenate([np.arange(1000) + 1023, np.sort(rng.integers(0, 10**9, 500)), np.arange(600) + 59048])
    pts = h.points(idx)
    one = np.vstack([h.points(np.array([i])) for i in idx])
    np.testing.assert_allclose(pts, one, rtol=0, atol=2e-16)
