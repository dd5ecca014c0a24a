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
    #: ``[transient] method`` (the deck calls its routine, :func:`transient_routine`)
    method: str = "crank-nicolson"
    #: initial temperature K of the free nodes, or None: the steady state at ``start``
    initial: float | None = None
    #: the named constant of each load table (``""``: none, e.g. an orbital load): that load's table is written as
    #: multiples of the constant
    load_names: tuple = ()

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

    def __post_init__(self):
        if len(self.load_names) < len(self.loads):
            object.__setattr__(self, "load_names", tuple(self.load_names) + ("",) * (len(self.loads) -
                                                                                    len(self.load_names)))


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
    #: the validity statement (comment lines without the mark, :func:`fem2tmm.export.validity.validity_lines`)
    validity: tuple = ()
    #: ``(x (n, m) K, y (n, m) m²)`` or None: each node's GR to space as a function of its own temperature
    #: (``GR_space`` its design value); written as $ARRAYS doublet tables read by INTRP1 of the node's T
    space_tables: tuple | None = None


def space_table_rows(deck: "Deck") -> list[int]:
    """The nodes whose GR to space follows their own temperature (``deck.space_tables``): free nodes with a GR to
    space."""
    if deck.space_tables is None:
        return []
    y = np.asarray(deck.space_tables[1], float)
    # (a constant table, as a load's hot-spot node has, is its plain GR)
    return [i for i in range(len(deck.numbers)) if not deck.boundary[i] and deck.GR_space[i] != 0
            and np.ptp(y[i]) > 0]


def space_table_name(number: int) -> str:
    """The $ARRAYS name of node ``number``'s table of GR to space against its own temperature."""
    return f"GRS{int(number)}"


def space_table_array(number: int, x_C: np.ndarray, y: np.ndarray) -> list[str]:
    """The $ARRAYS statement (lines, continued at the deck's width) of node ``number``'s GR-to-space table: doublets
    (temperature °C, GR m²)."""
    return continued(f"{space_table_name(number)}({2 * len(x_C)}) = ",
                     [f"{_fmt(a)}, {_fmt(b)}" for a, b in zip(x_C, y)])


def space_table_statement(number: int, space: int) -> str:
    """The $VARIABLES1 statement that sets node ``number``'s GR to ``space`` from its own temperature."""
    return f"    GR({int(number)}, {int(space)}) = INTRP1(T{int(number)}, {space_table_name(number)});"


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


def _fmt_all(v: np.ndarray) -> list[str]:
    """:func:`_fmt` of every value of ``v`` (the same strings; Python floats formatted in one list comprehension:
    10⁶ conductors at 1 000 super nodes)."""
    v = np.asarray(v, float)
    return [repr(x) for x in np.where(np.isfinite(v), v, 0.0).tolist()]


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


#: the longest line of a written deck (ESATAN's input line; SINDA/FLUINT's too): longer statements continue
LINE_WIDTH = 132
#: the transient routine of each ``[transient] method`` (ESATAN-TMS transient solution routines: SLCRNC
#: Crank-Nicolson; SLGEAR Gear's backward-differentiation formulae, the family of BDF2, with its own order and
#: step control); None: ESATAN has no routine of that scheme (no fully implicit first-order routine), the deck
#: calls SLCRNC and says so
ESATAN_ROUTINES = {"crank-nicolson": "SLCRNC", "backward-euler": None, "bdf2": "SLGEAR"}


def continued(head: str, items, tail: str = ";", sep: str = ", ", indent: int = 4, width: int = LINE_WIDTH,
              cont: int = 8) -> list[str]:
    """One statement ``head + sep.join(items) + tail`` as lines of at most ``width`` characters.

    Lines break only between items, each broken line ending with the separator's non-blank part (``,`` of an
    array, ``+`` / ``-`` of a sum), so that the statement reads as continued in any of the thermal tools'
    conventions (a ``;``-terminated ESATAN statement may span lines).  ``indent`` blanks before the first line,
    ``cont`` before the continuation lines.  An item longer than a line stays whole on its own line.

    Parameters
    ----------
    head : str
        Start of the statement, e.g. ``"QI1001 = "`` or ``"QTAB1(10) = "``.
    items : sequence of str
        The pieces joined by ``sep``.
    tail : str
        End of the statement (``";"``).

    Returns
    -------
    list of str
        The lines, without newline characters.
    """
    items = [str(x) for x in items]
    pad, padc = " " * indent, " " * cont
    if not items:
        return [pad + head.rstrip() + tail]
    one = pad + head + sep.join(items) + tail
    if len(one) <= width:
        return [one]
    brk = sep.rstrip()  # what ends a broken line
    lines, cur = [], pad + head + items[0]
    for it in items[1:]:
        piece = sep + it
        if len(cur) + len(piece) + len(tail) <= width:
            cur += piece
        else:
            lines.append(cur + brk)
            cur = padc + (sep.lstrip() + it if not brk else it)
    lines.append(cur + tail)
    return lines


