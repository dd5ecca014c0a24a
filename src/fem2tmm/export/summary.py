"""The run summary: the ``summary.json`` dict (:func:`build_summary`) and the plain-text table the command
line prints from it (:func:`summary_table`)."""

from __future__ import annotations

import numpy as np

from ..arrays import unique
from .._version import __version__
from ..constants import KELVIN
from ..reduce.network import conductive_links
from ..result import Result
from .heatflow import by_correction as _by_correction, heat_flow_rows, heat_flow_summary, network_radiated_W
from .orbit import orbit_summary


#: the stages that make the reduced network (the measured choice's cost is stated against their time; the
#: "estimate" stage itself and the detailed reference are not among them)
REDUCTION_STAGES = ("cluster", "reduce", "radiation", "solve_reduced", "recover", "presolve_space", "ir_detailed",
                    "radiation_aware", "recovery")

#: a range record's deck units as the tables print them
UNIT_TEXT = {"degC": "°C", "W/m2": "W/m²"}


def count_of(k: int, noun: str) -> str:
    """``"1 boundary node"``, ``"2 boundary nodes"``."""
    return f"{k} {noun}{'' if k == 1 else 's'}"


def build_summary(result: Result, timings: dict[str, float]) -> dict:
    """The ``summary.json`` dict of a run (plain JSON types) from its :class:`~fem2tmm.result.Result` and the
    stage timings (s)."""
    case, mesh, model = result.case, result.mesh, result.model
    detailed = result.detailed.solution
    T = result.T_detailed_nodes
    fixed_heat = {}  # heat flowing INTO each fixed-temperature boundary (SteadySolution.heat_fixed: out of it)
    if detailed is not None:
        for g in model.fixed:
            fixed_heat[g.name] = -float(detailed.heat_fixed[g.dof])
    s = {
        "version": __version__,
        "case": case.source,
        "load_case": case.name or None,  # the [[cases]] name in a multi-case run
        "mesh": {"file": str(case.mesh.file) if case.mesh.file else mesh.source, "nodes": int(mesh.n_nodes),
                 "elements": int(mesh.n_elements), "model_nodes": int(np.sum(model.node_dof >= 0)),
                 "dofs": int(model.n_dof), "thermal_elements": int(len(model.elements)),
                 "radiating_faces": int(model.faces.n),
                 "ignored_cards": dict((mesh.cards or {}).get("ignored", {})),
                 "modelled_cards": dict((mesh.cards or {}).get("modelled", {})),
                 "joints": dict(model.joints)},
        "reduced": None,
        "radiation": _radiation_summary(result),
        "accuracy": {"rms_K": None, "max_K": None},
        "detailed": None if detailed is None else {
            "iterations": detailed.iterations, "stopped_on": detailed.stats.get("stopped_on"),
            "T_min_C": float(np.nanmin(T) - KELVIN), "T_max_C": float(np.nanmax(T) - KELVIN),
            "heat_into_fixed_W": fixed_heat, "loads_W": dict(model.loads),
            "to_space_W": float(detailed.to_space.sum()),
        },
        "temperatures_C": _temperatures(result),
        "loads_W": {"boundaries": dict(model.loads), "absorbed_solar": _absorbed_solar(result)},
        "energy_balance_W": {"reduced": None, "detailed": None if detailed is None else detailed.balance},
        "solar": _solar_summary(result),
        "orbit": orbit_summary(result),
        "quadrics": result.quadrics,
        "cache": result.cache,
        "timings_s": dict(timings),
        "transient": None,
    }
    if result.transient is not None:
        from .transient import transient_summary

        s["transient"] = transient_summary(result)
    red = result.reduced
    if red is not None:
        rm, rs = red.network, red.solution
        n_links_space = int(np.count_nonzero(rm.g_space > 0))
        by_correction = _by_correction(rm)
        s["reduced"] = {
            "super_nodes": int(np.count_nonzero(rm.kind == "cluster")),
            "boundary_nodes": int(np.count_nonzero(rm.kind == "boundary")),
            "kept_nodes": int(np.count_nonzero(rm.kind == "kept")),
            "super_faces": int(result.reduced.super_faces_count if result.reduced.super_faces_count is not None
                                else np.count_nonzero(rm.area > 0)),
            "conductive_links": conductive_links(rm.K),
            "radiative_links": n_links_space + (0 if rm.GR is None else conductive_links(rm.GR)),
            "negative_links": rm.report.get("negative_links", 0),
            "method": rm.report.get("method"),
            # which reduction ran ([reduction] radiation_aware / [radiation] ir_on, "auto" resolved, and why)
            "reductor": result.reduced.method,
            "choice": result.reduced.choice,
            "filter": rm.report.get("filter"),
            "clustering": result.reduced.clustering.report if result.reduced.clustering is not None else None,
            "iterations": rs.iterations,
            "heat_into_fixed_W": {str(rm.names[i]): -float(rs.heat_fixed[i]) for i in np.flatnonzero(rm.fixed)},
            "to_space_W": float(rs.to_space.sum()) + rm.hot_spot_W,
            # the network's radiation to space (couplings and correction) against the traced emission to space of
            # its recovered field (relative difference), and each part's emission share stopped by inactive sides
            "emission_check": result.reduced.emission_check,
            "radiation_aware": None if rm.radiative is None else {
                "outer_iterations": result.reduced.outer_iterations,
                "last_step_K": (result.reduced.outer_iterations or [{}])[-1].get("max_dT_K"),
                "H_W_per_K": float(rm.radiative.H[~rm.fixed].sum()),
                # the heat radiated outside the couplings to space (by the correction load and the distribution
                # with K' = K + diag(h): the known loads minus the network's Q), and the total heat radiated
                "radiated_by_correction_W": by_correction,
                "radiated_W": None if by_correction is None and rm.hot_spots is None else network_radiated_W(rm, rs),
                # the loads' hot-spot nodes (fem2tmm.reduce.radiative.HotSpots): W each applies and radiates
                "hot_spots_W": None if rm.hot_spots is None else dict(zip(rm.hot_spots.labels(),
                                                                          map(float, rm.hot_spots.Q))),
                "biot": (result.reduced.outer_iterations or [{}])[-1].get("biot"),
                # load-case sets: the cases whose decks share GL, GR and C (emission linearised once, about the
                # converged field of case `linearised_at`); None: this case's own network
                "shared_network": result.reduced.shared_network,
                "note": "K = K'_SN - diag(H_SN) of K' = K + diag(4 sigma eps A T_ref^3); Q includes the correction "
                        "load Q_corr at the last reference state (fem2tmm.reduce.radiative)"},
            "refinement": None if result.reduced.refinement is None else {
                "target_rms_K": result.case.reduction.target_rms, "stop": result.reduced.refinement.stop,
                "rounds": result.reduced.refinement.history, "estimator": result.case.reduction.refine_estimator,
                "note": "estimated RMS of the recovered field: the residual under the true loads (FE faces emitting at "
                        "their own temperatures) solved on the detailed mesh, linearised (fem2tmm.reduce.refine); the "
                        "final round's partition is the one solved and compared"},
        }
        s["energy_balance_W"]["reduced"] = rs.balance
        if red.parametric is not None:  # the states the deck's correction follows
            s["reduced"]["parametric"] = parametric_summary(result)
        ch = red.choice or {}
        if ch.get("estimate_seconds") is not None and timings:  # the measured choice's cost (issue 42: <= 20 %)
            stages = sum(timings.get(k, 0.0) for k in REDUCTION_STAGES)
            # without the detailed reference the range's choices rest on estimates too (stages estimate_range and,
            # where the floor's candidates were estimated, verify_floor): the whole measured choice's cost beside it
            ranged = timings.get("estimate_range", 0.0) + (timings.get("verify_floor", 0.0)
                                                           if (ch.get("floor") or {}).get("by") == "estimate" else 0.0)
            # a reduction stage reused from the stage cache costs nothing here: no share of its time is stated
            reused = sorted(k for k, v in (result.cache or {}).items()
                            if v == "reused" and k.rsplit("/", 1)[-1] in REDUCTION_STAGES)
            s["reduced"]["choice"] = {**ch, "reduction_seconds": stages, "reduction_reused": reused,
                                      "estimate_cost_fraction": None if reused
                                      else ch["estimate_seconds"] / max(stages, 1e-9),
                                      "range_estimate_seconds": ranged,
                                      "estimate_total_cost_fraction": None if reused
                                      else (ch["estimate_seconds"] + ranged) / max(stages, 1e-9)}
        if red.verified is not None:  # the validity range (fem2tmm.verify) and its cost within the run
            s["reduced"]["verified"] = dict(red.verified)
            if red.verified.get("seconds") is not None and timings:
                s["reduced"]["verified"]["cost_fraction"] = red.verified["seconds"] / max(sum(timings.values()), 1e-9)
        if result.reduced.delivered is not None:
            s["reduced"]["delivered"] = {k: result.reduced.delivered.get(k) for k in ("npz_vs_in_process_K",
                                                                                "esatan_vs_in_process_K",
                                                                                "esatan_compared", "error")}
        if detailed is not None:
            ok = model.node_dof >= 0

            def accuracy(T_rec: np.ndarray) -> dict:
                err = (model.node_temperatures(T_rec) - T)[ok]
                return {"rms_K": float(np.sqrt(np.mean(err**2))), "max_K": float(np.abs(err).max()),
                        "nodes": int(ok.sum())}

            dv = result.reduced.delivered
            delivered = dv is not None and dv.get("T") is not None
            # what the user receives: the network written, read back (reduced.npz), solved, recovered with the
            # recovery read from reduced.npz (fem2tmm.export.deliverable); the in-process model's figure beside it
            s["accuracy"] = accuracy(dv["T"] if delivered else result.reduced.T_recovered)
            s["accuracy"]["of"] = "the exported network" if delivered else "the in-process model"
            s["accuracy"]["in_process"] = accuracy(result.reduced.T_recovered)
            if result.reduced.thesis_T_recovered is not None:
                s["accuracy"]["thesis_method"] = accuracy(result.reduced.thesis_T_recovered)
            s["accuracy"].update(_honesty(result))
    # every input and output named, steady (or orbit-averaged) and transient, and per part (fem2tmm.export.heatflow)
    s["heat_flows"] = heat_flow_summary(result)
    if red is not None and red.positive is not None:
        s["positive_network"] = dict(result.reduced.positive)
        if detailed is not None and result.reduced.T_recovered_exact is not None:
            ok = model.node_dof >= 0
            e = (model.node_temperatures(result.reduced.T_recovered_exact) - T)[ok]
            exact = {"rms": float(np.sqrt(np.mean(e**2))), "max": float(np.abs(e).max())}
            pos = {"rms": s["accuracy"]["rms_K"], "max": s["accuracy"]["max_K"]}
            s["positive_network"]["recovered_error_K"] = {
                "positive": pos, "exact": exact,
                "ratio_rms": pos["rms"] / exact["rms"] if exact["rms"] > 0 else None}
    return s


