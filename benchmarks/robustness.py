"""``fem2tmm bench robustness``: the generated robustness campaign of issue 31 at a long profile.

The generator and the check are the default test run's (``tests/robustness.py``): small shells, slivers, boxes,
solids and parts touching at a node; conductivity over three decades; emissivity 0-1, specular and diffuse, Sun on
and off; sinks 0-400 K, heaters 0-1 kW, held temperatures above and below the sink; steady and transient; thesis and
radiation-aware; 1-50 super nodes.  Each model either solves (balances closed to 1e-9 relative, temperatures within
their sources' bounds) or is refused with a Fem2TmmError; anything else (a traceback, a non-convergence, an open
balance, a temperature out of bounds) is a failure, reported with the model that produced it.

One JSON line: ``models``, ``solved``, ``refused`` (cause -> count), ``failures`` (list of {what, error}),
``seconds``.  ``FEM2TMM_ROBUSTNESS_MODELS`` sets the number of models (default 2000).
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


def bench_robustness(n_models: int | None = None, seed: int = 31) -> list[dict]:
    from hypothesis import HealthCheck, given, seed as hseed, settings

    from robustness import check, models

    n = int(n_models or os.environ.get("FEM2TMM_ROBUSTNESS_MODELS", 2000))
    outcome: collections.Counter = collections.Counter()
    refused: collections.Counter = collections.Counter()
    failures: list[dict] = []

    @hseed(seed)
    @settings(max_examples=n, deadline=None, database=None, suppress_health_check=list(HealthCheck),
              phases=["generate"])
    @given(models())
    def one(model):
        data, mesh, what = model
        try:
            res = check(data, mesh)
        except Exception as exc:  # a failure: recorded with its model, the campaign goes on
            outcome["failed"] += 1
            failures.append({"what": what, "error": f"{type(exc).__name__}: {exc}"[:400],
                             "where": traceback.format_exc().strip().splitlines()[-3][:200], "data": repr(data)[:2000]})
            return
        if res.startswith("solved"):
            outcome["solved"] += 1
            if res != "solved":
                outcome["outside_bounds_negative_conductances"] += 1
        else:
            outcome["refused"] += 1
            refused[res.removeprefix("refused: ")] += 1

    t0 = time.perf_counter()
    one()
    return [{"bench": "robustness", "models": sum(outcome.values()), "solved": outcome["solved"],
             "refused": outcome["refused"], "refused_by_cause": dict(refused.most_common()),
             "solved_outside_bounds_negative_conductances": outcome["outside_bounds_negative_conductances"],
             "failed": outcome["failed"], "failures": failures, "seconds": round(time.perf_counter() - t0, 1)}]
