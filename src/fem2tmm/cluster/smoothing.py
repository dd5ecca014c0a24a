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
minimum s–t cut (Greig et al.) on integer capacities (real costs scaled so that their sum stays below 2³⁰
and rounded; at most 10⁶ per unit cost); the A side is the set of nodes reachable from the source in the
residual graph of a maximum flow (Dinic's algorithm, compiled with numba).  That set, the smallest minimum
cut's source side, is the same for every maximum flow, so the result does not depend on the flow algorithm.

A new assignment is kept only if (1) both clusters stay connected and (2) the total boundary length
(area) does not grow; otherwise the pair keeps its old assignment.  Hence smoothing never lengthens the
boundary and never breaks contiguity.  Pairs are visited in increasing (A, B) order, each seeing the
labels left by the previous ones.  The whole loop over pairs is one compiled kernel (:func:`_smooth`):
the per-pair work is O(band), where building a scipy graph per pair cost ~1.6 ms of overhead each.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..arrays import unique

_CAP_TOTAL = 2**30  # finite capacities sum to at most this (kept from the int32 max-flow; exact in int64)
_INF = 2**30 + 2**29


def boundary_length(indptr: np.ndarray, indices: np.ndarray, lengths: np.ndarray, labels: np.ndarray) -> float:
    """Total length (area) of the edges (faces) between elements of different clusters, each counted once."""
    rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    cut = (rows < indices) & (labels[rows] != labels[indices])
    return float(lengths[cut].sum())


@njit(cache=True, nogil=True)
def _source_side(n_nodes, src, snk, first, nxt, to, cap):
    """Dinic's maximum flow on an arc list (arc a's reverse is a ^ 1, ``cap`` residual capacities, modified);
    returns (n_nodes,) bool, the nodes reachable from ``src`` in the final residual graph."""
    level = np.empty(n_nodes, np.int64)
    queue = np.empty(n_nodes, np.int64)
    it = np.empty(n_nodes, np.int64)
    path = np.empty(n_nodes, np.int64)
    while True:
        level[:] = -1
        level[src] = 0
        queue[0] = src
        qh, qt = 0, 1
        while qh < qt:
            u = queue[qh]
            qh += 1
            a = first[u]
            while a >= 0:
                v = to[a]
                if cap[a] > 0 and level[v] < 0:
                    level[v] = level[u] + 1
                    queue[qt] = v
                    qt += 1
                a = nxt[a]
        if level[snk] < 0:
            reached = np.zeros(n_nodes, np.bool_)
            for i in range(qt):
                reached[queue[i]] = True
            return reached
        it[:] = first
        depth = 0
        u = src
        while True:
            if u == snk:
                f = cap[path[0]]
                for i in range(1, depth):
                    if cap[path[i]] < f:
                        f = cap[path[i]]
                for i in range(depth):
                    cap[path[i]] -= f
                    cap[path[i] ^ 1] += f
                depth = 0
                u = src
                continue
            advanced = False
            while it[u] >= 0:
                a = it[u]
                v = to[a]
                if cap[a] > 0 and level[v] == level[u] + 1:
                    path[depth] = a
                    depth += 1
                    u = v
                    advanced = True
                    break
                it[u] = nxt[a]
            if not advanced:
                if u == src:
                    break
                level[u] = -1  # dead end for this phase
                depth -= 1
                a = path[depth]
                u = to[a ^ 1]
                it[u] = nxt[a]


@njit(cache=True, nogil=True, inline="always")
def _arc_pair(first, nxt, to, cap, m, u, v, c_uv, c_vu):
    """Add arc m: u -> v (capacity c_uv) and its reverse m + 1: v -> u (c_vu); returns m + 2."""
    to[m] = v
    cap[m] = c_uv
    nxt[m] = first[u]
    first[u] = m
    to[m + 1] = u
    cap[m + 1] = c_vu
    nxt[m + 1] = first[v]
    first[v] = m + 1
    return m + 2


@njit(cache=True, nogil=True)
def _cut(indptr, indices, lengths, lab, X, band, nb, nA, A, B, cA, cB, is_seed, lbar, scale, bidx):
    """Minimum of eq. 4.1 over ``band[:nb]`` (the first ``nA`` in A); ``bidx`` (n,) band index of each element
    (-1 outside), set by the caller.  Returns (nb,) bool, True where the cut puts the element in A."""
    d = X.shape[1]
    to_src = np.empty(nb)
    to_snk = np.empty(nb)
    inside_sum = 0.0
    n_in = 0
    for i in range(nb):
        e = band[i]
        sa = 0.0
        sb = 0.0
        for c in range(d):
            sa += (X[e, c] - cA[c]) ** 2
            sb += (X[e, c] - cB[c]) ** 2
        dA = np.sqrt(sa)
        dB = np.sqrt(sb)
        cost_A = dA / (dA + dB) if dA + dB > 0 else 0.5
        to_src[i] = 1.0 - cost_A
        to_snk[i] = cost_A
        for q in range(indptr[e], indptr[e + 1]):
            j = indices[q]
            wq = lengths[q] / (lengths[q] + lbar)
            if bidx[j] >= 0:
                inside_sum += wq
                n_in += 1
            elif lab[j] == A:
                to_src[i] += wq
            elif lab[j] == B:
                to_snk[i] += wq
    total = to_src.sum() + to_snk.sum() + inside_sum
    f = min(scale, _CAP_TOTAL / max(total, 1e-300))
    n_nodes = nb + 2
    src, snk = nb, nb + 1
    n_arcs = n_in + 4 * nb
    first = np.full(n_nodes, -1, np.int64)
    nxt = np.empty(n_arcs, np.int64)
    to = np.empty(n_arcs, np.int64)
    cap = np.empty(n_arcs, np.int64)
    m = 0
    for i in range(nb):
        e = band[i]
        cs = np.int64(np.rint(to_src[i] * f))
        ct = np.int64(np.rint(to_snk[i] * f))
        if is_seed[e]:
            if i < nA:
                cs = _INF
            else:
                ct = _INF
        # src -> i (reverse i -> src, 0), i -> snk (reverse snk -> i, 0)
        m = _arc_pair(first, nxt, to, cap, m, src, i, cs, 0)
        m = _arc_pair(first, nxt, to, cap, m, i, snk, ct, 0)
        for q in range(indptr[e], indptr[e + 1]):
            jl = bidx[indices[q]]
            if jl > i:  # an undirected edge: two arcs of equal capacity, each the other's reverse
                c = np.int64(np.rint(lengths[q] / (lengths[q] + lbar) * f))
                m = _arc_pair(first, nxt, to, cap, m, i, jl, c, c)
    reached = _source_side(n_nodes, src, snk, first, nxt, to, cap)
    return reached[:nb].copy()


def pair_cut(indptr, indices, lengths, labels, band, n_in_A: int, A: int, B: int, centroids, centre_A,
             centre_B, is_seed, lbar: float, scale: float = 1e6) -> np.ndarray:
    """Minimise eq. 4.1 over the band of the pair (A, B) by a minimum s–t cut.

    ``band`` (nb,) elements, the first ``n_in_A`` currently in A and the others in B; elements outside the
    band keep ``labels``.  ``centre_A``, ``centre_B`` (d,) cluster centres (m), ``is_seed`` (n,) bool,
    ``lbar`` the mean boundary edge length (m).

    Returns ``new_A`` (nb,) bool, True for the band elements the cut puts in A.
    """
    band = np.asarray(band, np.int64)
    bidx = np.full(len(labels), -1, np.int64)
    bidx[band] = np.arange(len(band))
    return _cut(np.asarray(indptr, np.int64), np.asarray(indices, np.int64), np.asarray(lengths, float),
                np.asarray(labels, np.int64), np.ascontiguousarray(centroids, dtype=float), band, len(band),
                int(n_in_A), int(A), int(B), np.asarray(centre_A, float), np.asarray(centre_B, float),
                np.asarray(is_seed, np.bool_), float(lbar), float(scale), bidx)


@njit(cache=True, nogil=True)
def _grow_band(indptr, indices, lab, band, start, end, cluster, layers, bidx):
    """Append to ``band`` the elements of ``cluster`` within ``layers - 1`` steps of ``band[start:end]``."""
    lo, hi = start, end
    for _ in range(layers - 1):
        top = end
        end = _append_neighbours(indptr, indices, lab, band, lo, hi, end, cluster, bidx)
        if end == top:
            break
        lo, hi = top, end
    return end


@njit(cache=True, nogil=True)
def _append_neighbours(indptr, indices, lab, band, lo, hi, end, cluster, bidx):
    """Append to ``band`` (from ``end`` on) the elements of ``cluster`` adjacent to ``band[lo:hi]`` and not yet in
    it; return the new end."""
    for i in range(lo, hi):
        e = band[i]
        for q in range(indptr[e], indptr[e + 1]):
            j = indices[q]
            if lab[j] == cluster and bidx[j] < 0:
                bidx[j] = end
                band[end] = j
                end += 1
    return end


@njit(cache=True, nogil=True)
def cluster_lists(lab, X, w, k):
    """Doubly linked member lists of the k clusters of ``lab`` (n,) (each in increasing element order) and their
    sizes: returns ``(head (k,), nxt (n,), prv (n,), cnt (k,), W (k,) total weight, centre (k, d) weighted
    centroid of X (n, d))``."""
    n = lab.shape[0]
    d = X.shape[1]
    head = np.full(k, -1, np.int64)
    nxt = np.full(n, -1, np.int64)
    prv = np.full(n, -1, np.int64)
    cnt = np.zeros(k, np.int64)
    W = np.zeros(k)
    centre = np.zeros((k, d))
    for e in range(n - 1, -1, -1):
        c = lab[e]
        nxt[e] = head[c]
        if head[c] >= 0:
            prv[head[c]] = e
        head[c] = e
        cnt[c] += 1
        W[c] += w[e]
        for a in range(d):
            centre[c, a] += w[e] * X[e, a]
    for c in range(k):
        centre[c] /= W[c]
    return head, nxt, prv, cnt, W, centre


@njit(cache=True, nogil=True, inline="always")
def relink(head, nxt, prv, e, old, new):
    """Move element ``e`` from the member list of cluster ``old`` to the front of that of ``new``."""
    if prv[e] >= 0:
        nxt[prv[e]] = nxt[e]
    else:
        head[old] = nxt[e]
    if nxt[e] >= 0:
        prv[nxt[e]] = prv[e]
    prv[e] = -1
    nxt[e] = head[new]
    if head[new] >= 0:
        prv[head[new]] = e
    head[new] = e


@njit(cache=True, nogil=True)
def _connected(indptr, indices, lab, start, cluster, size, seen, stamp, queue):
    """True if the ``size`` elements labelled ``cluster`` are one piece containing ``start``."""
    if lab[start] != cluster:
        return False
    seen[start] = stamp
    queue[0] = start
    qh, qt = 0, 1
    while qh < qt:
        e = queue[qh]
        qh += 1
        for q in range(indptr[e], indptr[e + 1]):
            j = indices[q]
            if lab[j] == cluster and seen[j] != stamp:
                seen[j] = stamp
                queue[qt] = j
                qt += 1
    return qt == size


@njit(cache=True, nogil=True)
def _smooth(indptr, indices, lengths, lab, X, w, seeds, pair_a, pair_b, k, layers, scale, tol):
    """The loop over pairs (module docstring); ``lab`` modified in place; ``tol`` < 0: no balance check.
    Returns (accepted, rejected_longer, rejected_disconnected, rejected_unbalanced, moved)."""
    n = lab.shape[0]
    head, nxt, prv, cnt, W, centre = cluster_lists(lab, X, w, k)
    mean = W.sum() / k
    is_seed = np.zeros(n, np.bool_)
    is_seed[seeds] = True
    bidx = np.full(n, -1, np.int64)
    band = np.empty(n, np.int64)
    seen = np.zeros(n, np.int64)
    queue = np.empty(n, np.int64)
    stamp = 0
    stats = np.zeros(5, np.int64)
    for p in range(pair_a.shape[0]):
        A, B = pair_a[p], pair_b[p]
        nA = 0
        lsum = 0.0
        lcount = 0
        e = head[A]
        while e >= 0:
            on = False
            for q in range(indptr[e], indptr[e + 1]):
                if lab[indices[q]] == B:
                    lsum += lengths[q]
                    lcount += 1
                    on = True
            if on:
                bidx[e] = nA
                band[nA] = e
                nA += 1
            e = nxt[e]
        if lcount == 0:
            continue  # no longer neighbours after an earlier pair moved
        lbar = lsum / lcount
        n1 = nA
        nA = _grow_band(indptr, indices, lab, band, 0, n1, A, layers, bidx)
        nb = _append_neighbours(indptr, indices, lab, band, 0, n1, nA, B, bidx)
        nb = _grow_band(indptr, indices, lab, band, nA, nb, B, layers, bidx)
        new_A = _cut(indptr, indices, lengths, lab, X, band, nb, nA, A, B, centre[A], centre[B], is_seed, lbar,
                     scale, bidx)
        changed = 0
        gain = 0.0
        len_old = 0.0
        len_new = 0.0
        for i in range(nb):
            e = band[i]
            old_in_A = i < nA
            if new_A[i] != old_in_A:
                changed += 1
                gain += w[e] if new_A[i] else -w[e]
            mine = A if new_A[i] else B
            for q in range(indptr[e], indptr[e + 1]):
                j = indices[q]
                jl = bidx[j]
                if jl >= 0:
                    half = 0.5 * lengths[q]
                    other = A if new_A[jl] else B
                else:
                    half = lengths[q]
                    other = lab[j]
                if lab[e] != lab[j]:
                    len_old += half
                if mine != other:
                    len_new += half
        ok = changed > 0
        if ok and len_new > len_old * (1 + 1e-12):
            stats[1] += 1
            ok = False
        if ok and tol >= 0:
            dev_old = max(abs(W[A] - mean), abs(W[B] - mean))
            dev_new = max(abs(W[A] + gain - mean), abs(W[B] - gain - mean))
            if dev_new > max(tol * mean, dev_old):
                stats[3] += 1
                ok = False
        if ok:
            moved_to_A = 0
            for i in range(nb):
                if new_A[i] and i >= nA:
                    moved_to_A += 1
            moved_to_B = changed - moved_to_A
            for i in range(nb):
                lab[band[i]] = A if new_A[i] else B
            cntA = cnt[A] + moved_to_A - moved_to_B
            cntB = cnt[B] - moved_to_A + moved_to_B
            stamp += 1
            okA = cntA > 0 and _connected(indptr, indices, lab, seeds[A], A, cntA, seen, stamp, queue)
            stamp += 1
            okB = okA and cntB > 0 and _connected(indptr, indices, lab, seeds[B], B, cntB, seen, stamp, queue)
            if not okB:
                for i in range(nb):
                    lab[band[i]] = A if i < nA else B
                stats[2] += 1
            else:
                for i in range(nb):
                    e = band[i]
                    if new_A[i] == (i < nA):
                        continue
                    old, new = (B, A) if new_A[i] else (A, B)
                    relink(head, nxt, prv, e, old, new)
                cnt[A], cnt[B] = cntA, cntB
                W[A] += gain
                W[B] -= gain
                stats[0] += 1
                stats[4] += changed
        for i in range(nb):
            bidx[band[i]] = -1
    return stats


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
    seeds : (k,) seed element of each cluster (never moved; ``labels[seeds[c]] == c``)
    layers : band depth on each side of a boundary (>= 1)
    scale : integer units per unit cost in the max-flow (reduced if the capacities would overflow)
    balance_tol : None, or a relative tolerance: a pair's new assignment is also rejected when it takes
        either cluster's weight further than ``balance_tol`` from the mean *and* further than it was (so
        smoothing does not undo the balancing of :mod:`.growing`)

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
    rows = np.repeat(np.arange(n), np.diff(indptr))
    cut = (rows < indices) & (lab[rows] != lab[indices])
    la, lb = lab[rows[cut]], lab[indices[cut]]
    pair_keys = unique(np.minimum(la, lb) * k + np.maximum(la, lb))
    stats["pairs"] = len(pair_keys)
    s = _smooth(np.asarray(indptr, np.int64), np.asarray(indices, np.int64), np.asarray(lengths, float), lab,
                np.ascontiguousarray(centroids, dtype=float), np.asarray(weights, float),
                np.asarray(seeds, np.int64), pair_keys // k, pair_keys % k, k, int(layers), float(scale),
                -1.0 if balance_tol is None else float(balance_tol))
    for key, v in zip(("accepted", "rejected_longer", "rejected_disconnected", "rejected_unbalanced", "moved"), s):
        stats[key] = int(v)
    stats["boundary_after"] = boundary_length(indptr, indices, lengths, lab)
    return lab, stats
