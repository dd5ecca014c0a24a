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


def _metis_whole(points, cells, types, k, seed=0):
    """pymetis k-way on a whole part's dual graph with area vertex weights and no region cuts (the issue's
    baseline: it crosses sharp edges).  Returns labels; the time includes the dual graph and the areas."""
    import pymetis
    import scipy.sparse as sp

    from fem2tmm.cluster.adjacency import dual_graph
    from fem2tmm.mesh import geometry

    g = dual_graph(points, cells, types, "shell")
    m = len(cells)
    areas = geometry.shell_areas(points, cells, "quad4")
    A = sp.coo_matrix((np.ones(len(g.a)), (g.a, g.b)), shape=(m, m))
    A = (A + A.T).tocsr()
    vw = np.maximum(1, np.rint(areas / areas.mean() * 1000)).astype(np.int64)
    _, parts = pymetis.part_graph(k, adjacency=pymetis.CSRAdjacency(A.indptr, A.indices), vweights=vw,
                                  options=pymetis.Options(seed=seed))
    return np.asarray(parts, np.int64)


def _quality(labels, areas, regions, graph, sharp, k):
    """Area CV (over all clusters and the largest within one region), edge cut (m: shared edges between
    clusters), clusters spanning more than one region, sharp edges (dual-graph links above the feature angle)
    inside a cluster, and whether every cluster is one piece through the links of the part."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    a = np.bincount(labels, areas, minlength=k)
    nreg = int(regions.max()) + 1
    spans = np.bincount(np.unique(labels * nreg + regions) // nreg, minlength=k)
    cv_reg = [float(a[u].std() / a[u].mean()) for u in (np.unique(labels[regions == r]) for r in range(nreg))
              if len(u) > 1]
    same = labels[graph.a] == labels[graph.b]
    m = len(labels)
    n_comp = connected_components(csr_matrix((np.ones(int(same.sum())), (graph.a[same], graph.b[same])),
                                             shape=(m, m)), directed=False)[0]
    return {"area_cv": float(a.std() / a.mean()), "area_cv_max_in_region": max(cv_reg, default=0.0),
            "edge_cut_m": float(graph.measure[~same].sum()),
            "clusters_crossing_regions": int((spans > 1).sum()),
            "sharp_edges_inside_clusters": int((same & sharp).sum()), "contiguous": bool(n_comp == k)}


def _interleaved(variants: dict, rounds: int, baseline: str) -> tuple[dict, dict, dict]:
    """Run each variant once per round, in turn (so that the machine's load drifts alike for all); returns the
    last labels, the times (s) per variant and the per-round time ratios to ``baseline``."""
    import time

    labels, times = {}, {name: [] for name in variants}
    for _ in range(rounds):
        for name, fn in variants.items():
            t = time.perf_counter()
            labels[name] = fn()
            times[name].append(time.perf_counter() - t)
    ratios = {name: np.asarray(times[name]) / np.asarray(times[baseline]) for name in variants}
    return labels, times, ratios


def _case_rows(mesh_name, variants, rounds, quality, k, m):
    labels, times, ratios = _interleaved(variants, rounds, "pymetis_whole_part")
    rows = []
    for name in variants:
        rows.append({"bench": "cluster_metis", "mesh": mesh_name, "elements": m, "clusters": k, "method": name,
                     "rounds": rounds, "median_s": float(np.median(times[name])),
                     "times_s": [round(t, 4) for t in times[name]],
                     "time_ratio_to_pymetis": float(np.median(ratios[name])),
                     "time_ratio_range": [float(ratios[name].min()), float(ratios[name].max())],
                     **quality(labels[name])})
    return rows, labels


def bench_cluster_metis(sizes=("baffle", "1e6"), accuracy: bool = True, rounds: int = 5,
                        rounds_1e6: int = 3, accuracy_seeds=(0, 1)) -> list[dict]:
    """Clustering time, balance and edge cut against METIS, interleaved, and the reduced error with each (#21).

    * ``baffle``: the baffle mesh (18 404 quads, examples/baffle) -> 100 clusters with ``method="growing"``
      (balanced, the default), the thesis scheme (``balance=False``), ``method="metis"`` (pymetis per region)
      and pymetis k-way on the whole part with area weights (the issue's baseline: it crosses sharp edges; its
      time includes the dual graph and the areas, as fem2tmm's includes its geometry); ``rounds`` rounds, each
      variant once per round in turn, warm (the compiled kernels loaded by a first call);
    * ``1e6``: a plate of 10⁶ quads -> 1000, balanced growing and pymetis k-way, ``rounds_1e6`` rounds
      interleaved the same way;
    * ``accuracy``: examples/baffle/case_100.toml (100 super nodes) with fem2tmm's own clusters, with
      ``[clustering] method = "metis"`` and with the whole-part METIS labels (``run(labels=...)``), for each
      ``[radiation] seed`` of ``accuracy_seeds``: the three runs share one stage cache, so they are compared
      with the same detailed reference (its own random streams, ``role="reference"``), whose noise (two
      independent half references) is reported beside the error.

    Each timing row: ``median_s``, ``times_s``, ``time_ratio_to_pymetis`` (median over rounds of the ratio
    within a round) and its range, and the quality measures of :func:`_quality`.
    """
    import tempfile

    from fem2tmm.cluster import PartInput, cluster_parts
    from fem2tmm.cluster.adjacency import dual_graph
    from fem2tmm.cluster.regions import sharp_links
    from fem2tmm.io import read_mesh
    from fem2tmm.mesh import geometry

    from .cases import REPO

    def _repo_file(*parts):
        return str(REPO.joinpath(*parts))

    rows = []
    labels = {}
    if "baffle" in sizes or accuracy:
        mesh = read_mesh(_repo_file("meshes", "baffle.msh"), unit="mm")
        groups = ["aperture_lip", "front_cone", "outer_skin", "main_cone", "middle_annulus", "back_annulus"]
        el = np.unique(np.concatenate([mesh.group(g).elements for g in groups]))
        cells, types = mesh.padded_cells[el], mesh.element_types[el]
        areas = mesh.element_areas(el)
        part = PartInput("baffle", "shell", el, cells, types, 100)
        regions = cluster_parts(mesh.points, [part], mesh.n_elements).regions[el]  # also loads the kernels
        g = dual_graph(mesh.points, cells, types, "shell")
        sharp = sharp_links(g, geometry.shell_normals(mesh.points, cells[:, :4], "quad4"), 30.0)
        variants = {
            "growing_balanced": lambda: cluster_parts(mesh.points, [part], mesh.n_elements).labels[el],
            "pymetis_whole_part": lambda: _metis_whole(mesh.points, cells[:, :4], types, 100),
            "metis_per_region": lambda: cluster_parts(mesh.points, [part], mesh.n_elements, method="metis").labels[el],
            "growing_thesis": lambda: cluster_parts(mesh.points, [part], mesh.n_elements, balance=False).labels[el],
        }
        if "baffle" in sizes:
            r, labels = _case_rows("baffle", variants, rounds, lambda lb: _quality(lb, areas, regions, g, sharp, 100),
                                   100, len(el))
            rows += r
        else:
            labels = {"pymetis_whole_part": variants["pymetis_whole_part"]()}
    if "1e6" in sizes:
        from fem2tmm.mesh import shapes

        plate = shapes.plate(1.0, 1.0, 1000, 1000)
        m = plate.n_elements
        pa = plate.element_areas()
        pc = plate.padded_cells
        ppart = PartInput("plate", "shell", np.arange(m), pc, plate.element_types, 1000)
        pg = dual_graph(plate.points, pc, plate.element_types, "shell")
        v1e6 = {
            "growing_balanced": lambda: cluster_parts(plate.points, [ppart], m).labels,
            "pymetis_whole_part": lambda: _metis_whole(plate.points, pc[:, :4], plate.element_types, 1000),
        }
        r, _ = _case_rows("plate_1e6", v1e6, rounds_1e6,
                          lambda lb: _quality(lb, pa, np.zeros(m, np.int64), pg, np.zeros(len(pg.a), bool), 1000),
                          1000, m)
        rows += r
    if accuracy:
        import dataclasses

        from fem2tmm.case import Case
        from fem2tmm.pipeline import run

        case = Case.from_toml(_repo_file("examples", "baffle", "case_100.toml"))
        whole = np.full(mesh.n_elements, -1, np.int64)
        whole[el] = labels["pymetis_whole_part"]
        for seed in accuracy_seeds:
            c = dataclasses.replace(case, radiation=dataclasses.replace(case.radiation, seed=int(seed)))
            c_metis = dataclasses.replace(c, clustering=dataclasses.replace(c.clustering, method="metis"))
            with tempfile.TemporaryDirectory() as cache:
                for name, cc, lab in (("growing_balanced", c, None), ("metis_per_region", c_metis, None),
                                      ("pymetis_whole_part", c, whole)):
                    res = run(cc, labels=lab, cache=cache)
                    a = res.summary["accuracy"]
                    rows.append({"bench": "cluster_metis_accuracy", "case": "examples/baffle/case_100.toml",
                                 "radiation_seed": int(seed), "clusters": name, "n_super_nodes": int(res.reduced.network.n),
                                 "rms_K": a["rms_K"], "max_K": a["max_K"],
                                 "reference_noise_rms_K": a["reference_noise_rms_K"], "excludes": a.get("excludes")})
    return rows
