"""``fem2tmm bench cases`` (``python -m benchmarks.run cases``): load cases on the baffle example (18 404 quads), in-process and on a Dask LocalCluster.

Rows (one JSON object each):

* ``cases_serial`` / ``cases_local1`` / ``cases_local``: 8 cases whose optics all differ (every case traces its
  own super-face REFs and detailed solar loads; clustering and reduction are shared), in this process
  (``serial``: the tracer's two threads), on ``LocalCluster(n_workers=1)`` and on ``LocalCluster(n_workers=2)``
  (single-threaded workers), interleaved rounds, medians, the machine's load; the speed-ups, the Amdahl bound
  against the serial run, and whether all gave bit-for-bit the same temperatures.
* ``cases_extra``: one case from an empty stage cache (the full run), then 8 cases that differ only in a heater
  power with the shared stages cached: the time per extra case against the full run (goal <= 10 %).
* ``cases_sizing``: from the measured ray throughput per worker and the size of the data a worker receives, the
  workers a 10^6-element model x 100 orbit positions x 20 cases needs to finish in one hour (assumptions in the
  row).
"""

from __future__ import annotations

import copy
import os
import pickle
import tempfile
import time

import numpy as np

from fem2tmm import _validation as check
from fem2tmm.case import Case
from fem2tmm.pipeline import run
from fem2tmm.radiation.solar import _SolarBatches, sunlit_emitters
from fem2tmm.radiation.surfaces import TriangleScene
from fem2tmm.radiation.tracer import BATCH, _detach_scenes
from fem2tmm.stages.radiation import radiation_surface

from .run import REPO


def _base(rays_per_face: int, solar_rays_per_face: int) -> dict:
    return {
        "mesh": {"file": str(REPO / "meshes" / "baffle.msh"), "unit": "mm"},
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"paint": {"emissivity": 0.05, "absorptivity": 0.2, "specular": 1.0}},
        "parts": [{"name": "baffle", "groups": ["aperture_lip", "front_cone", "outer_skin", "main_cone",
                                                "middle_annulus", "back_annulus"],
                   "material": "al", "thickness": 1e-3, "front": "paint", "back": "paint", "super_nodes": 10,
                   "quadric": ["front_cone", "main_cone"]}],
        "boundary": [{"name": "screws", "kind": "temperature", "groups": ["screw_rims"], "value": 20.0},
                     {"name": "heater", "kind": "power", "groups": ["middle_annulus"], "value": 1.0}],
        "environment": {"sink_temperature": -100.0, "sun_direction": [-1.0, 1.0, 1.41421356],
                        "solar_flux": 17400.0, "solar_rays_per_face": solar_rays_per_face},
        "radiation": {"rays_per_face": rays_per_face},
        "reference": {"detailed": False},
    }


def _case(data: dict):
    return Case.from_dict(copy.deepcopy(data), source="<bench cases>")


