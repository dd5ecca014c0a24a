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


def transient_rows(counts=N_SN, n: int = 60, thesis: bool = True, allocation: str | None = None) -> list[dict]:
    """The study (module docstring) at each super-node count of ``counts`` (``allocation``: ``[clustering]
    allocation``)."""
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
                raw = bracket_raw(N, thesis=th, allocation=allocation)
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
                             "allocation": allocation,
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


#: the super-node counts of ``fem2tmm bench offdesign_transient_forms``
FORMS_N_SN = (100, 300, 1000)


def linear_forms(rec, T_star: np.ndarray, times: np.ndarray, load: str = "heater", held: tuple = ("edge",)
                 ) -> list[dict]:
    """The transient of the bracket linearised about ``T_star``, reduced in several forms, against its own detailed
    solution: what a network's capacitance can carry.

    The detailed model: C T' + L T = q P(t) + b with L = K + diag(4σ e T*³) (the emission linearised about the design
    field; the IR exchange between the panels is left out in every form alike), the ``held`` super nodes' DOFs at
    their design temperature, :data:`STEPS` for P, Crank–Nicolson with the run's step.  Y (n_f, n_s) is the exact
    static condensation onto the super-node means (the saddle [[L, Aᵀ], [A, 0]] solved for each mean), x the heater's
    static correction (zero means, K-orthogonal to Y).  Each form's super-node means are then recovered in time exactly
    (the constrained detailed equations integrated with the means given, as ``fem2tmm recover --in-time`` does), so
    what differs is only the means' dynamics:

    - ``lumped``: C_SN = diag(Yᵀc) (the row sums: what a deck's diagonal C carries), loads Yᵀq: the network's form;
    - ``consistent``: the full YᵀCY (no diagonal deck can carry it);
    - ``enriched``: the basis [Y, x, x_b] with its full mass matrix (one extra DOF per load and for the constant
      load b: the heater's hot spot builds up and decays with its own inertia);
    - ``enriched, lumped C_SN``: the same with YᵀCY replaced by the lumped diagonal (the couplings to x kept);
    - ``lag τ``: the lumped network with the heater put where it is deposited (each cluster's share) and the rest of
      Yᵀq (the spreading the hot spot causes) through a first-order lag P_τ' = (P − P_τ)/τ, τ = m/k or 2m/k of x
      (m = xᵀCx, k = xᵀLx): a form a deck can carry (one extra node with C = τ G).

    Returns one dict per form: RMS / max K over every free DOF and output time, and when the max occurs.
    """
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    from fem2tmm.constants import SIGMA

    held = [list(rec.names).index(n) for n in held]  # the held super nodes (one DOF each)
    held_dofs = [int(rec.A[i].indices[0]) for i in held]
    free_sn = np.setdiff1d(np.arange(rec.n_sn), held)
    f = np.setdiff1d(np.arange(rec.n_dof), held_dofs)
    h = 4.0 * SIGMA * rec.e * T_star**3
    L = (rec.K + sp.diags(h)).tocsr()
    Cf = rec.C.diagonal()[f]
    q = np.asarray(rec.load_q[list(rec.load_names).index(load)].todense()).ravel()[f]
    b = h * T_star - SIGMA * rec.e * (T_star**4 - rec.T_sink**4)
    Lff = L[f][:, f].tocsc()
    bf = b[f] - (L[f][:, held_dofs] @ T_star[held_dofs] if held_dofs else 0.0)
    A = rec.A[free_sn][:, f].tocsr()
    ns, nf = len(free_sn), len(f)
    dt = float(times[1] - times[0])
    P = heater_at(times)

    def cn(M, K, forcing, x0):  # Crank–Nicolson over the output times (one step each)
        lhs = 2.0 / dt * M + K
        lu = sla.splu(sp.csc_matrix(lhs)) if sp.issparse(K) else None
        out, x = [x0], x0
        for i in range(1, len(times)):
            r = (2.0 / dt * M - K) @ x + forcing(i - 1) + forcing(i)
            x = lu.solve(r) if lu is not None else np.linalg.solve(lhs, r)
            out.append(x)
        return np.array(out)

    T0 = sla.spsolve(Lff, q * P[0] + bf)
    T_ref = cn(sp.diags(Cf), Lff, lambda i: q * P[i] + bf, T0)
    saddle = sla.splu(sp.bmat([[Lff, A.T], [A, None]]).tocsc())
    Y = saddle.solve(np.vstack([np.zeros((nf, ns)), np.eye(ns)]))[:nf]
    x = saddle.solve(np.concatenate([q, np.zeros(ns)]))[:nf]
    xb = saddle.solve(np.concatenate([bf, np.zeros(ns)]))[:nf]
    constrained = sla.splu(sp.bmat([[2.0 / dt * sp.diags(Cf) + Lff, A.T], [A, None]]).tocsc())

    def in_time(means):  # the field with these means, integrated with the same scheme and step
        T, out = T0, [T0]
        for i in range(1, len(times)):
            r = 2.0 / dt * Cf * T - Lff @ T + q * (P[i - 1] + P[i]) + 2.0 * bf
            T = constrained.solve(np.concatenate([r, means[i]]))[:nf]
            out.append(T)
        return np.array(out)

    def row(form, means):
        e = in_time(means) - T_ref
        worst = np.abs(e).max(axis=1)
        return {"form": form, "rms_K": round(float(np.sqrt(np.mean(e**2))), 3), "max_K": round(float(worst.max()), 2),
                "max_at_s": float(times[int(np.argmax(worst))])}

    Ksn = Y.T @ (Lff @ Y)
    C_lumped = Y.T @ Cf
    means0 = A @ T0
    rows = [row("lumped (the network's form)", cn(np.diag(C_lumped), Ksn, lambda i: Y.T @ (q * P[i] + bf), means0)),
            row("consistent YᵀCY", cn(Y.T @ (Cf[:, None] * Y), Ksn, lambda i: Y.T @ (q * P[i] + bf), means0))]
    B = np.hstack([Y, x[:, None], xb[:, None]])
    MB, KB = B.T @ (Cf[:, None] * B), B.T @ (Lff @ B)
    g0 = np.concatenate([means0, [P[0], 1.0]])
    rows.append(row("enriched [Y, x], consistent", cn(MB, KB, lambda i: B.T @ (q * P[i] + bf), g0) @ (A @ B).T))
    MB[:ns, :ns] = np.diag(C_lumped)
    rows.append(row("enriched [Y, x], lumped C_SN", cn(MB, KB, lambda i: B.T @ (q * P[i] + bf), g0) @ (A @ B).T))
    q_lumped = C_lumped * (A @ (q / Cf))  # each cluster's share of the heat where it is deposited
    spread = Y.T @ q - q_lumped
    m, k = x @ (Cf * x), x @ (Lff @ x)
    for name, tau in (("lag τ = m/k", m / k), ("lag τ = 2m/k", 2.0 * m / k)):
        M2 = np.zeros((ns + 1, ns + 1))
        M2[:ns, :ns], M2[ns, ns] = np.diag(C_lumped), tau
        K2 = np.zeros((ns + 1, ns + 1))
        K2[:ns, :ns], K2[:ns, ns], K2[ns, ns] = Ksn, -spread, 1.0
        g = cn(M2, K2, lambda i: np.concatenate([Y.T @ bf + q_lumped * P[i], [P[i]]]),
               np.concatenate([means0, [P[0]]]))
        rows.append(dict(row(name, g[:, :ns]), tau_s=round(float(tau), 1)))
    return rows


