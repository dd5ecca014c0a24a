"""TMRT reduction of a network with user sets of Kept, Suppressed and Grouped nodes (TMRT 2009 slides 9–21).

- **Suppressed** nodes (conduction-only: no GR, not boundary) are condensed exactly by the Schur complement of the
  conduction matrix: ``K' = K_RR − K_RS K_SS⁻¹ K_SR`` over the remaining nodes R.  Their loads go to R through the
  *power distribution factors* ``PD = −K_RS K_SS⁻¹`` (columns sum to 1); their temperatures come back through the
  *temperature recovery factors* ``T_S = TRt T_R + TRq Q_S`` with ``TRt = −K_SS⁻¹ K_SR`` (rows sum to 1) and
  ``TRq = K_SS⁻¹``.  Exact in steady state whatever the loads and radiation on R (suppressed nodes are linear).
- **Grouped** nodes become one average node per group: couplings summed (conductive after the condensation, and
  radiative), dissipation summed, temperature the capacitance-weighted average (the TMRT hypothesis: fluxes and
  radiative exchange proportional to the node's share; radiative error of second order in the spread).
- **Capacitance**: ``"equivalent"`` — TMRT's equivalent capacitance matrix ``TRᵀ M TR`` made diagonal by row
  sums, i.e. every suppressed node's capacitance distributed by its recovery factors (total conserved), groups
  summed; or ``"summed"`` — groups summed and each suppressed node's capacitance given wholly to the reduced node
  with its largest recovery factor (the "user affectation" of TMRT, made automatic).
- Post-processing: **RA** (recomputed average of a set of detailed nodes from the recovered temperatures) and
  **CE** (conductive exchange between two sets).  Filtering of small couplings: :func:`fem2tmm.reduce.filters.
  filter_links` on the reduced conduction matrix (symmetric, zero row sums preserved).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import Fem2TmmError
from ..linalg import factorize
from ..reduce.filters import filter_links
from .grouping import assemble_reduced, restriction, sum_couplings, weighted_mean
from .network import Network


@dataclass(frozen=True)
class TmrtReduction:
    """Result of :func:`tmrt_reduce`.

    ``reduced`` the reduced network (kept nodes and one average node per group, in the detailed order of their first
    member); ``labels`` (n_d,) reduced node of every detailed node (-1: suppressed); ``suppressed`` (n_s,) detailed
    indices; ``remaining`` (n_r,) detailed indices of the kept and grouped nodes; ``PD`` (n_red, n_s) power
    distribution factors onto the reduced nodes; ``TRt`` (n_s, n_red) temperature recovery factors from the reduced
    temperatures; ``report`` counts and the filter report.
    """

    detailed: Network
    reduced: Network
    labels: np.ndarray
    suppressed: np.ndarray
    remaining: np.ndarray
    PD: np.ndarray
    TRt: np.ndarray
    lu: object = None
    report: dict = field(default_factory=dict)

    def recover(self, T_reduced: np.ndarray, Q_suppressed: np.ndarray | None = None) -> np.ndarray:
        """Detailed temperatures (n_d,) K: kept nodes their own, grouped nodes their group's, suppressed nodes
        ``TRt T_red + K_SS⁻¹ Q_S`` (``Q_suppressed`` (n_s,) W, default the deck's QI on them)."""
        T_reduced = np.asarray(T_reduced, float)
        T = np.empty(self.detailed.n)
        keep = self.labels >= 0
        T[keep] = T_reduced[self.labels[keep]]
        if len(self.suppressed):
            Qs = self.detailed.QI[self.suppressed] if Q_suppressed is None else np.asarray(Q_suppressed, float)
            T[self.suppressed] = self.TRt @ T_reduced + (self.lu.solve(Qs) if np.any(Qs) else 0.0)
        return T


def _sets(net: Network, suppress, groups) -> tuple[np.ndarray, list[np.ndarray]]:
    s = net.index(np.asarray(list(suppress), np.int64), where=f"{net.source}: suppressed nodes")
    gs = [net.index(np.asarray(list(g), np.int64), where=f"{net.source}: group {k + 1}") for k, g in enumerate(groups)]
    allg = np.concatenate(gs) if gs else np.zeros(0, np.int64)
    u, c = np.unique(np.r_[s, allg], return_counts=True)
    if (c > 1).any():
        raise Fem2TmmError(f"{net.source}: {net.describe(u[c > 1])} are listed twice (suppressed and/or in several "
                           "groups); each node is kept, suppressed or in one group")
    b = net.boundary
    if b[s].any():
        raise Fem2TmmError(f"{net.source}: boundary {net.describe(s[b[s]])} cannot be suppressed")
    for k, g in enumerate(gs):
        if len(g) > 1 and b[g].any():
            raise Fem2TmmError(f"{net.source}: group {k + 1} contains boundary {net.describe(g[b[g]])}; boundary "
                               "nodes cannot be grouped with others")
    radiative = np.asarray(abs(net.GR)[s].sum(axis=1)).ravel() > 0 if len(s) else np.zeros(0, bool)
    if radiative.any():
        raise Fem2TmmError(f"{net.source}: suppressed {net.describe(s[radiative])} have radiative couplings (GR); "
                           "only conduction-only nodes can be suppressed exactly — group them or keep them")
    return s, gs


def tmrt_reduce(net: Network, suppress=(), groups=(), capacitance: str = "equivalent",
                filter_threshold: float = 0.0) -> TmrtReduction:
    """Reduce ``net`` (active nodes) with node numbers to ``suppress`` and ``groups`` (lists of node numbers); all
    other nodes are kept.  ``capacitance`` "equivalent" | "summed"; ``filter_threshold`` in [0, 1) for
    :func:`~fem2tmm.reduce.filters.filter_links` (0: no filter).  See the module docstring for the mathematics.
    """
    if capacitance not in ("equivalent", "summed"):
        raise Fem2TmmError(f"capacitance = {capacitance!r}: expected 'equivalent' or 'summed'")
    net = net.active()
    s, gs = _sets(net, suppress, groups)
    n = net.n
    is_s = np.zeros(n, bool)
    is_s[s] = True
    r = np.flatnonzero(~is_s)
    s = np.flatnonzero(is_s)
    # reduced node of every remaining node: groups share one, others alone; ordered by first member
    grp = np.full(n, -1, np.int64)
    for k, g in enumerate(gs):
        grp[g] = k
    key = np.where(grp[r] >= 0, -1 - grp[r], r)  # a group is identified by its (negative) id
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    lab_r = rank[inv.ravel()]
    n_red = len(first)
    labels = np.full(n, -1, np.int64)
    labels[r] = lab_r
    P = restriction(lab_r, n_red)  # (n_r, n_red)
    K = net.K()
    Krr = K[r][:, r].tocsr()
    PD = np.zeros((n_red, len(s)))
    TRt = np.zeros((len(s), n_red))
    lu = None
    if len(s):
        Kss = K[s][:, s].tocsc()
        Ksr = K[s][:, r].tocsc()
        adj = np.flatnonzero(np.diff(Ksr.indptr))  # remaining nodes touching a suppressed one
        try:
            lu = factorize(Kss, "pivoting")
            X = lu.solve(Ksr[:, adj].toarray()) if len(adj) else np.zeros((len(s), 0))
        except RuntimeError:
            X = None
        if X is None or not np.all(np.isfinite(X)):
            raise Fem2TmmError(f"{net.source}: some suppressed nodes are not conductively connected to any kept or "
                               "grouped node (their temperature is undetermined); keep one of them")
        tr = np.zeros((len(s), len(r)))
        tr[:, adj] = -X  # TRt on the remaining nodes (n_s, n_r)
        corr = Ksr[:, adj].T @ X  # K_RS K_SS⁻¹ K_SR on the adjacent block
        Kp = Krr - sp.csr_matrix((corr.ravel(), (np.repeat(adj, len(adj)), np.tile(adj, len(adj)))),
                                 shape=Krr.shape)
        TRt = tr @ P.toarray()
        PD = TRt.T.copy()  # −K_RS K_SS⁻¹ = TRtᵀ by symmetry, summed per reduced node
    else:
        Kp = Krr
    Kred = (P.T @ Kp @ P).toarray()
    Kred = 0.5 * (Kred + Kred.T)
    report = {"kept": int(len(r) - sum(len(g) for g in gs)),
              "suppressed": int(len(s)), "groups": len(gs), "reduced_nodes": n_red}
    if filter_threshold > 0:
        Kred, report["filter"] = filter_links(Kred, filter_threshold)
    GLred = -Kred
    np.fill_diagonal(GLred, 0.0)
    GLred[np.abs(GLred) < 1e-14 * max(np.abs(GLred).max(initial=0.0), 1e-300)] = 0.0
    C_r = net.C[r]
    C_red = np.asarray(P.T @ C_r).ravel()
    if len(s) and capacitance == "equivalent":
        C_red = C_red + TRt.T @ net.C[s]
    elif len(s):
        C_red = C_red + np.bincount(np.argmax(TRt, axis=1), weights=net.C[s], minlength=n_red)
    Q_red = np.asarray(P.T @ net.QI[r]).ravel() + (PD @ net.QI[s] if len(s) else 0.0)
    reduced = assemble_reduced(net.subset(r), lab_r, sp.csr_matrix(GLred), sum_couplings(net.GR[r][:, r], P), C_red,
                               Q_red, f"TMRT: {len(s)} suppressed, {len(gs)} groups, {n} -> {n_red} nodes")
    return TmrtReduction(detailed=net, reduced=reduced, labels=labels, suppressed=s, remaining=r, PD=PD, TRt=TRt,
                         lu=lu, report=report)


def recomputed_average(net: Network, T: np.ndarray, nodes) -> float:
    """RA: capacitance-weighted average temperature (K) of the detailed ``nodes`` (numbers) at detailed T (n,) K."""
    idx = net.index(np.asarray(list(nodes), np.int64), where=f"{net.source}: RA nodes")
    return float(weighted_mean(np.asarray(T)[idx], net.C[idx], np.zeros(len(idx), np.int64), 1)[0])


def conductive_exchange(net: Network, T: np.ndarray, nodes_a, nodes_b) -> float:
    """CE: heat (W) conducted from the detailed node set ``nodes_a`` to ``nodes_b`` (numbers; disjoint) at T (n,) K:
    ``Σ_{i∈a, j∈b} GL_ij (T_i − T_j)``."""
    a = net.index(np.asarray(list(nodes_a), np.int64), where=f"{net.source}: CE first set")
    b = net.index(np.asarray(list(nodes_b), np.int64), where=f"{net.source}: CE second set")
    if np.intersect1d(a, b).size:
        raise Fem2TmmError(f"{net.source}: CE sets share {net.describe(np.intersect1d(a, b))}")
    T = np.asarray(T, float)
    G = net.GL[a][:, b]
    return float(T[a] @ np.asarray(G.sum(axis=1)).ravel() - np.asarray(G.sum(axis=0)).ravel() @ T[b])


__all__ = ["TmrtReduction", "conductive_exchange", "recomputed_average", "tmrt_reduce"]
