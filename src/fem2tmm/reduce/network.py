"""The reduced thermal network: super nodes, exact reduced conduction, capacitance, loads, space radiation.

It turns an :class:`~fem2tmm.fem.model.FEModel` and a :class:`~fem2tmm.cluster.Clustering` into a
:class:`ReducedModel` of plain arrays that the radiation stage, the steady solver, the recovery and the
exporters consume.

Super-node order: the clusters (part by part), then one boundary node per fixed-temperature group, then
the nodes the user keeps.  The space node is not a super node; it is the sink of ``g_space`` and the
last row/column of ``GR``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..arrays import unique
from ..case import Case
from ..cluster import Clustering
from ..errors import Fem2TmmError, InternalError, format_ids
from ..fem.model import FEModel
from .capacitance import equivalent_capacitance, supernode_capacitance
from .conduction import ConductiveReduction, reduce_conduction
from .filters import filter_links, negative_links
from .radiative import RadiationAware, emission_entries, emission_weights, split_radiative
from .supernodes import SuperNodes, build_supernodes

@dataclass(frozen=True)
class ReducedModel:
    """A reduced network.  Shapes: n = n_SN super nodes (clusters, then boundary, then kept nodes).

    ``K`` (n, n) W/K dense (after the optional filter); ``C`` (n,) J/K or None; ``Q`` (n,) W = Y q;
    ``g_space`` (n,) m² εA to the sink; ``GR`` (n, n) m² node-to-node radiative couplings or None;
    ``fixed`` (n,) bool, ``T_fixed`` (n,) K; ``names`` (n,) str; ``part`` (n,) part index or -1.
    """

    names: np.ndarray
    kind: np.ndarray
    part: np.ndarray
    K: np.ndarray
    C: np.ndarray | None
    Q: np.ndarray
    g_space: np.ndarray
    fixed: np.ndarray
    T_fixed: np.ndarray
    T_sink: float
    supernodes: SuperNodes
    reduction: ConductiveReduction
    element_cluster: np.ndarray  # (m,) reduced cluster id of each model element (-1: fully determined element)
    GR: np.ndarray | None = None
    area: np.ndarray | None = None  # (n,) m² radiating area of each super node (both sides, active)
    report: dict = field(default_factory=dict)
    radiative: RadiationAware | None = None  # radiation-aware reduction (K is then K̃ = K'_SN − diag(H_SN))
    #: ``(x (n, m) K, y (n, m) m²)`` or None: each super node's coupling to space as a function of its own
    #: temperature (the radiation-aware network's effective emission, :func:`fem2tmm.reduce.radiative.effective_emission`);
    #: ``g_space`` then holds its value at the design state
    g_space_table: tuple | None = None
    #: :class:`fem2tmm.reduce.radiative.HotSpots` or None: the radiator nodes of the heat each load's footprint
    #: radiates inside its own super nodes (the deck's extra nodes; coupled to no super node)
    hot_spots: object | None = None

    @property
    def n(self) -> int:
        return len(self.names)

    @property
    def hot_spot_W(self) -> float:
        """W applied to and radiated to space by the :attr:`hot_spots` nodes at the design state (0 without)."""
        return 0.0 if self.hot_spots is None else float(np.sum(self.hot_spots.Q))


def determined_elements(model: FEModel, kept: np.ndarray | None = None) -> np.ndarray:
    """(m,) bool: model elements whose nodes are all fixed-temperature (or kept) DOFs — no unknown inside."""
    one_node = np.zeros(model.n_dof, bool)
    one_node[[g.dof for g in model.fixed]] = True
    if kept is not None:
        one_node[kept] = True
    ed = model.element_dofs
    return np.where(ed >= 0, one_node[np.maximum(ed, 0)], True).all(axis=1)

def kept_dofs(model: FEModel, case: Case) -> np.ndarray:
    """DOFs of ``[reduction] keep_nodes`` (original node ids) and of the conductance joints' ends (a joint
    stays its own link between one-node super nodes; fixed-temperature ends are boundary nodes already)."""
    ids = np.asarray(case.reduction.keep_nodes, np.int64)
    joint = np.setdiff1d(model.link_dofs, [g.dof for g in model.fixed])
    if not len(ids):
        return joint
    idx = model.mesh.node_index(ids, where=f"{case.source}: [reduction] keep_nodes")
    dofs = model.node_dof[idx]
    outside = ids[dofs < 0]
    if len(outside):
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: nodes {format_ids(outside)} belong to no thermal element")
    fixed = np.isin(dofs, [g.dof for g in model.fixed])
    if fixed.any():
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: nodes {format_ids(ids[fixed])} are in a "
                           "fixed-temperature boundary (already a boundary node)")
    return np.union1d(dofs, joint)


def build_reduced(model: FEModel, clustering: Clustering, case: Case, T_ref: np.ndarray | None = None) -> ReducedModel:
    """Super nodes, exact reduced conduction, capacitance, loads and (space-only) radiation.

    ``T_ref`` (n_dof,) K: reduce ``K + diag(h)`` with the emission linearised about it (radiation-aware
    reduction, :mod:`fem2tmm.reduce.radiative`): ``K`` is then K̃ (zero row sums) and ``radiative`` holds
    H_SN, h and the reduction of K' for the correction load and the recovery.
    """
    labels_all = clustering.labels[model.elements]
    boundary = np.array([g.dof for g in model.fixed], np.int64)
    kept = kept_dofs(model, case)
    # Elements whose nodes are all boundary/kept DOFs have no unknown: their conduction links those
    # one-node super nodes directly, and a cluster made only of them is dropped (it is fully determined).
    ed = model.element_dofs
    lone = determined_elements(model, kept)  # (their capacitance goes to their nodes, below)
    determined = lone | (labels_all < 0)
    rows = np.flatnonzero(~determined)
    used_clusters = unique(labels_all[rows])
    new_id = np.full(len(clustering.cluster_part), -1, np.int64)
    new_id[used_clusters] = np.arange(len(used_clusters))
    cluster_part = clustering.cluster_part[used_clusters]
    labels = new_id[labels_all[rows]]
    n_cl = len(used_clusters)
    shares = model.capacity_shares if model.capacity_shares is not None else model.volume_shares
    sn = build_supernodes(model.n_dof, ed[rows], shares[rows], labels, boundary=boundary, kept=kept,
                          n_clusters=n_cl)
    keep_entry = ~determined[model.coo.elem]
    coo = model.coo.select(keep_entry)
    h = None
    if T_ref is not None:
        elem_row = np.full(model.mesh.n_elements, -1, np.int64)
        elem_row[model.elements] = np.arange(len(model.elements))
        f = model.faces
        face_row = elem_row[f.element]  # conduction entries are numbered by model element row
        emis = emission_entries(f.W, face_row, f.eps_area, T_ref)
        # h counts every face: a fully determined element's faces emit from one-node super nodes (joint ends, kept
        # nodes), whose H_SN = Y'h must hold that emission (the network gives it them, radiation_aware_network);
        # only the clustered elements' entries enter the local condensation
        h = np.bincount(emis.rows, emis.vals, minlength=model.n_dof)
        coo = type(coo).concatenate([coo, emis.select(~determined[emis.elem])])
    red = reduce_conduction(coo, sn, labels, elements=rows, method=case.reduction.method,
                            zero_row_sums=T_ref is None)
    K = red.K.copy()
    row_of_dof = _row_of_dof(sn, model.n_dof)
    if determined.any():
        direct = model.coo.select(~keep_entry)
        np.add.at(K, (row_of_dof[direct.rows], row_of_dof[direct.cols]), direct.vals)
    if model.links is not None:  # joints: their own conductances between one-node super nodes
        L = model.links
        np.add.at(K, (row_of_dof[L.rows], row_of_dof[L.cols]), L.vals)
    radiative = None
    if T_ref is not None:
        # H_SN = Y' h (the identity K'_SN 1 = Y' h, module docstring of reduce/radiative.py), not the row sums of
        # K'_SN: those carry the round-off of a zero-row-sum conduction matrix (1e-12 W/K per super node where no
        # face emits), which the correction load would turn into spurious watts (-H T_SN)
        K, _ = split_radiative(K)
        H = red.distribute(h)
        radiative = RadiationAware(reduction=red, K=K, H=H, e=emission_weights(model.faces.W, model.faces.eps_area),
                                   h=h, T_sink=model.T_sink)
    report = {"method": red.method, "diagnostics": dict(red.diagnostics),
              "determined_elements": int(determined.sum()), "dropped_clusters": int(len(clustering.cluster_part) - n_cl)}
    if case.reduction.filter > 0:
        K, frep = filter_links(K, case.reduction.filter)
        report["filter"] = frep
    # capacitance
    C = None
    if model.capacity_shares is not None:
        if case.reduction.capacitance == "equivalent":
            C = equivalent_capacitance(red, model.capacity)
        else:
            # the elements in no cluster whose nodes are all one-node super nodes (joint ends, kept nodes) give those
            # nodes their shares; a held node's temperature is given, it gets none (as before)
            lone_dofs = ed[lone]
            gets = (lone_dofs >= 0) & ~np.isin(lone_dofs, boundary)
            lone_rows = np.where(gets, row_of_dof[np.maximum(lone_dofs, 0)], -1)
            if np.any(gets & (lone_rows < 0)):
                raise InternalError("an element without a cluster has a node that is no one-node super node")
            C = supernode_capacitance(sn, model.capacity_shares[rows], labels,
                                      unclustered=(lone_rows, model.capacity_shares[lone]))
    n = sn.n_sn
    element_cluster = np.full(len(model.elements), -1, np.int64)
    element_cluster[rows] = labels
    # names, kinds, fixed nodes
    names, part = [], np.full(n, -1, np.int64)
    counters = {}
    fixed = np.zeros(n, bool)
    fixed_by_dof = {g.dof: g for g in model.fixed}
    first_node = np.full(model.n_dof, -1, np.int64)  # the lowest mesh node of each DOF (names of kept nodes)
    in_model = np.flatnonzero(model.node_dof >= 0)
    first_node[model.node_dof[in_model[::-1]]] = in_model[::-1]
    for i in range(n):
        if sn.cluster[i] >= 0:
            p = int(cluster_part[sn.cluster[i]])
            part[i] = p
            counters[p] = counters.get(p, 0) + 1
            names.append(f"{model.parts[p].name}_{counters[p]}")
        elif int(sn.dof[i]) in fixed_by_dof:
            g = fixed_by_dof[int(sn.dof[i])]
            names.append(g.name)
            fixed[i] = True
        else:
            names.append(f"node_{int(model.mesh.node_ids[first_node[sn.dof[i]]])}")
    pairs, gl = negative_links(K)
    report["negative_links"] = int(len(pairs))
    report["negative_GL_W_per_K"] = float(gl.sum()) if len(gl) else 0.0
    return ReducedModel(names=np.array(names), kind=np.asarray(sn.kind), part=part, K=K, C=C, fixed=fixed,
                        supernodes=sn, reduction=red, element_cluster=element_cluster, GR=None, report=report,
                        radiative=radiative,
                        **case_values(model, sn, red, element_cluster))


def case_values(model: FEModel, sn: SuperNodes, red: ConductiveReduction, element_cluster: np.ndarray) -> dict:
    """The fields of a :class:`ReducedModel` that the case's loads, boundary temperatures, sink and optics
    give it, everything else being fixed by the mesh, the clustering and the conduction: ``Q`` = Y q (n,) W,
    ``g_space`` (n,) m² (space-only radiation: each super node radiates through the εA of its faces' active
    sides), ``area`` (n,) m² active radiating area, ``T_fixed`` (n,) K and ``T_sink`` K."""
    f = model.faces
    n = sn.n_sn
    owner = face_owner(model, sn, element_cluster)
    T_fixed = np.zeros(n)
    row_of_dof = _row_of_dof(sn, model.n_dof)
    for g in model.fixed:  # loop over fixed-temperature groups
        T_fixed[row_of_dof[g.dof]] = g.T
    return {"Q": red.distribute(model.Q), "g_space": np.bincount(owner, weights=f.eps_area, minlength=n).astype(float),
            "area": np.bincount(owner, weights=f.active_area, minlength=n).astype(float), "T_fixed": T_fixed,
            "T_sink": model.T_sink}


def refresh_reduced(rm: ReducedModel, model: FEModel) -> ReducedModel:
    """``rm`` (built for another case with the same mesh, clustering and conduction, e.g. taken from the stage
    cache) with this ``model``'s loads, boundary temperatures, sink and optics (:func:`case_values`)."""
    return replace(rm, **case_values(model, rm.supernodes, rm.reduction, rm.element_cluster))