def bench_offdesign_transient_forms(counts=FORMS_N_SN, allocation: str | None = None) -> list[dict]:
    """``fem2tmm bench offdesign_transient_forms``: the bracket's transient (default settings; ``allocation`` its
    ``[clustering] allocation``) at each count, the run's own reduced transient against its detailed one, and beside
    it the same transient linearised about the design field in each form of :func:`linear_forms`: what the network's
    diagonal capacitance costs at the maximum, and which forms reach 3 K."""
    from fem2tmm.case import Case
    from fem2tmm.mesh import shapes
    from fem2tmm.pipeline import run

    from .offdesign import bracket_raw

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for N in counts:
            raw = bracket_raw(N, verify=False, allocation=allocation)
            raw["boundary"][1]["value"] = STEPS
            raw["transient"] = dict(TRANSIENT)
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = run(Case.from_dict(raw, base_dir=Path.cwd()), mesh=shapes.bracket(n=60),
                          out=Path(tmp) / f"n{N}")
            wall = time.perf_counter() - t0
            acc = res.transient.accuracy()
            rows.append({"bench": "offdesign_transient_forms", "super_nodes": N, "allocation": allocation,
                         "form": "the run's own transient",
                         "rms_K": round(acc["rms_K"], 3), "max_K": round(acc["max_K"], 2), "run_s": round(wall, 1)})
            print(rows[-1], flush=True)
            for r in linear_forms(res.reduced.recovery, res.detailed.solution.T, res.transient.times):
                rows.append({"bench": "offdesign_transient_forms", "super_nodes": N, "allocation": allocation,
                             "linearised": True, **r})
                print(rows[-1], flush=True)
    return rows


def bench_offdesign_transient_forms_loads() -> list[dict]:
    """``fem2tmm bench offdesign_transient_forms_loads``: :func:`bench_offdesign_transient_forms` with ``[clustering]
    allocation = "loads"`` at 300 and 100 super nodes: whether smaller super nodes at the heater, with or without the
    lag node a deck can carry, bring the diagonal capacitance's maximum to 3 K."""
    return bench_offdesign_transient_forms(counts=(300, 100), allocation="loads")
