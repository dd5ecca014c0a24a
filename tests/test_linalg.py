"""linalg.factorize: every backend solves the same symmetric systems to round-off, and a singular or indefinite
matrix is refused (not silently perturbed).

Reference: a dense LAPACK solve (numpy.linalg.solve) of the same matrix; the tolerance is the backward-stable
bound of a direct solve, ‖x − x_ref‖/‖x_ref‖ ≤ c·κ·ε with κ ≈ 10³ for these plates (c·κ·ε ≈ 1e-11 taken).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from fem2tmm import linalg


def _plate(n: int, h: float = 0.0):
    """5-point conduction Laplacian of an n x n grid (W/K), one corner held (removed), plus diag(h)."""
    e = np.ones(n)
    T = sp.diags([-e[:-1], 2 * e, -e[:-1]], [-1, 0, 1])
    K = (sp.kron(sp.eye(n), T) + sp.kron(T, sp.eye(n))).tocsr()
    K = K - sp.diags(np.asarray(K.sum(axis=1)).ravel())  # zero row sums (a conduction matrix)
    K = K + sp.diags(np.full(n * n, h))
    return sp.csr_matrix(K[1:][:, 1:])


def _backends():
    out = ["scipy"]
    for name in ("pardiso", "cholmod"):
        if linalg._installed(name):
            out.append(name)
    return out


@pytest.mark.parametrize("name", _backends())
@pytest.mark.parametrize("kind", ["spd", "symmetric"])
def test_backends_agree_with_dense(monkeypatch, name, kind):
    monkeypatch.setattr(linalg, "SOLVER", name)
    monkeypatch.setattr(linalg, "FAST_MIN", 0)
    K = _plate(30, h=1e-3)
    rng = np.random.default_rng(1)
    b = rng.standard_normal((K.shape[0], 3))
    ref = np.linalg.solve(K.toarray(), b)
    f = linalg.factorize(K, kind)
    x = f.solve(b)
    assert np.linalg.norm(x - ref) / np.linalg.norm(ref) < 1e-11
    x1 = f.solve(b[:, 0])
    assert x1.shape == (K.shape[0],)
    assert np.linalg.norm(x1 - ref[:, 0]) / np.linalg.norm(ref[:, 0]) < 1e-11
    if name != "cholmod" or kind == "spd":
        assert linalg.backend(K.shape[0], kind) == name


@pytest.mark.parametrize("name", _backends())
def test_saddle_and_singular(monkeypatch, name):
    """A saddle matrix [[K, aᵀ], [a, 0]] (symmetric indefinite) is solved; an exactly singular matrix raises
    (SuperLU decides after PARDISO's failure or perturbed pivots), it is not answered with a perturbed solution."""
    monkeypatch.setattr(linalg, "SOLVER", name)
    monkeypatch.setattr(linalg, "FAST_MIN", 0)
    n = 20
    e = np.ones(n * n)
    T = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    K = (sp.kron(sp.eye(n), T) + sp.kron(T, sp.eye(n))).tocsr()
    K = sp.csr_matrix(K - sp.diags(np.asarray(K.sum(axis=1)).ravel()))  # singular: floating
    M = sp.bmat([[K, e[:, None] / e.size], [e[None, :] / e.size, None]], format="csr")
    rng = np.random.default_rng(2)
    b = rng.standard_normal(M.shape[0])
    ref = np.linalg.solve(M.toarray(), b)
    x = linalg.factorize(M, "symmetric").solve(b)
    assert np.linalg.norm(x - ref) / np.linalg.norm(ref) < 1e-10
    S = _plate(20, h=1e-3).tolil()
    S[5, :] = 0.0
    S[:, 5] = 0.0  # an unknown no equation holds: exactly singular
    for kind in ("spd", "symmetric"):
        with pytest.raises(RuntimeError):  # SuperLU: "Factor is exactly singular"
            linalg.factorize(S.tocsr(), kind)


def test_small_matrices_stay_with_scipy(monkeypatch):
    monkeypatch.setattr(linalg, "SOLVER", "auto")
    assert linalg.backend(linalg.FAST_MIN - 1, "spd") == "scipy"
    assert linalg.backend(10**6, "general") == "scipy"  # unsymmetric: SuperLU on the symmetric ordering


def test_a_pinned_blas_count_holds_against_nested_limits():
    """linalg.pinned_blas: while a load-case set holds BLAS at one thread, a nested blas_threads(n) of one case must
    not change the count another case's factorisation runs with (threadpoolctl limits are process-wide; OpenBLAS'
    Cholesky gives other bits on 1 and 2 threads, so a change in the middle made the sets' networks depend on timing)."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from fem2tmm.linalg import blas_threads, pinned_blas

    def blas_now():
        return {i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas"}

    before = blas_now()
    with pinned_blas(1):
        assert blas_now() == {1}
        with blas_threads(2):
            assert blas_now() == {1}  # inert inside the pin
        assert blas_now() == {1}
    assert blas_now() == before
    with blas_threads(1):  # outside a pin it limits as before
        assert blas_now() == {1}
    assert blas_now() == before


def test_a_saddle_with_a_definite_block_is_solved_through_its_schur_complement():
    """linalg.saddle_factor: [[Kd, Aᵀ], [A, 0]] with Kd = a floating plate's conduction plus a small positive
    diagonal (emission) and A the means of 12 strips of it (a recovery's constraints) against a dense LAPACK solve:
    the block elimination (Kd's factorisation and the dense Schur complement A Kd⁻¹ Aᵀ) and the whole-matrix path
    agree with it to the backward-stable bound above; a Kd without the diagonal (floating: singular) is refused by the
    elimination's Cholesky and taken by the whole-matrix path, which the constraints make regular."""
    n = 24
    T = sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    K = (sp.kron(sp.eye(n), T) + sp.kron(T, sp.eye(n))).tocsr()
    K = sp.csr_matrix(K - sp.diags(np.asarray(K.sum(axis=1)).ravel()))  # zero row sums: floating
    strips = np.arange(n * n) // (n * n // 12)
    A = sp.csr_matrix((np.full(n * n, 12.0 / (n * n)), (strips, np.arange(n * n))), shape=(12, n * n))
    rng = np.random.default_rng(3)
    for h, definite in ((1e-3, True), (0.0, False)):
        Kd = sp.csr_matrix(K + sp.diags(np.full(n * n, h)))
        M = sp.bmat([[Kd, A.T], [A, None]]).toarray()
        b = rng.standard_normal((M.shape[0], 2))
        ref = np.linalg.solve(M, b)
        f = linalg.saddle_factor(Kd, A, definite=definite)
        assert isinstance(f, linalg._SchurSaddle) is definite
        for x, r in ((f.solve(b), ref), (f.solve(b[:, 0]), ref[:, 0])):
            assert np.linalg.norm(x - r) / np.linalg.norm(r) < 1e-10
    # told definite where it is not: the elimination fails and the whole matrix is factorised instead
    f = linalg.saddle_factor(K, A, definite=True)
    assert not isinstance(f, linalg._SchurSaddle)
