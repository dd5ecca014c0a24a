"""The Nastran reader: :func:`read_nastran` puts the deck's tokens, bulk cards, properties, joints and loads
together into a :class:`~fem2tmm.mesh.Mesh` (see :mod:`fem2tmm.io.nastran`).
"""

from __future__ import annotations

import warnings
from collections import Counter
from pathlib import Path

import numpy as np

from ...errors import Fem2TmmError
from ...mesh import ElementBlock, Mesh, PropertyData, unique_ints
from ...mesh.elements import DIM, ELEMENT_TYPES
from ..units import UNIT_SYSTEMS, length_scale, unit_system_name
from .deck import _Deck, _LOAD_CARDS, is_structural
from .geometry import (_Grids, _bad_ids, _check_midside, _check_unique, _coordinate_systems, _elements, _grids, _lookup,
                       _midside_offset, _pid_groups)
from .properties import _deck_units, _materials, _properties
from .joints import _joints


def read_nastran(path, unit: str = "m", unit_system: str | None = None, temperature_unit: str | None = None,
                 loads: bool | tuple[str, ...] = False, ignore_cards=(), strict: bool = True,
                 load_set: int | None = None, spc_set: int | None = None) -> Mesh:
    """Read a Nastran bulk data deck into a :class:`~fem2tmm.mesh.Mesh`.

    Parameters
    ----------
    path : str or Path
        The deck (any name).  INCLUDEd files are searched relative to the including file, then the top
        deck's folder, then the working directory.
    unit : str
        Length unit of the deck (``m``, ``cm``, ``mm``, ``um``, ``in``, ``ft``).
    unit_system : str or None
        Unit system of the material and load values (:data:`fem2tmm.io.units.UNIT_SYSTEMS`); None: implied
        by ``unit`` (``m`` SI, ``mm`` mm-tonne-s, others undefined: material values are dropped).
    temperature_unit : "K", "C", "F", "R" or None
        Temperature scale of the deck (per-degree material values, SPC/TEMP values).
    loads : bool or tuple of card names
        Read the deck's thermal boundary conditions (all, or only these cards) into ``Mesh.loads``.
    ignore_cards : card names
        Structural cards fem2tmm does not model that the user drops explicitly.
    strict : bool
        Refuse unmodelled structural cards (one error listing them); False lists them in
        ``Mesh.cards["refused"]`` instead (``fem2tmm inspect``).
    load_set, spc_set : int or None
        The load / SPC set id to read when the deck has several.

    Returns
    -------
    Mesh
        ``points`` (n, 3) float64 in metres, in GRID file order; ``node_ids`` (n,) GRID ids; one block per
        element type with the original element ids; groups ``"PID <n>"`` (``"CONROD MID <m>"``);
        ``properties``; ``section_area`` of line elements; ``midside``; ``joints``; ``cards``; ``loads``.

    Raises
    ------
    Fem2TmmError
        Unreadable file or INCLUDE (every place tried named), include cycle, malformed field of a used card
        (file and line named), duplicate ids, undefined or cyclic coordinate systems, elements referencing
        missing GRIDs, unsupported PBARL section types, unmodelled structural cards (``strict``), property
        cards used by the wrong kind of element, a deck with no supported element.
    """
    path = Path(path)
    if unit_system is not None:
        us = unit_system_name(unit_system, where=f"{path}: unit_system")
        scale = UNIT_SYSTEMS[us][0]
    else:
        scale = length_scale(unit, where=f"{path}: unit")
    factors = _deck_units(unit, unit_system, temperature_unit, str(path))
    deck = _Deck()
    deck.read(path, top=True)
    source = str(path)

    # cards: refused (structural, not modelled), ignored (everything else unread)
    ignore = {str(c).upper() for c in ignore_cards}
    load_cards = set(_LOAD_CARDS) if loads is True else ({c.upper() for c in loads} if loads else set())
    unread = Counter(deck.unknown)
    support = {"CHBDY", "CHBDYG", "CHBDYE", "CHBDYP", "PHBDY", "RADM"}  # read when any load card is
    for c in _LOAD_CARDS:
        n = deck.count(c)
        if n and not (load_cards and (c in load_cards or c in support)):
            unread[c] += n
    refused = {c: n for c, n in unread.items() if is_structural(c) and c not in ignore}
    ignored = {c: n for c, n in unread.items() if c not in refused}
    if refused and strict:
        listed = ", ".join(f"{c} ({n})" for c, n in sorted(refused.items(), key=lambda kv: (-kv[1], kv[0])))
        names = ", ".join(f'"{c}"' for c in sorted(refused))
        raise Fem2TmmError(
            f"{source}: structural cards that fem2tmm does not model: {listed}; they connect GRIDs, so the "
            f"thermal model would silently lose those connections. To drop them explicitly set "
            f"[mesh] ignore_cards = [{names}] in the case file"
        )

    systems = _coordinate_systems(deck)
    gid, x, gtab = _grids(deck, systems)
    _bad_ids(gid, "GRID", gtab.where)
    _check_unique(gid, gtab.seq, "GRID", deck)
    grids = _Grids(gid)

    per_type, midside, conrod, counts, n95 = _elements(deck, grids, source)
    joints, jcounts = _joints(deck, grids)
    counts.update(jcounts)

    blocks, pids, dims, line_cards = [], [], [], []
    for etype in ELEMENT_TYPES:
        if per_type[etype]:
            eid = np.concatenate([p[0] for p in per_type[etype]])
            pid = np.concatenate([p[1] for p in per_type[etype]])
            cells = np.concatenate([p[2] for p in per_type[etype]])
            blocks.append(ElementBlock(etype, cells.astype(np.int64), eid.astype(np.int64)))
            pids.append(pid)
            dims.append(np.full(len(eid), DIM[etype], np.int8))
    groups, used = _pid_groups(blocks, pids, dims, len(gid), source)
    used_pid = {p: d for p, d in used.items() if p > 0}
    properties = _properties(deck, used_pid, factors, scale, n95)

    # CONROD: a material group per MID, the area per element
    section_area = None
    if any(b.type == "line2" for b in blocks):
        allpid = np.concatenate(pids)
        section_area = np.full(len(allpid), np.nan)
        for name, grp in groups.items():
            pdata = properties.get(name)
            if pdata is not None and pdata.area is not None:
                section_area[grp.elements] = pdata.area
        if conrod is not None:
            eids = np.concatenate([b.ids for b in blocks])
            ceid, cmid, carea = conrod
            pos = np.flatnonzero(allpid < 0)
            section_area[pos] = _lookup(ceid, carea, eids[pos]) * scale**2
            mats = _materials(deck, set(int(m) for m in cmid))
            for m in unique_ints(cmid):
                mat = mats.get(int(m))
                f = factors
                properties[f"CONROD MID {int(m)}"] = PropertyData(
                    conductivity=None if (mat is None or mat["k"] is None or f is None) else mat["k"] * f["conductivity"],
                    conductivity_tensor=None if (mat is None or mat["tensor"] is None or f is None)
                    else tuple(float(v) for v in mat["tensor"] * f["conductivity"]),
                    density=None if (mat is None or mat["rho"] is None or f is None) else mat["rho"] * f["density"],
                    specific_heat=None if (mat is None or mat["cp"] is None or f is None)
                    else mat["cp"] * f["specific_heat"],
                    material_id=int(m), card="CONROD")

    ms = _check_midside(midside, blocks, joints, gid, source)
    if len(ms):
        quad = {c.split(" ")[0]: n for c, n in counts.items() if c.endswith("(quadratic)")}
        off = _midside_offset(x * scale, ms)
        warnings.warn(
            f"{source}: quadratic elements ({', '.join(f'{c} {n}' for c, n in quad.items())}) are modelled by their "
            f"corner nodes; their {len(ms)} mid-side GRIDs take the mean temperature of the edge ends in the outputs"
            + (f"; mid-side nodes lie up to {off:.3g} of the edge length off the straight edge (curved edges are "
               "straightened: areas and volumes are approximate)" if off > 1e-9 else ""),
            stacklevel=2,
        )
    if ignored:
        listed = ", ".join(f"{n} ({c})" for n, c in sorted(ignored.items(), key=lambda kv: (-kv[1], kv[0])))
        warnings.warn(f"{source}: ignored non-structural cards (listed in summary.json mesh.ignored_cards): {listed}",
                      stacklevel=2)
    deck_loads = None
    if load_cards:
        from .loads import read_loads

        deck_loads = read_loads(deck, grids, blocks, x * scale, load_cards, factors, temperature_unit,
                                load_set, spc_set, source)
    cards = {"modelled": dict(counts), "ignored": dict(ignored), "refused": dict(refused)}
    mesh = Mesh(
        points=x * scale,
        blocks=tuple(blocks),
        groups=groups,
        node_ids=gid.astype(np.int64),
        source=source,
        properties=properties,
        section_area=section_area,
        midside=ms if len(ms) else None,
        joints=tuple(joints),
        cards=cards,
        loads=deck_loads,
    )
    return mesh
