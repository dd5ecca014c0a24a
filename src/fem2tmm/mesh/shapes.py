"""Parametric structured meshes with named groups, for tests, examples and the demo.

Every generator returns a :class:`~fem2tmm.mesh.Mesh` in metres.  Surface generators build shells
(``element="quad4"`` or ``"tri3"``, each quad split into two triangles); their front side (right-hand
normal) is documented per generator.  Edge groups are node groups (dim 1), surface groups element
groups (dim 2), volume groups element groups (dim 3).

>>> from fem2tmm.mesh import shapes
>>> m = shapes.annulus(0.05, 0.15, n_r=20, n_theta=120)
>>> sorted(m.groups)
['annulus', 'inner', 'outer']
"""

from __future__ import annotations

import numpy as np

from ..errors import Fem2TmmError
from .core import ElementBlock, Mesh, make_group, pad_cells


def _build(points, cells_by_type: dict[str, np.ndarray], groups: dict, name: str) -> Mesh:
    """Assemble a Mesh; ``groups`` maps name -> (dim, element indices or None, node indices or None)."""
    blocks, off = [], 0
    for t, c in cells_by_type.items():
        c = np.asarray(c, dtype=np.int64)
        blocks.append(ElementBlock(t, c, np.arange(off + 1, off + len(c) + 1, dtype=np.int64)))
        off += len(c)
    padded = pad_cells(blocks)
    gr = {}
    for g, (dim, el, nd) in groups.items():
        gr[g] = make_group(g, dim, el, nd, mesh_cells=padded)
    return Mesh(points=np.asarray(points, float), blocks=tuple(blocks), groups=gr, source=f"<shapes.{name}>")


def _grid_quads(nu: int, nv: int, wrap_u: bool = False) -> np.ndarray:
    """Quads of a (nu+1 or nu) x (nv+1) node grid, node (i, j) = j * nu_nodes + i, counter-clockwise in (u, v)."""
    nu_nodes = nu if wrap_u else nu + 1
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="xy")
    i, j = i.ravel(), j.ravel()
    i1 = (i + 1) % nu_nodes
    return np.stack([j * nu_nodes + i, j * nu_nodes + i1, (j + 1) * nu_nodes + i1, (j + 1) * nu_nodes + i], axis=1)


def _shell_cells(quads: np.ndarray, element: str) -> dict[str, np.ndarray]:
    if element == "quad4":
        return {"quad4": quads}
    if element == "tri3":
        # every quad split along its 0-2 diagonal (the classic structured triangulation: on a rectangular
        # grid its P1 stiffness is the 5-point stencil, and a uniform load gives equal interior shares)
        return {"tri3": np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])}
    raise Fem2TmmError(f"meshes: element must be 'quad4' or 'tri3', got {element!r}")


def _check(**kw):
    for k, v in kw.items():
        if v < 1:
            raise Fem2TmmError(f"meshes: {k} must be >= 1, got {v}")


def plate(lx: float = 1.0, ly: float = 1.0, nx: int = 10, ny: int = 10, element: str = "quad4",
          origin=(0.0, 0.0, 0.0), name: str = "plate") -> Mesh:
    """Flat rectangle [0, lx] x [0, ly] in the plane z = origin z; front side +z.

    Groups: ``name`` (2-D), edges ``xmin xmax ymin ymax`` (nodes).
    """
    _check(nx=nx, ny=ny)
    x, y = np.meshgrid(np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), indexing="xy")
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]) + np.asarray(origin, float)
    cells = _shell_cells(_grid_quads(nx, ny), element)
    idx = np.arange(x.size).reshape(ny + 1, nx + 1)
    groups = {
        name: (2, np.arange(sum(len(c) for c in cells.values())), None),
        "xmin": (1, None, idx[:, 0]),
        "xmax": (1, None, idx[:, -1]),
        "ymin": (1, None, idx[0, :]),
        "ymax": (1, None, idx[-1, :]),
    }
    return _build(pts, cells, groups, "plate")


