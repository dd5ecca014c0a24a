"""Time-dependent inputs: scalar tables and vectors that vary in time.

* :class:`Table` — a scalar function of time given by points ``[[t, v], ...]``: linear interpolation between
  them, constant (first / last value) outside.  A constant is a one-point table.
* :class:`Series` — a vector (n,) that varies in time as ``base + Σ_k patterns[:, k] f_k(t)`` with scalar
  tables ``f_k``: a boundary whose value is a table contributes its unit-value load vector (or its fixed
  DOF indicator) times its table.  Linear maps (the reduction's power distribution ``Y``, the recovery's ``X``)
  are applied to the base and to each pattern once (:meth:`Series.map`), never per time step.

A table also wraps periodically: :meth:`Table.periodic` evaluates it at ``start + ((t − start) mod P)`` with
the end of a period (``t = start + k P``, k ≥ 1) mapped to ``start + P`` so that a step ending there sees the
period's last value.

Units are the caller's: seconds for ``t``; K, W or W/m² for the values.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import Fem2TmmError


@dataclass(frozen=True)
class Table:
    """Piecewise-linear scalar function of time.  ``t`` (k,) s strictly increasing, ``v`` (k,) values."""

    t: np.ndarray
    v: np.ndarray
    period: float | None = None  # P (s): evaluate at start + ((t - start) mod P)
    start: float = 0.0

    def __post_init__(self):
        t = np.atleast_1d(np.asarray(self.t, float))
        v = np.atleast_1d(np.asarray(self.v, float))
        if t.ndim != 1 or t.shape != v.shape or t.size == 0:
            raise Fem2TmmError(f"a time table needs matching, non-empty time and value columns (got {t.shape}, {v.shape})")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise Fem2TmmError("a time table holds a value that is not a finite number")
        if np.any(np.diff(t) <= 0):
            raise Fem2TmmError("the times of a time table must be strictly increasing")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "v", v)

    @classmethod
    def constant(cls, value: float) -> "Table":
        return cls(np.array([0.0]), np.array([float(value)]))

    @property
    def is_constant(self) -> bool:
        return bool(np.all(self.v == self.v[0]))

    def local_time(self, t):
        """The time at which the table is read: ``t`` itself, or its image in (start, start + P]."""
        t = np.asarray(t, float)
        if self.period is None:
            return t
        P = self.period
        k = np.ceil((t - self.start) / P - 1e-12) - 1.0
        return t - np.maximum(k, 0.0) * P

    def __call__(self, t):
        """Value(s) at time(s) ``t`` (s); scalar in, float out."""
        out = np.interp(self.local_time(t), self.t, self.v)
        return float(out) if np.ndim(out) == 0 else out

    def periodic(self, start: float, period: float) -> "Table":
        """The same table read periodically with period ``period`` (s) from ``start`` (s)."""
        if not period > 0:
            raise Fem2TmmError(f"the period of a periodic table must be positive, got {period}")
        return Table(self.t, self.v, period=float(period), start=float(start))

    def mapped(self, fn) -> "Table":
        """A table with values ``fn(v)`` (e.g. °C -> K)."""
        return Table(self.t, fn(self.v), self.period, self.start)

    def breakpoints(self, start: float, end: float) -> np.ndarray:
        """Times in (start, end) where the table has a kink (s), sorted."""
        if self.period is None:
            bp = self.t
        else:
            P = self.period
            k0 = np.floor((start - self.start) / P) - 1
            k1 = np.ceil((end - self.start) / P) + 1
            ks = np.arange(k0, k1 + 1)
            bp = (self.t[None, :] + ks[:, None] * P).ravel()
        return np.unique(bp[(bp > start) & (bp < end)])


def parse_table(value, where: str, base_dir: Path | None = None, unit: str = "") -> Table:
    """A :class:`Table` from a case-file value: a number, ``[[t, v], ...]`` or the path of a two-column CSV file.

    ``where`` names the file and key in error messages, ``unit`` the value's unit (e.g. "W"); relative CSV paths
    are relative to ``base_dir``.
    """
    expected = f"expected a number{' in ' + unit if unit else ''}, a time table [[t, v], ...] or a CSV file name"
    if isinstance(value, bool):
        raise Fem2TmmError(f"{where}: {expected}, got {value!r}")
    if isinstance(value, (int, float)):
        return Table.constant(float(value))
    if isinstance(value, str):
        path = Path(value)
        if base_dir is not None and not path.is_absolute():
            path = base_dir / path
        if not path.exists():  # "5 W", "20 C": a number with its unit is read as a file name
            number = re.match(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", value)
            like = f"; for the number write {where.rsplit('.', 1)[-1].split(' ')[-1]} = {number.group(0).strip()} " \
                   "(no quotes, no unit)" if number else ""
            raise Fem2TmmError(f"{where}: cannot read {value!r}: not a number, and there is no file {path}; {expected} "
                               f"(two columns: time s, value){like}")
        return read_csv_table(path, where)
    if isinstance(value, list):
        rows = value
        ok = len(rows) > 0 and all(isinstance(r, list) and len(r) == 2 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in r) for r in rows)
        if not ok:
            raise Fem2TmmError(f"{where}: a time table is a list of [time (s), value] pairs, e.g. "
                               f"[[0, 20.0], [600, 40.0]]; got {value!r}")
        a = np.asarray(rows, float)
        return _checked(a[:, 0], a[:, 1], where)
    raise Fem2TmmError(f"{where}: expected a number, a table [[t, v], ...] or a CSV file name, got {value!r}")


def _checked(t, v, where: str) -> Table:
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise Fem2TmmError(f"{where}: the time table holds a value that is not a finite number")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        raise Fem2TmmError(f"{where}: the times of the table must be strictly increasing (row {int(bad[0]) + 2}: "
                           f"{t[bad[0] + 1]} after {t[bad[0]]})")
    return Table(t, v)


def read_csv_table(path: Path, where: str) -> Table:
    """A two-column CSV file (time s, value; comma, semicolon or whitespace separated; a header line and
    ``#`` comments allowed) as a :class:`Table`."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise Fem2TmmError(f"{where}: cannot read the time table {path}: {exc}") from None
    rows = []
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c for c in line.replace(";", ",").replace(",", " ").split()]
        try:
            vals = [float(c) for c in cells]
        except ValueError:
            if not rows:  # a header line
                continue
            raise Fem2TmmError(f"{where}: {path}, line {lineno}: expected two numbers, got {line!r}") from None
        if len(vals) != 2:
            raise Fem2TmmError(f"{where}: {path}, line {lineno}: expected two columns (time s, value), got {len(vals)}")
        rows.append(vals)
    if not rows:
        raise Fem2TmmError(f"{where}: {path} holds no [time, value] rows")
    a = np.asarray(rows)
    return _checked(a[:, 0], a[:, 1], f"{where} ({path})")


