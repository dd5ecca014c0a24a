"""Benchmark runner: ``python -m benchmarks.run [NAME ...]`` from the repository root, or ``fem2tmm bench
[NAME ...]`` from anywhere inside a source checkout; one JSON object per line.

Each benchmark runs in a fresh subprocess so that its peak memory (``peak_rss_GB``, the child's
maximum resident set size) is its own.  Timings are medians of repeated runs where stated
(``repeats``).  Goals from the issues are checked as ratios against a baseline measured in the same
run where the issue names one, because this machine is shared and noisy.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

REPO = Path(__file__).resolve().parents[1]

#: name -> "module:function"; the function returns a list of JSON-serialisable dicts
REGISTRY: dict[str, str] = {
    "assemble": "benchmarks.pipeline:bench_assemble",
    "solve": "benchmarks.pipeline:bench_solve",
    "pipeline_baffle": "benchmarks.pipeline:bench_pipeline_baffle",
    "pipeline_truss": "benchmarks.pipeline:bench_pipeline_truss",
    "pipeline_1m": "benchmarks.pipeline:bench_pipeline_1m",
    "pipeline_stages": "benchmarks.pipeline:bench_pipeline_stages",
    "scaling": "benchmarks.scaling:bench_scaling",
    "nastran": "benchmarks.io:bench_nastran",
    "cluster": "benchmarks.cluster:bench_cluster",
    "cluster_metis": "benchmarks.cluster:bench_cluster_metis",
    "accuracy": "benchmarks.accuracy:bench_accuracy",
    "accuracy_composite": "benchmarks.accuracy:bench_accuracy_composite",
    "accuracy_truss": "benchmarks.accuracy:bench_accuracy_truss",
    "allocation": "benchmarks.accuracy:bench_allocation",
    "accuracy_quiet": "benchmarks.accuracy:bench_composite_quiet",
    "accuracy_floor": "benchmarks.accuracy:bench_composite_floor",
    "accuracy_mismatch": "benchmarks.accuracy:bench_composite_mismatch",
    "accuracy_modes": "benchmarks.accuracy:bench_composite_modes",
    "reduce": "benchmarks.reduce:bench_reduce",
    "reduce_dask": "benchmarks.distributed:bench_reduce_dask",
    "memory_per_element": "benchmarks.distributed:bench_memory_per_element",
    "rays": "benchmarks.radiation:bench_rays",
    "solar": "benchmarks.solar:bench_solar",
    "quadric": "benchmarks.quadric:bench_quadric",
    "network": "benchmarks.network:bench_network",
    "cases": "benchmarks.loadcases:bench_cases",
    "cases_warm": "benchmarks.loadcases:bench_cases_warm",
    "cases_smallsat": "benchmarks.loadcases:bench_cases_smallsat",
    "network_positive": "benchmarks.network:bench_network_positive",
    "link_filter": "benchmarks.network:bench_link_filter",
    "transient": "benchmarks.transient:bench_transient",
    "orbit": "benchmarks.orbit:bench_orbit",
    "refine": "benchmarks.refine:bench_refine",
    "envelope": "benchmarks.envelope:bench_envelope",
    "envelope_orbit": "benchmarks.envelope:bench_envelope_orbit",
    "envelope_parametric": "benchmarks.envelope:bench_envelope_parametric",
    "envelope_deck": "benchmarks.envelope:bench_envelope_deck",
    "robustness": "benchmarks.robustness:bench_robustness",
    "rom": "benchmarks.rom:bench_rom_all",
    "satellite": "benchmarks.satellite:bench_satellite",
    "thermoelastic": "benchmarks.thermoelastic:bench_thermoelastic",
    "choice": "benchmarks.choice:bench_choice",
    "offdesign": "benchmarks.offdesign:bench_offdesign",
    "offdesign_curve": "benchmarks.offdesign:bench_offdesign_curve",
    "offdesign_books": "benchmarks.offdesign:bench_offdesign_books",
    "offdesign_loads": "benchmarks.offdesign:bench_offdesign_loads",
    "offdesign_area": "benchmarks.offdesign:bench_offdesign_area",
    "offdesign_transient": "benchmarks.offdesign_transient:bench_offdesign_transient",
    "offdesign_transient_forms": "benchmarks.offdesign_transient:bench_offdesign_transient_forms",
    "offdesign_transient_forms_loads": "benchmarks.offdesign_transient:bench_offdesign_transient_forms_loads",
}


#: name -> what it measures, one line (``fem2tmm bench list``)
ABOUT: dict[str, str] = {
    "assemble": "FE model build (K, capacity, faces, loads) of a 10^6-quad plate",
    "solve": "one conduction solve of a 10^6-quad plate, Newton included",
    "pipeline_baffle": "examples/baffle end to end at 10 and 100 super nodes, reference included",
    "pipeline_truss": "examples/truss (121 693 tets) end to end at 10 and 100 super nodes",
    "pipeline_1m": "a 1.07e6-quad conformal shell structure end to end against one PARDISO/CHOLMOD solve",
    "pipeline_stages": "the 1M structure's pipeline at 2.7e5 quads, stage by stage",
    "scaling": "pipeline and baseline solve at 1e4, 1e5, 1e6 (3e6) elements: cost curve, exponents, memory",
    "nastran": "reading a 10^6-element CQUAD4 Nastran deck",
    "cluster": "clustering time and memory, 1e5 and 1e6 quads, 3e5 tets",
    "cluster_metis": "clustering against METIS: time, balance, edge cut and the reduced error with each",
    "accuracy": "recovered error against super nodes on every study (the convergence plot)",
    "accuracy_composite": "the composite box alone, both methods, 10 to 1 000 super nodes",
    "accuracy_truss": "the truss alone at 10 and 100 super nodes",
    "allocation": "composite box error against super nodes for each way of allocating the count",
    "accuracy_quiet": "composite slope with the detailed ray factors (no ray noise)",
    "accuracy_floor": "the composite error at one count against the rays of the network and of the reference",
    "accuracy_mismatch": "composite error with and without the emission discretisation mismatch",
    "accuracy_modes": "composite error with each super face emitting at its super node's temperature",
    "reduce": "the conduction reduction: local against global, time and exactness",
    "reduce_dask": "the reduction of 2.7e5 quads serially and on a LocalCluster, bit-identical",
    "memory_per_element": "peak memory of the pipeline per element, and the size that fits 24 GB",
    "rays": "exchange-factor tracing throughput against bare Embree queries",
    "solar": "solar tracing throughput against bare Embree queries",
    "quadric": "quadric super faces against planar ones",
    "network": "an existing network (every FE DOF a node) grouped to about 1 000 nodes",
    "cases": "a set of load cases serially and on Dask",
    "cases_warm": "the load-case set on Dask clusters that are already running",
    "cases_smallsat": "8 cases x orbit positions on the small satellite, serial and on Dask",
    "network_positive": "the positive sparse network of examples/baffle",
    "link_filter": "the deck's conductors after the link filter against the error, examples/composite",
    "transient": "transients on the baffle and a 1e6-quad plate: reduced against detailed, and cost",
    "orbit": "orbital heat fluxes on the small satellite: tracing throughput and cost",
    "refine": "error-driven refinement on the composite box",
    "envelope": "the handed-over network over an envelope of load cases",
    "envelope_orbit": "the composite box's network over an orbit's load envelope",
    "envelope_parametric": "the deck a user edits beyond the case set, with and without parametric tables",
    "envelope_deck": "each example's deck edited as a user would, default against the thesis network",
    "robustness": "the generated robustness campaign (thousands of random models, default against thesis)",
    "rom": "the super-node network against projection ROMs (POD-Galerkin, POD-DEIM) at equal size",
    "satellite": "examples/satellite from 30 to 1 000 super nodes",
    "thermoelastic": "the thermo-elastic chain on examples/truss with CalculiX",
    "choice": "what the default reduction chooses on every study, and what each method gives there",
    "offdesign": "the L-bracket's single-case deck edited (0, 5, 40 W, sink) and solved outside fem2tmm",
    "offdesign_curve": "the edited L-bracket deck from 30 to 1 000 super nodes",
    "offdesign_books": "the L-bracket deck's heat books from its own conductors and loads",
    "offdesign_loads": "the L-bracket's edited decks and stepped transient with allocation = \"loads\"",
    "offdesign_area": "the same with allocation = \"area\" (equal areas, the default until 2026-12-07)",
    "offdesign_transient": "the L-bracket's transient deck (10 -> 40 -> 0 W) integrated outside fem2tmm",
    "offdesign_transient_forms": "the L-bracket's transient in network forms a deck can and cannot carry",
    "offdesign_transient_forms_loads": "the same forms with allocation = \"loads\", at 100 and 300 super nodes",
}


def median_time(fn: Callable[[], object], repeats: int = 3) -> tuple[float, list[float]]:
    """Median wall time (s) of ``repeats`` calls and the individual times."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def median_call(fn, repeat: int, cpu: bool = False):
    """Median wall time of ``fn()`` over ``repeat`` calls (and the median CPU time of the process when ``cpu``)."""
    wall, proc, out = [], [], None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        wall.append(time.perf_counter() - t)
        proc.append(time.process_time() - c)
    if cpu:
        return float(np.median(wall)), float(np.median(proc)), out
    return float(np.median(wall)), out



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


