"""Circular radiating fin (thesis section 4.4.3): writes fin.msh (Gmsh 4.1) and fin_v22.msh (Gmsh 2.2).

Geometry (millimetres): flat annulus in the plane z = 0, centred on the z axis,
    inner radius  R_IN  = 50 mm   (edge held at 20 degC in the thesis)
    outer radius  R_OUT = 150 mm  (insulated edge)
    thickness 1 mm (not in the mesh: a shell property of the case file).
Mesh: structured quadrilaterals, N_RADIAL = 20 along the radius x N_CIRC = 120 around = 2400 quads,
21 x 120 = 2520 nodes, the thesis' "20 elements along the radius and 120 along the circumference".
Element normals point to +z.
Physical groups: "fin" (2-D, all quads), "inner_edge" and "outer_edge" (1-D, the two circles, as line elements).

Run:  python meshes/make_fin.py   (with a Python that has the gmsh package, e.g. /work/venv-gmsh)
"""

import math

import gmsh
import numpy as np

import _gmshtools as gt

R_IN = 50.0
R_OUT = 150.0
N_RADIAL = 20
N_CIRC = 120


def build() -> None:
    gt.start("fin")
    occ = gmsh.model.occ
    # four quarter annuli (each a 4-cornered patch that can be meshed transfinitely), glued into one surface mesh
    for k in range(4):
        c, s = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
        radial = occ.addLine(occ.addPoint(R_IN * c, R_IN * s, 0.0), occ.addPoint(R_OUT * c, R_OUT * s, 0.0))
        occ.revolve([(1, radial)], 0, 0, 0, 0, 0, 1, math.pi / 2)
    occ.removeAllDuplicates()
    occ.synchronize()
    surface = [tag for _dim, tag in gmsh.model.getEntities(2)]
    circles = {"inner_edge": [], "outer_edge": []}
    for _dim, curve in gmsh.model.getEntities(1):
        a, b = gmsh.model.getBoundary([(1, curve)])
        pa = np.array(gmsh.model.getValue(0, a[1], []))
        pb = np.array(gmsh.model.getValue(0, b[1], []))
        ra, rb = np.hypot(*pa[:2]), np.hypot(*pb[:2])
        if abs(ra - rb) > 1.0:  # radial segment
            gmsh.model.mesh.setTransfiniteCurve(curve, N_RADIAL + 1)
        else:  # quarter arc
            gmsh.model.mesh.setTransfiniteCurve(curve, N_CIRC // 4 + 1)
            circles["inner_edge" if ra < 0.5 * (R_IN + R_OUT) else "outer_edge"].append(curve)
    for tag in surface:
        gmsh.model.mesh.setTransfiniteSurface(tag)
        gmsh.model.mesh.setRecombine(2, tag)
    gmsh.model.addPhysicalGroup(2, surface, name="fin")
    gmsh.model.addPhysicalGroup(1, circles["inner_edge"], name="inner_edge")
    gmsh.model.addPhysicalGroup(1, circles["outer_edge"], name="outer_edge")
    gmsh.model.mesh.generate(2)
    gt.orient_surfaces(lambda tag, c: np.tile([0.0, 0.0, 1.0], (len(c), 1)))


def main() -> None:
    build()
    gt.summary(gt.write("fin.msh", 4.1))
    gt.summary(gt.write("fin_v22.msh", 2.2))
    gmsh.finalize()


if __name__ == "__main__":
    main()
