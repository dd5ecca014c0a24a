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
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Mapping

from ..errors import Fem2TmmError
from ..loadcases import expand, has_cases
from .environment_tables import _EnvironmentTables
from .model_tables import _ModelTables
from .settings_tables import _SettingsTables
from .types import (Boundary, ClusteringSettings, ComputeSettings, Environment, ExportSettings, Joint, Material,
                    MeshSpec, NONE_OPTICS, Optics, OrbitSettings, Part, RadiationSettings, ReductionSettings,
                    ReferenceSettings, SolverSettings, TransientSpec)


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


class _Parser(_ModelTables, _EnvironmentTables, _SettingsTables):
    """The case file's reader: the checks every table shares and the top level (:meth:`case`); each table's
    own method comes from its mixin (model, environment, settings tables)."""

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
            unit = (": write the number alone, no quotes, in SI units (m, W, W/(m K); temperatures in °C)"
                    if isinstance(v, str) and re.match(r"\s*[-+]?\.?\d", v) else "")  # "2 mm", "170 W/mK"
            raise self.err(f"{where}.{key}", f"expected a number, got {v!r}{unit}")
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
        reduction = replace(reduction, **self.verify(
            top.get("reduction", {}).get("verify") if isinstance(top.get("reduction"), Mapping) else None, boundaries))
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


def load_cases(case) -> list[tuple[str, Any, dict]]:
    """The validated cases of a :class:`~fem2tmm.case.Case` read from a file with ``[[cases]]``/``[sweep]``:
    ``[(name, Case, parameters), ...]``, each parsed with its own name in its messages
    (``case.toml [case 'hot']: [optics.paint].absorptivity: ...``).  A single-case file gives
    ``[("", case, {})]`` (the case itself, unchanged).  Each case's ``raw`` is its merged dictionary."""
    raw = dict(case.raw)
    if not has_cases(raw):
        return [("", case, {})]
    out = []
    for spec in expand(raw, case.source):
        c = Case.from_dict(spec.data, base_dir=Path(case.base_dir), source=f"{case.source} [case {spec.name!r}]")
        # messages name the case; the case keeps the file as its source and the base file's [compute]
        out.append((spec.name, replace(c, source=case.source, name=spec.name, compute=case.compute), spec.parameters))
    return out


def load(path: str | Path) -> Case:
    """Read and validate a case file: :meth:`Case.from_toml` (docs/case-file.md)."""
    return Case.from_toml(path)
