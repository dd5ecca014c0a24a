"""``fem2tmm bench [NAME ...]``: micro and macro benchmarks, one JSON object per line.

Each benchmark runs in a fresh subprocess so that its peak memory (``peak_rss_GB``, the child's
maximum resident set size) is its own.  Timings are medians of repeated runs where stated
(``repeats``).  Goals from the issues are checked as ratios against a baseline measured in the same
run where the issue names one, because this machine is shared and noisy.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time
from typing import Callable

#: name -> "module:function"; the function returns a list of JSON-serialisable dicts
REGISTRY: dict[str, str] = {
    "assemble": "fem2tmm.bench:bench_assemble",
    "solve": "fem2tmm.bench:bench_solve",
}


def _optional(name: str, target: str) -> None:
    REGISTRY[name] = target


_optional("nastran", "fem2tmm.io.benchmarks:bench_nastran")
_optional("cluster", "fem2tmm.cluster.benchmarks:bench_cluster")
_optional("reduce", "fem2tmm.reduce.benchmarks:bench_reduce")
_optional("rays", "fem2tmm.radiation.benchmarks:bench_rays")


def median_time(fn: Callable[[], object], repeats: int = 3) -> tuple[float, list[float]]:
    """Median wall time (s) of ``repeats`` calls and the individual times."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def _plate_case(n: int):
    from .case import Case
    from .meshes import plate

    mesh = plate(1.0, 1.0, n, n)
    case = Case.from_dict({
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"black": {"emissivity": 1.0}},
        "parts": [{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3,
                   "front": "black", "back": "black"}],
        "boundary": [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                     {"kind": "flux", "groups": ["plate"], "value": 100.0}],
    })
    return mesh, case


def bench_assemble(n: int = 1000, repeats: int = 3) -> list[dict]:
    """Assembly of an n x n quad plate (default 10⁶ elements): FE model build (K, capacity, faces, loads).

    Baseline: scipy's COO -> CSR conversion of the same element-matrix entries (the irreducible part).
    """
    import numpy as np

    from .fem.model import build_model

    mesh, case = _plate_case(n)
    model = build_model(mesh, case)
    t_build, times = median_time(lambda: build_model(mesh, case), repeats)
    coo = model.coo
    t_base, _ = median_time(lambda: coo.tocsr(model.n_dof), repeats)
    return [{"bench": "assemble", "elements": int(mesh.n_elements), "nodes": int(mesh.n_nodes),
             "median_s": round(t_build, 3), "times_s": [round(t, 3) for t in times],
             "baseline": "scipy coo->csr of the same 16 entries/element", "baseline_median_s": round(t_base, 3),
             "ratio_to_baseline": round(t_build / t_base, 2), "nnz_entries": int(len(coo.vals)),
             "goal": "< 15 s and < 4 GB (issue 2)", "checksum_K_trace": float(np.sum(model.K.diagonal()))}]


def bench_solve(n: int = 1000, repeats: int = 3) -> list[dict]:
    """One linear conduction solve of an n x n quad plate (10⁶ elements), Newton included.

    Baseline: ``scipy.sparse.linalg.spsolve`` with its default (COLAMD) ordering on the same matrix.
    """
    import dataclasses

    import numpy as np
    import scipy.sparse.linalg as spla

    from .fem.model import build_model
    from .pipeline import detailed_problem
    from .solve.steady import solve_steady

    mesh, case = _plate_case(n)
    model = build_model(mesh, case)
    prob = dataclasses.replace(detailed_problem(model), g_space=np.zeros(model.n_dof))
    t_solve, times = median_time(lambda: solve_steady(prob), repeats)
    free = ~model.fixed_mask
    K = model.K[free][:, free].tocsc()
    t_base, _ = median_time(lambda: spla.spsolve(K, model.Q[free]), 1)
    return [{"bench": "solve", "unknowns": int(free.sum()), "median_s": round(t_solve, 3),
             "times_s": [round(t, 3) for t in times], "baseline": "scipy spsolve (default COLAMD), 1 run",
             "baseline_s": round(t_base, 3), "ratio_to_baseline": round(t_solve / t_base, 2),
             "goal": "< 30 s (issue 2)"}]


def _child(name: str) -> None:
    import importlib
    import resource

    mod, fn = REGISTRY[name].split(":")
    rows = getattr(importlib.import_module(mod), fn)()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6  # kB -> GB
    for r in rows:
        r.setdefault("peak_rss_GB", round(peak, 3))
        print("BENCH " + json.dumps(r), flush=True)


def main(names: list[str] | None = None) -> int:
    from .errors import Fem2TmmError

    names = list(names or [])
    if names == ["list"]:
        for k, v in REGISTRY.items():
            print(f"{k:10s} {v}")
        return 0
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise Fem2TmmError(f"unknown benchmark(s) {', '.join(unknown)}; available: {', '.join(REGISTRY)}")
    for name in names or list(REGISTRY):
        cmd = [sys.executable, "-c", f"from fem2tmm.bench import _child; _child({name!r})"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        lines = [ln[6:] for ln in p.stdout.splitlines() if ln.startswith("BENCH ")]
        if p.returncode != 0:
            print(json.dumps({"bench": name, "error": (p.stderr.strip().splitlines() or ["failed"])[-1]}), flush=True)
            continue
        for ln in lines:
            print(ln, flush=True)
    return 0
