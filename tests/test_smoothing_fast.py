"""The compiled linear reciprocity + closure of :func:`smooth` (weights and transposition, then a counting and a
writing merge that produce F and GR with their space column directly) against a plain scipy/numpy formulation of
the same mathematics, on random cases with the awkward rows: empty rows, groups that traced no ray, εA = 0,
rows whose only entry is the space column, explicit zeros, pairs seen from one side only."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fem2tmm.radiation.smoothing import enforce_reciprocity, scale_rows, smooth


def _random_case(seed: int, g: int, density: float, one_sided: bool = False, all_open: bool = False):
    """Raw REFs F_raw (g, g + 1) (last column space), εA (g,), rays (g,), blocked (g,); with ``all_open`` every
    group traced rays and lost 0.4 of them to space (no row needs the closure scaling)."""
    rng = np.random.default_rng(seed)
    raw = sp.random(g, g + 1, density=density, random_state=rng, format="coo")
    r, c, d = raw.row, raw.col, 0.05 * raw.data
    if one_sided:  # only (i, j) with i <= j in the g x g block: never both (i, j) and (j, i)
        keep = (c >= r) | (c == g)
        r, c, d = r[keep], c[keep], d[keep]
    d[rng.random(d.size) < 0.05] = 0.0  # explicit zeros (kept by the csr conversion below)
    F_raw = sp.csr_matrix((d, (r, c)), shape=(g, g + 1))
    F_raw = F_raw.tolil()
    for i in rng.choice(g, size=max(1, g // 8), replace=False):  # rows with only their space entry
        F_raw[i, :g] = 0.0
        F_raw[i, g] = 0.4
    for i in rng.choice(g, size=max(1, g // 10), replace=False):  # empty rows
        F_raw[i, :] = 0.0
    F_raw = F_raw.tocsr()
    ea = rng.random(g) + 0.1
    ea[rng.random(g) < 0.1] = 0.0
    rays = rng.integers(1, 60, g).astype(float)
    rays[rng.random(g) < 0.15] = 0.0
    blocked = 0.1 * rng.random(g)
    if all_open:
        F_raw = F_raw.tolil()
        F_raw[:, g] = 0.4
        F_raw = F_raw.tocsr()
        rays[:] = 50.0
    return F_raw, ea, rays, blocked


def _reference(F_raw, ea, rays, blocked, exponent=0.4):
    """(F, GR, lse) dense before the closure scaling: GR = M + Mᵀ, M_ij = w_ij εA_i F_raw_ij,
    w_ij = ½(1 + sign(X)|X|^exponent), X = (a_j - a_i)/(a_j + a_i), a = εA/max(n, 1) (X = ∓1 when only j / only i
    traced rays, 0 when neither); LSE = 1 - blocked - Σ_j GR_ij/εA - space_raw, F = GR/εA with space column
    space_raw + LSE (rows with εA = 0 are 0), GR space column εA (space_raw + LSE)."""
    g = F_raw.shape[0]
    A = sp.csr_matrix(F_raw)[:, :g].tocoo()
    i, j = A.row, A.col
    a = ea / np.maximum(rays, 1)
    ti, tj = rays[i] > 0, rays[j] > 0
    den = a[i] + a[j]
    with np.errstate(divide="ignore", invalid="ignore"):
        X = np.where(den > 0, (a[j] - a[i]) / den, 0.0)
    X = np.where(ti & tj, X, np.where(tj, -1.0, np.where(ti, 1.0, 0.0)))
    w = np.where(X != 0, 0.5 + 0.5 * np.sign(X) * np.abs(X) ** exponent, 0.5)
    M = sp.coo_matrix((ea[i] * A.data * w, (i, j)), shape=(g, g)).tocsr()
    GR = (M + M.T).toarray()
    space_raw = sp.csr_matrix(F_raw)[:, g].toarray().ravel()
    pos = ea > 0
    inv = np.where(pos, 1.0 / np.where(pos, ea, 1.0), 0.0)
    lse = np.where(pos, 1.0 - blocked - GR.sum(axis=1) * inv - space_raw, 0.0)
    space = np.where(pos, space_raw + lse, 0.0)
    F = np.hstack([GR * inv[:, None], space[:, None]])
    return F, np.hstack([GR, (ea * space)[:, None]]), lse


def _assert_canonical(A, g):
    assert A.shape == (g, g + 1)
    assert A.indices.dtype == np.int32 and A.indptr.dtype == np.int32
    assert A.has_canonical_format  # sorted columns, no duplicates
    assert np.all(A.data != 0.0)  # explicit zeros dropped


@pytest.mark.parametrize("seed,g,density,one_sided,all_open", [
    (0, 1, 0.5, False, False), (1, 7, 0.4, False, False), (2, 40, 0.15, False, False),
    (3, 120, 0.05, False, False), (4, 90, 0.2, True, False), (5, 60, 0.9, False, False), (6, 30, 0.0, False, False),
    (11, 50, 0.3, False, True),
])
def test_smooth_matches_the_plain_formulation(seed, g, density, one_sided, all_open):
    F_raw, ea, rays, blocked = _random_case(seed, g, density, one_sided, all_open)
    F, GR, lse = smooth(F_raw, ea, rays, blocked)
    F_ref, GR_ref, lse_ref = _reference(F_raw, ea, rays, blocked)
    for got in (F, GR):
        _assert_canonical(got, g)
        # the space column is each row's last stored entry
        has_space = got.toarray()[:, g] != 0
        assert np.all(got.indices[got.indptr[1:][has_space] - 1] == g)
    np.testing.assert_allclose(lse, lse_ref, rtol=0, atol=1e-14)
    assert np.all(lse[ea == 0] == 0) and F[ea == 0].nnz == 0
    G = GR[:, :g].toarray()
    assert np.array_equal(G, G.T)  # symmetric to the last bit
    # the closure only scales the reciprocal block symmetrically: GR_ij = d_i GR_ref_ij d_j, same pattern
    G_ref = GR_ref[:, :g]
    np.testing.assert_array_equal(G != 0, G_ref != 0)
    i, j = np.nonzero(np.triu(G_ref))
    if i.size:
        E = np.zeros((i.size, g))
        E[np.arange(i.size), i] += 1
        E[np.arange(i.size), j] += 1
        logr = np.log(G[i, j] / G_ref[i, j])
        y = np.linalg.lstsq(E, logr, rcond=None)[0]
        np.testing.assert_allclose(E @ y, logr, rtol=0, atol=1e-12)
    # space REFs >= 0, exactly 0 for the rows that traced rays of which none escaped; F = GR/εA, rows with space
    # close exactly; rows that close through space and needed no scaling are the plain formulation's
    space_raw = F_raw.toarray()[:, g]
    Fd = F.toarray()
    closed = (rays > 0) & (space_raw == 0) & (ea > 0)
    assert np.all(Fd[:, g] >= 0) and np.all(Fd[closed, g] == 0)
    pos = ea > 0
    np.testing.assert_allclose(GR.toarray()[pos, :g], ea[pos, None] * Fd[pos, :g], rtol=1e-13, atol=1e-300)
    open_ = pos & (Fd[:, g] > 0)
    np.testing.assert_allclose(Fd[open_].sum(axis=1), 1 - blocked[open_], rtol=0, atol=1e-13)
    if all_open:
        assert not closed.any() and np.all(F_ref[pos, g] >= 0)
        np.testing.assert_allclose(Fd, F_ref, rtol=1e-12, atol=1e-15)


def test_smooth_closes_rows_and_gr_is_diag_ea_times_f():
    F_raw, ea, rays, blocked = _random_case(7, 80, 0.1)
    F, GR, lse = smooth(F_raw, ea, rays, blocked)
    pos = ea > 0
    has_space = F.toarray()[:, -1] > 0  # rows of closed groups: tests/test_closure.py (random rows are infeasible)
    np.testing.assert_allclose(np.asarray(F.sum(axis=1)).ravel()[pos & has_space], 1 - blocked[pos & has_space],
                               atol=1e-13)
    # GR = diag(εA) F on the rows with εA > 0 (an εA = 0 row of F is 0, its GR row holds the M_ji of the others)
    np.testing.assert_allclose(GR.toarray()[pos], (ea[:, None] * F.toarray())[pos], rtol=1e-13, atol=1e-300)


def test_smooth_does_not_depend_on_the_thread_count():
    F_raw, ea, rays, blocked = _random_case(8, 500, 0.04)
    base = smooth(F_raw, ea, rays, blocked, threads=1)
    for threads in (2, 3, 8):
        got = smooth(F_raw, ea, rays, blocked, threads=threads)
        for A, B in zip(base[:2], got[:2]):
            assert np.array_equal(A.indptr, B.indptr) and np.array_equal(A.indices, B.indices)
            assert np.array_equal(A.data.view(np.uint64), B.data.view(np.uint64))
        assert np.array_equal(base[2].view(np.uint64), got[2].view(np.uint64))


def test_smooth_block_is_enforce_reciprocity_of_the_scaled_raw_exchange():
    # the same kernels without closure: bit for bit the g x g block of smooth's GR (all rows open, so the closure
    # scales nothing)
    F_raw, ea, rays, blocked = _random_case(9, 70, 0.2, all_open=True)
    g = len(ea)
    _, GR, _ = smooth(F_raw, ea, rays, blocked)
    R = enforce_reciprocity(scale_rows(F_raw[:, :g], ea), ea, rays, threads=3)
    B = GR[:, :g].tocsr()
    B.eliminate_zeros()
    assert R.shape == (g, g) and R.has_sorted_indices
    assert np.array_equal(R.indptr, B.indptr) and np.array_equal(R.indices, B.indices)
    assert np.array_equal(R.data, B.data)


def test_smooth_sums_duplicates_and_handles_no_groups():
    F_raw, ea, rays, blocked = _random_case(10, 25, 0.3)
    # every entry stored twice as two halves (exact): summed first, so the result is the same to the bit
    dup = sp.csr_matrix((np.repeat(0.5 * F_raw.data, 2), np.repeat(F_raw.indices, 2), 2 * F_raw.indptr),
                        shape=F_raw.shape)
    assert not dup.has_canonical_format
    a, b = smooth(F_raw, ea, rays, blocked), smooth(dup, ea, rays, blocked)
    for A, B in zip(a[:2], b[:2]):
        assert np.array_equal(A.indices, B.indices) and np.array_equal(A.data, B.data)
    assert np.array_equal(a[2], b[2])
    F0, GR0, lse0 = smooth(sp.csr_matrix((0, 1)), np.zeros(0), np.zeros(0), np.zeros(0))
    assert F0.shape == GR0.shape == (0, 1) and F0.nnz == GR0.nnz == 0 and lse0.shape == (0,)


def test_fractional_variance_goes_through_the_same_closure():
    F_raw, ea, rays, blocked = _random_case(11, 50, 0.2)
    with np.errstate(all="ignore"):
        F, GR, lse = smooth(F_raw, ea, rays, blocked, method="fractional_variance")
    g = len(ea)
    pos = ea > 0
    _assert_canonical(F, g)
    _assert_canonical(GR, g)
    np.testing.assert_allclose(np.asarray(F.sum(axis=1)).ravel()[pos], 1 - blocked[pos], atol=1e-13)
    # GR = diag(εA) F on the rows with εA > 0 (an εA = 0 row of F is 0, its GR row holds the M_ji of the others)
    np.testing.assert_allclose(GR.toarray()[pos], (ea[:, None] * F.toarray())[pos], rtol=1e-13, atol=1e-300)
    G = GR[:, :g].toarray()
    assert np.array_equal(G, G.T)
