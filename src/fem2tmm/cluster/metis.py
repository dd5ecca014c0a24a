"""METIS (through the optional ``pymetis``) as the partitioner of one region (``[clustering] method = "metis"``).

The regions are the same as with the default method (split at sharp edges, junctions and attribute changes,
:mod:`.regions`), and the part's super nodes are shared among them the same way (:mod:`.allocate`); only the
partition of each connected region changes: METIS k-way on the region's dual graph with the element weights
(areas / volumes) as integer vertex weights and the shared edge lengths (face areas) as edge weights, asking
for contiguous parts (METIS option ``contig``).  METIS may still return an empty or a non-contiguous part on
awkward graphs; :func:`repair` then merges every stray piece into the neighbouring cluster it shares the
longest boundary with and refills empty clusters by halving the heaviest one (two-seed region growing), so
the result has exactly k non-empty contiguous clusters like every other partition in fem2tmm.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import Fem2TmmError
from .adjacency import induced_csr
from .growing import grow

_SCALE = 1000  # integer weight units per mean weight (METIS takes integers)


def available() -> bool:
    """True when ``pymetis`` can be imported."""
    try:
        import pymetis  # noqa: F401
    except ImportError:
        return False
    return True


def require() -> None:
    """Raise a clear :class:`Fem2TmmError` when ``pymetis`` is missing (before any long computation)."""
    if not available():
        raise Fem2TmmError(
            '[clustering] method = "metis" needs the optional package pymetis; install it with '
            '`pip install "fem2tmm[metis]"` (or `pip install pymetis`), or use the default method'
        )


def _ints(x: np.ndarray) -> np.ndarray:
    return np.maximum(1, np.rint(x / x.mean() * _SCALE)).astype(np.int64)


def metis_region(indptr: np.ndarray, indices: np.ndarray, lengths: np.ndarray, centroids: np.ndarray,
                 weights: np.ndarray, k: int, seed: int = 0) -> np.ndarray:
    """Partition one connected region into ``k`` contiguous clusters with METIS.

    Parameters
    ----------
    indptr, indices, lengths : CSR dual graph of the region (n elements, symmetric), ``lengths`` the shared
        edge length (m) or face area (m²) of each link
    centroids : (n, d) element centroids (m), used only by :func:`repair`
    weights : (n,) element weights > 0 (m² or m³)
    k : number of clusters, 1 <= k <= n
    seed : METIS random seed

    Returns
    -------
    (n,) int64 cluster of each element in 0..k-1, every cluster non-empty and contiguous.
    """
    import pymetis

    n = len(weights)
    if k == 1:
        return np.zeros(n, np.int64)
    if k == n:
        return np.arange(n, dtype=np.int64)
    ew = _ints(lengths) if len(lengths) else None
    opts = pymetis.Options(contig=1, seed=int(seed))
    adj = pymetis.CSRAdjacency(np.asarray(indptr, np.int64), np.asarray(indices, np.int64))
    try:
        _, parts = pymetis.part_graph(k, adjacency=adj, vweights=_ints(weights), eweights=ew, options=opts)
    except RuntimeError:  # METIS refuses "contig" on some graphs: ask without it and repair
        opts = pymetis.Options(seed=int(seed))
        _, parts = pymetis.part_graph(k, adjacency=adj, vweights=_ints(weights), eweights=ew, options=opts)
    return repair(indptr, indices, lengths, centroids, np.asarray(parts, np.int64), k)


def repair(indptr: np.ndarray, indices: np.ndarray, lengths: np.ndarray, centroids: np.ndarray,
           labels: np.ndarray, k: int) -> np.ndarray:
    """Make ``labels`` (n,) of a connected region exactly k non-empty contiguous clusters.

    Every connected piece of a cluster other than its largest (by element count) joins the neighbouring
    cluster it shares the longest boundary with (repeated until every cluster is one piece); then, while a
    cluster is empty, the cluster with the most elements is halved by region growing from two of its elements
    far apart (the farthest from its first element, and the farthest from that one).
    """
    lab = np.array(labels, np.int64)
    n = len(lab)
    rows = np.repeat(np.arange(n), np.diff(indptr))
    for _ in range(n):
        same = lab[rows] == lab[indices]
        g = sp.csr_matrix((np.ones(int(same.sum()), np.int8), (rows[same], indices[same])), shape=(n, n))
        n_comp, comp = connected_components(g, directed=False)
        size = np.bincount(comp, minlength=n_comp)
        piece_label = np.zeros(n_comp, np.int64)
        piece_label[comp] = lab
        main = np.full(k, -1, np.int64)
        order = np.argsort(size, kind="stable")
        main[piece_label[order]] = order  # the largest piece of each cluster is written last and wins
        stray = main[piece_label] != np.arange(n_comp)
        if not stray.any():
            break
        cross = stray[comp[rows]] & (lab[rows] != lab[indices])
        key = comp[rows[cross]] * k + lab[indices[cross]]
        tot = np.bincount(key, lengths[cross], minlength=n_comp * k).reshape(n_comp, k)
        move = stray & (tot.max(axis=1) > 0)
        lab = np.where(move[comp], np.argmax(tot, axis=1)[comp], lab)
    scratch = np.full(n, -1, np.int64)
    while True:
        count = np.bincount(lab, minlength=k)
        empty = np.flatnonzero(count == 0)
        if len(empty) == 0:
            return lab
        el = np.flatnonzero(lab == int(np.argmax(count)))
        ptr, ind, _ = induced_csr(indptr, indices, lengths, el, scratch)
        X = centroids[el, :3]
        a = int(np.argmax(((X - X[0]) ** 2).sum(1)))
        b = int(np.argmax(((X - X[a]) ** 2).sum(1)))
        half = grow(ptr, ind, X, np.array([a, b]))
        lab[el[half == 1]] = empty[0]
