"""Nastran property and material cards: the deck's unit system, MAT4/MAT5 (and RHO of MAT1/MAT8), bar sections,
laminates (PCOMP/PCOMPG) and the shell, solid and line properties (see :mod:`fem2tmm.io.nastran`).
"""

from __future__ import annotations

import warnings

import numpy as np

from ...errors import Fem2TmmError
from ...mesh import PropertyData
from ..units import material_factors, unit_system_name
from .deck import _Deck, _SHELL_PROPS, _scalar_int, _scalar_real
from .geometry import _check_unique


def _deck_units(unit: str, unit_system: str | None, temperature_unit: str | None, where: str):
    """SI factors of the deck's material/load values (:func:`~fem2tmm.io.units.material_factors`) or None.

    Without ``unit_system``: ``m`` means SI and ``mm`` the mm-tonne-s system (as before); any other length
    unit leaves the values undefined (the case must give them, or declare ``[mesh] unit_system``).
    """
    if unit_system is None:
        unit_system = {"m": "m-kg-s", "mm": "mm-t-s"}.get(str(unit).strip().lower())
    if unit_system is None:
        return None
    system = unit_system_name(unit_system, where=f"{where}: unit_system")
    if "lbf" in system and temperature_unit is None:
        raise Fem2TmmError(
            f"{where}: unit system {system!r} is ambiguous about temperature: conductivity per degree F "
            "or per kelvin? set [mesh] temperature_unit = \"F\" (or \"R\", \"K\", \"C\")"
        )
    return material_factors(system, temperature_unit)


def _materials(deck: _Deck, used_mids: set[int]) -> dict[int, dict]:
    """MID -> {"k": float|None, "tensor": (6,)|None, "rho", "cp"} in deck units (MAT4, MAT5, MAT1, MAT8)."""
    m4 = deck.table("MAT4", {"MID": (0, "i"), "K": (1, "r"), "CP": (2, "r"), "RHO": (3, "r")}, lenient=True)
    m5 = deck.table("MAT5", {"MID": (0, "i"), **{k: (1 + j, "r") for j, k in enumerate(_TENSOR)},
                             "CP": (7, "r"), "RHO": (8, "r")}, lenient=True)
    m1 = deck.table("MAT1", {"MID": (0, "i"), "RHO": (4, "r")}, lenient=True)
    m8 = deck.table("MAT8", {"MID": (0, "i"), "RHO": (7, "r")}, lenient=True)
    for t in (m4, m5, m1, m8):
        t.check(np.isin(t.val["MID"], list(used_mids)) | t.blank["MID"])
        t.require("MID")
        _check_unique(t.val["MID"], t.seq, t.card, deck)

    def v(t, key, r):
        return None if t.blank[key][r] else float(t.val[key][r])

    mats: dict[int, dict] = {}
    for t in (m1, m8):
        for r in range(len(t)):
            mats.setdefault(int(t.val["MID"][r]), {"k": None, "tensor": None, "rho": None, "cp": None})["rho"] = v(t, "RHO", r)
    for r in range(len(m4)):
        m = mats.setdefault(int(m4.val["MID"][r]), {"k": None, "tensor": None, "rho": None, "cp": None})
        m["k"] = v(m4, "K", r)
        for key, col in (("rho", "RHO"), ("cp", "CP")):
            m[key] = v(m4, col, r) if v(m4, col, r) is not None else m[key]
    for r in range(len(m5)):
        mid = int(m5.val["MID"][r])
        m = mats.setdefault(mid, {"k": None, "tensor": None, "rho": None, "cp": None})
        ten = np.array([m5.val[k][r] for k in _TENSOR])  # blanks are 0.0 (MAT5 defaults)
        if m["k"] is not None:
            raise Fem2TmmError(f"{m5.where(r)}: material {mid} is defined by both MAT4 and MAT5; keep one")
        m["tensor"] = ten
        for key, col in (("rho", "RHO"), ("cp", "CP")):
            m[key] = v(m5, col, r) if v(m5, col, r) is not None else m[key]
    return mats


