"""``[reduction] network = "positive"``: the thesis' condensation replaced by a positive sparse network.

The exact condensation's dense K_SN has negative conductances, which ESATAN and SINDA users distrust and which
break the maximum principle; this method fits a positive network between touching super nodes to its response
(:mod:`fem2tmm.lpm.positive`) and checks it by the network criteria of :class:`fem2tmm.lpm.grouping.Criteria`.
The recovery is the thesis' (linear), from the positive network's temperatures.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..case import Case
from ..errors import Fem2TmmError, NetworkRefusal
from ..fem.model import FEModel
from ..reduce.network import ReducedModel, negative_loads
from ..solve.steady import SteadySolution, solve_steady
from ..solve.problems import reduced_problem
from .base import Reduced, ReductionInputs
from .thesis import ThesisReductor, solve_exact


class PositiveReductor(ThesisReductor):
    """The thesis' reduction with a positive sparse network fitted to the exact one; ``method_report`` holds the fit's
    criteria and ``T_recovered_exact`` the exact condensation's recovered field."""

    name = "positive"

    def reduce(self, inputs: ReductionInputs, prog, start: Reduced | None = None) -> Reduced:
        with prog.stage("solve_reduced", "solving the reduced model"):
            try:
                exact = solve_exact(inputs)
            except NetworkRefusal:  # (its negative conductances: the positive network is the way out, fitted alone)
                exact = None
        with prog.stage("positive", "fitting a positive sparse network"):
            rm, sol, report = positive_reduced(inputs.model, inputs.network, exact, inputs.case)
        red = Reduced(method=self.name, network=rm, solution=sol, T_recovered=np.zeros(0),
                        q_recover=inputs.q_recover, case=inputs.case, method_report=report)
        red.T_recovered_exact = None if exact is None else rm.reduction.recover(exact.T, inputs.q_recover)
        return self._recovered(inputs, prog, red)


def positive_reduced(model: FEModel, rm: ReducedModel, exact: SteadySolution | None, case: Case
                     ) -> tuple[ReducedModel, SteadySolution, dict]:
    """Replace the exact dense K_SN of ``rm`` by a positive sparse network between touching super nodes fitted to
    its response (:mod:`fem2tmm.lpm.positive`, the exact solution ``exact`` weighing as the case's own state), solve
    it, and compare with the exact reduction by the network criteria (:class:`fem2tmm.lpm.grouping.Criteria`
    defaults: δ ≤ 3 K per super node, heat into each boundary within 0.1 W below 1 W, 10 % above).  Returns the new
    model, its solution and the report for ``summary.json``.

    ``exact`` None: the exact network has no physical steady solution (its negative conductances under these loads);
    the fit is then to its responses alone, and the report's comparisons with it are None (``exact``: why)."""
    from ..lpm.grouping import Criteria, flow_errors
    from ..lpm.positive import positive_network

    pn = positive_network(rm.K, rm.supernodes.A, model.K, rm.fixed, states=None if exact is None else exact.T)
    rm_pos = dataclasses.replace(rm, K=pn.K, report={**rm.report, "positive": pn.report, "negative_links": 0,
                                                      "negative_GL_W_per_K": 0.0})
    try:
        sol = solve_steady(reduced_problem(rm_pos), T0=None if exact is None else exact.T, tol=case.solver.tolerance,
                           max_iter=case.solver.max_iterations)
    except Fem2TmmError as exc:
        if exact is not None:
            raise
        held_back, shares = negative_loads(rm)
        why = (f"the loads' exact distribution takes {-held_back:.3g} W from {shares} super nodes (negative loads)"
               if shares else str(exc))
        # (the radiation-aware reduction is not defined on the positive network: its advice says to leave it)
        aware = '[reduction] network = "exact" with radiation_aware = true or '
        raise NetworkRefusal(f"{case.source}: neither the exact reduced network (its negative conductances) nor the "
                             f"positive one fitted to it has a physical steady solution under these loads: {why}; use "
                             f"{aware if np.any(model.space_coupling() > 0) else ''}more super nodes") from None
    if exact is None:
        return rm_pos, sol, {**pn.report, "exact": "no physical steady solution (its negative conductances)",
                             "T_vs_exact_K": None, "heat_into_fixed_W": None, "criteria": None}
    crit = Criteria()
    delta = np.abs(sol.T - exact.T)
    f = np.flatnonzero(rm.fixed)
    err, ok = flow_errors(-exact.heat_fixed[f], -sol.heat_fixed[f], crit)
    report = {**pn.report,
              "T_vs_exact_K": {"max": float(delta.max(initial=0.0)), "rms": float(np.sqrt(np.mean(delta**2)))},
              "heat_into_fixed_W": {str(rm.names[i]): {"exact": float(exact.heat_fixed[i]),
                                                       "positive": float(sol.heat_fixed[i])} for i in f},
              "criteria": {"delta_max_K": crit.delta_max, "q_max_W": crit.q_max, "q_lim_W": crit.q_lim,
                           "q_rel_max": crit.q_rel_max,
                           "met": bool((delta[~rm.fixed] < crit.delta_max).all() and ok.all()),
                           "max_flow_error": float(err.max(initial=0.0))}}
    return rm_pos, sol, report