def annulus(r_in: float = 0.05, r_out: float = 0.15, n_r: int = 20, n_theta: int = 120, element: str = "quad4",
            z: float = 0.0, name: str = "annulus") -> Mesh:
    """Flat annulus r_in <= r <= r_out in the plane z; front side +z.  Groups: ``name``, ``inner``, ``outer``."""
    _check(n_r=n_r, n_theta=n_theta)
    if not 0 <= r_in < r_out:
        raise Fem2TmmError(f"shapes.annulus: need 0 <= r_in < r_out, got {r_in}, {r_out}")
    th = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    r = np.linspace(r_in, r_out, n_r + 1)
    R, TH = np.meshgrid(r, th, indexing="ij")  # rows: radius index j, columns theta index i
    pts = np.column_stack([(R * np.cos(TH)).ravel(), (R * np.sin(TH)).ravel(), np.full(R.size, z)])
    # (theta, r) grid order gives e_theta x e_r = -z: reverse the quads for a +z front side
    cells = _shell_cells(_grid_quads(n_theta, n_r, wrap_u=True)[:, ::-1], element)
    idx = np.arange(R.size).reshape(n_r + 1, n_theta)
    groups = {name: (2, np.arange(sum(len(c) for c in cells.values())), None),
              "inner": (1, None, idx[0]), "outer": (1, None, idx[-1])}
    return _build(pts, cells, groups, "annulus")


def cone(r0: float = 0.05, r1: float = 0.05, length: float = 0.5, n_theta: int = 24, n_z: int = 10,
         element: str = "quad4", outward: bool = True, name: str = "cone") -> Mesh:
    """Truncated cone (cylinder when r0 == r1) about the z axis from z = 0 (radius r0) to z = length (r1).

    Front side outward (away from the axis) when ``outward`` else inward.
    Groups: ``name`` (2-D), ``end0`` (z = 0), ``end1`` (z = length).
    """
    _check(n_theta=n_theta, n_z=n_z)
    if r0 < 0 or r1 < 0 or (r0 == 0 and r1 == 0) or length <= 0:
        raise Fem2TmmError(f"shapes.cone: bad dimensions r0={r0}, r1={r1}, length={length}")
    th = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    zz = np.linspace(0, length, n_z + 1)
    Z, TH = np.meshgrid(zz, th, indexing="ij")
    R = r0 + (r1 - r0) * Z / length
    pts = np.column_stack([(R * np.cos(TH)).ravel(), (R * np.sin(TH)).ravel(), Z.ravel()])
    quads = _grid_quads(n_theta, n_z, wrap_u=True)  # (theta, z) counter-clockwise -> normal outward
    if not outward:
        quads = quads[:, ::-1]
    cells = _shell_cells(quads, element)
    idx = np.arange(Z.size).reshape(n_z + 1, n_theta)
    groups = {name: (2, np.arange(sum(len(c) for c in cells.values())), None),
              "end0": (1, None, idx[0]), "end1": (1, None, idx[-1])}
    return _build(pts, cells, groups, "cone")


def cylinder(radius: float = 0.05, length: float = 0.5, n_theta: int = 24, n_z: int = 10,
             element: str = "quad4", outward: bool = True, name: str = "cylinder") -> Mesh:
    """Cylinder about the z axis, z in [0, length]; see :func:`cone`."""
    return cone(radius, radius, length, n_theta, n_z, element, outward, name)


def beam(length: float = 1.0, width: float = 0.01, n: int = 100, element: str = "quad4", name: str = "beam") -> Mesh:
    """A strip of ``n`` quads (one element wide) along x in [0, length], y in [0, width]; front side +z.

    Groups: ``name`` (2-D), ``root`` (x = 0 nodes), ``tip`` (x = length nodes).
    """
    m = plate(length, width, n, 1, element=element, name=name)
    groups = {name: (2, m.groups[name].elements, None), "root": (1, None, m.groups["xmin"].nodes),
              "tip": (1, None, m.groups["xmax"].nodes)}
    return _build(m.points, {b.type: b.cells for b in m.blocks}, groups, "beam")