_TENSOR = ("KXX", "KXY", "KXZ", "KYY", "KYZ", "KZZ")


#: PBARL / PBEAML section types: number of dimensions and area A(DIM1, DIM2, ...) (MSC Nastran QRG, PBARL)
_SECTIONS = {
    "ROD": (1, lambda d: np.pi * d[0] ** 2),
    "TUBE": (2, lambda d: np.pi * (d[0] ** 2 - d[1] ** 2)),
    "TUBE2": (2, lambda d: np.pi * (d[0] ** 2 - (d[0] - d[1]) ** 2)),
    "BAR": (2, lambda d: d[0] * d[1]),
    "BOX": (4, lambda d: 2 * d[0] * d[2] + 2 * (d[1] - 2 * d[2]) * d[3]),
    "I": (6, lambda d: d[1] * d[4] + d[2] * d[5] + (d[0] - d[4] - d[5]) * d[3]),
    "CHAN": (4, lambda d: 2 * d[0] * d[3] + (d[1] - 2 * d[3]) * d[2]),
    "T": (4, lambda d: d[0] * d[2] + (d[1] - d[2]) * d[3]),
    "L": (4, lambda d: d[0] * d[2] + (d[1] - d[2]) * d[3]),
    "H": (4, lambda d: d[1] * d[2] + d[0] * d[3]),
}


def _section_area(deck: _Deck, card: str, pid: int, fields: list[bytes], where: str) -> float:
    """Area of a PBARL/PBEAML section (end A) in deck units."""
    stype = fields[3].strip().upper().decode("latin-1") if len(fields) > 3 else ""
    if stype not in _SECTIONS:
        raise Fem2TmmError(
            f"{where}: {card} {pid}: section type {stype!r} is not supported (area known for "
            f"{', '.join(_SECTIONS)}); give the area with a PBAR/PBEAM card, or set the part's 'area' in the case"
        )
    n, fn = _SECTIONS[stype]
    dims = [_scalar_real(f) for f in fields[8 : 8 + n]]
    if len(dims) < n or any(d is None or d <= 0 for d in dims):
        raise Fem2TmmError(f"{where}: {card} {pid} ({stype}) needs {n} positive dimensions DIM1..DIM{n}")
    area = float(fn(dims))
    if not area > 0:
        raise Fem2TmmError(f"{where}: {card} {pid} ({stype}): the dimensions give a non-positive area {area}")
    return area


def _ply_average(mats, plies, where: str):
    """Thickness-weighted conductivity (scalar or tensor), density and specific heat of a laminate
    (in-plane conduction of plies in parallel: k t = Σ kᵢ tᵢ; ρ c t = Σ ρᵢ cᵢ tᵢ)."""
    t = sum(th for _, th in plies)
    if any(mid not in mats for mid, _ in plies):
        return None, None, None, None
    ks = [mats[mid] for mid, _ in plies]
    if all(m["k"] is not None for m in ks):
        k, ten = sum(m["k"] * th for m, (_, th) in zip(ks, plies)) / t, None
    elif all(m["k"] is not None or m["tensor"] is not None for m in ks):
        iso = np.array([1.0, 0, 0, 1.0, 0, 1.0])
        ten = sum((m["tensor"] if m["tensor"] is not None else m["k"] * iso) * th for m, (_, th) in zip(ks, plies)) / t
        k = None
    else:
        k = ten = None
    rho = cp = None
    if all(m["rho"] is not None for m in ks):
        mass = sum(m["rho"] * th for m, (_, th) in zip(ks, plies))
        rho = mass / t
        if all(m["cp"] is not None for m in ks) and mass > 0:
            cp = sum(m["rho"] * m["cp"] * th for m, (_, th) in zip(ks, plies)) / mass
    return k, ten, rho, cp


