"""The local reduction on Dask, and the pipeline's memory per element (``fem2tmm bench reduce_dask``,
``fem2tmm bench memory_per_element``).

* :func:`bench_reduce_dask` — the reduction stage (:func:`fem2tmm.reduce.network.build_reduced`) of the generated
  shell structure (:func:`benchmarks.cases.big_shell_structure`, 1000 super nodes as in ``pipeline_1m``) in this
  process and on a ``LocalCluster`` of single-threaded worker processes, rounds interleaved; asserts that both give
  the same bits (K, C, a recovered field); the client's and the workers' peak memory.
* :func:`bench_memory_per_element` — the whole pipeline's peak resident memory (no detailed reference) at two sizes
  of the same structure, each in a fresh process; the straight line through them and the element count it reaches
  at a memory limit.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

from .run import child_env, reset_peak, vm


def _worker_peak_mb() -> float:
    """This (worker) process's peak resident memory since its mark was last reset (MB)."""
    return vm("VmHWM")


def _reset_worker_peak() -> bool:
    return reset_peak()


def bench_reduce_dask(n: int = 204, super_nodes: int = 1000, workers: int = 2, rounds: int = 3) -> list[dict]:
    """Reduction stage of ``big_shell_structure(n)`` (≈ 6.4 n² quads; 2.66·10⁵ at n = 204) serially and on
    ``LocalCluster(workers)``, ``rounds`` interleaved rounds (serial, then Dask), medians.

    ``clusters_s`` is the per-cluster local step (the part that runs as Dask tasks), ``rest_s`` the remainder
    (numbering, the multifrontal interface condensation, which stays on the client).  ``bound_s`` is what
    ``workers`` workers could reach if the local step split perfectly and cost nothing to ship:
    ``rest_s + clusters_s / workers`` of the serial run.  Peak memory: ``client_peak_MB`` over the reduction (the
    mark reset just before it), ``worker_peak_MB`` each worker's peak over its life.
    """
    from fem2tmm.compute import open_executor, using
    from fem2tmm.fem.model import build_model
    from fem2tmm.reduce.network import build_reduced
    from fem2tmm.stages.cluster import cluster_model

    from .cases import big_shell_structure
    from .pipeline import pipeline_1m_case

    case = pipeline_1m_case(super_nodes, 1e4)
    mesh = big_shell_structure(n)
    model = build_model(mesh, case)
    clustering = cluster_model(model, case)  # (without the solar pre-pass: the reduction's cost does not need it)
    small_case = pipeline_1m_case(8, 1e4)
    small = build_model(big_shell_structure(12), small_case)
    small_clustering = cluster_model(small, small_case)
    build_reduced(small, small_clustering, small_case)  # warm-up: JIT compilation
    ex = open_executor("local", workers)
    with using(ex):  # warm-up of the workers (imports)
        build_reduced(small, small_clustering, small_case)
    runs = {"serial": [], "dask": []}
    T_sn = None
    ref = None
    try:
        for r in range(rounds):
            for mode in ("serial", "dask"):
                if mode == "dask":
                    ex.client.run(_reset_worker_peak)
                reset_peak()
                rss0 = vm("VmRSS")
                t0 = time.perf_counter()
                if mode == "serial":
                    rm = build_reduced(model, clustering, case)
                else:
                    with using(ex):
                        rm = build_reduced(model, clustering, case)
                wall = time.perf_counter() - t0
                d = rm.reduction.diagnostics
                if T_sn is None:
                    T_sn = np.linspace(250.0, 320.0, rm.n)
                got = (rm.K, rm.C, rm.reduction.recover(T_sn))
                if ref is None:
                    ref = got
                same = all(np.array_equal(a, b) for a, b in zip(got, ref))
                row = {"wall_s": wall, "reduce_s": d["seconds"], "clusters_s": d["clusters_seconds"],
                       "tasks": d["tasks"], "client_peak_MB": vm("VmHWM"), "client_rss_before_MB": rss0,
                       "bit_identical": same, "load": os.getloadavg()[0]}
                if mode == "dask":
                    row["worker_peak_MB"] = sorted(ex.client.run(_worker_peak_mb).values())
                runs[mode].append(row)
                print(f"reduce_dask round {r + 1}/{rounds} {mode}: {wall:.1f} s (local step {d['clusters_seconds']:.1f} s,"
                      f" {d['tasks']} tasks), client peak {row['client_peak_MB']:.0f} MB, identical {same}, "
                      f"load {row['load']:.1f}", file=sys.stderr, flush=True)
                del rm, got
        n_workers = ex.workers
    finally:
        ex.close()
    assert all(x["bit_identical"] for v in runs.values() for x in v), "the Dask reduction differs from the serial one"
    med = {m: {k: statistics.median([x[k] for x in v]) for k in ("wall_s", "reduce_s", "clusters_s", "client_peak_MB")}
           for m, v in runs.items()}
    s = med["serial"]
    rest = s["reduce_s"] - s["clusters_s"]
    bound = rest + s["clusters_s"] / workers
    return [{"bench": "reduce_dask", "elements": int(model.mesh.n_elements), "n_dof": int(model.n_dof),
             "super_nodes": len(clustering.cluster_part), "workers": n_workers,
             "rounds": rounds, "serial": med["serial"], "dask": med["dask"],
             "serial_rest_s": rest, "bound_s": bound, "speedup": s["reduce_s"] / med["dask"]["reduce_s"],
             "speedup_bound": s["reduce_s"] / bound, "runs": runs, "bit_identical": True,
             "load_average": os.getloadavg(),
             "note": "clusters_s: the per-cluster local step (Dask tasks with a scheduler); the rest (multifrontal "
                     "interface condensation, numbering) stays on the client"}]


