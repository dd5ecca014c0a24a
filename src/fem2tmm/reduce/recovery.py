"""Power distribution ``q_SN = Y q`` and temperature recovery ``T = X q + Yᵀ T_SN`` (thesis eq. 4.5–4.8).

``M⁻¹ = [[X, Yᵀ], [Y, −K_SN]]`` with ``M = [[K, Aᵀ], [A, 0]]``; X and Y are never formed.  Two operators
apply them:

* :class:`GlobalOperator` — one sparse LU of M; ``M [T; λ] = [q; T_SN]`` gives T and, with T_SN = 0, λ = Y q.
* :class:`LocalOperator` — the local scheme of DESIGN §3.3: per cluster the local saddle matrix
  ``P = [[K_II, a_Iᵀ], [a_I, 0]]`` (interior nodes I) and coupling ``C = [K_IB; a_B]`` (interface nodes B), and
  the multifrontal elimination of the interface unknowns (:mod:`fem2tmm.reduce.frontal`).  Power
  distribution: interior loads are condensed cluster by cluster, then one forward sweep over the fronts.
  Recovery runs backwards: interface temperatures from a forward + backward sweep (the Guyan relation),
  then each cluster's interior from its own P.

Memory against time: P and C (∝ the cluster's non-zeros) and the front factors are always kept; each
cluster's factorisation (dense Cholesky: nI² doubles; SuperLU of K_II: its fill) is kept while the total stays
under ``factor_memory_mb`` (default 1 GiB) and recomputed at each call beyond that.  At 10⁶ quad elements in
1000 clusters the shell-like clusters use SuperLU (~0.5 MB each), so everything is kept; a recovery then costs
triangular solves only.  Dense factors of large chunky clusters would not fit (8 MB at nI = 1000): those are
recomputed, which costs about the local phase of the reduction per call.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import reverse_cuthill_mckee

from ..errors import Fem2TmmError
from ..linalg import factorize

#: widest band (reverse Cuthill-McKee order of K_II) for which a "sparse" cluster is factorised by LAPACK's banded
#: Cholesky instead of SuperLU (measurements: docs/design-notes.md, reduce/conduction.py)
BAND_MAX = 80


class Factor:
    """LU factorisation of a square matrix, dense LAPACK for small ones, SuperLU otherwise.

    ``matrix`` (n, n) scipy.sparse; ``dense`` chooses LAPACK; ``what`` names the matrix in error messages.
    ``solve(b)`` accepts (n,) or (n, r).  A singular matrix raises Fem2TmmError.  Pickles (the stage cache,
    :mod:`fem2tmm.cache`) hold the LAPACK factors, or the sparse matrix, factorised again when loaded (SuperLU
    objects do not pickle; the same matrix gives the same factors).
    """

    def __init__(self, matrix: sp.spmatrix, dense: bool, what: str):
        self.n = matrix.shape[0]
        self.dense = dense
        self._what = what
        self._matrix = None if dense else sp.csc_matrix(matrix)
        if dense:
            a = matrix.toarray()
            lu, piv = sla.lu_factor(a, check_finite=False, overwrite_a=True)
            d = np.abs(np.diag(lu))
            if d.size and not d.min() > 1e-13 * d.max():
                raise Fem2TmmError(f"{what} is singular (smallest/largest pivot {d.min():.2e}/{d.max():.2e})")
            self._lu = (lu, piv)
        else:
            try:
                self._lu = factorize(self._matrix, "symmetric")
            except RuntimeError as exc:  # "Factor is exactly singular"
                raise Fem2TmmError(f"{what} is singular ({exc})") from None

    def __getstate__(self):
        return {**self.__dict__, "_lu": self._lu if self.dense else None}

    def __setstate__(self, state):
        self.__dict__.update(state)
        if not self.dense:
            self._lu = factorize(self._matrix, "symmetric")

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


class ClusterSolver:
    """Solves with one cluster's local saddle matrix ``P = [[K_II, a_Iᵀ], [a_I, 0]]`` (size nI + 1).

    ``kind`` chooses the method:

    * ``"cholesky"`` (small or chunky cluster, every interior node connected to an interface node, so K_II is
      positive definite): dense Cholesky of K_II;
    * ``"sparse"`` (large shell-like cluster, K_II positive definite): SuperLU of K_II with a symmetric minimum
      degree order; the condensed map comes out of a second SuperLU factorisation of the local matrix ordered
      [I, μ, B] without pivoting (its trailing factors *are* the Schur complement), so no solve with the
      nB + 1 right-hand sides is needed (``"sparse_solves"`` if that needed pivoting after all);
    * ``"banded"`` (asked as ``"sparse"``, when K_II in reverse Cuthill-McKee order has a band of at most
      :data:`BAND_MAX`): LAPACK's banded Cholesky of K_II, the condensed map from banded solves with the
      nB + 1 right-hand sides (3x faster than the two SuperLU factorisations for a ~1 000-node shell cluster,
      9x for 6 000);
    * ``"lu"`` / ``"sparse_lu"`` (floating cluster: K_II singular, P is not): dense LU / SuperLU of P.

    With K_II factorised, solves border the constraint in: ``u = K_II⁻¹ a_Iᵀ``, ``s = a_I u``, and
    ``P⁻¹ [c; d] = [y − u μ; μ]`` with ``y = K_II⁻¹ c``, ``μ = (a_I y − d)/s``.

    SuperLU factorises quickly but its solves with many right-hand sides run at well under 1 GFlop/s, while
    dense LAPACK/BLAS reaches ~100 GFlop/s on 2 cores.
    """

    _BORDERED = ("cholesky", "sparse", "sparse_solves", "banded")

    def __init__(self, P: sp.csc_matrix, kind: str, what: str):
        self.nI = nI = P.shape[0] - 1
        self.kind, self.what, self.P = kind, what, P
        if kind == "cholesky":
            Pd = P.toarray()
            self.a = Pd[nI, :nI].copy()
            try:
                self.L = sla.cholesky(Pd[:nI, :nI], lower=True, overwrite_a=True, check_finite=False)
            except np.linalg.LinAlgError:
                raise Fem2TmmError(f"{what} is not positive definite (elements of zero or negative "
                                   "conductivity?)") from None
            d = np.diag(self.L)
            if not d.min() > 1e-7 * d.max():
                raise Fem2TmmError(f"{what} is singular (elements of zero conductivity?)")
        elif kind in ("sparse", "banded") and self._banded(P, force=kind == "banded"):
            self.kind = "banded"  # (a cluster condensed so is factorised so again when recomputed)
        elif kind in ("sparse", "banded"):
            self.kind = "sparse"
            self.a = P[nI, :nI].toarray().ravel()
            try:
                self._factor_kii()
            except RuntimeError:
                raise Fem2TmmError(f"{what} is singular (elements of zero conductivity?)") from None
        else:
            self.lu = Factor(P, dense=(kind == "lu"), what=what)
        if kind in self._BORDERED:
            self.u = self._ksolve(self.a)
            self.s = float(self.a @ self.u)

    def _banded(self, P: sp.csc_matrix, force: bool = False) -> bool:
        """Banded Cholesky of K_II in reverse Cuthill-McKee order when its band is narrow (``BAND_MAX``): a
        shell cluster of ~1 000 nodes has a band of ~30, and LAPACK's banded factorisation and solves beat two
        SuperLU factorisations 3x there (measurements: docs/design-notes.md, reduce/conduction.py).  False
        (nothing set) for a wider band."""
        nI = self.nI
        Kii = P[:nI, :nI].tocsr()
        order = reverse_cuthill_mckee(Kii, symmetric_mode=True)
        Kp = Kii[order][:, order].tocoo()
        band = int(np.abs(Kp.row - Kp.col).max(initial=0))
        if band > BAND_MAX and not force:
            return False
        low = Kp.row >= Kp.col
        ab = np.zeros((band + 1, nI))
        ab[(Kp.row - Kp.col)[low], Kp.col[low]] = Kp.data[low]  # (a CSR matrix's entries are unique)
        try:
            self.cb = sla.cholesky_banded(ab, lower=True, check_finite=False)
        except np.linalg.LinAlgError:
            raise Fem2TmmError(f"{self.what} is not positive definite (elements of zero or negative "
                               "conductivity?)") from None
        d = self.cb[0]
        if not d.min() > 1e-7 * d.max():  # (the diagonal of the Cholesky factor, as for the dense kind)
            raise Fem2TmmError(f"{self.what} is singular (elements of zero conductivity?)")
        self.order = order
        self.a = P[nI, :nI].toarray().ravel()
        return True

    def _factor_kii(self) -> None:
        self.klu = spla.splu(self.P[:self.nI, :self.nI].tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                             options=dict(SymmetricMode=True))

    def __getstate__(self):
        """SuperLU objects do not pickle (stage cache): factorised again from P when loaded.  A dense Cholesky
        factor travels as its lower triangle (half the bytes: Dask results, cache files) with its memory order, so
        that it comes back the same bits and the solves with it too."""
        state = {k: v for k, v in self.__dict__.items() if k != "klu"}
        L = state.get("L")
        if L is not None and not L[np.triu_indices(L.shape[0], 1)].any():
            state["L"] = (L[np.tril_indices(L.shape[0])], L.shape[0], bool(L.flags.f_contiguous))
        return state

    def __setstate__(self, state):
        if isinstance(state.get("L"), tuple):
            packed, n, fortran = state["L"]
            L = np.zeros((n, n), order="F" if fortran else "C")
            L[np.tril_indices(n)] = packed
            state = {**state, "L": L}
        self.__dict__.update(state)
        if self.kind in ("sparse", "sparse_solves"):
            self._factor_kii()

    def _ksolve(self, b):
        if self.kind == "cholesky":
            return sla.cho_solve((self.L, True), b, check_finite=False)
        if self.kind == "banded":
            out = np.empty_like(np.asarray(b, float))
            out[self.order] = sla.cho_solve_banded((self.cb, True), np.asarray(b, float)[self.order],
                                                   check_finite=False)
            return out
        return self.klu.solve(b)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``P⁻¹ rhs`` for rhs (nI + 1, r)."""
        if self.kind not in self._BORDERED:
            return self.lu.solve(rhs)
        y = self._ksolve(np.asfortranarray(rhs[:-1]))
        mu = (self.a @ y - rhs[-1]) / self.s
        return np.vstack([y - np.outer(self.u, mu), mu[None, :]])

    def condensed(self, C: sp.csr_matrix, KBB: np.ndarray) -> np.ndarray:
        """The cluster's symmetric map K*ᵢ ((nB+1), (nB+1)) from (T_B, T_SN,i) to (f_B, q_i).

        ``C`` (nI+1, nB) = [K_IB; a_B] and ``KBB`` (nB, nB) dense.  Eliminating T_I from the local matrix over
        (T_I, T_B, μ) leaves ``G = [[K_BB, a_Bᵀ], [a_B, 0]] − [K_IB, a_Iᵀ]ᵀ K_II⁻¹ [K_IB, a_Iᵀ]`` with
        ``G [T_B; μ] = [f_B; T_SN]``; with q = −μ, ``K*ᵢ = [[G_BB − g gᵀ/γ, g/γ], [gᵀ/γ, −1/γ]]`` (g = G_Bμ,
        γ = G_μμ = −s).  Equivalently ``[[K_BB − Cᵀ P⁻¹ C, Cᵀ P⁻¹ e], [·, −eᵀ P⁻¹ e]]`` (e the last unit vector).
        """
        nB = KBB.shape[0]
        nI = self.nI
        out = np.empty((nB + 1, nB + 1))
        if self.kind in ("cholesky", "banded"):  # G = [[K_BB, a_Bᵀ], [a_B, 0]] − rhsᵀ K_II⁻¹ rhs, rhs = [K_IB, a_Iᵀ]
            Cd = C.toarray()
            rhs = np.empty((nI, nB + 1))
            rhs[:, :nB] = Cd[:nI]
            rhs[:, nB] = self.a
            # rhsᵀ K_II⁻¹ rhs = Wᵀ W with W = L⁻¹ rhs: one triangular solve (dense, or banded in the RCM order)
            if self.kind == "cholesky":
                W = sla.solve_triangular(self.L, rhs, lower=True, check_finite=False, overwrite_b=True)
            else:
                W, info = sla.lapack.dtbtrs(self.cb, rhs[self.order], uplo="L", overwrite_b=1)
                if info != 0:
                    raise Fem2TmmError(f"{self.what}: banded triangular solve failed (LAPACK info {info})")
            # −WᵀW by BLAS' symmetric rank-k update (half a product's flops), its upper triangle mirrored
            G = sla.blas.dsyrk(-1.0, W, trans=1, lower=0)
            iu = np.triu_indices(nB + 1, 1)
            G[iu[1], iu[0]] = G[iu]
            G[:nB, :nB] += KBB
            G[:nB, nB] += Cd[nI]
            G[nB, :nB] += Cd[nI]
            g, gam = G[:nB, nB], G[nB, nB]
            out[:nB, :nB] = G[:nB, :nB] - np.outer(g, g) / gam
            out[:nB, nB] = out[nB, :nB] = g / gam
            out[nB, nB] = -1.0 / gam
        elif self.kind == "sparse" and self._trailing(C, KBB, out):
            pass
        else:
            if self.kind == "sparse":  # pivoting was needed after all: solve with the right-hand sides
                self.kind = "sparse_solves"
            rhs = np.zeros((nI + 1, nB + 1))
            rhs[:, :nB] = C.toarray()
            rhs[nI, nB] = 1.0
            Z = self.solve(rhs)
            CtZ = C.T @ Z
            out[:nB, :nB] = KBB - CtZ[:, :nB]
            out[:nB, nB] = out[nB, :nB] = CtZ[:, nB]
            out[nB, nB] = -Z[nI, nB]
        return 0.5 * (out + out.T)

    def _trailing(self, C: sp.csr_matrix, KBB: np.ndarray, out: np.ndarray) -> bool:
        """K*ᵢ from the trailing LU factors of the local matrix ordered [I, μ, B]; False if pivoting was needed.

        After eliminating I and then μ without pivoting, the trailing (μ, B) factors hold γ = U_μμ,
        g/γ = L_Bμ and the Schur complement K*_BB = L_BB U_BB.  I is ordered by SuperLU's minimum degree on
        K_II (its column permutation with symmetric mode).
        """
        nI, nB = self.nI, KBB.shape[0]
        o = self.klu.perm_c
        new = np.empty(nI + 1 + nB, np.int64)  # position of each local unknown: I by o, then μ, then B
        new[o] = np.arange(nI)
        new[nI] = nI
        new[nI + 1:] = nI + 1 + np.arange(nB)
        Pc, Cc = self.P.tocoo(), C.tocoo()
        bi, bj = np.nonzero(KBB)
        r = np.concatenate([new[Pc.row], new[Cc.row], nI + 1 + Cc.col, nI + 1 + bi])
        c = np.concatenate([new[Pc.col], nI + 1 + Cc.col, new[Cc.row], nI + 1 + bj])
        v = np.concatenate([Pc.data, Cc.data, Cc.data, KBB[bi, bj]])
        n = nI + 1 + nB
        try:
            lu = spla.splu(sp.csc_matrix((v, (r, c)), shape=(n, n)), permc_spec="NATURAL",
                           diag_pivot_thresh=0.0, options=dict(SymmetricMode=True, Equil=False))
        except RuntimeError:
            return False
        ident = np.arange(n)
        if not (np.array_equal(lu.perm_r, ident) and np.array_equal(lu.perm_c, ident)):
            return False
        Lt = lu.L[nI:, nI:].toarray()
        Ut = lu.U[nI:, nI:].toarray()
        out[:nB, :nB] = Lt[1:, 1:] @ Ut[1:, 1:]
        out[:nB, nB] = out[nB, :nB] = Lt[1:, 0]
        out[nB, nB] = -1.0 / Ut[0, 0]
        return True

    @property
    def nbytes(self) -> int:
        if self.kind == "cholesky":
            return self.L.nbytes + self.u.nbytes
        if self.kind == "banded":
            return self.cb.nbytes + self.order.nbytes + self.u.nbytes
        if self.kind in self._BORDERED:
            return 12 * (self.klu.L.nnz + self.klu.U.nnz) + self.u.nbytes
        return self.lu.nbytes