def part_node_sets(model) -> list[np.ndarray]:
    """The mesh node indices of each part's thermal elements (one sorted array per part)."""
    cells = model.element_cells
    n = model.mesh.n_nodes
    part = np.broadcast_to(model.element_part[:, None], cells.shape)
    ok = cells >= 0
    key = unique(part[ok].astype(np.int64) * n + cells[ok])
    bounds = np.searchsorted(key, np.arange(len(model.parts) + 1, dtype=np.int64) * n)
    return [key[bounds[p]:bounds[p + 1]] - p * n for p in range(len(model.parts))]


def _stats(T_nodes_K: np.ndarray, sets: list[np.ndarray], names: list[str]) -> dict:
    out = {}
    for name, nodes in zip(names, sets):
        t = T_nodes_K[nodes] - KELVIN
        t = t[np.isfinite(t)]
        out[name] = ({"min": float(t.min()), "mean": float(t.mean()), "max": float(t.max())} if t.size
                     else {"min": None, "mean": None, "max": None})
    return out


def parametric_summary(result: Result) -> dict:
    """``reduced.parametric`` of summary.json: the states the deck's correction load follows (case units)."""
    par = result.reduced.parametric
    celsius = {b.name for b in result.case.boundaries if b.kind == "temperature"} | {"sink"}
    return {"values": {n: [float(v - (KELVIN if n in celsius else 0.0)) for v in vals]
                       for n, vals in zip(par["names"], par["values"])},
            "units": {n: ("degC" if n in celsius else "case units (W or W/m2)") for n in par["names"]},
            "largest_correction_change_W": {n: float(np.abs(d).sum(axis=1).max())
                                            for n, d in zip(par["names"], par["dQ"])},
            "gl_relative_change": par["gl_change"], "from": par.get("from", "[reduction] parametric")}


