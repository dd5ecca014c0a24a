"""EUI-like entrance baffle (thesis sections 3.3 and 6.3): writes baffle.msh (Gmsh 4.1).

A 1 mm aluminium sheet-metal part modelled as one conformal shell (surface) mesh: the thickness is a shell
property of the case file, not part of the mesh.  Axis along +z, the aperture at the front (z = 90 mm), the
mounting flange at the back (z = 0).  Outer diameter 80 mm, length 90 mm.  Dimensions in millimetres, as
(radius r, height z) profiles revolved about the z axis:

  aperture_lip    cylinder  r = 13,                z 82 -> 90   knife-edge lip hanging into the bore from the
                                                                aperture edge
  front_cone      cone      (r 13, z 90) -> (r 40, z 86)        shallow conical annulus around the aperture
                                                                (8.4 deg from the plane), faces the Sun
  outer_skin      cylinder  r = 40,                z 45 -> 86   closes the annular chamber between the front
                                                                cone and the middle interface
  main_cone       cone      (r 13, z 82) -> (r 30, z 0)         the sunlight-reflecting bore, widening towards
                                                                the back (11.7 deg half-angle)
  middle_annulus  plane     z = 45, r 20.67 -> 40               flat annular interface (flange ring) from the
                                                                main cone to the skin
  back_annulus    plane     z = 0,  r 16 -> 40                  flat mounting flange; the main cone stands on it
                                                                at r = 30, so its inner part (r 16-30) is the
                                                                exit stop of the bore; six screw holes of
                                                                diameter 3.4 on a bolt circle of radius 35 at
                                                                angles 0, 60, ..., 300 deg from +x (screw_1 at
                                                                +x, counter-clockwise about +z)

Junctions: lip/front cone (aperture edge), lip/main cone, front cone/skin and skin/middle annulus are two-surface
edges; the middle annulus meets the main cone (z = 45) and the main cone meets the back flange (r = 30) in
T-junctions (three surfaces on one curve).  All surfaces share their nodes along the junction curves (OpenCASCADE
fragment, then one mesh).  The volume enclosed by the lip, front cone, skin, middle annulus and upper main cone
is a closed chamber; the space between the middle interface and the back flange is open at r = 40.

Mesh: unstructured quadrilaterals (Frontal-Delaunay triangles recombined by Blossom; this geometry gives no
left-over triangles), target size H = 1.5 mm, nine nodes on each screw-hole rim (the thesis keeps "6 x 9 nodes
around the screw holes"): 18 404 quads and 18 450 nodes, close to the thesis' structural mesh (18 460 elements,
18 590 nodes).  (Gmsh's "Frontal-Delaunay for quads" algorithm silently leaves the lip and the front cone
nearly empty here, hence the plain Frontal-Delaunay.)

Element normals (right-hand rule of the node order), checked element by element before writing:
  aperture_lip, main_cone: towards the axis (into the bore); front_cone: +z; outer_skin: away from the axis;
  middle_annulus: -z; back_annulus: +z.
This is the outward normal of the closed chamber, so the orientation is consistent across every edge shared by
two surfaces (the main cone below the middle annulus continues the one above it; the back flange faces the
inside of the bore like the main cone).  At the two T-junctions "consistent" has no meaning.

Physical groups: 2-D "aperture_lip", "front_cone", "outer_skin", "main_cone", "middle_annulus",
"back_annulus"; 1-D "screw_rims" (all six hole rims) and "screw_1" ... "screw_6" (one rim each).

Run:  python meshes/make_baffle.py   (with a Python that has the gmsh package, e.g. /work/venv-gmsh)
"""

import math

import gmsh
import numpy as np

import _gmshtools as gt

R_APERTURE = 13.0
Z_FRONT = 90.0
R_OUTER = 40.0
Z_FRONT_CONE_OUTER = 86.0
Z_LIP_END = 82.0
R_CONE_BACK = 30.0
Z_MIDDLE = 45.0
R_BACK_INNER = 16.0
R_BOLT = 35.0
D_HOLE = 3.4
N_HOLES = 6
N_RIM = 9  # nodes (= segments) on each hole rim
H = 1.50  # target element size, mm


def r_main_cone(z: float) -> float:
    """Radius of the main cone at height z (mm)."""
    return R_APERTURE + (R_CONE_BACK - R_APERTURE) * (Z_LIP_END - z) / Z_LIP_END


# name: profile segment ((r0, z0), (r1, z1)) revolved about z
PROFILES = {
    "aperture_lip": ((R_APERTURE, Z_FRONT), (R_APERTURE, Z_LIP_END)),
    "front_cone": ((R_APERTURE, Z_FRONT), (R_OUTER, Z_FRONT_CONE_OUTER)),
    "outer_skin": ((R_OUTER, Z_FRONT_CONE_OUTER), (R_OUTER, Z_MIDDLE)),
    "main_cone": ((R_APERTURE, Z_LIP_END), (R_CONE_BACK, 0.0)),
    "middle_annulus": ((r_main_cone(Z_MIDDLE), Z_MIDDLE), (R_OUTER, Z_MIDDLE)),
}
HOLE_ANGLES = [2 * math.pi * k / N_HOLES for k in range(N_HOLES)]


