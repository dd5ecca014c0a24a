"""The network handed over, and the check that it is the network measured.

:func:`write_network` writes what a thermal engineer takes away: ``reduced.npz`` (the network and, under
``recovery_*`` keys, everything the recovery needs: :mod:`fem2tmm.reduce.exported`), ``model.esatan`` and
``model.sinda``.  :func:`fem2tmm.handover.check_deliverable` writes the same files into a scratch folder, reads them back with
:mod:`fem2tmm.lpm` (the readers a user's deck goes through), solves them with the network solver and recovers the
FE field with the recovery read back from ``reduced.npz``: ``summary.json`` ``accuracy`` is that field's error
against the detailed reference, ``accuracy.in_process`` the in-process model's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import KELVIN
from ..reduce.supernodes import super_node_positions
from ..result import Result
from .esatan import Deck, constant_name, node_numbers, write_esatan
from .sinda import write_sinda
from .transient import deck_transient
from .validity import validity_arrays, validity_lines


def network_positions(result: Result) -> np.ndarray:
    """(n, 3) m position of each node of the reduced network (:func:`~fem2tmm.reduce.supernodes.
    super_node_positions`: a cluster's capacitance-weighted centroid), NaN where unknown."""
    rm = result.reduced.network
    sn = rm.supernodes
    if sn is None or sn.n_sn != rm.n:
        return np.full((rm.n, 3), np.nan)
    model = result.model
    shares = model.capacity_shares if model.capacity_shares is not None else model.volume_shares
    return super_node_positions(sn, rm.element_cluster, model.element_cells, shares, model.node_dof,
                                model.mesh.points)


def write_positions(path: Path, numbers: np.ndarray, positions: np.ndarray) -> None:
    """``nodes.csv``: ``node,x,y,z`` (m) of every node with a known position, node numbers as in the decks
    (what ``fem2tmm network reduce --coordinates`` reads)."""
    ok = np.isfinite(positions).all(axis=1)
    rows = [f"{int(k)},{x!r},{y!r},{z!r}\n" for k, (x, y, z) in zip(numbers[ok], positions[ok].tolist())]
    path.write_text("node,x,y,z\n" + "".join(rows), encoding="utf-8")


def network_arrays(result: Result) -> dict[str, np.ndarray]:
    """The arrays of ``reduced.npz`` (DESIGN §4.3 and §4.7): the network, its solution and its recovery;
    ``positions`` (n, 3) m the super nodes' positions (:func:`network_positions`)."""
    rm, rs = result.reduced.network, result.reduced.solution
    n = rm.n
    GR = np.zeros((n + 1, n + 1))
    if rm.GR is not None:
        GR[:n, :n] = rm.GR
    GR[:n, n] = GR[n, :n] = rm.g_space
    C = rm.C if rm.C is not None else np.full(n, np.nan)
    out = dict(names=rm.names.astype(str), numbers=deck_node_numbers(result), is_boundary=rm.fixed, C=C, K=rm.K,
               GR=GR, Q=rm.Q, T=rs.T - KELVIN,
               kind=rm.kind.astype(str), part=rm.part, T_sink=np.float64(rm.T_sink - KELVIN),
               positions=network_positions(result))
    if rm.hot_spots is not None:  # the loads' hot-spot nodes (arithmetic, GR to space only), after the n nodes
        hs = rm.hot_spots
        out.update(hot_spot_labels=np.array(hs.labels(), dtype=str), hot_spot_part=hs.part, hot_spot_Q=hs.Q,
                   hot_spot_GR=hs.g, hot_spot_T=hs.T - KELVIN)
    if rm.g_space_table is not None:  # GR to space (the last column of GR) as a function of each node's own T
        out["GR_space_table_T"], out["GR_space_table"] = (np.asarray(v, float) for v in rm.g_space_table)
    if result.reduced.recovery is not None:
        out.update(result.reduced.recovery.arrays())
    par = result.reduced.parametric
    if par is not None:  # [reduction] parametric: Q at another value of a constant = Q + the interpolated dQ
        out["parametric_names"] = np.array(par["names"], dtype=str)
        for k, (values, dQ) in enumerate(zip(par["values"], par["dQ"])):
            out[f"parametric_values_{k}"], out[f"parametric_dQ_{k}"] = np.asarray(values, float), np.asarray(dQ, float)
    out.update(validity_arrays(result.reduced.verified))  # the range it was verified over (fem2tmm.verify)
    return out


def deck_node_numbers(result: Result) -> np.ndarray:
    """(n,) the deck number of each node of the reduced network (as in ``model.esatan`` and ``model.sinda``: D1001 …,
    :func:`fem2tmm.export.esatan.node_numbers` shifted by ``[export] node_offset``)."""
    return node_numbers(deck_parts(result.reduced.network), len(result.model.parts))[0][:result.reduced.network.n] \
        + result.case.export.node_offset


def deck_parts(rm) -> np.ndarray:
    """(n + r,) the part of each deck node: the network's nodes, then its loads' hot-spot nodes (``rm.hot_spots``)."""
    hs = rm.hot_spots
    return np.asarray(rm.part, np.int64) if hs is None else np.r_[np.asarray(rm.part, np.int64), hs.part]


def _with_hot_spots(deck: Deck, rm, rec) -> Deck:
    """``deck`` with the loads' hot-spot nodes of ``rm`` appended (after the network's n nodes): diffusion nodes
    without capacitance (arithmetic), their share of each named load (its constant) as QI, a GR to space only."""
    import dataclasses

    hs = rm.hot_spots
    if hs is None:
        return deck
    n, r = rm.n, hs.n
    m = n + r

    def pad(a, fill=0.0):
        return np.r_[np.asarray(a, float), np.full(r, fill)]

    GL = np.zeros((m, m))
    GL[:n, :n] = deck.GL
    GR = np.zeros((m, m))
    GR[:n, :n] = deck.GR
    named = [str(x) for x in rec.load_names] if rec is not None else []
    load_terms = []
    fixed = np.asarray(rm.fixed, bool)
    for name, v, frac in deck.load_terms:  # (a load's share on a fixed node: its hot spot applies it)
        j = [k for k in range(r) if constant_name(str(hs.load[k])) == name]
        extra = np.zeros(r)
        extra[j] = hs.unit[j]
        load_terms.append((name, v, np.r_[np.where(fixed, 0.0, np.asarray(frac, float)), extra]))
    tables = deck.space_tables
    if tables is not None:  # a constant row: written as a plain GR
        x, y = tables
        x, y = np.asarray(x, float), np.asarray(y, float)
        xs = hs.T[:, None] * np.geomspace(0.8, 1.25, x.shape[1])[None, :]
        tables = (np.r_[x, xs], np.r_[y, np.repeat(hs.g[:, None], y.shape[1], 1)])
    tr = deck.transient
    if tr is not None:  # a named load's table carries its hot spot's share too
        loads = []
        for (pat, t, v), nm in zip(tr.loads, tr.load_names):
            extra = np.zeros(r)
            for k in range(r):
                if nm and constant_name(str(hs.load[k])) == nm and hs.load[k] in named:
                    b = rec.load_q[named.index(str(hs.load[k]))].toarray().ravel()
                    unit = float(np.sum(rm.reduction.distribute(b)[~np.asarray(rm.fixed, bool)]))
                    scale = float(np.sum(np.asarray(pat, float)[~np.asarray(rm.fixed, bool)])) / unit if unit else 0.0
                    extra[k] = hs.unit[k] * scale
            loads.append((np.r_[np.asarray(pat, float), extra], t, v))
        tabled = {nm for nm in tr.load_names if nm}
        base = None if tr.base is None else np.r_[np.asarray(tr.base, float),
                                                  np.where([constant_name(str(x)) in tabled for x in hs.load], 0.0, hs.Q)]
        tr = dataclasses.replace(tr, loads=tuple(loads), base=base)
    return dataclasses.replace(
        deck, labels=np.r_[np.asarray(deck.labels).astype(str), hs.labels()],
        boundary=np.r_[deck.boundary, np.zeros(r, bool)],
        T=np.r_[np.asarray(deck.T, float), hs.T], C=pad(deck.C), A=pad(deck.A),
        alp=pad(deck.alp), eps=pad(deck.eps), GL=GL, GR=GR, GR_space=np.r_[np.asarray(deck.GR_space, float), hs.g],
        Q=np.r_[np.asarray(deck.Q, float), hs.Q], load_terms=tuple(load_terms), space_tables=tables, transient=tr)


def surface_emissivity(result: Result) -> np.ndarray:
    """(n,) the emissivity of each super node's faces' active sides, area-weighted (0 for a node without a radiating
    side): the deck's ``EPS``, a surface property as an engineer reads it.  The network's radiation is in its GR;
    until 2026-12-07 EPS was the coupling to space over the area, which a radiation-aware network's effective
    emission took above 1 (29 of examples/fin's 51 nodes, up to 1.0018).  ``ALP`` stays 0: the absorbed solar is in
    the loads (docs/case-file.md)."""
    from ..reduce.network import face_owner

    rm, f = result.reduced.network, result.model.faces
    n = rm.n
    owner = face_owner(result.model, rm.supernodes, rm.element_cluster)
    ok = owner >= 0
    eps_area = (np.asarray(f.emissivity, float) * f.active).reshape(-1, 2).sum(axis=1) * f.area  # (f,) m², both sides
    total = np.bincount(owner[ok], weights=f.active_area[ok], minlength=n)[:n]
    emitted = np.bincount(owner[ok], weights=eps_area[ok], minlength=n)[:n]
    return np.divide(emitted, total, out=np.zeros(n), where=total > 0)


def network_deck(result: Result) -> Deck:
    """The ESATAN / SINDA deck of the reduced network."""
    rm, rs = result.reduced.network, result.reduced.solution
    n = rm.n
    numbers, space = node_numbers(deck_parts(rm), len(result.model.parts))
    ex = result.case.export
    numbers, space = numbers + ex.node_offset, space + ex.node_offset
    hot_numbers, numbers = numbers[n:], numbers[:n]
    load_terms = ()
    rec = result.reduced.recovery
    if rec is not None and len(rec.load_names):  # each named power / flux: its distribution Y'q per unit value
        pats = rec.load_q.toarray()
        load_terms = tuple((constant_name(nm), float(v), rm.reduction.distribute(p))
                           for nm, v, p in zip(rec.load_names, rec.load_values, pats))
    temps = {b.name for b in result.case.boundaries if b.kind == "temperature"}
    temperature_terms = {int(i): constant_name(rm.names[i]) for i in np.flatnonzero(rm.fixed) if rm.names[i] in temps}
    parametric_terms = ()
    par = result.reduced.parametric
    if par is not None:  # the correction load following the named constants (°C in the deck for temperatures)
        from ..reduce.radiative import parametric_weights

        terms = []
        for name, values, dQ in zip(par["names"], par["values"], par["dQ"]):
            x, W = parametric_weights(values, sink=name == "sink")
            celsius = name == "sink" or name in temps
            terms.append(("SINK" if name == "sink" else constant_name(name), x - (KELVIN if celsius else 0.0), W,
                          np.asarray(dQ, float)))
        parametric_terms = tuple(terms)
    transient = None
    if result.transient is not None:
        transient = deck_transient(result.transient)
    if transient is not None:  # the named constant of each load table, the initial state
        import dataclasses

        tabled = [constant_name(b.name) for b in result.case.boundaries if b.table is not None and b.kind != "temperature"]
        init = result.case.transient.initial_temperature
        transient = dataclasses.replace(transient, load_names=tuple(tabled[:len(transient.loads)]),
                                        initial=None if isinstance(init, str) else float(init))
    GL = -rm.K.copy()
    np.fill_diagonal(GL, 0.0)
    area = rm.area if rm.area is not None else np.zeros(n)
    eps = surface_emissivity(result)
    C = rm.C if rm.C is not None else np.zeros(n)
    deck = Deck(numbers=numbers, labels=rm.names, boundary=rm.fixed, T=rs.T, C=np.nan_to_num(C), A=area,
                alp=np.zeros(n), eps=eps, GL=GL, GR=np.zeros((n, n)) if rm.GR is None else rm.GR,
                GR_space=rm.g_space, Q=rm.Q, space=space, T_space=rm.T_sink,
                transient=transient,
                model_name=ex.model_name or Path(result.case.source).stem, load_terms=load_terms,
                temperature_terms=temperature_terms, parametric_terms=parametric_terms,
                validity=tuple(validity_lines(result.reduced.verified, result.reduced.choice)),
                space_tables=rm.g_space_table)
    if rm.hot_spots is None:
        return deck
    import dataclasses

    return dataclasses.replace(_with_hot_spots(deck, rm, rec), numbers=np.r_[numbers, hot_numbers])


def write_network(folder: Path, result: Result, sinda: bool = True) -> None:
    """``reduced.npz``, ``model.esatan``, ``nodes.csv`` (the decks' node positions) and (``sinda``) ``model.sinda``
    into ``folder``."""
    arrays = network_arrays(result)
    np.savez(folder / "reduced.npz", **arrays)
    deck = write_deck(folder, result)
    # (the network's nodes: the loads' hot-spot nodes that follow them have no place of their own)
    write_positions(folder / "nodes.csv", deck.numbers[:len(arrays["positions"])], arrays["positions"])
    if sinda:
        write_sinda(folder / "model.sinda", deck, submodel=deck.model_name)


def write_deck(folder: Path, result: Result) -> Deck:
    """``model.esatan`` alone into ``folder``, as :func:`write_network` writes it; returns the deck written."""
    deck = network_deck(result)
    write_esatan(folder / "model.esatan", deck, title=Path(result.case.source).stem)
    return deck


__all__ = ["deck_node_numbers", "network_arrays", "network_deck", "network_positions", "write_deck", "write_network",
           "write_positions"]
