"""BTA-like truss (thesis section 6.2): writes truss.msh (Gmsh 4.1), linear tetrahedra.

An aluminium support frame of square-section beams, 10 mm x 10 mm, in the envelope
x in [0, 300], y in [0, 200], z in [0, 150] (millimetres), fused into one solid, with two mounting pads:

  bottom and top rectangular frames (z in [0, 10] and [140, 150]): four beams each along the envelope edges
  four corner posts (along z) joining the frames
  on each long side (y in [0, 10] and [190, 200]): a mid post at x in [145, 155] and two diagonals meeting at
      the top of the mid post (an inverted V: (5, 5) -> (150, 145) -> (295, 5) in (x, z), beam centre lines)
  on each short side (x in [0, 10] and [290, 300]): one diagonal, (y, z) = (5, 5) -> (195, 145) at x = 0 and
      (5, 145) -> (195, 5) at x = 300
  a cross beam along y at x in [145, 155] in the bottom frame and in the top frame
  pad "fixed"  : block x in [0, 30],    y in [85, 115], z in [-10, 0], under the bottom beam of the x = 0 end
  pad "heated" : block x in [270, 300], y in [85, 115], z in [-10, 0], under the bottom beam of the x = 300 end

The diagonals are square prisms that lie in the plane of their side (their faces flush with the frame's), cut
flush with the envelope; their ends are buried in the joints.  All beams are fused (OpenCASCADE fuse) into one
volume; the pads are separate volumes sharing their contact face (30 mm x 10 mm each) with it (fragment), so
the mesh is conformal across it.

Mesh: linear tetrahedra, target size H = 2.685 mm: 35 603 nodes, 121 693 tetrahedra (the thesis' BTA mesh has
35 217 nodes).

Physical groups: 3-D "truss" (all three volumes), "pad_fixed_volume", "pad_heated_volume";
2-D "pad_fixed", "pad_heated": the bottom face (z = -10, 30 mm x 30 mm) of each pad, where the boundary
condition applies (20 degC on the fixed pad, 10 W on the heated pad in the thesis' study).  The 2-D groups are
written as triangles: faces of the tetrahedra, not shells.

Run:  python meshes/make_truss.py   (with a Python that has the gmsh package, e.g. /work/venv-gmsh)
"""

import math

import gmsh

import _gmshtools as gt

LX, LY, LZ = 300.0, 200.0, 150.0  # envelope
A = 10.0  # beam section side
PAD = (30.0, 30.0, 10.0)  # pad size along x, y, z
H = 2.685  # target element size, mm

PADS = {
    "pad_fixed": (0.0, 0.5 * (LY - PAD[1]), -PAD[2]),
    "pad_heated": (LX - PAD[0], 0.5 * (LY - PAD[1]), -PAD[2]),
}


def _beams() -> list[tuple[int, int]]:
    """Axis-aligned members as OCC boxes."""
    occ = gmsh.model.occ
    tags = []
    for y in (0.0, LY - A):
        for z in (0.0, LZ - A):
            tags.append(occ.addBox(0, y, z, LX, A, A))  # along x
    for x in (0.0, LX - A):
        for z in (0.0, LZ - A):
            tags.append(occ.addBox(x, 0, z, A, LY, A))  # along y
    for x in (0.0, 0.5 * (LX - A), LX - A):
        for y in (0.0, LY - A):
            tags.append(occ.addBox(x, y, 0, A, A, LZ))  # posts along z (corners and mid posts)
    for z in (0.0, LZ - A):
        tags.append(occ.addBox(0.5 * (LX - A), 0, z, A, LY, A))  # cross beams along y
    return [(3, t) for t in tags]


