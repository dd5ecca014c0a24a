"""Is the model physically plausible?  Unit mistakes caught before the long computation.

A millimetre mesh read with ``[mesh] unit = "m"`` is a 500 m plate, ``thickness = 2.0`` meant as mm is a 2 m
shell, a conductivity in W/(mm K) is a thousand times too small: each runs to a result without an error.  The
checks here compare each input with its physical range and with the model's own size and return one message per
implausible input (naming the file, the key and what was expected); :func:`warn_implausible` warns them,
``fem2tmm run`` before the clustering and ``fem2tmm inspect`` (the extent) with the same words.

The ranges (sources beside each constant) are wide on purpose: a warning must mean "almost certainly a unit".
"""

from __future__ import annotations

import contextvars
import warnings

import numpy as np

from ..arrays import unique
from ..case import Case
from ..mesh.elements import SHELL_TYPES, TYPE_CODE
from .model import FEModel

#: a model larger than this (m) is probably a file in millimetres read as metres (the largest spacecraft
#: structures modelled in one mesh, e.g. a deployed solar array wing, are ~10-30 m)
LARGE_EXTENT_M = 50.0
#: a model smaller than this (m) is probably a file in metres read as millimetres (1 m read as mm is 1 mm)
SMALL_EXTENT_M = 2.0e-3
#: a shell thicker than this fraction of its part's largest extent is a block, not a shell (thin-shell models
#: need t much smaller than the span; a 2 mm sheet given as thickness = 2.0 on a 0.1 m plate is 20x its size)
THICK_SHELL_RATIO = 0.2
#: conductivities of real solids, W/(m K): silica aerogel ~0.015 (lowest solid), diamond ~2200 and pyrolytic
#: graphite in-plane ~1700-2000 (highest); CRC Handbook of Chemistry and Physics, "Thermal conductivity of solids"
CONDUCTIVITY_RANGE = (1.0e-3, 3000.0)
#: a heat flux above this (W/m²) is 100 W/cm², about the densest electronics dissipation; 730x the solar constant
#: and above the sunlight at Parker Solar Probe's closest perihelion (~0.046 au: 1361 / 0.046² ~ 6.4e5 W/m²)
MAX_FLUX = 1.0e6


def extent_note(extent_m: float, unit: str, key: str) -> str | None:
    """What is implausible about a model ``extent_m`` (m, the largest bounding-box side) read in ``unit``, or None.

    ``key`` names the setting that gives the unit (``'[mesh] unit'`` in a case, ``'--unit'`` for inspect); the
    advice never repeats the unit already in force.
    """
    unit = str(unit).strip().lower()
    if extent_m > LARGE_EXTENT_M:
        what = f"{extent_m:.4g} m across with {_unit_setting(key, unit)}: larger than {LARGE_EXTENT_M:g} m"
        return what + (", is the file in millimetres? then give " + _unit_setting(key, "mm") if unit != "mm"
                       else f", check the lengths of the file and {key}")
    if 0 < extent_m < SMALL_EXTENT_M:
        what = f"{extent_m:.4g} m across with {_unit_setting(key, unit)}: smaller than {SMALL_EXTENT_M * 1e3:g} mm"
        return what + (", is the file in metres? then give " + _unit_setting(key, "m") if unit != "m"
                       else f", check the lengths of the file and {key}")
    return None


def _unit_setting(key: str, unit: str) -> str:
    return f'{key} = "{unit}"' if key.startswith("[") else f"{key} {unit}"


def implausible(model: FEModel, case: Case) -> list[str]:
    """One message per implausible input of ``case`` on its assembled ``model`` (empty when all is plausible):
    the model's extent against ``[mesh] unit``, each shell part's thickness against the part's size, each
    conductivity against :data:`CONDUCTIVITY_RANGE` and the heat flux of the Sun and of each power / flux
    boundary against :data:`MAX_FLUX`.  Emissivity and absorptivity outside [0, 1] are refused by the case reader
    already."""
    src = case.source
    out = []
    mesh = model.mesh
    cells = model.element_cells
    used = unique(cells[cells >= 0])
    if len(used):
        ext = float(np.ptp(mesh.points[used], axis=0).max())
        note = extent_note(ext, case.mesh.unit, "[mesh] unit")
        if note:
            out.append(f"{src}: the model ({case.mesh.file}) is {note}")
    out += _thickness_notes(model, case)
    out += _conductivity_notes(model, case)
    out += _flux_notes(model, case)
    return out


