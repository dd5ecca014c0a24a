"""Composite satellite-like box (issue 21): writes composite.msh (Gmsh 2.2 ASCII, millimetres).

A 600 x 600 x 500 mm box of shells, 15 mm quads (40 x 40 x 33 per face, 9 840 quads): the bottom face
``deck`` (held at 20 degC in the example, like a platform deck on a temperature-controlled structure), four
side walls and a top panel of thin composite (``walls``, ``top``) and a 150 x 150 mm ``heater`` patch in the
middle of the +x wall.  Front sides (right-hand normals) point outwards.
Physical groups (2-D, disjoint): deck, walls, heater, top.

Built with fem2tmm's own structured generator (no gmsh needed):  python meshes/make_composite.py
"""

from __future__ import annotations

import os

import meshio
import numpy as np

from fem2tmm import meshes

HERE = os.path.dirname(os.path.abspath(__file__))
LX, LY, LZ = 0.6, 0.6, 0.5  # m
H = 0.015  # m, element size
HEATER = 0.15  # m, side of the square heater patch on the +x wall


def build():
    box = meshes.box(LX, LY, LZ, round(LX / H), round(LY / H), round(LZ / H))
    cen = box.element_centroids()
    group = np.full(box.n_elements, "walls", dtype=object)
    group[box.group("zmin").elements] = "deck"
    group[box.group("zmax").elements] = "top"
    xmax = box.group("xmax").elements
    c = cen[xmax]
    patch = (np.abs(c[:, 1] - LY / 2) < HEATER / 2) & (np.abs(c[:, 2] - LZ / 2) < HEATER / 2)
    group[xmax[patch]] = "heater"
    return box, group


def main() -> None:
    box, group = build()
    names = ["deck", "walls", "heater", "top"]
    tag = np.array([names.index(g) + 1 for g in group])
    cells = box.padded_cells[:, :4]
    mesh = meshio.Mesh(box.points * 1000.0, [("quad", cells)],
                       cell_data={"gmsh:physical": [tag], "gmsh:geometrical": [tag]},
                       field_data={n: np.array([i + 1, 2]) for i, n in enumerate(names)})
    out = os.path.join(HERE, "composite.msh")
    meshio.write(out, mesh, file_format="gmsh22", binary=False)
    print(f"wrote {out}: {len(box.points)} nodes, {len(cells)} quads, "
          + ", ".join(f"{n} {int((tag == i + 1).sum())}" for i, n in enumerate(names)))


if __name__ == "__main__":
    main()
