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

from ..errors import Fem2TmmError
from ..linalg import factorize

SIGMA = 5.670374419e-8  # W/(m² K⁴), CODATA 2018


@dataclass(frozen=True)
class FacedRadiation:
    """Face-to-face radiation in factored form: node couplings ``Wᵀ G W``.

    ``W`` (f, n) sparse, rows sum to 1 (face temperature⁴ = W T⁴ as the area-weighted nodal average);
    ``G`` (f, f) sparse symmetric face couplings GR (m²) without the space column.
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


def _as_operator(M):
    return M if sp.issparse(M) else np.asarray(M, float)


def _radiation_laplacian(problem: SteadyProblem):
    """L = diag(GR 1) − GR for node-to-node GR (sparse or dense), or None."""
    if problem.GR is None:
        return None
    GR = problem.GR
    if sp.issparse(GR):
        GR = sp.csr_matrix(GR)
        GR = GR - sp.diags(GR.diagonal())
        return (sp.diags(np.asarray(GR.sum(axis=1)).ravel()) - GR).tocsr()
    GR = np.array(GR, float)
    np.fill_diagonal(GR, 0.0)
    return np.diag(GR.sum(axis=1)) - GR


def _faced_laplacian(faced: FacedRadiation):
    G = sp.csr_matrix(faced.G)
    G = G - sp.diags(G.diagonal())
    Lf = (sp.diags(np.asarray(G.sum(axis=1)).ravel()) - G).tocsr()
    return Lf


def residual(problem: SteadyProblem, T: np.ndarray) -> np.ndarray:
    """r(T) (n,) in W: net heat leaving each node minus its applied load."""
    T4 = T**4
    r = problem.K @ T + SIGMA * problem.g_space * (T4 - problem.T_sink**4) - problem.Q
    L = _radiation_laplacian(problem)
    if L is not None:
        r = r + SIGMA * (L @ T4)
    if problem.faced is not None:
        W = problem.faced.W
        r = r + SIGMA * (W.T @ (_faced_laplacian(problem.faced) @ (W @ T4)))
    return np.asarray(r).ravel()


def check_solvable(problem: SteadyProblem, labels: np.ndarray | None = None, describe=None) -> None:
    """Raise if a connected set of free nodes has neither a fixed temperature nor radiation.

    ``describe(node_indices) -> str`` names the culprit part(s) for the message.
    """
    n = len(problem.Q)
    K = problem.K
    A = sp.csr_matrix(K) if sp.issparse(K) else sp.csr_matrix(np.asarray(K))
    A = abs(A)
    if problem.GR is not None:
        A = A + abs(sp.csr_matrix(problem.GR))
    if problem.faced is not None:
        W = problem.faced.W
        A = A + abs(W.T @ (abs(problem.faced.G) @ W))
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


def solve_steady(problem: SteadyProblem, T0: float | np.ndarray | None = None, tol: float = 1e-9,
                 max_iter: int = 200) -> SteadySolution:
    """Solve the steady network by damped Newton.

    ``T0`` start temperature(s) in K (default: mean of the fixed temperatures, else the sink).
    Stops when max|ΔT| < ``tol`` K (or below round-off, 1e-13 x max T).
    """
    n = len(problem.Q)
    fixed = np.asarray(problem.fixed, bool)
    free = np.flatnonzero(~fixed)
    if T0 is None:
        T0 = float(np.mean(problem.T_fixed[fixed])) if fixed.any() else max(problem.T_sink, 3.0)
    T = np.broadcast_to(np.asarray(T0, float), (n,)).copy()
    T[fixed] = problem.T_fixed[fixed]
    if np.any(T <= 0):
        raise Fem2TmmError("start and fixed temperatures must be above absolute zero")
    K = _as_operator(problem.K)
    L = _radiation_laplacian(problem)
    Lf = _faced_laplacian(problem.faced) if problem.faced is not None else None
    dense = not sp.issparse(K)
    radiative = (problem.g_space > 0).any() or L is not None or Lf is not None

    def res(T):
        return residual(problem, T)

    def jacobian(T):
        d = 4 * SIGMA * T**3
        if dense:
            J = np.array(K, float)
            if L is not None:
                J = J + (L if not sp.issparse(L) else L.toarray()) * d[None, :]
            J[np.diag_indices(n)] += d * problem.g_space
            if Lf is not None:
                W = problem.faced.W
                J = J + (W.T @ (Lf @ (W @ sp.diags(d)))).toarray()
            return J[np.ix_(free, free)]
        J = sp.csr_matrix(K) + sp.diags(d * problem.g_space)
        if L is not None:
            J = J + (sp.csr_matrix(L) @ sp.diags(d))
        if Lf is not None:
            W = problem.faced.W
            J = J + W.T @ (Lf @ (W @ sp.diags(d)))
        J = sp.csr_matrix(J)
        return J[free][:, free].tocsc()

    cache = {}

    def step_solve(T, b):
        # a purely conductive problem has a constant Jacobian: factorise it once
        if not radiative and "lu" in cache:
            return cache["lu"](b)
        J = jacobian(T)
        if dense:
            return np.linalg.solve(J, b)
        lu = factorize(J)
        if not radiative:
            cache["lu"] = lu.solve
        return lu.solve(b)

    r = res(T)
    rn = np.linalg.norm(r[free])
    converged, it, step = False, 0, np.inf
    if len(free) == 0:
        converged = True
    while not converged and it < max_iter:
        it += 1
        dT = np.asarray(step_solve(T, -r[free])).ravel()
        if not np.all(np.isfinite(dT)):
            raise Fem2TmmError("the steady solve failed (singular or ill-conditioned system); check boundary conditions")
        full = float(np.max(np.abs(dT))) if len(dT) else 0.0
        if full < tol or full < 1e-13 * float(np.max(np.abs(T))):
            # converged: the step is below the tolerance (or round-off); take it without line search
            T[free] += dT
            r = res(T)
            step, converged = full, True
            break
        # positivity: never let a temperature drop by more than 80 % in one step
        a = 1.0
        dec = dT < 0
        if dec.any():
            a = min(1.0, float(np.min(0.8 * T[free][dec] / -dT[dec])))
        if radiative:
            while a > 1e-6:
                Tn = T.copy()
                Tn[free] += a * dT
                rn_new = np.linalg.norm(res(Tn)[free])
                if rn_new <= (1 - 1e-4 * a) * rn or rn_new < 1e-12 * (1 + np.abs(problem.Q).sum()):
                    break
                a *= 0.5
        T[free] += a * dT
        r = res(T)
        rn = np.linalg.norm(r[free])
        step = float(np.max(np.abs(a * dT))) if len(dT) else 0.0
    if not converged:
        raise Fem2TmmError(
            f"the steady solve did not converge in {max_iter} Newton iterations (last max |ΔT| = {step:.3g} K); "
            "check the model (isolated parts, extreme properties)"
        )
    heat_fixed = np.zeros(n)
    heat_fixed[fixed] = r[fixed]  # net heat leaving a fixed node into the network = heat supplied by the boundary
    to_space = SIGMA * problem.g_space * (T**4 - problem.T_sink**4)
    applied = float(np.sum(problem.Q))
    fixed_in = float(np.sum(heat_fixed))
    space = float(np.sum(to_space))
    imbalance = applied + fixed_in - space
    # relative to the gross heat flows (two fixed nodes may exchange heat with a zero net sum)
    scale = max(float(np.abs(problem.Q).sum()), float(np.abs(heat_fixed).sum()), float(np.abs(to_space).sum()), 1e-300)
    balance = {"applied_W": applied, "fixed_W": fixed_in, "space_W": space, "imbalance_W": imbalance,
               "relative": abs(imbalance) / scale if scale > 1e-300 else 0.0}
    return SteadySolution(T=T, iterations=it, converged=converged, max_step=step, heat_fixed=heat_fixed,
                          to_space=to_space, balance=balance)