def child_env() -> dict:
    """The environment of a benchmark subprocess: this one's, with the repository root on ``PYTHONPATH`` (so that
    ``import benchmarks`` works from any directory)."""
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": str(REPO) + (os.pathsep + path if path else "")}


def main(names: list[str] | None = None) -> int:
    """Run the named benchmarks (all by default; ``list`` lists them), each in a fresh subprocess."""
    from fem2tmm.errors import Fem2TmmError

    names = list(names or [])
    if names == ["list"]:
        width = max(map(len, REGISTRY))
        for k in REGISTRY:
            print(f"{k:{width}s}  {ABOUT[k]}")
        return 0
    unknown = [n for n in names if n not in REGISTRY and n != "pipeline"]
    if unknown:
        raise Fem2TmmError(f"unknown benchmark(s) {', '.join(unknown)}; available: {', '.join(REGISTRY)}")
    groups = {"pipeline": ["pipeline_baffle", "pipeline_truss", "pipeline_1m"]}
    expanded = []
    for n in names or list(REGISTRY):
        expanded += groups.get(n, [n])
    for name in expanded:
        cmd = [sys.executable, "-c", f"from benchmarks.run import _child; _child({name!r})"]
        p = subprocess.run(cmd, capture_output=True, text=True, env=child_env())
        lines = [ln[6:] for ln in p.stdout.splitlines() if ln.startswith("BENCH ")]
        if p.returncode != 0:
            print(json.dumps({"bench": name, "error": (p.stderr.strip().splitlines() or ["failed"])[-1]}), flush=True)
            continue
        for ln in lines:
            print(ln, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
