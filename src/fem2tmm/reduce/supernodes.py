"""Super-node definition ``T_SN = A T`` (thesis §4.3.1, DESIGN §3.2).

Row i of A for a cluster holds the capacitance (or volume) that the cluster's *own* elements give each of
their nodes, divided by the cluster's total, so every row sums to 1 and a node on the border of two clusters
appears in both rows with the share each side gives it.  Fixed-temperature groups (already merged into one DOF
each) and nodes the user keeps become one-node super nodes with a unit row; they keep their weights in the
rows of the clusters around them (thesis beam example, the matrix A above eq. 4.15).

Super-node order: clusters 0 … n_clusters−1, then the boundary DOFs in the order given, then the kept DOFs.

The saddle matrix ``M = [[K, Aᵀ], [A, 0]]`` is invertible only when the rows of A are independent and they fix
the mean temperature of every connected part; :func:`build_supernodes` checks both and raises a
:class:`~fem2tmm.errors.Fem2TmmError` naming the clusters and DOFs involved, instead of leaving it to a singular
factorisation.  Cheap structural tests come first (a row with a node no other row touches is independent of
the others); a numerical rank test runs only on the few rows that fail them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..arrays import unique
from ..errors import Fem2TmmError, format_ids
from ..linalg import dependent_rows as _dependent_rows
from .capacitance import cluster_capacitance

@dataclass(frozen=True)
class SuperNodes:
    """Definition of the super nodes.

    ``A`` (n_SN, n_dof) csr, rows sum to 1; ``kind`` (n_SN,) "cluster" | "boundary" | "kept";
    ``cluster`` (n_SN,) cluster id or −1; ``dof`` (n_SN,) the DOF of one-node super nodes or −1;
    ``capacity`` (n_SN,) cluster sums of the shares A was built from (J/K, or m³ with volume weights),
    0 for one-node super nodes; ``interface`` (n_dof,) bool: DOFs touched by the elements of more than one
    cluster, plus every boundary / kept DOF (the nodes the local reduction keeps until the Guyan step).
    """

    A: sp.csr_matrix
    kind: np.ndarray
    cluster: np.ndarray
    dof: np.ndarray
    capacity: np.ndarray
    interface: np.ndarray

    @property
    def n_sn(self) -> int:
        return self.A.shape[0]

    @property
    def n_dof(self) -> int:
        return self.A.shape[1]

    @property
    def n_clusters(self) -> int:
        return int(np.count_nonzero(self.cluster >= 0))

    @property
    def one_node(self) -> np.ndarray:
        """Indices (k,) of the one-node (boundary and kept) super nodes."""
        return np.flatnonzero(self.dof >= 0)


def _as_dofs(values, name: str, n_dof: int) -> np.ndarray:
    arr = np.asarray(values if values is not None else (), dtype=np.int64).ravel()
    bad = arr[(arr < 0) | (arr >= n_dof)]
    if bad.size:
        raise Fem2TmmError(f"{name} DOFs {format_ids(bad)} are outside 0..{n_dof - 1}")
    uniq, counts = unique(arr, return_counts=True)
    if np.any(counts > 1):
        raise Fem2TmmError(f"{name} DOFs {format_ids(uniq[counts > 1])} are listed more than once")
    return arr


def _check_inputs(n_dof, cells, shares, labels, n_clusters):
    cells = np.asarray(cells)
    if cells.ndim != 2 or not np.issubdtype(cells.dtype, np.integer):
        raise Fem2TmmError(f"cells must be an (m, k) integer array of DOF indices padded with -1, got {cells.shape}")
    cells = cells.astype(np.int64, copy=False)
    shares = np.asarray(shares, float)
    labels = np.asarray(labels)
    if shares.shape != cells.shape:
        raise Fem2TmmError(f"shares {shares.shape} must have the shape of cells {cells.shape}")
    if labels.shape != (cells.shape[0],) or (labels.size and not np.issubdtype(labels.dtype, np.integer)):
        raise Fem2TmmError(f"labels must be ({cells.shape[0]},) integers (one cluster id per element)")
    labels = labels.astype(np.int64, copy=False)
    valid = cells >= 0
    rows = np.flatnonzero(np.any(cells >= n_dof, axis=1))
    if rows.size:
        raise Fem2TmmError(f"element rows {format_ids(rows)} refer to DOFs >= n_dof = {n_dof}")
    rows = np.flatnonzero(np.any(valid & (~np.isfinite(shares) | (shares < 0)), axis=1))
    if rows.size:
        raise Fem2TmmError(f"element rows {format_ids(rows)} have negative or non-finite capacity/volume shares; "
                           "check density, specific heat and thickness of these elements")
    if labels.size and labels.min() < 0:
        raise Fem2TmmError(f"element rows {format_ids(np.flatnonzero(labels < 0))} have a negative cluster label")
    if n_clusters is None:
        n_clusters = int(labels.max()) + 1 if labels.size else 0
    if labels.size and labels.max() >= n_clusters:
        raise Fem2TmmError(f"cluster labels go up to {labels.max()} but n_clusters = {n_clusters}")
    empty = np.flatnonzero(np.bincount(labels, minlength=n_clusters) == 0)
    if empty.size:
        raise Fem2TmmError(f"clusters {format_ids(empty)} have no element; labels must be 0..n_clusters-1 "
                           "with every cluster used (renumber the labels)")
    return cells, np.where(valid, shares, 0.0), labels, valid, n_clusters


def _describe_rows(rows, kind, cluster, dof) -> str:
    cl = cluster[rows][cluster[rows] >= 0]
    parts = []
    if cl.size:
        parts.append(f"clusters {format_ids(cl)}")
    for k in ("boundary", "kept"):
        d = dof[rows][kind[rows] == k]
        if d.size:
            parts.append(f"{k} DOFs {format_ids(d)}")
    return " and ".join(parts)


def build_supernodes(n_dof: int, cells: np.ndarray, shares: np.ndarray, labels: np.ndarray,
                     boundary=(), kept=(), n_clusters: int | None = None) -> SuperNodes:
    """Super nodes of a clustered model.

    Parameters
    ----------
    n_dof : number of DOFs (after fixed-temperature groups were merged into one DOF each).
    cells : (m, k) int DOF indices of each model element, padded with −1 (k ≤ 8).
    shares : (m, k) float capacitance (J/K), or volume (m³) in steady state, that each element gives each of its
        nodes; padded entries are ignored.
    labels : (m,) int cluster id of each element, 0 … n_clusters−1, every cluster used.
    boundary : DOF indices of fixed-temperature (isothermal, merged) nodes; each becomes a one-node super node.
    kept : DOF indices the user keeps; each becomes a one-node super node.
    n_clusters : number of clusters (default ``labels.max() + 1``).

    Returns
    -------
    SuperNodes with A (n_SN, n_dof), n_SN = n_clusters + len(boundary) + len(kept).

    Raises Fem2TmmError for inconsistent input, DOFs used by no element (and not kept), and super nodes that
    are linearly dependent or do not fix the mean temperature of every connected part.
    """
    n_dof = int(n_dof)
    cells, shares, labels, valid, nc = _check_inputs(n_dof, cells, shares, labels, n_clusters)
    boundary = _as_dofs(boundary, "boundary", n_dof)
    kept = _as_dofs(kept, "kept", n_dof)
    both = np.intersect1d(boundary, kept)
    if both.size:
        raise Fem2TmmError(f"DOFs {format_ids(both)} are both fixed-temperature (boundary) and kept; "
                           "a fixed-temperature node is already a super node of its own: drop them from kept")
    one = np.concatenate([boundary, kept])
    n_one = one.size
    n_sn = nc + n_one

    totals = cluster_capacitance(shares, labels, nc)
    zero = np.flatnonzero(~(totals > 0))
    if zero.size:
        raise Fem2TmmError(f"clusters {format_ids(zero)} have zero total capacitance/volume, so their mean "
                           "temperature is undefined; check thickness, density and specific heat of their elements")

    k = cells.shape[1]
    mask = valid.ravel()
    r = np.repeat(labels, k)[mask]
    c = cells.ravel()[mask]
    v = (shares / totals[labels][:, None]).ravel()[mask]
    A = sp.csr_matrix((np.concatenate([v, np.ones(n_one)]),
                       (np.concatenate([r, nc + np.arange(n_one)]), np.concatenate([c, one]))),
                      shape=(n_sn, n_dof))
    A.sum_duplicates()

    kind = np.array(["cluster"] * nc + ["boundary"] * boundary.size + ["kept"] * kept.size, dtype=object)
    cluster = np.concatenate([np.arange(nc), np.full(n_one, -1)]).astype(np.int64)
    dof = np.concatenate([np.full(nc, -1), one]).astype(np.int64)
    capacity = np.concatenate([totals, np.zeros(n_one)])

    # distinct (node, cluster) pairs: which nodes several clusters touch
    key = unique(c * nc + r)
    pair_node, pair_cluster = key // nc, key % nc
    n_touch = np.bincount(pair_node, minlength=n_dof)
    is_one = np.zeros(n_dof, bool)
    is_one[one] = True
    interface = (n_touch > 1) | is_one

    orphan = np.flatnonzero((n_touch == 0) & ~is_one)
    if orphan.size:
        raise Fem2TmmError(f"DOFs {format_ids(orphan)} belong to no element of the thermal model and are not kept; "
                           "their temperature is undefined: remove them from the DOF numbering or keep them")

    sn = SuperNodes(A=A, kind=kind, cluster=cluster, dof=dof, capacity=capacity, interface=interface)
    _check_independent(sn, pair_node, pair_cluster, is_one)
    _check_parts_fixed(sn, cells, valid)
    return sn


def _check_independent(sn: SuperNodes, pair_node, pair_cluster, is_one) -> None:
    """Raise if rows of A are linearly dependent.

    A cluster with an interior node (a node no other row touches) is independent of all other rows, so only
    clusters made of interface nodes (one-element clusters, clusters covered by kept nodes, duplicated
    clusters) and the one-node rows among their nodes go to the numerical test.
    """
    nc = sn.n_clusters
    has_interior = np.zeros(nc, bool)
    has_interior[pair_cluster[~sn.interface[pair_node]]] = True
    suspects = np.flatnonzero(~has_interior)
    if not suspects.size:
        return
    own = np.zeros(nc, bool)  # has a node that is not a one-node super node
    own[pair_cluster[~is_one[pair_node]]] = True
    covered = suspects[~own[suspects]]
    if covered.size:
        raise Fem2TmmError(
            f"clusters {format_ids(covered)} have only kept/boundary DOFs as nodes, so their mean temperature is "
            "fixed by those one-node super nodes (linearly dependent super nodes): merge each such cluster into a "
            "neighbouring one, or stop keeping its nodes")
    in_suspect = np.isin(pair_cluster, suspects)
    sn_of_dof = np.full(sn.n_dof, -1)
    sn_of_dof[sn.dof[sn.one_node]] = sn.one_node
    nodes = unique(pair_node[in_suspect])
    extra = sn_of_dof[nodes]
    rows = np.concatenate([suspects, extra[extra >= 0]])
    for group in _dependent_rows(sn.A[rows]):
        g = rows[group]
        raise Fem2TmmError(
            f"super nodes are linearly dependent: {_describe_rows(g, sn.kind, sn.cluster, sn.dof)} "
            "have no node of their own and their mean-temperature definitions repeat each other (for example two "
            "clusters over the same nodes, or a one-element cluster whose nodes are all shared): merge such "
            "clusters with a neighbour or stop keeping the nodes involved")


def _check_parts_fixed(sn: SuperNodes, cells: np.ndarray, valid: np.ndarray) -> None:
    """Raise unless the super nodes fix the mean temperature of every connected part.

    With B = A·P (P the node → connected-part indicator), M is singular iff B has dependent columns: a
    temperature constant on each part, zero on average for every super node, would be free.  A part with a
    super node lying entirely inside it is fixed; only the other parts go to the numerical test.
    """
    m, k = cells.shape
    n = sn.n_dof
    first = np.repeat(cells[:, 0], k)[valid.ravel()]
    other = cells.ravel()[valid.ravel()]
    graph = sp.csr_matrix((np.ones(first.size, np.int8), (first, other)), shape=(n, n))
    n_parts, part = connected_components(graph, directed=False)
    A = sn.A.tocoo()
    B = sp.csr_matrix((A.data, (A.row, part[A.col])), shape=(sn.n_sn, n_parts))
    B.sum_duplicates()
    B.eliminate_zeros()
    pure = np.diff(B.indptr) == 1
    fixed = np.zeros(n_parts, bool)
    fixed[B.indices[np.repeat(pure, np.diff(B.indptr))]] = True
    loose = np.flatnonzero(~fixed)
    if not loose.size:
        return
    sub = B[:, loose].tocsc()
    groups = _dependent_rows(sub.T.tocsr())
    if groups:
        parts = loose[groups[0]]
        rows = unique(sub[:, groups[0]].tocoo().row)
        sample = [int(np.flatnonzero(part == p)[0]) for p in parts[:10]]
        raise Fem2TmmError(
            f"the super nodes do not fix the mean temperature of each connected part: "
            f"{_describe_rows(rows, sn.kind, sn.cluster, sn.dof) or 'no super node'} span disconnected parts "
            f"(parts containing DOFs {format_ids(sample)}) that no other super node separates; split such clusters "
            "so that each lies within one connected part, or connect the parts")


def super_node_positions(supernodes: SuperNodes, element_cluster: np.ndarray, element_cells: np.ndarray,
                         shares: np.ndarray, node_dof: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Position of each super node: a cluster's centroid weighted by its elements' nodal capacitance shares (the
    capacitance-weighted centroid), a one-node super node's (fixed-temperature group, kept node) the centroid of
    the mesh nodes merged into its DOF.

    Parameters
    ----------
    supernodes : SuperNodes
        ``cluster`` and ``dof`` of each super node (n_SN,).
    element_cluster : (m,) int
        Cluster of each model element, -1 for none.
    element_cells : (m, k) int
        Mesh node indices of each model element, padded with -1.
    shares : (m, k) float
        Capacitance (J/K) or volume (m³) each element gives each of its nodes.
    node_dof : (n_nodes,) int
        DOF of each mesh node, -1 outside the model.
    points : (n_nodes, 3) float
        Mesh node coordinates, m.

    Returns
    -------
    (n_SN, 3) float
        Positions in m (NaN for a super node without weight).
    """
    out = np.full((supernodes.n_sn, 3), np.nan)
    ok = (element_cells >= 0) & (np.asarray(element_cluster)[:, None] >= 0)
    cl = np.broadcast_to(np.asarray(element_cluster)[:, None], element_cells.shape)[ok]
    w = np.asarray(shares, float)[ok]
    xyz = np.asarray(points, float)[element_cells[ok]]
    n_cl = int(max(cl.max(initial=-1), supernodes.cluster.max(initial=-1))) + 1
    total = np.bincount(cl, weights=w, minlength=n_cl).astype(float)  # (an empty bincount is int)
    centroid = np.stack([np.bincount(cl, weights=w * xyz[:, i], minlength=n_cl) for i in range(3)],
                        axis=1).astype(float)
    centroid /= np.where(total > 0, total, np.nan)[:, None]
    rows = np.flatnonzero(supernodes.cluster >= 0)
    out[rows] = centroid[supernodes.cluster[rows]]
    one = np.flatnonzero(supernodes.dof >= 0)
    if len(one):
        has = node_dof >= 0
        dof = node_dof[has]
        count = np.bincount(dof, minlength=supernodes.n_dof).astype(float)
        mean = np.stack([np.bincount(dof, weights=points[has, i], minlength=supernodes.n_dof) for i in range(3)],
                        axis=1).astype(float) / np.where(count > 0, count, np.nan)[:, None]
        out[one] = mean[supernodes.dof[one]]
    return out


__all__ = ["SuperNodes", "build_supernodes", "super_node_positions"]
