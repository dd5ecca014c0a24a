"""``fem2tmm bench robustness``: the generated robustness campaign of issue 31 at a long profile.

The generator and the check are the default test run's (``tests/robustness.py``): small shells, slivers, boxes,
solids and parts touching at a node; conductivity over three decades; emissivity 0-1, specular and diffuse, Sun on
and off; sinks 0-400 K, heaters 0-1 kW, held temperatures above and below the sink; steady and transient; thesis and
radiation-aware; 1-50 super nodes.  Each model either solves (balances closed to 1e-9 relative, temperatures within
their sources' bounds) or is refused with a Fem2TmmError; anything else (a traceback, a non-convergence, an open
balance, a temperature out of bounds) is a failure, reported with the model that produced it.

Issue 42 adds real-structure models (an inactive solid block on a radiator, RBE2 spiders that collapse elements,
bars on panel edges, aluminium beside low-k CFRP, MLI as an effective emittance with CBUSH stitches across, a heater
on a unit's footprint of at most 1/16 of its panel, where the default allocation puts smaller super nodes) and
draws ``radiation_aware`` from true / false / "auto".  Every solved model with the default ``"auto"`` records the
default's error and the thesis method's against the detailed reference (``tests/robustness.accuracy_record``):
``accuracy`` counts the models where the default is worse than the thesis method by more than the reference's own
ray noise (``accuracy.reference_noise_rms_K``, two half-budget tracings; without face-to-face radiation there are
no rays and the margin is the floor ``MARGIN_FLOOR_K``), and by more than 3x that noise, at the design state; and
``accuracy.verified_range`` (:func:`range_table`) how often the verified range handed the thesis' network over
instead of the radiation-aware one the design-state estimate kept; ``accuracy.floor`` (:func:`floor_table`) how often
the radiation-aware network whose short super nodes are fed along K̃'s links replaced the one fed from the held node;
``accuracy.positive_for_a_transient`` the models whose first network could not integrate the transient asked for and
whose default handed the positive network over instead (their design-state errors, outside the comparison).

One JSON line: ``models``, ``solved``, ``refused`` (cause -> count), ``failures`` (list of {what, error}),
``default_refused_for_the_network`` (the models with the default reduction settings refused for the network's
negative conductances or its super nodes at 0 K, properties of the network and not of the model: {what, cause,
data}), ``accuracy`` (above), ``seconds``.  ``FEM2TMM_ROBUSTNESS_MODELS`` sets the number of models (default 2000);
``FEM2TMM_ROBUSTNESS_RECORDS`` names a file for every ``"auto"`` model's record (one JSON line each: both methods'
errors, the reference noise, the choice's estimates and their noise, the mesh call ``what`` and the case ``data``).
"""

from __future__ import annotations

import collections
import os
import sys
import time
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO / "tests") not in sys.path:
    sys.path.append(str(REPO / "tests"))


#: kelvin: the smallest margin of the default-vs-thesis comparison (the check's bound tolerance, 1 mK): models
#: without rays have no reference noise, and their two errors can differ at round-off
MARGIN_FLOOR_K = 1e-3


def accuracy_table(records: list[dict]) -> dict:
    """The default-vs-thesis comparison over the ``"auto"`` models (``records`` from ``check(..., record=)``)."""
    import numpy as np

    rows = [r for r in records if r]
    # the positive network handed over for a transient the first network could not integrate: the thesis' network
    # solves the steady design state (often exactly) but not what was asked, so these are a trade of their own, not
    # the default's choice between two networks that both run
    swapped = [r for r in rows if r.get("network_refused")]
    rows = [r for r in rows if not r.get("network_refused")]
    out = {"models": len(rows),
           "positive_for_a_transient": [{k: r.get(k) for k in ("what", "default_rms_K", "thesis_rms_K", "noise_K")}
                                        for r in swapped],
           "margin": "max(reference_noise_rms_K, reference_floor_K, 1 mK)", "by_choice": {},
           "worse": [], "cold_field_references": sum(1 for r in rows if r.get("reference_floor_K")),
           "thesis_refused_default_solved": sum(1 for r in rows if r["thesis_rms_K"] is None)}
    comp = [r for r in rows if r["thesis_rms_K"] is not None]
    for chosen in sorted({r["chosen"] for r in comp}):
        rs = [r for r in comp if r["chosen"] == chosen]
        d = np.array([r["default_rms_K"] for r in rs])
        t = np.array([r["thesis_rms_K"] for r in rs])
        # the reference's own resolution: its ray noise, and for a field stopped on the cold-field floor (within
        # ~1 K of 0 K, loads at round-off) its own temperature, below which its solver resolves nothing
        margin = np.maximum([max(r["noise_K"], r.get("reference_floor_K", 0.0)) for r in rs], MARGIN_FLOOR_K)
        out["by_choice"][chosen] = {
            "models": len(rs), "default_rms_K_median": float(np.median(d)), "thesis_rms_K_median": float(np.median(t)),
            "default_better_by_more_than_noise": int(np.sum(t - d > margin)),
            "within_noise": int(np.sum(np.abs(d - t) <= margin)),
            "default_worse_by_more_than_noise": int(np.sum(d - t > margin)),
            "default_worse_by_more_than_3x_noise": int(np.sum(d - t > 3 * margin)),
            "largest_excess_K": float(np.max(d - t))}
        out["worse"] += [r for r, w in zip(rs, d - t > margin) if w]
    out["default_worse_by_more_than_noise"] = len(out["worse"])
    out["worse"] = sorted(out["worse"], key=lambda r: r["thesis_rms_K"] - r["default_rms_K"])[:20]
    out["verified_range"] = range_table(rows)
    out["floor"] = floor_table(rows)
    return out


