"""Ray-tracing benchmarks (``fem2tmm bench rays``): one dict per measurement, medians of repeated timings.

* ``throughput``: exchange-factor tracing (the REF matrix ℱ included) on a closed 20 k-triangle sphere (inner
  sides, diffuse ε = 0.5) and on an ~18 k-element baffle-like cone shell with vanes (ε = 0.1, specular reflectance
  0.9), in intersection queries (ray segments) per second, against bare embreex closest-hit queries on as many rays
  of the same model, run in the same number of threads (goal: ratio >= 0.7).
* ``convergence``: mean relative error of ℱ₁₂ between the two quadrangles of thesis §2.3.5 (ε = 0.8, diffuse
  reflectance 0.2, against the exact value) and of the point-wise view factor of §2.2.5 against rays per face,
  Halton and crude Monte Carlo, and the log-log slope κ (goal: κ >= 0.75 for Halton, thesis Fig. 2.18); the
  sampler alone on ball indicators and a jittered oracle show the best rate any sampling can reach on such
  integrands (:func:`bench_convergence`).
* ``super_faces``: REF time on the baffle with its FE faces as groups against ~100 super faces (angular/axial
  strips) at equal ray density (thesis Table 5.1 reports a 29x gain with its own per-face tracer), and the super
  faces at 1/30 of that density (still a lower line-sum error than the FE faces).
"""

from __future__ import annotations

import time

import numpy as np

from fem2tmm.radiation.engine import make_engine
from fem2tmm.radiation.reference import TWO_QUADS, two_quads_ref
from fem2tmm.radiation.smoothing import fitted_rate
from fem2tmm.radiation.surfaces import GroupEmitters, Surface, TriangleScene
from fem2tmm.radiation.tracer import exchange_factors, map_batches, trace_exchange

from .cases import baffle_surface, sphere_surface
from .kappa import ball_indicator_errors, jittered_view_factor_errors
from .run import median_call

def raw_embree_runner(scene: TriangleScene, origins: np.ndarray, directions: np.ndarray, threads: int,
                      direct: bool = False):
    """A callable running bare closest-hit queries on the rays (origins (r, 3) m, directions (r, 3)) of ``scene``,
    split over ``threads`` Python threads: with ``direct`` False, embreex's own ``EmbreeScene.run`` on float32
    arrays prepared beforehand, over a scene that embreex builds (the issue's baseline); with ``direct`` True, the
    tracer's compiled C-API query loop (:func:`~fem2tmm.radiation.engine.EmbreeEngine.intersect`) over ``scene``'s
    own Embree scene (so the ratio to it is the tracer's bookkeeping alone)."""
    chunks = np.array_split(np.arange(len(origins)), max(threads, 1) * 8)
    if direct:
        o64 = np.ascontiguousarray(origins, np.float64)
        d64 = np.ascontiguousarray(directions, np.float64)
        prim, t = np.empty(len(o64), np.int64), np.empty(len(o64))

        def query(b):
            a, e = chunks[b][0], chunks[b][-1] + 1
            scene.engine.intersect(o64[a:e], d64[a:e], out=(prim[a:e], t[a:e]))
    else:
        ex = make_engine(scene.tri_vertices, "embreex")
        o32 = np.ascontiguousarray(origins - ex.center, np.float32)
        d32 = np.ascontiguousarray(directions, np.float32)

        def query(b):
            a, e = chunks[b][0], chunks[b][-1] + 1
            ex.raw(o32[a:e], d32[a:e])

    return lambda: map_batches(query, len(chunks), threads)


def _emission_rays(scene: TriangleScene, groups: np.ndarray, n: int, seed: int = 0):
    """``n`` emission rays of the model (origins on the emitting sides, cosine directions)."""
    surf = scene.surface
    em = GroupEmitters.build(scene, groups, np.where(surf.active, surf.emissivity, 0.0), int(groups.max()) + 1)
    rng = np.random.default_rng(seed)
    k = rng.integers(0, len(em.entry_prim), n)
    return scene.emit(em.entry_prim[k], 1.0 - 2.0 * em.entry_side[k], rng.random((n, 4)))


