"""Load cases and sweeps: one case file -> several named cases (``[[cases]]``, ``[sweep]``).

A case is the base file deep-merged with the case's own tables, so every key of the case file can vary
without code that knows it (DESIGN §4.5)::

    [[cases]]
    name = "hot"
    [cases.optics.paint]              # tables merge key by key into [optics.paint]
    absorptivity = 0.4
    [cases.boundary.heater]           # a table over an array of tables ([[boundary]]) addresses one entry
    value = 12.0                      # by its `name` (or by its position: [cases.boundary.0])

Merge rule (:func:`deep_merge`): a table merges into a table key by key; a table over an array of tables
merges into the entries it names (by their ``name`` key, or by their 0-based position written as a key);
anything else (a number, a string, an array, an array of tables such as ``[[cases.boundary]]``) replaces the
base value whole.  The merged dictionary is then validated by the ordinary parser
(:meth:`fem2tmm.case.Case.from_dict`), whose messages name the case.

``[sweep]`` varies parameters given by dotted key paths (``"optics.paint.absorptivity"``,
``"boundary.heater.value"``: the same addressing as above, one path segment per key):

* ``[sweep.grid]`` path = [values]: every combination (Cartesian product, first path slowest);
* ``[sweep.zip]`` path = [values]: lists of equal length, taken element by element (combined with a grid
  as a product);
* ``[sweep.random]`` path = {distribution = "uniform", low, high} | {distribution = "normal", mean, std} |
  {distribution = "triangular", low, mode, high}, with ``[sweep] samples`` and ``seed``: value of sample i of
  a path is drawn from its own generator, ``SeedSequence(seed, spawn_key=(crc32(path), i))``, so a sample
  does not depend on how many samples or which other paths are drawn.

Without ``[[cases]]`` the sweep points are the cases (``<sweep name>_<k>``); with both, every case is swept
(``<case>_<sweep name>_<k>``).  Case names are folder names of the output: letters, digits, ``_ - . +``,
starting with a letter or digit, unique ignoring case, at most 100 characters, no Windows device name.
"""

from __future__ import annotations

import itertools
import math
import re
import zlib
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from .errors import Fem2TmmError

#: top-level keys of a case file that describe the set of cases, not one case
MULTI_KEYS = ("cases", "sweep", "compute")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]{0,99}$")
_DEVICES = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)), *(f"lpt{i}" for i in range(10))}
DISTRIBUTIONS = {"uniform": ("low", "high"), "normal": ("mean", "std"), "triangular": ("low", "mode", "high")}


@dataclass(frozen=True)
class CaseSpec:
    """One expanded case: its ``name`` (a folder name), the merged case dictionary ``data`` (base + overrides)
    and ``parameters`` {dotted path: value} set by a sweep (empty for a plain ``[[cases]]`` entry)."""

    name: str
    data: dict
    parameters: dict = field(default_factory=dict)


def has_cases(raw: Mapping[str, Any]) -> bool:
    """Whether a raw case dictionary defines several cases (``[[cases]]`` or ``[sweep]``)."""
    return "cases" in raw or "sweep" in raw


def check_name(name: Any, where: str) -> str:
    """``name`` if it is a safe folder name (module docstring), else :class:`Fem2TmmError` naming ``where``."""
    if not isinstance(name, str) or not _NAME.match(name) or name.endswith("."):
        raise Fem2TmmError(f"{where}: case name {name!r} is not a safe folder name; use 1-100 letters, digits, "
                           "'_', '-', '.', '+', starting with a letter or digit (not ending with '.')")
    if name.split(".")[0].lower() in _DEVICES:
        raise Fem2TmmError(f"{where}: case name {name!r} is a reserved device name on Windows; choose another")
    return name


# ------------------------------------------------------------------------------------------------- merging
def deep_merge(base: Any, override: Any, where: str = "") -> Any:
    """``override`` merged over ``base`` (neither is modified): the merge rule of the module docstring.
    ``where`` (dotted path so far) names the place in errors."""
    if isinstance(override, Mapping) and isinstance(base, Mapping):
        out = dict(base)
        for k, v in override.items():
            out[k] = deep_merge(base[k], v, f"{where}.{k}" if where else k) if k in base else _copy(v)
        return out
    if isinstance(override, Mapping) and _is_table_array(base):
        out = [dict(e) for e in base]
        for k, v in override.items():
            i = _entry(base, k, where)
            out[i] = deep_merge(out[i], v, f"{where}.{k}")
        return out
    return _copy(override)


