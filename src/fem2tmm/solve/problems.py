"""The steady problems of a run and the case's solver settings.

:func:`detailed_problem` and :func:`reduced_problem` build a :class:`~fem2tmm.solve.steady.SteadyProblem` from
the FE model or the reduced network (matrices and vectors only); :func:`solve_case` solves one with ``[solver]``'s
settings on the run's executor.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..case import Case
from ..fem.model import FEModel
from ..reduce.network import ReducedModel
from .steady import SteadyProblem, SteadySolution, solve_steady


# --------------------------------------------------------------------------------------------- problems
def detailed_problem(model: FEModel) -> SteadyProblem:
    """The detailed steady problem (radiation: every active side sees only space)."""
    return SteadyProblem(K=model.K, Q=model.Q, fixed=model.fixed_mask, T_fixed=model.fixed_values,
                         g_space=model.space_coupling(), T_sink=model.T_sink)


def reduced_problem(rm: ReducedModel) -> SteadyProblem:
    """The steady problem of the reduced network ``rm``."""
    return SteadyProblem(K=rm.K, Q=rm.Q, fixed=rm.fixed, T_fixed=rm.T_fixed, g_space=rm.g_space,
                         T_sink=rm.T_sink, GR=rm.GR, names=tuple(rm.names), g_table=rm.g_space_table)


def solver_settings(case: Case) -> dict:
    """The keyword arguments of :func:`solve_unit` that ``[solver]`` sets."""
    return {"tol": case.solver.tolerance, "max_iter": case.solver.max_iterations}


def solve_case(problem: SteadyProblem, case: Case) -> SteadySolution:
    """The steady solution of ``problem`` with ``[solver]``'s settings: one work unit on the run's executor
    (:func:`fem2tmm.compute.map_units`: in process, or on the Dask cluster of ``[compute]``)."""
    from ..compute import map_units

    [solution] = map_units(solve_unit, [problem], shared=solver_settings(case), what="steady solves")
    return solution


def solve_unit(problem: SteadyProblem, tol: float, max_iter: int) -> SteadySolution:
    """A steady solve as a work unit (:func:`solve_case`, the reference-noise halves)."""
    return solve_steady(problem, tol=tol, max_iter=max_iter)


def describe_nodes(model: FEModel) -> Callable[[np.ndarray], str]:
    """``describe(dofs) -> str``: the parts holding some DOFs, for the solvability check's messages."""

    def describe(dofs: np.ndarray) -> str:
        mask = np.isin(model.element_dofs, dofs).any(axis=1)
        names = sorted({model.parts[p].name for p in np.unique(model.element_part[mask])})
        return "parts " + ", ".join(repr(n) for n in names)

    return describe
