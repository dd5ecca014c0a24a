"""Error-driven refinement (issue 21 item 5): estimate the recovery error, split the clusters that cause it.

The residual
------------
The recovered field T of a reduced model satisfies, inside every cluster, the detailed equations up to a load
spread like the super-node weights (the Lagrange multiplier of the constraint ``A T = T_SN``), and up to the loads
the reduced model cannot see: the thesis' uniform emission per super node, or (radiation-aware with
``ir_on = "detailed"``) the IR that its super faces emit uniformly at the super-node temperature instead of from
the FE faces at their own temperatures.  The estimator puts all of it into one residual under the *true* loads,

    r = q_true − K T − E(T),        E(T) = σ e ⊙ (T⁴ − T_s⁴),

with the absorbed IR of q_true from a side-to-side tally traced once (the pipeline glue,
:func:`fem2tmm.stages.refinement_residual`).

The global estimate (default, :func:`global_estimate`)
------------------------------------------------------
One Newton step of the whole detailed problem from T: ``J δT = r`` with ``J = K + diag(4σ e T³) − G``, G the
linearised re-absorption of the emission change by the faces that see each other (without it the step
under-estimates: the emission K' lets a hotter face lose partly comes back).  K' = K + diag(4σ e T³) is factored
once (sparse LU, the detailed size); G enters by GMRES preconditioned with K' (the Krylov acceleration of the
contracting fixed point δT ← K'⁻¹(r + G δT): the same δT, in fewer solves).  Each cluster is charged with the
error it *causes* through the adjoint ``z = J⁻ᵀ(w ⊙ δT)``: ``Σ w δT² = zᵀ r`` split over the DOFs and face sides
that carry r (an emitting super face's misplaced IR shows up on the panels it sees, but splitting the emitter is
what removes it).  Measured on examples/composite (estimate / measured RMS): 0.99, 0.99, 0.98 at 10, 25, 50
super nodes (without G: 0.89, 0.84, 0.82).

The local estimate (:func:`local_error`)
----------------------------------------
The same residual solved on every cluster's *interior* DOFs (those whose elements all belong to that cluster) with
every other DOF held at its recovered temperature: a local detailed solve of each cluster with its neighbours'
temperatures given.  Interior DOFs of different clusters share no element, so ``K'_II`` is block diagonal by
construction and all clusters cost one sparse factorisation.  It cannot see the error on the interfaces nor that
of the super-node temperatures: on examples/composite it under-estimates about twice (0.62, 0.51, 0.48).

The splitter
------------
A marked cluster is split in two by 2-means on its element centroids (weighted by element volume) seeding a region
growing on the cluster's own dual graph restricted to links inside one region (the clustering kernels
:func:`~fem2tmm.cluster.seeding.weighted_kmeans`, :func:`~fem2tmm.cluster.seeding.seed_elements`,
:func:`~fem2tmm.cluster.growing.grow`), so both halves are contiguous and stay in the cluster's part and region.
Clusters are marked by Dörfler's bulk criterion (:func:`mark`): the fewest worst clusters whose shares make up
a fraction θ of the total.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..arrays import kept, unique
from ..constants import SIGMA
from ..errors import Fem2TmmError
from ..linalg import factorize

#: Dörfler marking fraction: the worst clusters carrying this share of the estimated squared error are split
BULK = 0.5
#: clusters with fewer elements are never split
MIN_ELEMENTS = 4


def interior_dofs(element_dofs: np.ndarray, element_cluster: np.ndarray, n_dof: int,
                  fixed: np.ndarray | None = None) -> np.ndarray:
    """(n_dof,) int64: the cluster of each DOF whose elements all belong to that one cluster, -1 otherwise.

    Parameters
    ----------
    element_dofs : (m, p) int DOFs of each thermal element, padded with -1
    element_cluster : (m,) int cluster of each element, -1 for unclustered elements
    n_dof : number of DOFs
    fixed : (n_dof,) bool or None, DOFs held at a temperature (never interior)

    Returns
    -------
    (n_dof,) int64 cluster of each interior DOF, -1 for DOFs on a cluster interface, outside the clusters or
    fixed.  A cluster none of whose DOFs lies outside it (a whole free part) gets no interior DOF: held by
    nothing, its local problem would be singular without emission.
    """
    ed = np.asarray(element_dofs, np.int64)
    cl = np.broadcast_to(np.asarray(element_cluster, np.int64)[:, None], ed.shape)
    ok = ed >= 0
    lo = np.full(n_dof, np.iinfo(np.int64).max)
    hi = np.full(n_dof, -2, np.int64)
    np.minimum.at(lo, ed[ok], cl[ok])
    np.maximum.at(hi, ed[ok], cl[ok])
    out = np.where((lo == hi) & (lo >= 0), lo, -1)
    if fixed is not None:
        out[np.asarray(fixed, bool)] = -1
    k = int(np.asarray(element_cluster).max(initial=-1)) + 1
    d_ok, c_ok = ed[ok], cl[ok]
    edge = (out[d_ok] < 0) & (c_ok >= 0)  # element incidences on a non-interior DOF: they hold the cluster
    held = np.zeros(k, bool)
    held[c_ok[edge]] = True
    out[(out >= 0) & ~held[np.maximum(out, 0)]] = -1
    return out


def local_error(K: sp.spmatrix, h: np.ndarray, residual: np.ndarray, dof_cluster: np.ndarray) -> np.ndarray:
    """(n_dof,) K: the estimated error δT of every interior DOF, ``K'_II δT_I = r_I`` (zero elsewhere).

    Parameters
    ----------
    K : (n_dof, n_dof) sparse conduction matrix, W/K
    h : (n_dof,) W/K linearised emission 4σ e T³ at the recovered field (zeros: conduction only)
    residual : (n_dof,) W residual of the recovered field under the true loads, ``q − K T − E(T)``
    dof_cluster : (n_dof,) int, :func:`interior_dofs`

    Returns
    -------
    (n_dof,) float: ``T_local − T_recovered`` on the interior DOFs, 0 on the others.
    """
    inner = np.flatnonzero(np.asarray(dof_cluster) >= 0)
    dT = np.zeros(len(dof_cluster))
    if not inner.size:
        return dT
    Kp = (sp.csr_matrix(K) + sp.diags(np.asarray(h, float)))[inner][:, inner]
    dT[inner] = factorize(Kp, "spd").solve(np.asarray(residual, float)[inner])
    return dT


def global_estimate(K: sp.spmatrix, h: np.ndarray, residual: np.ndarray, free: np.ndarray, weight: np.ndarray,
                    dof_owner: np.ndarray, n_clusters: int, source: tuple | None = None,
                    feedback: tuple | None = None, shares: bool = True,
                    cache: dict | None = None, tol: float | None = None,
                    pre: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(δT, share)``: the error of every free DOF from one detailed linear solve, and each cluster's share of it.

    ``K'_FF δT_F = r_F`` with ``r = residual + Bᵀ dp`` (only the fixed DOFs held): like :func:`local_error` with
    the interfaces free too, one Newton step of the whole detailed problem from the recovered field under the
    estimator's loads, which also sees the error of the super-node temperatures themselves.  The squared error
    ``Σ w δT²`` is then split over the *sources* of the residual by the adjoint ``z = K'⁻¹(w ⊙ δT)``:
    ``Σ w δT² = zᵀ r = Σ_j z_j residual_j + Σ_g dp_g (B z)_g``, the first sum charged to the cluster of DOF j,
    the second to the cluster that owns source g (e.g. a face side whose emission the reduced model misplaces:
    the error it causes shows up elsewhere, but splitting *its* cluster is what removes it).

    Parameters
    ----------
    K : (n_dof, n_dof) sparse W/K; h : (n_dof,) W/K linearised emission; residual : (n_dof,) W
    free : (n_dof,) bool DOFs not held
    weight : (n_dof,) mesh nodes per DOF (the RMS weights)
    dof_owner : (n_dof,) int cluster charged with each DOF's residual (:func:`owner_dofs`), -1: none
    n_clusters : K
    source : ``(B, dp, owner)`` or None: B (g, n_dof) sparse maps DOF values to the g sources, dp (g,) W their
        misplaced power, owner (g,) int their cluster (-1: none)
    feedback : ``(B, g, E)`` or None: the linearised re-absorption of the emission change, ``G = Bᵀ diag(g) E``
        (E (g, n_dof) sparse: each emitting side's temperature from the DOFs, g (g,) W/K its 4σεA T³, B as above
        but for the absorption of what side k emits): the operator becomes ``J = K' − G`` (the faces that see
        each other give back part of what K' lets a hotter face emit; without it the step under-estimates),
        solved by GMRES on ``(I − K'⁻¹G) δT = K'⁻¹ r``, the Krylov acceleration of the fixed point
        ``δT ← K'⁻¹(r + G δT)`` (contracting: a face re-absorbs less than all of any emission), to
        :data:`FEEDBACK_TOL`, the adjoint likewise with ``Gᵀ``
    shares : False skips the adjoint solve (δT only; share is then zeros)
    cache : a dict keeping the factorisation of ``K + diag(h)`` on the free DOFs for another call with the same
        ``K``, ``h`` and ``free`` (another residual at the same field), or None
    tol : the re-absorption solve's relative tolerance (default :data:`FEEDBACK_TOL`)
    pre : a list of ``(h on the free DOFs, factorisation of K + diag(h) there)`` at earlier fields, or None.  Where one
        is near enough (:func:`_preconditioner`) it stands for the factorisation: ``J = K'_p + diag(h − h_p) − G``
        solved by the same GMRES on ``(I − K'_p⁻¹(G − diag(h − h_p))) δT = K'_p⁻¹ r`` to ``tol``; otherwise the
        factorisation made here is kept in it (at most :data:`PRECONDITIONERS`: the first and the latest)

    Returns
    -------
    δT (n_dof,) K (0 on held DOFs) and share (n_clusters,) K² (may be negative: cancelling sources).
    """
    idx = np.flatnonzero(np.asarray(free, bool))
    n = len(free)
    r = np.asarray(residual, float).copy()
    if source is not None:
        B, dp, owner_g = source
        r += np.asarray(B.T @ dp).ravel()
    dT, z = np.zeros(n), np.zeros(n)
    share = np.zeros(n_clusters)
    if not idx.size:
        return dT, share
    cache = {} if cache is None else cache
    h = np.asarray(h, float)
    if "lu" not in cache:
        near = _preconditioner(pre, h[idx]) if pre is not None else None
        if near is None:
            cache["lu"], cache["shift"] = factorize((sp.csr_matrix(K) + sp.diags(h))[idx][:, idx], "spd"), None
            if pre is not None:  # kept for the next fields: the first one and the latest
                pre[:] = kept(pre, (h[idx].copy(), cache["lu"]), PRECONDITIONERS)
        else:
            cache["lu"], cache["shift"] = near[1], np.zeros(n)
            cache["shift"][idx] = h[idx] - near[0]
    lu, shift = cache["lu"], cache.get("shift")
    G = Gt = None
    if feedback is not None:
        Bf, g, E = feedback
        G = lambda x: np.asarray(Bf.T @ (g * np.asarray(E @ x).ravel())).ravel()  # noqa: E731
        Gt = lambda x: np.asarray(E.T @ (g * np.asarray(Bf @ x).ravel())).ravel()  # noqa: E731
    if shift is not None:  # K' factorised at another field: its diagonal's change joins the iterated operator
        G = _less(G, shift)
        Gt = _less(Gt, shift)
    if G is None:
        dT[idx] = lu.solve(r[idx])
        if not shares:
            return dT, share
        z[idx] = lu.solve((np.asarray(weight, float) * dT)[idx])  # K' symmetric: its own adjoint
    else:
        limit = None if shift is None else PRECONDITIONED_MAX_ITER
        x = _fixed_point(lu, r, G, idx, n, tol, limit)
        if x is None:  # the factorisation at another field did not do: this field's own
            return _own(K, h, residual, free, weight, dof_owner, n_clusters, source, feedback, shares, cache, tol, pre)
        dT[idx] = x
        if not shares:
            return dT, share
        x = _fixed_point(lu, np.asarray(weight, float) * dT, Gt, idx, n, tol, limit)
        if x is None:
            return _own(K, h, residual, free, weight, dof_owner, n_clusters, source, feedback, shares, cache, tol, pre)
        z[idx] = x
    own = np.asarray(dof_owner)
    sel = own >= 0
    share += np.bincount(own[sel], (z * np.asarray(residual, float))[sel], minlength=n_clusters)
    if source is not None:
        og = np.asarray(owner_g)
        sg = og >= 0
        share += np.bincount(og[sg], (dp * np.asarray(B @ z).ravel())[sg], minlength=n_clusters)
    return dT, share