def _pipeline_peak(n: int, super_nodes: int, rays: float) -> dict:
    """One pipeline run (no detailed reference) of ``big_shell_structure(n)`` in this (fresh) process: its peak
    resident memory (MB) and wall time."""
    from fem2tmm.pipeline import run

    from .cases import big_shell_structure
    from .pipeline import pipeline_1m_case

    mesh = big_shell_structure(n)
    t0 = time.perf_counter()
    res = run(pipeline_1m_case(super_nodes, rays), mesh=mesh, reference=False, quiet=True)
    return {"n": n, "elements": int(mesh.n_elements), "n_dof": int(res.model.n_dof),
            "wall_s": time.perf_counter() - t0, "peak_MB": vm("VmHWM"), "load": os.getloadavg()[0]}


def bench_memory_per_element(sizes: tuple[int, ...] = (125, 204), super_nodes: int = 1000, rays: float = 1e7,
                             limit_GB: float = 24.0) -> list[dict]:
    """Peak resident memory of the pipeline (no detailed reference) on ``big_shell_structure(n)`` for each ``n`` in
    ``sizes``, each in a fresh subprocess; ``per_element_kB`` the slope of the line through the first and last
    point, and ``elements_at_limit`` where that line reaches ``limit_GB``."""
    runs = []
    for n in sizes:
        code = (f"import json; from benchmarks import distributed as b; "
                f"print(json.dumps(b._pipeline_peak({n}, {super_nodes}, {rays})))")
        res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=child_env())
        runs.append(json.loads(res.stdout.strip().splitlines()[-1]))
        print(f"memory_per_element n={n}: {runs[-1]}", file=sys.stderr, flush=True)
    a, b = runs[0], runs[-1]
    slope = (b["peak_MB"] - a["peak_MB"]) / (b["elements"] - a["elements"])  # MB per element
    base = a["peak_MB"] - slope * a["elements"]
    return [{"bench": "memory_per_element", "runs": runs, "per_element_kB": slope * 1024, "intercept_MB": base,
             "limit_GB": limit_GB, "elements_at_limit": (limit_GB * 1024 - base) / slope,
             "super_nodes": super_nodes, "rays": rays, "load_average": os.getloadavg()}]
