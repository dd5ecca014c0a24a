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
    "pipeline_baffle": "fem2tmm.bench:bench_pipeline_baffle",
    "pipeline_truss": "fem2tmm.bench:bench_pipeline_truss",
    "pipeline_1m": "fem2tmm.bench:bench_pipeline_1m",
    "nastran": "fem2tmm.io.benchmarks:bench_nastran",
    "cluster": "fem2tmm.cluster.benchmarks:bench_cluster",
    "cluster_metis": "fem2tmm.cluster.benchmarks:bench_cluster_metis",
    "accuracy": "fem2tmm.reduce.benchmarks_accuracy:bench_accuracy",
    "reduce": "fem2tmm.reduce.benchmarks:bench_reduce",
    "rays": "fem2tmm.radiation.benchmarks:bench_rays",
    "solar": "fem2tmm.radiation.benchmarks_solar:bench_solar",
    "quadric": "fem2tmm.radiation.benchmarks_quadric:bench_quadric",
    "network": "fem2tmm.lpm.benchmarks:bench_network",
}


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
    rss_mesh = vm("VmRSS")
    reset_peak()
    model = build_model(mesh, case)  # peak of one build, mesh included (the repeats below free it first)
    peak = vm("VmHWM")
    coo = model.coo
    t_base, _ = median_time(lambda: coo.tocsr(model.n_dof), repeats)
    trace = float(np.sum(model.K.diagonal()))
    del model, coo

    def once():
        build_model(mesh, case)

    t_build, times = median_time(once, repeats)
    return [{"bench": "assemble", "elements": int(mesh.n_elements), "nodes": int(mesh.n_nodes),
             "median_s": round(t_build, 3), "times_s": [round(t, 3) for t in times],
             "build_peak_rss_GB": round(peak * 2**20 / 1e9, 3), "mesh_rss_GB": round(rss_mesh * 2**20 / 1e9, 3),
             "baseline": "scipy coo->csr of the same 16 entries/element", "baseline_median_s": round(t_base, 3),
             "ratio_to_baseline": round(t_build / t_base, 2), "nnz_entries": 16 * int(mesh.n_elements),
             "goal": "< 15 s and < 4 GB (issue 2)", "checksum_K_trace": trace}]


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


def _repo_file(*parts) -> str:
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    p = root.joinpath(*parts)
    if not p.exists():
        from .errors import Fem2TmmError

        raise Fem2TmmError(f"{p} not found: the pipeline benchmarks run from a source checkout of fem2tmm")
    return str(p)


def _pipeline_row(name: str, result, wall: float) -> dict:
    s = result.summary
    return {"bench": name, "wall_s": round(wall, 2), "timings_s": {k: round(v, 3) for k, v in s["timings_s"].items()},
            "elements": s["mesh"]["elements"], "nodes": s["mesh"]["nodes"],
            "super_nodes": (s["reduced"] or {}).get("super_nodes"), "rays": (s["radiation"] or {}).get("rays"),
            "accuracy": s["accuracy"]}


def _run_case(name: str, case_file: str, super_nodes: int | None = None) -> list[dict]:
    """Run an example case (optionally with every part at ``super_nodes``) into a temporary folder."""
    import dataclasses
    import tempfile

    from .case import Case
    from .pipeline import run

    case = Case.from_toml(_repo_file(*case_file.split("/")))
    if super_nodes is not None:
        case = dataclasses.replace(case, parts=tuple(dataclasses.replace(p, super_nodes=super_nodes)
                                                     for p in case.parts))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run(case, out=f"{tmp}/out")
        wall = time.perf_counter() - t0
    return [_pipeline_row(name, res, wall)]


def bench_pipeline_baffle() -> list[dict]:
    """The baffle example (18 404 quads) at 10 and 100 super nodes, detailed reference included
    (goal: under 60 s each, issue 8)."""
    return _run_case("pipeline_baffle_10sn", "examples/baffle/case.toml") + \
        _run_case("pipeline_baffle_100sn", "examples/baffle/case.toml", super_nodes=100)


def bench_pipeline_truss() -> list[dict]:
    """The truss example (121 693 tets, 35 603 nodes) at 10 and 100 super nodes, reference included."""
    return _run_case("pipeline_truss_10sn", "examples/truss/case.toml") + \
        _run_case("pipeline_truss_100sn", "examples/truss/case.toml", super_nodes=100)