def _temperatures(result: Result) -> dict:
    """``temperatures_C``: the result temperatures per part (min / mean over its nodes / max, °C) — recovered
    from the reduced model when there is one, the detailed solution otherwise — the detailed reference's per part
    when both ran, and each reduced node's temperature."""
    model = result.model
    sets = part_node_sets(model)
    names = [p.name for p in model.parts]
    reduced = result.reduced is not None
    out = {"source": "recovered from the reduced model" if reduced else "detailed model",
           "parts": _stats(result.T_nodes, sets, names), "reference": None, "super_nodes": None}
    if reduced and result.detailed.solution is not None:
        out["reference"] = {"source": "detailed model", "parts": _stats(result.T_detailed_nodes, sets, names)}
    if reduced:
        out["super_nodes"] = {str(k): float(t - KELVIN) for k, t in zip(result.reduced.network.names,
                                                                          result.reduced.solution.T)}
    return out


def _absorbed_solar(result: Result) -> float | None:
    """Absorbed solar power (W) the result model received: the super faces' when traced there, else the detailed
    mesh's; None without a Sun."""
    r = None if result.reduced is None else result.reduced.solar
    r = r if r is not None else result.detailed.solar
    return None if r is None else float(r.absorbed)


def build_cases_summary(multi, compute: dict, total_s: float) -> dict:
    """The top ``summary.json`` of a multi-case run (:class:`~fem2tmm.result.CasesResult`): one row per case
    (its folder, sweep parameters, temperature range, per-part ranges, accuracy, cache use, time) and the
    envelope over the cases (:mod:`fem2tmm.export.envelope`; None when the cases do not share one mesh)."""
    from .envelope import envelope, envelope_summary

    rows = []
    for name, r in multi.results.items():
        s = r.summary
        T = r.T_nodes
        rows.append({"name": name, "folder": name, "parameters": multi.parameters.get(name, {}),
                     "T_min_C": float(np.nanmin(T) - KELVIN), "T_max_C": float(np.nanmax(T) - KELVIN),
                     "parts": s["temperatures_C"]["parts"], "accuracy": s["accuracy"], "cache": s.get("cache"),
                     "time_s": float(sum(s["timings_s"].values()))})
    names = list(multi.results)
    env = same_mesh_envelope(multi)
    return {"version": __version__, "case": multi.case.source, "cases": rows, "compute": compute,
            "envelope": None if env is None else envelope_summary(envelope(env), names),
            "timings_s": {"total": total_s}}


