"""Reduction methods, one module each: a :class:`~fem2tmm.reductors.base.Reductor` that reduces, exports and
recovers (pyMOR's reductor pattern, ``reduce()`` / ``reconstruct()``).

===================  =================================================================================
``thesis``           :mod:`.thesis`: exact local condensation, linear recovery (Jacques 2016 ch. 3)
``positive``         :mod:`.positive`: the thesis' with a positive sparse network (``network = "positive"``)
``radiation_aware``  :mod:`.radiation_aware`: emission carried by the shape functions, outer iterations
===================  =================================================================================

The pipeline runs :func:`first_reductor` (the thesis' or its positive network), resolves ``"auto"`` with
:func:`choose_reduction` on that result (where only the estimated errors can decide, with
:func:`fem2tmm.stages.choice.measured_choice`), and, when another method is chosen, runs it from there
(:func:`reductor_for`).  A new method: a module with a :class:`~fem2tmm.reductors.base.Reductor` subclass, its
name in :data:`REDUCTORS`, and the rule that chooses it in :func:`reductor_for`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..case import Case
from ..constants import SIGMA
from ..fem.model import FEModel
from ..reduce.network import ReducedModel
from ..reduce.biot import biot_numbers
from ..result import Reduced
from .base import ReductionInputs, Reductor, exported_arrays
from .positive import PositiveReductor
from .radiation_aware import RadiationAwareReductor
from .thesis import ThesisReductor

__all__ = ["AUTO_BIOT", "ESTIMATE_MAX_UNKNOWNS", "REDUCTORS", "Reduced", "ReductionInputs", "Reductor", "choose_reduction",
           "exported_arrays", "first_reductor", "reductor_for"]

#: every reduction method by name (``Reduced.method``, ``summary.json reduced.reductor``)
REDUCTORS: dict[str, type[Reductor]] = {r.name: r for r in (ThesisReductor, PositiveReductor,
                                                            RadiationAwareReductor)}


#: ``"auto"`` estimates both candidates' errors on models of at most this many unknowns.  The estimate's cost is
#: one factorisation of the detailed Newton matrix, which grows faster than the reduction: measured with the
#: pipeline_1m case (2026-12-06, shared 2-core machine, scipy): 14.8-19.2 % of the reduction stages at 266 832 quads
#: (6.0-9.3 s), 37.5 % at 1 067 328 quads (23.7 s of 63.3 s, the whole run +24 %), against the 20 % the estimate may
#: cost.  Above it :data:`AUTO_BIOT` decides (docs/design-notes.md, "Which reduction by default")
ESTIMATE_MAX_UNKNOWNS = 300_000
#: above :data:`ESTIMATE_MAX_UNKNOWNS`, ``"auto"`` takes the radiation-aware reduction where the largest cluster Biot
#: number reaches this (a cluster as wide as the fin length √(k t / h_rad); every committed study with a thesis error
#: above 0.1 K RMS has Bi ≥ 9.5, every one below 1 has Bi ≤ 0.19 and a thesis error ≤ 0.1 K)
AUTO_BIOT = 1.0


def first_reductor(case: Case) -> Reductor:
    """The method every run starts with: the thesis' reduction, with its positive network when ``[reduction]
    network = "positive"``."""
    return REDUCTORS["positive" if case.reduction.network == "positive" else "thesis"]()


def reductor_for(case: Case) -> Reductor:
    """The method a case runs, its ``"auto"`` settings resolved (:func:`choose_reduction`)."""
    return REDUCTORS["radiation_aware"]() if case.reduction.radiation_aware is True else first_reductor(case)



def choose_reduction(model: FEModel, case: Case, rm: ReducedModel, T: np.ndarray) -> tuple[Case, dict]:
    """Resolve ``[reduction] radiation_aware`` and ``[radiation] ir_on`` when they are ``"auto"``.

    ``rm`` the thesis' reduced model, ``T`` (n_dof,) K its recovered field.  ``radiation_aware = "auto"`` becomes
    true when ``ir_on`` asks for the FE faces ("faces", "detailed"), false with ``network = "positive"`` (not
    defined for it) or without emission or radiating shell clusters; on a model of more than
    :data:`ESTIMATE_MAX_UNKNOWNS` unknowns, true when the largest cluster Biot number reaches :data:`AUTO_BIOT`;
    otherwise it stays ``"auto"``: the estimated errors of both candidates decide
    (:func:`fem2tmm.stages.choice.measured_choice`), and ``ir_on`` stays as asked.  ``ir_on = "auto"`` becomes "faces" with the radiation-aware reduction and face-to-face
    radiation, else "super_faces".  Returns the case with both set and ``{"radiation_aware", "ir_on", "chosen_by",
    "biot_cluster_max"}`` for the summary: the largest cluster Biot number (:func:`biot_numbers`, h = 4σ εA T³ of
    every active side at ``T``, as :func:`biot_weights`) whenever something radiates, None without shells; it is
    information (how far the thesis' uniform-load assumption is from holding), not the rule.
    """
    red, rad = case.reduction, case.radiation
    g = model.space_coupling()
    bi = None
    if np.any(g > 0):  # (reported whatever decides: it says how far the thesis' assumption is from holding)
        bi = biot_numbers(model, rm, 4.0 * SIGMA * g * np.maximum(np.asarray(T, float), 0.0) ** 3)["cluster_max"]
    if red.radiation_aware != "auto":
        aware = bool(red.radiation_aware)
        why = f"[reduction] radiation_aware = {str(aware).lower()}"
    elif red.network == "positive":
        aware, why = False, "auto: network = \"positive\" is the thesis' reduction's"
    elif rad.ir_on in ("faces", "detailed"):
        aware, why = True, f"auto: [radiation] ir_on = \"{rad.ir_on}\" needs it"
    elif not np.any(g > 0):
        aware, why = False, "auto: nothing radiates"
    elif bi is None:
        aware, why = False, "auto: no radiating shell clusters"
    elif model.n_dof > ESTIMATE_MAX_UNKNOWNS:  # the estimate would cost more than the reduction allows
        aware = bi >= AUTO_BIOT
        why = (f"auto: {model.n_dof} unknowns, above the {ESTIMATE_MAX_UNKNOWNS} the error estimate runs for (its "
               f"detailed factorisation would cost over 20 % of the reduction): the largest cluster Biot number "
               f"{bi:.3g} {'>=' if aware else '<'} {AUTO_BIOT:g}")
    else:  # measured: fem2tmm.stages.choice
        return case, {"radiation_aware": "auto", "ir_on": rad.ir_on, "chosen_by": "auto: the estimated errors",
                      "biot_cluster_max": float(bi)}
    ir_on = rad.ir_on if rad.ir_on != "auto" else ("faces" if aware and rad.enabled else "super_faces")
    resolved = dataclasses.replace(case, reduction=dataclasses.replace(red, radiation_aware=aware),
                                   radiation=dataclasses.replace(rad, ir_on=ir_on))
    return resolved, {"radiation_aware": aware, "ir_on": ir_on, "chosen_by": why,
                      "biot_cluster_max": None if bi is None else float(bi)}