def _own(K, h, residual, free, weight, dof_owner, n_clusters, source, feedback, shares, cache, tol, pre):
    """:func:`global_estimate` on the field's own factorisation, kept in ``pre`` beside the first."""
    del cache["lu"]
    out = global_estimate(K, h, residual, free, weight, dof_owner, n_clusters, source, feedback, shares, cache, tol)
    pre[:] = kept(pre, (np.asarray(h, float)[np.asarray(free, bool)], cache["lu"]), PRECONDITIONERS)
    return out


def _less(G, shift: np.ndarray):
    """``x ↦ G(x) − shift ⊙ x`` (G None: ``−shift ⊙ x``): the operator a factorisation at another field leaves."""
    if G is None:
        return lambda x: -shift * x
    return lambda x: G(x) - shift * x


def _preconditioner(pre: list, h: np.ndarray):
    """The kept ``(h_p, factorisation)`` of ``pre`` nearest the field's ``h`` (on the free DOFs), when the spread of
    the ratios ``h / h_p`` over the DOFs that emit, κ = max(max h/h_p, 1) / min(min h/h_p, 1), is at most
    :data:`PRECONDITION_KAPPA`; else None.  K is positive semi-definite, so the eigenvalues of
    (K + diag(h_p))⁻¹ (K + diag(h)) lie in [min(min h/h_p, 1), max(max h/h_p, 1)]: κ bounds the preconditioned
    operator's condition number, and GMRES reaches a relative residual ε in about ln(2/ε) / ln((√κ+1)/(√κ−1))
    iterations (10 at κ = 8, ε = 1e-3; docs/design-notes.md, "The range's estimate on one factorisation")."""
    best, kappa = None, PRECONDITION_KAPPA
    for hp, lu in pre:
        on = hp > 0
        if np.any((h > 0) != on):
            continue
        r = h[on] / hp[on]
        k = max(float(r.max(initial=1.0)), 1.0) / min(float(r.min(initial=1.0)), 1.0)
        if k <= kappa:
            best, kappa = (hp, lu), k
    return best