def same_mesh_envelope(multi) -> np.ndarray | None:
    """(k, n_nodes) node temperatures K of the cases when they share one mesh (same node ids), else None."""
    results = list(multi.results.values())
    ids = results[0].mesh.node_ids
    if any(r.mesh is not results[0].mesh and not np.array_equal(r.mesh.node_ids, ids) for r in results):
        return None
    return np.stack([r.T_nodes for r in results])


def cases_table(s: dict) -> str:
    """Plain-text table of a multi-case summary: one row per case (range, hottest part, cache use)."""
    rows = [("case", "T min °C", "T max °C", "hottest part", "reused stages")]
    for c in s["cases"]:
        parts = {k: v for k, v in c["parts"].items() if v["max"] is not None}
        hot = max(parts, key=lambda k: parts[k]["max"]) if parts else "-"
        reused = [k for k, v in (c.get("cache") or {}).items() if v == "reused"]
        rows.append((c["name"], f"{c['T_min_C']:.3f}", f"{c['T_max_C']:.3f}", hot, ", ".join(reused) or "-"))
    env = s.get("envelope")
    if env:
        rows.append(("envelope", f"{env['T_min_C']:.3f}", f"{env['T_max_C']:.3f}", "", ""))
    w = [max(len(r[i]) for r in rows) for i in range(5)]
    return "\n".join("  " + "  ".join(x.ljust(w[i]) for i, x in enumerate(r)).rstrip() for r in rows)


