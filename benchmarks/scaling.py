"""The cost curve (``fem2tmm bench scaling``, issue 43): the pipeline of :func:`benchmarks.pipeline.bench_pipeline_1m`
stage by stage, the detailed steady solve (conduction and emission to space) and the baselines (one factor-and-solve
of the Newton matrix, :mod:`benchmarks.baseline`) at 10⁴, 10⁵ and 10⁶ elements, super nodes and rays in proportion
(10 super nodes and 10⁵ rays per 10⁴ elements), each size in its own process (its peak memory its own).

Rows: one per size, and a ``scaling_fit`` row with each stage's fitted exponent (least squares of log time against
log elements over the sizes) and the plot (wall time against elements on log axes, the baselines beside the
pipeline), written to ``docs/benchmarks_scaling.png``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

from .cases import REPO

#: n (elements per 1 m edge of big_shell_structure: 6.4 n² quads) of 10⁴, 10⁵ and 10⁶ elements
SIZES = (40, 125, 395)
#: n of the 3·10⁶-element point (3.0·10⁶ quads), run only where memory allows (:func:`fits`)
LARGE = 685
#: bytes per element of the 10⁶ point's peak (5.62 GB at 998 560 quads, quiet run of 2026-12-06 09:17 UTC), with the
#: margin the estimate needs: the point runs where the machine's available memory holds 1.25x that
BYTES_PER_ELEMENT = 5.7e3
MEMORY_MARGIN = 1.25
PLOT = REPO / "docs" / "benchmarks_scaling.png"


def scaling_point(n: int, detailed: bool = True) -> dict:
    """One size: the pipeline's stage timings, the detailed steady solve, the baselines, the peak memory."""
    from fem2tmm.fem.model import build_model
    from fem2tmm.pipeline import detailed_problem, run
    from fem2tmm.solve.steady import solve_steady

    from .baseline import available, connected_pieces, newton_matrix, timed_solve
    from .cases import big_shell_structure
    from .pipeline import pipeline_1m_case
    from .run import reset_peak, vm

    run(pipeline_1m_case(8, 1e4), mesh=big_shell_structure(20), reference=False)  # warm-up: JIT, imports
    import scipy.sparse as sp

    for k in available():  # warm-up: loading MKL costs ~1.7 s on the first PARDISO call of a process
        timed_solve(k, sp.csr_matrix(sp.diags(np.arange(1.0, 101.0))), np.ones(100))
    mesh = big_shell_structure(n)
    elements = int(mesh.n_elements)
    sn = max(int(round(1000 * elements / 1e6)), 10)
    # the thesis' reduction at every size (what "auto" keeps at 10⁶, Biot 0.34; the coarser meshes' larger cluster
    # Biot numbers would switch "auto" to the radiation-aware reduction, another pipeline)
    case = pipeline_1m_case(sn, 1e7 * elements / 1e6, reduction={"radiation_aware": False})
    reset_peak()
    t0 = time.perf_counter()
    res = run(case, mesh=mesh, reference=False)
    wall = time.perf_counter() - t0
    peak = vm("VmHWM") * 2**20 / 1e9
    s = res.summary
    row = {"bench": "scaling", "n": n, "elements": elements, "nodes": int(mesh.n_nodes), "super_nodes": sn,
           "rays": (s["radiation"] or {}).get("rays"), "pipeline_s": round(wall, 3),
           "stages_s": {k: round(v, 3) for k, v in s["timings_s"].items()}, "pipeline_peak_rss_GB": round(peak, 3),
           "reduction": (s["reduced"] or {}).get("choice"), "connected_pieces": connected_pieces(res.model)}
    J, b = newton_matrix(res.model, res.reduced.T_recovered)
    del res
    row["unknowns"] = int(J.shape[0])
    row["baselines_s"] = {}
    for k in available():
        t, rel = timed_solve(k, J, b)
        row["baselines_s"][k] = round(t, 3)
        row.setdefault("baseline_residuals", {})[k] = float(f"{rel:.3g}")
    del J
    if detailed:  # the detailed reference's steady solve (conduction and emission to space, no face-to-face)
        model = build_model(mesh, case)
        prob = detailed_problem(model)
        t0 = time.perf_counter()
        sol = solve_steady(prob)
        row["detailed_solve_s"] = round(time.perf_counter() - t0, 3)
        row["detailed_newton_iterations"] = int(sol.iterations)
        from fem2tmm.linalg import backend

        row["detailed_solver"] = backend(int((~model.fixed_mask).sum()), "spd")
    row["peak_rss_GB"] = round(vm("VmHWM") * 2**20 / 1e9, 3)
    row["load_average"] = os.getloadavg()
    return row


