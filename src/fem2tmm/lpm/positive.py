"""A positive sparse network from fem2tmm's exact reduced conduction matrix (issue 20, item 4).

The exact reduction ``K_SN`` (DESIGN §3.2) is dense per connected part and has positive off-diagonal terms
(negative GL) that many primes refuse.  Here it is replaced by a network ``K⁺ = Bᵀ diag(g) B`` with

- links only between super nodes that *touch*: share an FE node, or are linked by a detailed conduction entry
  (a joint element) — the pattern of ``|A| |K| |A|ᵀ`` (A the super-node weights, K the detailed conduction);
- every conductance ``g_e > 0`` (links the fit drives to zero are simply absent);
- zero row sums and symmetry by construction (B is the edge-node incidence matrix).

The conductances minimise ``Σ_k ‖(K⁺ − K_SN) t_k‖²`` over the exact reduction's own response patterns ``t_k``: the
temperatures of a unit load on each free super node (boundary nodes at 0) and of a unit temperature on each
boundary node (no load) — together with the uniform field (in the null space of both) they span every response,
so the residual is the load error of K⁺ on the exact temperatures.  The problem is a non-negative least squares in
``g`` with the normal matrix ``H = (BBᵀ) ∘ (B T Tᵀ Bᵀ)`` (m × m, non-zero only for links sharing a node) and right
side ``c_e = Σ_k (B t_k)_e (B K_SN t_k)_e``; it is solved by :func:`scipy.optimize.nnls` on the Cholesky factor.

Weights: the load residual is seen through ``K_FF⁻¹`` (a temperature error; fixed rows — heat into the boundary —
at the mean diagonal), and the solved states of the actual load cases (``states``) are added as patterns weighing
``state_weight`` times all generic ones together: the network then reproduces the exact reduction's response to
the case's own loads closely, and its response to any other load as well as a sparse positive network can.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.optimize import nnls

from ..errors import Fem2TmmError


def touching_pairs(A: sp.spmatrix, K: sp.spmatrix) -> np.ndarray:
    """Pairs (m, 2) i < j of super nodes that touch: share a DOF or are coupled by a detailed conduction entry.

    ``A`` (n_SN, n_dof) super-node weights; ``K`` (n_dof, n_dof) detailed conduction (only its pattern is used).
    """
    Ab = sp.csr_matrix(A, dtype=float, copy=True)
    Ab.data = np.ones_like(Ab.data)
    Kb = sp.csr_matrix(K, dtype=float, copy=True)
    Kb.data = np.ones_like(Kb.data)
    Kb = Kb + sp.identity(Kb.shape[0], format="csr")  # a shared DOF touches itself
    S = sp.triu(Ab @ Kb @ Ab.T, k=1).tocoo()
    keep = S.data > 0
    return np.c_[S.row[keep], S.col[keep]].astype(np.int64)


def incidence(pairs: np.ndarray, n: int) -> sp.csr_matrix:
    """Edge-node incidence B (m, n): row e is e_a − e_b for the pair (a, b)."""
    m = len(pairs)
    rows = np.repeat(np.arange(m), 2)
    return sp.csr_matrix((np.tile([1.0, -1.0], m), (rows, pairs.ravel())), shape=(m, n))


def response_patterns(K: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Response patterns (n, p) of the conduction matrix ``K`` (n, n): unit load on each free node with the fixed
    nodes at 0, and unit temperature on each fixed node without load.  A part without a fixed node gets its
    patterns from the pseudo-inverse (loads balanced by a uniform sink)."""
    n = len(K)
    fixed = np.asarray(fixed, bool)
    F = np.flatnonzero(~fixed)
    B = np.flatnonzero(fixed)
    T = np.zeros((n, len(F) + len(B)))
    KFF = K[np.ix_(F, F)]
    rhs = np.zeros((len(F), len(F) + len(B)))
    rhs[:, : len(F)] = np.eye(len(F))
    rhs[:, len(F):] = -K[np.ix_(F, B)]
    try:
        T[F] = sla.solve(KFF, rhs, assume_a="sym")
    except (sla.LinAlgError, ValueError):
        T[F] = np.linalg.pinv(KFF) @ rhs
    T[B, len(F) + np.arange(len(B))] = 1.0
    return T


@dataclass(frozen=True)
class PositiveNetwork:
    """The fitted network: ``K`` (n, n) dense W/K (symmetric, zero row sums, off-diagonal ≤ 0), ``pairs`` (k, 2) the
    links kept (g > 0) and their ``GL`` (k,) W/K; ``report``: links candidate / kept, exact links and negative
    ones, relative load residual of the fit."""

    K: np.ndarray
    pairs: np.ndarray
    GL: np.ndarray
    report: dict = field(default_factory=dict)


