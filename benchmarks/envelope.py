"""``fem2tmm bench envelope``: the network handed over, measured over an envelope of load cases (issue 29).

examples/composite (k = 5 W/(m K) panels on a held deck, a heater, deep space; ``ir_on = "faces"``) as one case
file with five cases: nominal (heater 30 W, sink -270 °C, deck 20 °C), heater 0 W, heater 60 W, sink -100 °C,
deck 0 °C.  For each number of super nodes on the panels:

- ``shared``: the default radiation-aware reduction, one network for the set (GL, GR, C identical in every case's
  deck, each case's loads and correction at its own state), every figure the *exported* network's (read back from
  reduced.npz and model.esatan, solved by fem2tmm.lpm, recovered with the recovery read from reduced.npz), against
  that case's detailed reference, with the reference's own noise;
- ``design_deck_edited``: the nominal case's deck used for another case by editing its named constants (HEATER,
  EDGE/DECK, the sink), as a user would beyond the case set: its correction load stays at the design state;
- ``thesis``: the thesis' reduction (state-independent network), exported and recovered likewise.

One JSON line per (super nodes, method, case): ``rms_K``, ``max_K``, ``reference_noise_rms_K``, ``seconds``.
"""

from __future__ import annotations

import dataclasses
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
FOLDER = REPO / "examples" / "composite"
CASES = [{"name": "nominal"},
         {"name": "heater_0W", "boundary": {"heater": {"value": 0.0}}},
         {"name": "heater_60W", "boundary": {"heater": {"value": 60.0}}},
         {"name": "sink_-100C", "environment": {"sink_temperature": -100.0}},
         {"name": "deck_0C", "boundary": {"deck": {"value": 0.0}}}]
N_SN = (30, 100, 300, 1000)


def as_thesis(raw: dict) -> dict:
    """A case table switched to the thesis' reduction (no radiation-aware reduction, IR uniform per super node)."""
    raw["reduction"] = {"radiation_aware": False}
    raw.get("radiation", {}).pop("ir_on", None)
    return raw


def timed_run(case):
    """``(result, wall seconds)`` of ``fem2tmm.run(case)``, its warnings silenced."""
    from fem2tmm.pipeline import run

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run(case)
    return res, time.perf_counter() - t0


def _case(n_sn: int, aware: bool, file: str = "case.toml", cases=CASES):
    from fem2tmm.case import Case

    raw = tomllib.loads((FOLDER / file).read_text())
    raw["parts"][0]["super_nodes"] = n_sn
    if cases:
        raw["cases"] = cases
    return Case.from_dict(raw if aware else as_thesis(raw), base_dir=FOLDER)


def _err(model, T, T_ref) -> tuple[float, float]:
    ok = model.node_dof >= 0
    e = (model.node_temperatures(T) - model.node_temperatures(T_ref))[ok]
    return float(np.sqrt(np.mean(e**2))), float(np.abs(e).max())


def _edited(design, case_result):
    """The design case's network with the other case's named constants, solved and recovered."""
    from fem2tmm.solve.steady import solve_steady
    from fem2tmm.stages import reduced_problem

    rm = design.reduced.network
    rec = design.reduced.recovery
    other = case_result.case
    values = {b.name: b.value for b in other.boundaries}
    Q = np.array(rm.Q, float)
    for name, v0, pat in zip(rec.load_names, rec.load_values, rec.load_q.toarray()):
        Q += (values[name] - v0) * rm.reduction.distribute(pat)
    T_fixed = np.array(rm.T_fixed, float)
    for i in np.flatnonzero(rm.fixed):
        if rm.names[i] in values:
            T_fixed[i] = values[rm.names[i]]
    sink = other.environment.sink_temperature
    edited = dataclasses.replace(rm, Q=Q, T_fixed=T_fixed, T_sink=sink)
    T_sn = solve_steady(reduced_problem(edited), T0=design.reduced.solution.T).T
    return rec.recover(T_sn, loads={n: values[n] for n in rec.load_names}, T_sink=sink, T0=design.reduced.T_recovered)


def bench_envelope(n_sn=N_SN) -> list[dict]:
    rows = []
    for n in n_sn:
        for aware in (True, False):
            multi, seconds = timed_run(_case(n, aware))
            method = "shared" if aware else "thesis"
            for name, r in multi.results.items():
                a = r.summary["accuracy"]
                rows.append({"bench": "envelope", "super_nodes": n, "method": method, "case": name,
                             "rms_K": a["rms_K"], "max_K": a["max_K"], "of": a["of"],
                             "in_process_rms_K": a["in_process"]["rms_K"],
                             "reference_noise_rms_K": a.get("reference_noise_rms_K"),
                             "deck_vs_in_process_K": r.summary["reduced"]["delivered"]["esatan_vs_in_process_K"],
                             "seconds_all_cases": round(seconds, 1)})
            if aware:
                design = multi.results["nominal"]
                for name, r in multi.results.items():
                    if name == "nominal":
                        continue
                    rms, mx = _err(r.model, _edited(design, r), r.detailed.solution.T)
                    rows.append({"bench": "envelope", "super_nodes": n, "method": "design_deck_edited", "case": name,
                                 "rms_K": rms, "max_K": mx,
                                 "reference_noise_rms_K": r.summary["accuracy"].get("reference_noise_rms_K")})
    return rows


def bench_envelope_orbit(n_sn=N_SN) -> list[dict]:
    """``fem2tmm bench envelope_orbit``: examples/composite/case_orbit.toml (the box on a 700 km, β 30° orbit,
    nadir, the periodic orbit transient after the orbit-average steady start), radiation-aware (the network
    linearised at the start, its correction frozen there: the deck a user runs) and the thesis' reduction, at each
    count: the transient's RMS / max over every FE node and output time against the detailed transient, the
    orbit-average steady error with its reference noise, and the wall times."""
    rows = []
    for n in n_sn:
        for aware in (True, False):
            res, seconds = timed_run(_case(n, aware, "case_orbit.toml", cases=None))
            s = res.summary
            tr, a = s["transient"], s["accuracy"]
            acc = tr.get("accuracy", {})
            rows.append({"bench": "envelope_orbit", "super_nodes": n,
                         "method": "radiation_aware" if aware else "thesis",
                         "transient_rms_K": acc.get("rms_K"), "transient_max_K": acc.get("max_K"),
                         "steady_rms_K": a["rms_K"], "steady_max_K": a["max_K"],
                         "reference_noise_rms_K": a.get("reference_noise_rms_K"),
                         "transient_reduced_s": tr["timings_s"]["reduced"] + tr["timings_s"]["recover"],
                         "transient_detailed_s": tr["timings_s"]["detailed"],
                         "seconds": round(seconds, 1)})
            print(rows[-1], flush=True)
    return rows
