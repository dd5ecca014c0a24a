"""Capacitance of the super nodes (thesis §4.3.1, TMRT "equivalent capacitance").

Two conserving choices are offered:

* :func:`cluster_capacitance` — each cluster gets the capacitance its own elements give their nodes (the
  denominator of its row of A, so it is consistent with the super-node definition when A was built from the
  same shares).  One-node super nodes (kept / boundary DOFs) get what the elements *without a cluster* give them:
  an element whose every node is a one-node super node (all its nodes joint ends, kept or held: no unknown inside,
  no cluster) gives each of its nodes that is not held its share; the clustered elements' shares at a one-node
  super node are already in their cluster's.  The sum over super nodes is the model's total capacitance less what
  such elements give held nodes.
* :func:`equivalent_capacitance` — TMRT's equivalent capacitance matrix ``Y C Yᵀ`` made diagonal by summing
  each row onto the diagonal: ``C_eq = Y C Yᵀ 1 = Y c`` because ``Yᵀ 1 = 1`` (a uniform super-node
  temperature recovers a uniform field: ``M [1; 0] = [K 1; A 1] = [0; 1]`` since K has zero row sums and A
  rows sum to 1).  Hence ``Σ C_eq = 1ᵀ Y c = (Yᵀ1)ᵀ c = Σ c`` exactly.  Capacitance "conductively close" to a
  kept node is given to it; entries may be slightly negative for badly shaped super nodes.

When A was built from the same capacitance shares the two coincide: the nodal capacitance is then
``c = Aᵀ C_SN`` (each element share is counted once, in its own cluster's row) and ``Y Aᵀ = I`` gives
``C_eq = C_SN``, with 0 for kept nodes.  They differ when A uses other weights (volumes with a varying ρ·c,
areas for surface super nodes).

Units: shares and capacitances in J/K (or m³ when volumes are used as weights in steady state).
"""

from __future__ import annotations

import numpy as np

from ..errors import Fem2TmmError, format_ids


def cluster_capacitance(shares: np.ndarray, labels: np.ndarray, n_clusters: int | None = None) -> np.ndarray:
    """Total of the element-to-node shares of each cluster.

    ``shares`` (m, k) J/K (or m³) that each element gives each of its nodes (padded entries 0);
    ``labels`` (m,) cluster id of each element.  Returns (n_clusters,) J/K.
    """
    shares = np.asarray(shares, float)
    labels = np.asarray(labels, np.int64)
    if n_clusters is None:
        n_clusters = int(labels.max()) + 1 if labels.size else 0
    return np.bincount(labels, weights=shares.sum(axis=1), minlength=n_clusters)


def supernode_capacitance(supernodes, shares: np.ndarray, labels: np.ndarray,
                          unclustered: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Capacitance of each super node (n_SN,) J/K: cluster sums, and for one-node super nodes the shares of the
    elements without a cluster.

    Parameters
    ----------
    supernodes : :class:`~fem2tmm.reduce.supernodes.SuperNodes`
    shares : (m, k) J/K per clustered element and node (e.g. ρ·c·volume shares, even when A was built from volumes)
    labels : (m,) int, the cluster of each of those elements, as for A
    unclustered : ``(rows (u, k) int, shares (u, k) J/K)``, optional
        The elements in no cluster because every node of theirs is a one-node super node: the super-node row of
        each of their nodes (-1: nothing, a padded slot or a held node whose temperature is given) and its share,
        which goes to that row.  Without them a part whose every node is a joint end (a small panel stitched at
        every corner) had no capacitance at all, and a transient of it no solution.

    Σ result = Σ shares (+ Σ of the unclustered shares) exactly: each element belongs to one cluster or gives its
    shares to its own nodes.
    """
    per_cluster = cluster_capacitance(shares, labels, supernodes.n_clusters)
    out = np.zeros(supernodes.n_sn)
    is_cluster = supernodes.cluster >= 0
    out[is_cluster] = per_cluster[supernodes.cluster[is_cluster]]
    if unclustered is not None:
        rows, sh = np.asarray(unclustered[0], np.int64), np.asarray(unclustered[1], float)
        out += np.bincount(rows[rows >= 0], weights=sh[rows >= 0], minlength=supernodes.n_sn)
    return out


def equivalent_capacitance(reduction, nodal_capacity: np.ndarray) -> np.ndarray:
    """TMRT equivalent capacitance, made diagonal by row sums: ``C_eq = Y C Yᵀ 1 = Y c`` (n_SN,) J/K.

    ``reduction`` a :class:`~fem2tmm.reduce.conduction.ConductiveReduction` (its ``distribute`` applies Y
    locally); ``nodal_capacity`` (n_dof,) lumped capacitance c of each DOF in J/K (for example
    ``fem2tmm.fem.assembly.scatter_shares``).  Conserves the total: ``Σ C_eq = Σ c`` (see module docstring).
    """
    c = np.asarray(nodal_capacity, float)
    if c.shape != (reduction.n_dof,):
        raise Fem2TmmError(f"nodal capacity has shape {c.shape}; expected ({reduction.n_dof},) (one value per DOF)")
    bad = np.flatnonzero(~np.isfinite(c) | (c < 0))
    if bad.size:
        raise Fem2TmmError(f"nodal capacity is negative or not finite at DOFs {format_ids(bad)}; check density and "
                           "specific heat of the elements around them")
    return reduction.distribute(c)


__all__ = ["cluster_capacitance", "supernode_capacitance", "equivalent_capacitance"]
