"""The case's sections as validated frozen dataclasses (SI units, temperatures in K), and the names of the choices
each key accepts."""

from __future__ import annotations

from dataclasses import MISSING, dataclass, fields
from pathlib import Path
from typing import Any, Literal, get_args

from ..timefunc import Table


BoundaryKind = Literal["temperature", "power", "flux"]
SolarOn = Literal["detailed", "super_faces"]
Sampling = Literal["halton", "random"]
ReductionMethod = Literal["local", "global"]
CapacitanceMethod = Literal["cluster", "equivalent"]
ReducedNetwork = Literal["exact", "positive"]
ClusteringMethod = Literal["growing", "metis"]
ClusteringAllocation = Literal["area", "biot", "loads"]
TransientMethod = Literal["crank-nicolson", "backward-euler", "bdf2"]
TransientCapacitance = Literal["lumped", "consistent"]


@dataclass(frozen=True)
class Material:
    name: str
    conductivity: float | None  # W/(m K)
    density: float | None = None  # kg/m³
    specific_heat: float | None = None  # J/(kg K)


@dataclass(frozen=True)
class Optics:
    """Optical properties of one side of a surface (IR and solar bands).

    ``specular`` is the fraction of the reflected energy reflected specularly; ``transmissivity`` applies
    to both bands and ``transmission_specular`` is the fraction of the transmitted energy transmitted
    without change of direction.  IR reflectance = 1 - emissivity - transmissivity.
    """

    name: str
    emissivity: float
    absorptivity: float
    specular: float = 0.0
    transmissivity: float = 0.0
    transmission_specular: float = 1.0


NONE_OPTICS = "none"
#: the smallest non-zero emissivity accepted (real surfaces: 0.02 and up; below, a steady field runs to 1e50 K)
MIN_EMISSIVITY = 1e-3


@dataclass(frozen=True)
class Part:
    name: str
    groups: tuple[str, ...]
    material: str | None  # None: from the mesh (Nastran MAT4/MAT1)
    thickness: float | None  # m, shells; None: from the mesh (PSHELL)
    front: str  # optics name or "none"
    back: str
    super_nodes: int = 1
    quadric: bool | tuple[str, ...] = False  # True: the whole part; a tuple: only these groups of the part
    index: int = 0
    area: float | None = None  # m², line parts (bars); overrides the mesh's PBAR/PROD/... area


JointTreatment = Literal["conductance", "isothermal", "ignore"]
JOINT_TREATMENTS = get_args(JointTreatment)
JOINT_CARDS = ("RBE2", "RBE3", "CBUSH", "CELAS1", "CELAS2", "CGAP")


@dataclass(frozen=True)
class Joint:
    """How thermal joints (Nastran RBE2, RBE3, CBUSH, CELAS1/2, CGAP) conduct.

    The joints selected by ``cards`` (card types), ``pids`` (property ids) or ``elements`` (element ids) are
    ``conductance`` links (``conductance`` W/K per connection, or ``contact_conductance`` W/(m² K) over
    ``area`` m² per joint element, shared equally by its connections), ``isothermal`` (their nodes merged) or
    ``ignore`` (explicitly dropped).  When several entries select a joint, element ids win over PIDs, PIDs
    over card types.
    """

    treatment: JointTreatment
    cards: tuple[str, ...] = ()
    pids: tuple[int, ...] = ()
    elements: tuple[int, ...] = ()
    conductance: float | None = None  # W/K per connection
    contact_conductance: float | None = None  # W/(m² K)
    area: float | None = None  # m² per joint element
    name: str = ""
    index: int = 0


@dataclass(frozen=True)
class Boundary:
    """A boundary condition.  ``value`` is the value used by the steady analysis: the table's value at the
    ``[transient]`` start (0 s without a transient) when the value varies in time; ``table`` then holds the
    whole function of time (same units: K, W or W/m²)."""

    kind: BoundaryKind
    value: float  # K for temperature, W for power, W/m² for flux
    groups: tuple[str, ...] = ()
    nodes: tuple[int, ...] = ()  # original node (GRID) ids
    name: str = ""
    index: int = 0
    table: Table | None = None  # time-dependent value; None = constant


@dataclass(frozen=True)
class Environment:
    sink_temperature: float = 3.0  # K (at the [transient] start when it varies in time)
    sun_direction: tuple[float, float, float] | None = None  # unit vector from the model towards the Sun
    solar_flux: float = 0.0  # W/m²
    solar_on: SolarOn = "detailed"
    solar_rays_per_face: int = 100  # per FE face side (super_faces: per FE face of each super face)
    sink_table: Table | None = None  # K, time-dependent sink temperature; None = constant


