"""Plain-text summary table printed by the command line."""

from __future__ import annotations


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