def _copy(v):
    if isinstance(v, Mapping):
        return {k: _copy(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_copy(x) for x in v]
    return v


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(e, Mapping) for e in v)


def _entry(entries: list, key: str, where: str) -> int:
    """Index of the entry of an array of tables named ``key`` (its ``name``), or at position ``key``."""
    hits = [i for i, e in enumerate(entries) if e.get("name") == key]
    if len(hits) == 1:
        return hits[0]
    if len(hits) > 1:
        raise Fem2TmmError(f"{where}.{key}: {len(hits)} [[{where}]] entries are named {key!r}; address one by "
                           "its position (0-based) instead")
    if key.isdigit() and int(key) < len(entries):
        return int(key)
    names = [str(e["name"]) for e in entries if "name" in e]
    raise Fem2TmmError(f"{where}.{key}: no [[{where}]] entry is named {key!r} (names: {', '.join(names) or 'none'}; "
                       f"or give a position 0..{len(entries) - 1})")


def path_table(path: str, value: Any, where: str) -> dict:
    """The nested table that sets the dotted key ``path`` to ``value`` (``"a.b.c"`` -> {a: {b: {c: value}}})."""
    keys = path.split(".")
    if not path or any(not k for k in keys):
        raise Fem2TmmError(f"{where}: {path!r} is not a dotted key path like \"optics.paint.absorptivity\"")
    if keys[0] in MULTI_KEYS:
        raise Fem2TmmError(f"{where}: {path!r}: a sweep cannot change [{keys[0]}]")
    out: Any = value
    for k in reversed(keys):
        out = {k: out}
    return out


# ------------------------------------------------------------------------------------------------- sweeps
def _table(d, where, allowed) -> dict:
    if not isinstance(d, Mapping):
        raise Fem2TmmError(f"{where}: expected a table, got {type(d).__name__}")
    bad = sorted(set(d) - set(allowed))
    if bad:
        raise Fem2TmmError(f"{where}: unknown key(s) {', '.join(map(repr, bad))}; allowed: {', '.join(sorted(allowed))}")
    return dict(d)


def _number(d, key, where) -> float:
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise Fem2TmmError(f"{where}.{key}: expected a finite number, got {v!r}")
    return float(v)


def sweep_points(sweep: Mapping[str, Any], where: str) -> tuple[str, list[dict]]:
    """(sweep name, [{path: value}, ...]) of a ``[sweep]`` table (module docstring), in a fixed order."""
    s = _table(sweep, where, {"name", "grid", "zip", "random", "samples", "seed"})
    name = check_name(s.get("name", "sweep"), f"{where}.name")
    kinds = [k for k in ("grid", "zip", "random") if k in s]
    if not kinds:
        raise Fem2TmmError(f"{where}: give [sweep.grid], [sweep.zip] and/or [sweep.random] with dotted key paths")
    if "random" in s and len(kinds) > 1:
        raise Fem2TmmError(f"{where}: [sweep.random] cannot be combined with grid or zip")
    if "random" in s:
        return name, _random_points(s, where)
    if ("samples" in s or "seed" in s):
        raise Fem2TmmError(f"{where}: 'samples' and 'seed' belong to a [sweep.random] study")
    grid = _lists(s.get("grid", {}), f"{where}.grid")
    zipped = _lists(s.get("zip", {}), f"{where}.zip")
    lengths = {len(v) for v in zipped.values()}
    if len(lengths) > 1:
        raise Fem2TmmError(f"{where}.zip: every list must have the same length, got lengths "
                           + ", ".join(f"{k}: {len(v)}" for k, v in zipped.items()))
    rows = [dict(zip(zipped, vals)) for vals in zip(*zipped.values())] if zipped else [{}]
    points = []
    for combo in itertools.product(*grid.values()):
        for row in rows:
            points.append({**dict(zip(grid, combo)), **row})
    return name, points


def _lists(d, where) -> dict:
    if not isinstance(d, Mapping):
        raise Fem2TmmError(f"{where}: expected a table of dotted key paths -> lists of values")
    for k, v in d.items():
        path_table(k, None, where)
        if not isinstance(v, list) or not v:
            raise Fem2TmmError(f"{where}.{k!r}: expected a non-empty list of values, got {v!r}")
    return dict(d)