def _radiation_summary(result: Result) -> dict:
    def one(res):
        return {"rays": int(np.sum(res.rays)), "lse_rms": float(res.lse_rms), "kappa": res.kappa,
                "groups": int(res.n_groups), "links": int(res.GR.nnz), "segments": int(res.segments),
                "capped_energy_fraction": float(res.capped_energy_fraction),
                "blocked_fraction": float(res.blocked_fraction), "engine": res.engine, "sampling": res.sampling}

    r, d = None if result.reduced is None else result.reduced.radiation, result.detailed.radiation
    if r is None and d is None:
        return {"model": "space only: every active side radiates to the sink (face-to-face REFs not traced)",
                "rays": 0, "lse_rms": None, "kappa": None}
    out = {"model": "face-to-face radiative exchange factors (quasi-Monte Carlo ray tracing)"}
    if r is not None:
        out.update(one(r))
    else:
        out.update({"rays": 0, "lse_rms": None, "kappa": None})
    if d is not None:
        out["detailed"] = one(d)
    return out


def _honesty(result: Result) -> dict:
    """What the accuracy figures mean: the reference's own noise, the share of the heat radiation carries, and
    the error sources the metric cannot see."""
    det = result.detailed.solution
    out_fixed = float(np.clip(-det.heat_fixed, 0, None).sum())  # heat leaving through fixed-temperature nodes
    space = float(det.to_space.sum())
    noise = result.detailed.noise
    excludes = []
    if result.reduced is not None and result.reduced.solar_on == "detailed":
        excludes.append("solar ray noise and shadow resolution: with solar_on = \"detailed\" the reduced model and "
                        "the reference use the same detailed solar loads")
    if noise is None and (result.detailed.radiation is not None or result.detailed.solar is not None):
        excludes.append("the reference's own ray noise (not estimated: [reference] noise = false)")
    return {
        "reference_noise_rms_K": None if noise is None else noise["rms_K"],
        "reference_noise_max_K": None if noise is None else noise["max_K"],
        "reference_noise_method": None if noise is None else
        "two independent half-budget references (own random streams); reference = their mean, noise = (Ta - Tb)/2",
        "radiation_share": space / (space + out_fixed) if space + out_fixed > 0 else None,
        "excludes": excludes,
    }


def _solar_summary(result: Result) -> dict | None:
    def one(r):
        return {"absorbed_W": float(r.absorbed), "incident_W": float(r.incident), "shadowed_W": float(r.shadowed),
                "escaped_W": float(r.escaped), "blocked_W": float(r.blocked), "capped_W": float(r.capped),
                "rays": int(r.rays)}

    d, sf = result.detailed.solar, None if result.reduced is None else result.reduced.solar
    if d is None and sf is None:
        return None
    out = {"solar_on": (result.reduced is not None and result.reduced.solar_on) or "detailed"}
    if d is not None:
        out["detailed_mesh"] = one(d)
    if sf is not None:
        out["super_faces"] = one(sf)
    return out


#: super nodes listed one by one in the terminal table (more: their range, all of them in summary.json)
MAX_LISTED_NODES = 24
#: what negative GL are, said wherever their count is shown
NEGATIVE_GL_NOTE = ("negative GL are positive off-diagonal terms of the exact reduced conduction matrix: they belong "
                    "to the exact reduction (the reduced model reproduces the detailed conduction for any load); "
                    "[reduction] filter removes weak links")


def negative_gl_count(n: int) -> str:
    """'12 negative: exact reduction, keep them' (the terminal's short form of :data:`NEGATIVE_GL_NOTE`, which
    the report and the decks' comment give in full), '0 negative' when there are none."""
    return f"{n} negative: exact reduction, keep them" if n else "0 negative"


def _three(d: dict) -> str:
    return "—" if d.get("min") is None else f"{d['min']:.2f} / {d['mean']:.2f} / {d['max']:.2f} °C"


