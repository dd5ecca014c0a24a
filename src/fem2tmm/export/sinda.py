"""SINDA/FLUINT input of a reduced network, with the same named constants and time tables as the ESATAN deck.

Units (stated in the file): temperatures °C (ABSZRO = -273.15), capacitance J/K, linear conductors W/K,
radiation conductors m² (GR = ε A ℱ) with SIGMA = 5.670374419e-8 W/(m² K⁴) in CONTROL DATA.
Boundary (fixed-temperature) nodes have negative node ids; radiation conductors have negative conductor
ids, as SINDA/FLUINT requires.  Node numbers are those of :func:`fem2tmm.export.esatan.node_numbers`.

The named loads and fixed temperatures of the ESATAN deck are registers (``HEADER REGISTER DATA``): the sources
of ``HEADER SOURCE DATA`` and the boundary temperatures of ``HEADER NODE DATA`` are expressions of them, so that
changing ``HEATER`` changes that load as fem2tmm distributes it.  Loads that follow a time table or the network's
parametric correction are set in ``HEADER VARIABLES 1`` (``D1DEG1`` linear interpolation of a doublet array), a
named load with a table once, as multiples of its register.  Logic lines are Fortran: at most 72 columns,
continued with ``&`` in column 6; data lines at most 132 characters, array data continued over lines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import KELVIN, SIGMA
from .esatan import (Deck, _tabled_loads, linear_sum, named_constants, node_loads, space_table_rows,
                     transient_controls, transient_routine)

#: Fortran fixed-form statement field (logic blocks: columns 7 to 72)
FORTRAN_WIDTH = 72
#: data lines
DATA_WIDTH = 132


#: continuation lines of one Fortran 77 statement (the standard's limit); a longer sum goes on in a new statement
FORTRAN_CONTINUATIONS = 19


def _fortran(statement: str, items=None) -> list[str]:
    """A Fortran assignment ``statement`` + ``" ".join(items)`` in fixed form: columns 7-72, continuation lines with
    ``&`` in column 6, broken between items (each broken line ends with an operator, as :func:`linear_sum` gives
    them).  A sum longer than 1 + :data:`FORTRAN_CONTINUATIONS` lines continues in a new statement that adds to
    the assigned variable (``Q12 = Q12 + ...``)."""
    target = statement.split("=")[0].strip()
    lines, cur, n_lines = [], "      " + statement, 1
    for it in items or []:
        piece = (" " if not cur.endswith(" ") else "") + it
        if len(cur) + len(piece) <= FORTRAN_WIDTH:
            cur += piece
        elif n_lines <= FORTRAN_CONTINUATIONS:
            lines.append(cur)
            cur, n_lines = "     &  " + it, n_lines + 1
        else:  # a new statement: the trailing operator of this line starts it
            op = cur[-1]
            lines.append(cur[:-1].rstrip())
            cur, n_lines = f"      {target} = {target} {op} {it}", 1
    lines.append(cur)
    return lines


def _data(first: str, items, width: int = DATA_WIDTH, comment: str = "") -> list[str]:
    """Data-block values ``first, item, item, ...`` over lines of at most ``width`` characters (a line that does
    not end the entry ends with ``,``)."""
    lines, cur = [], "      " + first
    for it in items:
        piece = ", " + it
        if len(cur) + len(piece) + 1 <= width:
            cur += piece
        else:
            lines.append(cur + ",")
            cur = "      " + it
    tail = f"    $ {comment}" if comment and len(cur) + len(comment) + 6 <= width else ""
    lines.append(cur + tail)
    return lines


def write_sinda(path: str | Path, deck: Deck, submodel: str = "FEM2TMM") -> dict:
    """Write ``deck`` as SINDA/FLUINT input; returns counts {nodes, linear, radiation, longest_line}."""
    sub = "".join(c for c in submodel.upper() if c.isalnum())[:16] or "FEM2TMM"
    tr = deck.transient
    tabled = _tabled_loads(deck)
    out = [f"C fem2tmm reduced model, submodel {sub}",
           "C units: T degC, C J/K, linear conductors W/K, radiation conductors m2 (SIGMA below)",
           *(f"C {line}" for line in deck.validity),
           "HEADER OPTIONS DATA", "TITLE fem2tmm reduced model"]
    sink_named = any(c == "SINK" for c, *_ in deck.parametric_terms)
    registers = named_constants(deck)
    if registers:
        out.append("HEADER REGISTER DATA")
        out += [f"      {c} = {float(v)!r}    $ {what}" for c, v, what in registers]
    out += ["HEADER CONTROL DATA, GLOBAL", f"      SIGMA  = {SIGMA!r}", f"      ABSZRO = {-KELVIN!r}",
            "      UID    = SI"]
    # (SINDA/FLUINT's output interval is OUTPUT)
    out += [f"      {'OUTPUT' if c == 'OUTINT' else c:<6} = {float(v)!r}" for c, v in transient_controls(tr)]
    out.append(f"HEADER NODE DATA, {sub}")
    n = len(deck.numbers)
    init = None if tr is None else tr.initial
    for i in range(n):
        nid = -deck.numbers[i] if deck.boundary[i] else deck.numbers[i]
        if i in deck.temperature_terms:
            T = deck.temperature_terms[i]
        else:
            T = repr(float((init if init is not None and not deck.boundary[i] else deck.T[i]) - KELVIN))
        C = float(deck.C[i]) if deck.C[i] != 0 or deck.boundary[i] else -1.0  # negative C: an arithmetic node
        out.append(f"      {nid}, {T}, {C!r}    $ {deck.labels[i]}")
    space_T = "SINK" if sink_named else repr(float(deck.T_space - KELVIN))
    out.append(f"      -{deck.space}, {space_T}, 0.0    $ SPACE")
    out.append(f"HEADER CONDUCTOR DATA, {sub}")
    cid = 0
    iu, ju = np.triu_indices(n, 1)
    count = {}
    for kind, M, sign in (("linear", np.asarray(deck.GL), ""), ("radiation", np.asarray(deck.GR), "-")):
        nz = np.flatnonzero(M[iu, ju] != 0)  # upper-triangle pairs, row by row
        for a, b in zip(iu[nz], ju[nz]):
            cid += 1
            out.append(f"      {sign}{cid}, {deck.numbers[a]}, {deck.numbers[b]}, {float(M[a, b])!r}")
        count[kind] = len(nz)
    lin, rad = count["linear"], count["radiation"]
    space_cid = {}
    for a in np.flatnonzero(deck.GR_space):
        cid += 1
        rad += 1
        space_cid[int(a)] = cid
        out.append(f"      -{cid}, {deck.numbers[a]}, {deck.space}, {float(deck.GR_space[a])!r}")
    tables = tr.tables() if tr is not None else []
    arrays = []  # (SINDA array id, name, x, y, what)
    for k, (name, t, v, what) in enumerate(tables):
        if name.startswith("QTAB") and int(name[4:]) - 1 in tabled:
            c, R = tabled[int(name[4:]) - 1]
            v, what = np.asarray(v, float) / R, f"multiples of {c} in time"
        arrays.append((len(arrays) + 1, name, t, v, f"{what} (time s, value)"))
    ids = {a[1]: a[0] for a in arrays}
    for k, (c, x, W, _) in enumerate(deck.parametric_terms):
        for j in range(1, len(W)):
            nm = f"P{k + 1}W{j}"
            arrays.append((len(arrays) + 1, nm, x, W[j], f"{c}: weight of state {j} ({c}, weight)"))
            ids[nm] = arrays[-1][0]
    space_rows = space_table_rows(deck)  # GR to space following the node's own temperature: G<cid> = D1DEG1(T<n>, A)
    for i in space_rows:
        x, y = deck.space_tables
        arrays.append((len(arrays) + 1, f"GRS{deck.numbers[i]}", np.asarray(x[i]) - KELVIN, y[i],
                       "GR to space m2 against the node temperature degC"))
        ids[f"GRS{deck.numbers[i]}"] = arrays[-1][0]
    # the loads: the constant part and the named loads in SOURCE DATA (expressions of the registers); a node whose
    # load follows a table or the parametric correction, or whose expression does not fit a data line, gets its whole
    # load in VARIABLES 1 instead
    sources, logic = [], []
    for i, rest, terms, dynamic in node_loads(deck, lambda k: f"D1DEG1(TIMEM, A{ids[f'QTAB{k + 1}']})",
                                              lambda c, k, j: f"D1DEG1({c}, A{ids[f'P{k + 1}W{j}']})"):
        expr = " ".join(linear_sum(rest, terms))
        if dynamic or len(f"      {deck.numbers[i]}, {expr}") > DATA_WIDTH:  # (a data value stays on its line)
            logic += _fortran(f"Q{deck.numbers[i]} = ", linear_sum(rest, terms))
        else:
            sources.append((deck.numbers[i], expr))
    if sources:
        out.append(f"HEADER SOURCE DATA, {sub}")
        out += [f"      {num}, {expr}" for num, expr in sources]
    if arrays:
        out.append(f"HEADER ARRAY DATA, {sub}")
        for aid, name, x, y, what in arrays:
            out.append(f"C {name}: {what}"[:DATA_WIDTH])
            out += _data(f"{aid} = {float(x[0])!r}", [repr(float(y[0]))] +
                         [f"{float(a)!r}, {float(b)!r}" for a, b in zip(x[1:], y[1:])])
            out.append("      END")
    if tr is not None:
        for k, (i, _, _) in enumerate(tr.temperatures):
            logic += _fortran(f"T{deck.numbers[i]} = D1DEG1(TIMEM, A{ids[f'TTAB{k + 1}']})")
        if tr.sink is not None:
            logic += _fortran(f"T{deck.space} = D1DEG1(TIMEM, A{ids['TSINK']})")
    for i in space_rows:
        logic += _fortran(f"G{space_cid[i]} = D1DEG1(T{deck.numbers[i]}, A{ids[f'GRS{deck.numbers[i]}']})")
    if logic:
        out.append(f"HEADER VARIABLES 1, {sub}")
        out += logic
    out += ["HEADER OPERATIONS DATA", "      BUILD ALL"]
    if tr is None:  # the steady run: build the model, solve it, print the temperatures
        out += ["      CALL STEADY"]
    else:
        routine, warning = transient_routine(tr.method, "SINDA")
        if warning:
            out += [f"C {line}" for line in _wrap(warning, DATA_WIDTH - 2)]
        if init is None:
            out.append("C the transient starts from the steady state at TIMEO")
            out.append("      CALL STEADY")
        out.append(f"      CALL {routine}")
        if warning:
            import warnings

            warnings.warn(warning, stacklevel=2)
    out.append(f"      CALL TPRINT('{sub}')")
    out.append("END OF DATA")
    Path(path).write_text("\n".join(out) + "\n", encoding="ascii", errors="replace")
    return {"nodes": n + 1, "linear": lin, "radiation": rad, "longest_line": max(len(x) for x in out)}


def _wrap(text: str, width: int) -> list[str]:
    import textwrap

    return textwrap.wrap(text, width, break_long_words=False, break_on_hyphens=False)
