"""The TOML case file -> validated frozen dataclasses.  The only place that knows the schema.

Temperatures are °C in the file and Kelvin in the dataclasses; lengths in metres except ``[mesh] unit``
which is the length unit of the mesh file.  Every error names the file, the key and what was expected.
Unknown keys are errors (a typo must not silently change a model).

See DESIGN §4.2 for an annotated example.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import MISSING, dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal, Mapping, get_args

from .constants import ABSOLUTE_ZERO_C, KELVIN
from .errors import Fem2TmmError
from .io.units import LENGTH_UNITS, TEMPERATURE_UNITS, UNIT_SYSTEMS, unit_system_name
from .timefunc import Table, parse_table


BoundaryKind = Literal["temperature", "power", "flux"]
SolarOn = Literal["detailed", "super_faces"]
Sampling = Literal["halton", "random"]
ReductionMethod = Literal["local", "global"]
CapacitanceMethod = Literal["cluster", "equivalent"]
ReducedNetwork = Literal["exact", "positive"]
ClusteringMethod = Literal["growing", "metis"]
ClusteringAllocation = Literal["area", "biot"]
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
    # when some cluster's Biot number at the thesis' field reaches fem2tmm.reductors.AUTO_BIOT (reductors.choose_reduction)
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


@dataclass(frozen=True)
class ClusteringSettings:
    feature_angle: float = 30.0
    seed: int = 0
    smoothing_layers: int = 2
    balance: bool = True  # clusters of equal area within regions, area-proportional allocation (False: thesis)
    method: ClusteringMethod = "growing"  # growing | metis (pymetis on each region)
    # area | biot: shell elements weighted by their Biot number h_rad A/(k t) from an emission-to-space pre-solve
    # (fem2tmm.reduce.biot.biot_weights): more, smaller super nodes where heat spreads short distances
    allocation: ClusteringAllocation = "area"
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


@dataclass(frozen=True)
class Case:
    """A validated case.  Build it with :meth:`from_toml` or :meth:`from_dict`."""

    source: str
    mesh: MeshSpec
    materials: Mapping[str, Material]
    optics: Mapping[str, Optics]
    parts: tuple[Part, ...]
    boundaries: tuple[Boundary, ...] = ()
    joints: tuple[Joint, ...] = ()
    environment: Environment = field(default_factory=Environment)
    radiation: RadiationSettings = field(default_factory=RadiationSettings)
    reduction: ReductionSettings = field(default_factory=ReductionSettings)
    clustering: ClusteringSettings = field(default_factory=ClusteringSettings)
    reference: ReferenceSettings = field(default_factory=ReferenceSettings)
    solver: SolverSettings = field(default_factory=SolverSettings)
    compute: ComputeSettings = field(default_factory=ComputeSettings)
    export: ExportSettings = field(default_factory=ExportSettings)
    transient: TransientSpec | None = None
    orbit: OrbitSettings | None = None
    raw: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)
    base_dir: Path = field(default=Path("."), repr=False, compare=False)  # relative paths of the file start here
    name: str = ""  # the load case ([[cases]] name), "" for a single-case file

    @classmethod
    def from_toml(cls, path: str | Path) -> "Case":
        """Read and validate a case file (docs/case-file.md).

        Parameters
        ----------
        path : str or Path
            TOML case file; relative paths inside it start at its folder.

        Returns
        -------
        Case
            Every section validated, defaults filled in (SI units, temperatures in K).

        Raises
        ------
        Fem2TmmError
            Missing or unreadable file, invalid TOML, or an invalid key or value (named with file and key).
        """
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise Fem2TmmError(f"case file {path} does not exist") from None
        except OSError as exc:
            raise Fem2TmmError(f"case file {path} cannot be read: {exc}") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise Fem2TmmError(f"{path}: not valid TOML: {exc}") from None
        return cls.from_dict(data, base_dir=path.parent, source=str(path))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base_dir: str | Path = ".", source: str = "<case>") -> "Case":
        """Build and validate a case from the parsed TOML tables (same keys as the case file).

        Parameters
        ----------
        data : mapping
            ``{section: {key: value}}`` as :func:`tomllib.loads` returns it.
        base_dir : str or Path
            Folder that relative paths (mesh file, ...) start from.
        source : str
            Name used in error messages (the file path for :meth:`from_toml`).

        Returns
        -------
        Case

        Raises
        ------
        Fem2TmmError
            An unknown, missing or invalid key or value, naming ``source`` and the key.
        """
        return _Parser(source, Path(base_dir)).case(data)

    def with_changes(self, **sections) -> "Case":
        """A copy with some sections replaced, e.g. ``case.with_changes(reference=ReferenceSettings(False))``."""
        return replace(self, **sections)

    @property
    def has_sun(self) -> bool:
        """Whether the environment has a Sun: a direction and a positive solar flux."""
        env = self.environment
        return env.sun_direction is not None and env.solar_flux > 0

    @property
    def solar_aware(self) -> bool:
        """Whether the clustering follows a solar pre-pass: ``[clustering] solar_aware``, by default on when the
        super faces carry lumped solar loads (``solar_on = "super_faces"``), and only when there is a Sun."""
        flag = self.clustering.solar_aware
        if flag is None:
            flag = self.environment.solar_on == "super_faces"
        return bool(flag) and self.has_sun


# ---------------------------------------------------------------------------------------------- parser
def _default(cls, name: str):
    """The default of field ``name`` of the settings dataclass ``cls`` (the one place it is written)."""
    for f in fields(cls):
        if f.name == name:
            return f.default if f.default is not MISSING else f.default_factory()
    raise KeyError(name)


class _Parser:
    def __init__(self, source: str, base: Path):
        self.src = source
        self.base = base
        self.t0 = 0.0  # time (s) at which time tables give the steady value: [transient] start

    def err(self, where: str, msg: str) -> Fem2TmmError:
        return Fem2TmmError(f"{self.src}: {where}: {msg}")

    def table(self, data: Any, where: str, allowed: set[str], required: set[str] = frozenset()) -> dict:
        if not isinstance(data, Mapping):
            raise self.err(where, f"expected a table, got {type(data).__name__}")
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise self.err(where, f"unknown key(s) {', '.join(map(repr, unknown))}; allowed: {', '.join(sorted(allowed))}")
        missing = sorted(required - set(data))
        if missing:
            raise self.err(where, f"missing required key(s) {', '.join(map(repr, missing))}")
        return dict(data)

    def number(self, d: Mapping, key: str, where: str, default=None, lo=None, hi=None, lo_open=False,
               integer=False, required=False):
        if key not in d:
            if required:
                raise self.err(where, f"missing required key {key!r}")
            return default
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.err(f"{where}.{key}", f"expected a number, got {v!r}")
        if integer and (not float(v).is_integer()):
            raise self.err(f"{where}.{key}", f"expected an integer, got {v!r}")
        v = int(v) if integer else float(v)
        if not math.isfinite(v):
            raise self.err(f"{where}.{key}", f"expected a finite number, got {v!r}")
        if lo is not None and (v < lo or (lo_open and v == lo)):
            raise self.err(f"{where}.{key}", f"must be {'>' if lo_open else '>='} {lo}, got {v}")
        if hi is not None and v > hi:
            raise self.err(f"{where}.{key}", f"must be <= {hi}, got {v}")
        return v

    def string(self, d, key, where, default=None, choices=None, required=False):
        if key not in d:
            if required:
                raise self.err(where, f"missing required key {key!r}")
            return default
        v = d[key]
        if not isinstance(v, str):
            raise self.err(f"{where}.{key}", f"expected a string, got {v!r}")
        if choices is not None and v not in choices:
            raise self.err(f"{where}.{key}", f"must be one of {', '.join(map(repr, choices))}, got {v!r}")
        return v

    def boolean(self, d, key, where, default):
        v = d.get(key, default)
        if not isinstance(v, bool):
            raise self.err(f"{where}.{key}", f"expected true or false, got {v!r}")
        return v

    def boolean_or_auto(self, d, key, where, default):
        v = d.get(key, default)
        if not (isinstance(v, bool) or v == "auto"):
            raise self.err(f"{where}.{key}", f'expected true, false or "auto", got {v!r}')
        return v

    def strings(self, d, key, where) -> tuple[str, ...]:
        v = d.get(key, [])
        if isinstance(v, str):
            v = [v]
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise self.err(f"{where}.{key}", f"expected a list of strings, got {v!r}")
        return tuple(v)

    def ints(self, d, key, where) -> tuple[int, ...]:
        v = d.get(key, [])
        if not isinstance(v, list) or not all(isinstance(x, int) and not isinstance(x, bool) for x in v):
            raise self.err(f"{where}.{key}", f"expected a list of integer ids, got {v!r}")
        return tuple(v)

    # -------------------------------------------------------------------------------------- sections
    def case(self, data: Mapping[str, Any]) -> Case:
        top = self.table(data, "case", {"mesh", "materials", "optics", "parts", "boundary", "environment",
                                        "radiation", "reduction", "clustering", "reference", "solver", "joints",
                                        "transient", "compute", "cases", "sweep", "orbit", "export"},
                         {"parts"})
        from .loadcases import expand, has_cases

        if has_cases(top):
            expand(top, self.src)  # names, merge addresses and sweep tables checked before any computation
        mesh = self.mesh(top.get("mesh", {}))
        materials = {}
        for name, m in self.table(top.get("materials", {}), "[materials]", set(top.get("materials", {}) or {})).items():
            materials[name] = self.material(name, m)
        optics = {}
        for name, o in self.table(top.get("optics", {}), "[optics]", set(top.get("optics", {}) or {})).items():
            if name == NONE_OPTICS:
                raise self.err(f"[optics.{name}]", "'none' is reserved for inactive sides; choose another name")
            optics[name] = self.optic(name, o)
        parts_raw = top["parts"]
        if not isinstance(parts_raw, list) or not parts_raw:
            raise self.err("[[parts]]", "expected at least one [[parts]] entry")
        parts = tuple(self.part(i, p, materials, optics) for i, p in enumerate(parts_raw))
        names = [p.name for p in parts]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise self.err("[[parts]]", f"part names must be unique; repeated: {', '.join(dup)}")
        orbit = self.orbit(top["orbit"], top.get("environment", {})) if "orbit" in top else None
        tr = top.get("transient")
        if orbit is not None and isinstance(tr, Mapping) and tr.get("periodic") is True:
            # a periodic orbit transient: the period is the orbit's, end = start + period
            if "end" in tr:
                raise self.err("[transient].end", "with [orbit] and periodic = true the period is the orbital period "
                                                  f"({orbit.orbit.period:.3f} s): remove end")
            start = self.number(tr, "start", "[transient]", default=0.0)
            tr = {**tr, "end": start + orbit.orbit.period}
        transient = self.transient(tr) if tr is not None else None
        self.t0 = transient.start if transient is not None else 0.0
        b_raw = top.get("boundary", [])
        if not isinstance(b_raw, list):
            raise self.err("[[boundary]]", "expected an array of tables ([[boundary]] entries)")
        boundaries = tuple(self.boundary(i, b) for i, b in enumerate(b_raw))
        j_raw = top.get("joints", [])
        if not isinstance(j_raw, list):
            raise self.err("[[joints]]", "expected an array of tables ([[joints]] entries)")
        joints = tuple(self.joint(i, j) for i, j in enumerate(j_raw))
        radiation, reduction = self.radiation(top.get("radiation", {})), self.reduction(top.get("reduction", {}))
        reduction = replace(reduction, parametric=self.parametric(
            top.get("reduction", {}).get("parametric") if isinstance(top.get("reduction"), Mapping) else None,
            boundaries, reduction))
        if radiation.ir_on in ("detailed", "faces") and (reduction.radiation_aware is False or not radiation.enabled):
            raise self.err("[radiation].ir_on", f'"{radiation.ir_on}" places absorbed IR on the FE faces through the '
                           "radiation-aware reduction: set [reduction] radiation_aware = true or \"auto\" (and keep "
                           "[radiation] enabled)")
        return Case(
            source=self.src,
            mesh=mesh,
            materials=materials,
            optics=optics,
            parts=parts,
            boundaries=boundaries,
            joints=joints,
            environment=self.environment(top.get("environment", {})),
            radiation=radiation,
            reduction=reduction,
            clustering=self.clustering(top.get("clustering", {})),
            reference=self.reference(top.get("reference", {})),
            solver=self.solver(top.get("solver", {})),
            compute=self.compute(top.get("compute", {})),
            export=self.export(top.get("export", {})),
            transient=transient,
            orbit=orbit,
            raw=dict(data),
            base_dir=self.base,
        )

    def mesh(self, d) -> MeshSpec:
        w = "[mesh]"
        d = self.table(d, w, {"file", "unit", "unit_system", "temperature_unit", "nastran_loads", "ignore_cards",
                              "load_set", "spc_set"})
        f = self.string(d, "file", w)
        unit = self.string(d, "unit", w, default=_default(MeshSpec, "unit"))
        if unit.lower() not in LENGTH_UNITS:
            raise self.err("[mesh].unit", f"unknown length unit {unit!r}; expected one of {', '.join(LENGTH_UNITS)}")
        system = self.string(d, "unit_system", w)
        if system is not None:
            system = unit_system_name(system, where=f"{self.src}: [mesh].unit_system")
            sys_len = UNIT_SYSTEMS[system][0]
            if "unit" in d and abs(LENGTH_UNITS[unit.lower()] - sys_len) > 1e-12 * sys_len:
                raise self.err(w, f"unit = {unit!r} contradicts unit_system = {system!r}; give one of them")
            unit = next(u for u, v in LENGTH_UNITS.items() if abs(v - sys_len) <= 1e-12 * sys_len)
        tu = self.string(d, "temperature_unit", w, choices=tuple(TEMPERATURE_UNITS))
        loads = d.get("nastran_loads", False)
        if not isinstance(loads, bool):
            loads = self.strings(d, "nastran_loads", w)
            from .io.nastran import _LOAD_CARDS

            bad = [c for c in loads if c.upper() not in _LOAD_CARDS]
            if bad:
                raise self.err(f"{w}.nastran_loads", f"unknown load card(s) {bad}; expected true/false or a list "
                               f"of {', '.join(_LOAD_CARDS)}")
            loads = tuple(c.upper() for c in loads)
        return MeshSpec(file=(self.base / f) if f is not None else None, unit=unit.lower(), unit_system=system,
                        temperature_unit=tu, nastran_loads=loads,
                        ignore_cards=tuple(c.upper() for c in self.strings(d, "ignore_cards", w)),
                        load_set=self.number(d, "load_set", w, integer=True, lo=1),
                        spc_set=self.number(d, "spc_set", w, integer=True, lo=1))

    def joint(self, i, d) -> Joint:
        w = f"[[joints]][{i}]"
        d = self.table(d, w, {"name", "cards", "pids", "elements", "treatment", "conductance",
                              "contact_conductance", "area"}, {"treatment"})
        treat = self.string(d, "treatment", w, choices=JOINT_TREATMENTS)
        cards = tuple(c.upper() for c in self.strings(d, "cards", w))
        bad = [c for c in cards if c not in JOINT_CARDS]
        if bad:
            raise self.err(f"{w}.cards", f"{bad} are not joint cards; joint cards: {', '.join(JOINT_CARDS)}")
        pids, elements = self.ints(d, "pids", w), self.ints(d, "elements", w)
        if not (cards or pids or elements):
            raise self.err(w, "select joints with 'cards', 'pids' and/or 'elements'")
        g = self.number(d, "conductance", w, lo=0, lo_open=True)
        h = self.number(d, "contact_conductance", w, lo=0, lo_open=True)
        area = self.number(d, "area", w, lo=0, lo_open=True)
        if treat == "conductance":
            if (g is None) == (h is None):
                raise self.err(w, "a conductance joint needs either 'conductance' (W/K per connection) or "
                                  "'contact_conductance' (W/(m² K)) with 'area' (m²)")
            if h is not None and area is None:
                raise self.err(w, "'contact_conductance' needs 'area' (m² of contact per joint element)")
        elif g is not None or h is not None or area is not None:
            raise self.err(w, f"conductance/contact_conductance/area only apply to treatment = 'conductance', "
                              f"not {treat!r}")
        return Joint(treatment=treat, cards=cards, pids=pids, elements=elements, conductance=g,
                     contact_conductance=h, area=area, name=self.string(d, "name", w, default=f"joints_{i}"),
                     index=i)

    def material(self, name, d) -> Material:
        w = f"[materials.{name}]"
        d = self.table(d, w, {"conductivity", "density", "specific_heat"}, {"conductivity"})
        return Material(
            name=name,
            conductivity=self.number(d, "conductivity", w, lo=0, lo_open=True),
            density=self.number(d, "density", w, lo=0, lo_open=True),
            specific_heat=self.number(d, "specific_heat", w, lo=0, lo_open=True),
        )

    def optic(self, name, d) -> Optics:
        w = f"[optics.{name}]"
        d = self.table(d, w, {"emissivity", "absorptivity", "specular", "transmissivity", "transmission_specular"},
                       {"emissivity"})
        eps = self.number(d, "emissivity", w, lo=0, hi=1)
        if 0 < eps < MIN_EMISSIVITY:
            raise self.err(f"{w}.emissivity", f"{eps:g} is below any real surface's (polished gold about 0.02): use 0 "
                           f"for a side that does not radiate, or at least {MIN_EMISSIVITY:g}")
        alpha = self.number(d, "absorptivity", w, default=eps, lo=0, hi=1)
        tau = self.number(d, "transmissivity", w, default=_default(Optics, "transmissivity"), lo=0, hi=1)
        if eps + tau > 1 + 1e-12:
            raise self.err(w, f"emissivity + transmissivity = {eps + tau} exceeds 1")
        if alpha + tau > 1 + 1e-12:
            raise self.err(w, f"absorptivity + transmissivity = {alpha + tau} exceeds 1")
        return Optics(
            name=name,
            emissivity=eps,
            absorptivity=alpha,
            specular=self.number(d, "specular", w, default=_default(Optics, "specular"), lo=0, hi=1),
            transmissivity=tau,
            transmission_specular=self.number(d, "transmission_specular", w, lo=0, hi=1,
                                              default=_default(Optics, "transmission_specular")),
        )

    def part(self, i, d, materials, optics) -> Part:
        w = f"[[parts]][{i}]"
        d = self.table(d, w, {"name", "groups", "material", "thickness", "front", "back", "super_nodes", "quadric",
                              "area"}, {"name", "groups"})
        name = self.string(d, "name", w)
        w = f"[[parts]][{i}] ({name!r})"
        groups = self.strings(d, "groups", w)
        if not groups:
            raise self.err(f"{w}.groups", "expected at least one mesh group")
        mat = self.string(d, "material", w)
        if mat is not None and mat not in materials:
            raise self.err(f"{w}.material", f"{mat!r} is not a defined material; defined: {', '.join(materials) or '(none)'}")
        sides = {}
        for side in ("front", "back"):
            o = self.string(d, side, w, default=NONE_OPTICS)
            if o != NONE_OPTICS and o not in optics:
                raise self.err(f"{w}.{side}", f"{o!r} is not a defined optics; defined: {', '.join(optics) or '(none)'}, or 'none'")
            sides[side] = o
        return Part(
            name=name,
            groups=groups,
            material=mat,
            thickness=self.number(d, "thickness", w, lo=0, lo_open=True),
            front=sides["front"],
            back=sides["back"],
            super_nodes=self.number(d, "super_nodes", w, default=_default(Part, "super_nodes"), lo=1, integer=True),
            quadric=self.quadric(d, w, groups),
            index=i,
            area=self.number(d, "area", w, lo=0, lo_open=True),
        )

    def quadric(self, d, w, groups) -> bool | tuple[str, ...]:
        v = d.get("quadric", False)
        if isinstance(v, bool):
            return v
        if isinstance(v, list) and all(isinstance(x, str) for x in v):
            missing = [x for x in v if x not in groups]
            if missing:
                raise self.err(f"{w}.quadric", f"groups {missing} are not groups of this part ({list(groups)})")
            return tuple(v) if v else False
        raise self.err(f"{w}.quadric", f"expected true/false or a list of this part's groups, got {v!r}")

    def boundary(self, i, d) -> Boundary:
        w = f"[[boundary]][{i}]"
        d = self.table(d, w, {"kind", "groups", "nodes", "value", "name"}, {"kind", "value"})
        kind = self.string(d, "kind", w, choices=get_args(BoundaryKind))
        groups, nodes = self.strings(d, "groups", w), self.ints(d, "nodes", w)
        if not groups and not nodes:
            raise self.err(w, "give 'groups' (mesh group names) and/or 'nodes' (original node ids)")
        table = None
        if isinstance(d["value"], (list, str)):
            table = self.time_table(d["value"], f"{w}.value", kelvin=kind == "temperature")
            v = table(self.t0)
        elif kind == "temperature":
            v = self.number(d, "value", w, lo=ABSOLUTE_ZERO_C, lo_open=True) + KELVIN
        else:
            v = self.number(d, "value", w)
        return Boundary(kind=kind, value=v, groups=groups, nodes=nodes, name=self.string(d, "name", w, default=f"{kind}_{i}"),
                        index=i, table=table)

    def time_table(self, value, where: str, kelvin: bool) -> Table:
        """A value given as ``[[t, v], ...]`` or a two-column CSV file; °C -> K when ``kelvin``."""
        table = parse_table(value, where, self.base)
        if kelvin:
            if not table.v.min() > ABSOLUTE_ZERO_C:
                raise self.err(where, f"temperatures must be above {ABSOLUTE_ZERO_C} °C, got {table.v.min()}")
            table = table.mapped(lambda v: v + KELVIN)
        return table

    def environment(self, d) -> Environment:
        w = "[environment]"
        d = self.table(d, w, {"sink_temperature", "sun_direction", "solar_flux", "solar_on", "solar_rays_per_face"})
        sink_table = None
        if isinstance(d.get("sink_temperature"), (list, str)):
            sink_table = self.time_table(d["sink_temperature"], f"{w}.sink_temperature", kelvin=True)
            sink = sink_table(self.t0)
        else:
            sink = self.number(d, "sink_temperature", w, default=_default(Environment, "sink_temperature") - KELVIN,
                               lo=ABSOLUTE_ZERO_C) + KELVIN
        sun = d.get("sun_direction")
        if sun is not None:
            if (not isinstance(sun, list) or len(sun) != 3
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in sun)):
                raise self.err(f"{w}.sun_direction", f"expected three numbers [x, y, z], got {sun!r}")
            norm = math.sqrt(sum(float(x) ** 2 for x in sun))
            if not norm > 0:
                raise self.err(f"{w}.sun_direction", "must not be the zero vector")
            sun = tuple(float(x) / norm for x in sun)
        flux = self.number(d, "solar_flux", w, default=_default(Environment, "solar_flux"), lo=0)
        if flux > 0 and sun is None:
            raise self.err(w, "solar_flux is given but sun_direction is not")
        return Environment(sink_temperature=sink, sun_direction=sun, solar_flux=flux, sink_table=sink_table,
                           solar_on=self.string(d, "solar_on", w, default=_default(Environment, "solar_on"),
                                                choices=get_args(SolarOn)),
                           solar_rays_per_face=self.number(d, "solar_rays_per_face", w, lo=1, integer=True,
                                                           default=_default(Environment, "solar_rays_per_face")))

    def orbit(self, d, environment) -> OrbitSettings:
        from .orbit import Attitude, Orbit, Planet

        w = "[orbit]"
        d = self.table(d, "[orbit]", {"altitude", "semi_major_axis", "eccentricity", "inclination", "raan",
                                      "argument_of_perigee", "beta", "sun_argument", "date", "solar_flux", "positions",
                                      "eclipse", "kinds", "rays_per_face", "fluxes_on", "steady", "planet",
                                      "attitude"})
        if isinstance(environment, Mapping) and ("sun_direction" in environment or "solar_flux" in environment):
            raise self.err("[environment]", "sun_direction / solar_flux are set by [orbit] (the Sun by beta or date, "
                                            "[orbit] solar_flux); remove them from [environment]")
        wp = "[orbit.planet]"
        p = self.table(d.get("planet", {}), "[orbit.planet]", {"radius", "mu", "albedo", "ir_temperature",
                                                              "ir_emissivity", "ir_flux"})
        ir_t = self.number(p, "ir_temperature", wp, default=288.0 - KELVIN, lo=ABSOLUTE_ZERO_C)
        planet = Planet(radius=self.number(p, "radius", wp, default=6_378_136.0, lo=0, lo_open=True),
                        mu=self.number(p, "mu", wp, default=3.986004418e14, lo=0, lo_open=True),
                        albedo=self.number(p, "albedo", wp, default=0.3, lo=0, hi=1),
                        ir_temperature=ir_t + KELVIN,
                        ir_emissivity=self.number(p, "ir_emissivity", wp, default=1.0, lo=0, hi=1),
                        ir_flux=self.number(p, "ir_flux", wp, lo=0))
        date = d.get("date")
        if date is not None and not isinstance(date, str) and not hasattr(date, "year"):
            raise self.err(f"{w}.date", f"expected a date (2026-06-21T12:00:00 or a TOML date-time), got {date!r}")
        flux = d.get("solar_flux", 1366.1)
        if not (flux == "distance" or (isinstance(flux, (int, float)) and not isinstance(flux, bool))):
            raise self.err(f"{w}.solar_flux", f"expected a flux in W/m² or \"distance\", got {flux!r}")
        positions = d.get("positions", 24)
        if not ((isinstance(positions, int) and not isinstance(positions, bool)) or (
                isinstance(positions, list) and all(isinstance(x, (int, float)) for x in positions))):
            raise self.err(f"{w}.positions", f"expected a number of positions or a list of true anomalies (deg), "
                                             f"got {positions!r}")
        num = lambda k, default=None: self.number(d, k, w, default=default)  # noqa: E731
        try:
            orbit = Orbit.make(planet, altitude=num("altitude"), semi_major_axis=num("semi_major_axis"),
                               eccentricity=num("eccentricity", 0.0), inclination=num("inclination", 0.0),
                               raan=num("raan", 0.0), argument_of_perigee=num("argument_of_perigee", 0.0),
                               beta=num("beta"), sun_argument=num("sun_argument", 0.0), date=date, solar_flux=flux,
                               positions=positions, eclipse=self.string(d, "eclipse", w, default="cylindrical"),
                               where=f"{self.src}: {w}")
            a = self.table(d.get("attitude", {}), "[orbit.attitude]", {"kind", "primary", "secondary", "axes",
                                                                        "rotation"})
            attitude = Attitude.make(self.string(a, "kind", "[orbit.attitude]", default="nadir"), a.get("primary"),
                                     a.get("secondary"), a.get("axes"), a.get("rotation"),
                                     where=f"{self.src}: [orbit.attitude]")
        except (TypeError, ValueError) as exc:
            raise self.err(w, f"invalid value: {exc}") from None
        kinds = self.strings(d, "kinds", w) or ("solar", "albedo", "ir")
        bad = [k for k in kinds if k not in ("solar", "albedo", "ir")]
        if bad or len(set(kinds)) != len(kinds):
            raise self.err(f"{w}.kinds", f"expected distinct names among solar, albedo, ir, got {list(kinds)}")
        return OrbitSettings(orbit=orbit, attitude=attitude, kinds=tuple(kinds),
                             rays_per_face=self.number(d, "rays_per_face", w, default=100, lo=1, integer=True),
                             fluxes_on=self.string(d, "fluxes_on", w, default="detailed",
                                                   choices=("detailed", "super_faces")),
                             steady=self.string(d, "steady", w, default="average", choices=("average", "positions")))

    def radiation(self, d) -> RadiationSettings:
        w = "[radiation]"
        d = self.table(d, w, {"enabled", "rays_per_face", "ray_density", "sampling", "seed", "max_bounces", "target_lse",
                              "ir_on", "ir_rays_per_face"})
        rpf = self.number(d, "rays_per_face", w, lo=1, integer=True)
        dens = self.number(d, "ray_density", w, lo=0, lo_open=True)
        if rpf is not None and dens is not None:
            raise self.err(w, "give either rays_per_face or ray_density, not both")
        if rpf is None and dens is None:
            rpf = _default(RadiationSettings, "rays_per_face")
        D = lambda name: _default(RadiationSettings, name)  # noqa: E731
        return RadiationSettings(
            enabled=self.boolean(d, "enabled", w, D("enabled")),
            rays_per_face=rpf,
            ray_density=dens,
            sampling=self.string(d, "sampling", w, default=D("sampling"), choices=get_args(Sampling)),
            seed=self.number(d, "seed", w, default=D("seed"), lo=0, integer=True),
            max_bounces=self.number(d, "max_bounces", w, default=D("max_bounces"), lo=1, integer=True),
            target_lse=self.number(d, "target_lse", w, lo=0, lo_open=True),
            ir_on=self.string(d, "ir_on", w, default="auto", choices=("auto", "super_faces", "detailed", "faces")),
            ir_rays_per_face=self.number(d, "ir_rays_per_face", w, default=100, lo=1, integer=True),
        )

    def reduction(self, d) -> ReductionSettings:
        w = "[reduction]"
        d = self.table(d, w, {"enabled", "method", "capacitance", "filter", "keep_nodes", "network", "radiation_aware",
                              "outer_iterations", "target_rms", "max_super_nodes", "refine_rounds",
                              "refine_rays_per_face", "refine_estimator", "parametric"})
        if d.get("radiation_aware") is True and d.get("network", "exact") == "positive":
            raise self.err(w, "radiation_aware = true needs network = \"exact\" (the radiation-aware network is "
                              "K'_SN - diag(H_SN) with a correction load; the positive fit is not defined for it)")
        D = lambda name: _default(ReductionSettings, name)  # noqa: E731
        return ReductionSettings(
            enabled=self.boolean(d, "enabled", w, D("enabled")),
            method=self.string(d, "method", w, default=D("method"), choices=get_args(ReductionMethod)),
            capacitance=self.string(d, "capacitance", w, default=D("capacitance"), choices=get_args(CapacitanceMethod)),
            filter=self.number(d, "filter", w, default=D("filter"), lo=0, hi=1),
            keep_nodes=self.ints(d, "keep_nodes", w),
            radiation_aware=self.boolean_or_auto(d, "radiation_aware", w, D("radiation_aware")),
            outer_iterations=self.number(d, "outer_iterations", w, default=D("outer_iterations"), lo=1, integer=True),
            network=self.string(d, "network", w, default=D("network"), choices=get_args(ReducedNetwork)),
            target_rms=self.number(d, "target_rms", w, lo=0, lo_open=True),
            max_super_nodes=self.number(d, "max_super_nodes", w, lo=1, integer=True),
            refine_rounds=self.number(d, "refine_rounds", w, default=D("refine_rounds"), lo=0, integer=True),
            refine_rays_per_face=self.number(d, "refine_rays_per_face", w, default=D("refine_rays_per_face"), lo=1,
                                             integer=True),
            refine_estimator=self.string(d, "refine_estimator", w, default=D("refine_estimator"),
                                         choices=("global", "local")),
        )

    def parametric(self, d, boundaries, reduction) -> tuple:
        """``[reduction] parametric = {name = [values], ...}``: named power / flux / temperature boundaries (case units:
        W, W/m², °C) or ``sink`` (°C) and the values the radiation-aware correction is also computed at; SI out."""
        w = "[reduction].parametric"
        if d is None:
            return ()
        if not isinstance(d, Mapping) or not d:
            raise self.err(w, "expected a table {name = [values], ...} of named [[boundary]] entries or sink")
        if not reduction.enabled or reduction.radiation_aware is False:
            raise self.err(w, "the correction load it tabulates is the radiation-aware network's (the thesis' network "
                              "is state-independent: a named constant changed in the deck already gives what fem2tmm "
                              "gives): remove it, or keep [reduction] radiation_aware = \"auto\" or true")
        named = {b.name: b for b in boundaries}
        out = []
        for name, values in d.items():
            where = f"{w}.{name}"
            if name == "sink":
                if any(n.strip().upper() == "SINK" for n in named):
                    raise self.err(where, "a [[boundary]] is named 'sink', which parametric keeps for the sink "
                                          "temperature: rename that boundary")
                offset, lo = KELVIN, ABSOLUTE_ZERO_C
            elif name in named:
                b = named[name]
                if b.kind not in ("power", "flux", "temperature"):
                    raise self.err(where, f"[[boundary]] {name!r} is a {b.kind} boundary: only power, flux and "
                                          "temperature boundaries are deck constants")
                if b.table is not None:
                    raise self.err(where, f"[[boundary]] {name!r} follows a table in time; a parametric value "
                                          "would have no meaning there")
                offset, lo = (KELVIN, ABSOLUTE_ZERO_C) if b.kind == "temperature" else (0.0, None)
            else:
                raise self.err(where, f"no [[boundary]] named {name!r} (named boundaries: "
                                      f"{', '.join(sorted(n for n in named if n)) or 'none'}; or sink)")
            if not isinstance(values, list) or not values:
                raise self.err(where, "expected a non-empty list of values")
            vals = []
            for v in values:
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise self.err(where, f"{v!r} is not a number")
                if lo is not None and v <= lo:
                    raise self.err(where, f"{v!r} °C is at or below absolute zero")
                vals.append(float(v) + offset)
            if len(set(vals)) != len(vals):
                raise self.err(where, "repeated values")
            out.append((name, tuple(vals)))
        return tuple(out)

    def clustering(self, d) -> ClusteringSettings:
        w = "[clustering]"
        d = self.table(d, w, {"feature_angle", "seed", "smoothing_layers", "solar_aware", "balance", "method",
                                  "allocation"})
        aware = d.get("solar_aware")
        D = lambda name: _default(ClusteringSettings, name)  # noqa: E731
        return ClusteringSettings(
            solar_aware=None if aware is None else self.boolean(d, "solar_aware", w, None),
            feature_angle=self.number(d, "feature_angle", w, default=D("feature_angle"), lo=0, hi=180),
            seed=self.number(d, "seed", w, default=D("seed"), lo=0, integer=True),
            smoothing_layers=self.number(d, "smoothing_layers", w, default=D("smoothing_layers"), lo=0, integer=True),
            balance=self.boolean(d, "balance", w, D("balance")),
            method=self.string(d, "method", w, default=D("method"), choices=get_args(ClusteringMethod)),
            allocation=self.string(d, "allocation", w, default=D("allocation"), choices=get_args(ClusteringAllocation)),
        )

    def reference(self, d) -> ReferenceSettings:
        w = "[reference]"
        d = self.table(d, w, {"detailed", "rays_per_face", "ray_density", "noise", "steady"})
        rpf = self.number(d, "rays_per_face", w, lo=1, integer=True)
        dens = self.number(d, "ray_density", w, lo=0, lo_open=True)
        if rpf is not None and dens is not None:
            raise self.err(w, "give either rays_per_face or ray_density, not both")
        return ReferenceSettings(detailed=self.boolean(d, "detailed", w, _default(ReferenceSettings, "detailed")), rays_per_face=rpf, ray_density=dens,
                                 noise=self.boolean(d, "noise", w, _default(ReferenceSettings, "noise")),
                                 steady=self.boolean(d, "steady", w, _default(ReferenceSettings, "steady")))

    def export(self, d) -> ExportSettings:
        w = "[export]"
        d = self.table(d, w, {"model_name", "node_offset"})
        name = self.string(d, "model_name", w, default="")
        if name and not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,23}", name):
            raise self.err(f"{w}.model_name", f"must start with a letter and hold at most 24 letters, digits or "
                                              f"underscores (ESATAN's model names), got {name!r}")
        off = self.number(d, "node_offset", w, default=0, lo=0, integer=True)
        return ExportSettings(model_name=name, node_offset=int(off))

    def compute(self, d) -> ComputeSettings:
        w = "[compute]"
        d = self.table(d, w, {"scheduler", "workers"})
        return ComputeSettings(scheduler=check_scheduler(self.string(d, "scheduler", w, default="serial"),
                                                         f"{self.src}: {w}.scheduler"),
                               workers=self.number(d, "workers", w, lo=1, integer=True))

    def solver(self, d) -> SolverSettings:
        w = "[solver]"
        d = self.table(d, w, {"tolerance", "max_iterations"})
        D = lambda name: _default(SolverSettings, name)  # noqa: E731
        return SolverSettings(tolerance=self.number(d, "tolerance", w, default=D("tolerance"), lo=0, lo_open=True),
                              max_iterations=self.number(d, "max_iterations", w, default=D("max_iterations"), lo=1,
                                                         integer=True))

    def transient(self, d) -> TransientSpec:
        w = "[transient]"
        d = self.table(d, w, {"end", "start", "step", "tolerance", "output_every", "initial_temperature", "method",
                              "capacitance", "periodic", "periodic_tolerance"}, {"end"})
        start = self.number(d, "start", w, default=_default(TransientSpec, "start"))
        end = self.number(d, "end", w, required=True)
        if not end > start:
            raise self.err(f"{w}.end", f"must be after start ({start} s), got {end}")
        step = self.number(d, "step", w, lo=0, lo_open=True)
        tol = self.number(d, "tolerance", w, lo=0, lo_open=True)
        if step is not None and step > end - start:
            raise self.err(f"{w}.step", f"the step ({step} s) is longer than the transient itself (end - start = "
                                       f"{end} - {start} = {end - start} s): give a step of at most {end - start} s")
        if step is None and tol is None:
            raise self.err(w, "give 'step' (s, fixed time steps) or 'tolerance' (K, adaptive steps; 'step' is then "
                              "the largest step)")
        init = d.get("initial_temperature", "steady")
        if isinstance(init, str):
            if init != "steady":
                raise self.err(f"{w}.initial_temperature", f"expected a temperature (°C) or \"steady\", got {init!r}")
        else:
            init = self.number(d, "initial_temperature", w, lo=ABSOLUTE_ZERO_C, lo_open=True) + KELVIN
        return TransientSpec(
            end=end, start=start, step=step, tolerance=tol,
            output_every=self.number(d, "output_every", w, lo=0, lo_open=True),
            initial_temperature=init,
            method=self.string(d, "method", w, default=_default(TransientSpec, "method"), choices=TRANSIENT_METHODS),
            capacitance=self.string(d, "capacitance", w, default=_default(TransientSpec, "capacitance"),
                                    choices=get_args(TransientCapacitance)),
            periodic=self.boolean(d, "periodic", w, _default(TransientSpec, "periodic")),
            periodic_tolerance=self.number(d, "periodic_tolerance", w, default=_default(TransientSpec, "periodic_tolerance"),
                                           lo=0, lo_open=True),
        )


_ADDRESS = re.compile(r"^(tcp|tls|ucx|ws|wss)://[^\s/]+:\d+/?$")


def check_scheduler(value: str, where: str) -> str:
    """``value`` if it names a scheduler: "serial", "local" or an address "tcp://host:port"."""
    if value in ("serial", "local") or _ADDRESS.match(value):
        return value
    raise Fem2TmmError(f"{where}: expected 'serial', 'local' or a Dask scheduler address like "
                       f"'tcp://host:8786', got {value!r}")