def temperature_rows(s: dict) -> list[tuple[str, str]]:
    """(label, text) rows of the temperatures: per part min / mean / max (result and reference side by side)
    and per super node."""
    tc = s.get("temperatures_C") or {}
    rows = []
    ref = (tc.get("reference") or {}).get("parts") or {}
    src = "recovered" if tc.get("source", "").startswith("recovered") else "detailed"
    for name, d in (tc.get("parts") or {}).items():
        text = f"{src} {_three(d)}" + (f"  |  detailed {_three(ref[name])}" if name in ref else "")
        rows.append((f"T min/mean/max '{name}'", text))
    sn = tc.get("super_nodes") or {}
    if sn and len(sn) <= MAX_LISTED_NODES:
        items = [f"{k} {v:.2f}" for k, v in sn.items()]
        for k in range(0, len(items), 6):
            rows.append(("T super nodes [°C]" if k == 0 else "", ", ".join(items[k:k + 6])))
    elif sn:
        v = np.array(list(sn.values()))
        rows.append(("T super nodes", f"{len(sn)} nodes from {v.min():.2f} to {v.max():.2f} °C (each in summary.json "
                                      "temperatures_C.super_nodes)"))
    return rows


def refinement_rows(red: dict | None) -> list[tuple[str, str]]:
    """The row of the error-driven refinement's history (``reduced.refinement``), for the terminal and the report."""
    ref = red.get("refinement") if red else None
    if not ref:
        return []
    steps = ", ".join(f"{h['n_super_nodes']} SN {h['estimated_rms_K']:.3g} K" for h in ref["rounds"])
    return [("refinement", f"target {ref['target_rms_K']:g} K ({ref['estimator']} estimator), {ref['stop']}; "
                           f"estimated RMS per round: {steps}")]


def choice_text(choice: dict, short: bool = False) -> str:
    """One line saying which reduction a run used and why (summary.json ``reduced.choice``); ``short`` (the
    terminal): where ``"auto"`` compared both estimates, only those and where the whole reasoning is."""
    method = ("radiation-aware, IR on " + {"faces": "the FE face sides", "detailed": "the FE faces where it lands",
                                           "super_faces": "the super faces"}.get(choice["ir_on"], str(choice["ir_on"]))
              if choice["radiation_aware"] else "the thesis' reduction, uniform load per super node")
    bi = choice.get("biot_cluster_max")
    why = choice["chosen_by"] if bi is None or "Biot" in choice["chosen_by"] else \
        f"{choice['chosen_by']}; largest cluster Biot number {bi:.3g}"
    est = choice.get("estimated_rms_K") or {}
    if short and est.get("thesis") is not None and est.get("radiation_aware") is not None:
        why = (f"auto: estimated error thesis {est['thesis']:.3g} K, radiation-aware {est['radiation_aware']:.3g} K "
               "(why this one: the report, summary.json reduced.choice.chosen_by)")
    return f"{method}; {why}"


def parametric_rows(red: dict | None) -> list[tuple[str, str]]:
    """The terminal / report row of ``[reduction] parametric`` (summary.json ``reduced.parametric``)."""
    par = (red or {}).get("parametric")
    if not par:
        return []
    unit = {n: " °C" if u == "degC" else "" for n, u in par["units"].items()}  # (summary.json keeps "degC")
    what = "; ".join(f"{n} {vals[0]:g}{unit[n]} (design) and {', '.join(format(v, 'g') for v in vals[1:])}{unit[n]}"
                     for n, vals in par["values"].items())
    return [("parametric deck", f"the correction load follows {what} (model.esatan INTRP1 tables)")]


def allocation_rows(red: dict | None) -> list[tuple[str, str]]:
    """The report row of ``[clustering] allocation = "loads"`` where it moved super nodes (summary.json
    ``reduced.clustering.allocation``): which loads drew smaller super nodes around them, and how far."""
    al = ((red or {}).get("clustering") or {}).get("allocation") or {}
    near = {k: v for k, v in al.items() if isinstance(v, dict) and v.get("elements")}
    if al.get("method") != "loads" or not near:
        return []
    what = "; ".join(f"'{k}' ({v['area_m2']:.3g} m², {v['share']:.1%} of its parts): {v['elements']} elements within "
                     f"{100 * v['reach_m']:.3g} cm" for k, v in near.items())
    return [("clusters", f"smaller super nodes around the concentrated loads ([clustering] allocation = \"loads\"): "
                         f"{what}: a region of their own, weighted more per area (docs/case-file.md)")]


