"""The run summary: the ``summary.json`` dict (:func:`build_summary`) and the plain-text table the command
line prints from it (:func:`summary_table`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._version import __version__
from ..constants import KELVIN
from ..reduce.network import conductive_links
from .orbit import orbit_summary

if TYPE_CHECKING:
    from ..result import Result


def build_summary(result: Result, timings: dict[str, float]) -> dict:
    """The ``summary.json`` dict of a run (plain JSON types) from its :class:`~fem2tmm.result.Result` and the
    stage timings (s)."""
    case, mesh, model = result.case, result.mesh, result.model
    detailed = result.detailed
    T = result.T_detailed_nodes
    fixed_heat = {}
    if detailed is not None:
        for g in model.fixed:
            fixed_heat[g.name] = float(detailed.heat_fixed[g.dof])
    s = {
        "version": __version__,
        "case": case.source,
        "mesh": {"file": str(case.mesh.file) if case.mesh.file else mesh.source, "nodes": int(mesh.n_nodes),
                 "elements": int(mesh.n_elements), "model_nodes": int(np.sum(model.node_dof >= 0)),
                 "dofs": int(model.n_dof), "thermal_elements": int(len(model.elements)),
                 "radiating_faces": int(model.faces.n)},
        "reduced": None,
        "radiation": _radiation_summary(result),
        "accuracy": {"rms_K": None, "max_K": None},
        "detailed": None if detailed is None else {
            "iterations": detailed.iterations,
            "T_min_C": float(np.nanmin(T) - KELVIN), "T_max_C": float(np.nanmax(T) - KELVIN),
            "heat_into_fixed_W": fixed_heat, "loads_W": dict(model.loads),
            "to_space_W": float(detailed.to_space.sum()),
        },
        "energy_balance_W": {"reduced": None, "detailed": None if detailed is None else detailed.balance},
        "solar": _solar_summary(result),
        "orbit": orbit_summary(result),
        "quadrics": result.quadrics,
        "timings_s": dict(timings),
    }
    rm, rs = result.reduced, result.reduced_solution
    if rm is not None:
        n_links_space = int(np.count_nonzero(rm.g_space > 0))
        s["reduced"] = {
            "super_nodes": int(np.count_nonzero(rm.kind == "cluster")),
            "boundary_nodes": int(np.count_nonzero(rm.kind == "boundary")),
            "kept_nodes": int(np.count_nonzero(rm.kind == "kept")),
            "super_faces": int(result.super_faces_count if result.super_faces_count is not None
                                else np.count_nonzero(rm.area > 0)),
            "conductive_links": conductive_links(rm.K),
            "radiative_links": n_links_space + (0 if rm.GR is None else conductive_links(rm.GR)),
            "negative_links": rm.report.get("negative_links", 0),
            "method": rm.report.get("method"),
            "filter": rm.report.get("filter"),
            "clustering": result.clustering.report if result.clustering is not None else None,
            "iterations": rs.iterations,
            "heat_into_fixed_W": {str(rm.names[i]): float(rs.heat_fixed[i]) for i in np.flatnonzero(rm.fixed)},
            "to_space_W": float(rs.to_space.sum()),
        }
        s["energy_balance_W"]["reduced"] = rs.balance
        if detailed is not None:
            ok = model.node_dof >= 0
            err = (model.node_temperatures(result.T_recovered) - T)[ok]
            s["accuracy"] = {"rms_K": float(np.sqrt(np.mean(err**2))), "max_K": float(np.abs(err).max()),
                             "nodes": int(ok.sum())}
    return s


def _radiation_summary(result: Result) -> dict:
    def one(res):
        return {"rays": int(np.sum(res.rays)), "lse_rms": float(res.lse_rms), "kappa": res.kappa,
                "groups": int(res.n_groups), "links": int(res.GR.nnz), "segments": int(res.segments),
                "capped_energy_fraction": float(res.capped_energy_fraction),
                "blocked_fraction": float(res.blocked_fraction), "engine": res.engine, "sampling": res.sampling}

    r, d = result.radiation, result.radiation_detailed
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


def _solar_summary(result: Result) -> dict | None:
    def one(r):
        return {"absorbed_W": float(r.absorbed), "incident_W": float(r.incident), "shadowed_W": float(r.shadowed),
                "escaped_W": float(r.escaped), "blocked_W": float(r.blocked), "capped_W": float(r.capped),
                "rays": int(r.rays)}

    d, sf = result.solar_detailed, result.solar_super_faces
    if d is None and sf is None:
        return None
    out = {"solar_on": result.solar_on or "detailed"}
    if d is not None:
        out["detailed_mesh"] = one(d)
    if sf is not None:
        out["super_faces"] = one(sf)
    return out


def summary_table(s: dict) -> str:
    rows = [("mesh", f"{s['mesh']['nodes']} nodes, {s['mesh']['elements']} elements")]
    red = s.get("reduced")
    if red:
        rows.append(("reduced model", f"{red['super_nodes']} super nodes + {red['boundary_nodes']} boundary nodes, "
                     f"{red['conductive_links']} GL ({red['negative_links']} negative), {red['radiative_links']} GR"))
    rad = s.get("radiation") or {}
    if rad.get("rays"):
        rows.append(("radiation", f"{rad['rays']:,} rays, RMS line-sum error {rad['lse_rms']:.2e}"))
    det = s.get("detailed")
    if det:
        rows.append(("detailed T", f"{det['T_min_C']:.3f} .. {det['T_max_C']:.3f} °C"))
    acc = s.get("accuracy") or {}
    if acc.get("rms_K") is not None:
        rows.append(("reduced vs detailed", f"RMS {acc['rms_K']:.4f} K, max {acc['max_K']:.4f} K"))
    eb = s.get("energy_balance_W") or {}
    for k in ("detailed", "reduced"):
        if eb.get(k):
            rows.append((f"energy balance ({k})", f"{eb[k]['imbalance_W']:.3e} W (relative {eb[k]['relative']:.1e})"))
    t = s.get("timings_s") or {}
    if t:
        rows.append(("time", ", ".join(f"{k} {v:.2f} s" for k, v in t.items())))
    w = max(len(r[0]) for r in rows)
    return "\n".join(f"  {a.ljust(w)}  {b}" for a, b in rows)
