"""Thermal boundary conditions of a Nastran deck (``[mesh] nastran_loads``), for :mod:`fem2tmm.io.nastran`.

Cards read
----------
=====================  ==============================================================================
SPC                    SID G1 C1 D1 G2 C2 D2: GRID Gi held at temperature Di
SPC1                   SID C G1 G2 ... (``THRU``): GRIDs held at their TEMP value (else the TEMPD value)
TEMP, TEMPD            SID G T (three pairs per card); SID T (default temperature): values of SPC1 GRIDs
                       and of RADBC ambient points
CHBDY (NASTRAN-95)     EID PID TYPE G1-G4: a face (TYPE AREA3 / AREA4); emissivity E1 of its PHBDY
CHBDYG                 EID - TYPE IVIEWF IVIEWB RADMIDF RADMIDB - / G1-G8: a face (AREA3/4/6/8: corner
                       GRIDs G1-G3/G4); emissivity of RADM RADMIDF
CHBDYE                 EID EID2 SIDE ... RADMIDF: the face of shell element EID2 (SIDE 1 or 2)
QBDY1, QBDY3           SID Q0 (QBDY3: CNTRLND) EID1 EID2 ... (``THRU``, ``BY``): flux Q0 on CHBDYx faces
QBDY2                  SID EID Q01 ... : the mean of the GRID fluxes on the face of CHBDYx EID
QHBDY                  SID FLAG Q0 AF G1-G8: FLAG POINT: power Q0·AF at G1; AREA3/AREA4: flux Q0 on the face
QVOL                   SID QVOL CNTRLND EID1 ... (``THRU``): volumetric power on shell/solid elements
RADBC                  NODAMB FAMB CNTRLND EID1 ... (``THRU``): CHBDYx faces radiate to the ambient point
                       NODAMB (its SPC/TEMP value) with emissivity x FAMB
RADM                   RADMID ABSORP EMIS
=====================  ==============================================================================

The load and SPC set ids are those of the cards; a deck with several sets of a kind needs
``[mesh] load_set`` / ``spc_set``.  Temperatures are converted with ``[mesh] temperature_unit`` (required when
the deck gives temperatures), fluxes and powers with the deck's unit system.  Faces are given by their corner
GRIDs; the model integrates fluxes with the face's area shares.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ...errors import Fem2TmmError, format_ids
from ...mesh import DeckLoads
from ..units import TEMPERATURE_UNITS

_FACE_TYPES = {b"AREA3": 3, b"AREA4": 4, b"AREA6": 3, b"AREA8": 4}


def _id_list(fields, where: str) -> list[int]:
    """Integers of a list of fields with ``THRU`` (and ``BY``) ranges; blanks skipped."""
    out: list[int] = []
    f = [x.strip().upper() for x in fields if x.strip()]
    i = 0
    while i < len(f):
        if f[i] == b"THRU":
            if not out or i + 1 >= len(f):
                raise Fem2TmmError(f"{where}: THRU needs an id before and after it")
            step = 1
            hi = int(f[i + 1])
            if i + 3 < len(f) and f[i + 2] == b"BY":
                step = int(f[i + 3])
                i += 2
            out.extend(range(out[-1] + step, hi + 1, step))
            i += 2
            continue
        try:
            out.append(int(f[i]))
        except ValueError:
            raise Fem2TmmError(f"{where}: {f[i].decode('latin-1')!r} is not an id") from None
        i += 1
    return out


def _real(f: bytes, where: str, what: str, default=None) -> float:
    from .deck import _scalar_real

    v = _scalar_real(f) if f.strip() else default
    if v is None:
        raise Fem2TmmError(f"{where}: {what} {f.decode('latin-1').strip()!r} is not a number")
    return v


def _pad(f, n=24):
    return list(f) + [b""] * max(0, n - len(f))


def _select_set(records, wanted, kind: str, key: str, source: str, deck):
    """The records of one set id (first field): all when there is one id, ``wanted`` when there are several."""
    ids = sorted({int(f[0]) for _, f in records if f and f[0].strip()})
    if len(ids) <= 1 and wanted is None:
        return records
    if wanted is None:
        raise Fem2TmmError(f"{source}: the deck has {kind} sets {', '.join(map(str, ids))}; fem2tmm reads one: "
                           f"set [mesh] {key} = <id>")
    if wanted not in ids:
        raise Fem2TmmError(f"{source}: [mesh] {key} = {wanted}: no {kind} card has that set id "
                           f"(the deck has {', '.join(map(str, ids)) or 'none'})")
    return [(q, f) for q, f in records if f and f[0].strip() and int(f[0]) == wanted]


def read_loads(deck, grids, blocks, points, cards: set[str], factors: dict | None, temperature_unit: str | None,
               load_set: int | None, spc_set: int | None, source: str) -> DeckLoads:
    """The deck's thermal boundary conditions (cards in ``cards``) as a :class:`~fem2tmm.mesh.DeckLoads`.

    ``deck`` a parsed ``_Deck``, ``grids`` its GRID lookup, ``blocks`` the mesh's element blocks, ``points``
    (n, 3) m; ``factors`` SI factors of the deck's unit system (None: undefined -> an error if fluxes are read).
    """
    counts = Counter()
    recs = {c: deck.records(c) for c in ("SPC", "SPC1", "TEMP", "TEMPD", "QBDY1", "QBDY2", "QBDY3", "QHBDY",
                                          "QVOL", "CHBDY", "CHBDYG", "CHBDYE", "CHBDYP", "RADBC", "RADM", "PHBDY")}
    for c in ("SPC", "SPC1"):
        recs[c] = _select_set(recs[c], spc_set, "SPC", "spc_set", source, deck) if c in cards else []
    for c in ("QBDY1", "QBDY2", "QBDY3", "QHBDY", "QVOL"):
        recs[c] = recs[c] if c in cards else []
    loads = [(c, q, f) for c in ("QBDY1", "QBDY2", "QBDY3", "QHBDY", "QVOL") for q, f in recs[c]]
    if loads:
        sel = _select_set([(q, f) for _, q, f in loads], load_set, "load", "load_set", source, deck)
        keep = {q for q, _ in sel}
        for c in ("QBDY1", "QBDY2", "QBDY3", "QHBDY", "QVOL"):
            recs[c] = [(q, f) for q, f in recs[c] if q in keep]
    for c in ("TEMP", "TEMPD", "RADBC"):
        recs[c] = recs[c] if (c in cards or (c in ("TEMP", "TEMPD") and ("SPC1" in cards or "RADBC" in cards))) else []
    if recs["CHBDYP"] and (cards & {"QBDY1", "QBDY2", "QBDY3", "RADBC"}):
        raise Fem2TmmError(f"{deck.where(recs['CHBDYP'][0][0])}: CHBDYP (point/line/tube boundaries) is not supported "
                           "by nastran_loads; model those loads in the case file, or leave the cards out of "
                           "[mesh] nastran_loads")

    def temperature(v: float, where: str) -> float:
        if np.isnan(v):
            return v
        if temperature_unit is None:
            raise Fem2TmmError(f"{where}: the deck gives temperatures: set [mesh] temperature_unit "
                               "(\"K\", \"C\", \"F\" or \"R\") so that they can be read")
        a, b = TEMPERATURE_UNITS[temperature_unit]
        return a * v + b

    def factor(kind: str, where: str) -> float:
        if factors is None:
            raise Fem2TmmError(f"{where}: the deck's load values need a unit system: set [mesh] unit_system")
        return factors[kind]

    # ---- temperatures by id (GRIDs and ambient points)
    temp_of: dict[int, float] = {}
    for q, f in recs["TEMP"]:
        f = _pad(f)
        for j in (1, 3, 5):
            if f[j].strip():
                temp_of[int(f[j])] = _real(f[j + 1], deck.where(q), "TEMP value")
    tempd = None
    for q, f in recs["TEMPD"]:
        tempd = _real(_pad(f)[1], deck.where(q), "TEMPD value")
    fixed: dict[int, tuple[float, str]] = {}
    for q, f in recs["SPC"]:
        f = _pad(f)
        for j in (1, 4):
            if f[j].strip():
                fixed[int(f[j])] = (_real(f[j + 2], deck.where(q), "SPC value", default=0.0), deck.where(q))
        counts["SPC"] += 1
    for q, f in recs["SPC1"]:
        where = deck.where(q)
        for g in _id_list(f[2:], where):
            v = temp_of.get(g, tempd)
            fixed[g] = (np.nan if v is None else v, where)  # NaN: no TEMP/TEMPD (an error if the model uses it)
        counts["SPC1"] += 1
    fixed_ids = np.array(sorted(fixed), np.int64)
    _, is_grid = grids.find(fixed_ids)

    # ---- boundary faces (CHBDY, CHBDYG, CHBDYE)
    eps_of = {int(f[0]): _real(_pad(f)[2], deck.where(q), "RADM EMIS", default=1.0) for q, f in recs["RADM"]}
    phbdy = {int(f[0]): _real(_pad(f)[3], deck.where(q), "PHBDY E1", default=1.0) for q, f in recs["PHBDY"]
             if len(f) > 3 and f[3].strip()}
    faces: dict[int, tuple[np.ndarray, float, str]] = {}  # EID -> (corner node indices, emissivity, where)
    for q, f, modern in [(q, f, False) for q, f in recs["CHBDY"]] + [(q, f, True) for q, f in recs["CHBDYG"]]:
        f, where = _pad(f), deck.where(q)
        ftype = f[2].strip().upper()
        if ftype not in _FACE_TYPES:
            raise Fem2TmmError(f"{where}: CHBDY{'G' if modern else ''} TYPE {ftype.decode('latin-1')!r} is not supported "
                               "by nastran_loads (AREA3, AREA4, AREA6, AREA8 only)")
        n = _FACE_TYPES[ftype]
        g = [int(x) for x in (f[8 : 8 + n] if modern else f[3 : 3 + n])]
        eps = eps_of.get(int(f[5]), 1.0) if modern and f[5].strip() else (
            phbdy.get(int(f[1]), 1.0) if not modern and f[1].strip() else 1.0)
        faces[int(f[0])] = (grids.index(np.array(g), f"{where}: CHBDY {int(f[0])}"), eps, where)
    for q, f in recs["CHBDYE"]:
        f, where = _pad(f), deck.where(q)
        e2 = int(f[1])
        hit = [(b, np.flatnonzero(b.ids == e2)) for b in blocks]
        hit = [(b, r) for b, r in hit if len(r)]
        if not hit:
            raise Fem2TmmError(f"{where}: CHBDYE {int(f[0])}: element {e2} does not exist")
        b, r = hit[0]
        if b.type not in ("tri3", "quad4"):
            raise Fem2TmmError(f"{where}: CHBDYE on {b.type} element {e2}: only shell faces are supported; use "
                               "CHBDYG with the face's GRIDs")
        eps = eps_of.get(int(f[5]), 1.0) if f[5].strip() else 1.0
        faces[int(f[0])] = (np.asarray(b.cells[r[0]]), eps, where)

    def face_rows(eids, where):
        missing = [e for e in eids if e not in faces]
        if missing:
            raise Fem2TmmError(f"{where}: boundary elements {format_ids(np.array(missing))} have no CHBDY/CHBDYG/CHBDYE")
        out = np.full((len(eids), 4), -1, np.int64)
        for r, e in enumerate(eids):
            out[r, : len(faces[e][0])] = faces[e][0]
        return out

    flux_faces, flux_values = [], []
    nodal = np.zeros(len(points))
    for c, first in (("QBDY1", 2), ("QBDY3", 3)):
        for q, f in recs[c]:
            where = deck.where(q)
            q0 = _real(f[1], where, f"{c} Q0") * factor("flux", where)
            eids = _id_list(f[first:], where)
            flux_faces.append(face_rows(eids, where))
            flux_values.append(np.full(len(eids), q0))
            counts[c] += 1
    for q, f in recs["QBDY2"]:
        where = deck.where(q)
        vals = [_real(x, where, "QBDY2 flux") for x in f[2:] if x.strip()]
        flux_faces.append(face_rows([int(f[1])], where))
        flux_values.append(np.array([np.mean(vals) * factor("flux", where)]))
        counts["QBDY2"] += 1
    for q, f in recs["QHBDY"]:
        f, where = _pad(f), deck.where(q)
        flag = f[1].strip().upper()
        q0 = _real(f[2], where, "QHBDY Q0")
        if flag == b"POINT":
            af = _real(f[3], where, "QHBDY AF")
            nodal[grids.index(np.array([int(f[4])]), where)] += q0 * af * factor("power", where)
        elif flag in (b"AREA3", b"AREA4"):
            n = 3 if flag == b"AREA3" else 4
            row = np.full((1, 4), -1, np.int64)
            row[0, :n] = grids.index(np.array([int(x) for x in f[4 : 4 + n]]), where)
            flux_faces.append(row)
            flux_values.append(np.array([q0 * factor("flux", where)]))
        else:
            raise Fem2TmmError(f"{where}: QHBDY FLAG {flag.decode('latin-1')!r} is not supported (POINT, AREA3, AREA4)")
        counts["QHBDY"] += 1
    vol_el, vol_val = [], []
    if recs["QVOL"]:
        eid_all = np.concatenate([b.ids for b in blocks])
        order = np.argsort(eid_all)
        for q, f in recs["QVOL"]:
            where = deck.where(q)
            qv = _real(f[1], where, "QVOL") * factor("power_density", where)
            eids = np.array(_id_list(f[3:], where), np.int64)
            pos = np.minimum(np.searchsorted(eid_all[order], eids), len(order) - 1)
            bad = eid_all[order][pos] != eids
            if bad.any():
                raise Fem2TmmError(f"{where}: QVOL on elements {format_ids(eids[bad])} that do not exist")
            vol_el.append(order[pos])
            vol_val.append(np.full(len(eids), qv))
            counts["QVOL"] += 1
    rad_faces, rad_eps, rad_T = [], [], []
    for q, f in recs["RADBC"]:
        where = deck.where(q)
        amb = int(f[0])
        if amb in fixed:
            t_amb = fixed[amb][0]
        elif amb in temp_of or tempd is not None:
            t_amb = temp_of.get(amb, tempd)
        else:
            raise Fem2TmmError(f"{where}: RADBC ambient point {amb} has no SPC/TEMP/TEMPD temperature")
        famb = _real(f[1], where, "RADBC FAMB", default=1.0)
        eids = _id_list(f[3:], where)
        rad_faces.append(face_rows(eids, where))
        rad_eps.append(np.array([faces[e][1] * famb for e in eids]))
        rad_T.append(np.full(len(eids), temperature(t_amb, where)))
        counts["RADBC"] += 1
    fixed_nodes = grids.find(fixed_ids[is_grid])[0] if len(fixed_ids) else np.zeros(0, np.int64)
    fixed_values = np.array([temperature(fixed[int(g)][0], fixed[int(g)][1]) for g in fixed_ids[is_grid]])
    z4 = np.zeros((0, 4), np.int64)
    return DeckLoads(
        fixed_nodes=np.asarray(fixed_nodes, np.int64), fixed_values=fixed_values.astype(float),
        flux_faces=np.concatenate(flux_faces) if flux_faces else z4,
        flux_values=np.concatenate(flux_values) if flux_values else np.zeros(0),
        nodal_power=nodal,
        volume_elements=np.concatenate(vol_el) if vol_el else np.zeros(0, np.int64),
        volume_values=np.concatenate(vol_val) if vol_val else np.zeros(0),
        rad_faces=np.concatenate(rad_faces) if rad_faces else z4,
        rad_emissivity=np.concatenate(rad_eps) if rad_eps else np.zeros(0),
        rad_ambient=np.concatenate(rad_T) if rad_T else np.zeros(0),
        counts=dict(counts),
    )
