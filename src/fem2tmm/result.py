"""What a run produced: :class:`Result`, every stage's output in a named, typed field."""

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
from .reduce.network import ReducedModel
from .solve.steady import SteadySolution
from .solve.transient import TransientRun


@dataclass
class Result:
    """What a run produced.  ``summary`` is the dict written to ``summary.json``; fields of stages that did not
    run are None."""

    case: Case
    mesh: Mesh
    model: FEModel
    summary: dict = field(default_factory=dict)
    out: Path | None = None
    # detailed reference model
    detailed: SteadySolution | None = None
    radiation_detailed: ExchangeResult | None = None  # REFs between FE face sides
    solar_detailed: SolarResult | None = None  # solar rays traced on the FE face sides
    # reduced model
    clustering: Clustering | None = None
    reduced: ReducedModel | None = None
    reduced_solution: SteadySolution | None = None
    T_recovered: np.ndarray | None = None  # (n_dof,) K
    # [reduction] network = "positive": the fit's report and the exact reduction's recovered field (n_dof,) K
    positive: dict | None = None
    T_recovered_exact: np.ndarray | None = None
    radiation: ExchangeResult | None = None  # REFs between super faces
    super_faces_count: int | None = None  # number of super faces the REFs were traced between
    solar_super_faces: SolarResult | None = None  # solar rays traced on the super faces
    solar_on: str | None = None  # how the reduced model took its solar loads ("detailed" | "super_faces")
    # absorbed solar flux maps: (n_faces,) W/m² per FE face and (n_elements,) W/m² per mesh element (NaN outside)
    absorbed_solar_faces: np.ndarray | None = None
    absorbed_solar_elements: np.ndarray | None = None
    quadrics: list[dict] | None = None  # one fit report per quadric region (summary.json "quadrics")
    q_recover: np.ndarray | None = None  # (n_dof,) W detailed loads the recovery uses (applied + detailed solar)
    transient: TransientRun | None = None  # [transient]: both models in time, recovered temperatures
    # radiation-aware reduction: the thesis' pre-solve and the outer iterations
    thesis_T_recovered: np.ndarray | None = None  # (n_dof,) K recovered by the thesis' reduction (pre-solve)
    recovery: object | None = None  # fem2tmm.reduce.exported.ExportedRecovery written into reduced.npz
    delivered: dict | None = None  # export.deliverable.check_deliverable: the network read back, solved, recovered
    # the reduction the run used: {"radiation_aware", "ir_on", "chosen_by", "biot_cluster_max"}
    # (fem2tmm.stages.choose_reduction: what "auto" became, and why)
    reduction_choice: dict | None = None
    shared_network: dict | None = None  # load-case sets: {"linearised_at": case, "cases": [...]} sharing GL, GR, C
    radiation_aware: list[dict] | None = None  # one dict per outer iteration (max_dT_K, rms_dT_K, correction_W)
    refinement: object | None = None  # stages.Refinement of [reduction] target_rms: history, labels of every round
    # the reference's own noise: {"rms_K", "max_K"} from two independent half references, and their number
    reference_noise: dict | None = None
    reference_halves: int | None = None
    cache: dict[str, str] | None = None  # stage -> "computed" | "reused" (fem2tmm.cache; summary.json "cache")
    # orbit ([orbit]): fluxes traced on the FE faces (per face) and on the super faces (per side), how the reduced
    # model took them, the orbit-averaged loads, and per-position steady temperatures (k, n_dof) K
    orbit_detailed: OrbitalFluxes | None = None
    orbit_super_faces: OrbitalFluxes | None = None
    orbit_on: str | None = None
    orbit_T_positions: np.ndarray | None = None  # recovered (reduced) or detailed, one row per position
    orbit_T_positions_detailed: np.ndarray | None = None

    @property
    def orbit_fluxes(self) -> OrbitalFluxes | None:
        """The orbital fluxes the run used: on the FE faces, else on the super faces (None without [orbit])."""
        return self.orbit_detailed if self.orbit_detailed is not None else self.orbit_super_faces

    @property
    def T_detailed_nodes(self) -> np.ndarray | None:
        """(n_nodes,) detailed temperatures in K (NaN outside the model), or None."""
        return None if self.detailed is None else self.model.node_temperatures(self.detailed.T)

    @property
    def T_recovered_nodes(self) -> np.ndarray | None:
        """(n_nodes,) temperatures recovered from the reduced model in K (NaN outside the model), or None."""
        return None if self.T_recovered is None else self.model.node_temperatures(self.T_recovered)

    @property
    def T_nodes(self) -> np.ndarray:
        """The result temperatures (K) of every mesh node: recovered when reduced, detailed otherwise."""
        return self.T_recovered_nodes if self.T_recovered is not None else self.T_detailed_nodes


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
