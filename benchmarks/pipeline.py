"""Whole-pipeline and FE benchmarks (``fem2tmm bench assemble | solve | pipeline``): assembly and one solve of
a 10⁶-element plate, the baffle and truss examples, a generated 10⁶-element structure."""

from __future__ import annotations

import time

from .cases import REPO, big_shell_structure, plate_case
from .run import median_time, reset_peak, vm


def bench_assemble(n: int = 1000, repeats: int = 3) -> list[dict]:
    """Assembly of an n x n quad plate (default 10⁶ elements): FE model build (K, capacity, faces, loads).

    Baseline: scipy's COO -> CSR conversion of the same element-matrix entries (the irreducible part).
    """
    import numpy as np

    from fem2tmm.fem.model import build_model

    mesh, case = plate_case(n)
    rss_mesh = vm("VmRSS")
    reset_peak()
    model = build_model(mesh, case)  # peak of one build, mesh included (the repeats below free it first)
    peak = vm("VmHWM")
    coo = model.coo
    t_base, _ = median_time(lambda: coo.tocsr(model.n_dof), repeats)
    trace = float(np.sum(model.K.diagonal()))
    del model, coo

    def once():
        build_model(mesh, case)

    t_build, times = median_time(once, repeats)
    return [{"bench": "assemble", "elements": int(mesh.n_elements), "nodes": int(mesh.n_nodes),
             "median_s": round(t_build, 3), "times_s": [round(t, 3) for t in times],
             "build_peak_rss_GB": round(peak * 2**20 / 1e9, 3), "mesh_rss_GB": round(rss_mesh * 2**20 / 1e9, 3),
             "baseline": "scipy coo->csr of the same 16 entries/element", "baseline_median_s": round(t_base, 3),
             "ratio_to_baseline": round(t_build / t_base, 2), "nnz_entries": 16 * int(mesh.n_elements),
             "goal": "< 15 s and < 4 GB (issue 2)", "checksum_K_trace": trace}]


def bench_solve(n: int = 1000, repeats: int = 3) -> list[dict]:
    """One linear conduction solve of an n x n quad plate (10⁶ elements), Newton included.

    Baseline: ``scipy.sparse.linalg.spsolve`` with its default (COLAMD) ordering on the same matrix.
    """
    import dataclasses

    import numpy as np
    import scipy.sparse.linalg as spla

    from fem2tmm.fem.model import build_model
    from fem2tmm.pipeline import detailed_problem
    from fem2tmm.solve.steady import solve_steady

    mesh, case = plate_case(n)
    model = build_model(mesh, case)
    prob = dataclasses.replace(detailed_problem(model), g_space=np.zeros(model.n_dof))
    t_solve, times = median_time(lambda: solve_steady(prob), repeats)
    free = ~model.fixed_mask
    K = model.K[free][:, free].tocsc()
    t_base, _ = median_time(lambda: spla.spsolve(K, model.Q[free]), 1)
    return [{"bench": "solve", "unknowns": int(free.sum()), "median_s": round(t_solve, 3),
             "times_s": [round(t, 3) for t in times], "baseline": "scipy spsolve (default COLAMD), 1 run",
             "baseline_s": round(t_base, 3), "ratio_to_baseline": round(t_solve / t_base, 2),
             "goal": "< 30 s (issue 2)"}]


def _repo_file(*parts) -> str:
    return str(REPO.joinpath(*parts))


def _pipeline_row(name: str, result, wall: float) -> dict:
    s = result.summary
    return {"bench": name, "wall_s": round(wall, 2), "timings_s": {k: round(v, 3) for k, v in s["timings_s"].items()},
            "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
            "super_nodes": (s["reduced"] or {}).get("super_nodes"), "rays": (s["radiation"] or {}).get("rays"),
            "accuracy": s["accuracy"], "reduction": (s["reduced"] or {}).get("choice")}


def _run_case(name: str, case_file: str, super_nodes: int | None = None) -> list[dict]:
    """Run an example case (optionally with every part at ``super_nodes``) into a temporary folder."""
    import dataclasses
    import tempfile

    from fem2tmm.case import Case
    from fem2tmm.pipeline import run

    case = Case.from_toml(_repo_file(*case_file.split("/")))
    if super_nodes is not None:
        case = dataclasses.replace(case, parts=tuple(dataclasses.replace(p, super_nodes=super_nodes)
                                                     for p in case.parts))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run(case, out=f"{tmp}/out")
        wall = time.perf_counter() - t0
    return [_pipeline_row(name, res, wall)]


