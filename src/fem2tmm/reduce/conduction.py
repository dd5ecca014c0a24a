"""Exact conductive reduction ``K_SN = (A K⁺ Aᵀ)⁻¹`` (thesis §4.3, DESIGN §3.2–3.3).

``M = [[K, Aᵀ], [A, 0]]``, ``M⁻¹ = [[X, Yᵀ], [Y, −K_SN]]``.  Two methods give the same K_SN to round-off:

``method="global"`` (reference): one sparse LU of M, then n_SN solves with right-hand sides ``[0; e_i]``.

``method="local"`` (default): for each cluster, over its own elements only (local conduction K, weights a,
interior nodes I, interface nodes B), the local saddle system in unknowns (T_I, μ) with μ = −q_i

    [K_II  a_Iᵀ] [T_I]   [−K_IB T_B          ]
    [a_I    0  ] [ μ ] = [T_SN,i − a_B T_B   ]

is condensed into the cluster's symmetric map K*ᵢ from (T_B, T_SN,i) to (f_B, q_i), with f_B = K_BI T_I + K_BB T_B
+ a_Bᵀ μ the heat the cluster draws through its interface nodes.  With P the matrix above and C = [K_IB; a_B]:
``K*ᵢ = [[K_BB − Cᵀ P⁻¹ C, Cᵀ P⁻¹ e], [·, −eᵀ P⁻¹ e]]`` (e the last unit vector).  The K*ᵢ are summed into K* over
(super nodes ∪ interface nodes); kept / boundary DOFs are interface nodes that *are* super nodes (unit rows of
A), so they are retained; the other interface nodes are removed by Guyan condensation,
``K_SN = K*_SS − K*_SF K*_FF⁻¹ K*_FS`` (thesis eq. 4.9).  A cluster without interior node has a
singular P; its μ stays an unknown of the interface system, with the symmetric block
``[[K_BB, a_Bᵀ, 0], [a_B, 0, −1], [0, −1, 0]]`` over (T_B, μ, T_SN,i).

Memory is proportional to the clusters' sizes plus the interface fronts; nothing is n × n dense.  Each cluster
is condensed either by dense Cholesky (small or chunky clusters) or from the trailing factors of one SuperLU
factorisation (large shell-like clusters); see :class:`~fem2tmm.reduce.recovery.ClusterSolver` and the
constants below.  The interface unknowns are then removed by multifrontal elimination over a tree of clusters
(:mod:`fem2tmm.reduce.frontal`), which is the Guyan condensation done with dense BLAS-3 fronts.

On a Dask executor (:mod:`fem2tmm.compute`, ``[compute] scheduler``) the per-cluster step runs as tasks, each a
batch of contiguous clusters (:data:`BATCHES_PER_WORKER` per worker, about equal conduction entries) with only its
slices of the model's arrays; the client takes the results in cluster order and keeps factorisations under the
same budget as in process, so K_SN and the recovery operators are the same bits.  The multifrontal condensation
stays on the client.

The result is symmetrised and its diagonal reset to minus the off-diagonal row sum, so K_SN is exactly
symmetric with zero row sums; the raw asymmetry and row-sum residual are kept in ``diagnostics``.
"""

from __future__ import annotations

import pickle
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..arrays import unique
from ..compute import current
from ..errors import Fem2TmmError, format_ids
from ..fem.assembly import ElementCOO
from ..linalg import blas_threads
from ..progress import report as _report
from .frontal import ClusterTree, Frontal, elimination_nodes
from .recovery import Factor, GlobalOperator, LocalCluster, LocalOperator
from .supernodes import SuperNodes

