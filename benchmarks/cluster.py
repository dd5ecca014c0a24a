"""Timing and memory of the clustering stage (``fem2tmm bench cluster``).

Each case runs in a fresh Python subprocess so that its peak resident memory (``ru_maxrss``) is its own:

* ``"1e5"``: flat plate of 316 x 316 = 99 856 quads -> 100 clusters (3 runs, medians);
* ``"1e6"``: flat plate of 1000 x 1000 quads -> 1000 clusters (1 run);
* ``"tet3e5"``: cube of 37³ Kuhn-split hexahedra = 303 918 tets -> 300 clusters (1 run).

Goals (issue 3): 10⁶ -> 1000 in < 60 s and < 4 GB, 10⁵ -> 100 in < 5 s.

:func:`bench_seeding` compares weighted k-means variants (the choice made in :mod:`fem2tmm.cluster.seeding`).
Command line: ``python -m benchmarks.cluster [1e5 1e6 tet3e5]`` or ``... seeding`` (repository root).
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
from fem2tmm.mesh import shapes
from fem2tmm.cluster import PartInput, cluster_parts
kind, n, k = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
if kind == "shell":
    mesh = shapes.plate(1.0, 1.0, n, n)
else:
    mesh = shapes.box(1.0, 1.0, 1.0, n, n, n, kind="solid", element="tet4")
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


def _graded_centroids(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Centroids (≈n, 3) and areas of a unit plate of quads whose quarter [0, 0.5]² is 10x finer per axis."""
    nc = max(1, int(round(np.sqrt(n / 121))))
    xs = np.unique(np.r_[np.linspace(0, 0.5, 10 * nc + 1), np.linspace(0.5, 1, nc + 1)])
    mid, dx = 0.5 * (xs[1:] + xs[:-1]), np.diff(xs)
    X, Y = np.meshgrid(mid, mid, indexing="ij")
    pts = np.c_[X.ravel(), Y.ravel(), np.zeros(X.size)]
    return pts, (dx[:, None] * dx[None, :]).ravel()


def bench_seeding(cases=((300_000, 1000), (1_000_000, 1000)), methods=("weighted_kmeans", "minibatch", "kmeans"),
                  kmeans_max_nk: float = 3.1e8) -> list[dict]:
    """Weighted k-means variants on a plate with a 10x refined quarter (one run each, same process).

    Methods: ``weighted_kmeans`` (this package: restarts on a weighted subsample + full Lloyd passes),
    ``minibatch`` (scikit-learn ``MiniBatchKMeans``, batch 4096), ``kmeans`` (scikit-learn ``KMeans``,
    ``n_init=1``; skipped when n·k > ``kmeans_max_nk``).  Each row: ``name``, ``n``, ``k``, ``method``,
    ``time_s``, ``objective`` (Σ w‖p − μ‖², m⁴) and ``objective_ratio`` (to ``weighted_kmeans``).
    """
    import time

    from scipy.spatial import cKDTree

    from fem2tmm.cluster.seeding import weighted_kmeans

    rows = []
    for n, k in cases:
        X, w = _graded_centroids(n)
        res = {}
        for method in methods:
            if method == "kmeans" and len(X) * k > kmeans_max_nk:
                continue
            t = time.perf_counter()
            if method == "weighted_kmeans":
                C = weighted_kmeans(X, w, k, seed=0)
            elif method == "minibatch":
                from sklearn.cluster import MiniBatchKMeans

                C = MiniBatchKMeans(k, batch_size=4096, n_init=1, random_state=0).fit(X, sample_weight=w).cluster_centers_
            elif method == "kmeans":
                from sklearn.cluster import KMeans

                C = KMeans(k, n_init=1, random_state=0).fit(X, sample_weight=w).cluster_centers_
            else:
                raise ValueError(f"unknown seeding method {method!r}")
            dt = time.perf_counter() - t
            d, _ = cKDTree(C).query(X, workers=-1)
            res[method] = (dt, float(np.dot(w, d * d)))
        ref = res.get("weighted_kmeans", (None, np.nan))[1]
        for method, (dt, obj) in res.items():
            rows.append({"name": f"seeding_{len(X)}_{k}", "n": len(X), "k": k, "method": method, "time_s": dt,
                         "objective": obj, "objective_ratio": obj / ref})
    return rows


if __name__ == "__main__":  # pragma: no cover
    args = tuple(sys.argv[1:])
    if args == ("seeding",):
        for row in bench_seeding():
            print(json.dumps(row))
    else:
        for row in bench_cluster(args or ("1e5", "1e6", "tet3e5")):
            print(json.dumps(row))


def _metis_whole(points, cells, types, weights, k, seed=0):
    """pymetis k-way on a whole part's dual graph (area vertex weights, no region cuts): the issue's baseline.
    Returns labels; the time includes building the dual graph."""
    import pymetis
    import scipy.sparse as sp

    from fem2tmm.cluster.adjacency import dual_graph

    g = dual_graph(points, cells, types, "shell")
    m = len(cells)
    A = sp.coo_matrix((np.ones(len(g.a)), (g.a, g.b)), shape=(m, m))
    A = (A + A.T).tocsr()
    vw = np.maximum(1, np.rint(weights / weights.mean() * 1000)).astype(np.int64)
    _, parts = pymetis.part_graph(k, adjacency=pymetis.CSRAdjacency(A.indptr, A.indices), vweights=vw,
                                  options=pymetis.Options(seed=seed))
    return np.asarray(parts, np.int64)


