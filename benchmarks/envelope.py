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


def timed_run(case, reference: bool | None = None):
    """``(result, wall seconds)`` of ``fem2tmm.run(case, reference=reference)``, its warnings silenced."""
    from fem2tmm.pipeline import run

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run(case, reference=reference)
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
    from fem2tmm.solve.problems import reduced_problem

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


#: ``fem2tmm bench envelope_parametric``: the states ``[reduction] parametric`` computes (one at a time about the
#: nominal case; the case file's units) and test states between and across them, never computed
PARAMETRIC = {"heater": [0.0, 15.0, 45.0, 60.0], "deck": [0.0], "sink": [-200.0, -100.0]}
PARAMETRIC_TEST = [("heater 7.5 W", 7.5, 20.0, -270.0), ("heater 52.5 W", 52.5, 20.0, -270.0),
                   ("cold: 0 W, deck 0 °C", 0.0, 0.0, -270.0), ("hot: 60 W, sink -100 °C", 60.0, 20.0, -100.0),
                   ("20 W, deck 10 °C, sink -200 °C", 20.0, 10.0, -200.0), ("sink -150 °C", 30.0, 20.0, -150.0)]


def edited_deck_error(out: Path, constants: dict, sink: float, reference) -> tuple[float, float]:
    """RMS / max error (K) of the deck in ``out`` with its named constants edited (``constants``: boundary name ->
    value in the case file's units; the ESATAN constant is the name in capitals) and the sink at ``sink`` °C, read
    back by fem2tmm.lpm, solved and recovered with the recovery of ``out/reduced.npz`` (each named load at its edited
    value, the others at the deck's), against the detailed field of ``reference`` (a run of that state): what a user
    who edits the deck receives."""
    import re

    from fem2tmm.lpm import read_esatan
    from fem2tmm.lpm.solve import solve_network
    from fem2tmm.reduce.exported import load

    text = (out / "model.esatan").read_text()
    edits = dict(constants) | ({"sink": sink} if "SINK = " in text else {})
    for name, v in edits.items():
        text, n = re.subn(rf"(?m)^(\s*{name.upper()} = )[^;]+;", rf"\g<1>{float(v)!r};", text)
        assert n == 1, name
    if "SINK = " not in text:  # a deck without the parametric sink: the space node's temperature
        text, n = re.subn(r"(?m)^(\s*B\d+ = 'SPACE', T = )[^;]+;", rf"\g<1>{float(sink)!r};", text)
        assert n == 1
    path = out / "edited.esatan"
    path.write_text(text)
    net = read_esatan(path)
    T = solve_network(net, T0=None).T
    rec = load(out / "reduced.npz")
    labels = [str(n).upper() for n in net.labels]
    T_sn = np.array([T[labels.index(str(n).upper())] for n in rec.names])
    loads = {n: float(constants.get(n, v)) for n, v in zip(rec.load_names, rec.load_values)}
    field = rec.recover(T_sn, loads=loads, T_sink=sink + 273.15)  # its default start, as `fem2tmm recover`
    return _err(reference.model, field, reference.detailed.solution.T)


def _deck_state_error(out: Path, state, reference) -> tuple[float, float]:
    """:func:`edited_deck_error` of a composite state (name, heater W, deck °C, sink °C)."""
    _, heater, deck, sink = state
    return edited_deck_error(out, {"heater": heater, "deck": deck}, sink, reference)


def bench_envelope_parametric(n_sn=(100, 300)) -> list[dict]:
    """``fem2tmm bench envelope_parametric``: the deck a user edits beyond the case set (issue 29, item 2: "a user
    changes a heater in ESATAN and gets what fem2tmm would give").

    examples/composite's nominal case run twice: as it is (the deck's correction load frozen at the design state)
    and with ``[reduction] parametric`` (:data:`PARAMETRIC`: the correction at those states, one named constant at a
    time, written into the deck as INTRP1 tables of HEATER, DECK and SINK).  Each deck is edited to test states
    fem2tmm never computed (:data:`PARAMETRIC_TEST`), read back through fem2tmm.lpm, solved and recovered with the
    recovery of reduced.npz, against that state's detailed reference (its own run, with the reference noise and the
    error of the state's own network for scale).  One JSON line per (super nodes, state).
    """
    import tempfile

    rows = []
    for n in n_sn:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            walls = {}
            for tag, par in (("frozen", None), ("parametric", PARAMETRIC)):
                raw = tomllib.loads((FOLDER / "case.toml").read_text())
                raw["parts"][0]["super_nodes"] = n
                if par is not None:
                    raw.setdefault("reduction", {})["parametric"] = par
                from fem2tmm.case import Case
                from fem2tmm.pipeline import run

                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    run(Case.from_dict(raw, base_dir=FOLDER), out=tmp / tag)
                walls[tag] = round(time.perf_counter() - t0, 1)
            cases = [{"name": f"s{i}", "boundary": {"heater": {"value": h}, "deck": {"value": d}},
                      "environment": {"sink_temperature": s}} for i, (_, h, d, s) in enumerate(PARAMETRIC_TEST)]
            multi, seconds = timed_run(_case(n, True, cases=cases))
            for i, state in enumerate(PARAMETRIC_TEST):
                ref = multi.results[f"s{i}"]
                row = {"bench": "envelope_parametric", "super_nodes": n, "state": state[0],
                       "own_network_rms_K": ref.summary["accuracy"]["rms_K"],
                       "reference_noise_rms_K": ref.summary["accuracy"].get("reference_noise_rms_K")}
                for tag in ("frozen", "parametric"):
                    row[f"{tag}_deck_rms_K"], row[f"{tag}_deck_max_K"] = _deck_state_error(tmp / tag, state, ref)
                row.update(design_run_s=walls, reference_runs_s=round(seconds, 1))
                rows.append(row)
    return rows