#: interior-node count from which a cluster is always condensed by SuperLU (dense K_II: 8·nI² bytes)
DENSE_BELOW = 8000
#: shell-like clusters (nB + 1 ≤ SPARSE_RATIO · nI) of at least SPARSE_FROM interior nodes are condensed by
#: SuperLU, chunky (solid) ones by dense Cholesky; shells go to SuperLU from 300 nodes because its kept factors
#: are much smaller, so recovery stays cheap (measurements: docs/design-notes.md, reduce/conduction.py).
SPARSE_FROM = 300
SPARSE_RATIO = 0.35
#: memory (MiB) up to which per-cluster factorisations are kept for distribute / recover
FACTOR_MEMORY_MB = 1024.0
#: number of right-hand sides solved at once by the global method (memory n × batch doubles)
BATCH = 256
#: Dask tasks of the local step per worker (batches of contiguous clusters, about equal conduction entries)
BATCHES_PER_WORKER = 4
#: BLAS threads used inside the reduction.  One thread: the dense work is many mid-size factorisations, and
#: OpenBLAS's threads collapse when other processes hold the cores (measurements: docs/design-notes.md,
#: reduce/conduction.py).
BLAS_THREADS = 1


_TRIM = []


def release_freed_memory() -> None:
    """Give freed heap pages back to the OS (glibc ``malloc_trim``; no-op elsewhere).

    The local loop frees a large temporary SuperLU factor per cluster between the small factors it keeps; glibc
    then serves later temporaries from a fragmented heap that never shrinks; a trim after each cluster halves
    the peak RSS (measurements: docs/design-notes.md, reduce/conduction.py).
    """
    if not _TRIM:
        try:
            import ctypes
            import ctypes.util

            _TRIM.append(ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim)
        except (OSError, AttributeError, TypeError):
            _TRIM.append(None)
    if _TRIM[0] is not None:
        _TRIM[0](0)


