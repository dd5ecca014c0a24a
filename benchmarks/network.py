"""``fem2tmm bench network``: automatic grouping of a ~35 000-node network to ~1 000 nodes.

The network is generated from the truss FE model (``examples/truss/case.toml``, 35 603 mesh nodes in tetrahedra):
every FE DOF is a network node with its capacitance, loads and position; GL are the off-diagonal terms of the
assembled conduction matrix (FE conduction of tetrahedra: a few are negative, they are kept and simply never
condense anything); GR are the node-to-node couplings ``Wᵀ G W`` of the detailed face-to-face REFs (traced with
``RAYS_PER_FACE`` rays per face side) plus a SPACE boundary node at the sink.  The pads at 20 °C are the one
boundary node of the model.

Timed: the grouping given the detailed solution (sizing matrix, isolation, filters, components, compaction, the
reduced steady solve and the criteria) at thresholds found by a short bisection on p_f for ~1 000 groups, then a
5 x 4 sweep (identical partitions solved once) with its best passing pair.  The network generation (ray tracing)
and the detailed solve are timed separately.  Goal (issue 20): < 30 s.

On this FE-generated network the dimensionless couplings are all alike (K̃ ≈ 1–10: one material, one mesh size),
so the conductance filter percolates: around p_f ≈ 4.6 one giant component holds most nodes and the rest stay
alone, and the 1 000-node grouping fails the criteria (the giant group spans the whole temperature range).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from fem2tmm.case import Case
from fem2tmm.fem.model import build_model
from fem2tmm.lpm import grouping as G
from fem2tmm.lpm.network import Network
from fem2tmm.lpm.solve import solve_network
from fem2tmm.pipeline import load_mesh
from fem2tmm.stages.radiation import detailed_radiation

from .cases import REPO
from .run import reset_peak, vm

#: rays per FE face side of the detailed REFs behind the benchmark network's GR
RAYS_PER_FACE = 8
TARGET_NODES = 1000
#: the (p_f, ΔT_max) grid of the benchmark's sweep
SWEEP_PF = (4.0, 5.0, 6.0, 8.0, 10.0)
SWEEP_DTMAX = (0.01, 0.1, 1.0, 10.0)


def network_from_model(model, faced=None, g_space=None, T_sink: float = 3.0):
    """A :class:`~fem2tmm.lpm.network.Network` of a detailed FE model: one node per DOF (numbers 1..n_dof, positions
    the mean of the DOF's mesh nodes), GL = −offdiag(K), GR = Wᵀ G W of ``faced`` and a SPACE boundary node
    (number n_dof + 1, at ``T_sink`` K) coupled by ``g_space`` (n_dof,) m²."""
    n = model.n_dof
    K = sp.csr_matrix(model.K)
    GL = -(K - sp.diags(K.diagonal()))
    GL.eliminate_zeros()
    ok = np.flatnonzero(model.node_dof >= 0)
    cnt = np.bincount(model.node_dof[ok], minlength=n)
    X = np.stack([np.bincount(model.node_dof[ok], weights=model.mesh.points[ok, k], minlength=n) for k in range(3)],
                 axis=1) / np.maximum(cnt, 1)[:, None]
    GR = sp.csr_matrix((n, n))
    if faced is not None:
        W = sp.csr_matrix(faced.W)
        GR = (W.T @ sp.csr_matrix(faced.G) @ W).tocsr()
        GR = 0.5 * (GR + GR.T)
        GR.setdiag(0.0)
        GR.eliminate_zeros()
    g = np.zeros(n) if g_space is None else np.asarray(g_space, float)
    kind = np.array(["D"] * n + ["B"])
    T = np.full(n + 1, 293.15)
    for grp in model.fixed:
        kind[grp.dof] = "B"
        T[grp.dof] = grp.T
    T[n] = T_sink
    live = np.flatnonzero(g > 0)
    GRf = sp.bmat([[GR, sp.csr_matrix((g[live], (live, np.zeros(len(live), np.int64))), shape=(n, 1))],
                   [sp.csr_matrix((g[live], (np.zeros(len(live), np.int64), live)), shape=(1, n)), None]]).tocsr()
    GLf = sp.bmat([[GL, None], [None, sp.csr_matrix((1, 1))]]).tocsr()
    C = np.r_[model.capacity if model.capacity is not None else np.zeros(n), 0.0]
    z = np.zeros(n + 1)
    return Network(numbers=np.arange(1, n + 2), labels=np.array([f"DOF{i}" for i in range(n)] + ["SPACE"]),
                   kind=kind, T=T, C=C, A=z, alp=z, eps=z, QI=np.r_[model.Q, 0.0], GL=GLf, GR=GRf,
                   coordinates=np.r_[X, np.full((1, 3), np.nan)], source="truss network")


def bench_network() -> list[dict]:
    """Truss network (every FE DOF a node) grouped automatically to ~1 000 nodes."""
    t0 = time.perf_counter()
    case = Case.from_toml(REPO / "examples" / "truss" / "case.toml")
    model = build_model(load_mesh(case), case)
    faced, g_space, _ = detailed_radiation(model, case, rays_per_face=RAYS_PER_FACE)
    net = network_from_model(model, faced, g_space, T_sink=case.environment.sink_temperature)  # K already
    del faced
    t_build = time.perf_counter() - t0
    t0 = time.perf_counter()
    det = solve_network(net)
    t_detailed = time.perf_counter() - t0
    reset_peak()
    rss0 = vm("VmRSS")
    t0 = time.perf_counter()
    grouper = G.prepare(net, detailed=[det])
    t_prepare = time.perf_counter() - t0
    dtmax = 2.0
    lo, hi = -4.0, 3.0  # log10 p_f: more groups as p_f grows
    n_c = 0
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        n_c, _labels = grouper.labels(10**mid, dtmax)
        if abs(n_c - TARGET_NODES) <= 0.05 * TARGET_NODES:
            break
        lo, hi = (mid, hi) if n_c < TARGET_NODES else (lo, mid)
    pf = 10**mid
    t_search = time.perf_counter() - t0 - t_prepare
    t1 = time.perf_counter()
    g = G.group(grouper, pf, dtmax)
    t_group = time.perf_counter() - t1
    total = time.perf_counter() - t0
    chk = g.checks[0]
    t1 = time.perf_counter()
    sw = G.sweep(grouper, SWEEP_PF, SWEEP_DTMAX)
    t_sweep = time.perf_counter() - t1
    best = None if sw.best is None else {"pf": float(sw.pf[sw.best[0]]), "dtmax_K": float(sw.dtmax[sw.best[1]]),
                                         "reduced_nodes": int(sw.n_c[sw.best]),
                                         "ratio": round(float(sw.ratio[sw.best]), 4)}
    return [{"bench": "network", "nodes": int(net.n), "GL": int(net.GL.nnz // 2), "GR": int(net.GR.nnz // 2),
             "rays_per_face": RAYS_PER_FACE, "build_s": round(t_build, 2), "detailed_solve_s": round(t_detailed, 2),
             "pf": round(pf, 5), "dtmax_K": dtmax, "reduced_nodes": int(g.reduced.n), "ratio": round(g.ratio, 4),
             "grouping_s": round(total, 2),
             "grouping_split_s": {"prepare": round(t_prepare, 2), "pf_search": round(t_search, 2),
                                  "compact_solve_check": round(t_group, 2)},
             "criteria_met": bool(g.passed), "max_delta_K": round(float(chk.delta.max(initial=0.0)), 3),
             "grouping_peak_extra_GB": round((vm("VmHWM") - rss0) / 1024, 3),
             "sweep_points": int(sw.ratio.size), "sweep_partitions": len(grouper.cache), "sweep_s": round(t_sweep, 2),
             "sweep_best_passing": best,
             "goal": "30 000 nodes grouped in < 30 s (issue 20)"}]


def bench_network_positive() -> list[dict]:
    """``examples/baffle/case_100.toml`` with ``[reduction] network = "positive"``: the positive sparse network's
    links and recovered error against the detailed model next to the exact reduction's (goal: at most 2x)."""
    import dataclasses

    from fem2tmm.pipeline import run

    case = Case.from_toml(REPO / "examples" / "baffle" / "case_100.toml")
    case = dataclasses.replace(case, reduction=dataclasses.replace(case.reduction, network="positive"))
    t0 = time.perf_counter()
    res = run(case)
    wall = time.perf_counter() - t0
    pn = res.summary["positive_network"]
    err = pn["recovered_error_K"]
    return [{"bench": "network_positive", "case": "examples/baffle/case_100.toml", "wall_s": round(wall, 1),
             "positive_fit_s": round(res.summary["timings_s"].get("positive", float("nan")), 3),
             "super_nodes": res.summary["reduced"]["super_nodes"], "links": pn["links"],
             "candidate_links": pn["candidate_links"], "exact_links": pn["exact_links"],
             "exact_negative_links": pn["exact_negative_links"], "min_GL_W_per_K": pn["min_GL_W_per_K"],
             "relative_load_residual": round(pn["relative_load_residual"], 4),
             "T_vs_exact_max_K": round(pn["T_vs_exact_K"]["max"], 5),
             "recovered_rms_K": {"positive": round(err["positive"]["rms"], 5), "exact": round(err["exact"]["rms"], 5)},
             "recovered_max_K": {"positive": round(err["positive"]["max"], 5), "exact": round(err["exact"]["max"], 5)},
             "ratio_rms": round(err["ratio_rms"], 3), "criteria_met": pn["criteria"]["met"],
             "goal": "recovered error of the positive network <= 2x the exact reduction's (issue 20)"}]
#: thresholds of the link-filter measurement (0: the exact network)
FILTERS = (0.0, 1e-4, 1e-3, 3e-3, 1e-2)


def bench_link_filter(super_nodes=(100, 300)) -> list[dict]:
    """``examples/composite/case.toml`` at each count of ``super_nodes`` (radiation-aware, its default): the deck's
    GL (and negative GL) after the TMRT link filter (:func:`fem2tmm.reduce.filters.filter_links`) at each of
    :data:`FILTERS`, and what the user receives from that deck: the ESATAN deck written, read back and solved
    (:mod:`fem2tmm.lpm`), its super-node temperatures against the unfiltered network's, and the field recovered
    from them with ``reduced.npz``'s recovery against the detailed reference (issue 41 item 5)."""
    import dataclasses
    import tempfile
    from pathlib import Path

    from fem2tmm.constants import KELVIN
    from fem2tmm.export.deliverable import network_deck
    from fem2tmm.export.esatan import write_esatan
    from fem2tmm.lpm import read_esatan
    from fem2tmm.pipeline import run
    from fem2tmm.reduce.exported import load
    from fem2tmm.reduce.filters import filter_links

    rows = []
    for n_sn in super_nodes:
        case = Case.from_toml(REPO / "examples" / "composite" / "case.toml")
        parts = tuple(dataclasses.replace(p, super_nodes=n_sn) if p.name == "panels" else p for p in case.parts)
        case = dataclasses.replace(case, parts=parts)
        with tempfile.TemporaryDirectory(prefix="fem2tmm-filter-") as tmp:
            res = run(case, out=Path(tmp) / "out", quiet=True)
            rec = load(Path(tmp) / "out" / "reduced.npz")
            deck = network_deck(res)
            names = [str(x) for x in res.reduced.network.names]
            Td = res.detailed.solution.T
            K = -deck.GL.copy()
            np.fill_diagonal(K, -deck.GL.sum(axis=1))
            for f in FILTERS:
                Kf, rep = filter_links(K, f) if f > 0 else (K, {})
                GL = -Kf
                np.fill_diagonal(GL, 0.0)
                path = Path(tmp) / f"filter_{f:g}.esatan"
                counts = write_esatan(path, dataclasses.replace(deck, GL=GL))
                net = read_esatan(path)
                sol = solve_network(net)
                by = dict(zip([str(x) for x in net.labels], sol.T))
                T_sn = np.array([by[nm] for nm in names])
                e = rec.recover(T_sn, T0=res.reduced.T_recovered) - Td
                rows.append({"bench": "link_filter", "case": "examples/composite/case.toml", "super_nodes": n_sn,
                             "filter": f, "GL": counts["GL"], "negative_GL": counts["negative_GL"],
                             "sn_change_max_K": round(float(np.abs(T_sn - res.reduced.solution.T).max()), 4),
                             "field_rms_K": round(float(np.sqrt(np.mean(e**2))), 4),
                             "field_max_K": round(float(np.abs(e).max()), 4),
                             "max_relative_removed": rep.get("max_relative_removed", 0.0)})
    return rows


__all__ = ["bench_link_filter", "bench_network", "bench_network_positive", "network_from_model"]
