"""The parser's model tables: ``[mesh]``, ``[[joints]]``, ``[materials]``, ``[optics]``, ``[[parts]]``, ``[[boundary]]``.
"""

from __future__ import annotations

from typing import get_args

from ..constants import ABSOLUTE_ZERO_C, KELVIN
from ..io.units import LENGTH_UNITS, TEMPERATURE_UNITS, UNIT_SYSTEMS, unit_system_name
from .types import (Boundary, BoundaryKind, JOINT_CARDS, JOINT_TREATMENTS, Joint, MIN_EMISSIVITY, Material, MeshSpec,
                    NONE_OPTICS, Optics, Part, _default)


class _ModelTables:
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
            from ..io.nastran.deck import _LOAD_CARDS

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
            table = self.time_table(d["value"], f"{w}.value", kelvin=kind == "temperature",
                                    unit={"temperature": "°C", "power": "W", "flux": "W/m²"}[kind])
            v = table(self.t0)
        elif kind == "temperature":
            v = self.number(d, "value", w, lo=ABSOLUTE_ZERO_C, lo_open=True) + KELVIN
        else:
            v = self.number(d, "value", w)
        return Boundary(kind=kind, value=v, groups=groups, nodes=nodes, name=self.string(d, "name", w, default=f"{kind}_{i}"),
                        index=i, table=table)
