"""``fem2tmm bench satellite``: the satellite structure of ``examples/satellite`` from 30 to 1 000 super nodes
(issue 33).

The example's case (a generated Nastran deck: aluminium and CFRP panels with stiffeners on their edges, a titanium
tripod, fittings touching the panels by nodes, RBE2/CBUSH mounts, a held launcher interface, two heaters, a 700 km
Sun-synchronous orbit with the loads traced on the FE faces; ``case.toml``), run at each total of super nodes with

- ``radiation_aware``: the case as written (radiation-aware reduction, IR placed per FE face: the default of the
  example);
- ``thesis``: the thesis' reduction (``radiation_aware = false``, IR uniform over each super node).

The total is split between the parts: fittings N/10 (at most their 66 elements), bars N/10 (at most the 32 bars
that do not lie on panel nodes), panels the rest; the row ``split`` is the issue's 60 / 30 / 4.  Every figure is the *exported* network's
(``accuracy``: read back from reduced.npz and model.esatan, solved, recovered), orbit-average steady state, against
the detailed reference with its own noise; ``seconds`` is the whole run's wall time (detailed reference, orbital
fluxes and outputs included), ``reduce_s`` the clustering + reduction + super-face tracing + reduced solve.

One JSON line per (super nodes, method).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from .envelope import as_thesis, timed_run

REPO = Path(__file__).resolve().parents[1]
FOLDER = REPO / "examples" / "satellite"
N_SN = (30, 100, 300, 1000)
FREE_BARS = 32  # the tripod (3 x 6), its post (4) and the mast (10): the bars not lying on panel nodes
FITTING_ELEMENTS = 66  # a part takes at most one super node per element


def split(n: int) -> tuple[int, int, int]:
    """(panels, bars, fittings) for a total of ``n`` super nodes."""
    fittings = max(1, min(FITTING_ELEMENTS, n // 10))
    bars = max(1, min(FREE_BARS, n // 10))
    return n - fittings - bars, bars, fittings


def _case(counts, aware: bool):
    from fem2tmm.case import Case

    raw = tomllib.loads((FOLDER / "case.toml").read_text())
    for part, c in zip(raw["parts"], counts):
        part["super_nodes"] = c
    return Case.from_dict(raw if aware else as_thesis(raw), base_dir=FOLDER)


def _row(counts, aware: bool, label: str) -> dict:
    res, seconds = timed_run(_case(counts, aware))
    s = res.summary
    acc, red, tim = s["accuracy"], s["reduced"], s["timings_s"]
    return {"study": "satellite", "split": label, "panels_bars_fittings": list(counts),
            "method": "radiation_aware" if aware else "thesis", "super_nodes": red["super_nodes"],
            "rms_K": acc["rms_K"], "max_K": acc["max_K"], "in_process_rms_K": acc["in_process"]["rms_K"],
            "reference_noise_rms_K": acc["reference_noise_rms_K"],
            "reference_noise_max_K": acc["reference_noise_max_K"],
            "GL": red["conductive_links"], "GR": red["radiative_links"], "kept_nodes": red["kept_nodes"],
            "joined_elements": res.reduced.clustering.report.get("joined", {}).get("elements", 0),
            "energy_relative": max(abs(s["energy_balance_W"][k]["relative"]) for k in ("detailed", "reduced")),
            "seconds": round(seconds, 1),
            "reduce_s": round(sum(tim.get(k, 0.0) for k in ("cluster", "reduce", "radiation", "solve_reduced",
                                                           "recover")), 2)}


def bench_satellite() -> list[dict]:
    rows = []
    for n in N_SN:
        for aware in (True, False):
            rows.append(_row(split(n), aware, f"N={n}"))
            print(rows[-1], flush=True)
    for aware in (True, False):
        rows.append(_row((60, 30, 4), aware, "issue 60/30/4"))
        print(rows[-1], flush=True)
    return rows