def temperature_weights(K: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """S (n, n) turning a load residual into a temperature error: ``K_FF⁻¹`` on the free rows; the fixed rows (heat
    into the boundary) get the mean diagonal of ``K_FF⁻¹`` so that a watt there weighs like a watt elsewhere."""
    n = len(K)
    fixed = np.asarray(fixed, bool)
    F = np.flatnonzero(~fixed)
    S = np.zeros((n, n))
    inv = np.linalg.pinv(K[np.ix_(F, F)])
    S[np.ix_(F, F)] = inv
    B = np.flatnonzero(fixed)
    S[B, B] = float(np.mean(np.diag(inv))) if len(F) else 1.0
    return S


def fit_positive(K_SN: np.ndarray, pairs: np.ndarray, fixed: np.ndarray, weight: str = "temperature",
                 J: np.ndarray | None = None, states: np.ndarray | None = None,
                 state_weight: float = 1000.0) -> PositiveNetwork:
    """Non-negative conductances on ``pairs`` reproducing ``K_SN``'s response (see the module docstring).

    ``K_SN`` (n, n) W/K exact reduced conduction (symmetric, zero row sums); ``pairs`` (m, 2) candidate links;
    ``fixed`` (n,) bool fixed-temperature super nodes.
    """
    K_SN = np.asarray(K_SN, float)
    n = len(K_SN)
    pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
    if not len(pairs):
        raise Fem2TmmError("positive network: no touching super nodes to link")
    Bm = incidence(pairs, n)
    J = K_SN if J is None else np.asarray(J, float)
    T = response_patterns(J, fixed)
    n_generic = T.shape[1]
    if states is not None:  # the solved states themselves, weighted like state_weight x all generic patterns
        X = np.atleast_2d(np.asarray(states, float).T).reshape(n, -1)
        X = X - X.mean(axis=0)
        w = np.sqrt(state_weight) * np.linalg.norm(T) / max(np.linalg.norm(X), 1e-300)
        T = np.c_[T, w * X]
    S = temperature_weights(J, fixed) if weight == "temperature" else np.eye(n)
    BT = Bm @ T  # (m, p) temperature differences across each link
    BS = (Bm @ S)  # (m, n): link e's load pattern seen through the weights
    H = (BS @ BS.T) * (BT @ BT.T)
    c = np.einsum("ep,ep->e", BT, BS @ (S.T @ (K_SN @ T)))
    scale = float(np.abs(np.diag(H)).max(initial=1.0))
    H = H + 1e-13 * scale * np.eye(len(H))  # strictly positive definite for the factor (round-off level)
    L = np.linalg.cholesky(H)
    g, _ = nnls(L.T, sla.solve_triangular(L, c, lower=True), maxiter=50 * len(c))
    # the normal equations square the design's condition number: conductances below 1e-8 of the largest are noise
    keep = g > 1e-8 * max(float(g.max(initial=0.0)), 1e-300)
    gk = g[keep]
    pk = pairs[keep]
    Kp = np.zeros((n, n))
    np.add.at(Kp, (pk[:, 0], pk[:, 1]), -gk)
    np.add.at(Kp, (pk[:, 1], pk[:, 0]), -gk)
    Kp[np.diag_indices(n)] = -Kp.sum(axis=1)
    generic = T[:, :n_generic]
    res = (Kp - K_SN) @ generic
    iu = np.triu_indices(n, 1)
    exact = K_SN[iu]
    report = {
        "candidate_links": int(len(pairs)),
        "links": int(len(pk)),
        "exact_links": int(np.count_nonzero(exact != 0)),
        "exact_negative_links": int(np.count_nonzero(exact > 1e-12 * np.abs(np.diag(K_SN)).max(initial=1.0))),
        # load error of K⁺ on the exact response to unit loads / unit boundary temperatures, relative
        "relative_load_residual": float(np.linalg.norm(res) / max(np.linalg.norm(K_SN @ generic), 1e-300)),
        "min_GL_W_per_K": float(gk.min(initial=np.inf)) if len(gk) else None,
    }
    return PositiveNetwork(K=Kp, pairs=pk, GL=gk, report=report)


def positive_network(K_SN: np.ndarray, A: sp.spmatrix, K_detailed: sp.spmatrix, fixed: np.ndarray,
                     **kw) -> PositiveNetwork:
    """:func:`fit_positive` (keywords passed on) on the touching pairs of the super nodes ``A`` (n_SN, n_dof) over
    the detailed conduction ``K_detailed`` (n_dof, n_dof)."""
    return fit_positive(K_SN, touching_pairs(A, K_detailed), fixed, **kw)


__all__ = ["PositiveNetwork", "fit_positive", "incidence", "positive_network", "response_patterns", "touching_pairs"]