def conductive_links(K: np.ndarray, rtol: float = 0.0) -> int:
    """Number of non-zero off-diagonal pairs (GL) of a symmetric K."""
    iu = np.triu_indices(len(K), 1)
    return int(np.count_nonzero(np.abs(K[iu]) > rtol * np.abs(np.diag(K)).max(initial=0.0)))

def _row_of_dof(sn: SuperNodes, n_dof: int) -> np.ndarray:
    """(n_dof,) the super-node row of each one-node (boundary/kept) DOF, -1 elsewhere."""
    row = np.full(n_dof, -1, np.int64)
    row[sn.dof[sn.dof >= 0]] = np.flatnonzero(sn.dof >= 0)
    return row


def face_owner(model: FEModel, sn: SuperNodes, element_cluster: np.ndarray) -> np.ndarray:
    """(f,) the super-node row each radiating face belongs to: its element's cluster, or, for a face of a
    fully determined element (cluster -1), the one-node super node of its largest nodal share."""
    f = model.faces
    elem_row = np.full(model.mesh.n_elements, -1, np.int64)
    elem_row[model.elements] = np.arange(len(model.elements))
    cl = element_cluster[elem_row[f.element]]
    row_of_cluster = np.full(max(int(sn.cluster.max(initial=-1)) + 1, 0), -1, np.int64)
    row_of_cluster[sn.cluster[sn.cluster >= 0]] = np.flatnonzero(sn.cluster >= 0)
    owner = np.full(f.n, -1, np.int64)
    live = cl >= 0
    owner[live] = row_of_cluster[cl[live]]
    if (~live).any():
        owner[~live] = _row_of_dof(sn, model.n_dof)[f.dofs[~live, np.argmax(f.shares[~live], axis=1)]]
    return owner