def bench_throughput(repeat: int = 7, threads: int = 2, rays_per_face: int = 200) -> list[dict]:
    """Segments per second of exchange-factor tracing vs bare embreex on the sphere and the baffle.

    The machine is shared and its speed drifts by tens of per cent within minutes, so the runs are interleaved
    (baseline, tracer, direct baseline, baseline, tracer, ...; one unrecorded round that warms every runner up,
    then ``repeat`` rounds) and each ratio is taken per round, between runs a few seconds apart; the median of the
    per-round ratios is reported along with the median times.  The tracer's time is the whole ``trace_exchange`` call and its REF matrix ℱ: scene build, emission,
    tracing, tally, reciprocity and closure, then ``.F``."""
    out = []
    for name, (surf, groups) in (("sphere_20k", sphere_surface()), ("baffle_18k", baffle_surface()[:2])):
        scene = TriangleScene(surf)
        if scene.engine.name != "embree":
            return [{"bench": "rays.throughput", "skipped": "embreex not importable"}]
        # the REFs F included (they are derived from GR on first use)
        run = lambda: trace_exchange(surf, groups, rays_per_group=rays_per_face, threads=threads).F  # noqa: E731
        res = trace_exchange(surf, groups, rays_per_group=rays_per_face, threads=threads)  # the baselines' segments
        rays = _emission_rays(scene, groups, res.segments)
        runners = {"raw_embree": raw_embree_runner(scene, *rays, threads)}
        if scene.engine.direct is not None:  # the same queries through our own C-API scene: bookkeeping alone
            runners["raw_direct"] = raw_embree_runner(scene, *rays, threads, direct=True)
        wall = {k: [] for k in ["exchange", *runners]}
        cpu = {k: [] for k in wall}
        for r in range(repeat + 1):  # round 0 warms every runner up and is not recorded
            for key, fn in (("raw_embree", runners["raw_embree"]), ("exchange", run),
                            *((k, f) for k, f in runners.items() if k != "raw_embree")):
                t, c = time.perf_counter(), time.process_time()
                fn()
                if r:
                    wall[key].append(time.perf_counter() - t)
                    cpu[key].append(time.process_time() - c)
        med = {k: float(np.median(v)) for k, v in wall.items()}
        ratio = lambda k: float(np.median(np.array(wall[k]) / np.array(wall["exchange"])))  # noqa: E731
        row = {
            "bench": "rays.throughput", "model": name, "triangles": len(scene.tri_face),
            "groups": res.n_groups, "rays": int(res.rays.sum()), "segments": res.segments, "threads": threads,
            "rounds": repeat, "exchange_s": med["exchange"], "exchange_segments_per_s": res.segments / med["exchange"],
            "exchange_rays_per_s": float(res.rays.sum()) / med["exchange"], "raw_embree_s": med["raw_embree"],
            "raw_embree_rays_per_s": res.segments / med["raw_embree"], "ratio": ratio("raw_embree"),
            "ratio_rounds": [float(x) for x in np.array(wall["raw_embree"]) / np.array(wall["exchange"])],
            "ratio_cpu": float(np.median(np.array(cpu["raw_embree"]) / np.array(cpu["exchange"]))),
            "goal_ratio": 0.7,
        }
        if "raw_direct" in runners:
            row.update({"raw_direct_s": med["raw_direct"], "ratio_to_raw_direct": ratio("raw_direct")})
        out.append(row)
    return out


def _pointwise_scene():
    """Thesis §2.2.5: a 1e-4 m square emitter 5 m under the rectangle [-3, 2] x [-4, 3] (F = 0.295578)."""
    h = 0.5e-4
    pts = np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0],
                    [2, 3, 5], [2, -4, 5], [-3, -4, 5], [-3, 3, 5]], float)  # target ordered with normal -z
    surf = Surface(pts, [[0, 1, 2, 3], [4, 5, 6, 7]], emissivity=1.0,
                   active=np.array([[True, False], [True, False]]))
    return surf, np.array([0, -1, 1, -1])


POINTWISE_F = 0.295578  # thesis §2.2.5 (closed form, checked in tests/test_radiation_exchange.py)


