"""``fem2tmm bench orbit``: orbital heat fluxes (issue 18).

* ``orbit.throughput``: the smallsat example (``examples/smallsat``: 920 quads + 8 hexahedra, 700 km SSO, nadir
  pointing) at 24 positions (+ the eclipse boundaries), the three fluxes traced on the FE faces at 200 rays per
  face side: rays per second of albedo and planet-IR tracing (planet-focused Halton sampling: direction, cap
  intersection, shadow ray, bounces) relative to the solar tracer alone in the same run, and the time per kind.
* ``orbit.super_faces``: the same orbit traced on the example's super faces at the same ray density (origins over
  each super face as a whole) against the FE faces.
* ``orbit.convergence``: δ (thesis eq. 2.44, RMS error over 24 positions, both sides of a unit square and the
  runs, W/m²) of the albedo of the thesis' orbit case 1 (§2.4.4) against rays per face, for PFHS and for plain
  hemisphere sampling (cosine law over the face's hemisphere) with scrambled Halton points and with pseudo-random
  numbers, against the independent quadrature of eq. 2.23 of ``tests/test_orbit.py``; the rays each needs for
  δ = 0.1 W/m² (log-log interpolation) and the thesis' Fig. 2.31(b) as ``examples/smallsat/orbit_convergence.png``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from fem2tmm.case import Case
from fem2tmm.fem.model import build_model
from fem2tmm.io import read_mesh
from fem2tmm.radiation.orbital import trace_orbit
from fem2tmm.radiation.surfaces import TriangleScene
from fem2tmm.reduce.network import build_reduced, super_faces
from fem2tmm.stages.cluster import cluster_model
from fem2tmm.stages.radiation import radiation_surface

from .cases import REPO

CASE = REPO / "examples" / "smallsat" / "case.toml"
RAYS = 200


def _smallsat():
    case = Case.from_toml(CASE)
    mesh = read_mesh(case.mesh.file, unit=case.mesh.unit)
    model = build_model(mesh, case)
    return case, model, radiation_surface(model)


def _trace(case, surface, scene, groups, rays, kinds):
    o = case.orbit
    t0, c0 = time.perf_counter(), time.process_time()
    fl = trace_orbit(surface, o.orbit, o.attitude, kinds=kinds, groups=groups, rays_per_group=rays, scene=scene,
                     per="side")
    return fl, time.perf_counter() - t0, time.process_time() - c0


def bench_orbit_throughput() -> list[dict]:
    case, model, surface = _smallsat()
    scene = TriangleScene(surface)
    active = model.faces.active
    groups = np.where(active, np.arange(len(active)), -1)
    rows = {}
    for kind in ("solar", "albedo", "ir"):
        _trace(case, surface, scene, groups, RAYS, (kind,))  # warm-up (compilation, caches)
        fl, wall, cpu = _trace(case, surface, scene, groups, RAYS, (kind,))
        distinct = np.unique(fl.positions.true_anomaly, return_index=True)[1]
        rays = int(fl.rays[kind][distinct].sum())
        rows[kind] = {"wall_s": round(wall, 3), "cpu_s": round(cpu, 3), "rays": rays,
                      "rays_per_s": round(rays / wall), "rays_per_cpu_s": round(rays / cpu)}
    base = rows["solar"]["rays_per_cpu_s"]
    for kind in ("albedo", "ir"):
        rows[kind]["ratio_to_solar_cpu"] = round(rows[kind]["rays_per_cpu_s"] / base, 3)
    return [{"bench": "orbit.throughput", "model": "smallsat", "faces": int(model.faces.n),
             "positions": int(len(case.orbit.orbit.positions())), "rays_per_face": RAYS, **rows}]


def bench_orbit_super_faces() -> list[dict]:
    case, model, surface = _smallsat()
    scene = TriangleScene(surface)
    rm = build_reduced(model, cluster_model(model, case), case)
    sf_groups, owner = super_faces(model, rm)
    faces_per_group = np.bincount(sf_groups[sf_groups >= 0], minlength=len(owner))
    active = model.faces.active
    fe_groups = np.where(active, np.arange(len(active)), -1)
    kinds = ("solar", "albedo", "ir")
    _trace(case, surface, scene, fe_groups, 20, kinds)  # warm-up
    fe, wall_fe, cpu_fe = _trace(case, surface, scene, fe_groups, RAYS, kinds)
    sf, wall_sf, cpu_sf = _trace(case, surface, scene, sf_groups, np.maximum(faces_per_group * RAYS, 1), kinds)
    a_fe, a_sf = fe.total("absorbed").sum(axis=1), sf.total("absorbed").sum(axis=1)
    return [{"bench": "orbit.super_faces", "model": "smallsat", "super_faces": int(len(owner)),
             "fe_sides": int(active.sum()), "detailed_wall_s": round(wall_fe, 3), "detailed_cpu_s": round(cpu_fe, 3),
             "super_faces_wall_s": round(wall_sf, 3), "super_faces_cpu_s": round(cpu_sf, 3),
             "cpu_ratio_detailed_to_super_faces": round(cpu_fe / cpu_sf, 3),
             "absorbed_total_rel_diff_max": float(np.max(np.abs(a_sf - a_fe) / np.maximum(a_fe, 1e-9)))}]


def _rays_for(rays: list[int], deltas: list[float], target: float = 0.1) -> float | None:
    """Rays per face at which δ crosses ``target`` (log-log interpolation between the bracketing points; the
    last two points' slope extrapolates when none reaches it)."""
    r, d = np.log(np.asarray(rays, float)), np.log(np.asarray(deltas, float))
    k = np.flatnonzero(d <= math.log(target))
    if k.size and k[0] > 0:
        i = k[0] - 1
    elif k.size:
        return float(rays[0])
    else:
        i = len(r) - 2
    slope = (d[i + 1] - d[i]) / (r[i + 1] - r[i])
    return float(np.exp(r[i] + (math.log(target) - d[i]) / slope))


def bench_orbit_convergence() -> list[dict]:
    from tests.test_orbit import case_delta, case_reference  # the independent quadrature of eq. 2.23

    orbit, att, ref = case_reference(1)
    plans = {
        ("planet", "halton"): ([100, 300, 1000, 3000, 10000], 4),
        ("planet", "random"): ([100, 1000, 10000], 2),
        ("hemisphere", "halton"): ([100, 1000, 10000, 30000], 2),
        ("hemisphere", "random"): ([1000, 10000, 100000], 1),
    }
    out, curves = [], {}
    for (focus, sampling), (budget, runs) in plans.items():
        deltas = [case_delta(orbit, att, ref, n, range(runs), focus=focus, sampling=sampling) for n in budget]
        curves[(focus, sampling)] = (budget, deltas)
        out.append({"bench": "orbit.convergence", "case": "thesis 2.4.4 case 1", "focus": focus, "sampling": sampling,
                    "runs": runs, "rays_per_face": budget, "delta_W_m2": [round(x, 5) for x in deltas],
                    "rays_for_delta_0.1": _rays_for(budget, deltas)})
    need = {k: _rays_for(*v) for k, v in curves.items()}
    pf = need[("planet", "halton")]
    out.append({"bench": "orbit.convergence", "summary": "rays per face for delta = 0.1 W/m2, ratio to PFHS",
                "pfhs_halton": round(pf), **{f"{f}_{s}_ratio": round(need[(f, s)] / pf, 1) for f, s in need
                                             if (f, s) != ("planet", "halton")}})
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.0, 4.2), dpi=110)
        for (f, s), (b, d) in curves.items():
            ax.loglog(b, d, "o-" if f == "planet" else "s--",
                      label=f"{'PFHS' if f == 'planet' else 'hemisphere'}, {s}")
        ax.axhline(0.1, color="0.6", lw=0.8)
        ax.set_xlabel("rays per face")
        ax.set_ylabel("δ [W/m²] (eq. 2.44)")
        ax.set_title("Albedo, thesis orbit case 1 (cf. Fig. 2.31(b))")
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = REPO / "examples" / "smallsat" / "orbit_convergence.png"
        fig.savefig(path)
        plt.close(fig)
        out[-1]["plot"] = str(path.relative_to(REPO))
    except ImportError:
        pass
    return out


def bench_orbit() -> list[dict]:
    return bench_orbit_throughput() + bench_orbit_super_faces() + bench_orbit_convergence()
