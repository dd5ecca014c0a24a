"""Sparse direct solves shared by the stages, the backend chosen in one place (:func:`factorize`), and the BLAS
thread limit (:func:`blas_threads`).

Thermal conduction matrices (plus radiative linearisations) are symmetric positive definite once a temperature is
held, or diagonally dominant, structurally symmetric M-matrices (a radiative Jacobian ``L diag(4σT³)``).  Every
sparse factorisation in the tool goes through :func:`factorize`, told what the matrix is (``kind``):

- ``"spd"``: symmetric positive definite (a conduction matrix with a held DOF or a conductance to ground, the
  detailed Newton matrix K + diag(4σT³g), a transient's C/Δt + J): PARDISO (Intel MKL, through ``pypardiso``) or
  CHOLMOD (``scikit-sparse``) when installed and the matrix has at least :data:`FAST_MIN` unknowns, else
  SuperLU on a minimum-degree ordering of A + Aᵀ without pivoting (stable on an SPD matrix);
- ``"symmetric"``: symmetric indefinite (a saddle matrix [[K, Aᵀ], [A, 0]]): PARDISO's symmetric indefinite
  factorisation (Bunch-Kaufman pivoting, iterative refinement), else SuperLU on the same symmetric ordering with
  threshold pivoting;
- ``"general"``: structurally symmetric, diagonally dominant (a Jacobian with node-to-node radiation): SuperLU on the
  symmetric ordering without pivoting; ``"pivoting"``: the same ordering with threshold pivoting (the fallbacks for
  a Jacobian that is not diagonally dominant).

Neither package is required (``pip install fem2tmm[bench]``; CHOLMOD is GPL in part).  The environment variable
``FEM2TMM_SPARSE_SOLVER`` = ``pardiso`` | ``cholmod`` | ``scipy`` forces one (``auto``, the default: PARDISO, then
CHOLMOD, then scipy).  The backends agree to round-off (measurements: docs/benchmarks.md, "Performance").
"""

from __future__ import annotations

import contextlib
import os
import weakref

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

#: the sparse direct backend: "auto" (PARDISO, CHOLMOD, scipy: the first installed), or "pardiso" | "cholmod" | "scipy"
SOLVER = os.environ.get("FEM2TMM_SPARSE_SOLVER", "auto").strip().lower()
#: matrices with fewer unknowns stay with SuperLU even when PARDISO or CHOLMOD is installed: below ~10⁴ unknowns
#: every backend takes milliseconds and SuperLU has no setup cost (one code path for the small models of the tests)
FAST_MIN = 20_000

_BACKENDS: dict[str, bool] = {}


def _installed(name: str) -> bool:
    if name not in _BACKENDS:
        try:
            if name == "pardiso":
                import pypardiso  # noqa: F401
            elif name == "cholmod":
                import sksparse.cholmod  # noqa: F401
            _BACKENDS[name] = True
        except Exception:  # ImportError, or MKL's library not found
            _BACKENDS[name] = False
    return _BACKENDS[name]


def backend(n: int, kind: str = "spd") -> str:
    """The backend :func:`factorize` uses for an (n, n) matrix of ``kind``: "pardiso", "cholmod" or "scipy"."""
    if kind in ("general", "pivoting") or n < FAST_MIN or SOLVER == "scipy":
        return "scipy"
    order = ("pardiso", "cholmod") if SOLVER == "auto" else (SOLVER,)
    for name in order:
        if name == "cholmod" and kind != "spd":
            continue  # CHOLMOD's LDLᵀ does not pivot: not for an indefinite matrix
        if _installed(name):
            return name
    return "scipy"


