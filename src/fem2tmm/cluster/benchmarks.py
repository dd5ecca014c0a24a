"""Timing and memory of the clustering stage (``fem2tmm bench cluster``).

Each case runs in a fresh Python subprocess so that its peak resident memory (``ru_maxrss``) is its own:

* ``"1e5"``: flat plate of 316 x 316 = 99 856 quads -> 100 clusters (3 runs, medians);
* ``"1e6"``: flat plate of 1000 x 1000 quads -> 1000 clusters (1 run);
* ``"tet3e5"``: cube of 37³ Kuhn-split hexahedra = 303 918 tets -> 300 clusters (1 run).

Goals (issue 3): 10⁶ -> 1000 in < 60 s and < 4 GB, 10⁵ -> 100 in < 5 s.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

CASES = {
    "1e5": dict(kind="shell", n=316, clusters=100, repeats=3),
    "1e6": dict(kind="shell", n=1000, clusters=1000, repeats=1),
    "tet3e5": dict(kind="solid", n=37, clusters=300, repeats=1),
}

_CHILD = r"""
import json, resource, sys, time
import numpy as np
from fem2tmm import meshes
from fem2tmm.cluster import PartInput, cluster_parts
kind, n, k = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
if kind == "shell":
    mesh = meshes.plate(1.0, 1.0, n, n)
else:
    mesh = meshes.box(1.0, 1.0, 1.0, n, n, n, kind="solid", element="tet4")
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
part = PartInput("bench", kind, np.arange(mesh.n_elements), mesh.padded_cells, mesh.element_types, k)
t = time.perf_counter()
res = cluster_parts(mesh.points, [part], mesh.n_elements)
wall = time.perf_counter() - t
rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
p = res.report["parts"][0]
print(json.dumps({"elements": mesh.n_elements, "wall_s": wall, "steps_s": p["time_s"],
                  "rss_mesh_mb": rss0 / 1024, "rss_peak_mb": rss1 / 1024,
                  "cv": p["cluster_measure_cv"], "contiguous": p["contiguous"],
                  "boundary_before": p["boundary_before"], "boundary_after": p["boundary_after"]}))
"""


def _run_case(kind: str, n: int, k: int) -> dict:
    out = subprocess.run([sys.executable, "-c", _CHILD, kind, str(n), str(k)], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def bench_cluster(sizes=("1e5", "1e6", "tet3e5")) -> list[dict]:
    """Run the clustering benchmarks; one dict per case.

    Each dict: ``name``, ``elements``, ``clusters``, ``runs``, ``median_s`` (wall time of
    :func:`~fem2tmm.cluster.cluster_parts`), ``steps_s`` (median per step: geometry, regions, allocation,
    seeding, growing, smoothing), ``peak_rss_mb`` (largest peak resident memory of the subprocess over the
    runs, mesh included), ``mesh_rss_mb`` (peak after building the mesh, before clustering),
    ``cluster_measure_cv``, ``contiguous``, ``boundary_before``/``boundary_after`` (m or m²).
    """
    rows = []
    for name in sizes:
        if name not in CASES:
            raise ValueError(f"unknown clustering benchmark {name!r}; choose from {', '.join(CASES)}")
        c = CASES[name]
        runs = [_run_case(c["kind"], c["n"], c["clusters"]) for _ in range(c["repeats"])]
        steps = {s: float(np.median([r["steps_s"][s] for r in runs])) for s in runs[0]["steps_s"]}
        rows.append({
            "name": f"cluster_{name}",
            "elements": runs[0]["elements"],
            "clusters": c["clusters"],
            "runs": len(runs),
            "median_s": float(np.median([r["wall_s"] for r in runs])),
            "steps_s": steps,
            "peak_rss_mb": max(r["rss_peak_mb"] for r in runs),
            "mesh_rss_mb": max(r["rss_mesh_mb"] for r in runs),
            "cluster_measure_cv": runs[0]["cv"],
            "contiguous": all(r["contiguous"] for r in runs),
            "boundary_before": runs[0]["boundary_before"],
            "boundary_after": runs[0]["boundary_after"],
        })
    return rows


if __name__ == "__main__":  # pragma: no cover
    for row in bench_cluster(tuple(sys.argv[1:]) or ("1e5", "1e6", "tet3e5")):
        print(json.dumps(row))
