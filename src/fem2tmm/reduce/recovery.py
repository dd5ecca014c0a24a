"""Power distribution ``q_SN = Y q`` and temperature recovery ``T = X q + Yᵀ T_SN`` (thesis eq. 4.5–4.8).

``M⁻¹ = [[X, Yᵀ], [Y, −K_SN]]`` with ``M = [[K, Aᵀ], [A, 0]]``; X and Y are never formed.  Two operators
apply them:

* :class:`GlobalOperator` — one sparse LU of M; ``M [T; λ] = [q; T_SN]`` gives T and, with T_SN = 0, λ = Y q.
* :class:`LocalOperator` — the local scheme of DESIGN §3.3: per cluster the local saddle matrix
  ``P = [[K_II, a_Iᵀ], [a_I, 0]]`` (interior nodes I) and coupling ``C = [K_IB; a_B]`` (interface nodes B), and
  one sparse LU of the interface block K*_FF of the assembled K* (interface DOFs and the multipliers of clusters
  without interior nodes).  Recovery runs backwards: interface temperatures from the Guyan relation, then each
  cluster's interior from its own P.

Per-cluster factorisations are kept by default (``keep_factors=True``): recovery then costs only triangular
solves.  Their memory is the fill of each cluster's LU (about 12 bytes per non-zero; ~0.5 GB for 10⁶ quad
elements in 1000 clusters, measured in ``benchmarks.py``), against recomputing them, which costs about the
local phase of the reduction at every call.  With ``keep_factors=False`` only P and C are stored
(memory ∝ the cluster's non-zeros) and each call refactorises.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import Fem2TmmError


class Factor:
    """LU factorisation of a square matrix, dense LAPACK for small ones, SuperLU otherwise.

    ``matrix`` (n, n) scipy.sparse; ``dense`` chooses LAPACK; ``what`` names the matrix in error messages.
    ``solve(b)`` accepts (n,) or (n, r).  A singular matrix raises Fem2TmmError.
    """

    def __init__(self, matrix: sp.spmatrix, dense: bool, what: str):
        self.n = matrix.shape[0]
        self.dense = dense
        if dense:
            a = matrix.toarray()
            lu, piv = sla.lu_factor(a, check_finite=False, overwrite_a=True)
            d = np.abs(np.diag(lu))
            if d.size and not d.min() > 1e-13 * d.max():
                raise Fem2TmmError(f"{what} is singular (smallest/largest pivot {d.min():.2e}/{d.max():.2e})")
            self._lu = (lu, piv)
        else:
            try:
                self._lu = spla.splu(sp.csc_matrix(matrix))
            except RuntimeError as exc:  # "Factor is exactly singular"
                raise Fem2TmmError(f"{what} is singular ({exc})") from None

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self.dense:
            return sla.lu_solve(self._lu, b, check_finite=False)
        return self._lu.solve(np.ascontiguousarray(b) if b.ndim == 1 else np.asfortranarray(b))

    @property
    def nbytes(self) -> int:
        """Approximate memory of the factors in bytes."""
        if self.dense:
            return self._lu[0].nbytes
        return 12 * (self._lu.L.nnz + self._lu.U.nnz)


def _as_2d(x: np.ndarray, n: int, what: str) -> tuple[np.ndarray, bool]:
    x = np.asarray(x, float)
    if x.ndim == 1 and x.shape[0] == n:
        return x[:, None], True
    if x.ndim == 2 and x.shape[0] == n:
        return x, False
    raise Fem2TmmError(f"{what} has shape {x.shape}; expected ({n},) or ({n}, r)")


class GlobalOperator:
    """Applies X and Y through one sparse LU of the saddle matrix M (size n_dof + n_SN)."""

    def __init__(self, lu: Factor, n_dof: int, n_sn: int):
        self.lu, self.n_dof, self.n_sn = lu, n_dof, n_sn

    def distribute(self, q: np.ndarray) -> np.ndarray:
        q2, one = _as_2d(q, self.n_dof, "load q")
        sol = self.lu.solve(np.vstack([q2, np.zeros((self.n_sn, q2.shape[1]))]))
        out = sol[self.n_dof:]
        return out[:, 0] if one else out

    def recover(self, T_sn: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        t2, one = _as_2d(T_sn, self.n_sn, "super-node temperatures")
        q2 = np.zeros((self.n_dof, t2.shape[1])) if q is None else _as_2d(q, self.n_dof, "load q")[0]
        if q2.shape[1] != t2.shape[1]:
            raise Fem2TmmError(f"load q has {q2.shape[1]} columns but T_SN has {t2.shape[1]}")
        sol = self.lu.solve(np.vstack([q2, t2]))
        out = sol[:self.n_dof]
        return out[:, 0] if one else out


@dataclass
class LocalCluster:
    """Local data of one cluster for the local scheme.

    ``sn`` its super-node index; ``I`` (nI,) interior DOFs; ``B`` (nB,) interface DOFs; ``kB`` (nB,) their
    K* indices; ``P`` (nI+1, nI+1) local saddle matrix, ``C`` (nI+1, nB) coupling ``[K_IB; a_B]`` (both None
    for a cluster without interior node, whose multiplier is the K* unknown ``mu``); ``dense`` LAPACK or SuperLU.
    """

    sn: int
    I: np.ndarray
    B: np.ndarray
    kB: np.ndarray
    P: sp.csc_matrix | None
    C: sp.csr_matrix | None
    dense: bool
    mu: int = -1
    _factor: Factor | None = field(default=None, repr=False)

    def factor(self, keep: bool) -> Factor:
        f = self._factor
        if f is None:
            f = Factor(self.P, self.dense, f"local saddle matrix of cluster {self.sn}"
                       " (elements of zero conductivity, or several parts of the cluster not connected to the rest)")
            if keep:
                self._factor = f
        return f


class LocalOperator:
    """Applies X and Y cluster by cluster plus one interface solve (DESIGN §3.3).

    ``clusters`` list of :class:`LocalCluster`; ``kidx`` (n_dof,) K* index of each interface DOF (−1 for
    interior DOFs; one-node super nodes map to their super-node index); ``KFF`` factor of the condensed block
    (None when there is nothing to condense); ``KFS`` (n_F, n_SN) csr coupling of condensed to retained unknowns.
    K* unknowns are numbered super nodes first (0 … n_SN−1), then interface DOFs, then multipliers.
    """

    def __init__(self, clusters: list[LocalCluster], kidx: np.ndarray, n_sn: int, KFF: Factor | None,
                 KFS: sp.csr_matrix, keep_factors: bool):
        self.clusters, self.kidx, self.n_sn = clusters, kidx, n_sn
        self.KFF, self.KFS, self.keep_factors = KFF, KFS, keep_factors
        self.n_dof = kidx.shape[0]
        self.iface = np.flatnonzero(kidx >= 0)
        self.n_star = n_sn + KFS.shape[0]

    def _loads(self, q2: np.ndarray) -> np.ndarray:
        """Right-hand side over K* unknowns (n*, r) from a detailed load (n_dof, r).

        Interface rows: q_B − Σ_clusters Cᵀ P⁻¹ [q_I; 0]; cluster rows: the multiplier part of P⁻¹ [q_I; 0]
        (thesis: the local Y applied to the interior loads); multiplier rows: 0.
        """
        r = q2.shape[1]
        h = np.zeros((self.n_star, r))
        h[self.kidx[self.iface]] = q2[self.iface]  # K* indices of interface DOFs are distinct
        for cl in self.clusters:
            if cl.P is None or not np.any(q2[cl.I]):
                continue
            z = cl.factor(self.keep_factors).solve(np.vstack([q2[cl.I], np.zeros((1, r))]))
            h[cl.kB] -= cl.C.T @ z
            h[cl.sn] += z[-1]
        return h

    def _condensed(self, b: np.ndarray) -> np.ndarray:
        return self.KFF.solve(b) if self.KFF is not None else np.zeros((0, b.shape[1]))

    def distribute(self, q: np.ndarray) -> np.ndarray:
        q2, one = _as_2d(q, self.n_dof, "load q")
        h = self._loads(q2)
        out = h[:self.n_sn] - self.KFS.T @ self._condensed(h[self.n_sn:])
        return out[:, 0] if one else out

    def recover(self, T_sn: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        t2, one = _as_2d(T_sn, self.n_sn, "super-node temperatures")
        r = t2.shape[1]
        if q is None:
            q2 = None
            b = np.zeros((self.n_star - self.n_sn, r))
        else:
            q2 = _as_2d(q, self.n_dof, "load q")[0]
            if q2.shape[1] != r:
                raise Fem2TmmError(f"load q has {q2.shape[1]} columns but T_SN has {r}")
            b = self._loads(q2)[self.n_sn:]
        x = np.vstack([t2, self._condensed(b - self.KFS @ t2)])  # all K* unknowns
        T = np.zeros((self.n_dof, r))
        T[self.iface] = x[self.kidx[self.iface]]
        for cl in self.clusters:
            if cl.P is None:
                continue
            qI = q2[cl.I] if q2 is not None else np.zeros((cl.I.size, r))
            rhs = np.vstack([qI, t2[cl.sn][None, :]]) - cl.C @ x[cl.kB]
            T[cl.I] = cl.factor(self.keep_factors).solve(rhs)[:-1]
        return T[:, 0] if one else T

    @property
    def factor_nbytes(self) -> int:
        """Memory held by the kept factorisations (bytes)."""
        total = self.KFF.nbytes if self.KFF is not None else 0
        return total + sum(cl._factor.nbytes for cl in self.clusters if cl._factor is not None)


__all__ = ["Factor", "GlobalOperator", "LocalOperator", "LocalCluster"]