def verified_rows(red: dict | None) -> list[tuple[str, str]]:
    """The terminal / report row of the validity range (summary.json ``reduced.verified``): its worst verified
    state beside the design state's error and the reference noise, or why it is unverified."""
    v = (red or {}).get("verified")
    if not v:
        return []
    if v["status"] == "UNVERIFIED":
        rows = [("validity range", f"UNVERIFIED ({v['reason']})")]
        est = v.get("estimated")
        if est and est.get("worst") is not None:  # estimated where a choice rested on it (fem2tmm.range_checks)
            w = est["worst"]
            rows.append(("range, estimated", f"{len(est['states'])} states, a-posteriori (not verified): worst "
                         f"'{w['label']}' RMS {w['rms_K']:.3g} K, max {w['max_K']:.3g} K (design RMS "
                         f"{est['design']['rms_K']:.3g} K; {est['seconds']:.1f} s)"))
            rows += _range_pairs(red)
        return rows
    rng = "; ".join(f"{r['name']} {r['low']:.4g}..{r['high']:.4g} {UNIT_TEXT.get(r['unit'], r['unit'])}"
                    for r in v["range"])
    d, w, n = v["design"], v["worst"], v.get("reference_noise")
    text = f"{len(v['states'])} states over {rng or 'the design state only'}: "
    text += (f"worst '{w['label']}' RMS {w['rms_K']:.3g} K, max {w['max_K']:.3g} K" if w else "no state solved")
    text += f" (design RMS {d['rms_K']:.3g} K, max {d['max_K']:.3g} K"
    text += "" if n is None else f"; reference noise RMS {n['rms_K']:.2g} K"
    frac = v.get("cost_fraction")
    text += f"; {v['seconds']:.1f} s" + ("" if frac is None else f", {100 * frac:.0f} % of the run") + ")"
    rows = [("validity range", text)]
    if v["flagged"] or v["failed"]:
        rows.append(("", "WARNING: " + "; ".join(x for x in (
            v["flagged"] and f"above {v['threshold']['factor']:g} x the design error at {', '.join(v['flagged'])}",
            v["failed"] and f"no solution at {', '.join(v['failed'])}") if x)))
    return rows + _range_pairs(red)


def _range_pairs(red: dict) -> list[tuple[str, str]]:
    """Both networks over the same range (fem2tmm.verify.range_choice): the figures the choice rests on."""
    rc = (red.get("choice") or {}).get("verified_range")
    if not rc or not rc.get("checked", True):
        return []
    fmt = lambda x: "no solution" if x is None else f"{x:.3g}"  # noqa: E731
    pairs = "; ".join(f"{k} {fmt(a)} / {fmt(b)}" for k, (a, b) in rc["states_K"].items())
    what = "estimated RMS K" if rc.get("by") == "estimate" else "RMS K"
    return [("range, both networks", f"{what} radiation-aware / thesis: {pairs}; handed over: "
             + ("the thesis' network" if rc["thesis"] else "the radiation-aware network"))]