@dataclass(frozen=True)
class ConductiveReduction:
    """Reduced conduction matrix and the operators to distribute loads and recover temperatures.

    ``K`` (n_SN, n_SN) dense W/K, symmetric, zero row sums (off-diagonal entries may be positive: negative GL);
    ``method`` "local" | "global"; ``supernodes`` the :class:`SuperNodes` it was built for;
    ``diagnostics`` dict: ``asymmetry`` and ``rowsum_residual`` of the raw result (max abs / max diagonal),
    ``n_interface`` (interface DOFs), ``n_condensed`` (unknowns removed by Guyan condensation),
    ``factor_bytes`` (memory of the kept factorisations), ``cluster_solvers`` (local method: count per
    :class:`~fem2tmm.reduce.recovery.ClusterSolver` kind), ``tasks`` (local method: the Dask tasks of the
    per-cluster step, 0 when it ran in this process), ``clusters_seconds`` (its wall time), ``blas_threads``,
    ``seconds``.
    """

    K: np.ndarray
    method: str
    supernodes: SuperNodes
    operator: GlobalOperator | LocalOperator = field(repr=False)
    diagnostics: dict = field(default_factory=dict)

    @property
    def n_sn(self) -> int:
        return self.K.shape[0]

    @property
    def n_dof(self) -> int:
        return self.supernodes.n_dof

    def distribute(self, q: np.ndarray) -> np.ndarray:
        """Super-node loads ``q_SN = Y q``: q (n_dof,) or (n_dof, r) W → (n_SN,) or (n_SN, r) W.

        Exact for any load in linear conduction: ``K_SN T_SN = Y q`` has the super-node averages of the detailed
        solution as its solution.  A load distributed like A (``q = Aᵀ v``) gives back v.
        """
        with blas_threads(self.diagnostics.get("blas_threads")):
            return self.operator.distribute(q)

    def recover(self, T_sn: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Detailed temperatures ``T = X q + Yᵀ T_SN``: T_SN (n_SN,) or (n_SN, r) K, q (n_dof[, r]) W → (n_dof[, r]) K.

        With the q that was distributed this is the exact detailed solution; without q (or q = Aᵀ q_SN, since
        X Aᵀ = 0) it is the field of least conduction energy with the given super-node averages.
        """
        with blas_threads(self.diagnostics.get("blas_threads")):
            return self.operator.recover(T_sn, q)


def _finish(raw: np.ndarray, zero_row_sums: bool = True) -> tuple[np.ndarray, dict]:
    """Symmetrise, reset the diagonal to zero row sums (unless ``zero_row_sums`` is False: an operator with
    conductances to ground, see :mod:`.radiative`), and measure how far the raw matrix was from that."""
    scale = max(float(np.abs(np.diag(raw)).max(initial=0.0)), np.finfo(float).tiny)
    diag = {"asymmetry": float(np.abs(raw - raw.T).max(initial=0.0) / scale)}
    K = 0.5 * (raw + raw.T)
    if not zero_row_sums:
        return K, diag
    diag["rowsum_residual"] = float(np.abs(raw.sum(axis=1)).max(initial=0.0) / scale)
    np.fill_diagonal(K, 0.0)
    np.fill_diagonal(K, -K.sum(axis=1))
    return K, diag


def _check_coo(coo: ElementCOO, n_dof: int) -> None:
    if coo.rows.size and (min(coo.rows.min(), coo.cols.min()) < 0 or max(coo.rows.max(), coo.cols.max()) >= n_dof):
        raise Fem2TmmError(f"conduction entries refer to DOFs outside 0..{n_dof - 1}; renumber them like the cells")


def _global(coo: ElementCOO, sn: SuperNodes, batch: int):
    n, ns = sn.n_dof, sn.n_sn
    K = coo.tocsr(n)
    M = sp.bmat([[K, sn.A.T], [sn.A, None]], format="csc")
    lu = Factor(M, dense=False, what="saddle matrix [[K, Aᵀ], [A, 0]]")
    raw = np.empty((ns, ns))
    for j0 in range(0, ns, batch):
        j1 = min(j0 + batch, ns)
        rhs = np.zeros((n + ns, j1 - j0))
        rhs[n + np.arange(j0, j1), np.arange(j1 - j0)] = 1.0
        raw[:, j0:j1] = -lu.solve(rhs)[n:]
    return raw, GlobalOperator(lu, n, ns), {"n_interface": 0, "n_condensed": n,
                                           "factor_bytes": lu.nbytes}


def _entry_clusters(coo: ElementCOO, labels: np.ndarray, elements: np.ndarray | None) -> np.ndarray:
    labels = np.asarray(labels, np.int64)
    m = labels.shape[0]
    elements = np.arange(m) if elements is None else np.asarray(elements, np.int64)
    if elements.shape != (m,):
        raise Fem2TmmError(f"elements has shape {elements.shape}; expected ({m},) like labels")
    size = int(max(coo.elem.max(initial=-1), elements.max(initial=-1))) + 1
    row_of = np.full(size, -1, np.int64)
    row_of[elements] = np.arange(m)
    r = row_of[coo.elem]
    missing = unique(coo.elem[r < 0])
    if missing.size:
        raise Fem2TmmError(f"conduction entries of elements {format_ids(missing)} have no cluster label; "
                           "pass the labels of every element of the thermal model")
    return labels[r]


def _floating(rows: np.ndarray, cols: np.ndarray, iface: np.ndarray, p_cl: np.ndarray, p_node: np.ndarray,
              nc: int) -> np.ndarray:
    """(nc,) bool: True for the clusters where some interior node is not connected to any of their interface nodes
    through their own conduction entries (``rows``, ``cols`` (nnz,) DOFs of all entries; ``iface`` (n,) bool;
    ``p_cl``, ``p_node`` (p,) the (cluster, node) pairs).

    One graph for all clusters: the entries that touch an interior node (an interior node's entries are all its own
    cluster's), without the interface-interface ones.  A component that holds no interface node is then the interior
    nodes of one cluster cut off from its interface."""
    n = iface.size
    keep = ~(iface[rows] & iface[cols])
    g = sp.csr_matrix((np.ones(int(keep.sum()), np.int8), (rows[keep], cols[keep])), shape=(n, n))
    n_comp, comp = connected_components(g, directed=False)
    anchored = np.zeros(n_comp, bool)
    anchored[comp[iface]] = True
    inner = ~iface[p_node]
    out = np.zeros(nc, bool)
    out[p_cl[inner][~anchored[comp[p_node[inner]]]]] = True
    return out


class _Parts:
    """The local reduction's inputs, sorted by cluster, cut into the contiguous cluster ranges that the loop
    (:func:`_condense_clusters`) takes: ``p_node`` (p,) the nodes of each cluster (``p_start`` (nc+1,) offsets),
    ``iface`` / ``kidx`` (n,) interface flag and K* index of each DOF, ``A`` (nc, n) CSR super-node weights,
    ``rows_s`` / ``cols_s`` / ``vals_s`` (nnz,) the conduction entries by cluster (``e_start`` (nc+1,) offsets),
    ``floating`` / ``mu_of`` (nc,) per cluster."""

    def __init__(self, n, p_node, p_start, iface, kidx, A, e_start, rows_s, cols_s, vals_s, floating, mu_of):
        self.n, self.p_node, self.p_start, self.iface, self.kidx, self.A = n, p_node, p_start, iface, kidx, A
        self.e_start, self.rows_s, self.cols_s, self.vals_s = e_start, rows_s, cols_s, vals_s
        self.floating, self.mu_of = floating, mu_of

    def part(self, c0: int, c1: int, copy: bool = True) -> dict:
        """Clusters ``c0 … c1-1``: their slices, with node and entry offsets from 0 (copies unless ``copy`` is
        False: a task's data, not views of the whole model's arrays)."""
        c0, c1 = int(c0), int(c1)
        take = np.copy if copy else (lambda x: x)
        p0, p1 = self.p_start[c0], self.p_start[c1]
        e0, e1 = self.e_start[c0], self.e_start[c1]
        a0, a1 = self.A.indptr[c0], self.A.indptr[c1]
        nodes = take(self.p_node[p0:p1])
        return {"first": c0, "n": self.n, "nodes": nodes, "p_start": self.p_start[c0:c1 + 1] - p0,
                "inner": ~self.iface[nodes], "knodes": self.kidx[nodes],
                "a_start": self.A.indptr[c0:c1 + 1] - a0, "a_idx": take(self.A.indices[a0:a1]),
                "a_val": take(self.A.data[a0:a1]), "e_start": self.e_start[c0:c1 + 1] - e0,
                "rows": take(self.rows_s[e0:e1]), "cols": take(self.cols_s[e0:e1]), "vals": take(self.vals_s[e0:e1]),
                "floating": take(self.floating[c0:c1]), "mu_of": take(self.mu_of[c0:c1])}


def _condense_clusters(part: dict, dense_below: int, keep, report: bool = False) -> list:
    """The local step for the clusters of ``part`` (:meth:`_Parts.part`), in order: a list of ``(cl, gidx, blk,
    nbytes, None)`` per cluster, ``cl`` its :class:`~fem2tmm.reduce.recovery.LocalCluster`, ``blk`` its K*ᵢ
    over the K* unknowns ``gidx`` and ``nbytes`` its factorisation's memory; ``keep(cl, solver)`` decides whether
    the cluster keeps its factorisation.  ``report``: progress per cluster."""
    first, nc = part["first"], part["p_start"].size - 1
    nodes_all, inner_all, knodes, p_start = part["nodes"], part["inner"], part["knodes"], part["p_start"]
    a_start, a_idx_all, a_val_all = part["a_start"], part["a_idx"], part["a_val"]
    e_start, rows_s, cols_s, vals_s = part["e_start"], part["rows"], part["cols"], part["vals"]
    loc = np.full(part["n"], -1, np.int64)
    out = []
    for k in range(nc):
        c = first + k
        if report:
            _report(c, nc, "clusters reduced")
        ps = slice(p_start[k], p_start[k + 1])
        nodes, inner = nodes_all[ps], inner_all[ps]
        I, B = nodes[inner], nodes[~inner]
        nI, nB = I.size, B.size
        kB = knodes[ps][~inner]
        loc[I] = np.arange(nI)
        loc[B] = nI + np.arange(nB)
        a_idx = a_idx_all[a_start[k]:a_start[k + 1]]
        if np.any(loc[a_idx] < 0):
            raise Fem2TmmError(f"cluster {c}: the super-node weights use DOFs that none of its conduction entries "
                               "touch; build A and the conduction matrices from the same cells")
        a = np.zeros(nI + nB)
        a[loc[a_idx]] = a_val_all[a_start[k]:a_start[k + 1]]
        s = slice(e_start[k], e_start[k + 1])
        li, lj, v = loc[rows_s[s]], loc[cols_s[s]], vals_s[s]
        loc[nodes] = -1
        bb = (li >= nI) & (lj >= nI)
        KBB = np.bincount((li[bb] - nI) * nB + (lj[bb] - nI), weights=v[bb], minlength=nB * nB).reshape(nB, nB)
        nbytes = 0
        if nI:
            ii = (li < nI) & (lj < nI)
            ib = (li < nI) & (lj >= nI)
            ar = np.arange(nI)
            P = sp.csc_matrix((np.concatenate([v[ii], a[:nI], a[:nI]]),
                               (np.concatenate([li[ii], ar, np.full(nI, nI)]),
                                np.concatenate([lj[ii], np.full(nI, nI), ar]))), shape=(nI + 1, nI + 1))
            C = sp.csr_matrix((np.concatenate([v[ib], a[nI:]]),
                               (np.concatenate([li[ib], np.full(nB, nI)]),
                                np.concatenate([lj[ib] - nI, np.arange(nB)]))), shape=(nI + 1, nB))
            if part["floating"][k]:
                kind = "sparse_lu" if nI >= dense_below else "lu"
            elif nI >= dense_below or (nI >= SPARSE_FROM and nB + 1 <= SPARSE_RATIO * nI):
                kind = "sparse"
            else:
                kind = "cholesky"
            cl = LocalCluster(sn=c, I=I, B=B, kB=kB, P=P, C=C, kind=kind)
            solver = cl.solver()
            blk = solver.condensed(C, KBB)
            cl.kind = solver.kind
            nbytes = solver.nbytes
            keep(cl, solver)
            del solver
            gidx = np.concatenate([cl.kB, [c]])
        else:
            cl = LocalCluster(sn=c, I=I, B=B, kB=kB, P=None, C=None, kind="none", mu=int(part["mu_of"][k]))
            blk = np.zeros((nB + 2, nB + 2))
            blk[:nB, :nB] = 0.5 * (KBB + KBB.T)
            blk[:nB, nB] = blk[nB, :nB] = a
            blk[nB, nB + 1] = blk[nB + 1, nB] = -1.0
            gidx = np.concatenate([cl.kB, [cl.mu, c]])
        out.append((cl, gidx, blk, nbytes, None))
        if nI >= SPARSE_FROM:
            release_freed_memory()
    return out


def _condense_batch(part: dict, dense_below: int, budget: float, blas: int | None) -> list:
    """One Dask task of the local step: :func:`_condense_clusters` on ``part`` with ``blas`` BLAS threads (as on
    the client, so the same bits), each factorisation that could fit the ``budget`` (bytes) returned pickled in
    the last field, unpickled on the client only where the serial path would keep it."""
    blobs = {}

    def keep(cl, solver):
        if solver.nbytes <= budget:
            blobs[cl.sn] = pickle.dumps(solver, protocol=pickle.HIGHEST_PROTOCOL)

    with blas_threads(blas):
        out = _condense_clusters(part, dense_below, keep)
    return [(cl, gidx, blk, nbytes, blobs.get(cl.sn)) for cl, gidx, blk, nbytes, _ in out]


def _local(coo: ElementCOO, sn: SuperNodes, labels, elements, dense_below: int, factor_memory_mb: float,
           blas: int | None):
    n, ns, nc = sn.n_dof, sn.n_sn, sn.n_clusters
    ec = _entry_clusters(coo, labels, elements)
    if ec.size and ec.max() >= nc:
        raise Fem2TmmError(f"cluster labels go up to {ec.max()} but the super nodes have {nc} clusters")

    # nodes of each cluster from the diagonal entries (every element node has one), sorted by cluster
    d = coo.rows == coo.cols
    key = unique(ec[d] * n + coo.rows[d])
    p_cl, p_node = key // n, key % n
    n_touch = np.bincount(p_node, minlength=n)
    is_one = np.zeros(n, bool)
    is_one[sn.dof[sn.one_node]] = True
    iface = (n_touch > 1) | is_one
    if not np.array_equal(iface, sn.interface):
        bad = np.flatnonzero(iface != sn.interface)
        raise Fem2TmmError(f"the conduction entries and the super-node definition disagree on which clusters touch "
                           f"DOFs {format_ids(bad)}; build both from the same cells and labels")
    p_start = np.searchsorted(p_cl, np.arange(nc + 1))
    floating = _floating(coo.rows, coo.cols, iface, p_cl, p_node, nc)
    has_interior = np.zeros(nc, bool)
    has_interior[p_cl[~iface[p_node]]] = True

    # K* numbering: super nodes, then condensed interface DOFs, then multipliers of interior-less clusters
    kidx = np.full(n, -1, np.int64)
    kidx[sn.dof[sn.one_node]] = sn.one_node
    free = np.flatnonzero(iface & ~is_one)
    kidx[free] = ns + np.arange(free.size)
    mu_of = np.full(nc, -1, np.int64)
    no_int = np.flatnonzero(~has_interior)
    mu_of[no_int] = ns + free.size + np.arange(no_int.size)
    n_star = ns + free.size + no_int.size

    order = np.argsort(ec, kind="stable")
    e_start = np.searchsorted(ec[order], np.arange(nc + 1))
    rows_s, cols_s, vals_s = coo.rows[order], coo.cols[order], coo.vals[order]
    del order
    budget = factor_memory_mb * 2 ** 20
    t0 = time.perf_counter()
    parts = _Parts(n, p_node, p_start, iface, kidx, sn.A, e_start, rows_s, cols_s, vals_s, floating, mu_of)
    ex = current()
    if ex.distributed and nc > 1:  # batches of clusters as Dask tasks, their results taken in cluster order
        k = min(nc, BATCHES_PER_WORKER * max(ex.workers, 1))
        cuts = np.unique(np.concatenate([[0], np.searchsorted(e_start, np.arange(1, k) * (e_start[-1] / k)), [nc]]))
        items = [parts.part(c0, c1) for c0, c1 in zip(cuts[:-1], cuts[1:])]
        del parts, rows_s, cols_s, vals_s
        results = [r for batch in ex.map(_condense_batch, items, shared={"dense_below": dense_below, "budget": budget,
                                                                          "blas": blas}, what="cluster batches")
                   for r in batch]
        tasks, kept_bytes = len(items), 0
        del items
        for cl, _, _, nbytes, blob in results:  # the serial path's budget, in cluster order
            if blob is not None and kept_bytes + nbytes <= budget:
                cl._solver = pickle.loads(blob)
                kept_bytes += nbytes
    else:
        tasks, state = 0, {"kept": 0}

        def keep(cl, solver):  # kept while the total stays within the budget, in cluster order
            if state["kept"] + solver.nbytes <= budget:
                cl._solver = solver
                state["kept"] += solver.nbytes

        results = _condense_clusters(parts.part(0, nc, copy=False), dense_below, keep, report=True)
        _report(nc, nc, "clusters reduced")  # (each cluster is reported as it starts: this is the last one's end)
        # the sorted copy of the conduction entries, before the interface condensation (the reduction's memory peak:
        # 3 x 8 bytes per entry, 0.41 GB at 1.07·10⁶ quads)
        del parts, rows_s, cols_s, vals_s
    t_clusters = time.perf_counter() - t0
    blocks, clusters, multipliers = [], [], {}
    for cl, gidx, blk, _, _ in results:
        blocks.append((gidx, blk))
        clusters.append(cl)
        if cl.mu >= 0:
            multipliers[cl.mu] = cl.kB[cl.kB >= ns]
    del results

    # tree of clusters from the interface unknowns they share, then multifrontal condensation
    var = np.concatenate([g for g, _ in blocks]) if blocks else np.zeros(0, np.int64)
    owner = np.repeat(np.arange(nc), [g.size for g, _ in blocks])
    cond = var >= ns
    inc = sp.csr_matrix((np.ones(int(cond.sum())), (var[cond] - ns, owner[cond])), shape=(n_star - ns, nc))
    adj = (inc.T @ inc).tocsr()
    adj.setdiag(0)
    adj.eliminate_zeros()
    tree = ClusterTree(adj)
    elim = elimination_nodes(tree, var[cond], owner[cond], n_star, ns, multipliers)
    frontal = Frontal(blocks, tree, elim, ns,
                      what="interface system of the local reduction (the super nodes do not determine the "
                           "interface temperatures)")
    del blocks
    op = LocalOperator(clusters, kidx, ns, n_star, frontal)
    kinds = [cl.kind for cl in clusters]
    return frontal.K, op, {"n_interface": int(np.count_nonzero(iface)), "n_condensed": int(n_star - ns),
                           "factor_bytes": op.factor_nbytes, "tasks": tasks,
                           "clusters_seconds": t_clusters,
                           "cluster_solvers": {k: kinds.count(k) for k in sorted(set(kinds))}}


def reduce_conduction(coo: ElementCOO, supernodes: SuperNodes, labels: np.ndarray,
                      elements: np.ndarray | None = None, method: str = "local", *,
                      dense_below: int = DENSE_BELOW, factor_memory_mb: float = FACTOR_MEMORY_MB,
                      batch: int = BATCH, blas: int | None = BLAS_THREADS,
                      zero_row_sums: bool = True) -> ConductiveReduction:
    """Reduced conduction matrix between super nodes, ``K_SN = (A K⁺ Aᵀ)⁻¹``.

    Parameters
    ----------
    coo : element conduction matrices (W/K) in DOF numbering; ``coo.tocsr(n_dof)`` is K.
    supernodes : from :func:`~fem2tmm.reduce.supernodes.build_supernodes` over the same cells and labels.
    labels : (m,) cluster id of each model element (as given to ``build_supernodes``).
    elements : (m,) the global element index (``coo.elem`` value) of each row of ``labels``; default 0 … m−1.
    method : "local" (default; per-cluster condensation + Guyan) or "global" (sparse LU of M; reference).
    dense_below : interior-node count from which every cluster is condensed by SuperLU instead of dense
        LAPACK (local method; 0 forces SuperLU everywhere).
    factor_memory_mb : per-cluster factorisations are kept, for fast ``distribute`` / ``recover``, while their
        total stays under this many MiB; the others are recomputed at each call (local method).
    batch : right-hand sides solved at once by the global method (memory ``batch × n`` doubles).
    blas : BLAS threads during the reduction and in ``distribute`` / ``recover`` (None: leave as is).
    zero_row_sums : reset K_SN's diagonal so that its rows sum to zero exactly (a conduction matrix); False
        for an operator with conductances to ground such as ``K + diag(h)`` (:mod:`.radiative`).

    Returns
    -------
    ConductiveReduction with ``K`` (n_SN, n_SN) W/K and ``distribute`` / ``recover``.
    """
    if method not in ("local", "global"):
        raise Fem2TmmError(f"reduction method {method!r} is unknown; use 'local' or 'global'")
    _check_coo(coo, supernodes.n_dof)
    t0 = time.perf_counter()
    with blas_threads(blas):
        if method == "global":
            raw, op, info = _global(coo, supernodes, batch)
        else:
            raw, op, info = _local(coo, supernodes, labels, elements, dense_below, factor_memory_mb, blas)
    K, diag = _finish(raw, zero_row_sums)
    diag.update(info)
    diag["blas_threads"] = blas
    diag["seconds"] = time.perf_counter() - t0
    return ConductiveReduction(K=K, method=method, supernodes=supernodes, operator=op, diagnostics=diag)


__all__ = ["ConductiveReduction", "reduce_conduction", "DENSE_BELOW"]