def _laminates(deck: _Deck, used: dict[int, int]) -> dict[int, tuple[list, str]]:
    """PCOMP/PCOMPG PID -> (plies [(MID, T)], where) in deck units, for the used PIDs (LAM = SYM doubled)."""
    out = {}
    for card in ("PCOMP", "PCOMPG"):
        for seq, f in deck.records(card):
            where = deck.where(seq)
            pid = _scalar_int(f[0])
            if pid is None:
                raise Fem2TmmError(f"{where}: {card} PID {f[0].decode('latin-1')!r} is not an integer")
            if pid not in used:
                continue
            if pid in out:
                raise Fem2TmmError(f"property id {pid} is defined twice: {out[pid][1]} and {where}")
            lam = f[7].strip().upper() if len(f) > 7 else b""
            plies, mid, th = [], None, None
            step, off = (4, 0) if card == "PCOMP" else (8, 1)
            for j in range(8, len(f), step):
                block = f[j + off : j + off + 2]
                if len(block) < 2 or (not block[0] and not block[1]):
                    continue
                m = _scalar_int(block[0]) if block[0] else mid
                t = _scalar_real(block[1]) if block[1] else th
                if m is None or t is None or t <= 0:
                    raise Fem2TmmError(f"{where}: {card} {pid}: ply {len(plies) + 1} needs a MID and a positive T")
                plies.append((m, t))
                mid, th = m, t
            if not plies:
                raise Fem2TmmError(f"{where}: {card} {pid} has no plies")
            if lam == b"SYM":
                plies = plies + plies[::-1]
            elif lam not in (b"", b"MEM", b"BEND", b"SMEAR", b"SMCORE"):
                warnings.warn(f"{where}: {card} {pid}: LAM = {lam.decode('latin-1')} read as a plain ply list",
                              stacklevel=4)
            out[pid] = (plies, where)
    return out


