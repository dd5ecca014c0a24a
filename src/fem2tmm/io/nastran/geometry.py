"""Nastran bulk cards of the geometry: coordinate systems, GRIDs, elements (mid-side nodes) and the property
groups (see :mod:`fem2tmm.io.nastran`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ...errors import Fem2TmmError, format_ids
from ...mesh import Group, unique_ints
from ...mesh.elements import ELEMENT_TYPES, MIDSIDE_EDGES
from .deck import _CORDS, _CORD_FIELDS, _Deck, _ELEMENTS, _Table


def _cartesian(kind: str, x: np.ndarray) -> np.ndarray:
    """Local Cartesian coordinates (k, 3) of positions ``x`` (k, 3) given in a system of ``kind``.

    R: (x, y, z); C: (r, theta deg, z); S: (r, theta deg from the z axis, phi deg azimuth).
    """
    if kind == "R":
        return x
    r = x[:, 0]
    t = np.radians(x[:, 1])
    if kind == "C":
        return np.stack([r * np.cos(t), r * np.sin(t), x[:, 2]], axis=1)
    p = np.radians(x[:, 2])
    return np.stack([r * np.sin(t) * np.cos(p), r * np.sin(t) * np.sin(p), r * np.cos(t)], axis=1)


def _coordinate_systems(deck: _Deck) -> dict[int, tuple[str, np.ndarray, np.ndarray]]:
    """CID -> (kind, origin (3,), rows ex, ey, ez (3, 3)) in the basic system, deck length units."""
    spec = {"CID": (0, "i"), "RID": (1, "i")}
    spec.update({name: (2 + j, "r") for j, name in enumerate(_CORD_FIELDS)})
    cards: dict[int, tuple[str, int, np.ndarray, str]] = {}
    for card, kind in _CORDS.items():
        t = deck.table(card, spec)
        t.require("CID")  # blank A, B, C coordinates are 0.0
        rid = t.get("RID", 0)
        pts = np.stack([t.val[name] for name in _CORD_FIELDS], axis=1).reshape(-1, 3, 3)
        for r in range(len(t)):
            cid = int(t.val["CID"][r])
            if cid <= 0:
                raise Fem2TmmError(f"{t.where(r)}: {card} id must be a positive integer, got {cid}")
            if cid in cards:
                raise Fem2TmmError(
                    f"coordinate system {cid} is defined twice: {cards[cid][3]} and {t.where(r)}"
                )
            cards[cid] = (kind, int(rid[r]), pts[r], t.where(r))
    systems: dict[int, tuple[str, np.ndarray, np.ndarray]] = {0: ("R", np.zeros(3), np.eye(3))}
    for cid in cards:
        path = []
        c = cid
        while c not in systems:  # walk up the reference chain to a resolved system
            if c in path:
                chain = " -> ".join(str(x) for x in [*path[path.index(c) :], c])
                raise Fem2TmmError(
                    f"coordinate systems reference each other in a cycle: {chain} ({cards[c][3]})"
                )
            if c not in cards:
                child = path[-1]
                raise Fem2TmmError(
                    f"{cards[child][3]}: coordinate system {child} is defined in system {c}, which is not "
                    f"defined{_cord_hint(deck)}"
                )
            path.append(c)
            c = cards[c][1]
        for c in reversed(path):
            kind, rid, abc, where = cards[c]
            rkind, rorig, raxes = systems[rid]
            a, b, cc = rorig + _cartesian(rkind, abc) @ raxes
            ez = b - a
            lz = np.linalg.norm(ez)
            ac = cc - a
            if lz == 0.0 or np.linalg.norm(ac) == 0.0:
                raise Fem2TmmError(f"{where}: coordinate system {c}: points A, B, C must be distinct")
            ez = ez / lz
            ex = ac - (ac @ ez) * ez
            lx = np.linalg.norm(ex)
            if lx <= 1e-10 * np.linalg.norm(ac):
                raise Fem2TmmError(
                    f"{where}: coordinate system {c}: point C lies on the z axis through A and B; "
                    "it must define the xz plane"
                )
            ex = ex / lx
            systems[c] = (kind, a, np.stack([ex, np.cross(ez, ex), ez]))
    return systems


def _cord_hint(deck: _Deck) -> str:
    other = sorted(n for n in deck.unknown if n.startswith("CORD"))
    if not other:
        return ""
    return f" (this reader supports CORD2R/CORD2C/CORD2S only; the deck has {', '.join(other)} cards)"


def _grids(deck: _Deck, systems) -> tuple[np.ndarray, np.ndarray, "_Table"]:
    """GRID ids (n,) and basic coordinates (n, 3) in deck length units."""
    gs = deck.table("GRDSET", {"CP": (1, "i")})
    if len(gs) > 1:
        raise Fem2TmmError(f"more than one GRDSET card: {gs.where(0)} and {gs.where(1)}; keep one")
    cp_default = int(gs.get("CP", 0)[0]) if len(gs) else 0
    t = deck.table("GRID", {"ID": (0, "i"), "CP": (1, "i"), "X1": (2, "r"), "X2": (3, "r"), "X3": (4, "r")})
    t.require("ID")
    ids = t.val["ID"]
    cp = t.get("CP", cp_default)
    x = np.stack([t.val["X1"], t.val["X2"], t.val["X3"]], axis=1)  # blanks parse as 0.0 (default)
    for c in unique_ints(cp):
        c = int(c)
        if c == 0:
            continue
        sel = np.flatnonzero(cp == c)
        if c not in systems:
            raise Fem2TmmError(
                f"{t.where(sel[0])}: GRIDs {format_ids(ids[sel])} are given in coordinate system {c}, "
                f"which is not defined{_cord_hint(deck)}"
            )
        kind, orig, axes = systems[c]
        x[sel] = orig + _cartesian(kind, x[sel]) @ axes
    return ids, x, t


def _check_unique(ids: np.ndarray, seq: np.ndarray, what: str, deck: _Deck) -> None:
    """Error naming the first duplicated id and its first two locations (cards ``seq``)."""
    if len(ids) < 2:
        return
    order = np.lexsort((seq, ids))
    s = ids[order]
    dup = np.flatnonzero(s[1:] == s[:-1])
    if len(dup):
        r0, r1 = order[dup[0]], order[dup[0] + 1]
        n_dup = len(unique_ints(s[dup]))
        raise Fem2TmmError(
            f"{what} {int(s[dup[0]])} is defined twice: {deck.where(int(seq[r0]))} and {deck.where(int(seq[r1]))}"
            + (f"; {n_dup} ids are duplicated: {format_ids(unique_ints(s[dup]))}" if n_dup > 1 else "")
            + "; ids must be unique"
        )


def _bad_ids(ids: np.ndarray, what: str, where) -> None:
    bad = np.flatnonzero(ids <= 0)
    if len(bad):
        raise Fem2TmmError(f"{where(bad[0])}: {what} ids must be positive integers: {format_ids(ids[bad])}")


class _Grids:
    """GRID id -> mesh node index lookups with one error naming the missing ids."""

    def __init__(self, gid: np.ndarray):
        self.gid = gid
        self.order = np.argsort(gid, kind="stable")
        self.sorted = gid[self.order]

    def find(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(index (same shape), found (bool, same shape))."""
        ids = np.asarray(ids, np.int64)
        if not len(self.gid):
            return np.zeros(ids.shape, np.int64), np.zeros(ids.shape, bool)
        pos = np.minimum(np.searchsorted(self.sorted, ids), len(self.gid) - 1)
        return self.order[pos], self.sorted[pos] == ids

    def index(self, ids, what: str) -> np.ndarray:
        idx, ok = self.find(ids)
        if not ok.all():
            raise Fem2TmmError(f"{what} reference GRIDs {format_ids(unique_ints(np.asarray(ids)[~ok]))} that are "
                               "not defined")
        return idx