def box(lx: float = 1.0, ly: float = 1.0, lz: float = 1.0, nx: int = 4, ny: int = 4, nz: int = 4,
        kind: str = "shell", element: str | None = None, name: str = "box") -> Mesh:
    """Axis-aligned box [0, lx] x [0, ly] x [0, lz].

    ``kind="shell"``: its six faces as one conforming shell mesh, front sides outward, 2-D groups
    ``xmin xmax ymin ymax zmin zmax`` and ``name`` (all).  ``element`` quad4 (default) or tri3.
    ``kind="solid"``: the volume in hex8 (default), tet4 (6 per cube) or wedge6 (2 per cube); group
    ``name`` (3-D) and node groups ``xmin ... zmax`` on the faces.
    """
    _check(nx=nx, ny=ny, nz=nz)
    x, y, z = np.linspace(0, lx, nx + 1), np.linspace(0, ly, ny + 1), np.linspace(0, lz, nz + 1)
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    idx = np.arange(X.size).reshape(nx + 1, ny + 1, nz + 1)
    faces = {"xmin": idx[0, :, :], "xmax": idx[-1, :, :], "ymin": idx[:, 0, :], "ymax": idx[:, -1, :],
             "zmin": idx[:, :, 0], "zmax": idx[:, :, -1]}
    if kind == "solid":
        element = element or "hex8"
        i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
        c = [idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
             idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]]
        hexes = np.stack(c, axis=1)
        if element == "hex8":
            cells = {"hex8": hexes}
        elif element == "wedge6":
            h = hexes
            cells = {"wedge6": np.concatenate([h[:, [0, 1, 2, 4, 5, 6]], h[:, [0, 2, 3, 4, 6, 7]]])}
        elif element == "tet4":
            h = hexes  # Kuhn subdivision along the 0-6 diagonal: 6 positively oriented tets
            tets = [h[:, [0, 1, 2, 6]], h[:, [0, 2, 3, 6]], h[:, [0, 3, 7, 6]],
                    h[:, [0, 7, 4, 6]], h[:, [0, 4, 5, 6]], h[:, [0, 5, 1, 6]]]
            cells = {"tet4": np.concatenate(tets)}
        else:
            raise Fem2TmmError(f"shapes.box: solid element must be hex8, tet4 or wedge6, got {element!r}")
        m_el = sum(len(v) for v in cells.values())
        groups = {name: (3, np.arange(m_el), None)}
        groups.update({f: (2, None, v.ravel()) for f, v in faces.items()})
        return _build(pts, cells, groups, "box")
    if kind != "shell":
        raise Fem2TmmError(f"shapes.box: kind must be 'shell' or 'solid', got {kind!r}")
    element = element or "quad4"
    # quads of each face, oriented outward: grid (a, b) with a x b along the outward normal
    def face_quads(grid: np.ndarray, outward_flip: bool) -> np.ndarray:
        na, nb = grid.shape[0] - 1, grid.shape[1] - 1
        a, b = (v.ravel() for v in np.meshgrid(np.arange(na), np.arange(nb), indexing="ij"))
        q = np.stack([grid[a, b], grid[a + 1, b], grid[a + 1, b + 1], grid[a, b + 1]], axis=1)
        return q[:, ::-1] if outward_flip else q

    # (y,z) x-normal: e_y x e_z = +x -> xmax keeps, xmin flips; (x,z): e_x x e_z = -y -> ymin keeps
    spec = {"xmin": True, "xmax": False, "ymin": False, "ymax": True, "zmin": True, "zmax": False}
    cells_list, groups, start = [], {}, 0
    for f, flip in spec.items():
        q = _shell_cells(face_quads(faces[f], flip), element)
        (t, c), = q.items()
        cells_list.append(c)
        groups[f] = (2, np.arange(start, start + len(c)), None)
        start += len(c)
    allc = np.concatenate(cells_list)
    used = np.unique(allc)
    renum = np.full(len(pts), -1, np.int64)
    renum[used] = np.arange(len(used))
    groups[name] = (2, np.arange(start), None)
    return _build(pts[used], {element: renum[allc]}, groups, "box")


