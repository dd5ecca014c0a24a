"""The check that what a run hands over is what it measured (issue 29).

:func:`check_deliverable` writes the network a run hands over (:func:`fem2tmm.export.deliverable.write_network`)
into a scratch folder, reads it back with :mod:`fem2tmm.lpm` (the readers a user's deck goes through), solves it
with the network solver and recovers the FE field with the recovery read back from ``reduced.npz``
(:mod:`fem2tmm.reduce.exported`): ``summary.json`` ``accuracy`` is that field's error against the detailed
reference, ``accuracy.in_process`` the in-process model's.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from .export.deliverable import write_network
from .result import Result


def check_deliverable(result: Result, recover: bool = True, keep: dict | None = None) -> dict:
    """Write the network, read it back (``reduced.npz`` and ``model.esatan`` through :mod:`fem2tmm.lpm`), solve
    each with the network solver and recover the FE field with the recovery read from ``reduced.npz``.

    Returns ``{"T_sn": (n,) K from reduced.npz, "T_sn_esatan": (n,) K from the deck, "T": (n_dof,) K recovered
    (None without a recovery), "npz_vs_in_process_K", "esatan_vs_in_process_K": max |ΔT_SN| against the in-process
    network solution (a transient run: the deck's transient integrated as written, :func:`deck_transient`, against
    the in-process reduced transient at every output time; ``"esatan_compared"`` says which), "error" when the check
    could not run (its message)}``.  ``recover=False`` skips the recovery (a run without reference has no error to
    report).  ``keep``: a dict that receives what was read back, ``{"reduced": result.reduced, "text": the ESATAN
    deck's text, "recovery": the recovery of reduced.npz or None}``, for the validity range's check of the same
    network (:func:`fem2tmm.verify.verify_network` ``shared``), or None.
    """
    from .errors import Fem2TmmError

    try:
        return _check(result, recover, keep)
    except Fem2TmmError as exc:  # e.g. a 0 K sink, which the decks' boundary node cannot hold: say so, go on
        return {"T_sn": None, "T_sn_esatan": None, "T": None, "npz_vs_in_process_K": None,
                "esatan_vs_in_process_K": None, "error": str(exc)}


def _check(result: Result, recover: bool, keep: dict | None = None) -> dict:
    from .lpm.readers import read_network
    from .lpm.solve import solve_network
    from .reduce.exported import load

    rs = result.reduced.solution
    n = result.reduced.network.n
    with tempfile.TemporaryDirectory(prefix="fem2tmm-deliverable-") as tmp:
        folder = Path(tmp)
        write_network(folder, result, sinda=False)  # (what is read back: reduced.npz and the ESATAN deck)
        rm = result.reduced.network
        hot_T = rm.hot_spots.T if rm.hot_spots is not None else np.zeros(0)  # (its hot-spot nodes follow the n nodes)
        T_npz = solve_network(read_network(folder / "reduced.npz"), T0=np.r_[rs.T, hot_T, rm.T_sink]).T[:n]
        tr = result.transient
        if tr is not None and tr.reduced is not None:  # a transient deck: its transient, integrated as written
            T_deck = deck_transient(folder / "model.esatan", result)
            esatan_vs = None if T_deck is None else float(np.abs(T_deck - tr.reduced.T).max(initial=0.0))
            compared = "transient"
        else:
            net = read_network(folder / "model.esatan")
            T_deck = _by_label(net, solve_network(net, T0=None).T, result.reduced.network.names)
            esatan_vs = None if T_deck is None else float(np.abs(T_deck - rs.T).max(initial=0.0))
            compared = "steady"
        recovery = load(folder / "reduced.npz") if result.reduced.recovery is not None else None
        if keep is not None:
            keep.update(reduced=result.reduced, text=(folder / "model.esatan").read_text(encoding="utf-8"),
                        recovery=recovery)
    T = None
    if recovery is not None and recover:
        T = recovery.recover(T_npz, T0=result.reduced.T_recovered)
    return {"T_sn": T_npz, "T_sn_esatan": T_deck, "T": T,
            "npz_vs_in_process_K": float(np.abs(T_npz - rs.T).max(initial=0.0)),
            "esatan_vs_in_process_K": esatan_vs, "esatan_compared": compared}


def deck_transient(deck: Path, result: Result) -> np.ndarray | None:
    """(n_t, n_SN) K: the transient an ESATAN deck defines, integrated as written, at the run's output times, in the
    order of the network's names (None when a name is missing).

    The deck is read back once (:func:`~fem2tmm.lpm.esatan.read_esatan_in_time`): its GL, GR, C and initial
    temperatures, and its ``$VARIABLES1`` loads and boundary temperatures at every time of its ``$ARRAYS`` tables
    (linear in between, as ESATAN's INTRP1; periodic with TIMEND − TIMEO for a periodic run), then integrated by
    fem2tmm's transient solver with the run's settings: what the deck gives in a solver that integrates it the
    same way.
    """
    from .lpm.esatan import read_esatan_in_time
    from .lpm.network import LoadCase
    from .lpm.solve import steady_problem
    from .solve.transient import TransientProblem, solve_transient
    from .timefunc import Series, Table

    st = result.transient.settings
    net, bps, Q_t, T_t = read_esatan_in_time(deck, st.start, st.end)
    period = {"period": st.end - st.start, "start": st.start} if st.periodic else {}
    hats = tuple(Table(bps, np.eye(len(bps))[j], **period) for j in range(len(bps)))
    zero = np.zeros(net.n)
    # the deck's GR to the space node that follow each node's temperature (INTRP1 tables in $VARIABLES1) are read
    # as ESATAN integrates them, at every state (lpm.solve.steady_problem's g_table); read as their values at TIMEO
    # the periodic orbit plate's radiation-aware deck integrated 4.4e-4 K off the in-process transient
    at0 = steady_problem(net, LoadCase("TIMEO", zero, T_t[0]))
    sink = Table.constant(3.0)
    if at0.g_table is not None:  # the space node's temperature in time (its $VARIABLES1 table, if any)
        j = int(np.asarray(net.gr_tables[0][1]))
        sink = Table(bps, np.asarray(T_t)[:, j], **period)
    prob = TransientProblem(K=net.K(), C=net.C, Q=Series(zero, tuple(Q_t), hats), fixed=net.boundary,
                            T_fixed=Series(zero, tuple(T_t), hats), g_space=at0.g_space, T_sink=sink,
                            GR=at0.GR, faced=at0.faced, g_table=at0.g_table)
    init = result.case.transient.initial_temperature
    sol = solve_transient(prob, st, net.T if init == "steady" else init)
    out = _by_label(net, sol.T.T, result.reduced.network.names)
    return None if out is None else out.T


def _by_label(net, T: np.ndarray, names: np.ndarray) -> np.ndarray | None:
    """The deck's node temperatures in the order of the network's ``names`` (None when a name is missing)."""
    where = {str(lab).upper(): i for i, lab in enumerate(net.labels)}
    idx = [where.get(str(nm).upper()) for nm in names]
    if any(i is None for i in idx):
        return None
    return np.asarray(T)[idx]




__all__ = ["check_deliverable"]