class _PardisoFactor:
    """A PARDISO factorisation (upper triangle of a symmetric matrix); ``solve(b)`` for b (n,) or (n, r)."""

    def __init__(self, A: sp.spmatrix, mtype: int):
        import pypardiso

        s = pypardiso.PyPardisoSolver(mtype=mtype)
        # the upper triangle with every diagonal entry stored, zeros included (PARDISO's symmetric input; a row
        # without its diagonal, a saddle's constraint row, hangs or crashes it)
        Uc = sp.triu(A, k=1, format="coo")
        n = A.shape[0]
        ar = np.arange(n)
        U = sp.csr_matrix((np.concatenate([Uc.data, A.diagonal()]), (np.concatenate([Uc.row, ar]),
                           np.concatenate([Uc.col, ar]))), shape=A.shape)
        U.sort_indices()
        self.U, self.shape = U, A.shape
        s.iparm[11] = 0  # CSR, no transpose
        self._s = s
        weakref.finalize(self, _pardiso_free, s)
        s.set_phase(12)  # analysis and numerical factorisation
        s._call_pardiso(U, np.zeros((A.shape[0], 1), order="F"))
        if s.iparm[13] > 0:  # perturbed pivots: (nearly) singular; SuperLU decides and says so
            raise ArithmeticError(f"PARDISO perturbed {int(s.iparm[13])} pivots")

    def solve(self, b: np.ndarray) -> np.ndarray:
        b = np.asarray(b, float)
        s = self._s
        s.set_phase(33)
        return s._call_pardiso(self.U, np.asfortranarray(b))


def _pardiso_free(s) -> None:
    try:
        s.free_memory(everything=False)
    except Exception:  # interpreter shutdown
        pass


class _CholmodFactor:
    def __init__(self, A: sp.spmatrix):
        from sksparse.cholmod import cholesky

        self._f = cholesky(sp.csc_matrix(A))

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._f(np.asarray(b, float))


def factorize(A, kind: str = "spd"):
    """A factorisation of the sparse (n, n) matrix A with ``solve(b)``, b (n,) or (n, r).

    ``kind``: "spd" symmetric positive definite, "symmetric" symmetric indefinite, "general" structurally
    symmetric and diagonally dominant, "pivoting" structurally symmetric with partial pivoting (a fallback for a
    matrix that is not diagonally dominant); module docstring: which backend each takes.  A PARDISO or CHOLMOD
    factorisation that finds the matrix not positive definite falls back to SuperLU (which then decides).
    """
    name = backend(A.shape[0], kind)
    if name == "pardiso":
        try:
            return _PardisoFactor(A, 2 if kind == "spd" else -2)
        except Exception:  # PyPardisoError: not positive definite, singular
            pass
    elif name == "cholmod":
        try:
            return _CholmodFactor(A)
        except Exception:  # CholmodNotPositiveDefiniteError
            pass
    A = sp.csc_matrix(A)
    if kind in ("symmetric", "pivoting"):
        return spla.splu(A, permc_spec="MMD_AT_PLUS_A")
    return spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))


#: :func:`saddle_factor` eliminates through the Schur complement while n x m (the dense solves that form it) is at
#: most this many entries (160 MB); beyond, the whole saddle matrix is factorised
SCHUR_MAX_ENTRIES = 20_000_000
#: and keeps Kd⁻¹Aᵀ while it has at most this many entries (32 MB): each solve then needs one back-substitution with
#: Kd's factors instead of two (the recovery's chord steps, a solve each: examples/composite's 6 802 x 101, 2026-12-07)
SCHUR_KEEP_ENTRIES = 4_000_000