def _elements(deck: _Deck, grids: _Grids, source: str):
    """Element cards -> per fem2tmm type lists of (eid, group key, cells, card name); the mid-side rows
    (k, 3) of quadratic elements; CONROD (eid, mid, area) rows; NASTRAN-95 material-id group keys."""
    per_type: dict[str, list] = {t: [] for t in ELEMENT_TYPES}
    all_eids, all_seqs = [], []
    missing_el, missing_gr, missing_seq = [], [], []
    midside, counts, n95 = [], Counter(), set()
    for card, (etype, k, nmid, pmode) in _ELEMENTS.items():
        spec = {"EID": (0, "i"), "PID": (1, "i")}
        spec.update({f"G{j + 1}": (2 + j, "i") for j in range(k + nmid)})
        t = deck.table(card, spec)
        if not len(t):
            continue
        counts[card] = len(t)
        t.require("EID", *(f"G{j + 1}" for j in range(k)))
        eid = t.val["EID"]
        if pmode == "P":
            pid = t.get("PID", eid)  # Nastran: PID defaults to EID
        else:
            t.require("PID")
            pid = t.val["PID"]
            if pmode == "M":
                n95.update(int(p) for p in unique_ints(pid))
        _bad_ids(eid, card, t.where)
        g = np.stack([t.val[f"G{j + 1}"] for j in range(k)], axis=1)
        cells, found = grids.find(g)
        gm = np.stack([t.val[f"G{k + j + 1}"] for j in range(nmid)], axis=1) if nmid else np.zeros((len(t), 0), np.int64)
        has_m = ~np.stack([t.blank[f"G{k + j + 1}"] for j in range(nmid)], axis=1) if nmid else gm.astype(bool)
        mcells, mfound = grids.find(gm)
        mfound |= ~has_m
        if not (found.all() and mfound.all()):
            rows = np.flatnonzero(~(found.all(axis=1) & mfound.all(axis=1)))
            missing_el.append(eid[rows])
            missing_gr.append(np.concatenate([g[~found], gm[~mfound]]))
            missing_seq.append(t.seq[rows[0]])
        if has_m.any():
            edges = np.array(MIDSIDE_EDGES[etype])
            r, j = np.nonzero(has_m)
            midside.append(np.stack([mcells[r, j], cells[r, edges[j, 0]], cells[r, edges[j, 1]]], axis=1))
            counts[f"{card} (quadratic)"] = int(has_m.any(axis=1).sum())
        per_type[etype].append((eid, pid, cells, card))
        all_eids.append(eid)
        all_seqs.append(t.seq)
    t = deck.table("CONROD", {"EID": (0, "i"), "G1": (1, "i"), "G2": (2, "i"), "MID": (3, "i"), "A": (4, "r")})
    conrod = None
    if len(t):
        counts["CONROD"] = len(t)
        t.require("EID", "G1", "G2", "MID", "A")
        eid = t.val["EID"]
        _bad_ids(eid, "CONROD", t.where)
        g = np.stack([t.val["G1"], t.val["G2"]], axis=1)
        cells, found = grids.find(g)
        if not found.all():
            rows = np.flatnonzero(~found.all(axis=1))
            missing_el.append(eid[rows])
            missing_gr.append(g[~found])
            missing_seq.append(t.seq[rows[0]])
        # group key of a CONROD: minus its material id ("CONROD MID m")
        per_type["line2"].append((eid, -t.val["MID"], cells, "CONROD"))
        conrod = (eid, t.val["MID"], t.val["A"])
        all_eids.append(eid)
        all_seqs.append(t.seq)
    if missing_el:
        raise Fem2TmmError(
            f"{source}: elements {format_ids(unique_ints(np.concatenate(missing_el)))} reference GRIDs "
            f"{format_ids(unique_ints(np.concatenate(missing_gr)))} that are not defined "
            f"(first at {deck.where(int(min(missing_seq)))})"
        )
    if all_eids:
        _check_unique(np.concatenate(all_eids), np.concatenate(all_seqs), "element id", deck)
    ms = np.concatenate(midside) if midside else np.zeros((0, 3), np.int64)
    return per_type, ms, conrod, counts, n95


