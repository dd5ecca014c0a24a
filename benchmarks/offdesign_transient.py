"""``fem2tmm bench offdesign_transient``: the transient deck run outside fem2tmm (issue 41, acceptance 3).

The thin composite L-bracket of :mod:`benchmarks.offdesign` (one case, default settings, the detailed reference on)
with a transient: its heater steps 10 → 40 → 0 W (:data:`STEPS`), Crank–Nicolson, 20 s steps, output at every step,
starting from the steady state at 10 W.  The run writes ``model.esatan``; an independent reader and integrator
(``tests/deck_solver.py``: own code, no fem2tmm import) integrates that deck with the scheme and step it names, and its
super-node temperatures are recovered with the run's ``reduced.npz``, in time (``fem2tmm recover --in-time``: the
heat stored inside each super node integrated with the same scheme and step, the heater from the table the deck and
``reduced.npz`` carry) and, beside it, each output time on its own (quasi-static, ``fem2tmm recover`` without
``--in-time``).  The reference is the run's own detailed transient, same scheme and step.  RMS and max over every FE
node and every output time; beside it the in-process reduced transient (recovered by the run) and the thesis'
network.

One JSON line per (super nodes, method): ``deck_rms_K``, ``deck_max_K`` (the deck integrated outside, recovered in
time), ``deck_quasi_static_*``, ``run_rms_K``, ``run_max_K`` (the run's own reduced transient, recovered), ``*_at_s``
(when the worst error occurs), the run's wall time.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

#: the heater's table: (time s, W); linear between rows (20 s ramps)
STEPS = [[0.0, 10.0], [2000.0, 10.0], [2020.0, 40.0], [5000.0, 40.0], [5020.0, 0.0]]
#: the transient: end, step and output interval (s); Crank–Nicolson from the steady state at t = 0
TRANSIENT = {"end": 9000.0, "step": 20.0, "output_every": 20.0, "initial_temperature": "steady",
             "method": "crank-nicolson"}
N_SN = (100, 300)


def heater_at(t: np.ndarray) -> np.ndarray:
    """The heater's power (W) at times ``t`` (s): :data:`STEPS` interpolated linearly, held beyond its ends."""
    x, y = np.asarray(STEPS, float).T
    return np.interp(t, x, y)


def transient_rows(counts=N_SN, n: int = 60, thesis: bool = True) -> list[dict]:
    """The study (module docstring) at each super-node count of ``counts``."""
    from fem2tmm.constants import KELVIN
    from fem2tmm.errors import Fem2TmmError
    from fem2tmm.mesh import shapes
    from fem2tmm.pipeline import run
    from fem2tmm.reduce.exported import load

    from .offdesign import bracket_raw

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from deck_solver import read_esatan as read_independent
    from deck_solver import solve_esatan_transient

    from fem2tmm.case import Case

    mesh = shapes.bracket(n=n)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for N in counts:
            for method, th in [("default", False)] + ([("thesis", True)] if thesis else []):
                raw = bracket_raw(N, thesis=th)
                raw["boundary"][1]["value"] = STEPS
                raw["transient"] = dict(TRANSIENT)
                folder = Path(tmp) / f"{method}{N}"
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = run(Case.from_dict(raw, base_dir=Path.cwd()), mesh=mesh, out=folder)
                wall = time.perf_counter() - t0
                tr = res.transient
                model = res.model
                ok = model.node_dof >= 0
                T_ref = tr.detailed.T  # (n_t, n_dof) K

                def errors(T_dof):
                    e = np.stack([(model.node_temperatures(T_dof[i]) - model.node_temperatures(T_ref[i]))[ok]
                                  for i in range(len(tr.times))])
                    worst = np.unravel_index(np.argmax(np.abs(e)), e.shape)
                    return float(np.sqrt(np.mean(e**2))), float(np.abs(e).max()), float(tr.times[worst[0]])

                path = folder / "model.esatan"
                t1 = time.perf_counter()
                times, T_deck = solve_esatan_transient(path)
                deck_s = time.perf_counter() - t1
                if not np.allclose(times, tr.times):
                    raise AssertionError(f"the deck's output times {times[:3]}… differ from the run's {tr.times[:3]}…")
                m = read_independent(path)
                by = {str(lab).upper(): T_deck[int(k)] for lab, k in zip(m.labels, m.numbers)}
                rec = load(folder / "reduced.npz")
                T_sn = np.stack([by[str(x).upper()] for x in rec.names]) + KELVIN  # (n_sn, n_t)
                q = heater_at(times)
                T_qs = np.empty_like(T_ref)  # each output time on its own (quasi-static)
                for i in range(len(times)):
                    try:
                        T_qs[i] = rec.recover(T_sn[:, i], loads={"heater": q[i]},
                                              T0=None if i == 0 else T_qs[i - 1])
                    except Fem2TmmError:  # no quasi-static field at this time: counted as its linear recovery's
                        T_qs[i] = rec.recover(T_sn[:, i], loads={"heater": q[i]}, T0=T_qs[i - 1])
                q_s, q_max, q_at = errors(T_qs)
                # in time (fem2tmm recover --in-time): the deck's scheme and step, the heater's table
                T_rec = rec.recover_transient(T_sn, times, loads=lambda t: {"heater": float(heater_at(t))},
                                              step=TRANSIENT["step"], scheme=TRANSIENT["method"]).T
                d_rms, d_max, d_at = errors(T_rec)
                r_rms, r_max, r_at = errors(tr.T_recovered)
                rows.append({"bench": "offdesign_transient", "super_nodes": N, "method": method,
                             "deck_rms_K": round(d_rms, 3), "deck_max_K": round(d_max, 3), "deck_max_at_s": d_at,
                             "deck_quasi_static_rms_K": round(q_s, 3), "deck_quasi_static_max_K": round(q_max, 3),
                             "run_rms_K": round(r_rms, 3), "run_max_K": round(r_max, 3), "run_max_at_s": r_at,
                             "output_times": len(times), "scheme": TRANSIENT["method"], "step_s": TRANSIENT["step"],
                             "run_s": round(wall, 1), "deck_integration_s": round(deck_s, 1),
                             "goal": "300 SN: RMS <= 1.0 K, max <= 3.0 K over space and time (issue 41)"})
                print(rows[-1], flush=True)
    return rows


def bench_offdesign_transient() -> list[dict]:
    """``fem2tmm bench offdesign_transient``: the bracket's transient deck at 100 and 300 super nodes, the default
    network and the thesis'."""
    return transient_rows()