def _thickness_notes(model: FEModel, case: Case) -> list[str]:
    """Shell parts thicker than :data:`THICK_SHELL_RATIO` x their largest extent."""
    mesh = model.mesh
    shell = np.isin(model.element_types, [TYPE_CODE[t] for t in SHELL_TYPES])
    out = []
    for k, cp in enumerate(case.parts):
        sel = shell & (model.element_part == k)
        if not sel.any():
            continue
        area = mesh.element_areas(model.elements[sel])
        t = float(np.nanmax(model.volume_shares[sel].sum(axis=1) / np.where(area > 0, area, np.nan)))
        c = model.element_cells[sel]
        span = float(np.ptp(mesh.points[unique(c[c >= 0])], axis=0).max())
        if not (np.isfinite(t) and span > 0 and t > THICK_SHELL_RATIO * span):
            continue
        key = (f"[[parts]] {cp.name!r}.thickness = {cp.thickness:g}" if cp.thickness is not None
               else f"[[parts]] {cp.name!r}: the mesh's shell thickness {t:g}")
        out.append(f"{case.source}: {key} m is {t / span:.3g} x the part's size ({span:.3g} m): a shell that thick "
                   f"is a block; thickness is in m (2 mm is 2.0e-3)")
    return out


def _conductivity_notes(model: FEModel, case: Case) -> list[str]:
    """Conductivities of the case's materials and of the mesh's properties outside :data:`CONDUCTIVITY_RANGE`."""
    lo, hi = CONDUCTIVITY_RANGE
    seen = {}
    for cp in case.parts:
        if cp.material is not None:
            k = case.materials[cp.material].conductivity
            seen.setdefault(f"[materials.{cp.material}] conductivity = {k:g}", k)
        else:
            for g in cp.groups:
                p = model.mesh.properties.get(g)
                if p is not None and p.conductivity is not None:
                    seen.setdefault(f"[[parts]] {cp.name!r}: the mesh's conductivity {p.conductivity:g} "
                                    f"(group {g!r})", p.conductivity)
    out = []
    for key, k in seen.items():
        if k is not None and not lo <= k <= hi:
            out.append(f"{case.source}: {key} W/(m K) is outside the range of real solids ({lo:g} to {hi:g} "
                       "W/(m K): aerogel to diamond); conductivity is in W/(m K) (aluminium 170)")
    return out


def _flux_notes(model: FEModel, case: Case) -> list[str]:
    """The solar flux, and the power and flux boundaries, whose heat flux exceeds :data:`MAX_FLUX` (a power: over
    its surface groups)."""
    mesh = model.mesh
    out = []
    suns = [("[environment] solar_flux", case.environment.solar_flux)]
    if case.orbit is not None:
        suns.append(("[orbit] solar_flux", getattr(case.orbit.orbit, "solar_flux", 0.0)))
    for key, q in suns:
        if q > MAX_FLUX:
            out.append(f"{case.source}: {key} = {q:g} W/m2 is above {MAX_FLUX:g} W/m2 (the Sun at Parker Solar Probe's "
                       "perihelion is ~6.4e5; at the Earth 1361): the solar flux is in W/m2")
    for b in case.boundaries:
        if b.kind == "flux":
            q = abs(b.value)
        elif b.kind == "power" and b.groups:
            el = unique(np.concatenate([mesh.groups[g].elements for g in b.groups if g in mesh.groups]
                                          or [np.zeros(0, np.int64)]))
            el = el[mesh.element_dims[el] == 2] if len(el) else el
            area = float(np.nansum(mesh.element_areas(el))) if len(el) else 0.0
            if area <= 0:
                continue
            q = abs(b.value) / area
        else:
            continue
        if q > MAX_FLUX:
            val = f"{b.value:g} W/m2" if b.kind == "flux" else f"{b.value:g} W over {area:.3g} m2"
            out.append(f"{case.source}: [[boundary]] {b.name!r} value = {val} is a heat flux of {q:.3g} W/m2, above "
                       f"{MAX_FLUX:g} W/m2 (100 W/cm2, the densest electronics): check the value's unit "
                       "(W, W/m2) and [mesh] unit")
    return out


#: the messages a run has warned already (:func:`warn_once_per_run`)
_warned: contextvars.ContextVar[set | None] = contextvars.ContextVar("fem2tmm_plausibility_warned", default=None)


def warn_once_per_run() -> None:
    """Start a run: from here on :func:`warn_implausible` warns each message once (the load cases of a run, its
    refinement rounds and its linearisation share their inputs; Python's own once-per-place rule is reset whenever
    a warnings filter changes)."""
    _warned.set(set())


def warn_implausible(model: FEModel, case: Case) -> list[str]:
    """Warn (:class:`UserWarning`) each message of :func:`implausible` not warned yet in this run; returns them."""
    notes = implausible(model, case)
    seen = _warned.get()
    for note in notes:
        if seen is not None:
            if note in seen:
                continue
            seen.add(note)
        warnings.warn(note, stacklevel=2)
    return notes


__all__ = ["CONDUCTIVITY_RANGE", "LARGE_EXTENT_M", "MAX_FLUX", "SMALL_EXTENT_M", "THICK_SHELL_RATIO", "extent_note",
           "implausible", "warn_implausible", "warn_once_per_run"]
