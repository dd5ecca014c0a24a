"""Steady conductive-radiative network solver (detailed and reduced models alike).

Solves for the free temperatures T (K) of

    r(T) = K T + σ L T⁴ + σ g (T⁴ − T_sink⁴) − Q = 0,      L = diag(GR·1) − GR,

with K (n, n) the conduction matrix (W/K; sparse or dense), GR (n, n) node-to-node radiative
couplings (m², symmetric; optional), g (n,) radiative coupling of each node to the sink (m²), Q (n,) the
applied loads (W), and some nodes held at fixed temperatures.  Radiation may also be given in
factored form GR = Wᵀ G W (faces -> nodes), which keeps the detailed model sparse.

Newton's method with a positivity-preserving damping and a backtracking line search on the residual
norm: it converges from any uniform start between 3 K and 1000 K.  The energy balance (heat supplied
by the fixed nodes + applied loads = heat radiated to space) is part of the result.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..constants import SIGMA
from ..errors import Fem2TmmError
from ..linalg import factorize, roundoff


@dataclass(frozen=True)
class FacedRadiation:
    """Face-to-face radiation in factored form: node couplings ``Wᵀ G W``.

    ``W`` (f, n) sparse, rows sum to 1 (a face's irradiating T⁴ = W T⁴, the area-weighted nodal average);
    ``G`` (f, f) sparse symmetric face couplings GR (m²) without the space column.

    The net heat a node radiates to the other faces is the Laplacian of the node couplings ``C = Wᵀ G W``,
    ``σ [diag(C 1) T⁴ − C T⁴]``: each node emits at its own T⁴ with the εA its faces lend it (lumped, like its
    emission to space ``g_space`` and like every network node), and absorbs what the faces it belongs to
    receive.  Symmetric, zero row sums (an isothermal enclosure exchanges nothing), the sum over nodes is zero
    (energy is conserved).  The other discretisation, emission at the face-averaged T⁴ spread back by Wᵀ
    (``Wᵀ diag(G 1) W T⁴``), mixes forms with the lumped space term and differs from the radiation-aware
    reduction's lumped ``e ⊙ T⁴`` by 0.25 K RMS on the composite box, where the mesh barely resolves the fin
    length (examples/composite/README.md): one emission form throughout keeps the reduced models and their
    reference the same discretised problem.
    """

    W: sp.csr_matrix
    G: sp.csr_matrix


@dataclass(frozen=True)
class SteadyProblem:
    """A steady network.  Shapes: K (n, n); Q, g, T_fixed (n,); fixed (n,) bool."""

    K: object
    Q: np.ndarray
    fixed: np.ndarray
    T_fixed: np.ndarray
    g_space: np.ndarray
    T_sink: float
    GR: object | None = None  # (n, n) node-to-node radiative couplings, m²
    faced: FacedRadiation | None = None
    names: tuple[str, ...] | None = None
    #: ``(x, y)``, both (n, m): each node's coupling to the sink as a piecewise-linear function of its own
    #: temperature (knots ``x`` K ascending per row, values ``y`` m², constant beyond the end knots: the emission
    #: then grows as σ y_end T⁴); ``g_space`` is then only the start's value.  None: ``g_space`` constant
    g_table: tuple | None = None


def table_value(x: np.ndarray, y: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-row piecewise-linear interpolation ``(v, dv/dT)`` (n,) of tables ``x``, ``y`` (n, m) at ``T`` (n,),
    constant beyond each row's end knots (like ESATAN's INTRP1), ``dv/dT`` 0 there."""
    x, y, T = np.asarray(x, float), np.asarray(y, float), np.asarray(T, float)
    m = x.shape[1]
    if m == 1:
        return y[:, 0].copy(), np.zeros(len(T))
    k = np.clip((x <= T[:, None]).sum(axis=1) - 1, 0, m - 2)[:, None]
    x0, x1 = np.take_along_axis(x, k, 1)[:, 0], np.take_along_axis(x, k + 1, 1)[:, 0]
    y0, y1 = np.take_along_axis(y, k, 1)[:, 0], np.take_along_axis(y, k + 1, 1)[:, 0]
    slope = np.divide(y1 - y0, x1 - x0, out=np.zeros(len(T)), where=x1 > x0)
    inside = (T > x[:, 0]) & (T < x[:, -1])
    Tc = np.clip(T, x[:, 0], x[:, -1])
    v = np.where(Tc <= x0, y0, y0 + slope * (Tc - x0))
    return v, np.where(inside, slope, 0.0)


@dataclass(frozen=True)
class SteadySolution:
    """Temperatures (K) of every node and the energy balance (W).

    ``heat_fixed`` (n,) heat flowing INTO the model at each fixed node (0 elsewhere), ``to_space`` (n,) heat
    radiated to the sink by each node; ``balance`` = {applied, fixed, space, imbalance, relative}.
    """

    T: np.ndarray
    iterations: int
    converged: bool
    max_step: float
    heat_fixed: np.ndarray
    to_space: np.ndarray
    balance: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)