def _quality(labels, areas, regions, k):
    a = np.bincount(labels, areas, minlength=k)
    spans = np.bincount(np.unique(labels * (regions.max() + 1) + regions) // (regions.max() + 1), minlength=k)
    return {"area_cv": float(a.std() / a.mean()), "clusters_crossing_regions": int((spans > 1).sum())}


def bench_cluster_metis(sizes=("baffle", "1e6"), accuracy: bool = True) -> list[dict]:
    """Clustering time and balance against METIS in one run (issue 21), and the reduced error with each.

    * ``baffle``: the baffle mesh (18 404 quads) -> 100 clusters with ``method="growing"`` (balanced, default),
      the thesis scheme (``balance=False``), ``method="metis"`` (pymetis per region) and pymetis k-way on the
      whole part with area weights (the issue's baseline: it crosses sharp edges); warm timings (the compiled
      kernels loaded by a first call), median of 3; area CV; clusters crossing a region border (sharp edge or
      junction);
    * ``1e6``: a plate of 10⁶ quads -> 1000, balanced growing against pymetis k-way (one run each);
    * ``accuracy``: examples/baffle/case_100.toml run with fem2tmm's clusters and with the whole-part METIS
      labels (``run(labels=...)``), both against the same independent reference (its noise reported).
    """
    import time

    from fem2tmm.cluster import PartInput, cluster_parts
    from fem2tmm.io import read_mesh

    from .cases import REPO

    def _repo_file(*parts):
        return str(REPO.joinpath(*parts))

    rows = []
    if "baffle" in sizes or accuracy:
        mesh = read_mesh(_repo_file("meshes", "baffle.msh"), unit="mm")
        groups = ["aperture_lip", "front_cone", "outer_skin", "main_cone", "middle_annulus", "back_annulus"]
        el = np.unique(np.concatenate([mesh.group(g).elements for g in groups]))
        cells, types = mesh.padded_cells[el], mesh.element_types[el]
        areas = mesh.element_areas(el)
        part = PartInput("baffle", "shell", el, cells, types, 100)
        regions = cluster_parts(mesh.points, [part], mesh.n_elements).regions[el]  # also loads the kernels
        variants = {
            "growing_balanced": lambda: cluster_parts(mesh.points, [part], mesh.n_elements).labels[el],
            "growing_thesis": lambda: cluster_parts(mesh.points, [part], mesh.n_elements, balance=False).labels[el],
            "metis_per_region": lambda: cluster_parts(mesh.points, [part], mesh.n_elements, method="metis").labels[el],
            "pymetis_whole_part": lambda: _metis_whole(mesh.points, cells[:, :4], types, areas, 100),
        }
        labels = {}
        for name, fn in variants.items():
            times = []
            for _ in range(3):
                t = time.perf_counter()
                labels[name] = fn()
                times.append(time.perf_counter() - t)
            rows.append({"bench": "cluster_metis", "mesh": "baffle", "elements": len(el), "clusters": 100,
                         "method": name, "median_s": float(np.median(times)), **_quality(labels[name], areas, regions, 100)})
        base = next(r["median_s"] for r in rows if r["method"] == "pymetis_whole_part")
        for r in rows:
            r["time_ratio_to_pymetis"] = r["median_s"] / base
    if "1e6" in sizes:
        from fem2tmm.mesh import shapes

        plate = shapes.plate(1.0, 1.0, 1000, 1000)
        m = plate.n_elements
        areas = plate.element_areas()
        part = PartInput("plate", "shell", np.arange(m), plate.padded_cells, plate.element_types, 1000)
        t = time.perf_counter()
        lab = cluster_parts(plate.points, [part], m).labels
        t_ours = time.perf_counter() - t
        t = time.perf_counter()
        lab_m = _metis_whole(plate.points, plate.padded_cells[:, :4], plate.element_types, areas, 1000)
        t_m = time.perf_counter() - t
        zero = np.zeros(m, np.int64)
        for name, lb, tt in (("growing_balanced", lab, t_ours), ("pymetis_whole_part", lab_m, t_m)):
            rows.append({"bench": "cluster_metis", "mesh": "plate_1e6", "elements": m, "clusters": 1000,
                         "method": name, "wall_s": tt, "time_ratio_to_pymetis": tt / t_m, **_quality(lb, areas, zero, 1000)})
    if accuracy:
        from fem2tmm.case import Case
        from fem2tmm.pipeline import run

        case = Case.from_toml(_repo_file("examples", "baffle", "case_100.toml"))
        full = np.full(mesh.n_elements, -1, np.int64)
        for name in ("growing_balanced", "pymetis_whole_part"):
            lab = full.copy()
            lab[el] = labels[name]
            res = run(case, labels=None if name == "growing_balanced" else lab)
            a = res.summary["accuracy"]
            rows.append({"bench": "cluster_metis_accuracy", "case": "examples/baffle/case_100.toml", "clusters": name,
                         "rms_K": a["rms_K"], "max_K": a["max_K"], "reference_noise_rms_K": a["reference_noise_rms_K"],
                         "excludes": a["excludes"]})
    return rows
