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
    lin = rad = 0
    for a, b in zip(iu, ju):
        g = deck.GL[a, b]
        if g != 0:
            cid += 1
            lin += 1
            out.append(f"      {cid}, {deck.numbers[a]}, {deck.numbers[b]}, {float(g)!r}")
    for a, b in zip(iu, ju):
        g = deck.GR[a, b]
        if g != 0:
            cid += 1
            rad += 1
            out.append(f"      -{cid}, {deck.numbers[a]}, {deck.numbers[b]}, {float(g)!r}")
    for a in np.flatnonzero(deck.GR_space):
        cid += 1
        rad += 1
        out.append(f"      -{cid}, {deck.numbers[a]}, {deck.space}, {float(deck.GR_space[a])!r}")
    if np.any(deck.Q):
        out.append(f"HEADER SOURCE DATA, {sub}")
        for i in np.flatnonzero(deck.Q):
            out.append(f"      {deck.numbers[i]}, {float(deck.Q[i])!r}")
    out.append("END OF DATA")
    Path(path).write_text("\n".join(out) + "\n", encoding="ascii", errors="replace")
    return {"nodes": n + 1, "linear": lin, "radiation": rad}
