"""Seeds of the region growing: weighted k-means on element centroids (thesis §4.2.1, Fig. 4.3).

Weighted k-means minimises ``Σ_k Σ_{i∈c_k} w_i ‖p_i − μ_k‖²`` with ``μ_k`` the weighted mean of its points;
with area (volume) weights a refined patch of the mesh does not attract more clusters.

Algorithm (chosen by measurement; measurements: docs/design-notes.md, cluster/seeding.py):

1. **Weighted subsample.**  When there are more than ``S = max(20 k, 10 000)`` points, S indices are drawn
   with replacement with probability ∝ w and the distinct ones are weighted by how often they were drawn
   (an unbiased sample of the weighted point set).
2. **Restarts on the sample.**  Weighted greedy k-means++ (:func:`kmeans_plusplus`) then weighted Lloyd
   iterations to convergence (relative improvement < 10⁻⁴, at most 50), repeated ``n_init`` times (10 on small problems, 1 at 10⁶ elements); the
   lowest objective wins (restarts matter on small problems).
3. **A few Lloyd iterations on the full set** (``full_iter = 5``) to remove the sampling noise.

Lloyd's assignment step uses a KD-tree on the k centres (``scipy.spatial.cKDTree``, O(n log k)), the update
step weighted ``bincount``; much faster than scikit-learn's KMeans and MiniBatchKMeans.

One seed element per centre: the element whose centroid is nearest; when two centres pick the same
element, the centre nearer to it keeps it and the other takes its next-nearest free element.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from ..arrays import unique

BRUTE_BELOW = 2_000_000  # n·k below which the nearest centre is found by brute force (compiled), not a KD-tree


@njit(cache=True, nogil=True)
def _nearest(X, C):
    """Squared distance (n,) to the nearest of the centres ``C`` (k, d) and its index (n,) for points ``X`` (n, d)
    by brute force (ties: the lower index)."""
    n, d = X.shape
    d2 = np.empty(n)
    lab = np.empty(n, np.int64)
    for i in range(n):
        best, arg = np.inf, 0
        for c in range(C.shape[0]):
            s = 0.0
            for a in range(d):
                t = X[i, a] - C[c, a]
                s += t * t
            if s < best:
                best, arg = s, c
        d2[i] = best
        lab[i] = arg
    return d2, lab


def _lloyd(X: np.ndarray, w: np.ndarray, C: np.ndarray, max_iter: int, tol: float) -> tuple[np.ndarray, float]:
    """Weighted Lloyd iterations from centres ``C``; returns the centres and the last objective.

    The assignment is brute force below ``n·k = BRUTE_BELOW`` (3× faster than the KD-tree's query on the
    baffle's regions, ~3 000 points and 15 centres), a KD-tree above."""
    k = len(C)
    workers = -1 if len(X) > 50_000 else 1  # starting threads costs more than it saves on small sets
    brute = len(X) * k < BRUTE_BELOW
    X = np.ascontiguousarray(X, dtype=np.float64)
    prev = obj = np.inf
    for _ in range(max_iter):
        if brute:
            d2, lab = _nearest(X, np.ascontiguousarray(C, dtype=np.float64))
        else:
            d, lab = cKDTree(C).query(X, workers=workers)
            d2 = d * d
        obj = float(np.dot(w, d2))
        if prev - obj <= tol * obj:
            break
        W = np.bincount(lab, w, minlength=k)
        ok = W > 0
        new = C.copy()
        for j in range(X.shape[1]):
            new[ok, j] = np.bincount(lab, w * X[:, j], minlength=k)[ok] / W[ok]
        C = new
        prev = obj
    return C, obj


def kmeans_plusplus(X: np.ndarray, w: np.ndarray, k: int, rng: np.random.Generator) -> np.ndarray:
    """Weighted greedy k-means++ initial centres (k, d) drawn from the points ``X`` (n, d), k <= n.

    Each new centre is the best of ``2 + ⌊ln k⌋`` candidates drawn with probability ∝ w·D² (D: distance to
    the nearest centre so far), "best" meaning the lowest resulting objective Σ w·D².  O(n k log k).
    """
    n = len(X)
    trials = 2 + int(np.log(k))
    first = rng.choice(n, p=w / w.sum())
    centres = [first]
    d2 = ((X - X[first]) ** 2).sum(axis=1)
    sq = (X * X).sum(axis=1)
    for _ in range(1, k):
        p = w * d2
        tot = p.sum()
        if tot <= 0:  # fewer distinct points than centres: take unused points
            rest = np.setdiff1d(np.arange(n), centres)[: k - len(centres)]
            centres.extend(rest.tolist())
            break
        cand = np.searchsorted(np.cumsum(p), rng.random(trials) * tot)
        cand = np.minimum(cand, n - 1)
        dc = np.maximum(sq[None, :] + sq[cand][:, None] - 2.0 * (X[cand] @ X.T), 0.0)  # (trials, n)
        new = np.minimum(dc, d2[None, :])
        best = int(np.argmin(new @ w))
        centres.append(int(cand[best]))
        d2 = new[best]
    return X[np.asarray(centres)].astype(float)


def weighted_kmeans(X: np.ndarray, w: np.ndarray, k: int, seed: int | Sequence[int] = 0, sample_size: int | None = None,
                    n_init: int | None = None, full_iter: int = 5, tol: float = 1e-4,
                    max_iter: int = 50) -> np.ndarray:
    """Weighted k-means centres.

    Parameters
    ----------
    X : (n, 3) float, points (m)
    w : (n,) float > 0, weights (m² or m³)
    k : number of centres, 1 <= k <= n
    seed : random seed, an int or a sequence of ints; same inputs and seed give the same centres
    sample_size : number of weighted draws the restarts work on (default ``max(20 k, 10 000)``); the
        full set is used when it is not larger
    n_init : k-means++ restarts on the sample, the lowest objective wins (default ``2·10⁶ / (n_s k)``
        clipped to [1, min(k, 10)], n_s the sample size: many restarts on small problems, one at 10⁶
        elements, few when k is small and local minima are few)
    full_iter : most Lloyd iterations on the full set after the sample stage
    tol : relative improvement of the objective below which Lloyd iterations stop
    max_iter : most Lloyd iterations of each restart on the sample

    Returns
    -------
    (k, 3) float centres (m).
    """
    X = np.asarray(X, float)
    w = np.asarray(w, float)
    n = len(X)
    if k == 1:
        return (w @ X / w.sum())[None, :]
    rng = np.random.default_rng(seed)
    S = max(20 * k, 10_000) if sample_size is None else int(sample_size)
    Xs, ws = X, w
    if n > S:
        idx = rng.choice(n, size=S, p=w / w.sum())
        u, cnt = unique(idx, return_counts=True)
        if len(u) >= k:
            Xs, ws = X[u], cnt.astype(float)
    if n_init is None:
        n_init = int(np.clip(2e6 // (len(Xs) * k), 1, min(k, 10)))
    best, best_obj = None, np.inf
    for _ in range(n_init):
        C, obj = _lloyd(Xs, ws, kmeans_plusplus(Xs, ws, k, rng), max_iter, tol)
        if obj < best_obj:
            best, best_obj = C, obj
    if Xs is not X:
        best, _ = _lloyd(X, w, best, full_iter, tol)
    return best


def seed_elements(X: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """(k,) int64 distinct indices of the points of ``X`` (n, 3) nearest to each of ``centres`` (k, 3), k <= n."""
    k = len(centres)
    tree = cKDTree(X)
    d, nearest = tree.query(centres, k=1)
    nearest = np.asarray(nearest, np.int64)
    u, first, counts = np.unique(nearest, return_index=True, return_counts=True)
    if (counts == 1).all():
        return nearest
    # collisions: the nearer centre keeps the element, the others take their next-nearest free element
    order = np.lexsort((np.arange(k), d))  # by distance, ties by centre index
    taken: set[int] = set()
    out = np.empty(k, np.int64)
    pending = []
    for c in order:
        e = int(nearest[c])
        if e in taken:
            pending.append(c)
        else:
            taken.add(e)
            out[c] = e
    for c in pending:
        q = 2
        while True:
            q = min(2 * q, len(X))
            _, cand = tree.query(centres[c], k=q)
            free = [int(e) for e in np.atleast_1d(cand) if int(e) not in taken]
            if free:
                out[c] = free[0]
                taken.add(free[0])
                break
    return out
