"""The network case file of ``fem2tmm network reduce DECK --case net.toml`` (temperatures in °C, powers in W)::

    [reduction]
    method = "auto"                # auto (Fernández Rico grouping) | tmrt (user sets below)

    [grouping]                     # method = "auto"
    pf = 0.2                       # conductance filter p_f; omitted: the sweep's best pair (--pf overrides)
    dtmax = 10.0                   # temperature filter ΔT_max in K; omitted: the sweep's best (--dtmax overrides)
    mu = 3.33e-5                   # μ = 2λ/(ρc) in m²/s of the sizing matrix
    internal_boundary = true       # isolate the nodes conductively coupled to a boundary node
    pf_values = [0.001, 0.01, 0.1, 1.0, 10.0]       # sweep grid (defaults: 11 values 1e-3..1e2, log)
    dtmax_values = [0.1, 1.0, 10.0, 100.0]          # K (defaults: 9 values 1e-2..1e2, log)

    [criteria]                     # acceptance of the reduced network, per load case
    delta_max = 3.0                # K
    q_max = 0.1                    # W, below q_lim
    q_lim = 1.0                    # W
    q_rel_max = 0.10               # fraction, above q_lim

    [[load_cases]]                 # default: one case, the deck's own QI and boundary temperatures
    name = "hot"
    power = { 5 = 12.0 }           # W: replaces the QI of the listed node numbers
    boundary = { 9 = 40.0 }        # °C: replaces the temperature of the listed boundary nodes

    [tmrt]                         # method = "tmrt"
    suppress = [101, 102]          # conduction-only nodes condensed exactly
    groups = [[201, 202, 203]]     # each list becomes one average node
    capacitance = "equivalent"     # equivalent | summed
    filter = 0.0                   # drop reduced GL below filter x min(K_ii, K_jj) (0: keep all)

    [[post.ra]]                    # recomputed average (RA) of detailed nodes, from the recovered temperatures
    name = "panel"
    nodes = [1, 2, 3]
    [[post.ce]]                    # conductive exchange (CE) from one set of detailed nodes to another, W
    name = "panel_to_box"
    from = [1, 2]
    to = [3, 4]
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Fem2TmmError
from .grouping import MU_DEFAULT, Criteria

PF_DEFAULT = tuple(np.logspace(-3, 2, 11))
DTMAX_DEFAULT = tuple(np.logspace(-2, 2, 9))
_SECTIONS = {
    "reduction": {"method"},
    "grouping": {"pf", "dtmax", "mu", "internal_boundary", "pf_values", "dtmax_values"},
    "criteria": {"delta_max", "q_max", "q_lim", "q_rel_max"},
    "load_cases": {"name", "power", "boundary"},
    "tmrt": {"suppress", "groups", "capacitance", "filter"},
    "post": {"ra", "ce"},
}


@dataclass(frozen=True)
class LoadCaseSpec:
    """A load case as the user wrote it: ``power`` {node: W} and ``boundary`` {node: °C} overrides."""

    name: str
    power: dict = field(default_factory=dict)
    boundary: dict = field(default_factory=dict)


@dataclass(frozen=True)
class NetworkSettings:
    """Validated network case (see the module docstring for every key)."""

    method: str = "auto"
    pf: float | None = None
    dtmax: float | None = None
    mu: float = MU_DEFAULT
    internal_boundary: bool = True
    pf_values: tuple = PF_DEFAULT
    dtmax_values: tuple = DTMAX_DEFAULT
    criteria: Criteria = field(default_factory=Criteria)
    load_cases: tuple = ()
    suppress: tuple = ()
    groups: tuple = ()
    capacitance: str = "equivalent"
    filter: float = 0.0
    ra: tuple = ()  # ((name, (nodes...)), ...)
    ce: tuple = ()  # ((name, (from...), (to...)), ...)
    source: str = "defaults"
    text: str = ""

    @classmethod
    def from_toml(cls, path: str | Path) -> "NetworkSettings":
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
            data = tomllib.loads(text)
        except OSError as exc:
            raise Fem2TmmError(f"{path}: cannot read the network case ({exc.strerror})") from None
        except tomllib.TOMLDecodeError as exc:
            raise Fem2TmmError(f"{path}: not valid TOML ({exc})") from None
        return cls.from_dict(data, source=str(path), text=text)

    @classmethod
    def from_dict(cls, data: dict, source: str = "case", text: str = "") -> "NetworkSettings":
        for key, value in data.items():
            if key not in _SECTIONS:
                raise Fem2TmmError(f"{source}: unknown section [{key}] (known: {', '.join(sorted(_SECTIONS))})")
            tables = value if isinstance(value, list) else [value]
            for t in tables:
                if not isinstance(t, dict):
                    raise Fem2TmmError(f"{source}: [{key}] must be a table")
                bad = set(t) - _SECTIONS[key]
                if bad:
                    raise Fem2TmmError(f"{source}: [{key}] unknown keys {sorted(bad)} (known: "
                                       f"{', '.join(sorted(_SECTIONS[key]))})")
        red, grp, cr, tm = (data.get(k, {}) for k in ("reduction", "grouping", "criteria", "tmrt"))
        method = red.get("method", "auto")
        if method not in ("auto", "tmrt"):
            raise Fem2TmmError(f"{source}: [reduction] method = {method!r}: expected 'auto' or 'tmrt'")

        def num(table, key, default, where, lo=0.0, strict=False):
            v = table.get(key, default)
            if v is None:
                return None
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v) or \
                    (v <= lo if strict else v < lo):
                raise Fem2TmmError(f"{source}: [{where}] {key} = {v!r}: expected a number "
                                   f"{'>' if strict else '>='} {lo}")
            return float(v)

        def values(key, default):
            v = grp.get(key, default)
            if not isinstance(v, (list, tuple)) or not v or not all(isinstance(x, (int, float)) for x in v):
                raise Fem2TmmError(f"{source}: [grouping] {key} must be a non-empty list of numbers")
            return tuple(float(x) for x in v)

        crit = Criteria(delta_max=num(cr, "delta_max", 3.0, "criteria", strict=True),
                        q_max=num(cr, "q_max", 0.1, "criteria", strict=True),
                        q_lim=num(cr, "q_lim", 1.0, "criteria"),
                        q_rel_max=num(cr, "q_rel_max", 0.10, "criteria", strict=True))
        cases = []
        for k, lc in enumerate(data.get("load_cases", [])):
            name = str(lc.get("name", f"case{k + 1}"))
            maps = {}
            for key in ("power", "boundary"):
                m = lc.get(key, {})
                if not isinstance(m, dict):
                    raise Fem2TmmError(f"{source}: [[load_cases]] {name}: {key} must be a table {{node = value}}")
                try:
                    maps[key] = {int(a): float(b) for a, b in m.items()}
                except (TypeError, ValueError):
                    raise Fem2TmmError(f"{source}: [[load_cases]] {name}: {key} keys must be node numbers and "
                                       "values numbers") from None
            cases.append(LoadCaseSpec(name=name, **maps))
        if len({c.name for c in cases}) != len(cases):
            raise Fem2TmmError(f"{source}: [[load_cases]] names must be unique")
        groups = tm.get("groups", [])
        if not isinstance(groups, list) or not all(isinstance(g, list) and g for g in groups):
            raise Fem2TmmError(f"{source}: [tmrt] groups must be a list of non-empty lists of node numbers")
        capacitance = tm.get("capacitance", "equivalent")
        if capacitance not in ("equivalent", "summed"):
            raise Fem2TmmError(f"{source}: [tmrt] capacitance = {capacitance!r}: expected 'equivalent' or 'summed'")
        flt = num(tm, "filter", 0.0, "tmrt")
        if flt >= 1.0:
            raise Fem2TmmError(f"{source}: [tmrt] filter = {flt}: expected a fraction in [0, 1)")
        if method == "tmrt" and not (tm.get("suppress") or groups):
            raise Fem2TmmError(f"{source}: [reduction] method = 'tmrt' needs [tmrt] suppress and/or groups")
        post = data.get("post", {})
        ra, ce = [], []
        for item in post.get("ra", []):
            if not isinstance(item, dict) or set(item) - {"name", "nodes"} or not item.get("nodes"):
                raise Fem2TmmError(f"{source}: [[post.ra]] needs name and a non-empty nodes list")
            ra.append((str(item.get("name", f"RA{len(ra) + 1}")), tuple(int(v) for v in item["nodes"])))
        for item in post.get("ce", []):
            if not isinstance(item, dict) or set(item) - {"name", "from", "to"} or not item.get("from") \
                    or not item.get("to"):
                raise Fem2TmmError(f"{source}: [[post.ce]] needs name and non-empty from / to node lists")
            ce.append((str(item.get("name", f"CE{len(ce) + 1}")), tuple(int(v) for v in item["from"]),
                       tuple(int(v) for v in item["to"])))
        return cls(method=method, ra=tuple(ra), ce=tuple(ce), pf=num(grp, "pf", None, "grouping"),
                   dtmax=num(grp, "dtmax", None, "grouping"),
                   mu=num(grp, "mu", MU_DEFAULT, "grouping", strict=True),
                   internal_boundary=bool(grp.get("internal_boundary", True)),
                   pf_values=values("pf_values", PF_DEFAULT), dtmax_values=values("dtmax_values", DTMAX_DEFAULT),
                   criteria=crit, load_cases=tuple(cases),
                   suppress=tuple(int(v) for v in tm.get("suppress", [])),
                   groups=tuple(tuple(int(v) for v in g) for g in groups), capacitance=capacitance, filter=flt,
                   source=source, text=text)


__all__ = ["DTMAX_DEFAULT", "LoadCaseSpec", "NetworkSettings", "PF_DEFAULT"]