def linear_sum(constant: float | None, terms) -> tuple[str, list[str]]:
    """(first item, further items) of ``constant + Σ coefficient × factor`` for :func:`continued` with
    ``sep=" "``: every item but the last ends with the sign of the next term, so a broken line ends with
    ``+`` or ``-``.  ``terms``: (coefficient, factor text) pairs; zero coefficients are left out."""
    parts = [(float(c), f) for c, f in terms if c != 0]
    items = []
    if constant is not None or not parts:
        items.append(_fmt(0.0 if constant is None else constant))
    for c, f in parts:
        txt = f"{_fmt(abs(c))} * {f}"
        if items:
            items[-1] += " -" if c < 0 else " +"
            items.append(txt)
        else:
            items.append(("-" if c < 0 else "") + txt)
    return items


def comment_lines(text: str, width: int = LINE_WIDTH, prefix: str = "# ") -> list[str]:
    """A comment as lines of at most ``width`` characters, each starting with ``prefix``."""
    import textwrap

    return [prefix + s for s in textwrap.wrap(text, width - len(prefix), break_long_words=False,
                                              break_on_hyphens=False)] or [prefix.rstrip()]


def _tabled_loads(deck: Deck) -> dict:
    """{table index k: (constant NAME, reference value R W)} of the named loads that follow a time table: the
    deck writes the table as multiples of NAME (values / R) and NAME = R, so that the load is counted once and
    editing NAME scales the whole profile (NAME = 0: no load).  R is the load's design value, or the table's
    largest magnitude where that is 0."""
    tr = deck.transient
    if tr is None:
        return {}
    design = {c: v for c, v, _ in deck.load_terms}
    out = {}
    for k, c in enumerate(tr.load_names):
        if c and c in design:
            v = np.asarray(tr.loads[k][2], float)
            R = float(design[c]) if design[c] != 0 else float(np.max(np.abs(v), initial=0.0))
            out[k] = (c, R if R != 0 else 1.0)
    return out


def named_constants(deck: Deck) -> list[tuple[str, float, str]]:
    """(NAME, value in deck units, what) of the deck's named constants: each named load (W, or W/m² for a flux;
    a load with a time table: the reference its table is a multiple of), each named fixed temperature (°C) and
    SINK (°C) when the parametric correction follows the sink."""
    tabled = dict(_tabled_loads(deck).values())
    out = [(c, tabled.get(c, v), "W (or W/m2): a named load" + ("; its time table holds multiples of it"
                                                                  if c in tabled else ""))
           for c, v, _ in deck.load_terms]
    out += [(c, float(deck.T[i] - KELVIN), "degC: a named fixed temperature") for i, c in deck.temperature_terms.items()]
    if any(c == "SINK" for c, *_ in deck.parametric_terms):
        out.append(("SINK", float(deck.T_space - KELVIN), "degC: the sink (space) temperature"))
    return out