def big_shell_structure(n: int = 408):
    """A closed shell box 1 x 1 x 0.6 m with two internal shelves, ≈ 10⁶ quads for n = 408 (elements per
    edge of the 1 m faces)."""
    from . import meshes

    box = meshes.box(1.0, 1.0, 0.6, n, n, max(int(0.6 * n), 1), name="box")
    shelves = [meshes.plate(1.0, 1.0, n, n, origin=(0.0, 0.0, z), name=f"shelf_{k}")
               for k, z in enumerate((0.2, 0.4))]
    return meshes.merge(box, *shelves)


def bench_pipeline_1m(n: int = 408, super_nodes: int = 1000, rays: float = 1e7) -> list[dict]:
    """A generated ≈10⁶-element shell structure (closed box with two shelves, conformal), 1000 super nodes
    and ≈10⁷ rays between super faces, without the detailed reference (goal < 120 s and < 8 GB, issue 8)."""
    from .case import Case
    from .pipeline import run

    mesh = big_shell_structure(n)
    n_sf = 2 * super_nodes
    case = Case.from_dict({
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"white": {"emissivity": 0.85, "absorptivity": 0.2}},
        "parts": [{"name": "box", "groups": ["box"], "material": "al", "thickness": 1.5e-3, "front": "white",
                   "back": "white", "super_nodes": int(super_nodes * 0.6)},
                  {"name": "shelves", "groups": ["shelf_0", "shelf_1"], "material": "al", "thickness": 1e-3,
                   "front": "white", "back": "white", "super_nodes": super_nodes - int(super_nodes * 0.6)}],
        "boundary": [{"kind": "temperature", "groups": ["zmin"], "value": 20.0, "name": "base"},
                     {"kind": "power", "groups": ["shelf_1"], "value": 200.0, "name": "electronics"}],
        "environment": {"sink_temperature": -100.0, "sun_direction": [0.3, 0.2, 1.0], "solar_flux": 1366.0,
                        "solar_on": "super_faces", "solar_rays_per_face": 4},
        "radiation": {"rays_per_face": int(rays / n_sf)},
        "reference": {"detailed": False},
    })
    t0 = time.perf_counter()
    res = run(case, mesh=mesh, reference=False)
    wall = time.perf_counter() - t0
    row = _pipeline_row("pipeline_1m", res, wall)
    row["goal"] = "< 120 s and < 8 GB (issue 8)"
    return [row]


def vm(key: str) -> float:
    """A /proc/self/status memory figure (VmHWM peak, VmRSS current) in MB (Linux), NaN elsewhere."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def reset_peak() -> bool:
    """Reset the kernel's peak-RSS mark (VmHWM) of this process; False where that is not possible."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def _peak_rss_gb() -> float:
    """This process' peak resident set size in GB (VmHWM: unlike ru_maxrss it is not inherited through exec)."""
    v = vm("VmHWM")
    if v == v:  # not NaN
        return v * 2**20 / 1e9
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def _child(name: str) -> None:
    import importlib

    mod, fn = REGISTRY[name].split(":")
    rows = getattr(importlib.import_module(mod), fn)()
    peak = _peak_rss_gb()
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
    unknown = [n for n in names if n not in REGISTRY and n != "pipeline"]
    if unknown:
        raise Fem2TmmError(f"unknown benchmark(s) {', '.join(unknown)}; available: {', '.join(REGISTRY)}")
    groups = {"pipeline": ["pipeline_baffle", "pipeline_truss", "pipeline_1m"]}
    expanded = []
    for n in names or list(REGISTRY):
        expanded += groups.get(n, [n])
    for name in expanded:
        cmd = [sys.executable, "-c", f"from fem2tmm.bench import _child; _child({name!r})"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        lines = [ln[6:] for ln in p.stdout.splitlines() if ln.startswith("BENCH ")]
        if p.returncode != 0:
            print(json.dumps({"bench": name, "error": (p.stderr.strip().splitlines() or ["failed"])[-1]}), flush=True)
            continue
        for ln in lines:
            print(ln, flush=True)
    return 0
