"""SINDA/FLUINT node and conductor blocks of a reduced network.

Units (stated in the file): temperatures °C (ABSZRO = -273.15), capacitance J/K, linear conductors W/K,
radiation conductors m² (GR = ε A ℱ) with SIGMA = 5.670374419e-8 W/(m² K⁴) in CONTROL DATA.
Boundary (fixed-temperature) nodes have negative node ids; radiation conductors have negative conductor
ids, as SINDA/FLUINT requires.  Node numbers are those of :func:`fem2tmm.export.esatan.node_numbers`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import KELVIN, SIGMA
from .esatan import Deck


def write_sinda(path: str | Path, deck: Deck, submodel: str = "FEM2TMM") -> dict:
    """Write ``deck`` as SINDA/FLUINT input blocks; returns counts {nodes, linear, radiation}."""
    sub = "".join(c for c in submodel.upper() if c.isalnum())[:16] or "FEM2TMM"
    out = [f"C fem2tmm reduced model, submodel {sub}",
           "C units: T degC, C J/K, linear conductors W/K, radiation conductors m2 (SIGMA below)",
           "HEADER OPTIONS DATA", "TITLE fem2tmm reduced model", "HEADER CONTROL DATA, GLOBAL",
           f"      SIGMA  = {SIGMA!r}", f"      ABSZRO = {-KELVIN!r}", "      UID    = SI",
           f"HEADER NODE DATA, {sub}"]
    n = len(deck.numbers)
    for i in range(n):
        nid = -deck.numbers[i] if deck.boundary[i] else deck.numbers[i]
        out.append(f"      {nid}, {float(deck.T[i] - KELVIN)!r}, {float(deck.C[i])!r}    $ {deck.labels[i]}")
    out.append(f"      -{deck.space}, {float(deck.T_space - KELVIN)!r}, 0.0    $ SPACE")
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
    for a in np.flatnonzero(deck.GR_space):
        cid += 1
        rad += 1
        out.append(f"      -{cid}, {deck.numbers[a]}, {deck.space}, {float(deck.GR_space[a])!r}")
    tr = deck.transient
    if np.any(deck.Q):
        out.append(f"HEADER SOURCE DATA, {sub}")
        for i in np.flatnonzero(deck.Q):
            out.append(f"      {deck.numbers[i]}, {float(deck.Q[i])!r}")
    if tr is not None:
        _transient_blocks(out, deck, sub)
    else:  # the steady run: build the model, solve it, print the temperatures
        out += ["HEADER OPERATIONS DATA", "      BUILD ALL", "      CALL STEADY", f"      CALL TPRINT('{sub}')"]
    out.append("END OF DATA")
    Path(path).write_text("\n".join(out) + "\n", encoding="ascii", errors="replace")
    return {"nodes": n + 1, "linear": lin, "radiation": rad}


def _transient_blocks(out: list[str], deck: Deck, sub: str) -> None:
    """Doublet arrays of the time tables, the time-dependent sources and boundary temperatures (linear
    interpolation D1DEG1 in VARIABLES 1), the transient control constants and ``CALL TRANSIENT``."""
    tr = deck.transient
    tables = tr.tables()
    ids = {name: k + 1 for k, (name, _, _, _) in enumerate(tables)}
    out.append(f"HEADER ARRAY DATA, {sub}")
    for name, t, v, what in tables:
        pairs = ", ".join(f"{float(a)!r}, {float(b)!r}" for a, b in zip(t, v))
        out.append(f"      {ids[name]} = {pairs}    $ {name}: {what} (time s, value)")
        out.append("      END")
    out.append(f"HEADER VARIABLES 1, {sub}")
    for i in range(len(deck.numbers)):
        terms = tr.load_terms(i)
        if terms:
            rhs = "".join(f" {'-' if c < 0 else '+'} {abs(c)!r} * D1DEG1(TIMEM, A{ids[a]})" for a, c in terms)
            base = float(deck.Q[i] if tr.base is None else tr.base[i])  # the loads without their tables
            out.append(f"      Q{deck.numbers[i]} = {base!r}{rhs}")
    for k, (i, _, _) in enumerate(tr.temperatures):
        out.append(f"      T{deck.numbers[i]} = D1DEG1(TIMEM, A{ids[f'TTAB{k + 1}']})")
    if tr.sink is not None:
        out.append(f"      T{deck.space} = D1DEG1(TIMEM, A{ids['TSINK']})")
    out.append("HEADER CONTROL DATA, GLOBAL")
    out.append(f"      TIMEO  = {float(tr.start)!r}")
    out.append(f"      TIMEND = {float(tr.end)!r}")
    if tr.step is not None:
        out.append(f"      DTIMEI = {float(tr.step)!r}")
    out.append(f"      OUTPUT = {float(tr.output if tr.output is not None else tr.end - tr.start)!r}")
    out.append("HEADER OPERATIONS DATA")
    out.append("      BUILD ALL")
    out.append("      CALL TRANSIENT")
    out.append(f"      CALL TPRINT('{sub}')")