def _properties(deck: _Deck, used: dict[int, int], factors: dict | None, scale: float,
                nastran95: set[int]) -> dict[str, PropertyData]:
    """``"PID n"`` -> PropertyData (SI) for the property ids in ``used`` (PID -> element dimension).

    ``nastran95``: PIDs of NASTRAN-95 solids (CHEXA1/2, CWEDGE) whose field is a material id; a solid PID
    with no PSOLID whose id is a material's is read the same way (NASTRAN-95 CTETRA).
    """
    spec = {"PID": (0, "i"), "MID": (1, "i"), "T": (2, "r")}
    tables = [(deck.table(c, spec, lenient=True), c, 2) for c in _SHELL_PROPS]
    tables.append((deck.table("PSOLID", {"PID": (0, "i"), "MID": (1, "i")}, lenient=True), "PSOLID", 3))
    line_spec = {"PID": (0, "i"), "MID": (1, "i"), "A": (2, "r")}
    for c in ("PBAR", "PBEAM", "PROD"):
        tables.append((deck.table(c, line_spec, lenient=True), c, 1))
    tables.append((deck.table("PTUBE", {"PID": (0, "i"), "MID": (1, "i"), "OD": (2, "r"), "T": (3, "r")},
                              lenient=True), "PTUBE", 1))
    used_pids = np.array(sorted(used), np.int64)
    for t, _, _ in tables:
        t.check(np.isin(t.val["PID"], used_pids) | t.blank["PID"])
        t.require("PID")
    sections = {}
    for c in ("PBARL", "PBEAML"):
        for seq, f in deck.records(c):
            pid = _scalar_int(f[0])
            if pid in used:
                sections[pid] = (c, _scalar_int(f[1]) if len(f) > 1 else None,
                                 _section_area(deck, c, pid, f, deck.where(seq)), deck.where(seq))
    laminates = _laminates(deck, used)
    pid_all = np.concatenate([t.val["PID"] for t, _, _ in tables] + [np.array(list(sections) + list(laminates), np.int64)])
    seq_all = np.concatenate([t.seq for t, _, _ in tables] + [np.zeros(len(sections) + len(laminates), np.int64)])
    _check_unique(pid_all, seq_all, "property id", deck)

    # rows: pid -> (card, dim, mid, thickness or area (deck units) or plies, where)
    rows: dict[int, tuple] = {}
    for t, card, dim in tables:
        for r in np.flatnonzero(np.isin(t.val["PID"], used_pids)):
            pid = int(t.val["PID"][r])
            mid = None if t.blank["MID"][r] else int(t.val["MID"][r])
            size = None
            if card == "PTUBE":
                od = float(t.val["OD"][r])
                th = od / 2 if t.blank["T"][r] else float(t.val["T"][r])
                size = np.pi * (od**2 - (od - 2 * th) ** 2) / 4
            elif "T" in t.val and not t.blank["T"][r]:
                size = float(t.val["T"][r])
            elif "A" in t.val and not t.blank["A"][r]:
                size = float(t.val["A"][r])
            rows[pid] = (card, dim, mid, size, t.where(r))
    for pid, (card, mid, area, where) in sections.items():
        rows[pid] = (card, 1, mid, area, where)
    for pid, (plies, where) in laminates.items():
        rows[pid] = ("PCOMP", 2, None, plies, where)
    mats_used = {r[2] for r in rows.values() if r[2] is not None}
    mats_used |= {m for r in rows.values() if r[0] == "PCOMP" for m, _ in r[3]}
    mats_used |= {pid for pid, dim in used.items() if dim == 3 and pid not in rows}
    mats = _materials(deck, mats_used)
    for pid, dim in used.items():
        if pid not in rows and (dim == 3 and (pid in nastran95 or pid in mats)):
            rows[pid] = ("MID", 3, pid, None, "NASTRAN-95 solid: material id in the element card")

    out: dict[str, PropertyData] = {}
    missing: list[str] = []
    dropped = False
    for pid, (card, dim, mid, size, where) in rows.items():
        if used[pid] != dim:
            word = {1: "line", 2: "shell", 3: "solid"}
            raise Fem2TmmError(
                f"{where}: {card} {pid} is used by {word[used[pid]]} elements; a {card} is for {word[dim]} elements"
            )
        thick = area = None
        k = ten = rho = cp = None
        if card == "PCOMP":
            thick = sum(th for _, th in size) * scale
            vals = _ply_average(mats, size, where)
            if vals[0] is None and vals[1] is None:
                missing.extend(f"MID {m} (PID {pid})" for m, _ in size if m not in mats)
        else:
            if size is not None:
                if dim == 2:
                    thick = size * scale
                elif dim == 1:
                    area = size * scale**2
            vals = (None, None, None, None)
            if mid is not None:
                if mid not in mats:
                    missing.append(f"MID {mid} (PID {pid})")
                else:
                    m = mats[mid]
                    vals = (m["k"], m["tensor"], m["rho"], m["cp"])
        if factors is None:
            dropped = dropped or any(v is not None for v in vals)
        else:
            f = factors
            k = None if vals[0] is None else vals[0] * f["conductivity"]
            ten = None if vals[1] is None else tuple(float(x) for x in np.asarray(vals[1]) * f["conductivity"])
            rho = None if vals[2] is None else vals[2] * f["density"]
            cp = None if vals[3] is None else vals[3] * f["specific_heat"]
        out[f"PID {pid}"] = PropertyData(thickness=thick, conductivity=k, density=rho, specific_heat=cp,
                                         material_id=mid, conductivity_tensor=ten, area=area,
                                         card=card if card != "MID" else "NASTRAN-95 MID")
    if missing:
        warnings.warn(
            f"{deck.files[0]}: properties reference materials with no MAT4/MAT5/MAT1 card: {', '.join(missing)}; "
            "their conductivity, density and specific heat must come from the case file",
            stacklevel=3,
        )
    if dropped:
        warnings.warn(
            f"{deck.files[0]}: material values (MAT4/MAT5/MAT1) cannot be interpreted without a unit system "
            "(only length units 'm' = SI and 'mm' = mm-tonne-s imply one); they are ignored: set [mesh] "
            "unit_system, or give conductivity, density and specific_heat in the case file",
            stacklevel=3,
        )
    return out
