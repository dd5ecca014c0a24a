"""Compiled book-keeping kernels of the ray tracer against straightforward scipy/numpy formulations of the same
operations (the physics of the bounce loop is checked end to end in test_radiation_exchange.py)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from numba import njit

from fem2tmm.radiation._tracer_kernels import cos_sin_turn, random_state, uniform
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
    # the runs lie in order with gaps between them (each batch writes at its first ray)
    lengths = np.array(lengths)
    gaps = rng.integers(0, 4, lengths.size)
    starts = np.cumsum(lengths + gaps) - lengths
    buf_c, buf_v = np.full(starts[-1] + lengths[-1], -7, np.int32), np.full(starts[-1] + lengths[-1], np.nan)
    for k in range(lengths.size):
        buf_c[starts[k]:starts[k] + lengths[k]] = cols[lengths[:k].sum():lengths[:k + 1].sum()]
        buf_v[starts[k]:starts[k] + lengths[k]] = vals[lengths[:k].sum():lengths[:k + 1].sum()]
    indptr, c, data = runs_to_csr(np.array(groups), lengths, starts, buf_c, buf_v, g, np.empty(0, np.int32))
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
        cols, counts = np.empty(r, np.int32), np.empty(r)
        groups, lengths = _batch_tally(grp, ends, side_col, ncol, np.ones(0) if w is None else w, cols, counts)
        cols, counts = cols[:lengths.sum()], counts[:lengths.sum()]
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
    # closure: every row of F sums to 1 - blocked, with space REFs >= 0 and exactly 0 where no ray escaped (the
    # line-sum error itself, before closure, is checked against a plain formulation in test_smoothing_fast.py)
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
    space_raw, space = raw[:, g].toarray().ravel(), F[:, g].toarray().ravel()
    assert np.all(space >= 0) and np.all(space[space_raw == 0] == 0) and np.any(space > 0)


def test_first_hit_numbers_are_stratified_within_each_group_and_side():
    # per (group, side) pair with m hits: sorted u x m - rank is one phase in [0, 1) (systematic sampling); misses
    # (side -1) get 0
    rng = np.random.default_rng(6)
    major = np.sort(rng.integers(0, 200, 20_000))
    side = rng.integers(-1, 7, major.size)
    u = _first_hit_numbers(side, major, random_state(np.random.default_rng(7)))
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


@njit
def _draws(st, n):
    out = np.empty(n)
    for k in range(n):
        out[k] = uniform(st)
    return out


def _splitmix64(state: int, n: int) -> list[int]:
    """Plain-Python SplitMix64 (Steele, Lea & Flood 2014; Vigna's reference C code), the 64-bit outputs."""
    out, m = [], (1 << 64) - 1
    for _ in range(n):
        state = (state + 0x9E3779B97F4A7C15) & m
        z = state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & m
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & m
        out.append(z ^ (z >> 31))
    return out


def test_kernel_generator_is_splitmix64_and_uniform():
    # the compiled generator against an independent plain-Python SplitMix64 (the top 53 bits of each output / 2^53),
    # then uniformity: a Kolmogorov-Smirnov test on 10^6 draws (p > 1e-3 at a fixed seed) and the state advanced
    seed = 1234567
    st = np.array([seed], np.uint64)
    got = _draws(st, 1000)
    ref = np.array([(z >> 11) / 2.0**53 for z in _splitmix64(seed, 1000)])
    np.testing.assert_array_equal(got, ref)
    assert int(st[0]) == (seed + 1000 * 0x9E3779B97F4A7C15) % 2**64
    from scipy.stats import kstest

    st = random_state(np.random.default_rng(11))
    x = _draws(st, 1_000_000)
    assert 0.0 <= x.min() and x.max() < 1.0
    assert kstest(x, "uniform").pvalue > 1e-3


@njit
def _turns(v):
    c, s = np.empty(v.size), np.empty(v.size)
    for k in range(v.size):
        c[k], s[k] = cos_sin_turn(v[k])
    return c, s


def test_cos_sin_turn_matches_libm():
    # the polynomial (cos 2πv, sin 2πv) of the cosine-law directions against numpy's libm on 10^6 points and the
    # octant boundaries: within 2e-15 (the rounding of 2πv alone moves libm's result by up to ~1e-15)
    v = np.concatenate([np.random.default_rng(12).random(1_000_000), np.arange(9) / 8, [np.nextafter(1.0, 0.0)]])
    v = v[v < 1.0]
    c, s = _turns(v)
    np.testing.assert_allclose(c, np.cos(2 * np.pi * v), rtol=0, atol=2e-15)
    np.testing.assert_allclose(s, np.sin(2 * np.pi * v), rtol=0, atol=2e-15)