#: ``fem2tmm bench envelope_deck``: per example, its case file and the states a user edits its single-case deck to
#: (name, named constants in the case file's units, sink °C): each named load off, at 2x and 4x its value, a warm sink
#: and a colder held deck where the example has them
DECK_STATES = {
    "composite": ("case.toml", [("nominal", {"heater": 30.0, "deck": 20.0}, -270.0),
                                ("heater 0 W", {"heater": 0.0}, -270.0), ("heater 60 W", {"heater": 60.0}, -270.0),
                                ("heater 120 W", {"heater": 120.0}, -270.0), ("sink -100 °C", {}, -100.0),
                                ("deck 0 °C", {"deck": 0.0}, -270.0)]),
    "smallsat": ("case.toml", [("nominal", {}, -270.15), ("instrument 0 W", {"instrument_power": 0.0}, -270.15),
                               ("instrument 40 W", {"instrument_power": 40.0}, -270.15),
                               ("electronics 0 W", {"electronics_on_deck": 0.0}, -270.15),
                               ("electronics 60 W", {"electronics_on_deck": 60.0}, -270.15)]),
}


def bench_envelope_deck(examples=("composite", "smallsat")) -> list[dict]:
    """``fem2tmm bench envelope_deck``: each example as committed (one case, default settings, its super-node
    counts) and with the thesis' reduction, each deck edited to its :data:`DECK_STATES` as a user would (named
    constants, the space node's temperature), read back by fem2tmm.lpm, solved and recovered with its reduced.npz,
    against each state's own detailed reference (one run of the states as ``[[cases]]``, thesis' reduction, orbit
    average only: the same detailed model).  One JSON line per (example, state): ``default_rms_K``/``max_K``,
    ``thesis_rms_K``/``max_K``, ``default_better``, the reference noise."""
    import tempfile

    from fem2tmm.case import Case
    from fem2tmm.errors import Fem2TmmError
    from fem2tmm.pipeline import run

    rows = []
    for example in examples:
        folder = REPO / "examples" / example
        file, states = DECK_STATES[example]
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            walls = {}
            for tag, aware in (("default", True), ("thesis", False)):
                raw = tomllib.loads((folder / file).read_text())
                raw = raw if aware else as_thesis(raw)
                t0 = time.perf_counter()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    run(Case.from_dict(raw, base_dir=folder), out=tmp / tag)
                walls[tag] = round(time.perf_counter() - t0, 1)
            raw = as_thesis(tomllib.loads((folder / file).read_text()))
            if "orbit" in raw:
                raw["orbit"]["steady"] = "average"
            raw["cases"] = [{"name": f"s{i}", "boundary": {k: {"value": v} for k, v in c.items()},
                             "environment": {"sink_temperature": sink}} for i, (_, c, sink) in enumerate(states)]
            multi, seconds = timed_run(Case.from_dict(raw, base_dir=folder))
            for i, (name, constants, sink) in enumerate(states):
                ref = multi.results[f"s{i}"]
                row = {"bench": "envelope_deck", "example": example, "state": name,
                       "super_nodes": int(ref.summary["reduced"]["super_nodes"]) if "super_nodes" in ref.summary[
                           "reduced"] else None,
                       "reference_noise_rms_K": ref.summary["accuracy"].get("reference_noise_rms_K")}
                for tag in ("default", "thesis"):
                    try:
                        row[f"{tag}_rms_K"], row[f"{tag}_max_K"] = edited_deck_error(tmp / tag, constants, sink, ref)
                    except Fem2TmmError as e:  # what `fem2tmm recover` would tell the user: a row, not a crash
                        row[f"{tag}_rms_K"] = row[f"{tag}_max_K"] = None
                        row[f"{tag}_failed"] = str(e)
                row["default_better"] = (row["default_rms_K"] is not None and (
                    row["thesis_rms_K"] is None or row["default_rms_K"] < row["thesis_rms_K"]))
                row.update(design_run_s=walls, reference_runs_s=round(seconds, 1))
                rows.append(row)
    return rows


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
