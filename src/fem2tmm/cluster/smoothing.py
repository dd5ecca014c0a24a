"""Boundary smoothing by a binary min-cut per pair of neighbouring clusters (thesis §4.2.3, eq. 4.1, Fig. 4.6).

For a pair of clusters A, B that touch, the *band* is the elements of A and of B within ``layers`` steps of
their common boundary (layer 1: the elements on the boundary; default two layers each side, as in the
thesis).  Each band element i gets a binary label and pays

* a data term ``d_A/(d_A + d_B)`` if it is in A and ``d_B/(d_A + d_B)`` if it is in B, with d the distance
  from its centroid to the weighted centroid of the cluster (computed once, before smoothing);
* for every neighbour j with a different label, ``l_ij/(l_ij + l̄)`` with ``l_ij`` the length of the shared
  edge (solids: area of the shared face) and ``l̄`` the mean over the current A–B boundary.  Neighbours
  outside the band keep their label, so their terms become terminal capacities; neighbours in third
  clusters add a constant and are ignored.

The seed elements are tied to their cluster with an infinite capacity.  The minimum of eq. 4.1 is a
minimum s–t cut (Greig et al.); it is computed with ``scipy.sparse.csgraph.maximum_flow`` (integer
capacities: real costs scaled so that their sum stays below 2³⁰ and rounded; at most 10⁶ per unit cost)
and the A side is the set of nodes reachable from the source in the residual graph.

A new assignment is kept only if (1) both clusters stay connected and (2) the total boundary length
(area) does not grow; otherwise the pair keeps its old assignment.  Hence smoothing never lengthens the
boundary and never breaks contiguity.  Pairs are visited in increasing (A, B) order, each seeing the
labels left by the previous ones.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, maximum_flow

from .adjacency import gather_rows, is_connected

_CAP_TOTAL = 2**30  # finite capacities sum to at most this, so no int32 overflow in the flow
_INF = 2**30 + 2**29


def boundary_length(indptr: np.ndarray, indices: np.ndarray, lengths: np.ndarray, labels: np.ndarray) -> float:
    """Total length (area) of the edges (faces) between elements of different clusters, each counted once."""
    rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    cut = (rows < indices) & (labels[rows] != labels[indices])
    return float(lengths[cut].sum())


def _expand(indptr, indices, labels, start: np.ndarray, cluster: int, layers: int) -> np.ndarray:
    """Elements of ``cluster`` within ``layers - 1`` steps of ``start`` (inside the cluster)."""
    band = start
    front = start
    for _ in range(layers - 1):
        pos, _ = gather_rows(indptr, front)
        nb = np.unique(indices[pos])
        nb = nb[labels[nb] == cluster]
        front = np.setdiff1d(nb, band, assume_unique=True)
        if len(front) == 0:
            break
        band = np.union1d(band, front)
    return band


def pair_cut(indptr, indices, lengths, labels, band, n_in_A: int, A: int, B: int, centroids, centre_A,
             centre_B, is_seed, lbar: float, scale: float = 1e6, scratch: np.ndarray | None = None):
    """Minimise eq. 4.1 over the band of the pair (A, B) by a minimum s–t cut.

    ``band`` (nb,) elements, the first ``n_in_A`` currently in A and the others in B; elements outside the
    band keep ``labels``.  ``centre_A``, ``centre_B`` (d,) cluster centres, ``is_seed`` (n,) bool,
    ``lbar`` the mean boundary edge length.  ``scratch``: (n,) int64 of -1 (restored on return).

    Returns ``(new_A, (pos, own, j, jl, inside))``: ``new_A`` (nb,) bool, True for the band elements the cut
    puts in A, and the gathered band adjacency (CSR positions, owning band index, neighbour, neighbour's
    band index or -1, neighbour in the band) for the caller's bookkeeping.
    """
    nband = len(band)
    if scratch is None:
        scratch = np.full(len(labels), -1, np.int64)
    old_A = np.arange(nband) < n_in_A
    src, snk = nband, nband + 1
    # data term
    dA = np.linalg.norm(centroids[band] - centre_A, axis=1)
    dB = np.linalg.norm(centroids[band] - centre_B, axis=1)
    dsum = dA + dB
    cost_A = np.divide(dA, dsum, out=np.full(nband, 0.5), where=dsum > 0)  # paid if the element is in A
    cost_B = 1.0 - cost_A
    # smoothness term
    scratch[band] = np.arange(nband)
    pos, own = gather_rows(indptr, band)
    j = indices[pos]
    lj = lengths[pos]
    wgt = lj / (lj + lbar)
    jl = scratch[j]
    inside = jl >= 0
    outA = ~inside & (labels[j] == A)  # fixed neighbours in A: cutting costs wgt if the element goes to B
    outB = ~inside & (labels[j] == B)
    to_src = cost_B + np.bincount(own[outA], wgt[outA], minlength=nband)
    to_snk = cost_A + np.bincount(own[outB], wgt[outB], minlength=nband)
    total = to_src.sum() + to_snk.sum() + wgt[inside].sum()
    f = min(scale, _CAP_TOTAL / max(total, 1e-300))
    cap_src = np.rint(to_src * f).astype(np.int64)
    cap_snk = np.rint(to_snk * f).astype(np.int64)
    seeded = is_seed[band]
    cap_src[seeded & old_A] = _INF
    cap_snk[seeded & ~old_A] = _INF
    r = np.concatenate([own[inside], np.full(nband, src), np.arange(nband)])
    c = np.concatenate([jl[inside], np.arange(nband), np.full(nband, snk)])
    v = np.concatenate([np.rint(wgt[inside] * f).astype(np.int64), cap_src, cap_snk])
    G = sp.csr_matrix((v.astype(np.int32), (r, c)), shape=(nband + 2, nband + 2))
    G.eliminate_zeros()
    flow = maximum_flow(G, src, snk).flow
    R = (G - flow).tocsr()
    R.data[R.data < 0] = 0
    R.eliminate_zeros()
    reached = breadth_first_order(R, src, directed=True, return_predecessors=False)
    new_A = np.zeros(nband, bool)
    new_A[reached[reached < nband]] = True
    scratch[band] = -1
    return new_A, (pos, own, j, jl, inside)


def smooth(indptr: np.ndarray, indices: np.ndarray, lengths: np.ndarray, labels: np.ndarray,
           centroids: np.ndarray, weights: np.ndarray, seeds: np.ndarray, layers: int = 2,
           scale: float = 1e6, balance_tol: float | None = None) -> tuple[np.ndarray, dict]:
    """Smooth the boundaries between the clusters of one connected region.

    Parameters
    ----------
    indptr, indices, lengths : CSR dual graph of the region (n elements), ``lengths`` (nnz,) shared edge
        length (m) or face area (m²) of each link
    labels : (n,) int cluster of each element, 0..k-1, every cluster contiguous
    centroids : (n, d) element centroids (m), d = 3, or 4 with a feature coordinate (see :mod:`.driver`)
    weights : (n,) element weights (area/volume) for the cluster centres
    seeds : (k,) seed element of each cluster (never moved)
    layers : band depth on each side of a boundary (>= 1)
    scale : integer units per unit cost in the max-flow (reduced if the capacities would overflow)
    balance_tol : None, or a relative tolerance: a pair's new assignment is also rejected when it takes
        either cluster's weight further than ``balance_tol`` from the mean *and* further than it was (so
        smoothing does not undo :func:`.growing.grow_balanced`)

    Returns
    -------
    labels : (n,) int64 new labels (a copy)
    stats : dict with ``boundary_before``, ``boundary_after`` (m or m²), ``pairs``, ``accepted``,
        ``rejected_longer``, ``rejected_disconnected``, ``rejected_unbalanced``, ``moved`` (elements that
        changed cluster)
    """
    lab = np.array(labels, dtype=np.int64)
    n = len(lab)
    k = int(lab.max()) + 1 if n else 0
    before = boundary_length(indptr, indices, lengths, lab)
    stats = {"boundary_before": before, "boundary_after": before, "pairs": 0, "accepted": 0,
             "rejected_longer": 0, "rejected_disconnected": 0, "rejected_unbalanced": 0, "moved": 0}
    if k < 2 or layers < 1:
        return lab, stats
    W = np.bincount(lab, weights, minlength=k)
    centre = np.stack([np.bincount(lab, weights * centroids[:, j], minlength=k) for j in range(centroids.shape[1])], 1) / W[:, None]
    rows = np.repeat(np.arange(n), np.diff(indptr))
    cut = (rows < indices) & (lab[rows] != lab[indices])
    la, lb = lab[rows[cut]], lab[indices[cut]]
    pair_keys = np.unique(np.minimum(la, lb) * k + np.maximum(la, lb))
    stats["pairs"] = len(pair_keys)
    order = np.argsort(lab, kind="stable")
    members = np.split(order, np.cumsum(np.bincount(lab, minlength=k))[:-1])
    is_seed = np.zeros(n, bool)
    is_seed[seeds] = True
    scratch = np.full(n, -1, np.int64)  # reusable maps, reset after each use (cost O(band), not O(n))
    in_band = np.zeros(n, bool)

    for key in pair_keys.tolist():
        A, B = divmod(key, k)
        mA = members[A]
        pos, own = gather_rows(indptr, mA)
        nb = indices[pos]
        on = lab[nb] == B
        if not on.any():
            continue  # no longer neighbours after an earlier pair moved
        lbar = float(lengths[pos[on]].mean())
        bandA = _expand(indptr, indices, lab, np.unique(mA[own[on]]), A, layers)
        bandB = _expand(indptr, indices, lab, np.unique(nb[on]), B, layers)
        band = np.concatenate([bandA, bandB])
        nband = len(band)
        new_A, (pos, own, j, jl, inside) = pair_cut(indptr, indices, lengths, lab, band, len(bandA), A, B,
                                                    centroids, centre[A], centre[B], is_seed, lbar, scale, scratch)
        old_A = np.arange(nband) < len(bandA)

        # boundary length of the edges touching the band, before and after (inner edges seen twice)
        new_lab_band = np.where(new_A, A, B)
        lab_j_new = np.where(inside, new_lab_band[np.maximum(jl, 0)], lab[j])
        half = np.where(inside, 0.5, 1.0) * lengths[pos]
        len_old = float(half[lab[band][own] != lab[j]].sum())
        len_new = float(half[new_lab_band[own] != lab_j_new].sum())
        if (new_A == old_A).all():
            continue
        if len_new > len_old * (1 + 1e-12):
            stats["rejected_longer"] += 1
            continue
        if balance_tol is not None:
            mean = W.sum() / k
            gain = float(np.dot(weights[band], new_A.astype(float) - old_A))  # weight A gains from B
            dev_old = max(abs(W[A] - mean), abs(W[B] - mean))
            dev_new = max(abs(W[A] + gain - mean), abs(W[B] - gain - mean))
            if dev_new > max(balance_tol * mean, dev_old):
                stats["rejected_unbalanced"] += 1
                continue
        in_band[band] = True
        mB = members[B]
        newA = np.concatenate([mA[~in_band[mA]], band[new_A]])
        newB = np.concatenate([mB[~in_band[mB]], band[~new_A]])
        in_band[band] = False
        if not (is_connected(indptr, indices, newA, scratch) and is_connected(indptr, indices, newB, scratch)):
            stats["rejected_disconnected"] += 1
            continue
        lab[band] = new_lab_band
        members[A], members[B] = np.sort(newA), np.sort(newB)
        W[A], W[B] = weights[members[A]].sum(), weights[members[B]].sum()
        stats["accepted"] += 1
        stats["moved"] += int((new_A != old_A).sum())
    stats["boundary_after"] = boundary_length(indptr, indices, lengths, lab)
    return lab, stats
