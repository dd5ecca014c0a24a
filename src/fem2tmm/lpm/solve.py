"""Steady solution of a network (radiation included) with fem2tmm's Newton solver, and its boundary heat flows.

The kernel is :func:`fem2tmm.solve.steady.solve_steady` (one implementation): the network's GL Laplacian is the
conduction matrix, its GR goes in as node-to-node radiation (small networks: direct Newton) or, when GR is denser
than GL (its LU would fill in), in the factored form ``Iᵀ GR I`` that makes the solver use Newton-Krylov (GMRES
preconditioned by the LU of conduction plus lumped radiation; no fill-in from long-range GR).  Boundary nodes are
held at the load case's temperatures.  Fernández Rico linearises σGR(T_i⁴ − T_j⁴) by a secant and iterates
(eq. 45–47); Newton converges to the same fixed point, faster.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..constants import SIGMA
from ..errors import Fem2TmmError
from ..solve.steady import FacedRadiation, SteadyProblem, check_solvable, solve_steady
from .network import LoadCase, Network

#: networks above this size whose GR is denser than their GL go through the factored (Newton-Krylov) path: the
#: direct Jacobian's LU would fill in along the long-range radiative couplings
KRYLOV_MIN_NODES = 500


@dataclass(frozen=True)
class NetworkSolution:
    """Steady temperatures ``T`` (n,) K and heat flows INTO each boundary node from the rest of the network:
    ``H_conductive`` (n,) W and ``H_radiative`` (n,) W (0 on non-boundary nodes); ``iterations`` of Newton."""

    T: np.ndarray
    H_conductive: np.ndarray
    H_radiative: np.ndarray
    iterations: int

    @property
    def H(self) -> np.ndarray:
        return self.H_conductive + self.H_radiative


def steady_problem(net: Network, case: LoadCase) -> SteadyProblem:
    """The :class:`SteadyProblem` of ``net`` (active nodes only) under ``case``."""
    if (net.kind == "X").any():
        raise Fem2TmmError(f"{net.source}: solve the active network (Network.active()) — inactive nodes present")
    fixed = net.boundary
    T_fixed = np.where(fixed, case.T_boundary, 0.0)
    if fixed.any() and np.any(T_fixed[fixed] < 0):  # 0 K is a space node at absolute zero (a -273.15 °C sink)
        raise Fem2TmmError(f"{net.source}: case {case.name!r}: boundary temperatures must be at or above absolute "
                           "zero")
    n = net.n
    GR = sp.csr_matrix(net.GR)
    faced = None
    node_gr = None
    if n > KRYLOV_MIN_NODES and GR.nnz > net.GL.nnz:
        faced = FacedRadiation(W=sp.identity(n, format="csr"), G=GR)
    elif GR.nnz:
        node_gr = GR
    g_space, T_sink, g_table = np.zeros(n), 3.0, None
    if net.gr_tables:  # GR to one boundary node following each node's own temperature: its coupling to the sink
        i, j, k = (np.array([t[c] for t in net.gr_tables]) for c in range(3))
        if not (np.all(i == k) and np.all(j == j[0]) and fixed[j[0]]) or len(np.unique(i)) < len(i):
            raise Fem2TmmError(f"{net.source}: temperature-dependent GR are read only as each node's coupling to one "
                               "boundary node (the space node) following the node's own temperature")
        m = max(len(t[3]) for t in net.gr_tables)
        x, y = np.zeros((n, m)), np.zeros((n, m))
        x[:] = np.arange(m)  # nodes without a table: constant 0
        for a, _, _, xs, ys in net.gr_tables:  # a shorter table holds its last knot (np.pad's "edge", 25x slower)
            x[a, : len(xs)], y[a, : len(ys)] = xs, ys
            x[a, len(xs):], y[a, len(ys):] = xs[-1], ys[-1]
        g_space[i] = y[i, 0]
        T_sink, g_table = float(T_fixed[j[0]]), (x, y)
        keep = sp.csr_matrix((np.ones(len(i) * 2), (np.r_[i, j], np.r_[j, i])), shape=(n, n))
        GR = (GR - GR.multiply(keep)).tocsr()
        GR.eliminate_zeros()
        node_gr = GR if GR.nnz and faced is None else None
        if faced is not None:
            faced = FacedRadiation(W=faced.W, G=GR)
    return SteadyProblem(K=net.K(), Q=np.asarray(case.Q, float), fixed=fixed, T_fixed=T_fixed,
                         g_space=g_space, T_sink=T_sink, GR=node_gr, faced=faced, g_table=g_table)


def boundary_flows(net: Network, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Conductive and radiative heat (n,) W flowing into each boundary node from the other nodes at temperatures T."""
    b = net.boundary
    Hc = np.zeros(net.n)
    Hr = np.zeros(net.n)
    if b.any():
        rows = np.flatnonzero(b)
        GLb = net.GL[rows]
        GRb = net.GR[rows]
        Hc[rows] = GLb @ T - np.asarray(GLb.sum(axis=1)).ravel() * T[rows]
        T4 = T**4
        Hr[rows] = SIGMA * (GRb @ T4 - np.asarray(GRb.sum(axis=1)).ravel() * T4[rows])
    return Hc, Hr


def solve_network(net: Network, case: LoadCase | None = None, T0=None, tol: float = 1e-10) -> NetworkSolution:
    """Steady solution of ``net`` under ``case`` (default: the deck's own QI and boundary temperatures).

    ``T0`` start temperatures (K, scalar or (n,)); default: the deck's T where positive, else the boundary mean.
    Where Newton from ``T0`` does not converge it starts again from a uniform field (the mean of the boundary
    temperatures, raised to the radiative balance of the loads: :func:`~fem2tmm.solve.steady.solve_steady`).
    Raises :class:`Fem2TmmError` naming the nodes of a part with neither a boundary nor radiation.
    """
    case = net.default_case() if case is None else case
    problem = steady_problem(net, case)
    check_solvable(problem, describe=net.describe)
    fb = problem.fixed
    if T0 is None:
        mean = float(np.mean(problem.T_fixed[fb])) if fb.any() else 293.15
        T0 = np.where(net.T > 1.0, net.T, mean)
    if fb.any():
        # no free node starts below the coldest boundary temperature, which (its loads non-negative) it cannot end
        # below either, and from above the T⁴ emission converges monotonically: the L-bracket's deck at 100 super
        # nodes, its sink edited from -270 to 20 °C and started from its design temperatures (60-290 K), took 89
        # damped Newton steps (its cold nodes' 4σT³ ~100x too small, each full step thousands of K), 5 from there
        T0 = np.where(fb, T0, np.maximum(T0, float(problem.T_fixed[fb].min())))
    try:
        sol = solve_steady(problem, T0=T0, tol=tol)
    except Fem2TmmError as first:
        # a Newton started far from this state can stall where a uniform start converges: the L-bracket's deck at 300
        # super nodes, its sink edited from -270 to 20 °C (the held edge's temperature) and started from its design
        # temperatures (60-293 K), took 200 damped steps; from a uniform 293 K it converges in a few (2026-12-06)
        try:
            sol = solve_steady(problem, T0=None, tol=tol)
        except Fem2TmmError:
            raise first from None
    Hc, Hr = boundary_flows(net, sol.T)
    return NetworkSolution(T=sol.T, H_conductive=Hc, H_radiative=Hr, iterations=sol.iterations)


__all__ = ["NetworkSolution", "boundary_flows", "solve_network", "steady_problem"]
