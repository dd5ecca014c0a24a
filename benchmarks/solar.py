"""Solar ray-tracing benchmarks (``fem2tmm bench solar``): one dict per measurement, medians of repeated timings.

* ``solar.throughput``: solar tracing (shadow rays + specular bounces, α = 0.2, specular reflectance 0.8) on the
  ~18 k-element baffle-like cone shell with vanes of :func:`benchmarks.cases.baffle_surface`, 10° off
  its axis, in intersection queries (segments) per second, against bare embreex closest-hit queries on as many rays
  of the same model: the solar shadow rays themselves (parallel, coherent) and cosine-law emission rays.
* ``solar.super_faces``: solar tracing time with every active FE side its own group ("detailed") against ~100
  super faces at the same ray density (rays per m² of area projected normal to the Sun).
* ``solar.convergence``: RMS error of the face fluxes on the EUI-like cone (thesis §3.3.3) against a 100x-rays
  Halton reference, Halton against random origins at 100 / 1000 / 10000 rays per face.
"""

from __future__ import annotations

import numpy as np

from fem2tmm.radiation.smoothing import fitted_rate
from fem2tmm.radiation.solar import sun_origins, sunlit_emitters, trace_solar
from fem2tmm.radiation.surfaces import GroupEmitters, TriangleScene

from .cases import PERIHELION_FLUX, SUN_10DEG, baffle_surface, eui_cone
from .radiation import raw_embree_runner
from .run import median_call

def _shadow_rays(scene: TriangleScene, groups: np.ndarray, n: int, seed: int = 0):
    """``n`` solar shadow rays of the model: origins on the Sun-facing sides (pseudo-random, in proportion to the
    projected area), direction towards the Sun.  Returns ``(origins (n, 3), directions (n, 3))``."""
    g = int(groups.max()) + 1
    em = sunlit_emitters(scene, groups, g, SUN_10DEG)
    rng = np.random.default_rng(seed)
    grp = rng.choice(g, size=n, p=em.weight / em.weight.sum())
    *_, o, _ = sun_origins(scene, em, grp, rng.random((n, 2)), SUN_10DEG)
    return o, np.broadcast_to(SUN_10DEG, o.shape)


def _cosine_rays(scene: TriangleScene, groups: np.ndarray, n: int, seed: int = 0):
    """``n`` cosine-law emission rays from the sides of ``groups`` (diffuse emission, as the IR tracer emits)."""
    g = int(groups.max()) + 1
    em = GroupEmitters.build(scene, groups, np.ones(len(groups)), g)
    rng = np.random.default_rng(seed)
    k = rng.integers(0, len(em.entry_prim), n)
    return scene.emit(em.entry_prim[k], 1.0 - 2.0 * em.entry_side[k], rng.random((n, 4)))


def bench_solar_throughput(repeat: int = 3, threads: int = 2, ray_density: float = 2.0e7) -> list[dict]:
    """Segments per second of solar tracing vs bare embreex (parallel shadow rays and cosine rays) on the baffle."""
    surf, fe, _, _ = baffle_surface()
    scene = TriangleScene(surf)
    if scene.engine.name != "embree":
        return [{"bench": "solar.throughput", "skipped": "embreex not importable"}]
    t_sol, c_sol, res = median_call(lambda: trace_solar(surf, SUN_10DEG, PERIHELION_FLUX, groups=fe,
                                                         ray_density=ray_density, scene=scene, threads=threads),
                                     repeat, cpu=True)
    t_par, c_par, _ = median_call(raw_embree_runner(scene, *_shadow_rays(scene, fe, res.segments), threads),
                                   repeat, cpu=True)
    t_cos, _, _ = median_call(raw_embree_runner(scene, *_cosine_rays(scene, fe, res.segments), threads), repeat,
                               cpu=True)
    return [{
        "bench": "solar.throughput", "model": "baffle_18k", "triangles": len(scene.tri_face), "threads": threads,
        "ray_density_per_m2": ray_density, "rays": res.rays, "segments": res.segments,
        "segments_per_ray": res.segments / max(res.rays, 1), "solar_s": t_sol,
        "solar_segments_per_s": res.segments / t_sol, "solar_rays_per_s": res.rays / t_sol,
        "raw_embree_parallel_s": t_par, "raw_embree_parallel_rays_per_s": res.segments / t_par,
        "raw_embree_cosine_s": t_cos, "raw_embree_cosine_rays_per_s": res.segments / t_cos,
        "ratio_parallel": t_par / t_sol, "ratio_cosine": t_cos / t_sol, "solar_cpu_s": c_sol,
        "raw_embree_parallel_cpu_s": c_par, "incident_W": res.incident, "absorbed_W": res.absorbed,
    }]


def bench_solar_super_faces(repeat: int = 3, ray_density: float = 2.0e7, threads: int = 2) -> list[dict]:
    """Solar tracing time on the baffle: every active FE side its own group vs ~100 super faces, same density."""
    surf, fe, sf, _ = baffle_surface()
    scene = TriangleScene(surf)
    rows = {}
    for label, groups in (("detailed", fe), ("super_faces", sf)):
        t, res = median_call(lambda: trace_solar(surf, SUN_10DEG, PERIHELION_FLUX, groups=groups,
                                                  ray_density=ray_density, scene=scene, threads=threads), repeat)
        rows[label] = {"groups": len(res.power_group), "rays": res.rays, "segments": res.segments, "seconds": t,
                       "absorbed_W": res.absorbed}
    return [{"bench": "solar.super_faces", "model": "baffle_18k", "ray_density_per_m2": ray_density,
             **{f"{k}_{q}": v for k, d in rows.items() for q, v in d.items()},
             "ratio_detailed_over_super": rows["detailed"]["seconds"] / rows["super_faces"]["seconds"]}]


def bench_solar_convergence(rays=(100, 1000, 10000), seeds: int = 3, reference_factor: int = 100) -> list[dict]:
    """RMS face-flux error (W/m²) on the EUI-like cone 10° off the Sun, Halton vs random (mean over ``seeds``),
    against a Halton reference with ``reference_factor`` x 1000 rays per face, and the log-log slopes."""
    surf = eui_cone()
    scene = TriangleScene(surf)
    area = surf.face_areas
    n_ref = 1000 * reference_factor
    ref = trace_solar(surf, SUN_10DEG, PERIHELION_FLUX, rays_per_group=n_ref, seed=10_000, scene=scene)
    q_ref = ref.absorbed_face / area
    out = []
    for sampling in ("halton", "random"):
        errs = []
        for n in rays:
            e = [np.sqrt(np.mean((trace_solar(surf, SUN_10DEG, PERIHELION_FLUX, rays_per_group=n, sampling=sampling,
                                              seed=s, scene=scene).absorbed_face / area - q_ref) ** 2))
                 for s in range(seeds)]
            errs.append(float(np.mean(e)))
        out.append({"bench": "solar.convergence", "model": "eui_cone", "faces": surf.n_faces, "sampling": sampling,
                    "rays_per_face": list(rays), "rms_flux_error_W_m2": errs, "reference_rays_per_face": n_ref,
                    "slope": fitted_rate(rays, errs)[0], "seeds": seeds,
                    "max_flux_W_m2": float(q_ref.max())})
    return out


def bench_solar(repeat: int = 3) -> list[dict]:
    """All measurements of ``fem2tmm bench solar`` (list of dicts, medians over ``repeat``)."""
    return (bench_solar_throughput(repeat=repeat) + bench_solar_super_faces(repeat=repeat)
            + bench_solar_convergence())