def summary_table(s: dict) -> str:
    """The plain-text table the command line prints after a run, from the ``summary.json`` dict."""
    rows = [("mesh", f"{s['mesh']['nodes']} nodes, {s['mesh']['elements']} elements")]
    red = s.get("reduced")
    if red:
        rows.append(("reduced model", f"{red['super_nodes']} super nodes + "
                     f"{count_of(red['boundary_nodes'], 'boundary node')}, "
                     f"{red['conductive_links']} GL ({negative_gl_count(red['negative_links'])}), "
                     f"{red['radiative_links']} GR"))
        if red.get("choice"):
            rows.append(("reduction", choice_text(red["choice"], short=True)))
        rows += parametric_rows(red)
    pn = s.get("positive_network")
    if pn:
        err = pn.get("recovered_error_K")
        vs = "" if not err else (f"; recovered RMS {err['positive']['rms']:.4f} K vs {err['exact']['rms']:.4f} K "
                                 "exact")
        vs_exact = ("the exact reduction has no physical steady solution" if pn["T_vs_exact_K"] is None else
                    f"max {pn['T_vs_exact_K']['max']:.3g} K from the exact reduction, criteria "
                    f"{'met' if pn['criteria']['met'] else 'NOT met'}")
        rows.append(("positive network", f"{pn['links']} GL > 0 between touching super nodes (exact: "
                     f"{pn['exact_negative_links']} negative of {pn['exact_links']}), {vs_exact}{vs}"))
    rows += refinement_rows(red)
    rad = s.get("radiation") or {}
    if rad.get("rays"):
        rows.append(("radiation", f"{rad['rays']:,} rays, RMS line-sum error {rad['lse_rms']:.2e}"))
    chk = (red or {}).get("emission_check")
    if chk:
        rows.append(("emission to space", f"network {chk['network_W']:.4g} W, its recovered field {chk['traced_W']:.4g} "
                     f"W traced ({100 * chk['relative']:.2g} % apart)"))
        blocked = {k: v for k, v in (chk.get("blocked_by_part") or {}).items() if v > 0}
        if blocked:
            rows.append(("blocked by inactive sides", ", ".join(f"{k} {100 * v:.3g} %" for k, v in blocked.items())
                         + " of the part's emission (never emitted)"))
    rows += temperature_rows(s)
    acc = s.get("accuracy") or {}
    if acc.get("rms_K") is not None:
        noise = acc.get("reference_noise_rms_K")
        beside = "" if noise is None else f" (reference noise RMS {noise:.2g} K)"
        rows.append(("reduced vs detailed", f"RMS {acc['rms_K']:.4f} K, max {acc['max_K']:.4f} K{beside}"))
        if acc.get("thesis_method"):
            th = acc["thesis_method"]
            rows.append(("thesis' reduction", f"RMS {th['rms_K']:.4f} K, max {th['max_K']:.4f} K (the pre-solve)"))
        if acc.get("radiation_share") is not None:
            rows.append(("heat out by radiation", f"{100 * acc['radiation_share']:.1f} % (detailed model)"))
        for e in acc.get("excludes") or ():
            rows.append(("not in the error", e))
    rows += verified_rows(red)
    det = s.get("detailed") or {}
    loads = s.get("loads_W") or {}
    for name, w in (loads.get("boundaries") or {}).items():
        rows.append((f"load '{name}'", f"{w:.4g} W"))
    if loads.get("absorbed_solar") is not None:
        rows.append(("absorbed solar", f"{loads['absorbed_solar']:.4g} W"))
    for label, flows in (("reduced", (red or {}).get("heat_into_fixed_W")), ("detailed", det.get("heat_into_fixed_W"))):
        for name, w in (flows or {}).items():
            rows.append((f"into fixed '{name}' ({label})", f"{w:+.4g} W"))
    eb = s.get("energy_balance_W") or {}
    for k in ("detailed", "reduced"):
        if eb.get(k):
            rows.append((f"energy balance ({k})", f"{eb[k]['imbalance_W']:.3e} W (relative {eb[k]['relative']:.1e})"))
    rows += heat_flow_rows(s, "steady")
    tr = s.get("transient") or {}
    if tr:
        rows.append(("transient", f"{tr['method']}, {tr['start_s']:g} to {tr['end_s']:g} s, {len(tr['times_s'])} output "
                     "times" + (f", periodic after {tr['periods']} periods" if tr.get("periods") else "")))
        t_acc = tr.get("accuracy") or {}
        if t_acc:
            rows.append(("transient: reduced vs detailed", f"RMS {t_acc['rms_K']:.4f} K, max {t_acc['max_K']:.4f} K at "
                         f"t = {t_acc['time_of_max_s']:g} s (over space and time)"))
        for k, e in (tr.get("energy_balance") or {}).items():
            rows.append((f"transient energy ({k})", f"stored {e['stored_J']:.4g} J, imbalance {e['imbalance_J']:.2e} J "
                         f"(relative {e['relative']:.1e})"))
    rows += heat_flow_rows(s, "transient")
    t = s.get("timings_s") or {}
    if t:
        rows.append(("time", ", ".join(f"{k} {v:.2f} s" for k, v in t.items())))
    w = max(len(r[0]) for r in rows)
    return "\n".join(f"  {a.ljust(w)}  {b}" for a, b in rows)