class _SchurSaddle:
    """``solve(b)`` with the saddle matrix [[Kd, Aᵀ], [A, 0]] by block elimination: Kd (n, n) SPD factorised once,
    S = A Kd⁻¹ Aᵀ (m, m) dense SPD (Cholesky): μ = S⁻¹ (A Kd⁻¹ f − g), x = Kd⁻¹ (f − Aᵀ μ)."""

    def __init__(self, Kd, A):
        self.n, self.A = Kd.shape[0], sp.csr_matrix(A)
        self.lu = factorize(Kd, "spd")
        m = self.A.shape[0]
        cols = max(1, SCHUR_MAX_ENTRIES // max(self.n, 1))
        S = np.empty((m, m))
        At = self.A.T.tocsc()
        # Kd⁻¹Aᵀ kept where small: a solve then takes one sparse back-substitution instead of two
        self.Z = np.empty((self.n, m)) if self.n * m <= SCHUR_KEEP_ENTRIES else None
        for j in range(0, m, cols):  # the m solves in blocks of at most SCHUR_MAX_ENTRIES entries
            Zj = self.lu.solve(At[:, j:j + cols].toarray())
            S[:, j:j + cols] = self.A @ Zj
            if self.Z is not None:
                self.Z[:, j:j + cols] = Zj
        self.S = sla.cho_factor(0.5 * (S + S.T))

    def solve(self, b: np.ndarray) -> np.ndarray:
        b = np.asarray(b, float)
        f, g = b[: self.n], b[self.n:]
        y = self.lu.solve(f)
        mu = sla.cho_solve(self.S, self.A @ y - g)
        x = y - (self.Z @ mu if self.Z is not None else self.lu.solve(np.asarray(self.A.T @ mu)))
        return np.concatenate([x, mu], axis=0)


def saddle_factor(Kd, A, definite: bool):
    """A factorisation with ``solve(b)`` of the saddle matrix [[Kd, Aᵀ], [A, 0]] (Kd (n, n) symmetric, A (m, n)).

    ``definite``: the caller knows Kd is positive definite (a conduction matrix plus a positive diagonal on every
    connected piece: a held DOF, emission, a capacitance).  It is then eliminated through Kd's factorisation and the
    dense Schur complement A Kd⁻¹ Aᵀ, when n x m is at most :data:`SCHUR_MAX_ENTRIES`: on examples/composite's
    recovery (6 802 DOFs, 101 super nodes) 0.09 s against 0.78 s for SuperLU on the whole symmetric indefinite matrix
    (2026-12-07), whose constraint rows, each spanning a cluster, fill it.  Otherwise (or Kd singular) the whole
    matrix, :func:`factorize` kind "symmetric"."""
    n, m = Kd.shape[0], A.shape[0]
    if definite and m and n * m <= SCHUR_MAX_ENTRIES:
        try:
            return _SchurSaddle(Kd, A)
        except (RuntimeError, np.linalg.LinAlgError):  # not positive definite after all: the general path decides
            pass
    return factorize(sp.bmat([[Kd, A.T], [A, None]], format="csc"), "symmetric")


def solve(A, b: np.ndarray, kind: str = "spd") -> np.ndarray:
    """x = A⁻¹ b for a sparse (see :func:`factorize`) or dense A; b (n,) or (n, r)."""
    if sp.issparse(A):
        return factorize(A, kind).solve(np.asarray(b, dtype=float))
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


#: BLAS threads pinned for the whole process by :func:`pinned_blas` (None: not pinned)
_PINNED: list = [None]


@contextlib.contextmanager
def pinned_blas(n: int | None):
    """Hold BLAS at ``n`` threads for the whole process while the block runs (no-op for None), with every
    :func:`blas_threads` inside it inert.

    threadpoolctl's limits are process-wide, not per thread: where a load-case set runs its cases in client threads
    at once (on Dask), one case's ``blas_threads(1)`` around a small dense Newton set the count for another case's
    multifrontal Cholesky in the middle of it, and OpenBLAS' Cholesky, triangular solves and products give other
    bits on 1 thread than on 2 (fronts of 150 unknowns and up): the set's networks then differed from a serial run's
    in the last bits, depending on timing (tests/test_cases_pipeline.py, about one run in three).  A set pinned at
    one count computes every case the same way whatever the scheduling."""
    if n is None:
        yield
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # without threadpoolctl nothing here changes BLAS threads
        yield
        return
    with threadpool_limits(limits=n, user_api="blas"):
        _PINNED[0] = n
        try:
            yield
        finally:
            _PINNED[0] = None


def blas_threads(n: int | None):
    """Context manager limiting BLAS to ``n`` threads (no-op for None, without threadpoolctl or while
    :func:`pinned_blas` holds the count)."""
    if n is None or _PINNED[0] is not None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # threadpoolctl comes with scikit-learn; without it, leave BLAS alone
        return contextlib.nullcontext()
    return threadpool_limits(limits=n, user_api="blas")