def _lookup(keys: np.ndarray, values: np.ndarray, query: np.ndarray) -> np.ndarray:
    order = np.argsort(keys, kind="stable")
    return values[order[np.searchsorted(keys[order], query)]]


def _check_midside(ms: np.ndarray, blocks, joints, gid: np.ndarray, source: str) -> np.ndarray:
    """Unique mid-side rows; an error for mid-side GRIDs that are also corner nodes of other elements (bars
    included; joints may reach mid-side GRIDs: the model expresses them through the edge ends)."""
    if not len(ms):
        return ms
    _, first = np.unique(ms[:, 0], return_index=True)
    ms = ms[np.sort(first)]
    corner = np.zeros(len(gid), bool)
    for b in blocks:
        corner[b.cells.ravel()] = True
    clash = ms[corner[ms[:, 0]], 0]
    if len(clash):
        raise Fem2TmmError(
            f"{source}: GRIDs {format_ids(gid[clash])} are mid-side nodes of quadratic elements and also corner "
            "nodes of other elements (bars, linear elements); fem2tmm models quadratic elements by their corner "
            "nodes, so connect those elements to corner nodes"
        )
    return ms


def _midside_offset(points: np.ndarray, ms: np.ndarray) -> float:
    """Largest distance of a mid-side node from its edge midpoint, relative to the edge length."""
    mid = 0.5 * (points[ms[:, 1]] + points[ms[:, 2]])
    L = np.linalg.norm(points[ms[:, 2]] - points[ms[:, 1]], axis=1)
    return float((np.linalg.norm(points[ms[:, 0]] - mid, axis=1) / np.where(L > 0, L, 1.0)).max())


