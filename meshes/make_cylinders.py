"""Two perpendicular cylinders (thesis section 3.2): writes cylinders.msh (Gmsh 4.1).

Geometry (millimetres): two identical open cylinders (lateral surfaces only, no end caps),
    length L = 500 mm, diameter D = 100 mm (radius 50 mm),
    cylinder_1: axis along +y through (-75, 0, 0), y in [-250, 250]
    cylinder_2: axis along +z through (+75, 0, 0), z in [-250, 250]
The axes are perpendicular skew lines 150 mm apart along x (a 50 mm gap between the surfaces), so seen along x
the cylinders form a cross; the thesis' Sun-pointing x axis goes from cylinder_1 (the "-x cylinder") to
cylinder_2 (the "+x cylinder").
Mesh: structured quadrilaterals, N_CIRC = 12 around x N_AXIAL = 20 along = 240 identical shells per cylinder,
12 x 21 = 252 nodes per cylinder: 504 nodes in all, the thesis' count ("504 nodes in addition to the 3 K deep
space node"; 240 shells each).  The facet vertices lie on the true circle (inscribed 12-gon).
Element normals point outward (away from each cylinder's axis); the thesis sets the inner sides inactive.
Physical groups: "cylinder_1", "cylinder_2" (2-D).

Run:  python meshes/make_cylinders.py   (with a Python that has the gmsh package, e.g. /work/venv-gmsh)
"""

import gmsh
import numpy as np

import _gmshtools as gt

LENGTH = 500.0
RADIUS = 50.0
HALF_GAP = 75.0  # distance of each axis from the origin, along x
N_CIRC = 12
N_AXIAL = 20

# name: (centre point on the axis, unit axis direction)
CYLINDERS = {
    "cylinder_1": (np.array([-HALF_GAP, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])),
    "cylinder_2": (np.array([HALF_GAP, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])),
}


def build() -> dict[int, str]:
    gt.start("cylinders")
    occ = gmsh.model.occ
    surfaces = {}
    for name, (centre, axis) in CYLINDERS.items():
        start = centre - 0.5 * LENGTH * axis
        # facet vertices start on the +x side of the axis (both axes are perpendicular to x)
        circle = occ.addCircle(*start, RADIUS, zAxis=axis.tolist(), xAxis=[1.0, 0.0, 0.0])
        out = occ.extrude([(1, circle)], *(LENGTH * axis), numElements=[N_AXIAL], recombine=True)
        occ.synchronize()
        gmsh.model.mesh.setTransfiniteCurve(circle, N_CIRC + 1)
        surf = [tag for dim, tag in out if dim == 2]
        gmsh.model.addPhysicalGroup(2, surf, name=name)
        for tag in surf:
            surfaces[tag] = name
    gmsh.model.mesh.generate(2)

    def outward(tag, c):
        centre, axis = CYLINDERS[surfaces[tag]]
        d = c - centre
        return d - np.outer(d @ axis, axis)

    gt.orient_surfaces(outward)
    return surfaces


def main() -> None:
    build()
    gt.summary(gt.write("cylinders.msh", 4.1))
    gmsh.finalize()


if __name__ == "__main__":
    main()
