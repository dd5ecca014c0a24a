"""Automatic grouping of a thermal network (Fernández Rico 2018, ch. 4; equation numbers are the thesis').

1. Sizing matrix (eq. 24–34): for each conductive coupling, ``K^S_ij = μ G_ij / D_ij²`` with
   ``G_ij = 1 / (1/C_i + 1/C_j)`` (one capacitance zero: the other one; both zero: undetermined), ``D_ij`` the
   distance of the node centres and ``μ = 2λ/(ρc)`` (default 3.33e-5 m²/s: λ = 50 W/(m K), ρ = 3000 kg/m³,
   c = 1000 J/(kg K)).  Dimensionless couplings ``K̃ = K / K^S`` (eq. 35).
   Nodes without coordinates (NaN, or the origin, where ESATAN puts nodes without a position): their distances
   are unknown, so K^S and K̃ are zero for all their couplings — they are never condensed ("isolated nodes", the
   thesis' exception handling); the same for a pair whose capacitances are both zero.
2. Boundary isolation (§4.2.2): couplings of boundary nodes are removed from K̃ (K̃^B); internal boundary nodes
   (conductively coupled to a boundary node) are cut from every node that is not one (K̃^I) — couplings among
   internal boundary nodes stay.
3. Filters: ``K̃^I > p_f`` (eq. 36) and ``max over load cases |T_i − T_j| ≤ ΔT_max`` (eq. 37–38); their product
   is the adjacency matrix (eq. 39); its connected components (:func:`scipy.sparse.csgraph.connected_components`)
   are the reduced nodes.
4. Compaction (eq. 41–42): ``K^R = PᵀKP``, ``R^R = PᵀRP``, ``C^R = PᵀC``, ``Q^R = PᵀQ``; targets ``T̄^D`` are the
   capacitance-weighted means of the detailed temperatures (eq. 43; zero-capacitance nodes ignored, arithmetic mean
   when all are zero).
5. Validation (eq. 44–51): steady solve of the reduced network (Newton: the fixed point of eq. 45–47), then
   ``δ_i = |T̄^D_i − T̂^R_i| < δ_max`` on the non-boundary reduced nodes and, per boundary node, conductive and
   radiative heat flows within ``q_max`` (W) when below ``q_lim`` and within ``q̃_max`` (relative to the smaller of
   the two) above it.
6. Sweep over (p_f, ΔT_max): the reduction ratio ``r_r = 1 − (n_c − n_b)/(n_d − n_b)`` (eq. 23) and the pass/fail
   of the criteria on every load case; the chosen pair is the highest ratio that passes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import Fem2TmmError
from .network import LoadCase, Network
from .solve import NetworkSolution, solve_network

#: μ = 2λ/(ρc) with the thesis' typical λ = 50 W/(m K), ρ = 3000 kg/m³, c = 1000 J/(kg K) (§4.2.1)
MU_DEFAULT = 2 * 50.0 / (3000.0 * 1000.0)


@dataclass(frozen=True)
class Criteria:
    """Acceptance criteria of a reduced network (thesis §5.2.1 values as defaults): ``delta_max`` K on the reduced
    nodes' temperatures; boundary heat flows within ``q_max`` W below ``q_lim`` W and within ``q_rel_max``
    (fraction) above it."""

    delta_max: float = 3.0
    q_max: float = 0.1
    q_lim: float = 1.0
    q_rel_max: float = 0.10


# ------------------------------------------------------------------------------------------- sizing and filters
def known_positions(coordinates: np.ndarray | None, n: int) -> np.ndarray:
    """(n,) bool: nodes with a usable position (finite and not exactly the origin, ESATAN's 'no position')."""
    if coordinates is None:
        return np.zeros(n, bool)
    X = np.asarray(coordinates, float)
    return np.isfinite(X).all(axis=1) & (X != 0).any(axis=1)


def sizing_matrix(GL: sp.spmatrix, C: np.ndarray, coordinates: np.ndarray | None = None,
                  distances: sp.spmatrix | None = None, mu: float = MU_DEFAULT) -> sp.csr_matrix:
    """Sizing matrix K^S (n, n) W/K on the pattern of ``GL`` (eq. 32): ``μ G_ij / D_ij²``, zero where undetermined.

    ``C`` (n,) J/K; ``coordinates`` (n, 3) m (NaN / origin: unknown) or ``distances`` (n, n) sparse m given
    directly on GL's pattern (either triangle); ``mu`` m²/s.
    """
    G = sp.triu(sp.csr_matrix(GL), k=1).tocoo()
    i, j = G.row, G.col
    C = np.asarray(C, float)
    ci, cj = C[i], C[j]
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where((ci > 0) & (cj > 0), ci * cj / (ci + cj), np.where(ci > 0, ci, cj))
    if distances is not None:
        Dm = sp.csr_matrix(distances)
        Dm = Dm + Dm.T - sp.diags(Dm.diagonal())
        d = np.asarray(Dm[i, j]).ravel()
    elif coordinates is not None:
        X = np.asarray(coordinates, float)
        ok = known_positions(X, len(C))
        d = np.where(ok[i] & ok[j], np.linalg.norm(np.nan_to_num(X[i] - X[j]), axis=1), 0.0)
    else:
        d = np.zeros(len(i))
    with np.errstate(divide="ignore", invalid="ignore"):
        ks = np.where((d > 0) & (g > 0), mu * g / np.where(d > 0, d, 1.0) ** 2, 0.0)
    keep = ks > 0
    n = len(C)
    KS = sp.coo_matrix((ks[keep], (i[keep], j[keep])), shape=(n, n)).tocsr()
    return (KS + KS.T).tocsr()


def dimensionless(GL: sp.spmatrix, KS: sp.spmatrix) -> sp.csr_matrix:
    """K̃ = GL / K^S element-wise where K^S > 0 (eq. 35), (n, n) sparse symmetric."""
    inv = sp.csr_matrix(KS, dtype=float, copy=True)
    inv.data = 1.0 / inv.data
    out = sp.csr_matrix(GL, dtype=float).multiply(inv).tocsr()
    out.eliminate_zeros()
    return out


def isolate_boundaries(Kt: sp.spmatrix, GL: sp.spmatrix, boundary: np.ndarray,
                       internal: bool = True) -> tuple[sp.csr_matrix, np.ndarray]:
    """K̃^B / K̃^I (§4.2.2): remove every coupling of a boundary node and, with ``internal``, every coupling between
    an internal boundary node (conductively coupled to a boundary node in ``GL``) and a node that is not one.

    Returns the isolated K̃ (n, n) and the internal-boundary mask (n,) bool.
    """
    boundary = np.asarray(boundary, bool)
    GLc = sp.csr_matrix(GL)
    inner = np.zeros(len(boundary), bool)
    if internal and boundary.any():
        inner = (np.asarray(abs(GLc)[:, boundary].sum(axis=1)).ravel() > 0) & ~boundary
    coo = sp.csr_matrix(Kt).tocoo()
    keep = ~boundary[coo.row] & ~boundary[coo.col] & (inner[coo.row] == inner[coo.col])
    out = sp.csr_matrix((coo.data[keep], (coo.row[keep], coo.col[keep])), shape=coo.shape)
    return out, inner


def adjacency(Kt_I: sp.spmatrix, temperatures: np.ndarray, pf: float, dtmax: float) -> sp.csr_matrix:
    """Adjacency (n, n) of eq. 39: ``K̃^I > p_f`` and ``|T_i − T_j| ≤ ΔT_max`` in every load case.

    ``temperatures`` (n_cases, n) K (or (n,)).
    """
    coo = sp.csr_matrix(Kt_I).tocoo()
    T = np.atleast_2d(np.asarray(temperatures, float))
    dT = np.abs(T[:, coo.row] - T[:, coo.col]).max(axis=0) if len(coo.row) else np.zeros(0)
    keep = (coo.data > pf) & (dT <= dtmax)
    return sp.csr_matrix((np.ones(int(keep.sum())), (coo.row[keep], coo.col[keep])), shape=coo.shape)


def components(A: sp.spmatrix) -> tuple[int, np.ndarray]:
    """Connected components of an adjacency matrix: ``(n_c, labels (n,))``, labels in order of first node."""
    n_c, labels = connected_components(sp.csr_matrix(A), directed=False)
    # renumber in order of first appearance (scipy already does; made explicit for the contract)
    first = np.full(n_c, len(labels))
    np.minimum.at(first, labels, np.arange(len(labels)))
    rank = np.empty(n_c, np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(n_c)
    return n_c, rank[labels]


def reduction_ratio(n_d: int, n_c: int, n_b: int) -> float:
    """r_r = 1 − (n_c − n_b)/(n_d − n_b) (eq. 23)."""
    return 1.0 - (n_c - n_b) / (n_d - n_b) if n_d > n_b else 0.0


# ------------------------------------------------------------------------------------------------- compaction
def restriction(labels: np.ndarray, n_c: int | None = None) -> sp.csr_matrix:
    """Restriction matrix P (n_d, n_c): P_ij = 1 when detailed node i belongs to reduced node j (labels < 0: the
    node belongs to none, an empty row)."""
    labels = np.asarray(labels, np.int64)
    n_c = int(labels.max(initial=-1)) + 1 if n_c is None else n_c
    rows = np.flatnonzero(labels >= 0)
    return sp.csr_matrix((np.ones(len(rows)), (rows, labels[rows])), shape=(len(labels), n_c))


def weighted_mean(values: np.ndarray, C: np.ndarray, labels: np.ndarray, n_c: int | None = None) -> np.ndarray:
    """Capacitance-weighted mean per reduced node (eq. 43): zero-capacitance nodes ignored; arithmetic mean when a
    group has no capacitance; nodes with label < 0 ignored.  ``values`` (..., n_d) → (..., n_c)."""
    P = restriction(labels, n_c)
    C = np.clip(np.asarray(C, float), 0.0, None)
    V = np.atleast_2d(np.asarray(values, float))
    cw = np.asarray(P.T @ C).ravel()
    cnt = np.asarray(P.sum(axis=0)).ravel()
    num_c = (P.T @ (V * C).T).T
    num_a = (P.T @ V.T).T
    out = np.where(cw > 0, num_c / np.where(cw > 0, cw, 1.0), num_a / np.maximum(cnt, 1))
    return out if np.ndim(values) > 1 else out[0]


def sum_couplings(M: sp.spmatrix, P: sp.spmatrix) -> sp.csr_matrix:
    """PᵀMP without its diagonal (couplings inside a group vanish), (n_c, n_c) sparse."""
    R = (P.T @ sp.csr_matrix(M) @ P).tocsr()
    R.setdiag(0.0)
    R.eliminate_zeros()
    return R


def assemble_reduced(net: Network, labels: np.ndarray, GL: sp.spmatrix, GR: sp.spmatrix, C: np.ndarray,
                     QI: np.ndarray, note: str) -> Network:
    """The reduced :class:`Network` of ``net`` grouped by ``labels`` (n,) with the given reduced couplings, C and
    QI: each reduced node is numbered, labelled and typed after its member with the smallest node number; T is the
    capacitance-weighted mean; A summed, ALP and EPS area-weighted; position the mean of the known ones."""
    labels = np.asarray(labels, np.int64)
    n_c = int(labels.max(initial=-1)) + 1
    P = restriction(labels, n_c)
    order = np.lexsort((net.numbers, labels))  # per group, smallest number first
    rep = np.empty(n_c, np.int64)
    starts = np.r_[0, np.flatnonzero(np.diff(labels[order])) + 1] if len(order) else order
    rep[labels[order[starts]]] = order[starts]
    X = None
    if net.coordinates is not None:
        ok = known_positions(net.coordinates, net.n)
        Xw = np.where(ok[:, None], np.nan_to_num(net.coordinates), 0.0)
        cnt = np.asarray(P.T @ ok.astype(float)).ravel()
        X = np.where(cnt[:, None] > 0, (P.T @ Xw) / np.maximum(cnt, 1)[:, None], np.nan)
    A = np.asarray(P.T @ net.A).ravel()
    safe = np.where(A > 0, A, 1.0)
    alp = np.where(A > 0, np.asarray(P.T @ (net.alp * net.A)).ravel() / safe, net.alp[rep])
    eps = np.where(A > 0, np.asarray(P.T @ (net.eps * net.A)).ravel() / safe, net.eps[rep])
    return Network(numbers=net.numbers[rep], labels=net.labels[rep], kind=net.kind[rep],
                   T=weighted_mean(net.T, net.C, labels, n_c), C=np.asarray(C, float), A=A, alp=alp, eps=eps,
                   QI=np.asarray(QI, float), GL=sp.csr_matrix(GL), GR=sp.csr_matrix(GR), coordinates=X,
                   source=net.source, notes=net.notes + (note,))


def compact(net: Network, labels: np.ndarray) -> Network:
    """The reduced network of a grouping (eq. 41–42): couplings summed between groups (inside a group they vanish),
    C and QI summed (see :func:`assemble_reduced` for the rest); a group containing a boundary node must be that
    node alone (else :class:`Fem2TmmError`)."""
    labels = np.asarray(labels, np.int64)
    n_c = int(labels.max(initial=-1)) + 1
    P = restriction(labels, n_c)
    size = np.bincount(labels, minlength=n_c)
    bad = net.boundary & (size[labels] > 1)
    if bad.any():
        raise Fem2TmmError(f"{net.source}: boundary {net.describe(np.flatnonzero(bad))} grouped with other nodes; "
                           "boundary nodes must stay alone")
    return assemble_reduced(net, labels, sum_couplings(net.GL, P), sum_couplings(net.GR, P),
                            np.asarray(P.T @ net.C).ravel(), np.asarray(P.T @ net.QI).ravel(),
                            f"grouped {net.n} -> {n_c} nodes")


def compact_case(case: LoadCase, labels: np.ndarray, C: np.ndarray) -> LoadCase:
    """A load case on the reduced network: loads summed, temperatures capacitance-weighted (boundary nodes are
    alone in their group, so theirs are unchanged)."""
    labels = np.asarray(labels, np.int64)
    n_c = int(labels.max(initial=-1)) + 1
    return LoadCase(name=case.name, Q=np.bincount(labels, weights=case.Q, minlength=n_c),
                    T_boundary=weighted_mean(case.T_boundary, C, labels, n_c))


# ------------------------------------------------------------------------------------------------- validation
def flow_errors(HD: np.ndarray, HR: np.ndarray, crit: Criteria) -> tuple[np.ndarray, np.ndarray]:
    """Per boundary flow: the error measure of eq. 50–51 (relative above q_lim, W below) and whether it passes."""
    HD, HR = np.asarray(HD, float), np.asarray(HR, float)
    diff = np.abs(HD - HR)
    big = np.abs(HD) >= crit.q_lim
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = diff / np.minimum(np.abs(HD), np.abs(HR))
    rel = np.where(np.isfinite(rel), rel, np.inf)
    err = np.where(big, rel, diff)
    ok = np.where(big, rel < crit.q_rel_max, diff < crit.q_max)
    return err, ok


@dataclass(frozen=True)
class CaseCheck:
    """Detailed vs reduced in one load case.  ``T_target`` (n_c,) K capacitance-weighted detailed temperatures,
    ``T_reduced`` (n_c,) K, ``delta`` (n_c,) K (0 on boundary nodes); per boundary node of the reduced network
    (``boundary`` indices into it) the conductive / radiative flows (W) detailed and reduced with their error measure
    and pass flags; ``passed`` all criteria."""

    name: str
    T_target: np.ndarray
    T_reduced: np.ndarray
    delta: np.ndarray
    boundary: np.ndarray
    Hc_detailed: np.ndarray
    Hc_reduced: np.ndarray
    Hr_detailed: np.ndarray
    Hr_reduced: np.ndarray
    qc_error: np.ndarray
    qr_error: np.ndarray
    delta_ok: bool
    qc_ok: bool
    qr_ok: bool

    @property
    def passed(self) -> bool:
        return bool(self.delta_ok and self.qc_ok and self.qr_ok)

    def summary(self) -> dict:
        return {"passed": self.passed, "delta_ok": self.delta_ok, "conductive_flows_ok": self.qc_ok,
                "radiative_flows_ok": self.qr_ok, "max_delta_K": float(self.delta.max(initial=0.0)),
                "max_conductive_error": float(self.qc_error.max(initial=0.0)),
                "max_radiative_error": float(self.qr_error.max(initial=0.0))}


def check_case(net: Network, labels: np.ndarray, reduced: Network, case: LoadCase, detailed: NetworkSolution,
               crit: Criteria, rcase: LoadCase | None = None,
               solution: NetworkSolution | None = None) -> tuple[CaseCheck, NetworkSolution]:
    """Solve the reduced network in ``case`` and compare with the detailed solution (eq. 48–51).

    ``labels`` (n_d,) reduced node of each detailed node (-1: none, e.g. a TMRT-suppressed node); ``rcase`` the load
    case on the reduced network (default: :func:`compact_case`); ``solution`` its solution when already known.
    """
    rcase = compact_case(case, labels, net.C) if rcase is None else rcase
    T0 = weighted_mean(detailed.T, net.C, labels, reduced.n)
    sol = solution if solution is not None else solve_network(reduced, rcase, T0=T0)
    target = T0
    b = reduced.boundary
    delta = np.where(b, 0.0, np.abs(target - sol.T))
    # detailed flows per boundary node (boundary nodes are alone in their group: map by label)
    bd = np.flatnonzero(net.boundary)
    br = labels[bd]
    Hc_d, Hr_d = detailed.H_conductive[bd], detailed.H_radiative[bd]
    Hc_r, Hr_r = sol.H_conductive[br], sol.H_radiative[br]
    ec, okc = flow_errors(Hc_d, Hc_r, crit)
    er, okr = flow_errors(Hr_d, Hr_r, crit)
    chk = CaseCheck(name=case.name, T_target=target, T_reduced=sol.T, delta=delta, boundary=br, Hc_detailed=Hc_d,
                    Hc_reduced=Hc_r, Hr_detailed=Hr_d, Hr_reduced=Hr_r, qc_error=ec, qr_error=er,
                    delta_ok=bool((delta < crit.delta_max).all()), qc_ok=bool(okc.all()), qr_ok=bool(okr.all()))
    return chk, sol


# ---------------------------------------------------------------------------------------------------- driver
@dataclass
class Grouper:
    """Everything of the grouping that does not depend on (p_f, ΔT_max): the detailed solutions of the load cases
    and the isolated dimensionless couplings.  Build with :func:`prepare`."""

    net: Network
    cases: list
    detailed: list
    Kt: sp.csr_matrix
    Kt_I: sp.csr_matrix
    internal: np.ndarray
    crit: Criteria
    temperatures: np.ndarray  # (n_cases, n) K
    cache: dict = field(default_factory=dict)

    @property
    def n_b(self) -> int:
        return int(self.net.boundary.sum())

    def labels(self, pf: float, dtmax: float) -> tuple[int, np.ndarray]:
        return components(adjacency(self.Kt_I, self.temperatures, pf, dtmax))

    def evaluate(self, labels: np.ndarray) -> "Grouping":
        """Compact and check a grouping in every load case (cached by partition)."""
        key = np.asarray(labels, np.int64).tobytes()
        if key in self.cache:
            return self.cache[key]
        reduced = compact(self.net, labels)
        checks, sols = [], []
        identity = reduced.n == self.net.n  # nothing grouped: the reduced network is the detailed one
        for case, det in zip(self.cases, self.detailed):
            chk, sol = check_case(self.net, labels, reduced, case, det, self.crit, solution=det if identity else None)
            checks.append(chk)
            sols.append(sol)
        g = Grouping(labels=np.asarray(labels, np.int64), reduced=reduced, checks=checks, solutions=sols,
                     ratio=reduction_ratio(self.net.n, reduced.n, self.n_b))
        self.cache[key] = g
        return g


@dataclass(frozen=True)
class Grouping:
    """One grouping: ``labels`` (n_d,) reduced node of each detailed node, the ``reduced`` network, one
    :class:`CaseCheck` and reduced solution per load case, and the reduction ``ratio``."""

    labels: np.ndarray
    reduced: Network
    checks: list
    solutions: list
    ratio: float

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def groups(self, numbers: np.ndarray) -> list[list[int]]:
        """Groups as lists of detailed node numbers (sorted), in reduced-node order."""
        order = np.lexsort((numbers, self.labels))
        cuts = np.flatnonzero(np.diff(self.labels[order])) + 1
        return [sorted(int(v) for v in numbers[part]) for part in np.split(order, cuts)]


def prepare(net: Network, cases: list[LoadCase] | None = None, crit: Criteria | None = None,
            mu: float = MU_DEFAULT, distances: sp.spmatrix | None = None, internal_boundary: bool = True,
            detailed: list[NetworkSolution] | None = None) -> Grouper:
    """Detailed solutions (unless given) and the isolated K̃ of ``net`` (active nodes only)."""
    net = net.active()
    cases = [net.default_case()] if not cases else list(cases)
    crit = crit or Criteria()
    if detailed is None:
        detailed = [solve_network(net, c) for c in cases]
    KS = sizing_matrix(net.GL, net.C, coordinates=net.coordinates, distances=distances, mu=mu)
    Kt = dimensionless(net.GL, KS)
    Kt_I, inner = isolate_boundaries(Kt, net.GL, net.boundary, internal=internal_boundary)
    return Grouper(net=net, cases=cases, detailed=list(detailed), Kt=Kt, Kt_I=Kt_I, internal=inner, crit=crit,
                   temperatures=np.array([d.T for d in detailed]))


def group(grouper: Grouper, pf: float, dtmax: float) -> Grouping:
    """Group at thresholds ``pf`` (dimensionless) and ``dtmax`` (K) and check the result."""
    _, labels = grouper.labels(pf, dtmax)
    return grouper.evaluate(labels)


@dataclass(frozen=True)
class Sweep:
    """Reduction-ratio map over ``pf`` (a,) × ``dtmax`` (b,): ``ratio``, ``passed`` (a, b), ``max_delta`` (a, b) K
    (worst case), ``n_c`` (a, b); ``best`` (i, j) index of the highest passing ratio or None."""

    pf: np.ndarray
    dtmax: np.ndarray
    ratio: np.ndarray
    passed: np.ndarray
    max_delta: np.ndarray
    n_c: np.ndarray
    best: tuple | None


def sweep(grouper: Grouper, pf_values, dtmax_values) -> Sweep:
    """Evaluate every (p_f, ΔT_max) pair (identical partitions are solved once) and pick the highest ratio that
    passes all criteria in all load cases (ties: the smaller worst δ)."""
    pf_values = np.asarray(pf_values, float)
    dt_values = np.asarray(dtmax_values, float)
    shape = (len(pf_values), len(dt_values))
    ratio, md, nc = np.zeros(shape), np.zeros(shape), np.zeros(shape, np.int64)
    passed = np.zeros(shape, bool)
    for a, pf in enumerate(pf_values):
        for b, dt in enumerate(dt_values):
            g = group(grouper, pf, dt)
            ratio[a, b] = g.ratio
            passed[a, b] = g.passed
            md[a, b] = max(float(c.delta.max(initial=0.0)) for c in g.checks)
            nc[a, b] = g.reduced.n
    best = None
    if passed.any():
        cand = np.argwhere(passed)
        keys = [(-ratio[i, j], md[i, j]) for i, j in cand]
        best = tuple(int(v) for v in cand[min(range(len(cand)), key=keys.__getitem__)])
    return Sweep(pf=pf_values, dtmax=dt_values, ratio=ratio, passed=passed, max_delta=md, n_c=nc, best=best)


__all__ = [
    "Criteria", "CaseCheck", "Grouper", "Grouping", "MU_DEFAULT", "Sweep", "adjacency", "assemble_reduced",
    "check_case", "compact", "compact_case", "components", "dimensionless", "flow_errors", "group",
    "isolate_boundaries", "known_positions", "prepare", "reduction_ratio", "restriction", "sizing_matrix",
    "sum_couplings", "sweep", "weighted_mean",
]
