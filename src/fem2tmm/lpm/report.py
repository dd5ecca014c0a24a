"""``report.html`` of ``fem2tmm network reduce``: the (p_f, ΔT_max) reduction-ratio map with pass/fail, reduced
against detailed temperatures and boundary heat flows per load case (PNG images, opens offline)."""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ..constants import KELVIN
from ..export.report import _table


def sweep_map(path: Path, sw, chosen: tuple | None = None) -> None:
    """Reduction ratio r_r over the (p_f, ΔT_max) grid (log axes), passing pairs as dots, failing ones as crosses,
    the chosen pair as a star."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 5.2), dpi=110)
    P, D = np.meshgrid(sw.pf, sw.dtmax, indexing="ij")
    if len(sw.pf) > 1 and len(sw.dtmax) > 1:
        im = ax.pcolormesh(P, D, sw.ratio, shading="nearest", cmap="viridis", vmin=0.0, vmax=1.0)
        cs = ax.contour(P, D, sw.ratio, levels=[0.25, 0.5, 0.75, 0.9], colors="k", linewidths=0.7)
        ax.clabel(cs, fmt="%.2f", fontsize=7)
    else:
        im = ax.scatter(P.ravel(), D.ravel(), c=sw.ratio.ravel(), cmap="viridis", vmin=0.0, vmax=1.0, s=80)
    fig.colorbar(im, ax=ax, label="reduction ratio r_r")
    ok = sw.passed
    ax.scatter(P[ok], D[ok], marker="o", s=14, facecolor="white", edgecolor="k", label="criteria met")
    ax.scatter(P[~ok], D[~ok], marker="x", s=18, color="tab:red", label="criteria failed")
    if chosen is not None and chosen[0] is not None:
        ax.scatter([chosen[0]], [chosen[1]], marker="*", s=220, color="gold", edgecolor="k", label="chosen", zorder=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("conductance filter p_f")
    ax.set_ylabel("temperature filter ΔT_max [K]")
    ax.set_title("Reduction ratio and acceptance (all load cases)")
    ax.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def temperature_plot(path: Path, target: np.ndarray, reduced: np.ndarray, boundary: np.ndarray, title: str) -> None:
    """Reduced against detailed (capacitance-weighted) temperature of every reduced node, °C, with the 1:1 line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.6, 5.0), dpi=110)
    t, r = target - KELVIN, reduced - KELVIN
    lo, hi = float(min(t.min(), r.min())), float(max(t.max(), r.max()))
    ax.plot([lo, hi], [lo, hi], color="0.6", lw=1)
    ax.scatter(t[~boundary], r[~boundary], s=14, label="reduced nodes")
    ax.scatter(t[boundary], r[boundary], s=30, marker="s", label="boundary nodes")
    ax.set_xlabel("detailed (capacitance-weighted) [°C]")
    ax.set_ylabel("reduced [°C]")
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_report(folder: Path, res, summary: dict) -> list[str]:
    """Write ``report.html`` and its images into ``folder``; returns the image names."""
    folder = Path(folder)
    images = []
    if res.sweep is not None:
        sweep_map(folder / "sweep.png", res.sweep, (res.pf, res.dtmax))
        images.append(("sweep.png", "Reduction ratio over (p_f, ΔT_max); dots: all criteria met in every load case"))
    sections = []
    red = res.reduced
    for k, (case, chk) in enumerate(zip(res.cases, res.checks)):
        name = f"temperatures_{k + 1}.png"
        temperature_plot(folder / name, chk.T_target, chk.T_reduced, red.boundary, f"Load case {case.name}")
        images.append((name, f"Reduced against detailed temperatures, load case {case.name}"))
        rows = [(int(red.numbers[i]), str(red.labels[i]), f"{chk.T_target[i] - KELVIN:.3f}",
                 f"{chk.T_reduced[i] - KELVIN:.3f}", f"{chk.delta[i]:.3f}") for i in range(red.n)]
        flows = []
        for b, hcd, hcr, hrd, hrr in zip(chk.boundary, chk.Hc_detailed, chk.Hc_reduced, chk.Hr_detailed,
                                         chk.Hr_reduced):
            flows.append((int(red.numbers[b]), str(red.labels[b]), f"{hcd:.4g}", f"{hcr:.4g}", f"{hrd:.4g}",
                          f"{hrr:.4g}"))
        verdict = "met" if chk.passed else "NOT met"
        sections.append(
            f"<h2>Load case {html.escape(case.name)}: criteria {verdict}</h2>"
            f"<h3>Boundary heat flows (W, into the boundary)</h3>"
            + _table(flows, ("node", "label", "conductive detailed", "conductive reduced", "radiative detailed",
                             "radiative reduced"))
            + "<h3>Temperatures (°C)</h3>"
            + (_table(rows, ("node", "label", "detailed (weighted)", "reduced", "δ [K]")) if red.n <= 2000 else
               f"<p>{red.n} reduced nodes: see summary.json</p>"))
    s = summary
    head = [("deck", s["deck"]), ("method", s["method"]),
            ("nodes", f"{s['nodes']['detailed']} detailed ({s['nodes']['boundary']} boundary) -> "
                      f"{s['nodes']['reduced']} reduced"),
            ("reduction ratio r_r", f"{s['ratio']:.3f}"),
            ("thresholds", f"p_f = {s['thresholds']['pf']}, ΔT_max = {s['thresholds']['dtmax_K']} K"),
            ("criteria", f"δ_max = {s['criteria']['delta_max_K']} K; q_max = {s['criteria']['q_max_W']} W below "
                         f"q_lim = {s['criteria']['q_lim_W']} W, {100 * s['criteria']['q_rel_max']:.3g} % above: "
                         f"{'met' if s['criteria']['met'] else 'NOT met'}")]
    figs = "".join(f'<figure><img src="{n}" alt="{html.escape(c)}"><figcaption>{html.escape(c)}</figcaption>'
                   f"</figure>" for n, c in images)
    small = {k: v for k, v in s.items() if k not in ("cases", "detailed", "reduced", "groups")}
    doc = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>fem2tmm network reduction</title>
<style>body {{ font-family: sans-serif; margin: 2em; max-width: 1100px; }} td, th {{ border: 1px solid #bbb; padding: 3px 8px; }} table {{ border-collapse: collapse; }} img {{ max-width: 520px; }}</style></head><body>
<h1>fem2tmm network reduction</h1>
{_table(head, ("", ""))}
{figs}
{''.join(sections)}
<h2>Case</h2><pre>{html.escape(res.settings.text or "(defaults)")}</pre>
<h2>summary.json (without the per-node tables)</h2><pre>{html.escape(json.dumps(small, indent=1))}</pre>
</body></html>
"""
    (folder / "report.html").write_text(doc, encoding="utf-8")
    return [n for n, _ in images]


__all__ = ["sweep_map", "temperature_plot", "write_report"]