#: :func:`global_estimate` with ``pre``: a factorisation at another field stands for the field's own while the
#: spread of the linearised emission's ratios to its own is at most this (:func:`_preconditioner`)
PRECONDITION_KAPPA = 8.0
#: and at most this many are kept (the first field's, the estimate's design state, and the latest)
PRECONDITIONERS = 2
#: GMRES iterations with such a factorisation before the field's own is made
PRECONDITIONED_MAX_ITER = 40


#: relative residual of the preconditioned re-absorption solve of :func:`global_estimate` (GMRES; the fixed point's
#: relative change where it falls back to that) at which it stops
FEEDBACK_TOL = 1e-6
FEEDBACK_MAX_ITER = 200
#: GMRES restart length of that solve (its Krylov basis: FEEDBACK_RESTART vectors of the detailed size)
FEEDBACK_RESTART = 20


def _fixed_point(lu, rhs: np.ndarray, G, idx: np.ndarray, n: int, tol: float | None = None,
                 limit: int | None = None) -> np.ndarray | None:
    """x on ``idx`` solving ``(K' − G) x = rhs`` (``lu`` factors K' on idx; x = 0 off idx): GMRES on the
    preconditioned system ``(I − K'⁻¹G) x = K'⁻¹ rhs`` to ``tol`` (default :data:`FEEDBACK_TOL`; one solve with K' and one product
    with G per iteration, as the fixed point ``x ← K'⁻¹(rhs + G x)`` it accelerates), that fixed point where GMRES
    stops short.  Raises if it does not contract (more re-absorbed than emitted: a bug of the caller's operators).
    ``limit``: at most that many GMRES iterations, and None where they do not reach ``tol`` (no fixed point)."""
    import scipy.sparse.linalg as spla

    tol = FEEDBACK_TOL if tol is None else float(tol)
    m = idx.size
    full = np.zeros(n)

    def apply(y):
        full[idx] = y
        return y - lu.solve(np.asarray(G(full), float)[idx])

    b = lu.solve(rhs[idx])
    if not np.any(b):
        return b
    A = spla.LinearOperator((m, m), matvec=apply, dtype=float)
    its = FEEDBACK_MAX_ITER if limit is None else limit
    restart = min(FEEDBACK_RESTART, its)
    y, info = spla.gmres(A, b, x0=b.copy(), rtol=tol, atol=0.0, restart=restart, maxiter=-(-its // restart))
    if info == 0:
        return y
    if limit is not None:
        return None
    x = np.zeros(n)
    x[idx] = y
    for _ in range(FEEDBACK_MAX_ITER):
        new = lu.solve(rhs[idx] + G(x)[idx])
        step = np.abs(new - x[idx]).max(initial=0.0)
        x[idx] = new
        if step <= tol * max(np.abs(new).max(initial=0.0), 1e-300):
            return x[idx]
    raise RuntimeError(f"the re-absorption fixed point did not converge in {FEEDBACK_MAX_ITER} iterations")


def owner_dofs(element_dofs: np.ndarray, element_cluster: np.ndarray, n_dof: int,
               fixed: np.ndarray | None = None) -> np.ndarray:
    """(n_dof,) int64: one cluster of each DOF (the lowest-numbered among its elements'), -1 for DOFs of no
    cluster and fixed DOFs: the cluster a DOF's error is charged to."""
    ed = np.asarray(element_dofs, np.int64)
    cl = np.broadcast_to(np.asarray(element_cluster, np.int64)[:, None], ed.shape)
    ok = (ed >= 0) & (cl >= 0)
    lo = np.full(n_dof, np.iinfo(np.int64).max)
    np.minimum.at(lo, ed[ok], cl[ok])
    out = np.where(lo < np.iinfo(np.int64).max, lo, -1)
    if fixed is not None:
        out[np.asarray(fixed, bool)] = -1
    return out


def emission_residual(K: sp.spmatrix, T: np.ndarray, q: np.ndarray, e: np.ndarray, T_sink: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """``(r, h)``: residual ``q − K T − σ e (T⁴ − T_s⁴)`` (n_dof,) W and ``h = 4σ e T³`` (n_dof,) W/K.

    ``K`` (n_dof, n_dof) W/K, ``T`` (n_dof,) K, ``q`` (n_dof,) W the true loads (absorbed radiation included),
    ``e`` (n_dof,) m² the DOFs' emitting εA (:func:`~fem2tmm.reduce.radiative.emission_weights`), ``T_sink`` K.
    """
    T = np.asarray(T, float)
    e = np.asarray(e, float)
    r = np.asarray(q, float) - K @ T - SIGMA * e * (T**4 - T_sink**4)
    return r, 4.0 * SIGMA * e * T**3


def cluster_errors(dT: np.ndarray, dof_cluster: np.ndarray, n_clusters: int, weight: np.ndarray | None = None
                   ) -> tuple[np.ndarray, float]:
    """``(e2, rms)``: per-cluster weighted sum of squared errors (n_clusters,) K² and the estimated RMS (K).

    ``weight`` (n_dof,) mesh nodes per DOF (default 1): the RMS is ``√(Σ w δT² / Σ w)`` over all DOFs with
    ``w > 0``, like the summary's node RMS.
    """
    w = np.ones(len(dT)) if weight is None else np.asarray(weight, float)
    sel = np.asarray(dof_cluster) >= 0
    e2 = np.bincount(np.asarray(dof_cluster)[sel], w[sel] * dT[sel] ** 2, minlength=n_clusters)
    total = w.sum()
    return e2, float(np.sqrt(e2.sum() / total)) if total > 0 else 0.0


def mark(e2: np.ndarray, n_elements: np.ndarray, budget: int, bulk: float = BULK) -> np.ndarray:
    """Clusters to split (sorted int64): the fewest worst ones whose ``e2`` sum to ``bulk`` of the positive total,
    at most ``budget``, only clusters of at least :data:`MIN_ELEMENTS` elements with a positive share.

    ``e2`` (K,) K² each cluster's share of the squared error, ``n_elements`` (K,) their element counts."""
    e2 = np.asarray(e2, float)
    ok = (np.asarray(n_elements) >= MIN_ELEMENTS) & (e2 > 0)
    order = np.argsort(-np.where(ok, e2, -1.0), kind="stable")
    order = order[ok[order]]
    if budget <= 0 or not order.size:
        return np.zeros(0, np.int64)
    cum = np.cumsum(e2[order])
    n = int(np.searchsorted(cum, bulk * e2[e2 > 0].sum())) + 1  # shares may be negative (cancelling sources)
    return np.sort(order[:min(n, budget, order.size)]).astype(np.int64)


def split_clusters(labels: np.ndarray, split: np.ndarray, centroids: np.ndarray, weights: np.ndarray,
                   link_a: np.ndarray, link_b: np.ndarray, cluster_part: np.ndarray, seed: int = 0) -> np.ndarray:
    """Split each cluster of ``split`` in two contiguous halves; new labels numbered consecutively per part.

    Parameters
    ----------
    labels : (n_elements,) int cluster of each element, -1 outside the clusters
    split : (s,) int clusters to split
    centroids : (n_elements, 3) element centroids, m
    weights : (n_elements,) float > 0 element measures (e.g. volumes, m³)
    link_a, link_b : (p,) int element pairs that may share a cluster (sharing an edge/face, same part and region)
    cluster_part : (K,) int part of each cluster
    seed : k-means seed

    Returns
    -------
    (n_elements,) int64 labels 0 … K+s'−1 (s' ≤ s clusters actually split: a cluster whose largest connected
    piece has fewer than 2 elements is left whole), the clusters of each part consecutive, in the order
    (part, old label, half).
    """
    from ..cluster.growing import grow
    from ..cluster.seeding import seed_elements, weighted_kmeans

    labels = np.asarray(labels, np.int64)
    n = len(labels)
    k = len(cluster_part)
    la, lb = np.asarray(link_a, np.int64), np.asarray(link_b, np.int64)
    same = (labels[la] == labels[lb]) & (labels[la] >= 0)
    la, lb = la[same], lb[same]
    half = np.zeros(n, np.int64)  # 1: the element goes to the new half of its cluster
    marked = np.zeros(k, bool)
    marked[np.asarray(split, np.int64)] = True
    # elements and links grouped by cluster once (linear; each split then costs its own cluster's size)
    el_order = np.argsort(labels, kind="stable")
    el_start = np.searchsorted(labels[el_order], np.arange(k + 1))
    lk_lab = labels[la]
    lk_order = np.argsort(lk_lab, kind="stable")
    lk_start = np.searchsorted(lk_lab[lk_order], np.arange(k + 1))
    loc = np.full(n, -1, np.int64)  # scratch: local numbering of the cluster being split, restored after each
    for c in np.flatnonzero(marked):
        el = el_order[el_start[c]:el_start[c + 1]]
        if len(el) < 2:
            continue
        loc[el] = np.arange(len(el))
        lk = lk_order[lk_start[c]:lk_start[c + 1]]
        a, b = loc[la[lk]], loc[lb[lk]]
        loc[el] = -1
        g = sp.csr_matrix((np.ones(2 * len(a), np.int8), (np.r_[a, b], np.r_[b, a])), shape=(len(el), len(el)))
        _, comp = connected_components(g, directed=False)
        big = np.flatnonzero(comp == np.bincount(comp).argmax())  # split the largest piece
        if len(big) < 2:
            continue
        sub = g[big][:, big].tocsr()
        X, w = centroids[el[big]], np.asarray(weights, float)[el[big]]
        centres = weighted_kmeans(X, w, 2, seed=seed)
        seeds = seed_elements(X, centres)
        half[el[big]] = grow(sub.indptr, sub.indices, X, seeds)
    # renumber: by (part, old label, half)
    inside = labels >= 0
    key = np.where(inside, (np.asarray(cluster_part, np.int64)[np.maximum(labels, 0)] * (k + 1) + labels) * 2 + half,
                   -1)
    uniq, inv = unique(key[inside], return_inverse=True)
    out = np.full(n, -1, np.int64)
    out[inside] = inv.ravel()
    return out


def check_budget(target_rms: float | None, max_super_nodes: int | None, n_super_nodes: int) -> None:
    """Refuse a ``max_super_nodes`` budget below the starting clustering's count (before any tracing)."""
    if target_rms is not None and max_super_nodes is not None and max_super_nodes < n_super_nodes:
        raise Fem2TmmError(f"[reduction] max_super_nodes = {max_super_nodes} is below the {n_super_nodes} super nodes "
                           "the clustering starts from: raise it or lower the parts' super_nodes")


__all__ = ["BULK", "MIN_ELEMENTS", "check_budget", "cluster_errors", "emission_residual", "global_estimate",
           "interior_dofs", "local_error", "mark", "owner_dofs", "split_clusters"]