def _revolved(p0, p1) -> list[int]:
    occ = gmsh.model.occ
    line = occ.addLine(occ.addPoint(p0[0], 0.0, p0[1]), occ.addPoint(p1[0], 0.0, p1[1]))
    out = occ.revolve([(1, line)], 0, 0, 0, 0, 0, 1, 2 * math.pi)
    return [tag for dim, tag in out if dim == 2]


def _back_flange() -> tuple[int, list[int]]:
    """Planar annulus at z = 0 with the screw holes; returns (surface tag, hole circle tags)."""
    occ = gmsh.model.occ
    outer = occ.addCurveLoop([occ.addCircle(0, 0, 0, R_OUTER)])
    inner = occ.addCurveLoop([occ.addCircle(0, 0, 0, R_BACK_INNER)])
    holes = [occ.addCircle(R_BOLT * math.cos(a), R_BOLT * math.sin(a), 0, 0.5 * D_HOLE) for a in HOLE_ANGLES]
    loops = [occ.addCurveLoop([h]) for h in holes]
    return occ.addPlaneSurface([outer, inner] + loops), holes


def build() -> None:
    gt.start("baffle")
    occ = gmsh.model.occ
    origin = {}  # original surface tag -> region name
    for name, (p0, p1) in PROFILES.items():
        for tag in _revolved(p0, p1):
            origin[tag] = name
    flange, _holes = _back_flange()
    origin[flange] = "back_annulus"
    objects = [(2, t) for t in origin]
    _out, children = occ.fragment(objects[:1], objects[1:])
    occ.synchronize()
    # a revolved profile line that no surface uses any more (the middle annulus became a plain planar face)
    orphans = [(1, c) for _d, c in gmsh.model.getEntities(1) if len(gmsh.model.getAdjacencies(1, c)[0]) == 0]
    occ.remove(orphans, recursive=True)
    occ.synchronize()

    regions: dict[str, list[int]] = {}
    for (_dim, parent), kids in zip(objects, children):
        for _d, kid in kids:
            regions.setdefault(origin[parent], [])
            if kid not in regions[origin[parent]]:
                regions[origin[parent]].append(kid)
    owners = {}
    for name, tags in regions.items():
        for t in tags:
            if t in owners:
                raise RuntimeError(f"surface {t} is in both {owners[t]} and {name}")
            owners[t] = name
    if len(owners) != len(gmsh.model.getEntities(2)):
        raise RuntimeError("fragment produced surfaces without a region")

    # the screw-hole rims after the fragment: closed curves of the back flange centred on the bolt circle
    rims = []
    for a in HOLE_ANGLES:
        cx, cy = R_BOLT * math.cos(a), R_BOLT * math.sin(a)
        found = gmsh.model.getEntitiesInBoundingBox(cx - D_HOLE, cy - D_HOLE, -0.1, cx + D_HOLE, cy + D_HOLE, 0.1, 1)
        if len(found) != 1:
            raise RuntimeError(f"expected one rim curve at ({cx:.2f}, {cy:.2f}), found {found}")
        rims.append(found[0][1])

    for name in ("aperture_lip", "front_cone", "outer_skin", "main_cone", "middle_annulus", "back_annulus"):
        gmsh.model.addPhysicalGroup(2, sorted(regions[name]), name=name)
    gmsh.model.addPhysicalGroup(1, rims, name="screw_rims")
    for k, rim in enumerate(rims, start=1):
        gmsh.model.addPhysicalGroup(1, [rim], name=f"screw_{k}")

    for rim in rims:
        gmsh.model.mesh.setTransfiniteCurve(rim, N_RIM + 1)  # closed curve: N_RIM segments, N_RIM nodes
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * H)
    gmsh.option.setNumber("Mesh.MeshSizeMax", H)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay, then recombined
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)  # Blossom
    gmsh.model.mesh.generate(2)

    def wanted(tag, c):
        radial = np.column_stack([c[:, 0], c[:, 1], np.zeros(len(c))])
        radial /= np.linalg.norm(radial, axis=1, keepdims=True)
        z = np.tile([0.0, 0.0, 1.0], (len(c), 1))
        return {"aperture_lip": -radial, "front_cone": z, "outer_skin": radial, "main_cone": -radial,
                "middle_annulus": -z, "back_annulus": z}[owners[tag]]

    gt.orient_surfaces(wanted)


def main() -> None:
    build()
    gt.summary(gt.write("baffle.msh", 4.1))
    gmsh.finalize()


if __name__ == "__main__":
    main()