def node_loads(deck: Deck, in_time, of_constant) -> list[tuple[int, float | None, list, bool]]:
    """The load of every loaded node as ``rest + Σ coefficient × factor`` for both decks.

    ``in_time(k)``: the text of load table k interpolated at the time (``INTRP1(TIMEM, QTAB1)``);
    ``of_constant(NAME, k, j)``: the text of weight table j of parametric term k interpolated at NAME.  Returns
    (node index, rest W or None when zero, [(coefficient, factor text)], depends on time or a table) per node with a
    load: rest = the loads without tables (the steady QI for a steady deck) − the named loads' design share; the
    factors: each named constant (its fraction), each load table (a named load with a table: ``NAME * table``, its
    table alone, never the constant too), each parametric correction.  At the design values the sum is the run's
    Q(t) to round-off (rest below 1e-13 of the largest load is that round-off, written as 0)."""
    tr = deck.transient
    tabled = _tabled_loads(deck)
    tabled_names = {c for c, _ in tabled.values()}
    rest = np.array(deck.Q if tr is None or tr.base is None else tr.base, float)
    for c, v, frac in deck.load_terms:
        if c not in tabled_names:
            rest = rest - v * np.asarray(frac, float)
    scale = max(float(np.max(np.abs(deck.Q), initial=0.0)),
                max((abs(v) * float(np.max(np.abs(frac), initial=0.0)) for _, v, frac in deck.load_terms), default=0.0))
    rest[np.abs(rest) <= 1e-13 * scale] = 0.0
    out = []
    for i in range(len(deck.numbers)):
        terms = [(float(frac[i]), c) for c, _, frac in deck.load_terms if frac[i] != 0 and c not in tabled_names]
        dynamic = []
        if tr is not None:
            dynamic += [(float(p[i]), f"{tabled[k][0]} * {in_time(k)}" if k in tabled else in_time(k))
                        for k, (p, _, _) in enumerate(tr.loads) if p[i] != 0]
        dynamic += [(float(dQ[j, i]), of_constant(c, k, j)) for k, (c, _, _, dQ) in enumerate(deck.parametric_terms)
                    for j in range(1, len(dQ)) if dQ[j, i] != 0]
        if deck.Q[i] != 0 or rest[i] != 0 or terms or dynamic:
            out.append((i, float(rest[i]) if rest[i] != 0 else None, terms + dynamic, bool(dynamic)))
    return out


def transient_controls(tr: DeckTransient | None) -> list[tuple[str, float]]:
    """(control constant, value s) of a transient: TIMEO, TIMEND, DTIMEI (when the step is known) and OUTINT (the
    output interval; the whole run when none is given); [] for a steady deck."""
    if tr is None:
        return []
    out = [("TIMEO", tr.start), ("TIMEND", tr.end)] + ([("DTIMEI", tr.step)] if tr.step is not None else [])
    return out + [("OUTINT", tr.output if tr.output is not None else tr.end - tr.start)]


def transient_routine(method: str, tool: str = "ESATAN") -> tuple[str, str | None]:
    """(routine the deck calls, warning text or None) for ``[transient] method`` in ``tool`` ("ESATAN" or
    "SINDA")."""
    table = ESATAN_ROUTINES if tool == "ESATAN" else SINDA_ROUTINES
    fallback = "SLCRNC" if tool == "ESATAN" else "FWDBCK"
    routine = table.get(method)
    if routine is None:
        return fallback, (f"[transient] method = {method!r} has no matching {tool} transient routine: the {tool} "
                          f"deck calls {fallback} (Crank-Nicolson), whose results differ from the run's by the "
                          "schemes' truncation errors; use method = 'crank-nicolson' for a deck that runs as "
                          "computed")
    return routine, None


#: SINDA/FLUINT transient routines: FWDBCK (implicit forward-backward differencing, Crank-Nicolson); SINDA/FLUINT
#: has no backward-Euler or BDF2 routine
SINDA_ROUTINES = {"crank-nicolson": "FWDBCK", "backward-euler": None, "bdf2": None}


