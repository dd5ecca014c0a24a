"""Quadric super-face benchmarks (``fem2tmm bench quadric``): cost per ray of tracing against fitted quadrics
against the planar FE facets, one dict per measurement, medians of repeated timings.

* ``cylinders``: the perpendicular cylinders of thesis §3.2/§5.4 (``meshes/cylinders.msh``, 2 x 240 shells), 16
  super faces per cylinder (4 around x 4 along), each fitted on its own vertices; IR exchange factors (ε = 0.5,
  reflected 50 % specular, inner sides inactive).
* ``baffle``: the EUI-like baffle of :func:`fem2tmm.mesh.shapes.baffle` (5 184 quads) with its two cones (``main_cone``,
  ``front_cone``) fitted, one quadric per cone; 96 super faces (8 angular sectors per surface and side), both sides
  active, ε = 0.1 and the reflected 90 % all specular (a polished baffle: ~10 bounces per ray); IR exchange factors
  and solar fluxes with the Sun 10° off the axis.

Each row gives the planar and the quadric time (median of ``repeat``), rays, intersection queries (segments),
microseconds per ray and per segment, the ratio quadric / planar, the one-off set-up time of the quadric scene (fits,
patch areas, engines) and a physics figure of both runs.
"""

from __future__ import annotations

import time

import numpy as np

from fem2tmm.mesh import shapes
from fem2tmm.radiation.quadric import face_frames
from fem2tmm.radiation.quadric_scene import QuadricScene
from fem2tmm.radiation.solar import trace_solar
from fem2tmm.radiation.surfaces import Surface, TriangleScene
from fem2tmm.radiation.tracer import trace_exchange

from .cases import SUN_10DEG, cylinder_super_faces, cylinder_surface, read_cylinders
from .run import median_call

def cylinders_model():
    """``(surface, groups (2f,), region_of_face (f,), n_super_faces)`` of the committed perpendicular cylinders:
    16 super faces per cylinder, each its own quadric region."""
    points, faces, cyl = read_cylinders()
    sf = cylinder_super_faces(points, faces, cyl)
    return cylinder_surface(points, faces), np.c_[sf, -np.ones(len(faces), np.int64)].ravel(), sf, 32


def baffle_model(sectors: int = 8):
    """``(surface, groups (2f,), region_of_face (f,), n_super_faces)``: :func:`fem2tmm.mesh.shapes.baffle` with both
    sides active (ε = 0.1, specular), super faces = (surface, side, angular sector), the two cones as regions."""
    m = shapes.baffle()
    faces = m.blocks[0].cells
    f = len(faces)
    cen, _ = face_frames(m.points, faces)
    sector = np.floor((np.arctan2(cen[:, 1], cen[:, 0]) % (2 * np.pi)) / (2 * np.pi / sectors)).astype(np.int64)
    surface_id = np.full(f, -1, np.int64)
    region = np.full(f, -1, np.int64)
    names = [n for n, g in m.groups.items() if g.dim == 2]
    for k, name in enumerate(names):  # loop over the 6 surfaces of the baffle
        surface_id[m.groups[name].elements] = k
        if name in ("main_cone", "front_cone"):
            region[m.groups[name].elements] = k
    sf = (surface_id * sectors + sector) * 2
    groups = np.c_[sf, sf + 1].ravel()
    surf = Surface(m.points, faces, emissivity=0.1, absorptivity=0.1, specular=1.0)
    return surf, groups, region, 2 * sectors * len(names)


def _row(model, band, rays, t_flat, t_quad, seg_flat, seg_quad, setup, scene, extra):
    return {"bench": "quadric", "model": model, "band": band, "faces": int(scene.surface.n_faces),
            "quadric_surfaces": int(scene.n_surfaces), "quadric_triangles": int(scene._quad_tri.size),
            "rays": int(rays), "planar_s": t_flat, "quadric_s": t_quad, "planar_segments": int(seg_flat),
            "quadric_segments": int(seg_quad), "planar_us_per_ray": 1e6 * t_flat / rays,
            "quadric_us_per_ray": 1e6 * t_quad / rays, "planar_us_per_segment": 1e6 * t_flat / seg_flat,
            "quadric_us_per_segment": 1e6 * t_quad / seg_quad, "ratio": t_quad / t_flat,
            "quadric_setup_s": setup, **extra}


def bench_quadric(repeat: int = 3, threads: int = 2, rays_cylinders: int = 20_000, rays_baffle: int = 2000,
                  rays_solar: int = 200_000) -> list[dict]:
    """Quadric against planar super faces (see the module docstring); medians over ``repeat`` runs."""
    out = []
    for model, build, rays in (("cylinders", cylinders_model, rays_cylinders), ("baffle", baffle_model, rays_baffle)):
        surf, groups, region, n_sf = build()
        t0 = time.perf_counter()
        scene = QuadricScene.from_regions(surf, region)
        setup = time.perf_counter() - t0
        flat = TriangleScene(surf)
        t_f, r_f = median_call(lambda: trace_exchange(surf, groups, rays_per_group=rays, threads=threads,
                                                       scene=flat), repeat)
        t_q, r_q = median_call(lambda: trace_exchange(surf, groups, rays_per_group=rays, threads=threads,
                                                       scene=scene), repeat)
        extra = {"super_faces": n_sf, "planar_lse_rms": r_f.lse_rms, "quadric_lse_rms": r_q.lse_rms,
                 "planar_area_m2": float(r_f.area.sum()), "quadric_area_m2": float(r_q.area.sum())}
        if model == "cylinders":
            for key, r in (("planar", r_f), ("quadric", r_q)):
                GR = r.GR.toarray()
                extra[f"{key}_F12"] = float(GR[:16, 16:32].sum() / r.eps_area[:16].sum())
        out.append(_row(model, "ir", int(r_q.rays.sum()), t_f, t_q, r_f.segments, r_q.segments, setup, scene, extra))
        if model == "baffle":
            g_sun = groups.reshape(-1, 2)[:, 0] // 2  # one solar group per (surface, sector), both sides
            g_sun = np.repeat(g_sun, 2)
            run = lambda sc: trace_solar(surf, SUN_10DEG, 17400.0, groups=g_sun,  # noqa: E731
                                         ray_density=rays_solar / 0.01, scene=sc, threads=threads)
            t_f, s_f = median_call(lambda: run(flat), repeat)
            t_q, s_q = median_call(lambda: run(scene), repeat)
            extra = {"planar_absorbed_W": s_f.absorbed, "quadric_absorbed_W": s_q.absorbed,
                     "planar_escaped_W": s_f.escaped, "quadric_escaped_W": s_q.escaped}
            out.append(_row(model, "solar", s_q.rays, t_f, t_q, s_f.segments, s_q.segments, setup, scene, extra))
    return out
