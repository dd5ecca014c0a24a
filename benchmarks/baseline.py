"""The honest baseline of the whole-pipeline benchmarks (issue 43): one factor-and-solve of the model's Newton matrix
(the conduction matrix plus the linearised emission to space, 4σT³ g on the diagonal, held DOFs removed; symmetric
positive definite) with the best sparse direct solver available, and scipy's beside it.

Solvers (each timed factor + solve, its relative residual checked):

- ``pardiso``: Intel MKL PARDISO through ``pypardiso`` (the ``bench`` extra), real symmetric positive definite
  (``mtype = 2``, upper triangle), its default nested-dissection ordering;
- ``cholmod``: CHOLMOD through ``scikit-sparse`` (GPL in part: never a required dependency), supernodal Cholesky;
- ``scipy``: ``scipy.sparse.linalg.spsolve`` with a symmetric ordering (``permc_spec="MMD_AT_PLUS_A"``), SuperLU.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

#: a baseline whose relative residual ‖J x − b‖ / ‖b‖ exceeds this did not solve the system (a direct solve of a
#: well-conditioned SPD system of 10⁶ unknowns lands near 1e-14; 1e-8 leaves room for the conditioning, not for
#: a singular matrix, which gives O(1) and above)
RESIDUAL_MAX = 1e-8


def connected_pieces(model) -> int:
    """Connected pieces of the conduction graph on the free DOFs (K restricted to them): 1 for one structure."""
    from scipy.sparse.csgraph import connected_components

    free = ~model.fixed_mask
    n, _ = connected_components(sp.csr_matrix(model.K)[free][:, free], directed=False)
    return int(n)


def newton_matrix(model, T: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """The model's Newton matrix at the field T (n_dof,) K on its free DOFs, J = K + diag(4σT³ g) (W/K),
    and a right-hand side (its loads, W)."""
    from fem2tmm.constants import SIGMA

    free = ~model.fixed_mask
    J = sp.csr_matrix(model.K) + sp.diags(4.0 * SIGMA * np.asarray(T, float) ** 3 * model.space_coupling())
    J = sp.csr_matrix(J)[free][:, free].tocsr()
    J.sort_indices()
    return J, np.asarray(model.Q, float)[free].copy()


def _pardiso(J, b):
    import pypardiso

    s = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite: its upper triangle
    U = sp.triu(J, format="csr")
    U.sort_indices()
    x = s.solve(U, b)
    s.free_memory(everything=True)
    return x


def _cholmod(J, b):
    from sksparse.cholmod import cholesky

    return cholesky(sp.csc_matrix(J))(b)


def _scipy(J, b):
    import scipy.sparse.linalg as spla

    return spla.spsolve(sp.csc_matrix(J), b, permc_spec="MMD_AT_PLUS_A")


def available() -> dict:
    """name -> ``fn(J, b) -> x`` of the solvers importable here, best first (pardiso, cholmod), scipy last."""
    out = {}
    try:
        import pypardiso  # noqa: F401

        out["pardiso"] = _pardiso
    except ImportError:
        pass
    try:
        import sksparse.cholmod  # noqa: F401

        out["cholmod"] = _cholmod
    except ImportError:
        pass
    out["scipy"] = _scipy
    return out


LABELS = {"pardiso": "PARDISO (MKL via pypardiso, SPD, mtype 2), factor + solve",
          "cholmod": "CHOLMOD (scikit-sparse), factor + solve",
          "scipy": "scipy spsolve (SuperLU, permc_spec MMD_AT_PLUS_A), factor + solve"}


def timed_solve(name: str, J, b) -> tuple[float, float]:
    """(wall seconds, relative residual) of one factor-and-solve by solver ``name``; raises if it did not solve."""
    fn = available()[name]
    t0 = time.perf_counter()
    x = fn(J, b)
    t = time.perf_counter() - t0
    rel = float(np.linalg.norm(J @ x - b) / np.linalg.norm(b))
    if not rel <= RESIDUAL_MAX:
        raise AssertionError(f"baseline {name}: relative residual {rel:.3g} > {RESIDUAL_MAX:g}: not a solve")
    return t, rel