def bench_pipeline_baffle() -> list[dict]:
    """The baffle example (18 404 quads) at 10 and 100 super nodes, detailed reference included
    (goal: under 60 s each, issue 8)."""
    return _run_case("pipeline_baffle_10sn", "examples/baffle/case.toml") + \
        _run_case("pipeline_baffle_100sn", "examples/baffle/case.toml", super_nodes=100)


def bench_pipeline_truss() -> list[dict]:
    """The truss example (121 693 tets, 35 603 nodes) at 10 and 100 super nodes, reference included."""
    return _run_case("pipeline_truss_10sn", "examples/truss/case.toml") + \
        _run_case("pipeline_truss_100sn", "examples/truss/case.toml", super_nodes=100)


def bench_pipeline_1m(n: int = 408, super_nodes: int = 1000, rays: float = 1e7, rounds: int = 5) -> list[dict]:
    """A generated 1.07·10⁶-element shell structure (closed box with two shelves joined to its walls: one conformal
    structure, asserted connected), 1000 super nodes and ≈10⁷ rays between super faces, without the detailed
    reference (goal < 120 s and < 8 GB, issue 8), against one factor-and-solve of the model's Newton matrix by the
    best sparse direct solver available (PARDISO, else CHOLMOD) and by scipy's (symmetric ordering), timed in the
    same run, rounds interleaved (pipeline, then each baseline); the ratio is the median of the per-round ratios
    (issue 43: ≤ 6x PARDISO, peak ≤ 6 GB)."""
    import os
    import statistics
    import sys

    from fem2tmm.pipeline import run

    from .baseline import LABELS, available, connected_pieces, newton_matrix, timed_solve
    from .run import reset_peak, vm

    mesh = big_shell_structure(n)
    case = pipeline_1m_case(super_nodes, rays)
    solvers = list(available())
    run(pipeline_1m_case(8, 1e4), mesh=big_shell_structure(20), reference=False)  # warm-up: JIT compilation, imports
    import numpy as np
    import scipy.sparse as sp

    for k in solvers:  # warm-up: loading MKL costs ~1.7 s on the first PARDISO call of a process
        timed_solve(k, sp.csr_matrix(sp.diags(np.arange(1.0, 101.0))), np.ones(100))
    import tempfile
    from pathlib import Path

    walls, peaks, base = [], [], {k: [] for k in solvers}
    residuals = {}
    row = {}
    # the baseline's Newton matrix waits on disk while the pipeline runs: the pipeline's peak is its own and the mesh's
    # (held in memory between rounds it added ~0.2 GB to rounds 2-5; 2026-12-06)
    with tempfile.TemporaryDirectory(prefix="fem2tmm-bench-") as tmp:  # removed whatever happens
        keep = Path(tmp)
        for r in range(rounds):
            reset_peak()
            t0 = time.perf_counter()
            res = run(case, mesh=mesh, reference=False)
            walls.append(time.perf_counter() - t0)
            peaks.append(vm("VmHWM") * 2**20 / 1e9)
            if r == 0:
                pieces = connected_pieces(res.model)
                assert pieces == 1, f"the benchmark model splits into {pieces} pieces: not one structure"
                J, b = newton_matrix(res.model, res.reduced.T_recovered)
                sp.save_npz(keep / "J.npz", J, compressed=False)
                np.save(keep / "b.npy", b)
                row = _pipeline_row("pipeline_1m", res, walls[-1])
                row["connected_pieces"] = pieces
            else:
                J, b = sp.load_npz(keep / "J.npz").tocsr(), np.load(keep / "b.npy")
            del res
            for k in solvers:
                t, rel = timed_solve(k, J, b)
                base[k].append(t)
                residuals[k] = max(residuals.get(k, 0.0), rel)
            unknowns, nnz = int(J.shape[0]), int(J.nnz)
            del J, b
            print(f"pipeline_1m round {r + 1}/{rounds}: pipeline {walls[-1]:.1f} s, peak {peaks[-1]:.2f} GB, "
                  + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in base.items()) + f", load {os.getloadavg()[0]:.1f}",
                  file=sys.stderr, flush=True)
    best = solvers[0]
    ratios = [w / t for w, t in zip(walls, base[best])]
    row.update(
        wall_s=round(statistics.median(walls), 2), walls_s=[round(w, 2) for w in walls], rounds=rounds,
        pipeline_peak_rss_GB=round(max(peaks), 3), unknowns=unknowns, newton_nnz=nnz,
        baseline=LABELS[best], baseline_solver=best, baseline_s=round(statistics.median(base[best]), 3),
        ratio_to_baseline=round(statistics.median(ratios), 2), ratios=[round(x, 2) for x in ratios],
        baselines={k: {"label": LABELS[k], "median_s": round(statistics.median(v), 3),
                       "times_s": [round(t, 3) for t in v], "max_relative_residual": float(f"{residuals[k]:.3g}"),
                       "ratio_to_it": round(statistics.median([w / t for w, t in zip(walls, v)]), 2)}
                   for k, v in base.items()},
        load_average=os.getloadavg(),
        goal="< 120 s and < 8 GB (issue 8); <= 6x the PARDISO/CHOLMOD baseline, peak <= 6 GB (issue 43)")
    return [row]


