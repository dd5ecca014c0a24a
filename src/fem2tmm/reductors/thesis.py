"""The thesis' reduction (Jacques 2016 ch. 3): exact local condensation onto super nodes, linear recovery.

Conduction is condensed exactly onto the super nodes with uniform-load shape functions (a super node's heat is
taken as spread like its weights A); radiation and the Sun couple super faces.  The network is state-independent:
GL, GR and C hold for every load state, and the recovery is ``T = X q + Yᵀ T_SN``.  Its error grows with the
clusters' Biot number h_rad A/(k t) (docs/design-notes.md, "Which reduction by default").
"""

from __future__ import annotations

import numpy as np

from ..errors import Fem2TmmError, NetworkRefusal, either
from ..reduce.network import negative_loads
from ..solve.problems import reduced_problem, solve_case
from .base import Reduced, ReductionInputs, Reductor


class ThesisReductor(Reductor):
    """The thesis' reduction: the network as condensed (``[reduction] network = "exact"``)."""

    name = "thesis"

    def reduce(self, inputs: ReductionInputs, prog, start: Reduced | None = None) -> Reduced:
        with prog.stage("solve_reduced", "solving the reduced model"):
            sol = solve_exact(inputs)
        return self._recovered(inputs, prog, Reduced(method=self.name, network=inputs.network, solution=sol,
                                                       T_recovered=np.zeros(0), q_recover=inputs.q_recover,
                                                       case=inputs.case))

    def _recovered(self, inputs: ReductionInputs, prog, red: Reduced) -> Reduced:
        with prog.stage("recover", "recovering detailed temperatures"):
            red.T_recovered = self.reconstruct(red, red.solution.T)
        return red


def solve_exact(inputs: ReductionInputs):
    """The steady solution of the thesis' network ``inputs.network`` (a :class:`~fem2tmm.solve.steady.
    SteadySolution`), refused with the cause when its negative conductances leave it without one."""
    rm, case = inputs.network, inputs.case
    try:
        return solve_case(reduced_problem(rm), case)
    except Fem2TmmError:
        negative = int(rm.report.get("negative_links", 0))  # counted by build_reduced
        if not negative:
            raise
        # the exact condensation's negative conductances break the maximum principle: with extreme loads such a
        # network can have no positive steady solution although the detailed model has one.  The advice names what
        # can give one and is not in force: the positive network where the loads' exact distribution has no negative
        # share (it keeps the loads: a thin composite bracket's 40 W heater gives -33 W to 16 super nodes,
        # tests/test_no_refusal.py), the radiation-aware reduction where something emits
        held_back, shares = negative_loads(rm)
        emits = bool(np.any(inputs.model.space_coupling() > 0))
        advice = [x for x, ok in (("[reduction] network = \"positive\"",
                                   case.reduction.network != "positive" and not shares),
                                  ("radiation_aware = true", case.reduction.radiation_aware is not True and emits))
                  if ok] + ["more super nodes"]
        loads = ("" if not shares else f"; its exact distribution of the loads also takes {-held_back:.3g} W from "
                 f"{shares} super nodes (negative loads), which a positive network keeps")
        raise NetworkRefusal(
            f"{case.source}: the reduced network has {negative} negative conductances (the exact condensation of the "
            "thesis' reduction), which break the maximum principle, and no physical steady solution under these "
            f"loads (the detailed model has one){loads}; use {either(advice)}") from None
