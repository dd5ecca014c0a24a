"""ESATAN-TMS input deck of a reduced network (``$NODES``, ``$CONDUCTORS``); :mod:`fem2tmm.lpm.esatan` reads it.

Node numbers are deterministic: part ``p`` (0-based) numbers its super nodes ``(p + 1)·B + k`` (k = 1, 2 …),
boundary and kept nodes follow in block ``(n_parts + 1)·B``, and the space node is ``(n_parts + 2)·B``,
with ``B = 1000`` (or the next power of ten above the largest part).  Diffusion nodes (D) carry label,
temperature T (°C), capacitance C (J/K), area A (m²), ALP and EPS; fixed-temperature nodes and space are
boundary nodes (B).  ``GL(a, b)`` W/K and ``GR(a, b)`` m².  Negative GL (positive off-diagonal terms of
the exact reduced conduction matrix) are kept — they belong to the exact reduction — and counted in a
comment.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..constants import KELVIN, SIGMA


@dataclass(frozen=True)
class DeckTransient:
    """The time-dependent part of a deck: what the thermal tool needs to run the same transient.

    ``loads``: (pattern (n,) W per unit of the table, times (k,) s, values (k,)) — node i receives
    ``base_i + Σ pattern_i table(t)``, ``base`` (n,) W the loads without their tables (the steady start's QI when
    every table starts at its steady value; an orbit transient's steady QI holds the orbit average instead, which
    is why the decks write ``base``, not the steady QI, beside the tables); ``temperatures``: (node index, times s, values K) of boundary
    nodes that follow a table; ``sink``: (times s, values K) or None; ``start``, ``end``, ``step`` (s; an adaptive run's largest
    step, the solvers' DTIMEI), ``output`` (s), ``periodic`` (the tables repeat with period end − start).
    """

    loads: tuple = ()
    base: np.ndarray | None = None
    temperatures: tuple = ()
    sink: tuple | None = None
    start: float = 0.0
    end: float = 0.0
    step: float | None = None
    output: float | None = None
    periodic: bool = False

    def tables(self) -> list[tuple[str, np.ndarray, np.ndarray, str]]:
        """(array name, times, values, what) of every table, values in deck units (°C for temperatures)."""
        out = [(f"QTAB{k + 1}", t, v, "load multiplier") for k, (_, t, v) in enumerate(self.loads)]
        out += [(f"TTAB{k + 1}", t, v - KELVIN, "boundary temperature degC") for k, (_, t, v) in enumerate(self.temperatures)]
        if self.sink is not None:
            out.append(("TSINK", self.sink[0], self.sink[1] - KELVIN, "sink temperature degC"))
        return out

    def load_terms(self, i: int) -> list[tuple[str, float]]:
        """(array name, coefficient) of the time-dependent loads of node ``i``."""
        return [(f"QTAB{k + 1}", float(p[i])) for k, (p, _, _) in enumerate(self.loads) if p[i] != 0]


@dataclass(frozen=True)
class Deck:
    """A thermal network as read from / written to a deck.  Temperatures K, C J/K, A m², GL W/K, GR m².

    ``numbers`` (n,) node numbers, ``labels`` (n,), ``boundary`` (n,) bool, ``T`` (n,) K, ``C`` (n,),
    ``A`` (n,), ``alp`` (n,), ``eps`` (n,), ``GL`` (n, n) symmetric (zero diagonal), ``GR`` (n, n) and
    ``GR_space`` (n,); ``space`` node number and ``T_space`` K; ``Q`` (n,) W.
    """

    numbers: np.ndarray
    labels: np.ndarray
    boundary: np.ndarray
    T: np.ndarray
    C: np.ndarray
    A: np.ndarray
    alp: np.ndarray
    eps: np.ndarray
    GL: np.ndarray
    GR: np.ndarray
    GR_space: np.ndarray
    Q: np.ndarray
    space: int
    T_space: float
    transient: DeckTransient | None = None
    model_name: str = "FEM2TMM"
    #: named, parametric loads: (constant NAME, its value, fractions (n,)): node i's QI is the rest of Q_i plus
    #: Σ fraction_i × NAME, so that changing NAME in the deck changes that load as fem2tmm would distribute it
    load_terms: tuple = ()
    #: named fixed temperatures: {node index: constant NAME} (°C)
    temperature_terms: dict = field(default_factory=dict)
    #: the correction load following named constants ([reduction] parametric): (constant NAME, x (s,) in deck units,
    #: weights W (m, s) of each state as a function of NAME, dQ (m, n) W each state's correction minus the design's);
    #: node i's QI adds Σ_j dQ[j, i] × INTRP1(NAME, table of W[j]).  The constant SINK is the sink temperature (°C)
    parametric_terms: tuple = ()


def node_numbers(part: np.ndarray, n_parts: int) -> tuple[np.ndarray, int]:
    """Deterministic node numbers (n,) and the space node number from the part index of each node (-1: boundary)."""
    part = np.asarray(part, np.int64)
    counts = np.bincount(part[part >= 0], minlength=n_parts) if n_parts else np.zeros(0, np.int64)
    largest = max(int(counts.max(initial=0)), int(np.count_nonzero(part < 0)), 1)
    B = 1000
    while B <= largest:
        B *= 10
    numbers = np.zeros(len(part), np.int64)
    for p in range(n_parts):
        idx = np.flatnonzero(part == p)
        numbers[idx] = (p + 1) * B + 1 + np.arange(len(idx))
    idx = np.flatnonzero(part < 0)
    numbers[idx] = (n_parts + 1) * B + 1 + np.arange(len(idx))
    return numbers, (n_parts + 2) * B


def _fmt(v: float) -> str:
    return repr(float(v)) if np.isfinite(v) else "0.0"


#: solver control of the steady solution ($CONSTANTS $CONTROL; ESATAN-TMS generated decks set the same two before
#: CALL SOLVFM): convergence on the largest temperature change between iterations (K) and the iteration budget
RELXCA, NLOOP = 1e-4, 1000
#: ESATAN identifiers: a letter, then letters, digits or underscores; model names at most 24 characters
NAME_LENGTH = 24
_RESERVED = {"TIMEO", "TIMEND", "TIMEM", "DTIMEI", "OUTINT", "STEFAN", "RELXCA", "NLOOP", "TABS", "SPACE"}


def identifier(name: str, fallback: str = "FEM2TMM") -> str:
    """An ESATAN identifier from ``name``: upper case, letters / digits / underscores, a letter first, at most
    :data:`NAME_LENGTH` characters."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", str(name)).upper().strip("_")
    if not s or not s[0].isalpha():
        s = (fallback[:1] or "N") + "_" + s
    return s[:NAME_LENGTH]