@dataclass(frozen=True)
class Series:
    """A vector (n,) that varies in time: ``base + Σ_k patterns[k] · tables[k](t)``.

    ``base`` (n,); ``patterns`` tuple of (n,) arrays; ``tables`` tuple of :class:`Table` of the same length.
    """

    base: np.ndarray
    patterns: tuple = ()
    tables: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "base", np.asarray(self.base, float))
        pats = tuple(np.asarray(p, float) for p in self.patterns)
        if len(pats) != len(self.tables) or any(p.shape != self.base.shape for p in pats):
            raise Fem2TmmError("internal: a time series needs one pattern of the base's shape per table")
        object.__setattr__(self, "patterns", pats)
        object.__setattr__(self, "tables", tuple(self.tables))

    @classmethod
    def constant(cls, value: np.ndarray) -> "Series":
        return cls(np.asarray(value, float))

    @property
    def n(self) -> int:
        return self.base.shape[0]

    @property
    def is_constant(self) -> bool:
        return all(tb.is_constant for tb in self.tables)

    def __call__(self, t: float) -> np.ndarray:
        """The vector (n,) at time ``t`` (s)."""
        out = self.base.copy()
        for p, tb in zip(self.patterns, self.tables):
            out += tb(t) * p
        return out

    def at(self, times) -> np.ndarray:
        """The vectors at several times: (n, n_t)."""
        times = np.atleast_1d(np.asarray(times, float))
        out = np.repeat(self.base[:, None], times.size, axis=1)
        for p, tb in zip(self.patterns, self.tables):
            out += np.outer(p, tb(times))
        return out

    def map(self, fn) -> "Series":
        """The series of ``fn(vector)`` for a linear ``fn`` (applied to the base and each pattern once)."""
        return Series(fn(self.base), tuple(fn(p) for p in self.patterns), self.tables)

    def periodic(self, start: float, period: float) -> "Series":
        return Series(self.base, self.patterns, tuple(tb.periodic(start, period) for tb in self.tables))

    def breakpoints(self, start: float, end: float) -> np.ndarray:
        bps = [tb.breakpoints(start, end) for tb in self.tables if not tb.is_constant]
        return np.unique(np.concatenate(bps)) if bps else np.zeros(0)

    def sum(self) -> "Series":
        """The scalar series Σ_i vector_i as a one-element series."""
        return Series(np.array([self.base.sum()]), tuple(np.array([p.sum()]) for p in self.patterns), self.tables)


__all__ = ["Table", "Series", "parse_table", "read_csv_table"]
