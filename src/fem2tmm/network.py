"""The reduced thermal network: clustering -> super nodes -> reduced conduction -> radiation -> solve.

Pipeline-level glue (it knows the stage order, like :mod:`fem2tmm.pipeline`): it turns an
:class:`~fem2tmm.fem.model.FEModel` and a clustering into a :class:`ReducedModel` of plain arrays that
the steady solver, the recovery and the exporters consume.

Super-node order: the clusters (part by part), then one boundary node per fixed-temperature group, then
the nodes the user keeps.  The space node is not a super node; it is the sink of ``g_space`` and the
last row/column of ``GR``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .cluster import Clustering, PartInput, cluster_parts
from .errors import Fem2TmmError, format_ids
from .fem.model import FEModel
from .reduce import (ConductiveReduction, SuperNodes, build_supernodes, equivalent_capacitance, filter_links,
                     negative_links, reduce_conduction, supernode_capacitance)
from .solve.steady import SteadyProblem


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
    element_cluster: np.ndarray  # (m,) cluster of each model element
    GR: np.ndarray | None = None
    area: np.ndarray | None = None  # (n,) m² radiating area of each super node (both sides, active)
    report: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.names)

    def problem(self) -> SteadyProblem:
        return SteadyProblem(K=self.K, Q=self.Q, fixed=self.fixed, T_fixed=self.T_fixed, g_space=self.g_space,
                             T_sink=self.T_sink, GR=self.GR, names=tuple(self.names))


def cluster_model(model: FEModel, case, progress=None) -> Clustering:
    """Cluster every part of ``model`` with its requested number of super nodes."""
    parts = []
    for p, info in enumerate(model.parts):
        rows = np.flatnonzero(model.element_part == p)
        parts.append(PartInput(name=info.name, kind=info.kind, elements=model.elements[rows],
                               cells=model.element_cells[rows], types=model.element_types[rows],
                               n_clusters=info.super_nodes, attribute=model.element_attribute[rows]))
    cs = case.clustering
    return cluster_parts(model.mesh.points, parts, model.mesh.n_elements, feature_angle=cs.feature_angle,
                         seed=cs.seed, smoothing_layers=cs.smoothing_layers, progress=progress)


def kept_dofs(model: FEModel, case) -> np.ndarray:
    """DOFs of ``[reduction] keep_nodes`` (original node ids)."""
    ids = np.asarray(case.reduction.keep_nodes, np.int64)
    if not len(ids):
        return np.zeros(0, np.int64)
    mesh = model.mesh
    order = np.argsort(mesh.node_ids)
    pos = np.minimum(np.searchsorted(mesh.node_ids, ids, sorter=order), len(order) - 1)
    idx = order[pos]
    missing = ids[mesh.node_ids[idx] != ids]
    if len(missing):
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: node ids {format_ids(missing)} are not in the mesh")
    dofs = model.node_dof[idx]
    outside = ids[dofs < 0]
    if len(outside):
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: nodes {format_ids(outside)} belong to no thermal element")
    fixed = np.isin(dofs, [g.dof for g in model.fixed])
    if fixed.any():
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: nodes {format_ids(ids[fixed])} are in a "
                           "fixed-temperature boundary (already a boundary node)")
    return np.unique(dofs)


def build_reduced(model: FEModel, clustering: Clustering, case) -> ReducedModel:
    """Super nodes, exact reduced conduction, capacitance, loads and (space-only) radiation."""
    m = len(model.elements)
    labels = clustering.labels[model.elements]
    n_cl = len(clustering.cluster_part)
    boundary = np.array([g.dof for g in model.fixed], np.int64)
    kept = kept_dofs(model, case)
    shares = model.capacity_shares if model.capacity_shares is not None else model.volume_shares
    sn = build_supernodes(model.n_dof, model.element_dofs, shares, labels, boundary=boundary, kept=kept,
                          n_clusters=n_cl)
    red = reduce_conduction(model.coo, sn, labels, elements=np.arange(m), method=case.reduction.method)
    K = red.K
    report = {"method": red.method, "diagnostics": dict(red.diagnostics)}
    if case.reduction.filter > 0:
        K, frep = filter_links(K, case.reduction.filter)
        report["filter"] = frep
    # capacitance
    C = None
    if model.capacity_shares is not None:
        if case.reduction.capacitance == "equivalent":
            C = equivalent_capacitance(red, model.capacity)
        else:
            C = supernode_capacitance(sn, model.capacity_shares, labels)
    Q = red.distribute(model.Q)
    # space-only radiation: each cluster radiates through the εA of its faces' active sides
    f = model.faces
    face_cluster = clustering.labels[f.element]
    eps_area = (f.emissivity * f.active).reshape(-1, 2).sum(axis=1) * f.area
    area_active = f.active.reshape(-1, 2).sum(axis=1) * f.area
    n = sn.n_sn
    g_space = np.zeros(n)
    area = np.zeros(n)
    row_of_cluster = np.full(n_cl, -1, np.int64)
    row_of_cluster[sn.cluster[sn.cluster >= 0]] = np.flatnonzero(sn.cluster >= 0)
    g_space += np.bincount(row_of_cluster[face_cluster], weights=eps_area, minlength=n)
    area += np.bincount(row_of_cluster[face_cluster], weights=area_active, minlength=n)
    # names, kinds, fixed values
    names, part = [], np.full(n, -1, np.int64)
    counters = {}
    fixed = np.zeros(n, bool)
    T_fixed = np.zeros(n)
    fixed_by_dof = {g.dof: g for g in model.fixed}
    node_of_dof = {}
    if len(kept):
        nd = np.flatnonzero(model.node_dof >= 0)
        first = {}
        for node, d in zip(nd, model.node_dof[nd]):
            first.setdefault(int(d), int(node))
        node_of_dof = first
    for i in range(n):
        if sn.cluster[i] >= 0:
            p = int(clustering.cluster_part[sn.cluster[i]])
            part[i] = p
            counters[p] = counters.get(p, 0) + 1
            names.append(f"{model.parts[p].name}_{counters[p]}")
        elif int(sn.dof[i]) in fixed_by_dof:
            g = fixed_by_dof[int(sn.dof[i])]
            names.append(g.name)
            fixed[i] = True
            T_fixed[i] = g.T
        else:
            names.append(f"node_{int(model.mesh.node_ids[node_of_dof[int(sn.dof[i])]])}")
    pairs, gl = negative_links(K)
    report["negative_links"] = int(len(pairs))
    report["negative_GL_W_per_K"] = float(gl.sum()) if len(gl) else 0.0
    return ReducedModel(names=np.array(names), kind=np.asarray(sn.kind), part=part, K=K, C=C, Q=Q,
                        g_space=g_space, fixed=fixed, T_fixed=T_fixed, T_sink=model.T_sink, supernodes=sn,
                        reduction=red, element_cluster=labels, GR=None, area=area, report=report)


def conductive_links(K: np.ndarray, rtol: float = 0.0) -> int:
    """Number of non-zero off-diagonal pairs (GL) of a symmetric K."""
    iu = np.triu_indices(len(K), 1)
    return int(np.count_nonzero(np.abs(K[iu]) > rtol * np.abs(np.diag(K)).max(initial=0.0)))
