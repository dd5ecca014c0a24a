"""Small satellite for the orbit study (examples/smallsat): writes smallsat.msh (Gmsh 2.2, ASCII), millimetres.

Made with numpy and meshio only (no gmsh: every part is a structured grid on the same 50 mm lattice, so the parts
share their nodes where they meet and the mesh is conformal by construction).

Frame: x along the velocity, z towards nadir (the "earth" face z = 500 carries the instrument's view), y = z × x
(towards minus the orbit normal: in a Sun-synchronous orbit with β > 0 the Sun is on the -y side).

  box        : 500 x 500 x 500 shell cube [0, 500]^3, quads of 50 mm, normals outward; one group per wall:
               "wall_xm", "wall_xp", "wall_ym" (array side), "radiator" (y = 500, anti-Sun), "wall_zm" (zenith),
               "wall_zp" (earth face)
  deck       : internal shelf z = 250 over the whole box section (shares its edge nodes with the four side
               walls), normal +z, minus the instrument's footprint; group "deck"
  instrument : solid block x in [300, 400], y in [150, 250], z in [200, 300] (hex8 of 50 mm) through the deck
               (the deck's edge nodes around the hole are nodes of the block); group "instrument"
  instrument_bracket : plate x = 250, y in [150, 350], z in [250, 450] standing on the deck towards the earth
               face (shares the deck's nodes along y at x = 250), normal +x; group "instrument_bracket"
  array_bracket : plate x = 250, y in [-200, 0], z in [200, 300] from the -y wall to the array (shares a line of
               nodes with each), normal +x; group "array_bracket"
  solar_array : panel y = -200, x in [0, 500], z in [-250, 750] (10 x 20 quads), normal -y (cells towards the
               Sun side); group "solar_array"

Run:  python meshes/make_smallsat.py  (project environment: numpy, meshio)  -> meshes/smallsat.msh
"""

from __future__ import annotations

import os

import meshio
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
H = 50.0  # lattice step, mm


def grid(origin, u, v, nu: int, nv: int):
    """Points ((nu + 1)(nv + 1), 3) and quads (nu nv, 4) of the parallelogram origin + s u + t v, s, t in [0, 1],
    nodes ordered so that the right-hand normal is u x v."""
    s, t = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1), indexing="ij")
    pts = np.asarray(origin, float) + s.reshape(-1, 1) * np.asarray(u, float) + t.reshape(-1, 1) * np.asarray(v, float)
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
    quads = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1).reshape(-1, 4)
    return pts, quads


def hexes(lo, n):
    """Points and hex8 cells of the block lo + [0, n H] (n = (nx, ny, nz)), gmsh node order."""
    axes = [lo[k] + H * np.arange(n[k] + 1) for k in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = np.arange(len(pts)).reshape(n[0] + 1, n[1] + 1, n[2] + 1)
    a = idx[:-1, :-1, :-1], idx[1:, :-1, :-1], idx[1:, 1:, :-1], idx[:-1, 1:, :-1]
    b = idx[:-1, :-1, 1:], idx[1:, :-1, 1:], idx[1:, 1:, 1:], idx[:-1, 1:, 1:]
    return pts, np.stack([*a, *b], axis=-1).reshape(-1, 8)


def main(path: str = os.path.join(HERE, "smallsat.msh")) -> None:
    L = 500.0
    n = int(L / H)
    shells = []  # (group, points, quads)
    ex, ey, ez = np.eye(3) * L
    # walls, normals outward: u x v points out of the box
    shells.append(("wall_xm", *grid((0, 0, 0), ez, ey, n, n)))
    shells.append(("wall_xp", *grid((L, 0, 0), ey, ez, n, n)))
    shells.append(("wall_ym", *grid((0, 0, 0), ex, ez, n, n)))
    shells.append(("radiator", *grid((0, L, 0), ez, ex, n, n)))
    shells.append(("wall_zm", *grid((0, 0, 0), ey, ex, n, n)))
    shells.append(("wall_zp", *grid((0, 0, L), ex, ey, n, n)))
    # deck z = 250 without the instrument's footprint x in [300, 400], y in [150, 250]
    p, q = grid((0, 0, 250), ex, ey, n, n)
    c = p[q].mean(axis=1)
    hole = (c[:, 0] > 300) & (c[:, 0] < 400) & (c[:, 1] > 150) & (c[:, 1] < 250)
    shells.append(("deck", p, q[~hole]))
    shells.append(("instrument_bracket", *grid((250, 150, 250), (0, 200, 0), (0, 0, 200), 4, 4)))
    shells.append(("array_bracket", *grid((250, -200, 200), (0, 200, 0), (0, 0, 100), 4, 2)))
    shells.append(("solar_array", *grid((0, -200, -250), (500, 0, 0), (0, 0, 1000), 10, 20)))
    solid_pts, solid_cells = hexes((300.0, 150.0, 200.0), (2, 2, 2))

    # merge coincident nodes (all on the 50 mm lattice: exact after rounding)
    all_pts = np.concatenate([s[1] for s in shells] + [solid_pts])
    key = np.round(all_pts / (H / 2)).astype(np.int64)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    points = np.zeros((len(uniq), 3))
    points[inverse] = all_pts
    cells, phys, field = [], [], {}
    off = 0
    quads, quad_tags = [], []
    for tag, (name, p, q) in enumerate(shells, start=1):
        quads.append(inverse[q + off])
        quad_tags.append(np.full(len(q), tag))
        field[name] = np.array([tag, 2])
        off += len(p)
    cells.append(("quad", np.concatenate(quads)))
    phys.append(np.concatenate(quad_tags))
    tag = len(shells) + 1
    cells.append(("hexahedron", inverse[solid_cells + off]))
    phys.append(np.full(len(solid_cells), tag))
    field["instrument"] = np.array([tag, 3])
    mesh = meshio.Mesh(points, cells, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys},
                       field_data=field)
    meshio.write(path, mesh, file_format="gmsh22", binary=False)
    print(f"{path}: {len(points)} nodes, {sum(len(c[1]) for c in cells)} elements "
          f"({len(cells[0][1])} quads, {len(cells[1][1])} hexahedra)")


if __name__ == "__main__":
    main()