def _random_points(s: Mapping, where: str) -> list[dict]:
    if "samples" not in s or "seed" not in s:
        raise Fem2TmmError(f"{where}: a [sweep.random] study needs 'samples' (number of cases) and 'seed'")
    n, seed = s["samples"], s["seed"]
    for key, v, lo in (("samples", n, 1), ("seed", seed, 0)):
        if isinstance(v, bool) or not isinstance(v, int) or v < lo:
            raise Fem2TmmError(f"{where}.{key}: expected an integer >= {lo}, got {v!r}")
    params = s["random"]
    if not isinstance(params, Mapping) or not params:
        raise Fem2TmmError(f"{where}.random: expected dotted key paths -> {{distribution = ..., ...}}")
    draws = {}
    for path, spec in params.items():
        w = f"{where}.random.{path!r}"
        path_table(path, None, w)
        dist = spec.get("distribution") if isinstance(spec, Mapping) else None
        if dist not in DISTRIBUTIONS:
            raise Fem2TmmError(f"{w}: expected a table with distribution = one of {', '.join(map(repr, DISTRIBUTIONS))}")
        keys = DISTRIBUTIONS[dist]
        spec = _table(spec, w, {"distribution", *keys})
        a = [_number(spec, k, w) for k in keys]
        if dist == "uniform" and not a[0] < a[1] or dist == "triangular" and not a[0] <= a[1] <= a[2] and a[0] < a[2]:
            raise Fem2TmmError(f"{w}: need {' <= '.join(keys)} with low < high, got {a}")
        if dist == "normal" and not a[1] > 0:
            raise Fem2TmmError(f"{w}.std: must be > 0, got {a[1]}")
        tag = zlib.crc32(path.encode("utf-8"))
        vals = []
        for i in range(n):
            rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(tag, i)))
            vals.append(float(getattr(rng, dist)(*a)))
        draws[path] = vals
    return [{p: v[i] for p, v in draws.items()} for i in range(n)]


# ------------------------------------------------------------------------------------------------ expansion
def expand(raw: Mapping[str, Any], source: str = "<case>") -> list[CaseSpec]:
    """The cases of a raw case dictionary (as read from TOML): one unnamed case (name "") when it defines no
    ``[[cases]]`` and no ``[sweep]``, else the named cases in file order (each case times each sweep point).
    The dictionaries returned have no ``cases``, ``sweep`` or ``compute`` key.  Raises :class:`Fem2TmmError`
    naming ``source`` and the case on a malformed entry or name."""
    base = {k: v for k, v in raw.items() if k not in MULTI_KEYS}
    if not has_cases(raw):
        return [CaseSpec("", _copy(base))]
    entries = raw.get("cases", [])
    if not isinstance(entries, list) or not all(isinstance(e, Mapping) for e in entries):
        raise Fem2TmmError(f"{source}: [[cases]]: expected an array of tables ([[cases]] entries)")
    if "cases" in raw and not entries:
        raise Fem2TmmError(f"{source}: [[cases]]: no case given")
    cases = []
    for i, e in enumerate(entries):
        where = f"{source}: [[cases]][{i}]"
        if "name" not in e:
            raise Fem2TmmError(f"{where}: missing required key 'name'")
        name = check_name(e["name"], where)
        inner = [k for k in e if k in MULTI_KEYS]
        if inner:
            raise Fem2TmmError(f"{where} ({name!r}): [{inner[0]}] cannot be set per case")
        override = {k: v for k, v in e.items() if k != "name"}
        cases.append(CaseSpec(name, deep_merge(base, override, ""), {}))
    if not cases:
        cases = [CaseSpec("", _copy(base))]
    if "sweep" in raw:
        sname, points = sweep_points(raw["sweep"], f"{source}: [sweep]")
        width = len(str(len(points) - 1))
        swept = []
        for c in cases:
            for k, p in enumerate(points):
                data = c.data
                for path, v in p.items():
                    data = deep_merge(data, path_table(path, v, f"{source}: [sweep]"), "")
                prefix = f"{c.name}_" if c.name else ""
                swept.append(CaseSpec(f"{prefix}{sname}_{k:0{width}d}", data, dict(p)))
        cases = swept
    seen: dict[str, str] = {}
    for c in cases:
        low = c.name.lower()
        if low in seen:
            raise Fem2TmmError(f"{source}: case names must be unique (ignoring case, they are folder names): "
                               f"{seen[low]!r} and {c.name!r}")
        seen[low] = c.name
    return cases