def pipeline_1m_case(super_nodes: int = 1000, rays: float = 1e7, reduction: dict | None = None):
    """The case of :func:`bench_pipeline_1m` (its mesh: ``big_shell_structure``); ``reduction`` its ``[reduction]``
    table (default none: ``radiation_aware = "auto"``)."""
    from fem2tmm.case import Case

    n_sf = 2 * super_nodes
    extra = {} if reduction is None else {"reduction": dict(reduction)}
    return Case.from_dict({**extra,
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"white": {"emissivity": 0.85, "absorptivity": 0.2}},
        "parts": [{"name": "box", "groups": ["box"], "material": "al", "thickness": 1.5e-3, "front": "white",
                   "back": "white", "super_nodes": int(super_nodes * 0.6)},
                  {"name": "shelves", "groups": ["shelf_0", "shelf_1"], "material": "al", "thickness": 1e-3,
                   "front": "white", "back": "white", "super_nodes": super_nodes - int(super_nodes * 0.6)}],
        "boundary": [{"kind": "temperature", "groups": ["zmin"], "value": 20.0, "name": "base"},
                     {"kind": "power", "groups": ["shelf_1"], "value": 200.0, "name": "electronics"}],
        "environment": {"sink_temperature": -100.0, "sun_direction": [0.3, 0.2, 1.0], "solar_flux": 1366.0,
                        "solar_on": "super_faces", "solar_rays_per_face": 4},
        "radiation": {"rays_per_face": int(rays / n_sf)},
        "reference": {"detailed": False},
    })


def bench_pipeline_stages(n: int = 204, rounds: int = 1) -> list[dict]:
    """The pipeline_1m case on ``big_shell_structure(n)`` (266 832 quads for n = 204), stage by stage: wall time
    (summary.json timings) and CPU time (``time.process_time()``, all threads of the process, around each stage;
    on a shared machine the CPU column is the one to compare), after a warm-up run at n = 20.  Run it once per
    checkout, alternating checkouts, for an A/B (docs/benchmarks.md, "Speed-ups of 2026-12-06")."""
    import os
    from contextlib import contextmanager

    import fem2tmm.progress as progress
    from fem2tmm.pipeline import run

    cpu: dict[str, float] = {}
    plain = progress.Progress.stage

    @contextmanager
    def stage(self, name, label=None):
        c = time.process_time()
        try:
            with plain(self, name, label):
                yield
        finally:
            cpu[name] = cpu.get(name, 0.0) + time.process_time() - c

    mesh = big_shell_structure(n)
    rows = []
    progress.Progress.stage = stage
    try:
        run(pipeline_1m_case(8, 1e4), mesh=big_shell_structure(20), reference=False)  # warm-up: JIT, imports
        for _ in range(rounds):
            cpu.clear()
            c0, t0 = time.process_time(), time.perf_counter()
            res = run(pipeline_1m_case(), mesh=mesh, reference=False)
            row = _pipeline_row("pipeline_stages", res, time.perf_counter() - t0)
            row.update(cpu_s=round(time.process_time() - c0, 2), cpu_stage_s={k: round(v, 3) for k, v in cpu.items()},
                       load_average=os.getloadavg())
            rows.append(row)
            del res
    finally:
        progress.Progress.stage = plain
    return rows