class _Operators:
    """The problem's operators, built once: K, the node Laplacian of GR, and the factored face Laplacian."""

    def __init__(self, problem: SteadyProblem):
        self.p = problem
        K = problem.K
        if sp.issparse(K) and K.shape[0] <= DENSE_NETWORK and K.nnz >= DENSE_FILL * K.shape[0] ** 2:
            K = K.toarray()  # a network's conduction (a reduced one is dense): dense Jacobians cost less
        self.dense = not sp.issparse(K)
        self.K = np.asarray(K, float) if self.dense else sp.csr_matrix(K)
        self.L = None
        if problem.GR is not None:
            GR = problem.GR
            if sp.issparse(GR):
                GR = sp.csr_matrix(GR)
                GR = GR - sp.diags(GR.diagonal())
                self.L = (sp.diags(np.asarray(GR.sum(axis=1)).ravel()) - GR).tocsr()
                if self.dense:
                    self.L = self.L.toarray()
            else:
                GR = np.array(GR, float)
                np.fill_diagonal(GR, 0.0)
                self.L = np.diag(GR.sum(axis=1)) - GR
        self.W = self.Gf = None
        if problem.faced is not None:
            G = sp.csr_matrix(problem.faced.G)
            self.Gf = (G - sp.diags(G.diagonal())).tocsr()
            self.W = sp.csr_matrix(problem.faced.W)
            # each node's emitting share of the face couplings, diag(Wᵀ G W 1) = Wᵀ G 1 (W 1 = 1), m²
            self.face_lumped = np.asarray(self.W.T @ np.asarray(self.Gf.sum(axis=1)).ravel()).ravel()
        self.g = np.asarray(problem.g_space, float)
        self.dg = None  # σ g'(T)(T⁴ − T_s⁴) at the last state (W/K), with a g_table
        self.radiative = bool((self.g > 0).any() or self.L is not None or self.Gf is not None
                              or problem.g_table is not None)

    def lone(self, free: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(nodes, T)``: the free nodes coupled only radiatively, by constant couplings, to the sink and to fixed
        nodes (no conductor, no free radiative neighbour, no face radiation, a ``g_table`` row of one value: a deck's
        hot-spot node, an arithmetic radiator), and their temperatures with the fixed ones ``T`` (n,) K, from
        σ (g + Σ GR) T⁴ = Q + σ (g T_s⁴ + Σ GR T_fixed⁴) (a node whose right side is not positive left out)."""
        p = self.p
        n = len(self.g)
        on = np.zeros(n, bool)
        on[free] = True
        g = np.array(self.g, float)
        if p.g_table is not None:  # a table of one value is that constant coupling
            y = np.asarray(p.g_table[1], float)
            on &= np.all(y == y[:, :1], axis=1)
            g = y[:, 0].copy()
        if self.dense:
            nz = self.K != 0
            on &= ~(nz.any(axis=1) | nz.any(axis=0))
        else:  # no stored entry in its row or column (without a copy of K: a detailed model's is large)
            on &= (np.diff(self.K.indptr) == 0) & (np.bincount(self.K.indices, minlength=n) == 0)
        if self.W is not None:
            on &= np.asarray(abs(self.W).sum(axis=0)).ravel() == 0
        if not on.any():  # (a detailed model: every node conducts)
            return np.zeros(0, np.int64), np.zeros(0)
        a, b = g, g * p.T_sink**4
        if self.L is not None:
            held_T4 = T**4  # (the fixed nodes' only: a lone node has no free radiative neighbour)
            held_T4[free] = 0.0
            if sp.issparse(self.L):
                L = sp.csr_matrix(self.L)
                diag = L.diagonal()
                off = (L - sp.diags(diag)).tocsr()
                touched = np.asarray(abs(off)[:, free].sum(axis=1)).ravel() > 0
                b = b - np.asarray(off @ held_T4).ravel()
            else:
                diag = np.diag(self.L).copy()
                off = self.L - np.diag(diag)
                touched = np.abs(off[:, free]).sum(axis=1) > 0
                b = b - off @ held_T4
            on &= ~touched
            a = a + diag
        idx = np.flatnonzero(on & (a > 0))
        T4 = (p.Q[idx] / SIGMA + b[idx]) / a[idx]
        keep = T4 > 0.0
        return idx[keep], T4[keep] ** 0.25

    def at(self, T: np.ndarray) -> None:
        """The sink couplings at the state T (a ``g_table``: each node's own temperature), else nothing."""
        if self.p.g_table is not None:
            self.g, dg = table_value(*self.p.g_table, T)
            self.dg = SIGMA * dg * (T**4 - self.p.T_sink**4)

    def radiation(self, T4: np.ndarray) -> np.ndarray:
        """Net radiated heat (n,) W for nodal T⁴ (without the space term)."""
        out = np.zeros_like(T4)
        if self.L is not None:
            out = out + self.L @ T4
        if self.Gf is not None:  # the Laplacian of the node couplings Wᵀ G W (class FacedRadiation)
            out = out + self.face_lumped * T4 - self.W.T @ (self.Gf @ (self.W @ T4))
        return SIGMA * np.asarray(out).ravel()

    def emitting(self) -> np.ndarray:
        """Each node's radiative conductance, to space and to the other nodes (n,) m² (ε A-like)."""
        e = np.array(self.g, float)
        if self.L is not None:
            e = e + (self.L.diagonal() if sp.issparse(self.L) else np.diag(self.L))
        if self.Gf is not None:
            e = e + self.face_lumped
        return e

    def residual(self, T: np.ndarray) -> np.ndarray:
        p = self.p
        self.at(T)
        T4 = T**4
        r = self.K @ T + SIGMA * self.g * (T4 - p.T_sink**4) - p.Q + self.radiation(T4)
        return np.asarray(r).ravel()

    def jvp(self, d: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Jacobian-vector product J x with d = 4σT³ (full-length vectors)."""
        y = self.K @ x + d * self.g * x + (0.0 if self.dg is None else self.dg * x)
        dx = d * x / SIGMA
        return np.asarray(y).ravel() + self.radiation(dx)

    def jacobian(self, d: np.ndarray, free: np.ndarray, lumped_faces: bool = False):
        """Assembled Jacobian on the free nodes; with ``lumped_faces`` the face radiation is replaced by its
        lumped diagonal (the Newton-Krylov preconditioner)."""
        n = len(d)
        if self.dense:
            J = np.array(self.K, float)
            if self.L is not None:
                J = J + self.L * d[None, :]
            J[np.diag_indices(n)] += d * self.g + (0.0 if self.dg is None else self.dg)
            if self.Gf is not None:
                J[np.diag_indices(n)] += d * self.face_lumped
                J = J - (self.W.T @ (self.Gf @ (self.W @ sp.diags(d)))).toarray()
            return J[np.ix_(free, free)]
        J = self.K + sp.diags(d * self.g + (0.0 if self.dg is None else self.dg))
        if self.L is not None:
            J = J + sp.csr_matrix(self.L) @ sp.diags(d)
        if self.Gf is not None:
            J = J + sp.diags(d * self.face_lumped)
            if not lumped_faces:
                J = J - self.W.T @ (self.Gf @ (self.W @ sp.diags(d)))
        J = sp.csr_matrix(J)
        return J[free][:, free].tocsc()


def residual(problem: SteadyProblem, T: np.ndarray) -> np.ndarray:
    """r(T) (n,) in W: net heat leaving each node minus its applied load."""
    return _Operators(problem).residual(T)


def check_solvable(problem: SteadyProblem, describe=None) -> None:
    """Raise if a connected set of free nodes has neither a fixed temperature nor radiation.

    ``describe(node_indices) -> str`` names the culprit part(s) for the message.
    """
    K = problem.K
    A = sp.csr_matrix(K) if sp.issparse(K) else sp.csr_matrix(np.asarray(K))
    A = abs(A)
    if problem.GR is not None:
        A = A + abs(sp.csr_matrix(problem.GR))
    if problem.faced is not None:
        W = sp.csr_matrix(problem.faced.W)
        A = A + abs(W.T @ (abs(sp.csr_matrix(problem.faced.G)) @ W))
    ncomp, comp = sp.csgraph.connected_components(A, directed=False)
    anchored = np.zeros(ncomp, bool)
    anchored[np.unique(comp[problem.fixed])] = True
    anchored[np.unique(comp[problem.g_space > 0])] = True
    bad = np.flatnonzero(~anchored)
    if len(bad):
        nodes = np.flatnonzero(np.isin(comp, bad))
        what = describe(nodes) if describe else f"{len(nodes)} nodes"
        raise Fem2TmmError(
            f"the model has {len(bad)} connected part(s) with neither a fixed temperature nor radiation to space "
            f"({what}); their temperature is undetermined: add a temperature boundary, an active radiating side, "
            "or a conductive connection to the rest of the model"
        )


#: Newton also stops, for a field with a node below COLD_FIELD (K), once the free nodes' residuals sum to less than
#: RESIDUAL_FLOOR times the heat-flow scale (loads + the start's imbalance, W); and for a field within COLD_TOLERANCE
#: (K) of 0 K everywhere, once they sum to less than COLD_RESIDUAL times what its radiating nodes would emit at
#: COLD_FIELD (σ Σ g x 1 K⁴, W: a field at 0.3 K residual at most, loads at round-off, 1e-16 W, of a correction
#: formed at a cold state).  Near 0 K the Jacobian 4σεA·T³ vanishes (a 0 K sink and no load: T -> 3/4 T per step,
#: singular in floating point below ~1 mK), so the step criterion alone cannot be met there
RESIDUAL_FLOOR = 1e-11
COLD_FIELD = 1.0
COLD_RESIDUAL = 1e-2
COLD_TOLERANCE = 0.03
#: Newton also stops once it no longer contracts (a step over half the previous one) with the free nodes' residuals
#: below STALL_RESIDUAL of the gross heat flows or at the round-off of the conduction terms (linalg.roundoff): the
#: round-off floor of an ill-conditioned model, where the step
#: criterion cannot be met in floating point
STALL_RESIDUAL = 1e-10
#: the energy balance's scale is at least BALANCE_FLOOR of the start's heat flows, and at least the model's emission
#: at BALANCE_COLD kelvin (a model whose flows are smaller, a field at or near 0 K, is measured against that)
BALANCE_FLOOR = 1e-2
BALANCE_CONDUCTION = 1e-4
BALANCE_COLD = 10.0
#: trust region: one Newton step multiplies a node's temperature by at most 1 + MAX_GROWTH and divides it by at most
#: 1 / (1 - MAX_DROP) (a cold start under a strong load would otherwise jump to 1e20 K on the T³-small Jacobian)
MAX_GROWTH = 4.0
MAX_DROP = 0.8
#: a sparse conduction matrix of at most DENSE_NETWORK nodes and at least DENSE_FILL of its entries non-zero is
#: solved dense: an exported network's (the reduction's Schur complement is dense), read back by fem2tmm.lpm as a
#: sparse matrix.  examples/composite's deck (103 nodes, 96 % full), its heater edited: 11.5 -> 4.8 ms a solve
#: (5 Newton steps, min of 5, 2026-12-07)
DENSE_NETWORK = 4000
DENSE_FILL = 0.25
#: most free nodes for which a sparse Jacobian with a zero pivot is solved densely instead (step_solve)
DENSE_FALLBACK = 4000


def solve_steady(problem: SteadyProblem, T0: float | np.ndarray | None = None, tol: float = 1e-9,
                 max_iter: int = 200) -> SteadySolution:
    """Solve the steady network by damped Newton.

    ``T0`` start temperature(s) in K (default: mean of the fixed temperatures, else the sink).
    Stops when max|ΔT| < ``tol`` K (or below round-off, 1e-13 x max T); at the round-off floor of an
    ill-conditioned model (:data:`STALL_RESIDUAL`); or, for a field at or near 0 K, on the residual floors of
    :data:`RESIDUAL_FLOOR` and :data:`COLD_RESIDUAL` (``stats["stopped_on"]`` says which; docs/case-file.md,
    [solver]).  Each step stays in a trust region (:data:`MAX_GROWTH`, :data:`MAX_DROP`).  Sparse problems with factored
    face radiation use Newton-Krylov: GMRES on the exact Jacobian, preconditioned by the LU of the
    conduction matrix plus the lumped radiative conductances (the exact Jacobian would be dense-ish).
    """
    n = len(problem.Q)
    fixed = np.asarray(problem.fixed, bool)
    free = np.flatnonzero(~fixed)
    if T0 is None:
        T0 = float(np.mean(problem.T_fixed[fixed])) if fixed.any() else max(problem.T_sink, 3.0)
        # no colder than the whole model's radiative equilibrium with its loads (radiation-dominated nodes converge
        # monotonically from above, T⁴ being convex; from far below, the first steps overshoot)
        g_tot = float(np.sum(problem.g_space))
        q_tot = float(np.sum(problem.Q[~fixed]))
        if g_tot > 0 and q_tot > 0:
            T0 = max(T0, float(((q_tot / (SIGMA * g_tot)) + problem.T_sink**4) ** 0.25))
    T = np.broadcast_to(np.asarray(T0, float), (n,)).copy()
    T[fixed] = problem.T_fixed[fixed]
    if np.any(T[free] <= 0) or np.any(T[fixed] < 0):  # a fixed node may sit at 0 K (a deck's space node)
        raise Fem2TmmError("start temperatures must be above absolute zero, fixed ones at or above it")
    ops = _Operators(problem)
    krylov = (not ops.dense) and ops.Gf is not None
    lone, T_lone = ops.lone(free, T)
    # nodes whose only couplings are constant radiative ones to the sink and to fixed nodes (a deck's hot-spot node, an
    # arithmetic radiator): their balance in closed form, after which their Newton steps are zero.  From a start far
    # above it, Newton on T⁴ takes at most a quarter of a temperature a step (the L-bracket's composite deck edited to
    # its heater at 0 W: 21 steps, its hot-spot node from 400 K down to the sink)
    T[lone] = T_lone
    cache = {}
    stats = {"gmres_iterations": 0}

    def step_solve(T, b):
        # a purely conductive problem has a constant Jacobian: factorise it once
        if not ops.radiative and "lu" in cache:
            return cache["lu"](b)
        d = 4 * SIGMA * T**3
        ops.at(T)
        if ops.dense:
            return np.linalg.solve(ops.jacobian(d, free), b)
        if krylov:
            return _newton_krylov_step(ops, d, free, b, stats)
        # K + diag(4σT³g) is SPD; with node-to-node radiation, L diag(4σT³) makes it unsymmetric
        J = ops.jacobian(d, free)
        try:
            lu = factorize(J, "spd" if ops.L is None else "general")
        except RuntimeError:  # SuperLU's "Factor is exactly singular": a zero pivot, not necessarily a singular J
            # a network with zero row sums near 0 K (its emission conductance 4σεA·T³ ~1e-19 W/K beside a conduction
            # of 1e-3 W/K): the sparse LU without pivoting meets an exact zero; the dense LU pivots through it.
            # Too large for a dense solve: the singular-Jacobian refusal below (LinAlgError)
            if len(free) > DENSE_FALLBACK:
                raise np.linalg.LinAlgError("singular sparse Jacobian") from None
            return np.linalg.solve(J.toarray(), b)
        if not ops.radiative:
            cache["lu"] = lu.solve
        return lu.solve(b)

    r = ops.residual(T)
    rn = np.linalg.norm(r[free])
    # the residual criterion's scale (W): the applied loads and the start's imbalance (its heat flows); a field at or
    # near 0 K (a 0 K sink, no load) converges on it, where the step criterion alone would follow T -> 3/4 T towards
    # an underflowing Jacobian
    flow_scale = float(np.abs(problem.Q).sum() + np.abs(r).sum()) + 1e-300
    emitting = ops.emitting()
    cold_scale = SIGMA * COLD_FIELD**4 * float(emitting[free].sum())
    cold_floor = COLD_RESIDUAL * cold_scale

    def gross_flows(T, r):
        """Gross heat flows (W): loads, into the fixed nodes, emitted and absorbed from the sink."""
        return (float(np.abs(problem.Q).sum() + np.abs(r[fixed]).sum())
                + SIGMA * float(emitting @ (T**4 + problem.T_sink**4)))

    converged, it, step, prev_full = False, 0, np.inf, None
    if len(free) == 0:
        converged = True
    while not converged and it < max_iter:
        it += 1
        res = np.abs(r[free]).sum()
        if ((T[free].min(initial=np.inf) < COLD_FIELD and res <= RESIDUAL_FLOOR * flow_scale)
                or (T[free].max(initial=0.0) < COLD_TOLERANCE and res <= cold_floor)):
            step, converged = 0.0, True
            stats["stopped_on"] = "cold field"
            break
        try:
            dT = np.asarray(step_solve(T, -r[free])).ravel()
        except np.linalg.LinAlgError:
            raise Fem2TmmError(f"the steady solve met a singular Jacobian at Newton iteration {it} (residual "
                               f"{np.linalg.norm(r[free]):.3g} W, coldest node {T.min():.3g} K); check boundary "
                               "conditions") from None
        if not np.all(np.isfinite(dT)):
            raise Fem2TmmError("the steady solve failed (singular or ill-conditioned system); check boundary conditions")
        full = float(np.max(np.abs(dT))) if len(dT) else 0.0
        stalled = (prev_full is not None and full > 0.5 * prev_full
                   and np.abs(r[free]).sum() <= max(STALL_RESIDUAL * gross_flows(T, r), roundoff(ops.K, T)))
        if full < tol or full < 1e-13 * float(np.max(np.abs(T))) or stalled:
            # converged: the step is below the tolerance (or round-off), or Newton no longer contracts with the
            # residual at round-off of the heat flows (an ill-conditioned model: a sliver, extreme temperatures);
            # take it without line search
            T[free] += dT
            r = ops.residual(T)
            step, converged = full, True
            stats["stopped_on"] = "round-off" if stalled and not full < tol else "step"
            break
        prev_full = full
        # trust region: never let a temperature drop by more than MAX_DROP or grow by more than MAX_GROWTH times
        # itself in one step (positivity; a cold start under a strong load)
        a = 1.0
        dec = dT < 0
        if dec.any():
            a = min(a, float(np.min(MAX_DROP * T[free][dec] / -dT[dec])))
        inc = dT > 0
        if inc.any():
            a = min(a, float(np.min(MAX_GROWTH * T[free][inc] / dT[inc])))
        if ops.radiative:
            while a > 1e-6:
                Tn = T.copy()
                Tn[free] += a * dT
                rn_new = np.linalg.norm(ops.residual(Tn)[free])
                if rn_new <= (1 - 1e-4 * a) * rn or rn_new < 1e-12 * (1 + np.abs(problem.Q).sum()):
                    break
                a *= 0.5
        T[free] += a * dT
        r = ops.residual(T)
        rn = np.linalg.norm(r[free])
        step = float(np.max(np.abs(a * dT))) if len(dT) else 0.0
    if not converged:
        flows = float(np.abs(problem.Q).sum()) + float(np.abs(r).sum()) + 1e-300
        cold = int(np.argmin(T))
        name = problem.names[cold] if problem.names is not None else f"node {cold}"
        hint = (f"; {name} was driven to {T[cold]:.3g} K: its loads have no physical steady solution (a negative "
                "net load larger than what its couplings can bring)" if T[cold] < 1.0 else
                "; check the model (isolated parts, extreme properties) or raise [solver] max_iterations")
        raise Fem2TmmError(
            f"the steady solve did not converge in {max_iter} Newton iterations: the last full Newton step was "
            f"{float(np.max(np.abs(dT))) if len(free) else 0.0:.3g} K against the tolerance {tol:.3g} K (damped to "
            f"{step:.3g} K), and the residual is {np.linalg.norm(r[free]):.3g} W, {np.linalg.norm(r[free]) / flows:.3g} "
            f"of the heat flows{hint}"
        )
    heat_fixed = np.zeros(n)
    heat_fixed[fixed] = r[fixed]  # net heat leaving a fixed node into the network = heat supplied by the boundary
    ops.at(T)
    g_now = ops.g  # the sink couplings at the solution (g_table), else g_space
    to_space = SIGMA * g_now * (T**4 - problem.T_sink**4)
    applied = float(np.sum(problem.Q))
    fixed_in = float(np.sum(heat_fixed))
    space = float(np.sum(to_space))
    imbalance = applied + fixed_in - space
    # relative to the gross heat flows (two fixed nodes may exchange heat with a zero net sum), floored at
    # BALANCE_FLOOR of the start's heat flows: a field that settles at 0 K (a 0 K sink, no load) has flows of
    # 1e-20 W whose round-off would otherwise read as an open balance
    # the flows to space count gross (emitted and absorbed from the sink: near equilibrium with the sink their net is
    # the round-off of two large terms); a model with no flow at all (held at one temperature) is measured against
    # the conduction of a BALANCE_CONDUCTION relative temperature change
    k_diag = np.abs(ops.K.diagonal() if not ops.dense else np.diag(ops.K))
    scale = max(float(np.abs(problem.Q).sum()), float(np.abs(heat_fixed).sum()),
                SIGMA * float(g_now @ (T**4 + problem.T_sink**4)),
                BALANCE_FLOOR * flow_scale, cold_scale * (BALANCE_COLD / COLD_FIELD) ** 4,
                BALANCE_CONDUCTION * float(k_diag @ np.abs(T)), 1e-300)
    balance = {"applied_W": applied, "fixed_W": fixed_in, "space_W": space, "imbalance_W": imbalance,
               "relative": abs(imbalance) / scale if scale > 1e-300 else 0.0}
    return SteadySolution(T=T, iterations=it, converged=converged, max_step=step, heat_fixed=heat_fixed,
                          to_space=to_space, balance=balance, stats=stats)


def _newton_krylov_step(ops: _Operators, d: np.ndarray, free: np.ndarray, b: np.ndarray, stats: dict) -> np.ndarray:
    """Solve J x = b on the free nodes with preconditioned GMRES (tight tolerance: the Newton step is exact)."""
    import scipy.sparse.linalg as spla

    n = len(d)
    lu = factorize(ops.jacobian(d, free, lumped_faces=True), "spd" if ops.L is None else "general")
    full = np.zeros(n)

    def matvec(x):
        full[:] = 0.0
        full[free] = x
        return ops.jvp(d, full)[free]

    A = spla.LinearOperator((len(free), len(free)), matvec=matvec, dtype=float)
    M = spla.LinearOperator((len(free), len(free)), matvec=lu.solve, dtype=float)
    count = [0]

    def cb(_):
        count[0] += 1

    # inexact Newton: 1e-10 relative is far below what the next Newton step corrects; the stopping rule of
    # the Newton loop (max |ΔT|) still decides convergence
    x, info = spla.gmres(A, b, rtol=1e-10, atol=0.0, restart=60, maxiter=50, M=M, callback=cb,
                         callback_type="pr_norm")
    stats["gmres_iterations"] += count[0]
    if info != 0:
        rel = np.linalg.norm(matvec(x) - b) / max(np.linalg.norm(b), 1e-300)
        if not rel < 1e-6:
            # the Krylov residual stalled (a Jacobian dominated by the face couplings the preconditioner lumps, or
            # near-singular near 0 K): fall back to a direct factorisation of the exact Jacobian, face couplings
            # assembled (denser, but exact)
            stats["direct_fallbacks"] = stats.get("direct_fallbacks", 0) + 1
            try:
                x = factorize(ops.jacobian(d, free), "pivoting").solve(b)  # partial pivoting: a fallback
            except (RuntimeError, np.linalg.LinAlgError, MemoryError) as exc:
                raise Fem2TmmError(f"the radiative Newton step did not converge (GMRES relative residual {rel:.1e}) "
                                   f"and the direct factorisation of the exact Jacobian failed ({exc}); check the "
                                   "boundary conditions") from None
    return x