def bracket(width: float = 1.2, length: float = 1.2, n: int = 60, patch=(0.6, 1.0, 0.2),
            element: str = "quad4", name: str = "bracket") -> Mesh:
    """An L-bracket: two ``width`` x ``length`` panels meeting at a right angle along the x axis (the joint).

    The floor lies in z = 0, y in [0, length] (front side +z, towards the wall); the wall in y = 0, z in [0, length]
    (front side +y, towards the floor); both x in [0, width], ``n`` x ``n`` quads each, sharing the joint's nodes.
    ``patch = (x centre, z centre, side)``, m: a square heater patch of whole elements on the wall (the elements whose
    centre lies inside it).  Groups: ``floor``, ``wall`` (without the patch), ``heater`` (2-D), ``edge`` (the
    floor's free edge, y = length, nodes), ``top`` (the wall's free edge, z = length, nodes) and ``name`` (all).
    """
    _check(n=n)
    xs, ys = np.linspace(0, width, n + 1), np.linspace(0, length, n + 1)
    X, Y = np.meshgrid(xs, ys, indexing="xy")
    floor = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    wall = np.column_stack([X.ravel(), np.zeros(X.size), Y.ravel()])[n + 1:]  # its first row is the joint
    pts = np.concatenate([floor, wall])
    q = _grid_quads(n, n)  # counter-clockwise in (x, y): floor normal +z
    wall_index = np.concatenate([np.arange(n + 1), (n + 1) ** 2 + np.arange(n * (n + 1))])
    qw = wall_index[q][:, ::-1]  # (x, z) counter-clockwise is normal -y: reversed, front side +y
    cells = np.concatenate([q, qw])
    centre = pts[cells].mean(axis=1)
    cx, cz, side = patch
    nf = len(q)
    in_patch = np.zeros(len(cells), bool)
    in_patch[nf:] = (np.abs(centre[nf:, 0] - cx) < side / 2) & (np.abs(centre[nf:, 2] - cz) < side / 2)
    shell = _shell_cells(cells, element)
    per = len(next(iter(shell.values()))) // len(cells)  # tri3: two triangles per quad, first halves then second
    tile = lambda mask: np.flatnonzero(np.tile(mask, per))
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    groups = {name: (2, np.arange(per * len(cells)), None),
              "floor": (2, tile(np.arange(len(cells)) < nf), None),
              "wall": (2, tile((np.arange(len(cells)) >= nf) & ~in_patch), None),
              "heater": (2, tile(in_patch), None),
              "edge": (1, None, idx[-1]), "top": (1, None, wall_index[idx[-1]])}
    return _build(pts, shell, groups, "bracket")


def merge(*parts: Mesh, tol: float = 1e-9, name: str = "merged") -> Mesh:
    """Concatenate meshes and merge nodes closer than ``tol`` (relative to the overall size).

    Groups keep their names; a name used by several inputs takes the union.
    """
    from scipy.spatial import cKDTree

    pts = np.concatenate([p.points for p in parts])
    size = float(np.ptp(pts, axis=0).max()) or 1.0
    tree = cKDTree(pts)
    pairs = tree.query_pairs(tol * size, output_type="ndarray")
    rep = np.arange(len(pts))
    if len(pairs):
        import scipy.sparse as sp
        from scipy.sparse.csgraph import connected_components

        g = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(pts), len(pts)))
        _, comp = connected_components(g, directed=False)
        first = np.full(comp.max() + 1, len(pts))
        np.minimum.at(first, comp, np.arange(len(pts)))
        rep = first[comp]
    used, renum = np.unique(rep, return_inverse=True)
    node_off = np.concatenate([[0], np.cumsum([p.n_nodes for p in parts])])
    cells: dict[str, list[np.ndarray]] = {}
    elem_base: dict[str, int] = {}
    group_parts: dict[str, list] = {}
    # element numbering of the result: by type in order of first appearance, parts concatenated per type
    type_order = []
    for p in parts:
        for b in p.blocks:
            if b.type not in type_order:
                type_order.append(b.type)
    per_type_count = {t: 0 for t in type_order}
    positions = []  # per part: dict type -> start index within that type's concatenation
    for p in parts:
        pos = {}
        for b in p.blocks:
            pos[b.type] = per_type_count[b.type]
            per_type_count[b.type] += len(b.cells)
        positions.append(pos)
    start = 0
    for t in type_order:
        elem_base[t] = start
        start += per_type_count[t]
    for k, p in enumerate(parts):
        for b in p.blocks:
            cells.setdefault(b.type, []).append(renum[b.cells + node_off[k]])
        for g in p.groups.values():
            el = np.zeros(0, np.int64)
            if len(g.elements):
                blk = p.block_of(g.elements)
                el = np.concatenate([
                    elem_base[p.blocks[i].type] + positions[k][p.blocks[i].type]
                    + g.elements[blk == i] - p.offsets[i]
                    for i in np.unique(blk)
                ])
            group_parts.setdefault(g.name, []).append((g.dim, el, renum[g.nodes + node_off[k]]))
    groups = {}
    for g, items in group_parts.items():
        groups[g] = (max(i[0] for i in items), np.concatenate([i[1] for i in items]),
                     np.concatenate([i[2] for i in items]))
    return _build(pts[used], {t: np.concatenate(cells[t]) for t in type_order}, groups, name)