@dataclass(frozen=True)
class RadiationSettings:
    enabled: bool = True  # face-to-face REFs; False: every active side sees only space
    rays_per_face: int | None = 1000
    ray_density: float | None = None  # rays per m²
    sampling: Sampling = "halton"
    seed: int = 0
    max_bounces: int = 1000
    target_lse: float | None = None
    # where the reduced model puts absorbed IR: "super_faces" (thesis: uniform over each super node), "detailed"
    # (rays from the super faces tallied on the FE face sides that absorb them) or "faces" (every FE side emits at
    # the recovered field): both need the radiation-aware reduction; "auto": "faces" with it, else "super_faces"
    ir_on: str = "auto"
    ir_rays_per_face: int = 100  # ir_on = "detailed": rays per FE face of each emitting super face ("faces": side)


@dataclass(frozen=True)
class ReductionSettings:
    enabled: bool = True
    method: ReductionMethod = "local"
    capacitance: CapacitanceMethod = "cluster"
    filter: float = 0.0  # relative threshold of the TMRT link filter (0 = off)
    keep_nodes: tuple[int, ...] = ()  # original node ids kept as one-node super nodes
    # radiation-aware reduction (fem2tmm.reduce.radiative): reduce K + diag(4σεA T_ref³) about a pre-solve; "auto":
    # the method with the smaller estimated error (reductors.choose_reduction, stages.choice.measured_choice)
    radiation_aware: bool | str = "auto"
    outer_iterations: int = 20  # most re-linearisations about T_ref (each: reduction, network solve, recovery)
    network: ReducedNetwork = "exact"  # exact (dense K_SN) | positive (sparse, positive GL between touching super nodes)
    # error-driven refinement (fem2tmm.reduce.refine): split the worst clusters until the estimated RMS <= target_rms
    target_rms: float | None = None  # K; None = no refinement
    max_super_nodes: int | None = None  # budget of the refinement (super nodes of the clusters); None = no cap
    refine_rounds: int = 5  # budget: most refinement rounds (each: split, re-cluster, re-reduce, re-trace)
    refine_rays_per_face: int = 20  # rays per FE face side of the estimator's side-to-side IR tally
    refine_estimator: str = "global"  # global (one detailed linear solve) | local (clusters' interiors, interfaces held)
    # radiation-aware network: its correction load also at these values of named parameters, one at a time, so that
    # the deck follows them (fem2tmm.reductors.radiation_aware.parametric_corrections): ((name, values), ...) with a
    # named [[boundary]] (values in SI: W, W/m², K) or "sink" (K)
    parametric: tuple[tuple[str, tuple[float, ...]], ...] = ()
    # the validity range the run verifies against the detailed reference (fem2tmm.verify): False skips it; the
    # ranges the user sets, ((name, low, high), ...) in SI (W, W/m², K), replace the automatic choice for those names
    verify: bool = True
    verify_range: tuple[tuple[str, float, float], ...] = ()


@dataclass(frozen=True)
class ClusteringSettings:
    feature_angle: float = 30.0
    seed: int = 0
    smoothing_layers: int = 2
    balance: bool = True  # clusters of equal area within regions, area-proportional allocation (False: thesis)
    method: ClusteringMethod = "growing"  # growing | metis (pymetis on each region)
    # loads (the default since 2026-12-07): more, smaller super nodes around the named power and flux loads that are
    # concentrated on shells (fem2tmm.stages.cluster.load_weights; elsewhere as area) | area: equal areas | biot:
    # shell elements weighted by their Biot number h_rad A/(k t) from an emission-to-space pre-solve
    # (fem2tmm.reduce.biot.biot_weights): more, smaller super nodes where heat spreads short distances
    allocation: ClusteringAllocation = "loads"
    # clusters follow a cheap solar pre-pass (fem2tmm.cluster.driver.flux_feature); None = automatic: on when
    # [environment] solar_on = "super_faces" and there is a Sun
    solar_aware: bool | None = None


@dataclass(frozen=True)
class ReferenceSettings:
    """The detailed reference model.  Its face-to-face REFs use ``rays_per_face`` rays per FE face side or
    ``ray_density`` rays/m² (default: the ``[radiation]`` budget)."""

    detailed: bool = True
    rays_per_face: int | None = None
    ray_density: float | None = None
    # estimate the reference's own ray noise: two independent half-budget references (REFs; detailed solar in
    # "super_faces" mode), the reference is their mean and its noise RMS(T_a - T_b)/2
    noise: bool = True
    # the detailed *steady* reference in a [transient] run with a numeric initial_temperature: solved only when asked
    # (it is never needed there, and a field at or near 0 K makes it hard); always solved otherwise
    steady: bool = False