def constant_name(name: str) -> str:
    """The deck constant of a named boundary (its identifier; prefixed ``U_`` where it would shadow a control
    constant)."""
    c = identifier(name, "U")
    return ("U_" + c)[:NAME_LENGTH] if c in _RESERVED else c


def write_esatan(path: str | Path, deck: Deck, title: str = "fem2tmm reduced model") -> dict:
    """Write ``deck`` as an ESATAN input deck; returns counts {nodes, GL, GR, negative_GL}.

    Blocks in the order of ESATAN-TMS generated decks: ``$MODEL``, ``$NODES``, ``$CONDUCTORS``, ``$CONSTANTS``
    (``$REAL``: the named loads and fixed temperatures; ``$CONTROL``: STEFAN, RELXCA, NLOOP and, for a
    transient, TIMEO, TIMEND, DTIMEI, OUTINT), ``$ARRAYS`` (time tables), ``$INITIAL``, ``$VARIABLES1`` (loads
    QI, time-dependent boundary temperatures), ``$VARIABLES2``, ``$EXECUTION`` (``CALL SOLVFM`` or, with a
    transient, ``CALL SLCRNC``), ``$OUTPUTS`` (``PRNDTB`` of labels, temperatures, loads and capacitances) and
    ``$ENDMODEL``.  Every statement ends with ``;``.
    """
    n = len(deck.numbers)
    name = identifier(deck.model_name)
    lines = [f"$MODEL {name}", f"# {title}", "# written by fem2tmm; units: T degC, C J/K, A m2, GL W/K, GR m2, QI W",
             "$NODES"]
    for i in range(n):
        kind = "B" if deck.boundary[i] else "D"
        T = deck.temperature_terms.get(i, _fmt(deck.T[i] - KELVIN))
        lines.append(f"    {kind}{deck.numbers[i]} = '{deck.labels[i]}', T = {T}, "
                     f"C = {_fmt(deck.C[i])}, A = {_fmt(deck.A[i])}, ALP = {_fmt(deck.alp[i])}, EPS = {_fmt(deck.eps[i])};")
    sink_named = any(c == "SINK" for c, *_ in deck.parametric_terms)
    lines.append(f"    B{deck.space} = 'SPACE', T = {'SINK' if sink_named else _fmt(deck.T_space - KELVIN)};")
    iu, ju = np.triu_indices(n, 1)
    gl = deck.GL[iu, ju]
    nz = gl != 0
    negative = int(np.count_nonzero(gl[nz] < 0))
    lines.append("$CONDUCTORS")
    lines.append(f"# {int(nz.sum())} conductive links; {negative} are negative (exact reduction: they belong to the "
                 "reduced conduction matrix as a whole and must be kept)")
    for a, b, g in zip(iu[nz], ju[nz], gl[nz]):
        tag = "  # negative" if g < 0 else ""
        lines.append(f"    GL({deck.numbers[a]}, {deck.numbers[b]}) = {_fmt(g)};{tag}")
    gr = deck.GR[iu, ju]
    nzr = gr != 0
    for a, b, g in zip(iu[nzr], ju[nzr], gr[nzr]):
        lines.append(f"    GR({deck.numbers[a]}, {deck.numbers[b]}) = {_fmt(g)};")
    nzs = np.flatnonzero(deck.GR_space != 0)
    for a in nzs:
        lines.append(f"    GR({deck.numbers[a]}, {deck.space}) = {_fmt(deck.GR_space[a])};")
    tr = deck.transient
    lines.append("$CONSTANTS")
    named = [(c, v, "W (or W/m2): a named load, distributed over the nodes below") for c, v, _ in deck.load_terms]
    named += [(c, float(deck.T[i] - KELVIN), "degC: a named fixed temperature") for i, c in deck.temperature_terms.items()]
    if sink_named:
        named.append(("SINK", float(deck.T_space - KELVIN), "degC: the sink (space) temperature"))
    if named:
        lines.append("  $REAL")
        for c, v, what in named:
            lines.append(f"    {c} = {_fmt(v)};  # {what}")
    lines.append("  $CONTROL")
    lines.append(f"    STEFAN = {_fmt(SIGMA)};")
    lines.append(f"    RELXCA = {_fmt(RELXCA)};")
    lines.append(f"    NLOOP = {NLOOP};")
    if tr is not None:
        lines.append(f"    TIMEO = {_fmt(tr.start)};")
        lines.append(f"    TIMEND = {_fmt(tr.end)};")
        if tr.step is not None:
            lines.append(f"    DTIMEI = {_fmt(tr.step)};")
        lines.append(f"    OUTINT = {_fmt(tr.output if tr.output is not None else tr.end - tr.start)};")
    if tr is not None or deck.parametric_terms:
        lines.append("$ARRAYS")
        lines.append("  $REAL")
    if tr is not None:
        lines.append("# doublet arrays (time s, value), read by linear interpolation in time (INTRP1), constant "
                     "outside" + ("; periodic with period TIMEND - TIMEO" if tr.periodic else ""))
        for aname, t, v, what in tr.tables():
            pairs = ", ".join(f"{_fmt(a)}, {_fmt(b)}" for a, b in zip(t, v))
            lines.append(f"    {aname}({2 * len(t)}) = {pairs};  # {what}")
    if deck.parametric_terms:
        lines.append("# the network's correction load at other values of the named constants: doublet arrays (value of "
                     "the constant, weight of one computed state), read by INTRP1 of that constant (constant outside "
                     "the computed values); the weights are quadratic between the values and 0 or 1 at each of them")
        for k, (c, x, W, _) in enumerate(deck.parametric_terms):
            for j in range(1, len(W)):
                pairs = ", ".join(f"{_fmt(a)}, {_fmt(b)}" for a, b in zip(x, W[j]))
                lines.append(f"    P{k + 1}W{j}({2 * len(x)}) = {pairs};  # {c}: state {j}")
    lines.append("$INITIAL")
    lines.append("# the boundary temperatures are those of $NODES (and $VARIABLES1 where they follow a table)")
    lines.append("$VARIABLES1")
    # QI = the loads without tables (the steady QI for a steady deck) - the named loads' design share + the named
    # constants' share + the tables: exactly the run's Q(t)
    rest = np.array(deck.Q if tr is None or tr.base is None else tr.base, float)
    for c, v, frac in deck.load_terms:
        rest = rest - v * np.asarray(frac, float)
    for i in range(n):
        terms = [] if tr is None else tr.load_terms(i)
        par = [(c, float(frac[i])) for c, _, frac in deck.load_terms if frac[i] != 0]
        corr = [(f"P{k + 1}W{j}", c, float(dQ[j, i])) for k, (c, _, _, dQ) in enumerate(deck.parametric_terms)
                for j in range(1, len(dQ)) if dQ[j, i] != 0]
        if deck.Q[i] != 0 or rest[i] != 0 or terms or par or corr:
            rhs = "".join(f" {'-' if f < 0 else '+'} {_fmt(abs(f))} * {c}" for c, f in par)
            rhs += "".join(f" {'-' if c < 0 else '+'} {_fmt(abs(c))} * INTRP1(TIMEM, {a})" for a, c in terms)
            rhs += "".join(f" {'-' if d < 0 else '+'} {_fmt(abs(d))} * INTRP1({c}, {a})" for a, c, d in corr)
            lines.append(f"    QI{deck.numbers[i]} = {_fmt(rest[i])}{rhs};")
    if tr is not None:
        for k, (i, _, _) in enumerate(tr.temperatures):
            lines.append(f"    T{deck.numbers[i]} = INTRP1(TIMEM, TTAB{k + 1});")
        if tr.sink is not None:
            lines.append(f"    T{deck.space} = INTRP1(TIMEM, TSINK);")
    lines.append("$VARIABLES2")
    lines.append("$EXECUTION")
    lines.append("    CALL SLCRNC;" if tr is not None else "    CALL SOLVFM;")
    lines.append("$OUTPUTS")
    lines.append("    CALL PRNDTB(' ', 'L, T, QI, C', CURRENT);")
    lines.append(f"$ENDMODEL {name}")
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
    return {"nodes": n, "GL": int(nz.sum()), "GR": int(nzr.sum() + len(nzs)), "negative_GL": negative}
