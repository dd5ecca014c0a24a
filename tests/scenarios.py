"""Scenario builders shared by the tests and the benchmarks (``benchmarks/cases.py`` re-exports them): test
geometries with known answers, built from the public API.  Not part of the installed package."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fem2tmm.mesh import shapes
from fem2tmm.io import read_mesh
from fem2tmm.radiation.quadric import face_frames
from fem2tmm.radiation.surfaces import Surface

REPO = Path(__file__).resolve().parents[1]

#: Sun 10° off the baffle axis (thesis §3.3.3), towards +z
SUN_10DEG = np.array([np.sin(np.radians(10.0)), 0.0, np.cos(np.radians(10.0))])
PERIHELION_FLUX = 17400.0  # W/m², 0.28 AU (thesis §3.3.1)


def write_plate_deck(path, nx: int, ny: int, size: float = 1.0) -> Path:
    """Write a flat square plate of ``nx`` x ``ny`` CQUAD4 in small-field Nastran format.

    GRID ids ``1 .. (nx+1)(ny+1)`` row by row (x fastest), element ids ``1 .. nx ny``, one PSHELL
    (PID 1, t = 1e-3) and one MAT4 (MID 1, aluminium in SI).  ``size`` is the side length in deck
    units.  Returns the path.
    """
    path = Path(path)
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    x = (i.ravel() * (size / nx)).tolist()
    y = (j.ravel() * (size / ny)).tolist()
    n1 = nx + 1
    with open(path, "w") as f:
        f.write("BEGIN BULK\n")
        f.write("PSHELL         1       1   0.001\n")
        f.write("MAT4           1    170.    900.   2700.\n")
        f.writelines(f"GRID    {k + 1:8d}        {a:8.6f}{b:8.6f}      0.\n" for k, (a, b) in enumerate(zip(x, y)))
        e = np.arange(nx * ny)
        r, c = np.divmod(e, nx)
        g1 = (r * n1 + c + 1).tolist()
        f.writelines(
            f"CQUAD4  {k + 1:8d}       1{a:8d}{a + 1:8d}{a + n1 + 1:8d}{a + n1:8d}\n" for k, a in enumerate(g1)
        )
        f.write("ENDDATA\n")
    return path


def eui_cone(n_theta: int = 12, n_z: int = 4, n_r: int = 1, r0: float = 0.02, r1: float = 0.035,
             length: float = 0.08, r_hole: float = 0.004) -> Surface:
    """EUI-like entrance baffle (thesis §3.3.2): a cone frustum about z (radius ``r0`` at z = 0 to ``r1`` at
    z = ``length``, front side inwards) closed at its narrow end by an annulus (``r_hole`` to ``r0``, front side
    +z, i.e. into the baffle).  Both sides of every face: solar α = 0.2 with a specular reflectance of 0.8 (polished
    aluminium coating).  Faces: ``n_theta x (n_z + n_r)`` quads."""
    c = shapes.cone(r0, r1, length, n_theta=n_theta, n_z=n_z, outward=False)
    d = shapes.annulus(r_hole, r0, n_r=n_r, n_theta=n_theta)
    pts = np.concatenate([c.points, d.points])
    faces = np.concatenate([c.blocks[0].cells, d.blocks[0].cells + len(c.points)])
    return Surface(pts, faces, absorptivity=0.2, specular=1.0)


#: axis point and axis index (0 x, 1 y, 2 z) of the two cylinders of ``meshes/cylinders.msh`` (m)
CYLINDER_AXES = ((np.array([-0.075, 0.0, 0.0]), 1), (np.array([0.075, 0.0, 0.0]), 2))


def read_cylinders():
    """The committed perpendicular cylinders: ``(points (n, 3) m, faces (480, 4), cylinder (480,) 1 or 2)``."""
    m = read_mesh(REPO / "meshes" / "cylinders.msh", unit="mm")
    cyl = np.zeros(m.n_elements, np.int64)
    for c in (1, 2):
        cyl[m.groups[f"cylinder_{c}"].elements] = c
    return m.points, m.blocks[0].cells, cyl


def cylinder_super_faces(points, faces, cylinder, n_around: int = 4, n_along: int = 4) -> np.ndarray:
    """Super face (f,) of each face of the two cylinders (``cylinder`` (f,) 1 or 2): ``n_around`` angular sectors
    (the first starting at angle 0 about the axis, a node angle of the meshes) x ``n_along`` bands of the 500 mm
    length, numbered per cylinder."""
    cen, _ = face_frames(points, faces)
    sf = np.empty(len(faces), np.int64)
    for c, (o, ax) in enumerate(CYLINDER_AXES):
        mine = cylinder == c + 1
        u, v = [i for i in range(3) if i != ax]
        rel = cen[mine] - o
        sector = np.floor((np.arctan2(rel[:, v], rel[:, u]) % (2 * np.pi)) / (2 * np.pi / n_around)).astype(np.int64)
        band = np.clip(np.floor((rel[:, ax] + 0.25) / (0.5 / n_along)).astype(np.int64), 0, n_along - 1)
        sf[mine] = c * n_around * n_along + band * n_around + sector
    return sf


def cylinder_surface(points, faces) -> Surface:
    """Thesis §3.2 optics: ε = α = 0.5 on the outer (front) sides, the reflected 50 % specular, inner sides
    inactive."""
    f = len(faces)
    one, zero = np.ones(f), np.zeros(f)
    return Surface(points, faces, emissivity=np.c_[0.5 * one, zero], absorptivity=np.c_[0.5 * one, zero],
                   specular=np.c_[one, zero], active=np.c_[one > 0, zero > 0])
