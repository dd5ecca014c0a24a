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


def check_deliverable(result: Result, recover: bool = True) -> dict:
    """Write the network, read it back (``reduced.npz`` and ``model.esatan`` through :mod:`fem2tmm.lpm`), solve
    each with the network solver and recover the FE field with the recovery read from ``reduced.npz``.

    Returns ``{"T_sn": (n,) K from reduced.npz, "T_sn_esatan": (n,) K from the deck, "T": (n_dof,) K recovered
    (None without a recovery), "npz_vs_in_process_K", "esatan_vs_in_process_K": max |ΔT_SN| against the in-process
    network solution, "error" when the check could not run (its message)}``.  ``recover=False`` skips the recovery (a run without reference has no error to report).
    """
    from .lpm.readers import read_network
    from .lpm.solve import solve_network
    from .reduce.exported import load

    from .errors import Fem2TmmError

    try:
        return _check(result, recover)
    except Fem2TmmError as exc:  # e.g. a 0 K sink, which the decks' boundary node cannot hold: say so, go on
        return {"T_sn": None, "T_sn_esatan": None, "T": None, "npz_vs_in_process_K": None,
                "esatan_vs_in_process_K": None, "error": str(exc)}


def _check(result: Result, recover: bool) -> dict:
    from .lpm.readers import read_network
    from .lpm.solve import solve_network
    from .reduce.exported import load

    rs = result.reduced_solution
    n = result.reduced.n
    with tempfile.TemporaryDirectory(prefix="fem2tmm-deliverable-") as tmp:
        folder = Path(tmp)
        write_network(folder, result)
        T_npz = solve_network(read_network(folder / "reduced.npz"), T0=np.r_[rs.T, result.reduced.T_sink]).T[:n]
        net = read_network(folder / "model.esatan")
        T_deck = _by_label(net, solve_network(net, T0=None).T, result.reduced.names)
        recovery = load(folder / "reduced.npz") if result.recovery is not None else None
    T = None
    if recovery is not None and recover:
        T = recovery.recover(T_npz, T0=result.T_recovered)
    return {"T_sn": T_npz, "T_sn_esatan": T_deck, "T": T,
            "npz_vs_in_process_K": float(np.abs(T_npz - rs.T).max(initial=0.0)),
            "esatan_vs_in_process_K": None if T_deck is None else float(np.abs(T_deck - rs.T).max(initial=0.0))}


def _by_label(net, T: np.ndarray, names: np.ndarray) -> np.ndarray | None:
    """The deck's node temperatures in the order of the network's ``names`` (None when a name is missing)."""
    where = {str(lab).upper(): i for i, lab in enumerate(net.labels)}
    idx = [where.get(str(nm).upper()) for nm in names]
    if any(i is None for i in idx):
        return None
    return np.asarray(T)[idx]




__all__ = ["check_deliverable"]
