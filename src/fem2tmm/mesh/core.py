"""The mesh object every stage reads: points in metres, element blocks, named groups, original ids.

Elements are numbered globally in block order: element ``e`` of the mesh is row ``e - offset[b]`` of
block ``b``.  Groups hold global element indices (2-D/3-D physical groups, Nastran PIDs) and node
indices (every group; for 0-D/1-D groups only nodes).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Mapping

import numpy as np

from ..arrays import unique
from ..errors import Fem2TmmError, InternalError, format_ids
from . import geometry
from .elements import DIM, ELEMENT_TYPES, LINE_TYPES, N_NODES, SHELL_TYPES, SOLID_TYPES, TYPE_CODE


@dataclass(frozen=True)
class ElementBlock:
    """Elements of one type: ``cells`` (m, k) int64 node indices, ``ids`` (m,) int64 original ids."""

    type: str
    cells: np.ndarray
    ids: np.ndarray

    def __post_init__(self):
        if self.type not in ELEMENT_TYPES:
            raise Fem2TmmError(
                f"unsupported element type {self.type!r}; supported: {', '.join(ELEMENT_TYPES)}"
            )


@dataclass(frozen=True)
class Group:
    """A named set: ``elements`` (global element indices, empty for node groups) and ``nodes``.

    ``dim`` is the dimension of the physical group (0 points, 1 lines, 2 surfaces, 3 volumes).
    """

    name: str
    dim: int
    elements: np.ndarray
    nodes: np.ndarray


@dataclass(frozen=True)
class PropertyData:
    """Thermal data a mesh file carries for a group (Nastran PSHELL/PSOLID + MAT4/MAT1), in SI units.

    Any field may be None when the deck does not give it.
    """

    thickness: float | None = None  # m
    conductivity: float | None = None  # W/(m K)
    density: float | None = None  # kg/m³
    specific_heat: float | None = None  # J/(kg K)
    material_id: int | None = None
    #: MAT5 anisotropic conductivity (kxx, kxy, kxz, kyy, kyz, kzz) W/(m K) in the basic system, or None
    conductivity_tensor: tuple[float, ...] | None = None
    area: float | None = None  # m², cross-section of line elements (PBAR, PROD, ...)
    card: str | None = None  # the property card (PSHELL, PCOMP, PBARL, ...): where thickness/area come from


@dataclass(frozen=True)
class JointBlock:
    """Thermal joints of one card type (RBE2, RBE3, CBUSH, CELAS1, CELAS2, CGAP).

    ``ids`` (j,) element ids, ``pids`` (j,) property ids (0: the card has none), ``pairs`` (p, 2) mesh node
    indices of each connection (independent / first node, dependent / second node), ``owner`` (p,) row
    of ``ids`` that each connection belongs to.
    """

    card: str
    ids: np.ndarray
    pids: np.ndarray
    pairs: np.ndarray
    owner: np.ndarray


@dataclass(frozen=True)
class DeckLoads:
    """Thermal boundary conditions a Nastran deck carries (``[mesh] nastran_loads``), in SI units / K.

    ``fixed_nodes`` (f,) node indices with ``fixed_values`` (f,) K (SPC, SPC1 + TEMP/TEMPD);
    ``flux_faces`` (q, 4) node indices padded with -1 and ``flux_values`` (q,) W/m² (QBDY1/2/3, QHBDY areas);
    ``nodal_power`` (n_nodes,) W (QHBDY POINT); ``volume_elements`` (v,) global element indices with
    ``volume_values`` (v,) W/m³ (QVOL); ``rad_faces`` (r, 4) with ``rad_emissivity`` (r,) (x RADBC FAMB) and
    ``rad_ambient`` (r,) K (CHBDYx + RADBC + RADM).  ``counts`` card -> number of cards used.
    """

    fixed_nodes: np.ndarray
    fixed_values: np.ndarray
    flux_faces: np.ndarray
    flux_values: np.ndarray
    nodal_power: np.ndarray
    volume_elements: np.ndarray
    volume_values: np.ndarray
    rad_faces: np.ndarray
    rad_emissivity: np.ndarray
    rad_ambient: np.ndarray
    counts: Mapping[str, int] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class Mesh:
    """A structural mesh.

    Attributes
    ----------
    points : (n, 3) float64, metres
    blocks : element blocks in global element order
    groups : name -> :class:`Group`
    node_ids : (n,) int64 original node (GRID) ids
    source : the file it was read from (for error messages)
    properties : group name -> :class:`PropertyData` (Nastran decks)
    section_area : (m,) m² cross-section of each line element (NaN: not given), or None
    midside : (k, 3) int64 rows (node, a, b): mid-side nodes of quadratic elements, which the model does not
        solve for; their temperature is the mean of the edge ends a, b (outputs), or None
    joints : thermal joint cards (:class:`JointBlock`)
    cards : what the reader did with the deck's cards: ``{"ignored": {card: count}, "refused": {...},
        "modelled": {...}}``
    loads : the deck's own thermal boundary conditions (:class:`DeckLoads`), or None
    """

    points: np.ndarray
    blocks: tuple[ElementBlock, ...]
    groups: Mapping[str, Group] = field(default_factory=dict)
    node_ids: np.ndarray | None = None
    source: str = "<memory>"
    properties: Mapping[str, PropertyData] = field(default_factory=dict)
    section_area: np.ndarray | None = None
    midside: np.ndarray | None = None
    joints: tuple[JointBlock, ...] = ()
    cards: Mapping[str, Mapping[str, int]] = field(default_factory=dict)
    loads: DeckLoads | None = None

    def __post_init__(self):
        pts = np.asarray(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise Fem2TmmError(f"{self.source}: points must be an (n, 3) array, got shape {pts.shape}")
        object.__setattr__(self, "points", pts)
        if self.node_ids is None:
            object.__setattr__(self, "node_ids", np.arange(1, len(pts) + 1, dtype=np.int64))
        object.__setattr__(self, "blocks", tuple(self.blocks))
        self._check()

    # ------------------------------------------------------------------ sizes and indexing
    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @cached_property
    def offsets(self) -> np.ndarray:
        """(n_blocks + 1,) start of each block in the global element numbering."""
        return np.concatenate([[0], np.cumsum([len(b.cells) for b in self.blocks])]).astype(np.int64)

    @property
    def n_elements(self) -> int:
        return int(self.offsets[-1])

    @cached_property
    def element_types(self) -> np.ndarray:
        """(m,) int8 type code of each element (see :data:`fem2tmm.mesh.elements.TYPE_CODE`)."""
        return np.concatenate(
            [np.full(len(b.cells), TYPE_CODE[b.type], np.int8) for b in self.blocks] or [np.zeros(0, np.int8)]
        )

    @cached_property
    def element_ids(self) -> np.ndarray:
        """(m,) original element ids."""
        return np.concatenate([b.ids for b in self.blocks] or [np.zeros(0, np.int64)]).astype(np.int64)

    @cached_property
    def padded_cells(self) -> np.ndarray:
        """(m, 8) int64 node indices of every element, padded with -1."""
        return pad_cells(self.blocks)

    @cached_property
    def element_dims(self) -> np.ndarray:
        """(m,) int8 dimension of each element (1 lines, 2 shells, 3 solids)."""
        return np.concatenate(
            [np.full(len(b.cells), DIM[b.type], np.int8) for b in self.blocks] or [np.zeros(0, np.int8)]
        )

    def block_of(self, elements: np.ndarray) -> np.ndarray:
        """Block index of each global element index."""
        return np.searchsorted(self.offsets, np.asarray(elements), side="right") - 1

    def iter_blocks(self, elements: np.ndarray | None = None):
        """Yield ``(etype, cells, global_index)`` per block, restricted to ``elements`` if given."""
        if elements is None:
            for b, o in zip(self.blocks, self.offsets):
                yield b.type, b.cells, np.arange(o, o + len(b.cells))
            return
        elements = np.asarray(elements, dtype=np.int64)
        blk = self.block_of(elements)
        for i, b in enumerate(self.blocks):
            sel = elements[blk == i]
            if len(sel):
                yield b.type, b.cells[sel - self.offsets[i]], sel

    # ------------------------------------------------------------------ geometry helpers
    def _per_element(self, fn, width: int | None = None, elements=None) -> np.ndarray:
        """Evaluate ``fn(etype, cells)`` block by block into an (m,) or (m, width) array (NaN where None)."""
        if elements is None:
            m, pos = self.n_elements, None
        else:
            elements = np.asarray(elements, dtype=np.int64)
            m = len(elements)
            sorter = np.argsort(elements, kind="stable")
            pos = (sorter, elements[sorter])
        out = np.full((m,) if width is None else (m, width), np.nan)
        for etype, cells, gidx in self.iter_blocks(elements):
            val = fn(etype, cells)
            if val is None:
                continue
            if pos is None:
                out[gidx] = val
            else:
                out[pos[0][np.searchsorted(pos[1], gidx)]] = val
        return out

    def element_lengths(self, elements: np.ndarray | None = None) -> np.ndarray:
        """Length (m,) in m of line elements; NaN for shells and solids."""
        return self._per_element(
            lambda t, c: np.linalg.norm(self.points[c[:, 1]] - self.points[c[:, 0]], axis=1) if t in LINE_TYPES
            else None, elements=elements)

    def element_areas(self, elements: np.ndarray | None = None) -> np.ndarray:
        """Area (m,) in m² of shell elements; NaN for solids."""
        return self._per_element(
            lambda t, c: geometry.shell_areas(self.points, c, t) if t in SHELL_TYPES else None, elements=elements
        )

    def element_normals(self, elements: np.ndarray | None = None) -> np.ndarray:
        """Unit right-hand normal (m, 3) of shell elements at their centroid; NaN for solids."""
        return self._per_element(
            lambda t, c: geometry.shell_normals(self.points, c, t) if t in SHELL_TYPES else None,
            width=3,
            elements=elements,
        )

    def element_volumes(self, thickness: np.ndarray | float | None = None, elements=None) -> np.ndarray:
        """Volume (m,) in m³: |signed volume| of solids; area x thickness of shells (NaN without thickness)."""
        vol = self._per_element(
            lambda t, c: np.abs(geometry.solid_volumes(self.points, c, t)) if t in SOLID_TYPES else None,
            elements=elements,
        )
        if thickness is not None:
            area = self.element_areas(elements)
            shell = np.isnan(vol)
            vol[shell] = (area * np.broadcast_to(thickness, area.shape))[shell]
        return vol

    def element_centroids(self, elements: np.ndarray | None = None) -> np.ndarray:
        """Mean of the nodes of each element (m, 3) in metres."""
        return self._per_element(lambda t, c: geometry.centroids(self.points, c), width=3, elements=elements)

    # ------------------------------------------------------------------ groups
    def group(self, name: str, where: str = "") -> Group:
        """The group called ``name``; a clear error listing the available groups otherwise."""
        try:
            return self.groups[name]
        except KeyError:
            avail = ", ".join(repr(g) for g in sorted(self.groups)) or "(none)"
            pre = f"{where}: " if where else ""
            raise Fem2TmmError(
                f"{pre}group {name!r} is not in mesh {self.source}; available groups: {avail}"
            ) from None

    def node_index(self, ids, where: str) -> np.ndarray:
        """Mesh node indices of original node ids ``ids``; a clear error (``where`` names the key) for ids that are
        not in the mesh."""
        ids = np.asarray(ids, np.int64)
        order = np.argsort(self.node_ids)
        pos = np.minimum(np.searchsorted(self.node_ids, ids, sorter=order), len(order) - 1)
        idx = order[pos]
        missing = ids[self.node_ids[idx] != ids]
        if len(missing):
            raise Fem2TmmError(f"{where}: node ids {format_ids(missing)} are not in mesh {self.source}")
        return idx

    def nodes_of_elements(self, elements: np.ndarray) -> np.ndarray:
        """Sorted unique node indices used by the given elements."""
        pc = self.padded_cells[np.asarray(elements, dtype=np.int64)]
        return unique_ints(pc[pc >= 0])

    def used_nodes(self) -> np.ndarray:
        """(n,) bool: nodes referenced by at least one element."""
        used = np.zeros(self.n_nodes, bool)
        for b in self.blocks:
            used[b.cells.ravel()] = True
        return used

    def validate(self) -> "Mesh":
        """The mesh itself: it was checked when it was built (kept for callers of the former API)."""
        return self

    def _check(self) -> None:
        """Check what every stage relies on; raises :class:`Fem2TmmError` naming the culprits."""
        if self.n_elements == 0:
            raise Fem2TmmError(f"{self.source}: the mesh has no supported elements ({', '.join(ELEMENT_TYPES)})")
        bad = ~np.isfinite(self.points).all(axis=1)
        if bad.any():
            raise Fem2TmmError(
                f"{self.source}: non-finite (NaN/inf) coordinates at node ids {format_ids(self.node_ids[bad])}"
            )
        for b in self.blocks:
            if b.cells.ndim != 2 or b.cells.shape[1] != N_NODES[b.type]:
                raise Fem2TmmError(f"{self.source}: {b.type} block must have {N_NODES[b.type]} nodes per element")
            if len(b.cells) and (b.cells.min() < 0 or b.cells.max() >= self.n_nodes):
                badel = b.ids[((b.cells < 0) | (b.cells >= self.n_nodes)).any(axis=1)]
                raise Fem2TmmError(
                    f"{self.source}: {b.type} elements {format_ids(badel)} reference nodes that do not exist"
                )


def pad_cells(blocks) -> np.ndarray:
    """(m, 8) int64 node indices of the elements of ``blocks`` (in order), padded with -1."""
    m = sum(len(b.cells) for b in blocks)
    out = np.full((m, 8), -1, dtype=np.int64)
    o = 0
    for b in blocks:
        out[o : o + len(b.cells), : b.cells.shape[1]] = b.cells
        o += len(b.cells)
    return out


def unique_ints(a) -> np.ndarray:
    """Sorted unique values of an integer array as int64 (:func:`fem2tmm.arrays.unique`: one sort and a mask, not
    numpy 2's hash-based ``np.unique``)."""
    return unique(np.asarray(a, dtype=np.int64).ravel())


def make_group(name: str, dim: int, elements=None, nodes=None, mesh_cells: np.ndarray | None = None) -> Group:
    """Build a :class:`Group`; element groups get their nodes from ``mesh_cells`` (padded (m, 8))."""
    el = unique_ints(elements if elements is not None else [])
    if nodes is None:
        if mesh_cells is None:
            raise InternalError("make_group: nodes or mesh_cells is needed")
        pc = mesh_cells[el]
        nodes = pc[pc >= 0]
    nd = unique_ints(nodes)
    return Group(name=name, dim=int(dim), elements=el, nodes=nd)
