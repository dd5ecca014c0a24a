"""Greedy multi-source region growing (thesis §4.2.2, Fig. 4.5).

All clusters grow at once from their seed elements.  One priority queue holds candidates
``(key, element, cluster)``: an unassigned element adjacent to an element of the cluster, keyed by the
distance from the element's centroid to the centroid of *that cluster's seed* (not by a path length).
The smallest key is popped; if its element is still free it joins the cluster and its free neighbours
are pushed with their distance to the same seed.  Clusters are contiguous by construction (an element
only joins a cluster it touches) and, in a connected region, every element is reached.

Because the key is the distance to the seed and not an accumulated path length, this is not Dijkstra's
algorithm: the keys popped are not monotone (an element closer to the seed than the one that exposed it
is popped at once) and no vectorised shortest-path routine computes the same partition.  The loop is
therefore compiled (numba), with one exact pruning: a candidate is pushed only if its key is smaller than the
best key already queued for that element (the queued one would be popped first and win anyway).  Ties of the
key are broken by element, then cluster index.
Squared distances are used as keys (same order).  The centroids may carry a fourth, feature coordinate (a
scaled absorbed flux, see :mod:`.driver`): the distance is then taken in that 4-D space, so clusters follow
changes of the feature as well as the geometry, and they stay contiguous all the same.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..arrays import unique
from .smoothing import cluster_lists, relink


def grow(indptr: np.ndarray, indices: np.ndarray, centroids: np.ndarray, seeds: np.ndarray,
         offsets: np.ndarray | None = None) -> np.ndarray:
    """Assign every element of a connected region to one of the seeds.

    Parameters
    ----------
    indptr, indices : CSR adjacency of the region's dual graph (n elements, symmetric)
    centroids : (n, 3) element centroids (m), or (n, 4) with a feature coordinate (m)
    seeds : (k,) distinct element indices
    offsets : (k,) float (m²) or None; the key of an element for cluster c is ``d² − offsets[c]`` (a power
        distance: a larger offset lets the cluster reach further, see :func:`grow_balanced`).  The seeds are
        assigned first, so every cluster keeps at least its seed whatever the offsets

    Returns
    -------
    (n,) int64 cluster index 0..k-1 of each element (cluster c grows from ``seeds[c]``).

    Raises
    ------
    RuntimeError
        if some element is not reached (the region is not connected: a bug of the caller).
    """
    n = len(centroids)
    seeds = np.asarray(seeds, np.int64)
    if len(seeds) == 1:
        return np.zeros(n, np.int64)
    off = np.zeros(len(seeds)) if offsets is None else np.ascontiguousarray(offsets, dtype=np.float64)
    out = _grow(np.asarray(indptr, np.int64), np.asarray(indices, np.int64),
                np.ascontiguousarray(centroids, dtype=np.float64), seeds, off)
    if (out < 0).any():
        raise RuntimeError(f"region growing did not reach {int((out < 0).sum())} elements: region not connected")
    return out


@njit(cache=True, nogil=True)
def _less(kd, ke, kc, a, b):
    """Heap order: key, then element, then cluster (a total order: an element is pushed again only with a
    strictly smaller key, so no two entries are equal and the pops do not depend on the heap's layout)."""
    if kd[a] != kd[b]:
        return kd[a] < kd[b]
    if ke[a] != ke[b]:
        return ke[a] < ke[b]
    return kc[a] < kc[b]


@njit(cache=True, nogil=True, inline="always")
def _swap(kd, ke, kc, a, b):
    kd[a], kd[b] = kd[b], kd[a]
    ke[a], ke[b] = ke[b], ke[a]
    kc[a], kc[b] = kc[b], kc[a]


@njit(cache=True, nogil=True)
def _push(kd, ke, kc, size, d, e, c):
    """Add (d, e, c) to the heap of ``size`` entries and sift it up; returns the new size."""
    pos = size
    kd[pos], ke[pos], kc[pos] = d, e, c
    while pos > 0:
        parent = (pos - 1) // 2
        if not _less(kd, ke, kc, pos, parent):
            break
        _swap(kd, ke, kc, pos, parent)
        pos = parent
    return size + 1


@njit(cache=True, nogil=True)
def _pop(kd, ke, kc, size):
    """Remove the root of the heap of ``size`` entries (the last entry moves to the root and sifts down);
    returns ``(element, cluster, new size)`` of the root."""
    e, c = ke[0], kc[0]
    size -= 1
    kd[0], ke[0], kc[0] = kd[size], ke[size], kc[size]
    pos = 0
    while True:
        child = 2 * pos + 1
        if child >= size:
            break
        if child + 1 < size and _less(kd, ke, kc, child + 1, child):
            child += 1
        if not _less(kd, ke, kc, child, pos):
            break
        _swap(kd, ke, kc, pos, child)
        pos = child
    return e, c, size


@njit(cache=True, nogil=True)
def _expand(indptr, indices, centroids, seed_xyz, offsets, label, best, kd, ke, kc, size, e, c):
    """Queue the free neighbours of element ``e`` (just given to cluster ``c``) with their power distance."""
    dim = centroids.shape[1]
    for q in range(indptr[e], indptr[e + 1]):
        j = indices[q]
        if label[j] >= 0:
            continue
        d = -offsets[c]
        for a in range(dim):
            t = centroids[j, a] - seed_xyz[c, a]
            d += t * t
        if d < best[j]:
            best[j] = d
            size = _push(kd, ke, kc, size, d, j, c)
    return size


@njit(cache=True, nogil=True)
def _grow(indptr, indices, centroids, seeds, offsets):
    """The growing loop with an array-based binary heap of (key, element, cluster) (at most nnz entries).

    The seeds are labelled before the loop and their neighbours queued, so no cluster loses its seed."""
    n, dim = centroids.shape
    k = seeds.shape[0]
    cap = indices.shape[0] + k + 1
    kd = np.empty(cap)
    ke = np.empty(cap, np.int64)
    kc = np.empty(cap, np.int64)
    label = np.full(n, -1, np.int64)
    best = np.full(n, np.inf)
    seed_xyz = np.empty((k, dim))
    for c in range(k):
        seed_xyz[c] = centroids[seeds[c]]
        label[seeds[c]] = c
    size = 0
    for c in range(k):
        size = _expand(indptr, indices, centroids, seed_xyz, offsets, label, best, kd, ke, kc, size, seeds[c], c)
    while size > 0:
        e, c, size = _pop(kd, ke, kc, size)
        if label[e] >= 0:
            continue
        label[e] = c
        size = _expand(indptr, indices, centroids, seed_xyz, offsets, label, best, kd, ke, kc, size, e, c)
    return label


def grow_balanced(indptr: np.ndarray, indices: np.ndarray, centroids: np.ndarray, weights: np.ndarray,
                  seeds: np.ndarray, lengths: np.ndarray | None = None, tol: float = 0.02, max_passes: int = 10,
                  lloyd_steps: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """Region growing whose clusters carry equal weight (area/volume): one growing, then local boundary moves.

    The clusters are grown once from the seeds (:func:`grow`); ``lloyd_steps`` times each seed then moves to the
    element of its cluster nearest the cluster's weighted centroid (a Lloyd step on the mesh graph) and the
    clusters are grown again.  The weights are then balanced by :func:`balance` (a diffusion flow between
    neighbouring clusters carried out by moving boundary elements), which replaces the up to 40 growings of the
    earlier capacity-constrained scheme (measurements: docs/design-notes.md, cluster/growing.py).  Clusters stay
    contiguous and never leave the region (the graph is the region's).

    Parameters
    ----------
    indptr, indices : CSR adjacency of one connected region (n elements)
    centroids : (n, d) element centroids (m), d = 3 (or 4 with a feature coordinate)
    weights : (n,) element weights > 0 (m², m³ or m)
    seeds : (k,) distinct seed elements
    lengths : (nnz,) shared edge length (m) / face area (m²) of each link, or None (all 1): the conductance of
        the diffusion between two clusters is the length of their common boundary
    tol : target coefficient of variation of the cluster weights
    max_passes : most balancing passes (:func:`balance`)
    lloyd_steps : growings after the first with the seeds moved to their clusters' centroids

    Returns
    -------
    labels : (n,) int64, cluster of each element
    seeds : (k,) int64, the (moved) seed of each cluster, an element of it
    passes : balancing passes done
    """
    seeds = np.asarray(seeds, np.int64).copy()
    k = len(seeds)
    labels = grow(indptr, indices, centroids, seeds)
    if k < 2:
        return labels, seeds, 0
    w = np.asarray(weights, float)
    X = centroids[:, :3]
    for _ in range(lloyd_steps):
        W = np.bincount(labels, w, minlength=k)
        cen = np.stack([np.bincount(labels, w * X[:, j], minlength=k) for j in range(3)], 1) / W[:, None]
        d2 = ((X - cen[labels]) ** 2).sum(1)
        order = np.lexsort((d2, labels))
        seeds = order[np.searchsorted(labels[order], np.arange(k))]
        labels = grow(indptr, indices, centroids, seeds)
    labels, passes = balance(indptr, indices, centroids, w, labels, seeds, lengths, tol=tol, max_passes=max_passes)
    return labels, seeds, passes


def balance(indptr: np.ndarray, indices: np.ndarray, centroids: np.ndarray, weights: np.ndarray,
            labels: np.ndarray, seeds: np.ndarray, lengths: np.ndarray | None = None, tol: float = 0.02,
            max_passes: int = 10) -> tuple[np.ndarray, int]:
    """Even out the weights of contiguous clusters by moving elements across their boundaries.

    Each pass solves for the diffusion flow on the cluster graph (Hu & Blake 1999): with ``c_AB`` the length of
    the boundary between clusters A and B and L the weighted Laplacian of the cluster graph, ``L φ = W − W̄``
    (W the cluster weights, W̄ their mean) and ``f_AB = c_AB (φ_A − φ_B)`` is the weight A gives to B; it is the
    flow of least ``Σ f²/c`` that makes every weight equal.  The flows are then carried out pair by pair, the
    largest first (:func:`_carry`): elements of A touching B move to B in increasing order of
    ``|x − x_B|² − |x − x_A|²`` (x_A, x_B the weighted centroids at the start of the pass: the elements most
    B-like first, so the boundary advances as a power-diagram boundary would), as long as the moved weight
    stays within half an element of ``f_AB``.  An element never moves if it is a seed, or if removing it could
    disconnect A: its neighbours in A must stay connected through A's elements within two links of it (a local,
    sufficient test); B stays connected because the element touches it.  Passes repeat, with updated centroids
    and flows, until the coefficient of variation of the weights is at most ``tol``, a pass moves nothing or
    ``max_passes`` passes; the best labels seen are returned.  Everything is sequential and deterministic.

    Parameters
    ----------
    indptr, indices : CSR adjacency of one connected region (n elements)
    centroids : (n, d) element centroids (m)
    weights : (n,) element weights > 0
    labels : (n,) int cluster of each element, 0..k-1, every cluster contiguous and holding its seed
    seeds : (k,) seed element of each cluster (never moved)
    lengths : (nnz,) shared edge length / face area of each link, or None (all 1)
    tol : target coefficient of variation of the cluster weights
    max_passes : most passes

    Returns
    -------
    labels : (n,) int64 new labels (a copy), clusters contiguous, seeds in place
    passes : passes done
    """
    import scipy.sparse as sp

    from ..linalg import solve

    lab = np.array(labels, np.int64)
    seeds = np.asarray(seeds, np.int64)
    w = np.asarray(weights, float)
    k = len(seeds)
    n = len(lab)
    indptr = np.asarray(indptr, np.int64)
    indices = np.asarray(indices, np.int64)
    lengths = np.ones(len(indices)) if lengths is None else np.asarray(lengths, float)
    X = np.ascontiguousarray(centroids, dtype=np.float64)
    mean = float(w.sum()) / k
    if k < 2:
        return lab, 0
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
    is_seed = np.zeros(n, np.bool_)
    is_seed[seeds] = True
    best_cv, best = np.inf, lab.copy()
    passes = 0
    for passes in range(1, max_passes + 1):
        W = np.bincount(lab, w, minlength=k)
        cv = float(W.std() / mean)
        if cv < best_cv:
            best_cv, best = cv, lab.copy()
        if cv <= tol:
            break
        cut = (rows < indices) & (lab[rows] != lab[indices])
        la, lb = lab[rows[cut]], lab[indices[cut]]
        key, inv = unique(np.minimum(la, lb) * k + np.maximum(la, lb), return_inverse=True)
        c = np.bincount(inv.ravel(), lengths[cut], minlength=len(key))
        a, b = key // k, key % k
        L = sp.csr_matrix((np.r_[-c, -c, np.bincount(a, c, minlength=k) + np.bincount(b, c, minlength=k)],
                           (np.r_[a, b, np.arange(k)], np.r_[b, a, np.arange(k)])), shape=(k, k))
        phi = np.zeros(k)
        phi[1:] = solve(L[1:, 1:], (W - mean)[1:], "spd")  # the cluster graph of a region is connected
        f = c * (phi[a] - phi[b])
        src, dst = np.where(f > 0, a, b), np.where(f > 0, b, a)
        amount = np.abs(f)
        order = np.lexsort((key, -amount))
        moved = _carry(indptr, indices, X, w, lab, is_seed, src[order], dst[order], amount[order], k)
        if moved == 0:
            passes += 1
            break
    W = np.bincount(lab, w, minlength=k)
    if float(W.std() / mean) < best_cv:
        best = lab
    return best, passes


@njit(cache=True, nogil=True)
def _removable(indptr, indices, lab, e, A, mark, stamp, queue):
    """True if element ``e`` can leave cluster A without disconnecting it: its neighbours in A are connected
    through the elements of A within two links of ``e`` (``e`` excluded).  ``mark`` (n,) int64 scratch whose
    entries are all < ``stamp``; uses the stamps ``stamp`` and ``stamp + 1``."""
    first = -1
    count = 0
    for q in range(indptr[e], indptr[e + 1]):
        j = indices[q]
        if lab[j] == A:
            count += 1
            if first < 0:
                first = j
    if count <= 1:
        return count == 1
    for q in range(indptr[e], indptr[e + 1]):
        j = indices[q]
        if lab[j] != A:
            continue
        mark[j] = stamp
        for r in range(indptr[j], indptr[j + 1]):
            i = indices[r]
            if i != e and lab[i] == A:
                mark[i] = stamp
    mark[first] = stamp + 1
    queue[0] = first
    qh, qt = 0, 1
    while qh < qt:
        u = queue[qh]
        qh += 1
        for q in range(indptr[u], indptr[u + 1]):
            v = indices[q]
            if mark[v] == stamp:
                mark[v] = stamp + 1
                queue[qt] = v
                qt += 1
    for q in range(indptr[e], indptr[e + 1]):
        j = indices[q]
        if lab[j] == A and mark[j] != stamp + 1:
            return False
    return True


@njit(cache=True, nogil=True)
def _move_key(X, e, cA, cB):
    """|x_e − c_B|² − |x_e − c_A|²: small for elements more B-like than A-like."""
    s = 0.0
    for a in range(X.shape[1]):
        s += (X[e, a] - cB[a]) ** 2 - (X[e, a] - cA[a]) ** 2
    return s


@njit(cache=True, nogil=True)
def _carry(indptr, indices, X, w, lab, is_seed, src, dst, amount, k):
    """Carry out the flows ``amount[p]`` from cluster ``src[p]`` to ``dst[p]`` in that order by moving boundary
    elements (:func:`balance`); ``lab`` modified in place.  Returns the number of elements moved."""
    n = lab.shape[0]
    head, nxt, prv, cnt, W, centre = cluster_lists(lab, X, w, k)
    cap = indices.shape[0] + n + 1
    kd = np.empty(cap)
    ke = np.empty(cap, np.int64)
    kc = np.zeros(cap, np.int64)
    mark = np.zeros(n, np.int64)
    queue = np.empty(n, np.int64)
    stamp = 1
    w_min = w.min()
    total = 0
    for p in range(src.shape[0]):
        A, B = src[p], dst[p]
        goal = amount[p]
        if goal < 0.5 * w_min:
            continue
        cA, cB = centre[A], centre[B]
        size = 0
        e = head[A]
        while e >= 0:
            if not is_seed[e]:
                for q in range(indptr[e], indptr[e + 1]):
                    if lab[indices[q]] == B:
                        size = _push(kd, ke, kc, size, _move_key(X, e, cA, cB), e, 0)
                        break
            e = nxt[e]
        moved = 0.0
        while size > 0 and goal - moved >= 0.5 * w_min:
            e, _, size = _pop(kd, ke, kc, size)
            if lab[e] != A or moved + 0.5 * w[e] > goal:
                continue
            touches = False
            for q in range(indptr[e], indptr[e + 1]):
                if lab[indices[q]] == B:
                    touches = True
                    break
            if not touches:
                continue
            ok = _removable(indptr, indices, lab, e, A, mark, stamp, queue)
            stamp += 2
            if not ok:
                continue
            lab[e] = B
            relink(head, nxt, prv, e, A, B)
            moved += w[e]
            total += 1
            for q in range(indptr[e], indptr[e + 1]):
                j = indices[q]
                if lab[j] == A and not is_seed[j]:
                    size = _push(kd, ke, kc, size, _move_key(X, j, cA, cB), j, 0)
    return total