def super_faces(model: FEModel, rm: ReducedModel) -> tuple[np.ndarray, np.ndarray]:
    """Super faces: the active sides of each super node, grouped by super node and side (front/back).

    Returns ``groups`` (2f,) super-face index of each side (-1 inactive) and ``owner`` (n_sf,) the super-node
    row of each super face.  Sides of fully determined elements belong to the one-node super node of the
    face's largest nodal share.
    """
    f = model.faces
    owner_face = face_owner(model, rm.supernodes, rm.element_cluster)
    side_owner = np.repeat(owner_face, 2)
    side = np.tile([0, 1], f.n)
    key = np.where(f.active, side_owner * 2 + side, -1)
    uniq, inv = unique(key[key >= 0], return_inverse=True)
    groups = np.full(2 * f.n, -1, np.int64)
    groups[key >= 0] = inv.ravel()
    return groups, uniq // 2


def negative_loads(rm: ReducedModel) -> tuple[float, int]:
    """The negative load (W, <= 0) the network ``rm`` puts on its free super nodes (the exact distribution Y'q of
    non-negative loads can give some: a heater's neighbours on a thin panel), and on how many super nodes."""
    Q = np.asarray(rm.Q, float)[~np.asarray(rm.fixed, bool)]
    scale = max(float(np.abs(Q).max(initial=0.0)), 1e-300)
    low = Q < -1e-9 * scale
    return float(Q[low].sum()), int(low.sum())