def fit(rows: list[dict]) -> dict:
    """Per stage (and pipeline, baselines, detailed solve): the exponent p of time ∝ elements^p (least squares on
    log-log over the sizes where it was timed)."""
    series = {"pipeline": [r["pipeline_s"] for r in rows]}
    for r in rows:
        for k, v in r["stages_s"].items():
            series.setdefault(k, [])
        for k in r["baselines_s"]:
            series.setdefault("baseline_" + k, [])
    for k in series:
        if k == "pipeline":
            continue
        series[k] = [r["baselines_s"].get(k[9:]) if k.startswith("baseline_") else r["stages_s"].get(k)
                     for r in rows]
    if all("detailed_solve_s" in r for r in rows):
        series["detailed_solve"] = [r["detailed_solve_s"] for r in rows]
    x = np.log([r["elements"] for r in rows])
    out = {}
    for k, ts in series.items():
        ok = [i for i, t in enumerate(ts) if t is not None and t > 0]
        if len(ok) >= 2:
            out[k] = round(float(np.polyfit(x[ok], np.log([ts[i] for i in ok]), 1)[0]), 3)
    return {"exponents": out, "series": series}


def plot(rows: list[dict], fitted: dict, path=PLOT) -> str:
    """Wall time against elements on log axes: the pipeline, its largest stages and the baselines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    e = np.array([r["elements"] for r in rows], float)
    series, ex = fitted["series"], fitted["exponents"]
    last = {k: (v[-1] or 0) for k, v in series.items() if not k.startswith("baseline_") and k != "pipeline"}
    big = sorted(last, key=last.get, reverse=True)[:5]
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=90)
    ax.loglog(e, series["pipeline"], "o-k", lw=2, label=f"pipeline (p = {ex.get('pipeline', float('nan')):.2f})")
    for k in big:
        ax.loglog(e, series[k], ".-", label=f"{k} (p = {ex.get(k, float('nan')):.2f})")
    for k in series:
        if k.startswith("baseline_"):
            ax.loglog(e, series[k], "s--", label=f"{k[9:]}: one Newton solve (p = {ex.get(k, float('nan')):.2f})")
    ax.set_xlabel("elements")
    ax.set_ylabel("wall time (s)")
    ax.set_title("fem2tmm bench scaling (2 shared cores)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return str(path)


def fits(n: int) -> tuple[bool, float, float]:
    """Whether the size-``n`` point fits in this machine's available memory: (fits, needed GB, available GB); the
    need is :data:`BYTES_PER_ELEMENT` per element times :data:`MEMORY_MARGIN`."""
    need = BYTES_PER_ELEMENT * 6.4 * n * n * MEMORY_MARGIN / 1e9
    avail = float("nan")
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024 / 1e9
    except OSError:
        pass
    return bool(avail >= need), round(need, 1), round(avail, 1)


def bench_scaling(sizes=SIZES) -> list[dict]:
    """Each size in its own process (peak memory its own), then the fit and the plot; the 3·10⁶-element point
    (:data:`LARGE`) too where :func:`fits` says the memory allows (issue 43), a ``scaling_skipped`` row otherwise."""
    from .run import child_env

    rows, skipped = [], []
    ok, need, avail = fits(LARGE)
    if ok:
        sizes = tuple(sizes) + (LARGE,)
    else:
        skipped.append({"bench": "scaling_skipped", "n": LARGE, "elements": int(round(6.4 * LARGE * LARGE)),
                        "needs_GB": need, "available_GB": avail,
                        "why": "the machine's available memory does not hold the point's estimated peak"})
    for n in sizes:
        cmd = [sys.executable, "-c", "import json; from benchmarks.scaling import scaling_point; "
               f"print('ROW ' + json.dumps(scaling_point({int(n)})))"]
        p = subprocess.run(cmd, capture_output=True, text=True, env=child_env())
        got = [ln[4:] for ln in p.stdout.splitlines() if ln.startswith("ROW ")]
        if p.returncode != 0 or not got:
            raise RuntimeError(f"scaling point n={n} failed: {(p.stderr.strip().splitlines() or ['?'])[-1]}")
        rows.append(json.loads(got[0]))
    fitted = fit(rows)
    path = plot(rows, fitted)
    return rows + skipped + [{"bench": "scaling_fit", "exponents": fitted["exponents"], "plot": path,
                              "goal": "every stage's exponent <= 1.15 (issue 43)"}]
