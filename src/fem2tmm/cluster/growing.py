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
therefore run in Python on plain lists, with one exact pruning: a candidate is pushed only if its key is
smaller than the best key already queued for that element (the queued one would be popped first and win
anyway; on a tie the earlier push wins).  Measured: 10⁶ quads, 1000 seeds, 5.4 s on this machine.
Squared distances are used as keys (same order).  The centroids may carry a fourth, feature coordinate (a
scaled absorbed flux, see :mod:`.driver`): the distance is then taken in that 4-D space, so clusters follow
changes of the feature as well as the geometry, and they stay contiguous all the same.
"""

from __future__ import annotations

import heapq

import numpy as np


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
    ptr = indptr.tolist()
    nbr = indices.tolist()
    if centroids.shape[1] == 3:
        centroids = np.hstack([centroids, np.zeros((n, 1))])
    cx, cy, cz, cw = (centroids[:, j].tolist() for j in range(4))
    sx, sy, sz, sw = (centroids[seeds, j].tolist() for j in range(4))
    label = [-1] * n
    best = [float("inf")] * n
    heap = [(0.0, int(s), c) for c, s in enumerate(seeds)]
    for s in seeds.tolist():
        best[s] = 0.0
    heapq.heapify(heap)
    pop, push = heapq.heappop, heapq.heappush
    while heap:
        _, e, c = pop(heap)
        if label[e] >= 0:
            continue
        label[e] = c
        x, y, z, v = sx[c], sy[c], sz[c], sw[c]
        for j in nbr[ptr[e]:ptr[e + 1]]:
            if label[j] < 0:
                dx = cx[j] - x
                dy = cy[j] - y
                dz = cz[j] - z
                dw = cw[j] - v
                d = dx * dx + dy * dy + dz * dz + dw * dw
                if d < best[j]:
                    best[j] = d
                    push(heap, (d, j, c))
    out = np.array(label, dtype=np.int64)
    if (out < 0).any():
        raise RuntimeError(f"region growing did not reach {int((out < 0).sum())} elements: region not connected")
    return out