def _pid_groups(blocks, pids, dims, n_nodes: int, source: str):
    """Groups ``"PID n"`` (``"CONROD MID m"`` for negative keys -m) and key -> dimension, without a loop over
    elements."""
    if not blocks:
        return {}, {}
    pid = np.concatenate(pids)
    dim = np.concatenate(dims)
    el_order = np.argsort(pid, kind="stable")  # elements of each PID, ascending within it
    sp = pid[el_order]
    first = np.ones(len(sp), bool)
    np.not_equal(sp[1:], sp[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    upid = sp[starts]
    el_bounds = np.append(starts, len(sp))
    rank = np.empty(len(pid), np.int64)
    rank[el_order] = np.cumsum(first) - 1
    dmin = np.minimum.reduceat(dim[el_order], starts)
    dmax = np.maximum.reduceat(dim[el_order], starts)
    mixed = np.flatnonzero(dmin != dmax)
    if len(mixed):
        raise Fem2TmmError(
            f"{source}: property ids {format_ids(upid[mixed])} are used by elements of different kinds (bars, "
            "shells, solids); give each kind its own PIDs"
        )
    # node lists: unique (PID rank, node) pairs over every element corner
    offs = np.cumsum([0] + [len(b.cells) for b in blocks])
    keys = unique_ints(
        np.concatenate([(rank[o : o + len(b.cells), None] * n_nodes + b.cells).ravel() for b, o in zip(blocks, offs)])
    )
    nd_bounds = np.searchsorted(keys // n_nodes, np.arange(len(upid) + 1))
    groups = {}
    used = {}
    for r, p in enumerate(upid):
        name = f"PID {int(p)}" if p > 0 else f"CONROD MID {-int(p)}"
        groups[name] = Group(
            name=name,
            dim=int(dmin[r]),
            elements=el_order[el_bounds[r] : el_bounds[r + 1]].astype(np.int64),
            nodes=keys[nd_bounds[r] : nd_bounds[r + 1]] % n_nodes,
        )
        used[int(p)] = int(dmin[r])
    return groups, used