@dataclass
class LocalCluster:
    """Local data of one cluster for the local scheme.

    ``sn`` its super-node index; ``I`` (nI,) interior DOFs; ``B`` (nB,) interface DOFs; ``kB`` (nB,) their
    K* indices; ``P`` (nI+1, nI+1) local saddle matrix and ``C`` (nI+1, nB) coupling ``[K_IB; a_B]`` (None for
    a cluster without interior node, whose multiplier is the K* unknown ``mu``); ``kind`` the
    :class:`ClusterSolver` method.  ``P`` and ``C`` (memory ∝ the cluster's non-zeros) are always kept; the
    solver only when the caller's memory budget allows (``solver(keep=True)``).
    """

    sn: int
    I: np.ndarray
    B: np.ndarray
    kB: np.ndarray
    P: sp.csc_matrix | None
    C: sp.csr_matrix | None
    kind: str
    mu: int = -1
    _solver: ClusterSolver | None = field(default=None, repr=False)

    def solver(self, keep: bool = False) -> ClusterSolver:
        s = self._solver
        if s is None:
            s = ClusterSolver(self.P, self.kind, f"local saddle matrix of cluster {self.sn}")
            if keep:
                self._solver = s
        return s


class LocalOperator:
    """Applies X and Y cluster by cluster plus the multifrontal interface solve (DESIGN §3.3).

    ``clusters`` list of :class:`LocalCluster`; ``kidx`` (n_dof,) K* index of each interface DOF (−1 for
    interior DOFs; one-node super nodes map to their super-node index); ``frontal`` the
    :class:`~fem2tmm.reduce.frontal.Frontal` elimination of the interface unknowns.  K* unknowns are numbered
    super nodes first (0 … n_SN−1), then condensed interface DOFs, then multipliers.
    """

    def __init__(self, clusters: list[LocalCluster], kidx: np.ndarray, n_sn: int, n_star: int, frontal):
        self.clusters, self.kidx, self.n_sn, self.n_star = clusters, kidx, n_sn, n_star
        self.frontal = frontal
        self.n_dof = kidx.shape[0]
        self.iface = np.flatnonzero(kidx >= 0)

    def _loads(self, q2: np.ndarray) -> np.ndarray:
        """Right-hand side over K* unknowns (n*, r) from a detailed load (n_dof, r).

        Interface rows: q_B − Σ_clusters Cᵀ P⁻¹ [q_I; 0]; cluster rows: the multiplier part of P⁻¹ [q_I; 0]
        (the local Y applied to the interior loads); multiplier rows: 0.
        """
        r = q2.shape[1]
        h = np.zeros((self.n_star, r))
        h[self.kidx[self.iface]] = q2[self.iface]  # K* indices of interface DOFs are distinct
        for cl in self.clusters:
            if cl.P is None or not np.any(q2[cl.I]):
                continue
            z = cl.solver().solve(np.vstack([q2[cl.I], np.zeros((1, r))]))
            h[cl.kB] -= cl.C.T @ z
            h[cl.sn] += z[-1]
        return h

    def distribute(self, q: np.ndarray) -> np.ndarray:
        q2, one = _as_2d(q, self.n_dof, "load q")
        out = self.frontal.forward(self._loads(q2))[:self.n_sn]
        return out[:, 0] if one else out

    def recover(self, T_sn: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        t2, one = _as_2d(T_sn, self.n_sn, "super-node temperatures")
        r = t2.shape[1]
        if q is None:
            q2 = None
            h = np.zeros((self.n_star, r))
        else:
            q2 = _as_2d(q, self.n_dof, "load q")[0]
            if q2.shape[1] != r:
                raise Fem2TmmError(f"load q has {q2.shape[1]} columns but T_SN has {r}")
            h = self._loads(q2)
        x = self.frontal.backward(self.frontal.forward(h), t2)  # all K* unknowns
        T = np.zeros((self.n_dof, r))
        T[self.iface] = x[self.kidx[self.iface]]
        for cl in self.clusters:
            if cl.P is None:
                continue
            qI = q2[cl.I] if q2 is not None else np.zeros((cl.I.size, r))
            rhs = np.vstack([qI, t2[cl.sn][None, :]]) - cl.C @ x[cl.kB]
            T[cl.I] = cl.solver().solve(rhs)[:-1]
        return T[:, 0] if one else T

    @property
    def factor_nbytes(self) -> int:
        """Memory held by the kept factorisations (bytes)."""
        return self.frontal.nbytes + sum(cl._solver.nbytes for cl in self.clusters if cl._solver is not None)


__all__ = ["Factor", "ClusterSolver", "GlobalOperator", "LocalOperator", "LocalCluster"]
