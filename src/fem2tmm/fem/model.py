"""The detailed FE thermal model: parts, assembly, radiating faces, boundary conditions.

:func:`build_model` turns a :class:`~fem2tmm.mesh.Mesh` and a :class:`~fem2tmm.case.Case` into a
:class:`FEModel` of plain arrays.  Conventions:

* Only elements of the case's parts are thermal elements.  Other elements (e.g. surface triangles that
  tag a face of a solid) may still carry boundary conditions.  GRIDs no element uses are ignored.
* Degrees of freedom (DOFs): every node of a thermal element, except that the nodes of each
  fixed-temperature boundary are merged into one isothermal DOF (an exact multi-point constraint).
* Radiating faces: each shell element is one face with two sides (front = right-hand normal); each outer
  face of the solids (a face used by exactly one solid of the model and covered by no shell element) is a
  face whose front (outward) side has the part's ``front`` optics and whose back side is inactive.  Where a
  shell lies on a solid's face (a panel a fitting sits on, a skin) the two are in contact: the solid's face does
  not radiate and neither does the shell's side facing into the solid (neither side of a shell between two
  solids).
* Nodal lumping: capacity ``∫ρ c Nᵢ dV``, radiating area ``∫Nᵢ dA`` (row-sum lumping; equal shares on
  simplices and undistorted elements).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..arrays import unique, unique_rows
from ..case import Boundary, Case
from ..errors import Fem2TmmError, format_ids
from ..linalg import blas_threads
from ..mesh import Mesh
from .assembly import (ElementCOO, area_shares, block_geometry, capacity_matrices, conduction_matrices, line_matrices,
                       scatter_shares, to_coo, volume_shares)
from ..mesh.elements import LINE_TYPES, MIRROR, RULES, SHELL_TYPES, SOLID_FACES, SOLID_TYPES, TYPE_CODE
from ..mesh.geometry import cross, shell_normals, solid_jacobian

_CODE_TYPE = {v: k for k, v in TYPE_CODE.items()}


@dataclass(frozen=True)
class PartInfo:
    name: str
    kind: str  # shell | solid | line | mixed (several kinds: bars with the panels they stiffen, ...)
    elements: np.ndarray  # global element indices
    super_nodes: int
    quadric: bool


@dataclass(frozen=True)
class FixedGroup:
    name: str
    T: float  # K
    dof: int
    nodes: np.ndarray  # mesh node indices merged into the DOF


@dataclass(frozen=True)
class Faces:
    """Radiating faces.  ``nodes`` (f, 4) mesh node indices (-1 pad for triangles), ``dofs`` (f, 4) DOFs,
    ``shares`` (f, 4) ``∫Nᵢ dA`` m², ``area`` (f,) m², ``normal`` (f, 3), ``element`` (f,) global element,
    ``part`` (f,) part index, ``kind`` (f,) 0 shell / 1 solid face.  Side arrays (2f,), side 2i = front
    of face i: ``emissivity absorptivity specular transmissivity transmission_specular`` and ``active``.
    ``W`` (f, n_dof) sparse averaging weights (rows sum to 1): face value = W @ nodal value.
    ``unblocked`` (2f,) or None: the traced fraction of each side's emission that is not stopped by an inactive side
    (optics ``"none"``; docs/case-file.md), None before any tracing (1 everywhere).  A blocked ray is one the side
    never emits, as the traced exchange factors count it: :attr:`eps_area` is the emission εA (1 − blocked) that
    the REFs close on (:meth:`FEModel.with_unblocked`).  ``traced_area`` (f,) m² or None: the area each face emits
    from as the rays are traced (a fitted quadric's patch; :func:`fem2tmm.stages.radiation.traced_area`),
    None: its facet's, ``area``.
    """

    nodes: np.ndarray
    dofs: np.ndarray
    shares: np.ndarray
    area: np.ndarray
    normal: np.ndarray
    element: np.ndarray
    part: np.ndarray
    kind: np.ndarray
    emissivity: np.ndarray
    absorptivity: np.ndarray
    specular: np.ndarray
    transmissivity: np.ndarray
    transmission_specular: np.ndarray
    active: np.ndarray
    W: sp.csr_matrix
    unblocked: np.ndarray | None = None
    traced_area: np.ndarray | None = None

    @property
    def n(self) -> int:
        return len(self.area)

    @property
    def emitting_area(self) -> np.ndarray:  # (f,) m²: :attr:`traced_area` once traced, else :attr:`area`
        return self.area if self.traced_area is None else self.traced_area

    @property
    def eps_area(self) -> np.ndarray:
        """(f,) εA of each face summed over its active sides, m² (times :attr:`unblocked` once traced; A the
        :attr:`emitting_area`)."""
        e = self.emissivity * self.active
        if self.unblocked is not None:
            e = e * self.unblocked
        return e.reshape(-1, 2).sum(axis=1) * self.emitting_area

    @property
    def active_area(self) -> np.ndarray:
        """(f,) area of each face's active sides (0, 1 or 2 x its area), m²."""
        return self.active.reshape(-1, 2).sum(axis=1) * self.area


@dataclass(frozen=True)
class FEModel:
    """Assembled detailed model (DOF numbering).  Units: W/K, J/K, m², m³, W, K."""

    mesh: Mesh
    parts: tuple[PartInfo, ...]
    node_dof: np.ndarray  # (n_nodes,) DOF of each mesh node, -1 if not in the model
    n_dof: int
    elements: np.ndarray  # (m,) global element indices of the thermal elements (sorted)
    element_part: np.ndarray  # (m,) part index
    element_dofs: np.ndarray  # (m, 8) DOFs padded with -1
    element_cells: np.ndarray  # (m, 8) mesh node indices (solids re-oriented positive), padded with -1
    element_types: np.ndarray  # (m,) int8 type codes
    element_attribute: np.ndarray  # (m,) int: same value <=> same part, conductivity, ρc, thickness, optics
    volume_shares: np.ndarray  # (m, 8) m³ per element node
    capacity_shares: np.ndarray | None  # (m, 8) J/K, None when some part lacks density/specific heat
    coo: ElementCOO  # conduction element matrices (DOF numbering, elem = position in ``elements``)
    K: sp.csr_matrix
    volume: np.ndarray  # (n_dof,) m³
    capacity: np.ndarray | None  # (n_dof,) J/K
    faces: Faces
    Q: np.ndarray  # (n_dof,) applied loads, W
    fixed: tuple[FixedGroup, ...]
    T_sink: float
    loads: dict = field(default_factory=dict)  # boundary name -> W applied
    #: thermal joints kept as their own conductances (DOF numbering, ``elem`` = connection index); in K, not in coo
    links: ElementCOO | None = None
    joints: dict = field(default_factory=dict)  # report: card -> {treatment: number of joint elements}
    #: (n_dof,) extra εA (m²) to the sink of radiating deck faces (CHBDYx + RADBC), or None
    extra_space: np.ndarray | None = None

    @property
    def link_dofs(self) -> np.ndarray:
        """Sorted DOFs that conductance joints connect (kept as one-node super nodes by the reduction)."""
        if self.links is None or not len(self.links.rows):
            return np.zeros(0, np.int64)
        return unique(self.links.rows)

    @property
    def fixed_mask(self) -> np.ndarray:
        m = np.zeros(self.n_dof, bool)
        m[[g.dof for g in self.fixed]] = True
        return m

    @property
    def fixed_values(self) -> np.ndarray:
        v = np.zeros(self.n_dof)
        for g in self.fixed:
            v[g.dof] = g.T
        return v

    def with_unblocked(self, unblocked: np.ndarray | None, traced_area: np.ndarray | None = None) -> "FEModel":
        """This model whose sides emit εA (1 − blocked): ``unblocked`` (2f,) the traced fraction of each side's
        emission not stopped by an inactive side (:func:`fem2tmm.radiation.side_fractions`), or None; A the
        ``traced_area`` (f,) m² the rays are traced from (a fitted quadric's patch), or None (the facets').
        The emission every method and the detailed reference then share (the REFs close on it)."""
        if unblocked is None and traced_area is None:
            return self
        f, n = self.faces, self.faces.n
        u = f.unblocked if unblocked is None else np.clip(np.asarray(unblocked, float), 0.0, 1.0)
        a = f.traced_area if traced_area is None else np.asarray(traced_area, float)
        if (u is not None and u.shape != (2 * n,)) or (a is not None and a.shape != (n,)):
            raise ValueError(f"unblocked needs one value per side ({2 * n},) and traced_area one per face ({n},)")
        return replace(self, faces=replace(f, unblocked=u, traced_area=a))

    def space_coupling(self) -> np.ndarray:
        """(n_dof,) εA (m²) of every DOF to space, summed over the active sides of its faces."""
        f = self.faces
        g = scatter_shares(f.dofs, f.shares, self.n_dof, weights=f.eps_area / f.area)
        return g if self.extra_space is None else g + self.extra_space

    def node_temperatures(self, T_dof: np.ndarray) -> np.ndarray:
        """(n_nodes,) temperatures of every mesh node (NaN for nodes outside the model)."""
        out = np.full(len(self.node_dof), np.nan)
        ok = self.node_dof >= 0
        out[ok] = T_dof[self.node_dof[ok]]
        ms = self.mesh.midside
        if ms is not None and len(ms):  # mid-side nodes of quadratic elements: mean of the edge ends
            out[ms[:, 0]] = 0.5 * (out[ms[:, 1]] + out[ms[:, 2]])
        return out


def consistent_capacity(model: FEModel) -> sp.csr_matrix:
    """Consistent capacitance matrix (n_dof, n_dof) J/K: ``∫ ρ c NᵢNⱼ dV`` (shells: x thickness).

    Symmetric; its row sums are the lumped capacitance ``model.capacity``.  Each element's ρ·c (·thickness) is
    its capacity over its measure, so no property is read twice.  Raises if the model has no capacity.
    """
    if model.capacity_shares is None:
        raise Fem2TmmError("the consistent capacitance needs density and specific_heat for every part's material")
    pts = model.mesh.points
    coos = []
    for code in unique(model.element_types):
        t = _CODE_TYPE[int(code)]
        sel = np.flatnonzero(model.element_types == code)
        nk = RULES[t].N.shape[1]
        if t in LINE_TYPES:  # ∫ NᵢNⱼ dL = L/6 [[2, 1], [1, 2]]; the length is scaled out below
            Me = np.broadcast_to(np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0, (len(sel), 2, 2)).copy()
        else:
            Me = capacity_matrices(pts, model.element_cells[sel, :nk], t)
        measure = Me.sum(axis=(1, 2))
        Me *= (model.capacity_shares[sel, :nk].sum(axis=1) / measure)[:, None, None]
        coos.append(to_coo(model.element_dofs[sel, :nk], Me, sel))
    C = ElementCOO.concatenate(coos).tocsr(model.n_dof)
    C.sum_duplicates()
    return C


# ------------------------------------------------------------------------------------------ helpers
def _union(index_arrays, n: int) -> np.ndarray:
    """Sorted union of index arrays in [0, n) (a mask: linear time, unlike a hash/sort unique)."""
    mask = np.zeros(n, bool)
    for a in index_arrays:
        mask[a] = True
    return np.flatnonzero(mask)


def _part_elements(mesh: Mesh, case: Case) -> tuple[list[PartInfo], np.ndarray]:
    owner = np.full(mesh.n_elements, -1, np.int64)
    parts = []
    for p in case.parts:
        els = []
        for g in p.groups:
            grp = mesh.group(g, where=f"{case.source}: [[parts]] {p.name!r}.groups")
            if len(grp.elements) == 0:
                raise Fem2TmmError(
                    f"{case.source}: [[parts]] {p.name!r}: group {g!r} holds only nodes (a {grp.dim}-D group); "
                    "parts need surface (2-D) or volume (3-D) element groups"
                )
            els.append(grp.elements)
        el = _union(els, mesh.n_elements)
        clash = el[owner[el] >= 0]
        if len(clash):
            other = case.parts[int(owner[clash[0]])].name
            raise Fem2TmmError(
                f"{case.source}: elements {format_ids(mesh.element_ids[clash])} belong to parts {other!r} and "
                f"{p.name!r}; each element may be in one part only"
            )
        owner[el] = p.index
        dims = mesh.element_dims[el]
        kind = {1: "line", 2: "shell", 3: "solid"}[int(dims[0])] if dims.min() == dims.max() else "mixed"
        parts.append(PartInfo(p.name, kind, el, p.super_nodes, p.quadric))
    return parts, owner


def _properties(mesh: Mesh, case: Case, parts, owner) -> dict[str, np.ndarray]:
    """Per-element conductivity, density, specific heat, thickness from the case, else from the mesh."""
    m = mesh.n_elements
    props = {k: np.full(m, np.nan) for k in ("k", "rho", "cp", "t", "area")}
    props["tensor"] = np.full((m, 6), np.nan)
    if mesh.section_area is not None:
        props["area"][:] = mesh.section_area
    # mesh-provided data per element (Nastran PIDs)
    for gname, pdata in mesh.properties.items():
        grp = mesh.groups.get(gname)
        if grp is None:
            continue
        for key, attr in (("k", "conductivity"), ("rho", "density"), ("cp", "specific_heat"), ("t", "thickness")):
            v = getattr(pdata, attr)
            if v is not None:
                props[key][grp.elements] = v
        if pdata.conductivity_tensor is not None:
            props["tensor"][grp.elements] = pdata.conductivity_tensor
    for cp, info in zip(case.parts, parts):
        el = info.elements
        if cp.material is not None:
            mat = case.materials[cp.material]
            props["k"][el] = mat.conductivity
            props["tensor"][el] = np.nan
            props["rho"][el] = np.nan if mat.density is None else mat.density
            props["cp"][el] = np.nan if mat.specific_heat is None else mat.specific_heat
        if cp.thickness is not None:
            props["t"][el] = cp.thickness
        if cp.area is not None:
            props["area"][el] = cp.area
        if (np.isnan(props["k"][el]) & np.isnan(props["tensor"][el]).any(axis=1)).any():
            raise Fem2TmmError(
                f"{case.source}: [[parts]] {cp.name!r} has no material: set 'material' (a [materials] entry) "
                "or use a Nastran deck whose properties reference a MAT4/MAT5 with K (and, for other length units "
                "than m and mm, declare [mesh] unit_system)"
            )
        dims = mesh.element_dims[el]
        if np.isnan(props["area"][el[dims == 1]]).any():
            bad = el[(dims == 1) & np.isnan(props["area"][el])]
            raise Fem2TmmError(
                f"{case.source}: [[parts]] {cp.name!r}: line elements {format_ids(mesh.element_ids[bad])} have no "
                "cross-section area: set 'area' (m²) or use a Nastran deck with PBAR/PBARL/PBEAM/PBEAML/PROD/PTUBE"
            )
        if np.isnan(props["t"][el[dims == 2]]).any():
            raise Fem2TmmError(
                f"{case.source}: [[parts]] {cp.name!r} is a shell part without thickness (or has shells without it): set 'thickness' (m) "
                "or use a Nastran deck with PSHELL T"
            )
    return props


def _check_and_orient(mesh: Mesh, elements: np.ndarray, types: np.ndarray, cells: np.ndarray):
    """Mirror negatively oriented solids (with a warning naming them); raise on degenerate or partly inverted
    elements.

    Returns ``(cells, blocks)`` with ``blocks`` a list of ``(etype, rows, cells_of_rows, BlockGeometry)``.
    """
    cells = cells.copy()
    size = float(np.ptp(mesh.points, axis=0).max()) or 1.0
    blocks = []
    for code in unique(types):
        t = _CODE_TYPE[int(code)]
        sel = np.flatnonzero(types == code)
        nk = RULES[t].N.shape[1]
        c = cells[sel, :nk]
        if t in LINE_TYPES:
            L = np.linalg.norm(mesh.points[c[:, 1]] - mesh.points[c[:, 0]], axis=1)
            bad = L <= 1e-12 * size
            if bad.any():
                raise Fem2TmmError(
                    f"{mesh.source}: line elements {format_ids(mesh.element_ids[elements[sel[bad]]])} have zero "
                    "length (coincident end GRIDs); a zero-length connection is a joint (CBUSH/RBE2) or remove it"
                )
            blocks.append((t, sel, c, None))
            continue
        if t in SHELL_TYPES:
            geom = block_geometry(mesh.points, c, t)
            area = geom.measure @ RULES[t].w
            bad = area <= 1e-12 * size**2
            if t == "quad4":
                nq = geom.normal
                nbar = nq.sum(axis=1)
                bad |= (np.einsum("mqc,mc->mq", nq, nbar) <= 0).any(axis=1)
                # corners: a non-convex or bow-tie quad has a corner whose normal opposes the element's
                X = mesh.points[c]
                corner = cross(np.roll(X, -1, axis=1) - X, np.roll(X, 1, axis=1) - X)
                bad |= (np.einsum("mkc,mc->mk", corner, nbar) <= 0).any(axis=1)
            if bad.any():
                raise Fem2TmmError(
                    f"{mesh.source}: {t} elements {format_ids(mesh.element_ids[elements[sel[bad]]])} have zero area "
                    "or an inverted/non-convex (bow-tie) shape; fix or remove them in the mesh"
                )
        else:
            _, det = solid_jacobian(mesh.points, c, t)
            neg = (det @ RULES[t].w) < 0
            if neg.any():  # a mirrored node order (a numbering convention): the same element, reoriented
                warnings.warn(
                    f"{mesh.source}: {t} elements {format_ids(mesh.element_ids[elements[sel[neg]]])} have a negative "
                    "Jacobian (mirrored node order); reoriented", stacklevel=4)
                c[neg] = c[neg][:, list(MIRROR[t])]
                cells[sel[neg], :nk] = c[neg]
            geom = block_geometry(mesh.points, c, t)
            vol = geom.det @ RULES[t].w
            bad = (geom.det <= 0).any(axis=1) | (np.abs(vol) <= 1e-12 * size**3)
            if bad.any():
                raise Fem2TmmError(
                    f"{mesh.source}: {t} elements {format_ids(mesh.element_ids[elements[sel[bad]]])} have zero volume "
                    "or an inverted Jacobian (distorted or wrongly numbered nodes); fix them in the mesh"
                )
        blocks.append((t, sel, c, geom))
    return cells, blocks


def _solid_outer_faces(cells: np.ndarray, types: np.ndarray, elem_pos: np.ndarray):
    """Outer faces of the solids: ((F, 4) node indices padded -1, (F,) position in ``cells``, the contacts
    ((c, 4) node indices of each solid face a shell lies on, in the solid's outward order; (c,) the shell's row
    among the shells), and (b,) the rows among the shells of those buried between two solids).

    A face used by one solid only is outer, unless a shell element of the model lies on its nodes (a skin, or a
    panel a fitting sits on): that face is a contact, covered; the shell keeps its other side.  A shell on a face
    between two solids (a deck through a block) has solid on both sides."""
    facelist, owner = [], []
    for code in unique(types):
        t = _CODE_TYPE[int(code)]
        if t not in SOLID_TYPES:
            continue
        sel = np.flatnonzero(types == code)
        for f in SOLID_FACES[t]:
            fc = np.full((len(sel), 4), -1, np.int64)
            fc[:, : len(f)] = cells[sel][:, list(f)]
            facelist.append(fc)
            owner.append(elem_pos[sel])
    none = np.zeros((0, 4), np.int64), np.zeros(0, np.int64)
    if not facelist:
        return (*none, *none, none[1])
    F = np.concatenate(facelist)
    own = np.concatenate(owner)
    shell = np.isin(types, [TYPE_CODE[t] for t in SHELL_TYPES])
    S = cells[shell, :4].copy()
    S[types[shell] == TYPE_CODE["tri3"], 3] = -1
    big = np.iinfo(np.int64).max
    key = np.sort(np.where(F < 0, big, F), axis=1)
    skey = np.sort(np.where(S < 0, big, S), axis=1)
    _, inv, cnt = unique_rows(np.concatenate([key, skey]), return_inverse=True, return_counts=True)
    inv = inv.ravel()
    n_solid = np.bincount(inv[: len(key)], minlength=len(cnt))  # solids using each face
    outer_solid = n_solid[inv[: len(key)]] == 1
    covered = np.zeros(len(cnt), bool)
    covered[inv[len(key):]] = True  # a shell lies on it
    outer = outer_solid & ~covered[inv[: len(key)]]
    contact = outer_solid & covered[inv[: len(key)]]
    # the shell (first one, if several coincide) lying on each contact face
    shell_of = np.full(len(cnt), -1, np.int64)
    shell_of[inv[len(key):][::-1]] = np.arange(len(skey))[::-1]
    buried = np.flatnonzero(n_solid[inv[len(key):]] >= 2)
    return F[outer], own[outer], F[contact], shell_of[inv[: len(key)][contact]], buried


# ------------------------------------------------------------------------------------------ builder
def build_model(mesh: Mesh, case: Case) -> FEModel:
    """Assemble the detailed FE thermal model of ``case`` on ``mesh`` (see module docstring).

    BLAS runs on one thread here: the assembly makes many small BLAS calls (element ``einsum``/``matmul`` on a few
    nodes each) that threads only slow down on a shared machine (measured: docs/benchmarks.md, "Speed-ups of
    2026-12-06"; the model is bit-identical).  Warnings of the body count this wrapper in their stacklevel."""
    with blas_threads(1):
        return _build_model(mesh, case)


def _build_model(mesh: Mesh, case: Case) -> FEModel:
    parts, owner = _part_elements(mesh, case)
    props = _properties(mesh, case, parts, owner)
    elements = np.flatnonzero(owner >= 0)
    unused = mesh.n_elements - len(elements)
    types = mesh.element_types[elements]
    cells, blocks = _check_and_orient(mesh, elements, types, mesh.padded_cells[elements])
    epart = owner[elements]

    # ---- DOFs: nodes of thermal elements and joints; fixed-temperature groups and isothermal joints merged
    n_nodes = mesh.n_nodes
    iso_pairs, cond_pairs, cond_G, joint_report = _joint_links(mesh, case)
    iso_pairs = _midside_isothermal(mesh, iso_pairs)
    stencil, weights = _midside_stencil(mesh, cond_pairs)  # (l, 4) nodes and weights of each connection
    in_model = np.zeros(n_nodes, bool)
    in_model[cells[cells >= 0]] = True
    in_model[iso_pairs.ravel()] = True
    in_model[stencil.ravel()] = True
    node_boundary = np.full(n_nodes, -1, np.int64)
    fixed_specs = []
    specs = [(b.name, b.value, boundary_nodes(mesh, case, b)) for b in case.boundaries if b.kind == "temperature"]
    case_fixed = np.zeros(n_nodes, bool)
    for _, _, nodes in specs:
        case_fixed[nodes] = True
    specs += _deck_fixed(mesh, case_fixed, in_model)
    for si, (name, value, nodes) in enumerate(specs):
        nodes = nodes[in_model[nodes]]
        if len(nodes) == 0:
            raise Fem2TmmError(
                f"{case.source}: [[boundary]] {name!r} (temperature) touches no node of the thermal model's "
                "elements; check its groups/nodes"
            )
        clash = nodes[node_boundary[nodes] >= 0]
        if len(clash):
            other = specs[int(node_boundary[clash[0]])][0]
            raise Fem2TmmError(
                f"{case.source}: nodes {format_ids(mesh.node_ids[clash])} are in two temperature boundaries "
                f"({other!r} and {name!r}); merge them or make them disjoint"
            )
        node_boundary[nodes] = si
        fixed_specs.append((name, value, nodes))
    # union of merged nodes: each fixed group, each isothermal joint connection
    ea = [iso_pairs[:, 0]] + [np.full(len(n) - 1, n[0]) for _, _, n in fixed_specs]
    eb = [iso_pairs[:, 1]] + [n[1:] for _, _, n in fixed_specs]
    ea, eb = np.concatenate(ea).astype(np.int64), np.concatenate(eb).astype(np.int64)
    _, comp = connected_components(sp.csr_matrix((np.ones(len(ea)), (ea, eb)), shape=(n_nodes, n_nodes)),
                                   directed=False)
    first = np.full(n_nodes, n_nodes, np.int64)
    np.minimum.at(first, comp, np.arange(n_nodes))
    rep = first[comp]
    fixed_rep = [rep[n[0]] for _, _, n in fixed_specs]
    if len(set(fixed_rep)) < len(fixed_rep):
        raise Fem2TmmError(f"{case.source}: isothermal joints ([[joints]] treatment = 'isothermal') connect two "
                           "fixed-temperature boundaries; make those joints 'conductance' or merge the boundaries")
    used_rep = rep[in_model]
    uniq, inv = unique(used_rep, return_inverse=True)
    dof_of_rep = np.full(n_nodes, -1, np.int64)
    dof_of_rep[uniq] = np.arange(len(uniq))
    node_dof = np.full(n_nodes, -1, np.int64)
    node_dof[in_model] = dof_of_rep[used_rep]
    n_dof = len(uniq)
    fixed = tuple(FixedGroup(name, value, int(node_dof[nodes[0]]), nodes) for name, value, nodes in fixed_specs)

    # ---- element integrals
    element_dofs = np.where(cells >= 0, node_dof[np.maximum(cells, 0)], -1)
    vshares = np.zeros(cells.shape)
    coos = []
    for t, sel, c, geom in blocks:
        nk = c.shape[1]
        el = elements[sel]
        if t in LINE_TYPES:
            Ke, L = line_matrices(mesh.points, c, props["k"][el], props["area"][el], props["tensor"][el])
            coos.append(to_coo(element_dofs[sel, :nk], Ke, sel))
            vshares[sel, :nk] = (props["area"][el] * L / 2)[:, None]
            continue
        thick = props["t"][el] if t in SHELL_TYPES else None
        Ke = conduction_matrices(mesh.points, c, t, props["k"][el], thick, geom=geom, tensor=props["tensor"][el])
        coos.append(to_coo(element_dofs[sel, :nk], Ke, sel))
        vshares[sel, :nk] = volume_shares(mesh.points, c, t, thick, geom=geom)
    coo = ElementCOO.concatenate(coos)
    # joint conductances: G wᵢ wⱼ over each connection's 4-node stencil (a mid-side end is the mean of its
    # edge ends), zero row sums by construction
    sd = node_dof[stencil]
    i, j = np.meshgrid(np.arange(4), np.arange(4), indexing="ij")
    vals = cond_G[:, None, None] * weights[:, :, None] * weights[:, None, :]
    links = ElementCOO(sd[:, i].reshape(-1), sd[:, j].reshape(-1), vals.reshape(-1),
                       np.repeat(np.arange(len(cond_G)), 16))
    links = links.select(links.vals != 0)
    lk = sp.csr_matrix((links.vals, (links.rows, links.cols)), shape=(n_dof, n_dof))
    lk.sum_duplicates()
    lk.eliminate_zeros()  # both ends merged (isothermal / fixed): no conductance left
    lk = lk.tocoo()
    links = ElementCOO(lk.row.astype(np.int64), lk.col.astype(np.int64), lk.data, np.zeros(lk.nnz, np.int64))
    K = ElementCOO.concatenate([coo, links]).tocsr(n_dof)
    links = links if len(links.rows) else None
    K.sum_duplicates()
    volume = scatter_shares(element_dofs, vshares, n_dof)
    rc = props["rho"][elements] * props["cp"][elements]
    if np.isnan(rc).any():
        cshares, capacity = None, None
    else:
        cshares = vshares * rc[:, None]
        capacity = scatter_shares(element_dofs, cshares, n_dof)

    faces = _build_faces(mesh, case, parts, elements, types, cells, epart, node_dof, n_dof, blocks)

    # ---- loads
    Q = np.zeros(n_dof)
    loads = {}
    fixed_dofs = np.array([f.dof for f in fixed], np.int64)
    for b in case.boundaries:
        if b.kind == "temperature":
            continue
        q = _load_vector(mesh, case, b, node_dof, n_dof)
        _check_load_on_fixed(mesh, case, b, q, fixed, fixed_dofs)
        Q += q
        loads[b.name] = float(q.sum())
    extra_space = None
    if mesh.loads is not None:
        dl = mesh.loads
        nodal, eps_area = _deck_nodal_loads(mesh, dl, elements, vshares)
        for name, q in nodal.items():
            lost = np.abs(q[node_dof < 0]).sum()
            if lost > 1e-12 * max(np.abs(q).sum(), 1e-300):
                raise Fem2TmmError(f"{mesh.source}: deck {name} loads fall on GRIDs of no thermal element; check the "
                                   "[[parts]] groups or leave those cards out of [mesh] nastran_loads")
            ok = node_dof >= 0
            qd = np.bincount(node_dof[ok], weights=q[ok], minlength=n_dof)
            Q += qd
            loads[f"deck {name}"] = float(qd.sum())
        if eps_area is not None:
            amb = unique(dl.rad_ambient)
            T_sink = case.environment.sink_temperature
            if np.abs(amb - T_sink).max() > 1e-9 * max(T_sink, 1.0):
                raise Fem2TmmError(
                    f"{mesh.source}: RADBC ambient temperatures {', '.join(f'{t - 273.15:g}' for t in amb)} °C differ "
                    f"from [environment] sink_temperature = {T_sink - 273.15:g} °C; fem2tmm has one sink: set "
                    "sink_temperature to the RADBC ambient temperature, or leave RADBC out of [mesh] nastran_loads"
                )
            ok = node_dof >= 0
            extra_space = np.bincount(node_dof[ok], weights=eps_area[ok], minlength=n_dof)
    if unused:
        used_by_bc = set()
        for b in case.boundaries:
            for g in b.groups:
                used_by_bc.update(mesh.groups[g].elements.tolist() if g in mesh.groups else [])
        stray = np.setdiff1d(np.flatnonzero(owner < 0), np.fromiter(used_by_bc, np.int64, len(used_by_bc)))
        if len(stray):
            warnings.warn(
                f"{mesh.source}: {len(stray)} element(s) belong to no part and carry no boundary condition; they are "
                f"not part of the thermal model (ids {format_ids(mesh.element_ids[stray])})",
                stacklevel=3,
            )
    key = np.column_stack([epart, props["k"][elements], props["rho"][elements] * props["cp"][elements],
                           props["t"][elements], props["area"][elements], props["tensor"][elements]])
    _, attribute = unique_rows(np.nan_to_num(key, nan=-1.0), return_inverse=True)
    return FEModel(mesh=mesh, parts=tuple(parts), node_dof=node_dof, n_dof=n_dof, elements=elements,
                   element_part=epart, element_dofs=element_dofs, element_cells=cells, element_types=types,
                   element_attribute=attribute.ravel().astype(np.int64), volume_shares=vshares, capacity_shares=cshares,
                   coo=coo, K=K, volume=volume, capacity=capacity, faces=faces, Q=Q, fixed=fixed,
                   T_sink=case.environment.sink_temperature, loads=loads, links=links, joints=joint_report,
                   extra_space=extra_space)


def _joint_links(mesh: Mesh, case: Case):
    """Decide every joint element's treatment from ``case.joints``.

    Returns ``(iso_pairs (q, 2), cond_pairs (l, 2), cond_G (l,) W/K, report)``; raises one error listing the
    joint cards (with counts) that no ``[[joints]]`` entry covers, and for entries that select nothing.
    """
    iso, cond, G, report, undecided = [], [], [], {}, {}
    hits = np.zeros(len(case.joints), np.int64)
    for jb in mesh.joints:
        choice = np.full(len(jb.ids), -1, np.int64)
        for level in ("cards", "pids", "elements"):
            for j in case.joints:
                sel = getattr(j, level)
                if not sel:
                    continue
                if level == "cards":
                    m = np.full(len(jb.ids), jb.card in sel)
                else:
                    m = np.isin(jb.pids if level == "pids" else jb.ids, np.asarray(sel, np.int64))
                choice[m] = j.index
                hits[j.index] += int(m.sum())
        if (choice < 0).any():
            undecided[jb.card] = int((choice < 0).sum())
            continue
        counts = {}
        per_conn = choice[jb.owner]
        n_conn = np.bincount(jb.owner, minlength=len(jb.ids))
        for j in case.joints:
            mine = per_conn == j.index
            counts[j.treatment] = counts.get(j.treatment, 0) + int((choice == j.index).sum())
            if not mine.any():
                continue
            if j.treatment == "isothermal":
                iso.append(jb.pairs[mine])
            elif j.treatment == "conductance":
                cond.append(jb.pairs[mine])
                if j.conductance is not None:
                    G.append(np.full(int(mine.sum()), j.conductance))
                else:  # contact conductance over the element's area, shared by its connections
                    G.append(j.contact_conductance * j.area / n_conn[jb.owner[mine]])
        report[jb.card] = {k: v for k, v in counts.items() if v}
    if undecided:
        listed = ", ".join(f"{c} ({n})" for c, n in undecided.items())
        names = ", ".join(f'"{c}"' for c in undecided)
        raise Fem2TmmError(
            f"{mesh.source}: joint cards with no thermal treatment: {listed}; add to {case.source} e.g. "
            f"[[joints]] cards = [{names}] treatment = \"conductance\" conductance = <W/K per connection> "
            "(or treatment = \"isothermal\" / \"ignore\"; select by pids = [...] or elements = [...] as well)"
        )
    for j in case.joints:
        if hits[j.index] == 0:
            raise Fem2TmmError(f"{case.source}: [[joints]] {j.name!r} selects no joint element of {mesh.source} "
                               f"(cards {list(j.cards)}, pids {list(j.pids)}, elements {list(j.elements)})")
    z = np.zeros((0, 2), np.int64)
    return (np.concatenate(iso) if iso else z, np.concatenate(cond) if cond else z,
            np.concatenate(G) if G else np.zeros(0), report)


def _midside_map(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """(n_nodes,) edge ends a, b of each mid-side node (-1 elsewhere)."""
    a = np.full(mesh.n_nodes, -1, np.int64)
    b = np.full(mesh.n_nodes, -1, np.int64)
    if mesh.midside is not None and len(mesh.midside):
        a[mesh.midside[:, 0]] = mesh.midside[:, 1]
        b[mesh.midside[:, 0]] = mesh.midside[:, 2]
    return a, b


def _midside_stencil(mesh: Mesh, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each conductance connection (p, q) as 4 nodes and weights w (Σw = 0): the connection's temperature
    difference is w · T.  A mid-side end m (not solved for) is the mean of its edge ends: T_m = (T_a + T_b) / 2,
    exact for the corner-node model of the quadratic element."""
    a, b = _midside_map(mesh)
    nodes = np.empty((len(pairs), 4), np.int64)
    w = np.empty((len(pairs), 4))
    for k, sign in ((0, 1.0), (1, -1.0)):
        e = pairs[:, k]
        mid = a[e] >= 0
        nodes[:, 2 * k] = np.where(mid, a[e], e)
        nodes[:, 2 * k + 1] = np.where(mid, b[e], e)
        w[:, 2 * k] = sign * np.where(mid, 0.5, 1.0)
        w[:, 2 * k + 1] = sign * np.where(mid, 0.5, 0.0)
    return nodes, w


def _midside_isothermal(mesh: Mesh, pairs: np.ndarray) -> np.ndarray:
    """Isothermal connections with a mid-side end m replaced by connections to its edge ends a and b (exact when
    the joint merges a and b too, as a spider over a whole hole edge does; otherwise a stronger constraint, with a
    warning)."""
    a, b = _midside_map(mesh)
    mid = a[pairs] >= 0
    if not mid.any():
        return pairs
    rows = np.flatnonzero(mid.any(axis=1))
    extra = []
    for k in (0, 1):
        sel = rows[mid[rows, k]]
        other = pairs[sel, 1 - k]
        extra += [np.stack([other, a[pairs[sel, k]]], 1), np.stack([other, b[pairs[sel, k]]], 1)]
    out = np.concatenate([pairs[~mid.any(axis=1)], *extra])
    joined = np.zeros(mesh.n_nodes, bool)
    joined[pairs.ravel()] = True
    m = unique(pairs[mid])
    loose = m[~(joined[a[m]] & joined[b[m]])]
    if len(loose):
        warnings.warn(f"{mesh.source}: isothermal joints reach mid-side GRIDs {format_ids(mesh.node_ids[loose])} whose "
                      "edge ends they do not merge; those whole edges are merged instead (a stronger constraint)",
                      stacklevel=4)
    return out


def _deck_fixed(mesh: Mesh, case_fixed: np.ndarray, in_model: np.ndarray) -> list:
    """Fixed-temperature specs ``(name, K, nodes)`` of the deck's SPC/TEMP (one per distinct value); nodes the
    case fixes itself are left to the case (the case overrides the deck)."""
    dl = mesh.loads
    if dl is None or not len(dl.fixed_nodes):
        return []
    nodes, vals = dl.fixed_nodes, dl.fixed_values
    keep = ~case_fixed[nodes] & in_model[nodes]
    nodes, vals = nodes[keep], vals[keep]
    if np.isnan(vals).any():
        raise Fem2TmmError(f"{mesh.source}: SPC1 GRIDs {format_ids(mesh.node_ids[nodes[np.isnan(vals)]])} have no TEMP "
                           "(or TEMPD) value to be held at; add TEMP cards, or fix them in the case file")
    out = []
    for v in unique(vals):
        out.append((f"SPC {v - 273.15:g} C", float(v), unique(nodes[vals == v])))
    return out


def _deck_nodal_loads(mesh: Mesh, dl, elements: np.ndarray, vshares: np.ndarray):
    """Nodal powers (n_nodes,) W per kind of deck load, and the nodal εA (n_nodes,) m² of RADBC faces or None."""
    n = mesh.n_nodes
    out = {}

    def face_shares(faces):
        sh = np.zeros(faces.shape)
        for nk, t in ((3, "tri3"), (4, "quad4")):
            sel = np.flatnonzero((faces[:, 3] < 0) if nk == 3 else (faces[:, 3] >= 0))
            if len(sel):
                sh[sel, :nk] = area_shares(mesh.points, faces[sel, :nk], t)
        return sh

    if len(dl.flux_faces):
        out["flux (QBDY/QHBDY)"] = scatter_shares(dl.flux_faces, face_shares(dl.flux_faces), n, weights=dl.flux_values)
    if len(dl.volume_elements):
        pos = np.searchsorted(elements, dl.volume_elements)
        pos = np.minimum(pos, len(elements) - 1)
        if not (elements[pos] == dl.volume_elements).all():
            bad = dl.volume_elements[elements[pos] != dl.volume_elements]
            raise Fem2TmmError(f"{mesh.source}: QVOL on elements {format_ids(mesh.element_ids[bad])} that belong to no "
                               "part")
        cells = mesh.padded_cells[dl.volume_elements]
        out["QVOL"] = scatter_shares(cells, vshares[pos], n, weights=dl.volume_values)
    if np.any(dl.nodal_power):
        out["QHBDY POINT"] = dl.nodal_power
    eps_area = None
    if len(dl.rad_faces):
        eps_area = scatter_shares(dl.rad_faces, face_shares(dl.rad_faces), n, weights=dl.rad_emissivity)
    return out, eps_area


def _check_load_on_fixed(mesh: Mesh, case: Case, b: Boundary, q: np.ndarray, fixed, fixed_dofs: np.ndarray) -> None:
    """A power/flux load ``q`` (n_dof,) W that lands on fixed-temperature nodes goes straight into the boundary:
    an error when all of it does (it cannot heat anything: surely a wrong group), a warning with the watts when
    more than 1 % does (a heated panel with a fixed edge legitimately puts the edge nodes' share there)."""
    total = float(np.abs(q).sum())
    if total == 0 or not len(fixed_dofs):
        return
    on = q[fixed_dofs]
    lost = float(np.abs(on).sum())
    if lost < 0.01 * total:
        return
    names = ", ".join(repr(f.name) for f, w in zip(fixed, on) if w != 0)
    nodes = np.concatenate([f.nodes for f, w in zip(fixed, on) if w != 0])
    where = f"{case.source}: [[boundary]] {b.name!r} ({b.kind})"
    if lost >= (1 - 1e-12) * total:
        raise Fem2TmmError(
            f"{where}: the whole load ({q.sum():.6g} W) falls on nodes of the fixed-temperature boundary {names} "
            f"(nodes {format_ids(mesh.node_ids[nodes])}), so it would flow straight into that boundary and heat "
            "nothing; put the load on other groups or nodes"
        )
    warnings.warn(f"{where}: {on.sum():.6g} W of its {q.sum():.6g} W fall on nodes of the fixed-temperature boundary "
                  f"{names} and flow straight into it", stacklevel=4)


def boundary_nodes(mesh: Mesh, case: Case, b: Boundary) -> np.ndarray:
    """Sorted mesh node indices of a boundary ``b``: its groups' nodes and its own ``nodes`` (ids)."""
    nodes = ([mesh.group(g, where=f"{case.source}: [[boundary]] {b.name!r}.groups").nodes for g in b.groups]
             + ([mesh.node_index(b.nodes, where=f"{case.source}: [[boundary]] {b.name!r}.nodes")] if b.nodes else []))
    return unique(np.concatenate(nodes)) if nodes else np.zeros(0, np.int64)


def boundary_load(model: FEModel, case: Case, b: Boundary) -> np.ndarray:
    """Nodal loads (n_dof,) W of one power or flux boundary ``b`` of ``case`` (with its ``value``) on ``model``;
    with ``value = 1`` it is the load pattern a time table multiplies."""
    return _load_vector(model.mesh, case, b, model.node_dof, model.n_dof)


def load_patterns(model, case, names) -> dict:
    """{name: (n_dof,) W per unit value (W or W/m²)} of the named power / flux boundaries ``names`` of ``case``
    (:func:`boundary_load` at value 1): a named load at value v is v times its pattern."""
    named = {b.name: b for b in case.boundaries if b.name}
    return {n: boundary_load(model, case, replace(named[n], value=1.0)) for n in names}


def _load_vector(mesh: Mesh, case: Case, b: Boundary, node_dof: np.ndarray, n_dof: int) -> np.ndarray:
    """Nodal loads (n_dof,) W of a power or flux boundary."""
    where = f"{case.source}: [[boundary]] {b.name!r} ({b.kind})"
    el = _union([mesh.group(g, where=where).elements for g in b.groups], mesh.n_elements)
    node_groups = [g for g in b.groups if len(mesh.groups[g].elements) == 0]
    nodal = np.zeros(mesh.n_nodes)
    if len(el):
        dims = mesh.element_dims[el]
        if dims.min() != dims.max():
            raise Fem2TmmError(f"{where}: its groups mix surface and volume elements; use one kind")
        for t, c, _ in mesh.iter_blocks(el):
            if t in SHELL_TYPES:
                sh = area_shares(mesh.points, c, t)
            else:
                if b.kind == "flux":
                    raise Fem2TmmError(f"{where}: a flux (W/m²) needs a surface group; {b.groups} holds volume elements")
                sh = volume_shares(mesh.points, c, t)
            nodal += np.bincount(c.ravel(), weights=sh.ravel(), minlength=mesh.n_nodes)
        total = nodal.sum()
        if b.kind == "power":
            nodal *= b.value / total
        else:
            nodal *= b.value
    if node_groups or b.nodes:
        if b.kind == "flux":
            raise Fem2TmmError(f"{where}: a flux (W/m²) needs surface groups, not node groups or node ids")
        if len(el):
            raise Fem2TmmError(f"{where}: give either element groups or nodes for a power boundary, not both")
        nodes = boundary_nodes(mesh, case, b)
        nodal[nodes] = b.value / len(nodes)
    ok = node_dof >= 0
    lost = np.abs(nodal[~ok]).sum()
    if lost > 1e-12 * max(np.abs(nodal).sum(), 1e-300):
        raise Fem2TmmError(f"{where}: the load falls on nodes that belong to no thermal element; check its groups")
    return np.bincount(node_dof[ok], weights=nodal[ok], minlength=n_dof)


def _build_faces(mesh: Mesh, case: Case, parts, elements, types, cells, epart, node_dof, n_dof, blocks) -> Faces:
    shell = np.isin(types, [TYPE_CODE[t] for t in SHELL_TYPES])
    pos = np.arange(len(elements))
    sf = cells[shell, :4].copy()
    sf[types[shell] == TYPE_CODE["tri3"], 3] = -1
    of, own, contact_nodes, contact_shell, buried = _solid_outer_faces(cells, types, pos)
    fnodes = np.concatenate([sf, of])
    fpos = np.concatenate([pos[shell], own])
    kind = np.concatenate([np.zeros(len(sf), np.int8), np.ones(len(of), np.int8)])
    nf = len(fnodes)
    area = np.zeros(nf)
    normal = np.zeros((nf, 3))
    shares = np.zeros((nf, 4))
    # shells reuse their block geometry; face index of shell element row r is its rank among shells
    shell_rank = np.cumsum(shell) - 1
    todo = []
    for t, sel, c, geom in blocks:
        if t in SHELL_TYPES:
            todo.append((t, shell_rank[sel], c, geom))
    for t, nk in (("tri3", 3), ("quad4", 4)):
        sel = len(sf) + np.flatnonzero((of[:, 3] < 0) if nk == 3 else (of[:, 3] >= 0))
        if len(sel):
            c = fnodes[sel, :nk]
            todo.append((t, sel, c, block_geometry(mesh.points, c, t, need_gradients=False)))
    for t, sel, c, geom in todo:
        nk = c.shape[1]
        sh = area_shares(mesh.points, c, t, geom=geom)
        shares[sel, :nk] = sh
        area[sel] = sh.sum(axis=1)
        nn = geom.normal.sum(axis=1)
        normal[sel] = nn / np.linalg.norm(nn, axis=1, keepdims=True)
    part = epart[fpos]
    # side optics
    eps = np.zeros(2 * nf); alpha = np.zeros(2 * nf); spec = np.zeros(2 * nf)
    tau = np.zeros(2 * nf); tspec = np.ones(2 * nf); active = np.zeros(2 * nf, bool)
    for cp in case.parts:
        for side, oname in ((0, cp.front), (1, cp.back)):
            sel = np.flatnonzero(part == cp.index)
            if side == 1:  # back sides of solid outer faces are inside the material
                sel = sel[kind[sel] == 0]
            if oname == "none" or not len(sel):
                continue
            o = case.optics[oname]
            s = 2 * sel + side
            eps[s], alpha[s], spec[s], tau[s], tspec[s] = (o.emissivity, o.absorptivity, o.specular,
                                                           o.transmissivity, o.transmission_specular)
            active[s] = True
    # shells in contact with solids: the side of a shell lying on a solid's face that faces into the solid (its
    # front when its normal is opposite the face's outward one), both sides of a shell between two solids
    into = np.zeros(len(contact_shell), bool)
    for t, nk in (("tri3", 3), ("quad4", 4)):
        sel = np.flatnonzero((contact_nodes[:, 3] < 0) if nk == 3 else (contact_nodes[:, 3] >= 0))
        if len(sel):
            outward = shell_normals(mesh.points, contact_nodes[sel, :nk], t)
            into[sel] = np.einsum("ij,ij->i", normal[contact_shell[sel]], outward) < 0
    covered = np.concatenate([2 * contact_shell + np.where(into, 0, 1), 2 * buried, 2 * buried + 1])
    eps[covered] = alpha[covered] = tau[covered] = 0.0
    active[covered] = False
    fd = np.where(fnodes >= 0, node_dof[np.maximum(fnodes, 0)], -1)
    ok = fd >= 0
    rows = np.repeat(np.arange(nf), 4).reshape(nf, 4)
    W = sp.csr_matrix(((shares / area[:, None])[ok], (rows[ok], fd[ok])), shape=(nf, n_dof))
    W.sum_duplicates()
    return Faces(nodes=fnodes, dofs=fd, shares=shares, area=area, normal=normal, element=elements[fpos],
                 part=part, kind=kind, emissivity=eps, absorptivity=alpha, specular=spec, transmissivity=tau,
                 transmission_specular=tspec, active=active, W=W)