@dataclass(frozen=True)
class SolverSettings:
    tolerance: float = 1e-9  # K, max |ΔT| of the last Newton step
    max_iterations: int = 200


TRANSIENT_METHODS = get_args(TransientMethod)


@dataclass(frozen=True)
class TransientSpec:
    """``[transient]``: times in s, temperatures in K.  ``step`` (fixed steps) or ``tolerance`` (K, adaptive
    steps; ``step`` is then the largest step); ``initial_temperature`` K or ``"steady"``."""

    end: float
    start: float = 0.0
    step: float | None = None
    tolerance: float | None = None
    output_every: float | None = None
    initial_temperature: float | str = "steady"
    method: TransientMethod = "crank-nicolson"
    capacitance: TransientCapacitance = "lumped"  # lumped | consistent (detailed FE model)
    periodic: bool = False
    periodic_tolerance: float = 0.01


@dataclass(frozen=True)
class ExportSettings:
    """How the decks name and number their model: ``model_name`` (ESATAN ``$MODEL``, SINDA submodel; "" = from
    the case file's name) and ``node_offset`` added to every node number, so that several exports merge into one
    spacecraft model without a clash."""

    model_name: str = ""
    node_offset: int = 0


@dataclass(frozen=True)
class ComputeSettings:
    """Where the work units run (``[compute]``, or ``fem2tmm run --scheduler``): ``scheduler`` "serial"
    (in-process, no Dask), "local" (a ``dask.distributed.LocalCluster`` of ``workers`` processes, default one per
    core) or the address of a running Dask scheduler ("tcp://host:8786")."""

    scheduler: str = "serial"
    workers: int | None = None


@dataclass(frozen=True)
class OrbitSettings:
    """``[orbit]`` (with ``[orbit.planet]`` and ``[orbit.attitude]``): the orbit, the planet, the Sun, the
    spacecraft's attitude and how the orbital fluxes are traced and used (DESIGN §4.5, issue 18).

    ``orbit`` an :class:`~fem2tmm.orbit.Orbit` (positions, eclipses, Sun), ``attitude`` an
    :class:`~fem2tmm.orbit.Attitude`; ``kinds`` of fluxes among solar, albedo, ir; ``rays_per_face``
    rays per FE face side and position (planet and solar; per FE face of each super face on super faces);
    ``fluxes_on`` "detailed" (traced on the FE faces, the reduced model takes them through the exact power
    distribution) or "super_faces" (traced on the super faces, uniform over each super node); ``steady``
    "average" (one steady solve with the orbit-averaged loads) or "positions" (plus one steady solve per
    position)."""

    orbit: Any
    attitude: Any
    kinds: tuple[str, ...] = ("solar", "albedo", "ir")
    rays_per_face: int = 100
    fluxes_on: str = "detailed"
    steady: str = "average"


@dataclass(frozen=True)
class MeshSpec:
    file: Path | None
    unit: str = "m"
    unit_system: str | None = None  # Nastran material/load values (fem2tmm.io.units.UNIT_SYSTEMS)
    temperature_unit: str | None = None  # K | C | F | R: the deck's temperature scale
    nastran_loads: bool | tuple[str, ...] = False  # read the deck's SPC/TEMP/QBDY/QVOL/RADBC (all or these cards)
    ignore_cards: tuple[str, ...] = ()  # unmodelled structural Nastran cards dropped explicitly
    load_set: int | None = None  # Nastran load set id (when the deck has several)
    spc_set: int | None = None  # Nastran SPC set id

    def reader_options(self) -> dict:
        """Keyword arguments of :func:`fem2tmm.io.read_mesh` beyond the file and unit."""
        return {"unit_system": self.unit_system, "temperature_unit": self.temperature_unit,
                "loads": self.nastran_loads, "ignore_cards": self.ignore_cards, "load_set": self.load_set,
                "spc_set": self.spc_set}


def _default(cls, name: str):
    """The default of field ``name`` of the settings dataclass ``cls`` (the one place it is written)."""
    for f in fields(cls):
        if f.name == name:
            return f.default if f.default is not MISSING else f.default_factory()
    raise KeyError(name)
