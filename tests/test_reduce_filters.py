"""Capacitance of the super nodes and TMRT link filters (reduce/capacitance.py, reduce/filters.py)."""

from __future__ import annotations

import numpy as np
import pytest

from fem2tmm.errors import Fem2TmmError
from fem2tmm.fem.assembly import scatter_shares
from fem2tmm.reduce import (build_supernodes, equivalent_capacitance, filter_links, negative_links,
                            reduce_conduction, supernode_capacitance)
from test_reduce import PERM, beam, dense_inverse, make

# ----------------------------------------------------------------------------------------- capacitance


@pytest.mark.parametrize("kind", ["tet", "mixed"])
def test_capacitance_is_conserved_and_equivalent_capacitance_is_Y_c(kind):
    pr, labels = make(kind, seed=4)
    rng = np.random.default_rng(3)
    rho_c = rng.uniform(1e6, 3e6, pr.m)  # J/(m³ K), different per element
    cap = pr.shares * rho_c[:, None]  # J/K per element node
    c = scatter_shares(np.maximum(pr.cells, 0), cap, pr.n)  # padded shares are 0
    # A from volumes (steady-state weights), capacitance from ρ·c·volume: the two choices differ
    sn = build_supernodes(pr.n, pr.cells, pr.shares, labels, kept=[2, 9])
    red = reduce_conduction(pr.coo, sn, labels)
    C_sn = supernode_capacitance(sn, cap, labels)
    C_eq = equivalent_capacitance(red, c)
    total = cap.sum()
    # both conserve the total exactly (round-off of a sum: 1e-12 relative)
    assert abs(C_sn.sum() - total) < 1e-12 * total
    assert abs(C_eq.sum() - total) < 1e-12 * total
    # TMRT equivalent capacitance Y C Yᵀ 1 made diagonal by row sums, from the dense inverse of M
    _, Y, _ = dense_inverse(pr, sn)
    C = np.diag(c)
    assert np.abs(C_eq - Y @ C @ Y.T @ np.ones(sn.n_sn)).max() < 1e-9 * total
    assert np.abs(C_eq - C_sn).max() > 1e-3 * total / sn.n_sn  # really a different distribution here
    # with A built from the same capacitance shares, c = Aᵀ C_SN and Y Aᵀ = I give C_eq = C_SN exactly
    sn_c = build_supernodes(pr.n, pr.cells, cap, labels, kept=[2, 9])
    red_c = reduce_conduction(pr.coo, sn_c, labels)
    assert np.abs(equivalent_capacitance(red_c, c) - supernode_capacitance(sn_c, cap, labels)).max() < 1e-10 * total
    assert np.array_equal(sn_c.capacity, supernode_capacitance(sn_c, cap, labels))


def test_equivalent_capacitance_rejects_bad_input():
    coo, sn, labels = beam(10)
    red = reduce_conduction(coo, sn, labels)
    with pytest.raises(Fem2TmmError, match="expected \\(11,\\)"):
        equivalent_capacitance(red, np.ones(10))
    with pytest.raises(Fem2TmmError, match="negative or not finite at DOFs 3"):
        equivalent_capacitance(red, np.where(np.arange(11) == 3, -1.0, 1.0))


# --------------------------------------------------------------------------------------------- filters


def brute_filter(K, t):
    """Reference: loop over pairs, remove |K_ij| < t·min(K_ii, K_jj), give it back to both diagonals."""
    out = K.copy()
    n = len(K)
    removed, cond = 0, 0.0
    for i in range(n):
        for j in range(i + 1, n):
            if K[i, j] != 0 and abs(K[i, j]) < t * min(abs(K[i, i]), abs(K[j, j])):
                out[i, j] = out[j, i] = 0.0
                out[i, i] += K[i, j]
                out[j, j] += K[i, j]
                removed += 1
                cond += abs(K[i, j])
    return out, removed, cond


def random_network(n, seed):
    rng = np.random.default_rng(seed)
    G = np.triu(rng.lognormal(0, 2, (n, n)) * (rng.random((n, n)) < 0.6), 1)
    G[np.triu(rng.random((n, n)) < 0.05, 1)] *= -0.1  # a few negative links
    G = G + G.T
    K = -G
    np.fill_diagonal(K, G.sum(1))
    return K


@pytest.mark.parametrize("t", [0.0, 0.01, 0.1, 0.3])
def test_filter_matches_brute_force_and_keeps_symmetry_and_row_sums(t):
    K = random_network(30, seed=5)
    out, rep = filter_links(K, t)
    ref, removed, cond = brute_filter(K, t)
    assert np.allclose(out, ref, rtol=0, atol=1e-12 * np.abs(K).max())
    assert rep["links_removed"] == removed
    assert rep["conductance_removed_W_per_K"] == pytest.approx(cond, rel=1e-12)
    assert np.array_equal(out, out.T)
    assert np.abs(out.sum(1)).max() < 1e-12 * np.abs(np.diag(K)).max()
    assert rep["max_relative_removed"] < t or removed == 0
    if t == 0.0:
        assert removed == 0 and np.array_equal(out, K)


def test_filter_on_the_thesis_beam_and_negative_links():
    """Beam limit eq. 4.15 (kS/L)[[7,-9,3,-1],[-9,15,-9,3],[3,-9,15,-9],[-1,3,-9,7]] in thesis order."""
    kS, L = 2.0, 1.0
    coo, sn, labels = beam(1000, L, kS)
    K = reduce_conduction(coo, sn, labels).K
    pairs, gl = negative_links(K)
    # the two +3 entries: (node 1, SN b) and (SN a, node n), GL ≈ −3 kS/L (1e-3: the n_e = 1000 mesh)
    inv = np.argsort(PERM)
    got = sorted(tuple(sorted(inv[p])) for p in pairs)
    assert got == [(0, 2), (1, 3)]
    assert np.allclose(gl, -3 * kS / L, rtol=1e-3)
    # threshold 0.15 removes only the (node 1, node n) link: |−1| / min(7, 7) = 0.143 < 0.15 while the
    # next weakest, 3 / min(7, 15) = 0.43, stays
    out, rep = filter_links(K, 0.15)
    assert rep["links_removed"] == 1 and rep["links_kept"] == 5
    assert rep["conductance_removed_W_per_K"] == pytest.approx(kS / L, rel=1e-3)
    assert rep["max_relative_removed"] == pytest.approx(1 / 7, rel=1e-3)
    assert out[2, 3] == 0 and rep["parts_after"] == 1
    assert K[2, 2] - out[2, 2] == pytest.approx(kS / L, rel=1e-3)  # 7 → 6 kS/L: conductance back on the diagonal
    with pytest.raises(Fem2TmmError, match="threshold"):
        filter_links(K, 1.5)
