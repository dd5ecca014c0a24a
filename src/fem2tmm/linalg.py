"""Sparse direct solves shared by the stages, and the BLAS thread limit (:func:`blas_threads`).

Thermal conduction matrices (plus radiative linearisations) are symmetric, or diagonally dominant
M-matrices, so LU without pivoting on a minimum-degree ordering of A + Aᵀ is stable and, on 2-D/3-D
meshes, faster and leaner than SuperLU's default column ordering (measurements: docs/design-notes.md, linalg.py).
"""

from __future__ import annotations

import contextlib

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components


def factorize(A) -> "spla.SuperLU":
    """LU factorisation of a sparse, structurally symmetric, diagonally dominant matrix (n, n)."""
    A = sp.csc_matrix(A)
    return spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options=dict(SymmetricMode=True))


def solve(A, b: np.ndarray) -> np.ndarray:
    """x = A⁻¹ b for a sparse (see :func:`factorize`) or dense A; b (n,) or (n, r)."""
    if sp.issparse(A):
        return factorize(A).solve(np.asarray(b, dtype=float))
    return np.linalg.solve(np.asarray(A, float), b)


#: a residual within this many machine epsilons of its terms' magnitudes is at round-off
ROUNDOFF_ULPS = 32.0


def roundoff(K, T: np.ndarray) -> float:
    """Round-off level (W) of a conduction residual K T summed over the nodes: ``ROUNDOFF_ULPS`` machine epsilons of
    Σ_ij |K_ij| |T_j|.  K (n, n) sparse or dense, W/K; T (n,) K."""
    A = abs(sp.csr_matrix(K)) if sp.issparse(K) else np.abs(np.asarray(K, float))
    return ROUNDOFF_ULPS * float(np.finfo(float).eps) * float(np.sum(A @ np.abs(np.asarray(T, float))))


#: eigenvalue ratio of a Gram matrix below which rows are taken as dependent (singular-value ratio 1e-6)
RANK_RTOL = 1e-12


def dependent_rows(S: sp.csr_matrix) -> list[np.ndarray]:
    """Groups of rows of ``S`` that are linearly dependent (empty list when S has full row rank).

    Works per connected block of the Gram matrix S Sᵀ (rows sharing a column), dense only on those blocks.
    """
    G = (S @ S.T).tocsr()
    n_blocks, block = connected_components(G, directed=False)
    groups = []
    order = np.argsort(block, kind="stable")
    bounds = np.searchsorted(block[order], np.arange(n_blocks + 1))
    for b in range(n_blocks):
        rows = order[bounds[b]:bounds[b + 1]]
        g = G[rows][:, rows].toarray()
        w, v = np.linalg.eigh(g)
        null = w <= RANK_RTOL * max(w[-1], np.finfo(float).tiny)
        if np.any(null):
            vec = np.abs(v[:, null]).max(axis=1)
            groups.append(rows[vec > 1e-8 * vec.max()])
    return groups


def blas_threads(n: int | None):
    """Context manager limiting BLAS to ``n`` threads (no-op for None or without threadpoolctl)."""
    if n is None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # threadpoolctl comes with scikit-learn; without it, leave BLAS alone
        return contextlib.nullcontext()
    return threadpool_limits(limits=n, user_api="blas")