def bench_cases(n_cases: int = 8, workers: int = 2, rays_per_face: int = 2000, solar_rays_per_face: int = 20,
                rounds: int = 3) -> list[dict]:
    """See the module docstring; ``rays_per_face`` per super face, ``solar_rays_per_face`` per FE face side (the
    example's budget divided by 2.5 and 5, so that the 8 x 3 runs take minutes, not an hour); ``rounds``
    interleaved rounds of the three schedulers, medians."""

    base = _base(rays_per_face, solar_rays_per_face)
    optics = [{"name": f"eol{k}", "optics": {"paint": {"emissivity": round(0.05 + 0.01 * k, 3),
                                                        "absorptivity": round(0.2 + 0.02 * k, 3)}}}
              for k in range(n_cases)]
    rows, results = [], {}
    runs = (("serial", "serial", None), ("local1", "local", 1), ("local", "local", workers))
    walls = {label: [] for label, _, _ in runs}
    load = [round(x, 2) for x in os.getloadavg()]  # the machine is shared: its load beside the numbers
    for _ in range(rounds):  # interleaved rounds: the three schedulers see the same load
        for label, scheduler, n in runs:
            data = {**base, "cases": optics, "compute": {"scheduler": scheduler, **({"workers": n} if n else {})}}
            t0 = time.perf_counter()
            results[label] = run(_case(data), cache=None)
            walls[label].append(time.perf_counter() - t0)
    for label, scheduler, n in runs:
        multi = results[label]  # stage times and rays of the last round
        wall = float(np.median(walls[label]))
        stage = lambda name: sum(r.summary["timings_s"].get(name, 0.0) for r in multi.results.values())  # noqa: E731
        traced = [(r.detailed.solar.rays, int(np.sum(r.reduced.radiation.rays))) for r in multi.results.values()]
        rays = sum(a + b for a, b in traced)
        rows.append({"bench": f"cases_{label}", "cases": n_cases, "workers": n or 1, "wall_s": round(wall, 2),
                     "wall_s_rounds": [round(w, 2) for w in walls[label]],
                     "solar_detailed_s": round(stage("solar_detailed"), 2), "radiation_s": round(stage("radiation"), 2),
                     "rays": rays, "batches": int(sum(-(-a // BATCH) - (-b // BATCH) for a, b in traced)),
                     "rays_per_s": round(rays / max(stage("solar_detailed") + stage("radiation"), 1e-9))})
    same = all(np.array_equal(results["serial"].results[n].reduced.T_recovered, results[k].results[n].reduced.T_recovered)
               for k in ("local1", "local") for n in results["serial"].results)
    # Amdahl against the serial run: its multi-batch traces (detailed solar) already run on the tracer's 2
    # threads; the rest (assembly, single-batch REF traces, solves, recovery) on one core.  Even if 2 cores halved
    # that rest, the speed-up is at most 1 / (1 - f / 2).
    f = max(0.0, 1.0 - rows[0]["solar_detailed_s"] / rows[0]["wall_s"])
    rows[2].update({"speedup_vs_serial": round(rows[0]["wall_s"] / rows[2]["wall_s"], 2),
                    "speedup_vs_1_worker": round(rows[1]["wall_s"] / rows[2]["wall_s"], 2),
                    "speedup_1_worker_vs_serial": round(rows[0]["wall_s"] / rows[1]["wall_s"], 2),
                    "serial_one_core_fraction": round(f, 3), "amdahl_bound_vs_serial": round(1.0 / (1.0 - f / 2), 2),
                    "bit_identical": same, "rounds": rounds, "load_before": load,
                    "load_after": [round(x, 2) for x in os.getloadavg()],
                    "goal": "speed-up >= 1.7 on 2 cores (issue 19); here against 1 worker",
                    "baseline": "cases_serial: the same cases in this process (its ray tracer runs 2 threads); "
                                "cases_local1: one single-threaded worker (on Dask the cases run concurrently in "
                                "client threads, 2 per worker)"})

    # the time per extra case once the shared stages are cached, against the full run of one case
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run(_case(base), cache=tmp)
        full = time.perf_counter() - t0
        powers = [{"name": f"p{k}", "boundary": {"heater": {"value": 0.5 + 0.25 * k}}} for k in range(n_cases)]
        t0 = time.perf_counter()
        warm = run(_case({**base, "cases": powers}), cache=tmp)
        wall = time.perf_counter() - t0
    per_case = [sum(r.summary["timings_s"].values()) for r in warm.results.values()]
    reused = sorted({k for r in warm.results.values() for k, v in (r.summary["cache"] or {}).items() if v == "reused"})
    rows.append({"bench": "cases_extra", "full_run_s": round(full, 2), "cases": n_cases, "warm_wall_s": round(wall, 2),
                 "per_extra_case_s": round(float(np.median(per_case)), 3),
                 "ratio_to_full": round(float(np.median(per_case)) / full, 3), "reused": reused,
                 "per_case_stages_s": {k: round(v, 3) for k, v in next(iter(warm.results.values())).summary["timings_s"].items()},
                 "goal": "<= 10 % of a full run (issue 19)"})
    rows.append(_sizing(results["serial"], rows[1]["rays_per_s"]))  # one worker's measured throughput
    return rows


def bench_cases_warm(n_cases: int = 8, workers: int = 2, rays_per_face: int = 2000, solar_rays_per_face: int = 20,
                     rounds: int = 3) -> list[dict]:
    """The ``cases_*`` rows of :func:`bench_cases` on Dask clusters that are already running (as a user's cluster
    is: ``scheduler = "tcp://..."``): ``LocalCluster(1)`` and ``LocalCluster(workers)`` are started once, before
    the timed rounds, and each gets one untimed warm-up run (the workers import fem2tmm and load the compiled
    kernels); then ``rounds`` interleaved rounds of serial / one worker / ``workers`` workers, medians.  Rows
    ``cases_warm_serial`` / ``cases_warm_local1`` / ``cases_warm_local`` with the speed-ups and bit-identity, and
    the start-up time of each cluster (what :func:`bench_cases` includes in every run)."""
    import logging

    from distributed import Client, LocalCluster

    base = _base(rays_per_face, solar_rays_per_face)
    optics = [{"name": f"eol{k}", "optics": {"paint": {"emissivity": round(0.05 + 0.01 * k, 3),
                                                        "absorptivity": round(0.2 + 0.02 * k, 3)}}}
              for k in range(n_cases)]
    load = [round(x, 2) for x in os.getloadavg()]
    clusters, startup = {}, {}
    try:
        for label, n in (("local1", 1), ("local", workers)):
            t0 = time.perf_counter()
            clusters[label] = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=None, silence_logs=logging.ERROR)
            startup[label] = time.perf_counter() - t0
        runs = (("serial", "serial"), ("local1", clusters["local1"].scheduler_address),
                ("local", clusters["local"].scheduler_address))

        def once(scheduler, cases):
            data = {**base, "cases": cases, "compute": {"scheduler": scheduler}}
            return run(_case(data), cache=None)

        def cpu(label):  # CPU seconds used so far by this process and by the cluster's workers
            workers = 0.0
            if label in clusters:
                with Client(clusters[label]) as c:
                    workers = sum(c.run(_cpu_seconds).values())
            return _cpu_seconds(), workers

        for label, scheduler in runs:  # untimed warm-up: imports and kernel loads on every worker
            once(scheduler, optics[:2])
        walls, results = {label: [] for label, _ in runs}, {}
        cpus = {label: [] for label, _ in runs}
        for _ in range(rounds):
            for label, scheduler in runs:
                c0 = cpu(label)
                t0 = time.perf_counter()
                results[label] = once(scheduler, optics)
                walls[label].append(time.perf_counter() - t0)
                c1 = cpu(label)
                cpus[label].append((c1[0] - c0[0], c1[1] - c0[1]))
    finally:
        for c in clusters.values():
            c.close()
    med = {label: float(np.median(w)) for label, w in walls.items()}
    same = all(np.array_equal(results["serial"].results[n].reduced.T_recovered, results[k].results[n].reduced.T_recovered)
               for k in ("local1", "local") for n in results["serial"].results)
    client_cpu = {label: float(np.median([c[0] for c in v])) for label, v in cpus.items()}
    worker_cpu = {label: float(np.median([c[1] for c in v])) for label, v in cpus.items()}
    # on 2 cores the client's own work (assembly, reduction, solves, recovery, scatter) shares the cores with the
    # workers: the 2-worker run cannot beat (client CPU + workers' CPU) / cores
    cores = os.cpu_count() or 1
    floor = (client_cpu["local"] + worker_cpu["local"]) / cores
    rows = [{"bench": f"cases_warm_{label}", "cases": n_cases, "wall_s": round(med[label], 2),
             "wall_s_rounds": [round(w, 2) for w in walls[label]],
             "client_cpu_s": round(client_cpu[label], 2), "workers_cpu_s": round(worker_cpu[label], 2),
             **({"cluster_startup_s": round(startup[label], 2)} if label in startup else {})} for label, _ in runs]
    rows[2].update({"speedup_vs_1_worker": round(med["local1"] / med["local"], 2),
                    "speedup_vs_serial": round(med["serial"] / med["local"], 2), "bit_identical": same,
                    "rounds": rounds, "load_before": load, "load_after": [round(x, 2) for x in os.getloadavg()],
                    "cpu_floor_s": round(floor, 2), "cores": cores,
                    "speedup_bound_vs_1_worker": round(med["local1"] / floor, 2),
                    "bound": "wall(1 worker) / ((client CPU + workers' CPU of the 2-worker run) / cores)",
                    "goal": "speed-up >= 1.7 on 2 cores (issue 19), here against 1 worker, clusters running"})
    # sizing from the one-worker run's CPU seconds: rays per worker CPU second (Dask's overhead on the worker
    # included, the waiting of the cases that share it excluded; cases_sizing divides by the cases' summed stage
    # times instead, which count the time two concurrent cases wait for the same worker)
    traced = [(r.detailed.solar.rays, int(np.sum(r.reduced.radiation.rays))) for r in results["local1"].results.values()]
    rate = sum(a + b for a, b in traced) / max(worker_cpu["local1"], 1e-9)
    rows.append({**_sizing(results["local1"], rate), "bench": "cases_warm_sizing",
                 "rate_from": "rays traced / worker CPU seconds of the one-worker run (median of the rounds)"})
    return rows


def _cpu_seconds() -> float:
    """User + system CPU seconds of this process (all its threads) so far."""
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _sizing(multi, rays_per_s_per_worker: float, elements: float = 1e6, positions: int = 100, cases: int = 20,
            rays_per_face: int = 10, kinds: int = 3) -> dict:
    """Workers for ``elements`` x ``positions`` x ``cases`` in one hour at ``rays_per_s_per_worker``, tracing
    ``kinds`` flux kinds (solar, albedo, planet IR) at ``rays_per_face`` rays per FE face and position, and the
    data a worker receives (the pickled solar job of the baffle per face, scaled)."""

    r = next(iter(multi.results.values()))
    faces = r.model.faces.n
    surface = radiation_surface(r.model)
    scene = TriangleScene(surface)
    sun = np.asarray(r.detailed.solar.sun_direction)
    g = 2 * faces
    em = sunlit_emitters(scene, np.arange(g, dtype=np.int64), g, sun)  # the detailed solar job, as trace_solar builds it
    rays = check.ray_budget(r.case.environment.solar_rays_per_face, None, em.area, em.weight > 0)
    job = _SolarBatches(scene, surface.optics("solar"), em, rays, np.ones(g), sun, "halton", 0, 1 << 17, 1e-12, 1000,
                        groups=np.arange(g, dtype=np.int64))
    job_bytes = len(pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL))
    detached, _ = _detach_scenes(job)  # what each trace sends on Dask: the job without its scene
    scene_bytes = len(pickle.dumps(scene, protocol=pickle.HIGHEST_PROTOCOL))  # sent once per executor
    rays = kinds * rays_per_face * elements * positions * cases
    worker_hours = rays / rays_per_s_per_worker / 3600.0
    return {"bench": "cases_sizing", "model_elements": elements, "positions": positions, "cases": cases,
            "rays_per_face_per_kind": rays_per_face, "kinds": kinds, "rays_total": rays,
            "rays_per_s_per_worker_measured": round(rays_per_s_per_worker),
            "workers_for_one_hour": int(np.ceil(worker_hours)),
            "job_with_scene_bytes_per_face": round(job_bytes / faces, 1),
            "scene_bytes_per_face": round(scene_bytes / faces, 1),
            "job_without_scene_bytes_per_face": round(len(detached) / faces, 1),
            "scene_MB_per_worker_at_1e6_faces": round(scene_bytes / faces * elements / 1e6, 1),
            "job_MB_per_trace_per_worker_at_1e6_faces": round(len(detached) / faces * elements / 1e6, 1),
            "result_MB_per_batch_at_1e6_faces": 2.36,
            "note": "the scene (points, faces) goes to each worker once per executor; the job of a trace (per-side "
                    "optics, emitters, sampling tables) to each worker once per trace; each "
                    "batch task carries its index and returns only the sides its rays touched (int32 side + float64 "
                    "power, absorbed and incident): 2.36 MB per batch of 131 072 rays measured at 999 698 faces "
                    "(benchmarks/solar_batches_ab.py bytes), bounded by the rays of a batch, not by the faces"}


# ------------------------------------------------------------------------------------------------------------------
# ``fem2tmm bench cases_smallsat``: 8 cases x 12 orbit positions on the small satellite (issue 19's orbit variant)

SMALLSAT = REPO / "examples" / "smallsat" / "case.toml"


def _smallsat_base(positions: int, orbit_rays_per_face: int, rays_per_face: int) -> dict:
    """The small-satellite example (``examples/smallsat/case.toml``, 944 FE faces) at β = +17° (the example's
    10:30 SSO on its date) instead of a date, so that cases can vary β; ``positions`` true anomalies (plus the
    eclipse boundaries), ``orbit_rays_per_face`` orbital rays per FE face side and position, ``rays_per_face``
    REF rays per super face, orbit-average and per-position steady solves, no detailed reference."""
    import tomllib

    data = tomllib.loads(SMALLSAT.read_text())
    data["mesh"]["file"] = str(REPO / "meshes" / "smallsat.msh")
    orbit = data["orbit"]
    for key in ("date", "raan"):
        orbit.pop(key)
    orbit.update(beta=17.0, positions=positions, rays_per_face=orbit_rays_per_face, steady="positions")
    data["radiation"]["rays_per_face"] = rays_per_face
    data["reference"] = {"detailed": False}
    return data


def bench_cases_smallsat(workers: int = 2, positions: int = 12, orbit_rays_per_face: int = 20,
                         rays_per_face: int = 500, rounds: int = 3) -> list[dict]:
    """8 cases x ``positions`` orbit positions on the small satellite: serial, ``LocalCluster(1)`` and
    ``LocalCluster(workers)`` in the same run (``rounds`` interleaved rounds, medians), then the time per extra case
    once the shared stages are cached.

    The cases: β = 17° or 60° x begin- or end-of-life white paint (solar absorptivity 0.25 / 0.45) x deck
    electronics 15 W or 5 W, through ``[[cases]]`` overrides.  Per case the orbit is traced (solar, albedo and
    planet IR at every position) unless a case with the same β and optics traced it already; the REFs (IR optics
    unchanged), clustering and reduction are shared through the memory cache.  ``orbit_rays_per_face`` and
    ``rays_per_face`` are the example's budgets divided by 10 and 4 (200, 2000), so that each scheduler's run
    takes about a minute on 2 cores.  Rows: ``smallsat_serial`` / ``smallsat_local1`` / ``smallsat_local`` (wall
    time, summed stage times, segments traced; speed-ups and bit-identity of every case's temperatures and
    per-position temperatures across the three), ``smallsat_extra`` (one full run from an empty cache, then 8
    cases differing only in the deck power: time per extra case against the full run)."""
    import os

    base = _smallsat_base(positions, orbit_rays_per_face, rays_per_face)
    cases = [{"name": f"b{beta}_{life}_{q}W", "orbit": {"beta": float(beta)},
              "optics": {"white_paint": {"absorptivity": alpha}},
              "boundary": {"electronics_on_deck": {"value": float(q)}}}
             for beta in (17, 60) for life, alpha in (("bol", 0.25), ("eol", 0.45)) for q in (15, 5)]
    load = lambda: [round(x, 2) for x in os.getloadavg()]  # noqa: E731 - the machine is shared
    # warm-up (not timed): one small case compiles the kernels here and fills their on-disk cache for the workers
    run(Case.from_dict(_smallsat_base(1, 2, 50), base_dir=SMALLSAT.parent, source="<warm-up>"), cache=None)
    def same(a, b):
        return all(np.array_equal(a.results[k].reduced.T_recovered, b.results[k].reduced.T_recovered)
                   and np.array_equal(a.results[k].orbit.T_positions, b.results[k].orbit.T_positions)
                   for k in a.results)

    schedulers = (("serial", "serial", None), ("local1", "local", 1), ("local", "local", workers))
    stats = {label: [] for label, _, _ in schedulers}
    reference, identical = None, True
    for _ in range(rounds):  # interleaved rounds: the machine is shared, its load drifts
        for label, scheduler, n in schedulers:
            data = {**base, "cases": cases, "compute": {"scheduler": scheduler, **({"workers": n} if n else {})}}
            before = load()
            t0 = time.perf_counter()
            multi = run(Case.from_dict(copy.deepcopy(data), base_dir=SMALLSAT.parent,
                                       source="<bench cases_smallsat>"), cache=None)
            wall = time.perf_counter() - t0
            res = list(multi.results.values())
            stage = lambda name: sum(r.summary["timings_s"].get(name, 0.0) for r in res)  # noqa: E731
            traced = {id(r.orbit.detailed): r.orbit.detailed for r in res}  # the orbit traces (shared ones once)
            stats[label].append({"wall": wall, "orbit": stage("orbit_detailed"), "radiation": stage("radiation"),
                                 "traces": len(traced), "segments": sum(o.segments for o in traced.values()),
                                 "cases": len(res), "positions": len(res[0].orbit.fluxes.positions),
                                 "load": before})
            if reference is None:
                reference = multi
            else:
                identical = identical and same(reference, multi)
            del multi, res, traced
    rows = []
    for label, _, n in schedulers:
        st = stats[label]
        med = lambda key: float(np.median([x[key] for x in st]))  # noqa: E731
        rows.append({"bench": f"smallsat_{label}", "cases": st[0]["cases"], "positions": st[0]["positions"],
                     "workers": n or 1, "rounds": rounds, "wall_s": round(med("wall"), 2),
                     "wall_s_rounds": [round(x["wall"], 2) for x in st], "orbit_s": round(med("orbit"), 2),
                     "radiation_s": round(med("radiation"), 2), "orbit_traces": st[0]["traces"],
                     "orbit_segments": int(st[0]["segments"]),
                     "segments_per_s": round(st[0]["segments"] / max(med("orbit"), 1e-9)),
                     "orbit_rays_per_face": orbit_rays_per_face, "rays_per_face": rays_per_face,
                     "load_1min_before_each": [x["load"][0] for x in st]})
    walls = {label: np.array([x["wall"] for x in stats[label]]) for label in stats}
    rows[2].update({"speedup_vs_serial": round(float(np.median(walls["serial"] / walls["local"])), 2),
                    "speedup_vs_1_worker": round(float(np.median(walls["local1"] / walls["local"])), 2),
                    "speedups_from": "median over the rounds of the per-round ratio",
                    "bit_identical": identical,
                    "goal": "speed-up >= 1.7 on 2 cores (issue 19)",
                    "baseline": "smallsat_serial: the same cases in this process (the tracer's 2 threads); "
                                "smallsat_local1: one single-threaded worker"})

    # the time per extra case once the shared stages are cached, against the full run of one case
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        run(Case.from_dict(copy.deepcopy(base), base_dir=SMALLSAT.parent, source="<bench>"), cache=tmp)
        full = time.perf_counter() - t0
        powers = [{"name": f"deck{k}", "boundary": {"electronics_on_deck": {"value": 5.0 + 2.5 * k}}}
                  for k in range(len(cases))]
        t0 = time.perf_counter()
        warm = run(Case.from_dict(copy.deepcopy({**base, "cases": powers}), base_dir=SMALLSAT.parent,
                                  source="<bench>"), cache=tmp)
        wall = time.perf_counter() - t0
    per_case = [sum(r.summary["timings_s"].values()) for r in warm.results.values()]
    reused = sorted({k for r in warm.results.values() for k, v in (r.summary["cache"] or {}).items() if v == "reused"})
    rows.append({"bench": "smallsat_extra", "full_run_s": round(full, 2), "cases": len(powers),
                 "warm_wall_s": round(wall, 2), "per_extra_case_s": round(float(np.median(per_case)), 3),
                 "ratio_to_full": round(float(np.median(per_case)) / full, 3), "reused": reused,
                 "per_case_stages_s": {k: round(v, 3)
                                       for k, v in next(iter(warm.results.values())).summary["timings_s"].items()},
                 "goal": "<= 10 % of a full run (issue 19)", "load_after": load()})
    return rows