def bench_convergence(seeds: int = 100, rays=(250, 1000, 4000, 16000, 64000, 256000)) -> list[dict]:
    """Mean relative error against rays, Halton and random, with the log-log slope κ, on two cases:

    * ``two_quads_F12``: ℱ₁₂ between the two quadrangles of thesis §2.3.5 (coupled sampling of origin and
      direction: the hit/miss integrand is discontinuous in 4 dimensions), against the exact value of
      :func:`fem2tmm.radiation.reference.two_quads_ref` (0.08678924, Nyström quadrature of the reflection integral
      equation converged to 13 digits; the thesis' 0.0868 is its 4-digit rounding, 1.2e-4 off, which flattened the
      slope measured at 64 000 rays);
    * ``pointwise_F``: the 1e-4 m emitter under a rectangle of §2.2.5 (the origin hardly matters: a 2-D
      discontinuous integrand, the case of the thesis' "κ approaching 0.75", l. 1083);

    the same scrambled Halton points (and iid ones) with no ray tracer, on the indicator of a 4-D and a 2-D ball of
    known volume (:func:`benchmarks.kappa.ball_indicator_errors`); and, as the bound no sampling of these
    integrands can beat, the jittered (one uniform point per cell of an m^d grid) estimator of the two quadrangles'
    direct view factor in 4-D and from a point emitter in 2-D
    (:func:`benchmarks.kappa.jittered_view_factor_errors`, an independent numpy implementation).  For
    the indicator of a set with a smooth boundary in d dimensions, randomised QMC and stratified sampling converge
    at best as n^-(1/2 + 1/(2d)) (mean error; the variance of jittered sampling is O(n^-(1 + 1/d))): 0.625 for
    d = 4, 0.75 for d = 2.  The error is the mean over ``seeds`` of |estimate / reference - 1|."""
    pts, faces = np.concatenate(TWO_QUADS), np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    exact = float(two_quads_ref().ref[0, 1])
    surf_pw, groups_pw = _pointwise_scene()
    cases = (
        ("two_quads_F12", exact, 4,
         lambda n, sampling, s: exchange_factors(pts, faces, emissivity=0.8, rays_per_face=n, sampling=sampling,
                                                 seed=s, threads=1).F[0, 1]),
        ("pointwise_F", POINTWISE_F, 2,
         lambda n, sampling, s: trace_exchange(surf_pw, groups_pw, rays_per_group=[n, 0], sampling=sampling,
                                               seed=s, threads=1).F_raw[0, 1]),
    )
    out = []
    for case, ref, dim, estimate in cases:
        for sampling in ("halton", "random"):
            t = time.perf_counter()
            errs = [float(np.mean([abs(estimate(n, sampling, s) / ref - 1.0) for s in range(seeds)])) for n in rays]
            slope, local = fitted_rate(rays, errs)
            out.append({"bench": "rays.convergence", "case": case, "sampling": sampling, "reference": ref,
                        "rays_per_face": list(rays), "mean_rel_error": errs, "kappa": float(slope),
                        "kappa_local": local, "seeds": seeds, "goal_kappa_halton": 0.75,
                        "best_rate_for_a_discontinuous_integrand": 0.5 + 0.5 / dim,
                        "seconds": time.perf_counter() - t})
    for dim in (4, 2):  # the sampler alone, no ray tracer: the indicator of a ball of known volume
        t = time.perf_counter()
        r = ball_indicator_errors(dim, ns=rays, seeds=range(seeds))
        for sampling in ("halton", "random"):
            out.append({"bench": "rays.convergence", "case": f"ball_{dim}d_indicator", "sampling": sampling,
                        "reference": r["exact"], "rays_per_face": list(rays),
                        "mean_rel_error": r[sampling]["mean_rel_error"], "kappa": r[sampling]["kappa"],
                        "kappa_local": r[sampling]["kappa_local"], "seeds": seeds,
                        "best_rate_for_a_discontinuous_integrand": 0.5 + 0.5 / dim,
                        "seconds": time.perf_counter() - t})
    for case, emitter, dim in (("two_quads_view_factor_jittered_4d", "face", 4),
                               ("point_view_factor_jittered_2d", "point", 2)):
        t = time.perf_counter()
        r = jittered_view_factor_errors(seeds=range(2 * seeds), emitter=emitter)
        out.append({"bench": "rays.convergence", "case": case, "sampling": "jittered (numpy, independent)",
                    "rays_per_face": [int(n) for n in r["n"]], "mean_rel_error": [float(e) for e in r["mean_rel_error"]],
                    "kappa": float(r["kappa"]), "kappa_se": float(r["kappa_se"]),
                    "kappa_local": [float(k) for k in r["kappa_local"]], "seeds": 2 * seeds,
                    "best_rate_for_a_discontinuous_integrand": 0.5 + 0.5 / dim, "seconds": time.perf_counter() - t})
    return out


def bench_super_faces(repeat: int = 3, ray_density: float = 1.0e7, threads: int = 2) -> list[dict]:
    """REF time on the baffle: FE faces as groups vs ~100 super faces at equal ray density (rays per m²), and the
    super faces again at 1/30 of the density (their RMS LSE then is still below the FE faces' one: the time gain
    at equal accuracy).  Both runs intersect the same FE triangles with Embree, so at equal density the tracing
    work is the same; the thesis' Table 5.1 gain came from testing fewer, larger primitives."""
    surf, fe, sf, n_sf = baffle_surface()
    rows = {}
    for label, groups, dens in (("fe_faces", fe, ray_density), ("super_faces", sf, ray_density),
                                ("super_faces_low", sf, ray_density / 30)):
        t, res = median_call(lambda: trace_exchange(surf, groups, ray_density=dens, threads=threads), repeat)
        rows[label] = {"groups": res.n_groups, "rays": int(res.rays.sum()), "seconds": t,
                       "nnz_GR": int(res.GR.nnz), "lse_rms": res.lse_rms}
    return [{"bench": "rays.super_faces", "model": "baffle_18k", "ray_density_per_m2": ray_density,
             **{f"{k}_{q}": v for k, d in rows.items() for q, v in d.items()},
             "gain_equal_density": rows["fe_faces"]["seconds"] / rows["super_faces"]["seconds"],
             "gain_low_density": rows["fe_faces"]["seconds"] / rows["super_faces_low"]["seconds"],
             "thesis_gain_table_5_1": 29.0}]


def bench_rays(repeat: int = 3) -> list[dict]:
    """All ray-tracing measurements of ``fem2tmm bench rays`` (list of dicts, medians over ``repeat``; the
    throughput ratios over 7 interleaved rounds)."""
    return bench_throughput(repeat=7) + bench_convergence() + bench_super_faces(repeat=repeat)
