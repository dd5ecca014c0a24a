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


def grow(indptr: np.ndarray, indices: np.ndarray, centroids: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Assign every element of a connected region to one of the seeds.

    Parameters
    ----------
    indptr, indices : CSR adjacency of the region's dual graph (n elements, symmetric)
    centroids : (n, 3) element centroids (m), or (n, 4) with a feature coordinate (m)
    seeds : (k,) distinct element indices

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
    out = _grow(np.asarray(indptr, np.int64), np.asarray(indices, np.int64),
                np.ascontiguousarray(centroids, dtype=np.float64), seeds)
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
def _grow(indptr, indices, centroids, seeds):
    """The growing loop with an array-based binary heap of (key, element, cluster) (at most nnz + k entries)."""
    n, dim = centroids.shape
    k = seeds.shape[0]
    cap = indices.shape[0] + k + 1
    kd = np.empty(cap)
    ke = np.empty(cap, np.int64)
    kc = np.empty(cap, np.int64)
    label = np.full(n, -1, np.int64)
    best = np.full(n, np.inf)
    size = 0
    for c in range(k):
        size = _push(kd, ke, kc, size, 0.0, seeds[c], c)
        best[seeds[c]] = 0.0
    seed_xyz = np.empty((k, dim))
    for c in range(k):
        seed_xyz[c] = centroids[seeds[c]]
    while size > 0:
        e, c, size = _pop(kd, ke, kc, size)
        if label[e] >= 0:
            continue
        label[e] = c
        for q in range(indptr[e], indptr[e + 1]):
            j = indices[q]
            if label[j] >= 0:
                continue
            d = 0.0
            for a in range(dim):
                t = centroids[j, a] - seed_xyz[c, a]
                d += t * t
            if d < best[j]:
                best[j] = d
                size = _push(kd, ke, kc, size, d, j, c)
    return label