def transform(mesh: Mesh, rotation: np.ndarray | None = None, translation=(0.0, 0.0, 0.0)) -> Mesh:
    """The same mesh with points ``R @ p + t`` (groups and ids unchanged)."""
    R = np.eye(3) if rotation is None else np.asarray(rotation, float)
    pts = mesh.points @ R.T + np.asarray(translation, float)
    return Mesh(points=pts, blocks=mesh.blocks, groups=mesh.groups, node_ids=mesh.node_ids,
                source=mesh.source, properties=mesh.properties)


def rotation(axis: str, angle_deg: float) -> np.ndarray:
    """Rotation matrix about the x, y or z axis (right-hand rule)."""
    a = np.radians(angle_deg)
    c, s = np.cos(a), np.sin(a)
    i = "xyz".index(axis)
    R = np.eye(3)
    j, k = [q for q in range(3) if q != i]
    R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
    return R


def revolve(profile, n_theta: int = 48, name: str = "surface", flip: bool = False) -> Mesh:
    """Surface of revolution about z of a polyline ``profile`` ((p, 2) points (r, z), metres).

    Node rings sit at the profile points, ``n_theta`` nodes per ring (a ring of radius 0 is not allowed).
    The front side is e_θ x (profile direction) rotated; ``flip`` reverses it.  Groups: ``name`` (2-D),
    ``name + '_start'`` and ``name + '_end'`` (first and last ring, nodes).
    """
    prof = np.asarray(profile, float)
    if prof.ndim != 2 or prof.shape[1] != 2 or len(prof) < 2 or (prof[:, 0] <= 0).any():
        raise Fem2TmmError("shapes.revolve: profile must be (p >= 2, 2) points (r > 0, z)")
    th = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    R, TH = np.meshgrid(prof[:, 0], th, indexing="ij")
    Z = np.broadcast_to(prof[:, 1:2], R.shape)
    pts = np.column_stack([(R * np.cos(TH)).ravel(), (R * np.sin(TH)).ravel(), Z.ravel()])
    quads = _grid_quads(n_theta, len(prof) - 1, wrap_u=True)
    if flip:
        quads = quads[:, ::-1]
    idx = np.arange(R.size).reshape(len(prof), n_theta)
    groups = {name: (2, np.arange(len(quads)), None), f"{name}_start": (1, None, idx[0]),
              f"{name}_end": (1, None, idx[-1])}
    return _build(pts, {"quad4": quads}, groups, "revolve")


def _segment(p0, p1, h: float, include_end: bool = True) -> np.ndarray:
    n = max(1, int(np.ceil(np.hypot(p1[0] - p0[0], p1[1] - p0[1]) / h)))
    t = np.linspace(0, 1, n + 1) if include_end else np.linspace(0, 1, n + 1)[:-1]
    return np.asarray(p0, float) + t[:, None] * (np.asarray(p1, float) - np.asarray(p0, float))


