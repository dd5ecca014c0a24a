"""What a run produced: :class:`Result`, made of one typed part per stage output.

=====================  ===========================================================================================
``result.detailed``    :class:`Detailed`: the detailed reference (steady solution, FE-face REFs and Sun, its noise)
``result.reduced``     :class:`Reduced`: the reduction method's network, solution, recovered field and recovery
``result.orbit``       :class:`Orbit`: orbital fluxes and per-position temperatures
``result.transient``   :class:`~fem2tmm.solve.transient.TransientRun`: both models in time
=====================  ===========================================================================================

``result.detailed`` is always there (the FE model always is), its fields None where its stages did not run; the
other parts are None when their stage did not run.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .case import Case
from .cluster import Clustering
from .fem.model import FEModel
from .mesh import Mesh
from .radiation import ExchangeResult
from .radiation.orbital import OrbitalFluxes
from .radiation.solar import SolarResult
from .reduce.exported import ExportedRecovery
from .reduce.network import ReducedModel
from .solve.steady import SteadySolution
from .solve.transient import TransientRun


@dataclass
class Detailed:
    """The detailed reference model.

    Attributes
    ----------
    solution : its steady solution (None when a transient from a given temperature did not need one, or it failed
        there with a warning)
    radiation : REFs between the FE face sides (None without traced radiation)
    solar : solar rays traced on the FE face sides (None without the Sun there)
    noise : ``{"rms_K", "max_K"}`` the reference's own noise from two independent half references, or None
    halves : the number of those half references, or None
    """

    solution: SteadySolution | None = None
    radiation: ExchangeResult | None = None
    solar: SolarResult | None = None
    noise: dict | None = None
    halves: int | None = None


@dataclass
class Reduced:
    """The reduced model: what a reduction method (:mod:`fem2tmm.reductors`) returned and what the run added.

    Attributes
    ----------
    method : the reduction method that made the network ("thesis", "positive", "radiation_aware")
    network : the reduced model handed over (decks and ``reduced.npz`` are written from it)
    solution : its steady solution (super-node temperatures, K)
    T_recovered : (n_dof,) K the detailed field recovered from it
    q_recover : (n_dof,) W the detailed loads the recovery takes (applied, detailed solar, orbit average)
    case : the case as the method ran it (``"auto"`` resolved; ``ir_on`` may have fallen back, see ``notes``)
    recovery : the recovery written into ``reduced.npz`` (:class:`~fem2tmm.reduce.exported.ExportedRecovery`)
    method_report : the method's own report: the positive fit's (:attr:`positive`) or the outer iterations
        (:attr:`outer_iterations`)
    T_recovered_exact : (n_dof,) K with ``network = "positive"``: the exact condensation's recovered field
    ir : where the emitted IR lands on the FE sides (:class:`fem2tmm.radiation.ir_absorption.IRAbsorption`), or None
    notes : what the method changed in the choice it was given
    clustering : the clustering the super nodes come from
    choice : ``{"radiation_aware", "ir_on", "chosen_by", "biot_cluster_max"}``: the method the run used and why
        (:func:`fem2tmm.reductors.choose_reduction`)
    thesis_T_recovered : (n_dof,) K the thesis' recovered field when another method was chosen after it
    shared_network : load-case sets: ``{"linearised_at": case, "cases": [...]}`` sharing GL, GR and C
    radiation : REFs between super faces; ``super_faces_count`` the number of super faces traced
    solar : solar rays traced on the super faces; ``solar_on`` how the network took its solar loads
    refinement : :class:`fem2tmm.stages.refine.Refinement` of ``[reduction] target_rms`` (history, every round's labels)
    delivered : :func:`fem2tmm.handover.check_deliverable`: the network written, read back, solved and recovered
    parametric : ``[reduction] parametric``: the correction load at each parametric state as a departure from the
        design's (:func:`fem2tmm.reductors.radiation_aware.parametric_corrections`), written into the deck
    verified : the validity range and its check against the detailed model (:func:`fem2tmm.verify.verify_network`),
        or ``{"status": "UNVERIFIED", "reason"}``; stated in the decks and ``reduced.npz``
    emission_check : :func:`fem2tmm.stages.radiation.emission_check`: the network's radiation to space against the traced
        emission of its recovered field, and the blocked fraction of each part's emission (face-to-face radiation)
    """

    method: str
    network: ReducedModel
    solution: SteadySolution
    T_recovered: np.ndarray
    q_recover: np.ndarray
    case: Case
    recovery: ExportedRecovery | None = None
    method_report: object | None = None
    T_recovered_exact: np.ndarray | None = None
    ir: object | None = None
    notes: list[str] = field(default_factory=list)
    clustering: Clustering | None = None
    choice: dict | None = None
    thesis_T_recovered: np.ndarray | None = None
    shared_network: dict | None = None
    radiation: ExchangeResult | None = None
    super_faces_count: int | None = None
    solar: SolarResult | None = None
    solar_on: str | None = None
    refinement: object | None = None
    delivered: dict | None = None
    parametric: dict | None = None
    verified: dict | None = None
    emission_check: dict | None = None

    @property
    def positive(self) -> dict | None:
        """``network = "positive"``: the fit's report (criteria, heat into the fixed nodes), else None."""
        return self.method_report if self.method == "positive" else None

    @property
    def outer_iterations(self) -> list[dict] | None:
        """The radiation-aware reduction's outer iterations (one dict each: ``max_dT_K``, ``rms_dT_K``,
        ``correction_W``), else None."""
        return self.method_report if self.method == "radiation_aware" else None


@dataclass
class Orbit:
    """``[orbit]``: the fluxes and the per-position temperatures.

    Attributes
    ----------
    detailed : fluxes traced on the FE faces (per face), or None
    super_faces : fluxes traced on the super faces (per side), or None
    fluxes_on : how the reduced model took them ("detailed" | "super_faces"), None without a reduced model
    T_positions : (k, n_dof) K steady temperatures at each position (``steady = "positions"``): recovered from the
        reduced model, or the detailed model's without one
    T_positions_detailed : (k, n_dof) K the detailed model's beside a reduced model's, or None
    """

    detailed: OrbitalFluxes | None = None
    super_faces: OrbitalFluxes | None = None
    fluxes_on: str | None = None
    T_positions: np.ndarray | None = None
    T_positions_detailed: np.ndarray | None = None

    @property
    def fluxes(self) -> OrbitalFluxes | None:
        """The orbital fluxes the run used: on the FE faces, else on the super faces."""
        return self.detailed if self.detailed is not None else self.super_faces


@dataclass
class Result:
    """What a run produced: the inputs (``case``, ``mesh``, ``model``); one part per stage output (``detailed``
    always, its fields None where its stages did not run; the others None when their stage did not run); the
    absorbed solar maps and quadric fits of the scene; ``summary`` (the dict written to ``summary.json``), ``cache``
    {stage: "computed" | "reused"} and the output folder ``out``."""

    case: Case
    mesh: Mesh
    model: FEModel
    detailed: Detailed | None = None
    reduced: Reduced | None = None
    orbit: Orbit | None = None
    transient: TransientRun | None = None
    # absorbed solar flux maps: (n_faces,) W/m² per FE face and (n_elements,) W/m² per mesh element (NaN outside)
    absorbed_solar_faces: np.ndarray | None = None
    absorbed_solar_elements: np.ndarray | None = None
    quadrics: list[dict] | None = None  # one fit report per quadric region (summary.json "quadrics")
    summary: dict = field(default_factory=dict)
    cache: dict[str, str] | None = None  # stage -> "computed" | "reused" (fem2tmm.cache; summary.json "cache")
    out: Path | None = None

    @property
    def T_detailed_nodes(self) -> np.ndarray | None:
        """(n_nodes,) detailed steady temperatures in K (NaN outside the model), or None."""
        d = self.detailed
        return None if d is None or d.solution is None else self.model.node_temperatures(d.solution.T)

    @property
    def T_recovered_nodes(self) -> np.ndarray | None:
        """(n_nodes,) temperatures recovered from the reduced model in K (NaN outside the model), or None."""
        return None if self.reduced is None else self.model.node_temperatures(self.reduced.T_recovered)

    @property
    def T_nodes(self) -> np.ndarray:
        """The result temperatures (K) of every mesh node: recovered when reduced, detailed otherwise."""
        return self.T_recovered_nodes if self.reduced is not None else self.T_detailed_nodes


@dataclass
class CasesResult:
    """What a run of a case file with ``[[cases]]``/``[sweep]`` produced: ``results`` {case name: :class:`Result`}
    in file order, ``parameters`` {case name: {dotted key: value}} set by a sweep, ``summary`` the dict written to
    the top ``summary.json`` (per-case table, envelope), ``out`` the output folder."""

    case: Case
    results: dict[str, Result]
    parameters: dict[str, dict] = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    out: Path | None = None
