"""Scenario builders of the benchmarks: test geometries and cases built from the public API.

The builders the tests use too live in ``tests/scenarios.py`` and are re-exported here (one definition each).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from fem2tmm.mesh import shapes
from fem2tmm.case import Case
from fem2tmm.radiation.surfaces import Surface

REPO = Path(__file__).resolve().parents[1]
if str(REPO / "tests") not in sys.path:
    sys.path.append(str(REPO / "tests"))

from scenarios import (CYLINDER_AXES, PERIHELION_FLUX, SUN_10DEG, cylinder_super_faces,  # noqa: E402
                       cylinder_surface, eui_cone, read_cylinders, write_plate_deck)

__all__ = ["CYLINDER_AXES", "PERIHELION_FLUX", "REPO", "SUN_10DEG", "baffle_surface", "big_shell_structure",
           "cylinder_super_faces", "cylinder_surface", "eui_cone", "plate_case", "read_cylinders", "sphere_surface",
           "write_plate_deck"]


def plate_case(n: int):
    """``(mesh, case)``: an n x n quad aluminium plate (1 m², 1 mm), black, its ``xmin`` edge at 20 °C, 100 W/m²
    absorbed on the plate."""
    mesh = shapes.plate(1.0, 1.0, n, n)
    case = Case.from_dict({
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"black": {"emissivity": 1.0}},
        "parts": [{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3,
                   "front": "black", "back": "black"}],
        "boundary": [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                     {"kind": "flux", "groups": ["plate"], "value": 100.0}],
    })
    return mesh, case


def sphere_surface(subdivisions: int = 5) -> tuple[Surface, np.ndarray]:
    """Closed icosphere (radius 1 m) with its *inner* sides emitting (ε = 0.5, diffuse): (surface, groups)."""
    import trimesh  # a bench-only dependency (the [bench] extra)

    m = trimesh.creation.icosphere(subdivisions)
    faces = np.asarray(m.faces)[:, ::-1]  # reversed: the right-hand normal (front) points inwards
    f = len(faces)
    surf = Surface(np.asarray(m.vertices), faces, emissivity=0.5,
                   active=np.stack([np.ones(f, bool), np.zeros(f, bool)], axis=1))
    groups = np.stack([np.arange(f), np.full(f, -1)], axis=1).ravel()
    return surf, groups


def baffle_surface(n_circ: int = 240, n_axial: int = 60, n_vanes: int = 3, n_vane_rings: int = 6):
    """Baffle-like quad shell: a cone frustum (radius 0.05 -> 0.15 m over 0.3 m, inner side active) with
    ``n_vanes`` annular vanes inside (both sides active); ε = 0.1 with a specular reflectance of 0.9.

    Returns ``(surface, fe_groups (2f,), super_groups (2f,), n_super)``: FE faces sides as groups, and super faces
    made of angular/axial strips (cone: 16 sectors x 4 bands; each vane side: 6 sectors).
    """
    r0, r1, length = 0.05, 0.15, 0.3
    th = np.linspace(0.0, 2 * np.pi, n_circ, endpoint=False)
    z = np.linspace(0.0, length, n_axial + 1)
    r = r0 + (r1 - r0) * z / length
    cone_pts = np.stack([np.outer(r, np.cos(th)), np.outer(r, np.sin(th)), np.repeat(z[:, None], n_circ, 1)], -1)
    pts = [cone_pts.reshape(-1, 3)]
    ia = np.arange(n_axial)[:, None]
    ic = np.arange(n_circ)[None, :]
    nxt = (ic + 1) % n_circ
    # node order (a, c), (a, c+1), (a+1, c+1), (a+1, c): right-hand normal points inwards
    cone = np.stack([ia * n_circ + ic, ia * n_circ + nxt, (ia + 1) * n_circ + nxt, (ia + 1) * n_circ + ic], -1)
    cone = cone.reshape(-1, 4)
    faces = [cone]
    cone_sector = (np.broadcast_to(ic, (n_axial, n_circ)) * 16 // n_circ).ravel()
    cone_band = (np.broadcast_to(ia, (n_axial, n_circ)) * 4 // n_axial).ravel()
    fe_sf_front = [cone_sector + 16 * cone_band]
    fe_sf_back = [np.full(len(cone), -1)]
    base = len(pts[0])
    n_sf = 64
    for k in range(n_vanes):
        zk = length * (k + 1) / (n_vanes + 1)
        rk = r0 + (r1 - r0) * zk / length
        rad = np.linspace(0.55 * rk, rk, n_vane_rings + 1)
        vp = np.stack([np.outer(rad, np.cos(th)), np.outer(rad, np.sin(th)), np.full((n_vane_rings + 1, n_circ), zk)], -1)
        pts.append(vp.reshape(-1, 3))
        ja = np.arange(n_vane_rings)[:, None]
        vq = np.stack([ja * n_circ + ic, ja * n_circ + nxt, (ja + 1) * n_circ + nxt, (ja + 1) * n_circ + ic], -1)
        faces.append(vq.reshape(-1, 4) + base)
        base += len(pts[-1])
        sector = (np.broadcast_to(ic, (n_vane_rings, n_circ)) * 6 // n_circ).ravel()
        fe_sf_front.append(n_sf + sector)
        fe_sf_back.append(n_sf + 6 + sector)
        n_sf += 12
    pts = np.concatenate(pts)
    faces = np.concatenate(faces)
    f = len(faces)
    n_cone = len(cone)
    active_back = np.ones(f, bool)
    active_back[:n_cone] = False
    surf = Surface(pts, faces, emissivity=0.1, specular=1.0, active=np.stack([np.ones(f, bool), active_back], 1))
    active = np.stack([np.ones(f, bool), active_back], 1).ravel()
    fe = np.where(active, np.cumsum(active) - 1, -1)  # one group per active side
    sf = np.stack([np.concatenate(fe_sf_front), np.concatenate(fe_sf_back)], 1).ravel()
    return surf, fe.astype(np.int64), sf.astype(np.int64), n_sf


def big_shell_structure(n: int = 408):
    """A closed shell box 1 x 1 x 0.6 m with two internal shelves at z = 0.2 and 0.4 m, one conformal structure:
    the walls' z-divisions are a multiple of 3, so the shelf heights are grid lines and the merge joins each shelf's
    rim to the walls (one connected piece; 1.07·10⁶ quads for n = 408 elements per edge of the 1 m faces,
    ≈ 6.4 n² in general)."""
    nz = 3 * max(round(0.2 * n), 1)  # z = 0.2 and 0.4 m on grid lines
    box = shapes.box(1.0, 1.0, 0.6, n, n, nz, name="box")
    shelves = [shapes.plate(1.0, 1.0, n, n, origin=(0.0, 0.0, z), name=f"shelf_{k}")
               for k, z in enumerate((0.2, 0.4))]
    return shapes.merge(box, *shelves)
