"""``fem2tmm bench transient``: the transient stage on the baffle and on a 10⁶-element plate (issue 17).

* ``transient_baffle_<n>sn``: the baffle example (18 404 quads, REFs and solar traced, detailed reference with its
  FE-face REFs) with a heater on the back annulus following 5 (1 − cos 2πt/P) W, P = 6000 s, integrated over one
  period with 60 s Crank-Nicolson steps from the steady state: detailed against reduced transient time (wall and
  CPU; the ratio of the reduced side includes the recovery at every output time) and the recovered error over time.
* ``transient_plate_1m``: the 10⁶-quad plate (1 m, 1 mm aluminium, black both sides, one edge at 20 °C, a flux
  following the same cosine) reduced to 1000 super nodes with radiation on; 1000 reduced steps of 60 s.
  Goal: < 10 s for the 1000 steps (issue 17).  The model build (pipeline up to the steady solve) is reported too.
* ``transient_dense_1000``: 1000 steps of a 1000-node network with dense GL and GR (the worst case of a reduced
  model with face-to-face radiation).

Times are wall seconds unless ``_cpu`` (process CPU seconds: the machine is shared, the CPU time is what the
solver itself costs).
"""

from __future__ import annotations

import time

import numpy as np

from fem2tmm.case import Case
from fem2tmm.mesh.shapes import plate
from fem2tmm.pipeline import run

from .cases import REPO

PERIOD = 6000.0


def _cosine_table(amplitude: float, n: int = 101) -> list[list[float]]:
    """``amplitude (1 − cos 2πt/P)`` sampled at n points over one period, as a case-file table."""
    t = np.linspace(0.0, PERIOD, n)
    return [[float(a), float(amplitude * (1 - np.cos(2 * np.pi * a / PERIOD)))] for a in t]


def _row(name: str, res, wall: float) -> dict:
    tr = res.summary["transient"]
    acc = tr["accuracy"] or {}
    tm = tr["timings_s"]
    row = {"bench": name, "elements": res.summary["mesh"]["elements"], "nodes": res.summary["mesh"]["nodes"],
           "super_nodes": (res.summary["reduced"] or {}).get("super_nodes"), "steps": tr["solver"]["reduced"]["steps"],
           "wall_s": round(wall, 2), "transient_s": {k: round(v, 3) for k, v in tm.items()},
           "energy_relative": {k: v["relative"] for k, v in tr["energy_balance"].items()}}
    if "detailed" in tm:
        red = tm["reduced"] + tm["recover"]
        red_cpu = tm["reduced_cpu"] + tm["recover_cpu"]
        row["detailed_over_reduced"] = round(tm["detailed"] / red, 1)
        row["detailed_over_reduced_cpu"] = round(tm["detailed_cpu"] / red_cpu, 1)
        row["error_K"] = {"rms": acc.get("rms_K"), "max": acc.get("max_K"), "time_of_max_s": acc.get("time_of_max_s"),
                          "max_per_output_time": [round(v, 4) for v in acc.get("max_per_time_K", [])]}
    return row


def bench_transient_baffle(super_nodes: int = 10) -> list[dict]:
    import tomllib

    path = REPO / "examples" / "baffle" / "case.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    for p in data["parts"]:
        p["super_nodes"] = super_nodes
    data["boundary"].append({"name": "heater", "kind": "power", "groups": ["back_annulus"], "value": _cosine_table(5.0)})
    data["transient"] = {"end": PERIOD, "step": 60.0, "output_every": 300.0, "method": "crank-nicolson"}
    case = Case.from_dict(data, base_dir=path.parent, source=str(path))
    t0 = time.perf_counter()
    res = run(case)
    row = _row(f"transient_baffle_{super_nodes}sn", res, time.perf_counter() - t0)
    row["goal"] = "ratio detailed / reduced transient time (the thesis: hours against seconds)"
    return [row]


def bench_transient_plate_1m(n: int = 1000, super_nodes: int = 1000, steps: int = 1000) -> list[dict]:
    mesh = plate(1.0, 1.0, n, n)
    case = Case.from_dict({
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"black": {"emissivity": 0.85}},
        "parts": [{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                   "back": "black", "super_nodes": super_nodes}],
        "boundary": [{"kind": "temperature", "groups": ["xmin"], "value": 20.0, "name": "edge"},
                     {"kind": "flux", "groups": ["plate"], "value": _cosine_table(200.0), "name": "flux"}],
        "environment": {"sink_temperature": -100.0},
        "radiation": {"rays_per_face": 200},
        "reference": {"detailed": False},
        "transient": {"end": 60.0 * steps, "step": 60.0, "output_every": 6.0 * steps, "method": "crank-nicolson"},
    })
    t0 = time.perf_counter()
    res = run(case, mesh=mesh, reference=False)
    row = _row("transient_plate_1m", res, time.perf_counter() - t0)
    row["radiative_links"] = res.summary["reduced"]["radiative_links"]
    row["goal"] = f"{steps} reduced steps < 10 s (issue 17)"
    return [row]


def bench_transient_dense(n: int = 1000, steps: int = 1000, seed: int = 0) -> list[dict]:
    """Worst case of a reduced model: n = 1000 nodes with a dense conduction matrix and dense node-to-node GR (a
    seeded random symmetric network: 1 % of the GL links, every GR pair), one fixed node, εA to space on every node,
    a sinusoidal load; ``steps`` Crank-Nicolson steps of 60 s.  The flat 10⁶-quad plate's super nodes only see
    space, so this row times the dense radiative Newton (a modified Newton with a frozen factorisation)."""
    from fem2tmm.solve.transient import TransientProblem, TransientSettings, solve_transient
    from fem2tmm.timefunc import Series, Table

    rng = np.random.default_rng(seed)
    W = rng.random((n, n)) * (rng.random((n, n)) < 0.01)
    W = W + W.T
    np.fill_diagonal(W, 0.0)
    GR = rng.random((n, n)) * 1e-4
    GR = GR + GR.T
    np.fill_diagonal(GR, 0.0)
    fixed = np.zeros(n, bool)
    fixed[0] = True
    t = np.linspace(0.0, PERIOD, 101)
    prob = TransientProblem(K=np.diag(W.sum(axis=1)) - W, C=np.full(n, 100.0),
                            Q=Series(np.zeros(n), (np.full(n, 0.1),), (Table(t, 1 + np.sin(2 * np.pi * t / PERIOD)),)),
                            fixed=fixed, T_fixed=Series(np.full(n, 293.15)), g_space=np.full(n, 1e-3),
                            T_sink=Table.constant(3.0), GR=GR)
    settings = TransientSettings(end=60.0 * steps, step=60.0, output_every=600.0)
    w, c = time.perf_counter(), time.process_time()
    sol = solve_transient(prob, settings, 293.15)
    wall, cpu = time.perf_counter() - w, time.process_time() - c
    return [{"bench": "transient_dense_1000", "nodes": n, "steps": sol.stats["steps"], "wall_s": round(wall, 2),
             "cpu_s": round(cpu, 2), "factorizations": sol.stats["factorizations"],
             "newton_iterations": sol.stats["newton_iterations"], "energy_relative": sol.energy["relative"],
             "goal": f"{steps} reduced steps < 10 s (issue 17)"}]


def bench_transient() -> list[dict]:
    """Every measurement (see the module docstring)."""
    return bench_transient_baffle() + bench_transient_plate_1m() + bench_transient_dense()


__all__ = ["bench_transient", "bench_transient_baffle", "bench_transient_dense", "bench_transient_plate_1m"]
