"""``fem2tmm bench refine``: error-driven refinement on the composite box (issue 21 item 5).

Rows:

* ``refine_estimator``: the estimate of round 0 (``[reduction] target_rms`` below reach, ``refine_rounds = 0``: no
  split) against the measured RMS (recovered vs the detailed reference, 200 rays per FE face side, two halves),
  for the ``global`` and the ``local`` estimator at 10, 25 and 50 uniform super nodes; ``ratio`` = estimate /
  measured (1: exact; below 1: under-estimates);
* ``refine``: the loop from 10 super nodes to ``target_rms`` = 1.0 K (7x the reference noise, 0.14 K):
  rounds, final super nodes, estimate and measured RMS, wall time;
* ``refine_uniform``: the uniform clustering with the loop's final super-node count, for comparison.

All runs share one stage cache (the detailed REFs are traced once).
"""

from __future__ import annotations

import dataclasses
import tempfile
import time

START, TARGET = 10, 1.0
ESTIMATOR_POINTS = (10, 25, 50)


def _case(n: int, **reduction):
    from fem2tmm.case import Case

    from .cases import REPO

    case = Case.from_toml(REPO / "examples" / "composite" / "case.toml")
    parts = tuple(dataclasses.replace(p, super_nodes=n) if p.super_nodes > 1 else p for p in case.parts)
    # super-face emission (ir_on = "detailed"), 5 outer iterations: the lumping error that the refinement splits
    # clusters against (with per-FE-face emission, the example's setting, the error is the ray noise at any n_SN)
    radiation = dataclasses.replace(case.radiation, ir_on="detailed")
    reduction = {"outer_iterations": 5, **reduction}
    return dataclasses.replace(case, parts=parts, radiation=radiation,
                               reduction=dataclasses.replace(case.reduction, **reduction))


def bench_refine() -> list[dict]:
    from fem2tmm.pipeline import run

    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for estimator in ("global", "local"):
            for n in ESTIMATOR_POINTS:
                res = run(_case(n, target_rms=1e-6, refine_rounds=0, refine_estimator=estimator), cache=cache)
                est = res.summary["reduced"]["refinement"]["rounds"][0]["estimated_rms_K"]
                meas = res.summary["accuracy"]["rms_K"]
                rows.append({"bench": "refine_estimator", "estimator": estimator, "super_nodes": n,
                             "estimated_rms_K": round(est, 4), "measured_rms_K": round(meas, 4),
                             "ratio": round(est / meas, 3),
                             "reference_noise_rms_K": res.summary["accuracy"].get("reference_noise_rms_K")})
                print("BENCH_PROGRESS", rows[-1], flush=True)
        t0 = time.perf_counter()
        res = run(_case(START, target_rms=TARGET, refine_rounds=8), cache=cache)
        wall = time.perf_counter() - t0
        ref = res.summary["reduced"]["refinement"]
        final = ref["rounds"][-1]
        meas = res.summary["accuracy"]["rms_K"]
        rows.append({"bench": "refine", "start_super_nodes": START, "target_rms_K": TARGET, "stop": ref["stop"],
                     "rounds": [{k: (round(v, 4) if isinstance(v, float) else v) for k, v in h.items()}
                                for h in ref["rounds"]],
                     "final_super_nodes": final["n_super_nodes"], "estimated_rms_K": round(final["estimated_rms_K"], 4),
                     "measured_rms_K": round(meas, 4), "target_met": bool(meas <= TARGET),
                     "reference_noise_rms_K": res.summary["accuracy"].get("reference_noise_rms_K"),
                     "wall_s": round(wall, 1)})
        print("BENCH_PROGRESS", rows[-1], flush=True)
        uni = run(_case(final["n_super_nodes"]), cache=cache)
        rows.append({"bench": "refine_uniform", "super_nodes": uni.summary["reduced"]["super_nodes"],
                     "measured_rms_K": round(uni.summary["accuracy"]["rms_K"], 4)})
    return rows
