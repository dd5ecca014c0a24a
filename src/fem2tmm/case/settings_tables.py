"""The parser's settings tables: ``[radiation]``, ``[reduction]`` (and its parametric constants),
``[clustering]``, ``[reference]``, ``[export]``, ``[compute]``, ``[solver]``, ``[transient]``.
"""

from __future__ import annotations

import math
import re
from typing import Mapping, get_args

from ..constants import ABSOLUTE_ZERO_C, KELVIN
from ..errors import Fem2TmmError
from .types import (CapacitanceMethod, ClusteringAllocation, ClusteringMethod, ClusteringSettings, ComputeSettings,
                    ExportSettings, RadiationSettings, ReducedNetwork, ReductionMethod, ReductionSettings,
                    ReferenceSettings, Sampling, SolverSettings, TRANSIENT_METHODS, TransientCapacitance, TransientSpec,
                    _default)


class _SettingsTables:
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
                              "refine_rays_per_face", "refine_estimator", "parametric", "verify"})
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

    def _deck_constant(self, where: str, key, boundaries, if_tabled: str) -> tuple:
        """The deck constant ``key`` names in ``[reduction] parametric`` / ``verify``: ``sink`` or a named power, flux
        or temperature ``[[boundary]]`` without a time table (any case, as ESATAN reads names).  Returns ``(name,
        offset, lowest, unit)``: the boundary's own name, the offset from case units to SI (273.15 for °C), the
        case-unit value at or below which the constant is unphysical (None: no bound) and the case unit."""
        if str(key).lower() == "sink":
            return "sink", KELVIN, ABSOLUTE_ZERO_C, "°C"
        named = {b.name.upper(): b for b in boundaries if b.name}
        b = named.get(str(key).upper())
        if b is None:
            raise self.err(where, f"no [[boundary]] named {key!r} (named boundaries: "
                                  f"{', '.join(sorted(b.name for b in boundaries if b.name)) or 'none'}; or sink)")
        if b.kind not in ("power", "flux", "temperature"):
            raise self.err(where, f"[[boundary]] {b.name!r} is a {b.kind} boundary: only power, flux and "
                                  "temperature boundaries are deck constants")
        if b.table is not None:
            raise self.err(where, f"[[boundary]] {b.name!r} follows a table in time: {if_tabled}")
        if b.kind == "temperature":
            return b.name, KELVIN, ABSOLUTE_ZERO_C, "°C"
        return b.name, 0.0, None, "W" if b.kind == "power" else "W/m²"

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
        out = []
        for key, values in d.items():
            where = f"{w}.{key}"
            if str(key).lower() == "sink" and any(b.name.strip().upper() == "SINK" for b in boundaries if b.name):
                raise self.err(where, "a [[boundary]] is named 'sink', which parametric keeps for the sink "
                                      "temperature: rename that boundary")
            name, offset, lo, _ = self._deck_constant(where, key, boundaries, "a parametric value would have no "
                                                                              "meaning there")
            if any(n == name for n, _ in out):
                raise self.err(where, f"{name!r} is given twice")
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

    def verify(self, d, boundaries) -> dict:
        """``[reduction] verify``: ``true`` (default: the range chosen from the case, :mod:`fem2tmm.verify`),
        ``false`` (not verified) or ``{name = [low, high], ...}`` of named power / flux / temperature boundaries
        (W, W/m², °C; the name as in ``[[boundary]]``, any case) or ``sink`` (°C): the range of those constants;
        the others keep the automatic range.  Returns ``{"verify": bool, "verify_range": ((name, low, high), ...)}``
        in SI with each boundary's own name."""
        w = "[reduction].verify"
        if d is None or d is True:
            return {"verify": True, "verify_range": ()}
        if d is False:
            return {"verify": False, "verify_range": ()}
        if not isinstance(d, Mapping) or not d:
            raise self.err(w, "expected true, false or a table {name = [low, high], ...} of named [[boundary]] "
                              "entries or sink, e.g. verify = {heater = [0, 40], sink = [-270, 20]}")
        out = []
        for key, values in d.items():
            where = f"{w}.{key}"
            name, offset, lo_abs, unit = self._deck_constant(where, key, boundaries,
                                                             "it is not a constant of the deck; remove it from verify")
            if any(n == name for n, _, _ in out):
                raise self.err(where, f"{name!r} is given twice")
            if (not isinstance(values, list) or len(values) != 2
                    or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                           for v in values)):
                raise self.err(where, f"expected [low, high], two numbers in {unit}; got {values!r}")
            low, high = (float(v) for v in values)
            if low > high:
                raise self.err(where, f"low {low:g} is above high {high:g} {unit}: give [low, high]")
            if lo_abs is not None and low <= lo_abs:
                raise self.err(where, f"low {low:g} °C is at or below absolute zero ({lo_abs:g} °C)")
            out.append((name, low + offset, high + offset))
        return {"verify": True, "verify_range": tuple(out)}

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