def write_esatan(path: str | Path, deck: Deck, title: str = "fem2tmm reduced model") -> dict:
    """Write ``deck`` as an ESATAN input deck; returns counts {nodes, GL, GR, negative_GL, longest_line}.

    Blocks in the order of ESATAN-TMS generated decks (the ESATAN-TMS 2020 case template): ``$MODEL``,
    ``$LOCALS``, ``$NODES``, ``$CONDUCTORS``, ``$CONSTANTS`` (``$REAL``: the named loads and fixed temperatures;
    ``$CONTROL``: STEFAN, RELXCA, NLOOP and, for a transient, TIMEO, TIMEND, DTIMEI, OUTINT), ``$ARRAYS`` (time
    tables), ``$EVENTS``, ``$SUBROUTINES``, ``$INITIAL``, ``$EXECUTION`` (``CALL SOLVFM`` or, with a transient,
    the routine of ``[transient] method`` (:data:`ESATAN_ROUTINES`), after ``CALL SOLVFM`` when the transient
    starts from the steady state), ``$VARIABLES1`` (loads QI, time-dependent boundary temperatures, evaluated at
    every step), ``$VARIABLES2``, ``$OUTPUTS`` (``PRNDTB`` of labels, temperatures, loads and capacitances) and
    ``$ENDMODEL``.  Every statement ends with ``;``; no line is longer than :data:`LINE_WIDTH` characters (long
    statements continue over lines, :func:`continued`).  A named load that follows a time table is written once:
    ``QI = fraction × NAME × INTRP1(TIMEM, table of multiples of NAME)``.
    """
    n = len(deck.numbers)
    name = identifier(deck.model_name)
    tr = deck.transient
    tabled = _tabled_loads(deck)
    lines = [f"$MODEL {name}"]
    lines += comment_lines(title)
    lines += comment_lines("written by fem2tmm; units: T degC, C J/K, A m2, GL W/K, GR m2, QI W")
    lines += [f"# {line}" for line in deck.validity]  # the validity range (fem2tmm.export.validity)
    lines.append("$LOCALS")
    lines.append("$NODES")
    init = None if tr is None else tr.initial
    hot = [i for i in range(n) if str(deck.labels[i]).endswith(" hot spot") and deck.C[i] == 0]
    for i in range(n):
        kind = "B" if deck.boundary[i] else "D"
        if hot and i == hot[0]:
            lines += comment_lines("hot spots: the share of each load that its footprint radiates inside its own super "
                                   "nodes (the exact reduction does not pass it to them); arithmetic nodes coupled "
                                   "only to space, so that the loads are applied and radiated as applied; their "
                                   "temperatures are not the structure's")
        if i in deck.temperature_terms:
            T = deck.temperature_terms[i]
        elif init is not None and not deck.boundary[i]:
            T = _fmt(init - KELVIN)  # a transient from a given initial temperature starts from it
        else:
            T = _fmt(deck.T[i] - KELVIN)
        lines += continued(f"{kind}{deck.numbers[i]} = ", [f"'{deck.labels[i]}'", f"T = {T}", f"C = {_fmt(deck.C[i])}",
                                                          f"A = {_fmt(deck.A[i])}", f"ALP = {_fmt(deck.alp[i])}",
                                                          f"EPS = {_fmt(deck.eps[i])}"])
    sink_named = any(c == "SINK" for c, *_ in deck.parametric_terms)
    lines.append(f"    B{deck.space} = 'SPACE', T = {'SINK' if sink_named else _fmt(deck.T_space - KELVIN)};")
    iu, ju = np.triu_indices(n, 1)
    gl = deck.GL[iu, ju]
    nz = gl != 0
    negative = int(np.count_nonzero(gl[nz] < 0))
    lines.append("$CONDUCTORS")
    lines += comment_lines(f"{int(nz.sum())} conductive links; {negative} are negative (exact reduction: they "
                           "belong to the reduced conduction matrix as a whole and must be kept)")
    num = np.asarray(deck.numbers).tolist()
    lines += [f"    GL({num[a]}, {num[b]}) = {g};{'  # negative' if neg else ''}" for a, b, g, neg in
              zip(iu[nz].tolist(), ju[nz].tolist(), _fmt_all(gl[nz]), (gl[nz] < 0).tolist())]
    gr = deck.GR[iu, ju]
    nzr = gr != 0
    lines += [f"    GR({num[a]}, {num[b]}) = {g};" for a, b, g in
              zip(iu[nzr].tolist(), ju[nzr].tolist(), _fmt_all(gr[nzr]))]
    nzs = np.flatnonzero(deck.GR_space != 0)
    for a in nzs:
        lines.append(f"    GR({deck.numbers[a]}, {deck.space}) = {_fmt(deck.GR_space[a])};")
    lines.append("$CONSTANTS")
    named = named_constants(deck)
    if named:
        lines.append("  $REAL")
        for c, v, what in named:
            lines.append(f"    {c} = {_fmt(v)};  # {what}")
    lines.append("  $CONTROL")
    lines.append(f"    STEFAN = {_fmt(SIGMA)};")
    lines.append(f"    RELXCA = {_fmt(RELXCA)};")
    lines.append(f"    NLOOP = {NLOOP};")
    lines += [f"    {c} = {_fmt(v)};" for c, v in transient_controls(tr)]
    space_rows = space_table_rows(deck)
    lines.append("$ARRAYS")
    if tr is not None or deck.parametric_terms or space_rows:
        lines.append("  $REAL")
    if tr is not None:
        lines += comment_lines("doublet arrays (time s, value), read by linear interpolation in time (INTRP1), "
                               "constant outside" + ("; periodic with period TIMEND - TIMEO" if tr.periodic else ""))
        for k, (aname, t, v, what) in enumerate(tr.tables()):
            if aname.startswith("QTAB") and k in tabled:
                c, R = tabled[k]
                v, what = np.asarray(v, float) / R, f"multiples of {c} in time"
            lines += comment_lines(f"{aname}: {what}")
            lines += continued(f"{aname}({2 * len(t)}) = ", [f"{_fmt(a)}, {_fmt(b)}" for a, b in zip(t, v)])
    if deck.parametric_terms:
        lines += comment_lines("the network's correction load at other values of the named constants: doublet arrays "
                               "(value of the constant, weight of one computed state), read by INTRP1 of that "
                               "constant (constant outside the computed values); the weights are quadratic between "
                               "the values and 0 or 1 at each of them")
        for k, (c, x, W, _) in enumerate(deck.parametric_terms):
            for j in range(1, len(W)):
                lines += comment_lines(f"P{k + 1}W{j}: {c}, state {j}")
                lines += continued(f"P{k + 1}W{j}({2 * len(x)}) = ", [f"{_fmt(a)}, {_fmt(b)}" for a, b in zip(x, W[j])])
    if space_rows:
        lines += comment_lines("the effective emission to space of each node (GR m2) against its own temperature "
                               "(degC): doublet arrays read by INTRP1 in $VARIABLES1, constant outside (the emission "
                               "then grows as T^4)")
        x, y = deck.space_tables
        for i in space_rows:
            lines += space_table_array(deck.numbers[i], np.asarray(x[i]) - KELVIN, y[i])
    lines.append("$EVENTS")
    lines.append("$SUBROUTINES")
    lines.append("$INITIAL")
    lines += comment_lines("the boundary temperatures are those of $NODES (and $VARIABLES1 where they follow a table)")
    lines.append("$EXECUTION")
    warning = None
    if tr is None:
        lines.append("    CALL SOLVFM;")
    else:
        routine, warning = transient_routine(tr.method, "ESATAN")
        if warning:
            lines += comment_lines(warning)
        if init is None:
            lines += comment_lines("the transient starts from the steady state at TIMEO")
            lines.append("    CALL SOLVFM;")
        lines.append(f"    CALL {routine};")
    lines.append("$VARIABLES1")
    for i, rest, terms, _ in node_loads(deck, lambda k: f"INTRP1(TIMEM, QTAB{k + 1})",
                                        lambda c, k, j: f"INTRP1({c}, P{k + 1}W{j})"):
        lines += continued(f"QI{deck.numbers[i]} = ", linear_sum(rest, terms), sep=" ")
    if tr is not None:
        for k, (i, _, _) in enumerate(tr.temperatures):
            lines.append(f"    T{deck.numbers[i]} = INTRP1(TIMEM, TTAB{k + 1});")
        if tr.sink is not None:
            lines.append(f"    T{deck.space} = INTRP1(TIMEM, TSINK);")
    for i in space_rows:
        lines.append(space_table_statement(deck.numbers[i], deck.space))
    lines.append("$VARIABLES2")
    lines.append("$OUTPUTS")
    lines.append("    CALL PRNDTB(' ', 'L, T, QI, C', CURRENT);")
    lines.append(f"$ENDMODEL {name}")
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
    if warning:
        import warnings

        warnings.warn(warning, stacklevel=2)
    return {"nodes": n, "GL": int(nz.sum()), "GR": int(nzr.sum() + len(nzs)), "negative_GL": negative,
            "longest_line": max(len(x) for x in lines)}