def _diagonal(plane: str, offset: float, p0: tuple[float, float], p1: tuple[float, float]) -> tuple[int, int]:
    """Square prism along the centre line p0 -> p1 in the side plane ``plane`` ("xz" at y = offset, or "yz" at
    x = offset; points given in the plane's (first, second) coordinates), extended by A at both ends and cut to
    the envelope."""
    occ = gmsh.model.occ
    (u0, v0), (u1, v1) = p0, p1
    length = math.hypot(u1 - u0, v1 - v0) + 2 * A
    angle = math.atan2(v1 - v0, u1 - u0)
    if plane == "xz":
        bar = occ.addBox(-0.5 * length, offset, -0.5 * A, length, A, A)
        occ.rotate([(3, bar)], 0, 0, 0, 0, -1, 0, angle)  # rotation about -y turns +x towards +z
        occ.translate([(3, bar)], 0.5 * (u0 + u1), 0, 0.5 * (v0 + v1))
    else:
        bar = occ.addBox(offset, -0.5 * length, -0.5 * A, A, length, A)
        occ.rotate([(3, bar)], 0, 0, 0, 1, 0, 0, angle)  # rotation about +x turns +y towards +z
        occ.translate([(3, bar)], 0, 0.5 * (u0 + u1), 0.5 * (v0 + v1))
    envelope = occ.addBox(0, 0, 0, LX, LY, LZ)
    out, _ = occ.intersect([(3, bar)], [(3, envelope)])
    return out[0]


def _diagonals() -> list[tuple[int, int]]:
    c = 0.5 * A  # beam centre line offset from the envelope faces
    mid = 0.5 * LX
    out = []
    for y in (0.0, LY - A):
        out.append(_diagonal("xz", y, (c, c), (mid, LZ - c)))
        out.append(_diagonal("xz", y, (mid, LZ - c), (LX - c, c)))
    out.append(_diagonal("yz", 0.0, (c, c), (LY - c, LZ - c)))
    out.append(_diagonal("yz", LX - A, (c, LZ - c), (LY - c, c)))
    return out


def build() -> None:
    gt.start("truss")
    occ = gmsh.model.occ
    members = _beams() + _diagonals()
    frame, _ = occ.fuse(members[:1], members[1:])
    if len(frame) != 1:
        raise RuntimeError(f"fuse gave {len(frame)} volumes, expected one connected frame")
    pads = {name: (3, occ.addBox(*corner, *PAD)) for name, corner in PADS.items()}
    objects = frame + list(pads.values())
    _out, children = occ.fragment(objects[:1], objects[1:])
    occ.synchronize()
    volumes = {"frame": [t for _d, t in children[0]]}
    for k, name in enumerate(pads, start=1):
        volumes[name] = [t for _d, t in children[k]]
        if len(volumes[name]) != 1:
            raise RuntimeError(f"{name}: fragment gave volumes {volumes[name]}")
    all_volumes = sorted({t for v in volumes.values() for t in v})
    if len(all_volumes) != 3:
        raise RuntimeError(f"expected 3 volumes (frame + 2 pads), got {all_volumes}")

    gmsh.model.addPhysicalGroup(3, all_volumes, name="truss")
    for name, corner in PADS.items():
        gmsh.model.addPhysicalGroup(3, volumes[name], name=f"{name}_volume")
        x0, y0, z0 = corner
        e = 1e-3
        faces = gmsh.model.getEntitiesInBoundingBox(x0 - e, y0 - e, z0 - e, x0 + PAD[0] + e, y0 + PAD[1] + e,
                                                    z0 + e, 2)
        if len(faces) != 1:
            raise RuntimeError(f"{name}: expected one bottom face, found {faces}")
        gmsh.model.addPhysicalGroup(2, [faces[0][1]], name=name)

    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * H)
    gmsh.option.setNumber("Mesh.MeshSizeMax", H)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay surfaces
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay
    gmsh.option.setNumber("Mesh.Optimize", 1)
    gmsh.model.mesh.generate(3)


def main() -> None:
    build()
    gt.summary(gt.write("truss.msh", 4.1))
    gmsh.finalize()


if __name__ == "__main__":
    main()