def baffle(h: float = 3.0e-3, n_theta: int = 72, screw_radius: float = 2.5e-3) -> Mesh:
    """EUI-like entrance baffle (thesis §3.3, §6.3) as a structured shell mesh: the geometry of the
    committed ``meshes/baffle.msh`` (axis +z, aperture at z = 90 mm, flange at z = 0, Ø80 mm) without
    the screw holes, in metres.

    Element size along the profiles ≈ ``h``; ``n_theta`` nodes per ring.  2-D groups
    ``aperture_lip front_cone outer_skin main_cone middle_annulus back_annulus`` (front sides: lip and
    main cone towards the axis, front cone +z, skin outward, middle annulus -z, back annulus +z, as in
    ``baffle.msh``); node groups ``screw_1`` … ``screw_6`` (flange nodes within ``screw_radius`` of
    the six screw axes on the Ø70 mm bolt circle, ``screw_1`` at +x) and their union ``screw_rims``.
    """
    mm = 1e-3
    r_ap, z_front, r_out, z_fc, z_mid, r_flange_in, r_cone_back = 13, 90, 40, 86, 45, 16, 30
    z_lip = 82
    r_cone_mid = r_ap + (r_cone_back - r_ap) * (z_lip - z_mid) / z_lip  # main cone radius at z = 45
    hm = h / mm
    seg = lambda a, b: _segment(a, b, hm) * mm  # noqa: E731 - tiny local helper
    parts = [
        revolve(seg((r_ap, z_front), (r_ap, z_lip)), n_theta, "aperture_lip", flip=False),
        revolve(seg((r_ap, z_front), (r_out, z_fc)), n_theta, "front_cone", flip=True),
        revolve(seg((r_out, z_fc), (r_out, z_mid)), n_theta, "outer_skin", flip=False),
        revolve(np.concatenate([seg((r_ap, z_lip), (r_cone_mid, z_mid))[:-1],
                                seg((r_cone_mid, z_mid), (r_cone_back, 0.0))]), n_theta, "main_cone", flip=False),
        revolve(seg((r_cone_mid, z_mid), (r_out, z_mid)), n_theta, "middle_annulus", flip=True),
        revolve(np.concatenate([seg((r_flange_in, 0.0), (r_cone_back, 0.0))[:-1],
                                seg((r_cone_back, 0.0), (r_out, 0.0))]), n_theta, "back_annulus", flip=False),
    ]
    m = merge(*parts, tol=1e-7, name="baffle")
    # orient by the documented rule (the revolve direction depends on the profile direction)
    m = _orient_baffle(m)
    flange = m.groups["back_annulus"].nodes
    groups = {g.name: (g.dim, g.elements, g.nodes) for g in m.groups.values()
              if not g.name.endswith(("_start", "_end"))}
    screws = []
    for k in range(6):
        a = np.radians(60 * k)
        c = 35 * mm * np.array([np.cos(a), np.sin(a), 0.0])
        near = flange[np.linalg.norm(m.points[flange] - c, axis=1) <= screw_radius]
        if not len(near):
            raise Fem2TmmError("shapes.baffle: no flange node near a screw; use a finer mesh or a larger screw_radius")
        groups[f"screw_{k + 1}"] = (1, None, near)
        screws.append(near)
    groups["screw_rims"] = (1, None, np.concatenate(screws))
    return _build(m.points, {b.type: b.cells for b in m.blocks}, groups, "baffle")


def _orient_baffle(m: Mesh) -> Mesh:
    """Flip elements so that each baffle surface's front side follows the documented rule."""
    cells = m.blocks[0].cells.copy()
    n = m.element_normals()
    c = m.element_centroids()
    radial = np.column_stack([c[:, 0], c[:, 1], np.zeros(len(c))])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    want = {"aperture_lip": -radial, "main_cone": -radial, "outer_skin": radial,
            "front_cone": np.tile([0, 0, 1.0], (len(c), 1)), "middle_annulus": np.tile([0, 0, -1.0], (len(c), 1)),
            "back_annulus": np.tile([0, 0, 1.0], (len(c), 1))}
    for g, w in want.items():
        el = m.groups[g].elements
        flip = el[np.einsum("ij,ij->i", n[el], w[el]) < 0]
        cells[flip] = cells[flip][:, ::-1]
    return Mesh(m.points, (ElementBlock("quad4", cells, m.blocks[0].ids),), m.groups, m.node_ids, m.source)