def floor_table(rows: list[dict]) -> dict:
    """Over the ``"auto"`` models whose radiation-aware network had super nodes short of heat fed two ways and a
    verified range (``floor`` of the record: ``reduced.choice.floor``): how often the network fed along K̃'s links
    replaced the one fed from the held node, and each one's worst verified RMS (medians, K) on either side."""
    import numpy as np

    fl = [r["floor"] for r in rows if r.get("floor")]
    out = {"checked": len(fl)}
    for src in ("linked", "held"):
        rs = [f for f in fl if f["source"] == src]
        out[f"{src}_handed_over"] = {"models": len(rs), **{
            f"worst_K_median_{k}": float(np.median([f["worst_K"][k] for f in rs])) if rs else None
            for k in ("held", "linked")}}
    return out


def range_table(rows: list[dict]) -> dict:
    """Over the ``"auto"`` models whose radiation-aware network the estimate kept and whose range was verified
    (``verified_range`` of the record, :func:`fem2tmm.verify.range_choice`): how many the thesis' network replaced,
    and each network's worst verified RMS (medians, K) on either side of that choice."""
    import numpy as np

    vr = [r for r in rows if r.get("verified_range")]
    out = {"checked": len(vr)}
    for name, sel in (("thesis_handed_over", True), ("radiation_aware_kept", False)):
        rs = [r["verified_range"] for r in vr if r["verified_range"]["thesis"] is sel]
        out[name] = {"models": len(rs), "with_states_without_solution": sum(1 for r in rs if r["failed"]["kept"]),
                     **{f"worst_K_median_{k}": float(np.median([r["worst_K"][k] for r in rs])) if rs else None
                        for k in ("kept", "thesis")}}
    return out


def bench_robustness(n_models: int | None = None, seed: int = 31) -> list[dict]:
    from hypothesis import HealthCheck, given, seed as hseed, settings

    from robustness import CN_OSCILLATION, check, models

    n = int(n_models or os.environ.get("FEM2TMM_ROBUSTNESS_MODELS", 2000))
    outcome: collections.Counter = collections.Counter()
    refused: collections.Counter = collections.Counter()
    failures: list[dict] = []
    records: list[dict] = []
    network_refusals: list[dict] = []  # default settings refused for the network's property, not the input's

    @hseed(seed)
    @settings(max_examples=n, deadline=None, database=None, suppress_health_check=list(HealthCheck),
              phases=["generate"])
    @given(models())
    def one(model):
        data, mesh, what = model
        rec: dict = {}
        try:
            res = check(data, mesh, rec)
        except Exception as exc:  # a failure: recorded with its model, the campaign goes on
            outcome["failed"] += 1
            failures.append({"what": what, "error": f"{type(exc).__name__}: {exc}"[:400],
                             "where": traceback.format_exc().strip().splitlines()[-3][:200], "data": repr(data)[:2000]})
            return
        if rec:
            records.append({**rec, "what": what[:300], "data": data})  # data: the case, to reproduce the model
        if res.startswith("solved"):
            outcome["solved"] += 1
            if res.endswith(CN_OSCILLATION):
                outcome["outside_bounds_crank_nicolson"] += 1
            elif res != "solved":
                outcome["outside_bounds_negative_conductances"] += 1
        else:
            outcome["refused"] += 1
            refused[res.removeprefix("refused: ")] += 1
            red = data.get("reduction", {})
            if (red.get("radiation_aware", "auto") == "auto" and red.get("network", "exact") == "exact"
                    and ("negative conductances" in res or "absolute zero" in res)):  # (a network's, not the input's)
                network_refusals.append({"what": what[:300], "cause": res[:400], "data": repr(data)[:2000]})

    t0 = time.perf_counter()
    one()
    if os.environ.get("FEM2TMM_ROBUSTNESS_RECORDS"):  # every "auto" model's record, one JSON line each
        import json
        with open(os.environ["FEM2TMM_ROBUSTNESS_RECORDS"], "w") as fh:
            fh.writelines(json.dumps(r) + "\n" for r in records)
    return [{"bench": "robustness", "models": outcome["solved"] + outcome["refused"] + outcome["failed"], "solved": outcome["solved"],
             "refused": outcome["refused"], "refused_by_cause": dict(refused.most_common()),
             "solved_outside_bounds_negative_conductances": outcome["outside_bounds_negative_conductances"],
             "solved_outside_bounds_crank_nicolson": outcome["outside_bounds_crank_nicolson"],
             "default_refused_for_the_network": network_refusals,
             "failed": outcome["failed"], "failures": failures, "accuracy": accuracy_table(records), "seconds": round(time.perf_counter() - t0, 1)}]
