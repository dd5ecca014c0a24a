"""Clusters across element kinds and parts: contact through shared nodes (issue 33).

A structural deck puts bars on the nodes of the panels they stiffen, shells on the faces of solids and fittings on
the nodes of a panel.  Such elements cannot carry a super node of their own, or not always:

* a bar every node of which is also a node of a shell or a solid (a stiffener along a panel edge or across a
  panel), or a one-node super node (a fixed-temperature or kept node), is *embedded*: a cluster made of such bars
  has no node of its own, and its mean-temperature row nearly repeats those of the clusters around it.  Embedded
  bars are not clustered with their own part; each joins the cluster holding most of its nodes
  (:func:`join_units`), so a stiffener is reduced with the panel it stiffens.  (A shell skin on a solid's faces
  keeps clusters of its own: its rows stay independent, and its radiating faces keep their part's count);
* a part made of more disconnected pieces than the super nodes it asks for (eighteen single-hex fittings in a
  part given four) keeps its largest pieces and the others join the cluster they touch through the most shared
  nodes, whatever its part and kind; a piece touching nothing joins its part's nearest cluster only if a held or
  kept node fixes its own mean, and is refused otherwise (:func:`join_units`);
* what is left (rare: two parts' clusters over the same nodes, a one-element cluster whose nodes are all shared)
  is found on the exact super-node rows and merged into its best-connected neighbour (:func:`join_dependent`), so
  that "linearly dependent super nodes" never reaches the user.

Contact is counted on the thermal unknowns (``dofs``): nodes merged by an isothermal joint are one contact.
Everything is sparse and vectorised; indices are *rows*: the parts' elements concatenated in part order.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..arrays import unique
from ..linalg import dependent_rows
from ..mesh.elements import ELEMENT_TYPES, LINE_TYPES, SHELL_TYPES

#: rank of each element kind: an element lying on the nodes of higher-ranked elements is embedded in them
RANK = {"line": 1, "shell": 2, "solid": 3}
_RANK_OF_TYPE = np.array([1 if t in LINE_TYPES else 2 if t in SHELL_TYPES else 3 for t in ELEMENT_TYPES], np.int8)
#: a unit is drawn to a cluster of its own part over one of another part sharing as many nodes
SAME_PART_BONUS = 0.25


def element_rank(types: np.ndarray) -> np.ndarray:
    """(m,) int8 rank (1 line, 2 shell, 3 solid) of elements given by their type codes (:data:`TYPE_CODE`)."""
    return _RANK_OF_TYPE[np.asarray(types, np.int64)]


def kind_of_rank(rank: int) -> str:
    """"line", "shell" or "solid" for a rank of :data:`RANK`."""
    return {v: k for k, v in RANK.items()}[int(rank)]


def embedded(dofs: np.ndarray, rank: np.ndarray, n: int, one_node: np.ndarray | None = None) -> np.ndarray:
    """(m,) bool: bars (rank 1) every node of which is a one-node super node or a node of a shell or solid.

    Parameters
    ----------
    dofs : (m, k) int unknown of each element node, -1 padded (mesh node indices when nodes are the unknowns)
    rank : (m,) int rank of each element (:func:`element_rank`)
    n : size of the unknowns' index space
    one_node : (n,) bool unknowns that are one-node super nodes (fixed temperature, kept), or None
    """
    valid = dofs >= 0
    above = np.zeros((4, n), bool)  # above[r, d]: d is a node of an element of rank > r, or a one-node super node
    for r in (3, 2):
        d = dofs[rank == r]
        above[r - 1, d[d >= 0]] = True
    above[1] |= above[2]
    if one_node is not None:
        above |= np.asarray(one_node, bool)[None, :]
    lookup = above[np.clip(rank, 0, 3)[:, None], np.maximum(dofs, 0)]
    return np.where(valid, lookup, True).all(axis=1) & (rank == 1)


def _incidence(rows: np.ndarray, dofs: np.ndarray, group: np.ndarray, n_groups: int, n: int) -> sp.csr_matrix:
    """(n_groups, n) count of the nodes of ``rows`` per group."""
    d = dofs[rows]
    ok = d >= 0
    g = np.broadcast_to(group[:, None], d.shape)[ok]
    return sp.csr_matrix((np.ones(int(ok.sum())), (g, d[ok])), shape=(n_groups, n))


def join_units(labels: np.ndarray, unit: np.ndarray, unit_part: np.ndarray, cluster_part: np.ndarray,
               dofs: np.ndarray, centroid: np.ndarray, n: int, one_node: np.ndarray | None = None
               ) -> tuple[np.ndarray, dict]:
    """Give every element of a unit (an embedded element, a piece its part had no super node for) a cluster.

    A unit joins, as a whole, the cluster sharing the most nodes with it (a cluster of the unit's own part wins a
    tie, :data:`SAME_PART_BONUS`); units that touch no labelled element wait for their neighbours to be labelled
    (rounds); units touching nothing labelled at all join their part's nearest cluster by centroid (any part's when
    their part has none) if they hold a one-node super node (a joint's kept end, a held node) that fixes their own
    mean temperature; the others are returned unlabelled (``stats["unanchored"]``): sharing a super node with a
    piece they do not touch would leave their mean temperature free (a singular reduction).

    Parameters
    ----------
    labels : (R,) int cluster of each row, -1 for rows of units
    unit : (R,) int unit of each row (0 … U−1), -1 for clustered rows
    unit_part : (U,) int part of each unit
    cluster_part : (K,) int part of each cluster
    dofs : (R, k) int unknowns of each row's nodes, -1 padded
    centroid : (R, 3) float element centroids, m
    n : size of the unknowns' index space
    one_node : (n,) bool unknowns that are one-node super nodes, or None

    Returns
    -------
    labels : (R,) int, every row labelled but those of unanchored units
    stats : ``{"by_contact": units, "by_distance": units, "rounds": int, "into_other_part": units,
        "unanchored": [unit ids]}``
    """
    labels = np.asarray(labels, np.int64).copy()
    unit = np.asarray(unit, np.int64)
    n_units = int(unit.max()) + 1 if unit.size and unit.max() >= 0 else 0
    k = len(cluster_part)
    stats = {"by_contact": 0, "by_distance": 0, "rounds": 0, "into_other_part": 0, "unanchored": []}
    if n_units == 0:
        return labels, stats
    if k == 0:
        raise ValueError("join_units: no cluster to join")
    target = np.full(n_units, -1, np.int64)
    in_unit = np.flatnonzero(unit >= 0)
    U = _incidence(in_unit, dofs, unit[in_unit], n_units, n)
    fresh = np.flatnonzero(labels >= 0)
    D = sp.csr_matrix((n, k))
    while True:
        if fresh.size:
            d = dofs[fresh]
            ok = d >= 0
            lab = np.broadcast_to(labels[fresh][:, None], d.shape)[ok]
            D = D + sp.csr_matrix((np.ones(lab.size), (d[ok], lab)), shape=(n, k))
        pending = np.flatnonzero(target < 0)
        if not pending.size:
            break
        V = (U[pending] @ D).tocsr()
        V.eliminate_zeros()
        has = np.diff(V.indptr) > 0
        if not has.any():
            break
        stats["rounds"] += 1
        rows_of = np.repeat(np.arange(V.shape[0]), np.diff(V.indptr))
        V.data = V.data + SAME_PART_BONUS * (cluster_part[V.indices] == unit_part[pending][rows_of])
        best = np.asarray(V.argmax(axis=1)).ravel()
        chosen = pending[has]
        target[chosen] = best[has]
        stats["by_contact"] += int(chosen.size)
        stats["into_other_part"] += int(np.count_nonzero(cluster_part[best[has]] != unit_part[chosen]))
        new_rows = in_unit[np.isin(unit[in_unit], chosen)]
        labels[new_rows] = target[unit[new_rows]]
        fresh = new_rows
    left = np.flatnonzero(target < 0)
    if left.size:
        anchored = np.zeros(n_units, bool)
        if one_node is not None:
            d = dofs[in_unit]
            hit = np.where(d >= 0, np.asarray(one_node, bool)[np.maximum(d, 0)], False).any(axis=1)
            anchored[unit[in_unit][hit]] = True
        stats["unanchored"] = left[~anchored[left]].tolist()
        left = left[anchored[left]]
    if left.size:  # no contact with anything clustered: the nearest cluster of the unit's part (or of any part)
        lab = np.flatnonzero(labels >= 0)
        counts = np.bincount(labels[lab], minlength=k)
        cc = np.stack([np.bincount(labels[lab], centroid[lab, i], minlength=k) for i in range(3)], 1)
        cc /= np.maximum(counts, 1)[:, None]
        uc = np.stack([np.bincount(unit[in_unit], centroid[in_unit, i], minlength=n_units) for i in range(3)], 1)
        uc /= np.maximum(np.bincount(unit[in_unit], minlength=n_units), 1)[:, None]
        for p in unique(unit_part[left]):
            mine = left[unit_part[left] == p]
            pool = np.flatnonzero((cluster_part == p) & (counts > 0))
            if not pool.size:
                pool = np.flatnonzero(counts > 0)
            target[mine] = pool[cKDTree(cc[pool]).query(uc[mine])[1]]
        stats["by_distance"] = int(left.size)
        stats["into_other_part"] += int(np.count_nonzero(cluster_part[target[left]] != unit_part[left]))
        rows = in_unit[np.isin(unit[in_unit], left)]
        labels[rows] = target[unit[rows]]
    return labels, stats


def join_dependent(labels: np.ndarray, cluster_part: np.ndarray, dofs: np.ndarray, shares: np.ndarray,
                   one_node: np.ndarray, max_merges: int | None = None) -> tuple[np.ndarray, np.ndarray, list]:
    """Merge clusters whose super-node rows are linearly dependent into their best-connected neighbour.

    The rows are the super nodes' exact definition (:mod:`fem2tmm.reduce.supernodes`): each cluster's element
    shares over its nodes, normalised, plus a unit row per one-node super node.  Only clusters without a node of
    their own can be dependent; among those, each dependent group loses its smallest cluster (by total share),
    merged into the cluster sharing the most nodes with it (its own part first), until the rows are independent.

    Parameters
    ----------
    labels : (R,) int cluster of each element row, 0 … K−1
    cluster_part : (K,) int part of each cluster
    dofs : (R, k) int unknowns of each row's nodes, -1 padded
    shares : (R, k) float capacitance (J/K) or volume (m³) each element gives each of its nodes
    one_node : (n,) bool unknowns that are one-node super nodes (fixed temperature, kept)
    max_merges : stop after that many merges (default K)

    Returns
    -------
    labels : (R,) int renumbered 0 … K'−1
    kept : (K',) int the old id of each remaining cluster
    merges : list of ``(merged old id, into old id)``
    """
    labels = np.asarray(labels, np.int64).copy()
    cluster_part = np.asarray(cluster_part, np.int64)
    one_node = np.asarray(one_node, bool)
    n = len(one_node)
    k = len(cluster_part)
    alive = np.ones(k, bool)
    merges: list[tuple[int, int]] = []
    valid = dofs >= 0
    d_all = dofs[valid]
    w_all = np.where(valid, shares, 0.0)[valid]
    limit = k if max_merges is None else int(max_merges)
    while len(merges) < limit:
        r_all = np.broadcast_to(labels[:, None], dofs.shape)[valid]
        key = unique(r_all * n + d_all)
        pc, pn = key // n, key % n
        touch = np.bincount(pn, minlength=n)
        own = np.zeros(k, bool)
        own[pc[(touch[pn] == 1) & ~one_node[pn]]] = True
        suspects = np.flatnonzero(alive & ~own)
        if not suspects.size:
            break
        totals = np.bincount(r_all, w_all, minlength=k)
        sel = np.isin(r_all, suspects)
        pos = np.full(k, -1, np.int64)
        pos[suspects] = np.arange(suspects.size)
        nodes = unique(d_all[sel])
        extra = nodes[one_node[nodes]]  # the one-node super nodes among the suspects' nodes: unit rows
        S = sp.csr_matrix((np.concatenate([w_all[sel] / totals[r_all[sel]], np.ones(extra.size)]),
                           (np.concatenate([pos[r_all[sel]], suspects.size + np.arange(extra.size)]),
                            np.concatenate([d_all[sel], extra]))), shape=(suspects.size + extra.size, n))
        groups = dependent_rows(S.tocsr())
        groups = [g[g < suspects.size] for g in groups]
        groups = [suspects[g] for g in groups if g.size]
        if not groups:
            break
        before = len(merges)
        for g in groups:
            if len(merges) >= limit:
                break
            g = g[alive[g]]
            if not g.size:
                continue
            victim = int(g[np.argmin(totals[g])])
            # neighbours: clusters sharing nodes with the victim, by shared-node count, own part first
            vn = pn[pc == victim]
            share = np.isin(pn, vn) & (pc != victim) & alive[pc]
            if not share.any():
                continue
            cnt = np.bincount(pc[share], minlength=k).astype(float)
            cnt[cluster_part == cluster_part[victim]] += SAME_PART_BONUS
            cnt[~alive] = -1
            cnt[victim] = -1
            into = int(np.argmax(cnt))
            labels[labels == victim] = into
            alive[victim] = False
            merges.append((victim, into))
        if len(merges) == before:  # dependent but touching no other cluster: left to the reduction's own check
            break
    kept = np.flatnonzero(alive)
    renum = np.full(k, -1, np.int64)
    renum[kept] = np.arange(kept.size)
    return renum[labels], kept, merges


__all__ = ["RANK", "element_rank", "embedded", "join_units", "join_dependent"]
