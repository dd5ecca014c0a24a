"""Benchmarks of the conductive reduction (``fem2tmm bench reduce``).

Each public ``bench_*`` function returns a list of dicts, one per measurement, with medians of repeated
timings in seconds.  Problems: structured quad shells from :mod:`fem2tmm.mesh.shapes`, Voronoi clusters around
seeded random elements (contiguous, irregular, deterministic for a seed).

* :func:`bench_local_vs_global` — ~18 k-node quad cylinder, bottom ring a fixed-temperature DOF, 10 and 100
  super nodes: local and global in the same run, their largest relative difference.
* :func:`bench_scaling` — the same comparison on a 2.5·10⁵-element plate with 300 super nodes.
* :func:`bench_dense_global` — the thesis' comparison: local against a dense global solve of M (18 k nodes).
* :func:`bench_large` — 10⁶ quad elements → 1000 super nodes, local method alone: time and peak memory
  (peak resident set size of a fresh subprocess, so the figure is not polluted by earlier work).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import scipy.linalg as sla
from scipy.spatial import cKDTree

from fem2tmm.mesh import shapes
from fem2tmm.fem.assembly import conduction_matrices, to_coo, volume_shares
from fem2tmm.reduce.conduction import reduce_conduction
from fem2tmm.reduce.supernodes import build_supernodes

from .run import child_env, reset_peak, vm

ALUMINIUM_K = 170.0  # W/(m K)
THICKNESS = 1e-3  # m


def voronoi_labels(points: np.ndarray, cells: np.ndarray, n_clusters: int, seed: int = 0) -> np.ndarray:
    """Cluster id (m,) = nearest of ``n_clusters`` seed elements drawn at random (seeded), renumbered 0..n−1."""
    cen = points[cells].mean(axis=1)
    rng = np.random.default_rng(seed)
    seeds = cen[rng.choice(len(cen), n_clusters, replace=False)]
    lab = cKDTree(seeds).query(cen)[1]
    return np.unique(lab, return_inverse=True)[1]


def shell_problem(points: np.ndarray, cells: np.ndarray, fixed_nodes: np.ndarray | None = None):
    """Conduction COO, padded cells and volume shares of an aluminium quad4 shell, DOF-numbered.

    ``fixed_nodes`` are merged into one isothermal DOF (the last one).  Returns
    ``(coo, cells_dof (m, 4), shares (m, 4), n_dof, fixed_dof or None)``.
    """
    m = len(cells)
    t = np.full(m, THICKNESS)
    coo = to_coo(cells, conduction_matrices(points, cells, "quad4", np.full(m, ALUMINIUM_K), t), np.arange(m))
    shares = volume_shares(points, cells, "quad4", t)
    n = points.shape[0]
    if fixed_nodes is None:
        return coo, cells, shares, n, None
    rest = np.setdiff1d(np.arange(n), fixed_nodes)
    node_map = np.empty(n, np.int64)
    node_map[rest] = np.arange(rest.size)
    node_map[fixed_nodes] = rest.size
    return coo.renumber(node_map), node_map[cells], shares, rest.size + 1, rest.size


def _timed(fn, repeats: int):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def _compare(pts, cells, fixed_nodes, n_sn, repeats: int, seed: int, mesh: str) -> list[dict]:
    coo, cdof, shares, n, fixed = shell_problem(pts, cells, fixed_nodes)
    out = []
    for k in n_sn:
        labels = voronoi_labels(pts, cells, k, seed)
        sn = build_supernodes(n, cdof, shares, labels, boundary=[fixed])
        tg, rg = _timed(lambda: reduce_conduction(coo, sn, labels, method="global"), repeats)
        tl, rl = _timed(lambda: reduce_conduction(coo, sn, labels, method="local"), repeats)
        diff = float(np.abs(rl.K - rg.K).max() / np.abs(rg.K).max())
        out.append({"bench": "reduce", "case": "local_vs_global", "mesh": mesh, "nodes": int(pts.shape[0]),
                    "elements": int(len(cells)), "super_nodes": int(sn.n_sn), "global_s": tg, "local_s": tl,
                    "speedup": tg / tl, "max_rel_diff": diff, "interface_dofs": rl.diagnostics["n_interface"],
                    "local_paths": rl.diagnostics["cluster_solvers"], "repeats": repeats,
                    "baseline": "global = SuperLU of the saddle matrix M, n_SN solves (same run)"})
    return out


def bench_local_vs_global(n_sn=(10, 100), n_theta: int = 180, n_z: int = 99, repeats: int = 3,
                          seed: int = 0) -> list[dict]:
    """Local against global reduction on a quad cylinder of n_theta·(n_z+1) nodes (default 18 000)."""
    m = shapes.cylinder(0.5, 1.0, n_theta, n_z)
    return _compare(m.points, m.blocks[0].cells, m.groups["end0"].nodes, n_sn, repeats, seed,
                    f"cylinder {n_theta}x{n_z} quad4, bottom ring fixed")


def bench_scaling(nx: int = 500, n_sn=(300,), repeats: int = 3, seed: int = 0) -> list[dict]:
    """Local against global on an nx × nx quad plate (default 2.5·10⁵ elements): the gap grows with size."""
    m = shapes.plate(1.0, 1.0, nx, nx)
    return _compare(m.points, m.blocks[0].cells, m.groups["xmin"].nodes, n_sn, repeats, seed,
                    f"plate {nx}x{nx} quad4, x=0 edge fixed")


def _large_once(nx: int, n_clusters: int, seed: int) -> dict:
    t0 = time.perf_counter()
    m = shapes.plate(1.0, 1.0, nx, nx)
    pts, cells, edge = m.points, m.blocks[0].cells, m.groups["xmin"].nodes
    del m
    coo, cdof, shares, n, fixed = shell_problem(pts, cells, edge)  # x = 0 edge fixed
    labels = voronoi_labels(pts, cells, n_clusters, seed)
    del pts, cells
    t1 = time.perf_counter()
    setup_peak = vm("VmHWM")  # not ru_maxrss: Linux carries that over fork + exec from the parent
    reset = reset_peak()
    rss0 = vm("VmRSS")
    sn = build_supernodes(n, cdof, shares, labels, boundary=[fixed])
    t2 = time.perf_counter()
    red = reduce_conduction(coo, sn, labels)
    t3 = time.perf_counter()
    T = red.recover(np.full(sn.n_sn, 300.0))
    t4 = time.perf_counter()
    return {"elements": int(len(labels)), "nodes": int(n), "super_nodes": int(sn.n_sn),
            "setup_s": t1 - t0, "supernodes_s": t2 - t1, "reduce_s": t3 - t2, "recover_s": t4 - t3,
            "interface_dofs": red.diagnostics["n_interface"], "factor_MB": red.diagnostics["factor_bytes"] / 2 ** 20,
            "setup_peak_rss_MB": setup_peak, "rss_before_reduction_MB": rss0,
            "reduction_peak_rss_MB": vm("VmHWM") if reset else float("nan"),
            "peak_rss_MB": max(setup_peak, vm("VmHWM")),
            "recover_uniform_err": float(np.abs(T - 300.0).max())}


def _in_subprocess(call: str) -> dict:
    """Run ``call`` (an expression on this module returning a JSON-able dict) in a fresh Python process."""
    code = f"import json; from benchmarks import reduce as b; print(json.dumps(b.{call}))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=child_env())
    return json.loads(res.stdout.strip().splitlines()[-1])


def bench_large(nx: int = 1000, n_clusters: int = 997, repeats: int = 3, seed: int = 0) -> list[dict]:
    """Local reduction of an nx × nx quad plate (10⁶ elements) into ``n_clusters`` + 1 super nodes.

    Each repeat runs in a fresh Python subprocess.  ``reduction_peak_rss_MB`` is the process's peak resident
    memory from just before ``build_supernodes`` to the end of a recovery (Linux: the VmHWM mark is reset after
    the test problem is built, and includes the problem's arrays still alive, ``rss_before_reduction_MB``);
    ``peak_rss_MB`` is the whole run's, mesh generation and assembly included (``setup_peak_rss_MB``).
    """
    runs = [_in_subprocess(f"_large_once({nx}, {n_clusters}, {seed})") for _ in range(repeats)]
    med = {k: float(np.median([r[k] for r in runs])) for k in runs[0] if isinstance(runs[0][k], float)}
    first = runs[0]
    return [{"bench": "reduce", "case": "large_local", "goal": "< 60 s and < 8 GB (reduce_s, reduction_peak_rss_MB)",
             "elements": first["elements"], "nodes": first["nodes"],
             "super_nodes": first["super_nodes"], "interface_dofs": first["interface_dofs"],
             "repeats": repeats, **{k: med[k] for k in sorted(med)},
             "reduce_s_all": [r["reduce_s"] for r in runs]}]


def _dense_once(n_theta: int, n_z: int, n_sn: int, seed: int) -> dict:
    m = shapes.cylinder(0.5, 1.0, n_theta, n_z)
    pts, cells = m.points, m.blocks[0].cells
    coo, cdof, shares, n, fixed = shell_problem(pts, cells, m.groups["end0"].nodes)
    labels = voronoi_labels(pts, cells, n_sn, seed)
    sn = build_supernodes(n, cdof, shares, labels, boundary=[fixed])
    tl, rl = _timed(lambda: reduce_conduction(coo, sn, labels), 3)
    t0 = time.perf_counter()
    ns = sn.n_sn
    M = np.zeros((n + ns, n + ns))
    M[:n, :n] = coo.tocsr(n).toarray()
    M[n:, :n] = sn.A.toarray()
    M[:n, n:] = M[n:, :n].T
    rhs = np.zeros((n + ns, ns))
    rhs[n:] = np.eye(ns)
    K = -sla.solve(M, rhs, overwrite_a=True, check_finite=False)[n:]
    td = time.perf_counter() - t0
    return {"bench": "reduce", "case": "local_vs_dense_global", "nodes": int(n), "super_nodes": int(ns),
            "dense_global_s": td, "local_s": tl, "speedup": td / tl,
            "max_rel_diff": float(np.abs(K - rl.K).max() / np.abs(rl.K).max()),
            "baseline": "thesis-style global: dense LU of M (n + n_SN)² with n_SN right-hand sides, run once "
                        "(~5 GB); local median of 3", "goal": "local >= 20x faster at 100 super nodes"}


def bench_dense_global(n_theta: int = 180, n_z: int = 99, n_sn: int = 100, seed: int = 0) -> list[dict]:
    """The thesis' comparison: local against a dense global inversion on the ~18 k-node cylinder (~1 min)."""
    return [_in_subprocess(f"_dense_once({n_theta}, {n_z}, {n_sn}, {seed})")]


def bench_reduce() -> list[dict]:
    """Every reduction benchmark (``fem2tmm bench reduce``; about 7 minutes on 2 cores)."""
    return bench_local_vs_global() + bench_scaling() + bench_dense_global() + bench_large()


if __name__ == "__main__":
    for row in bench_reduce():
        print(json.dumps(row))
