"""Guyan condensation of the interface system by multifrontal elimination over a tree of clusters.

After the local step every cluster i contributes a small dense symmetric block K*ᵢ over its interface
unknowns and its super node (DESIGN §3.3).  Removing the interface unknowns (``K_SN = K*_SS − K*_SF K*_FF⁻¹
K*_FS``) with a general sparse solver means n_SN solves with a factor of K*_FF, slow at 10⁶ elements.  The
blocks behave like finite elements whose "elements" are clusters, so the classical multifrontal method
applies: a binary tree is built by recursive bisection of the cluster adjacency graph (nested dissection at the
cluster level); each tree node sums its children's dense update matrices, eliminates the unknowns whose
clusters all lie below it (every cluster touching them has been summed), and passes the Schur complement on
the rest to its parent.  Super-node unknowns are never eliminated; at the root the front is K_SN.  All work is
dense LAPACK/BLAS on fronts whose size is a separator plus the super nodes below, so the cost is a few dense
factorisations of the top separators — the result is exact, the same as any other elimination order.

The eliminated blocks are nonsingular: without multipliers the interface block is positive definite (fixing all
super-node averages leaves no free temperature), and a cluster without interior node has its multiplier
eliminated only where all its condensed interface nodes are eliminated (a constraint with a non-zero row on a
positive definite block).

The stored factors of each eliminated block (see :class:`_Front`) give forward / backward solves for the
power distribution and the temperature recovery.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numba import njit
from scipy.sparse.csgraph import connected_components, shortest_path

from ..arrays import unique
from ..errors import Fem2TmmError, InternalError

#: largest sub-graph bisected with a dense eigensolver (spectral); larger ones use breadth-first levels
SPECTRAL_MAX = 2500


@njit(cache=True, nogil=True)
def _scatter_add(F: np.ndarray, p: np.ndarray, val: np.ndarray) -> None:
    """``F[np.ix_(p, p)] += val`` in place without the (k, k) temporaries (``p`` distinct indices); the same single
    addition per entry, so the same bits."""
    k = p.size
    for i in range(k):
        pi = p[i]
        for j in range(k):
            F[pi, p[j]] += val[i, j]


def _bisect(W: sp.csr_matrix) -> np.ndarray:
    """Boolean (g,) side of each vertex of a weighted graph: balanced halves with a small cut."""
    g = W.shape[0]
    n_comp, comp = connected_components(W, directed=False)
    if n_comp > 1:  # whole components to the lighter side, largest first
        sizes = np.bincount(comp)
        side_of = np.zeros(n_comp, bool)
        load = [0, 0]
        for c in np.argsort(-sizes, kind="stable"):
            s = int(load[1] < load[0])
            side_of[c] = bool(s)
            load[s] += sizes[c]
        return side_of[comp]
    if g <= SPECTRAL_MAX:
        Wd = W.toarray()
        L = np.diag(Wd.sum(axis=1)) - Wd
        key = np.linalg.eigh(L)[1][:, 1]  # Fiedler vector
    else:  # level structure from a pseudo-peripheral vertex
        d = shortest_path(W, unweighted=True, indices=0)
        far = int(np.argmax(d))
        key = shortest_path(W, unweighted=True, indices=far)
    side = np.zeros(g, bool)
    side[np.argsort(key, kind="stable")[g // 2:]] = True
    return side


class ClusterTree:
    """Binary tree over clusters by recursive bisection; node ranges are contiguous in ``perm``.

    ``perm`` (nc,) clusters in leaf order; ``lo``, ``hi`` (n_nodes,) position range of each node;
    ``left``, ``right`` (n_nodes,) children (−1 at leaves); node 0 is the root; nodes are numbered in
    preorder, so processing them in reverse order visits children before parents.
    """

    def __init__(self, adjacency: sp.csr_matrix):
        nc = adjacency.shape[0]
        self.perm = np.empty(nc, np.int64)
        lo, hi, left, right = [], [], [], []
        stack = [(np.arange(nc), 0, -1, 0)] if nc else []  # (clusters, start position, parent, which child)
        while stack:
            ids, start, parent, which = stack.pop()
            t = len(lo)
            lo.append(start)
            hi.append(start + ids.size)
            left.append(-1)
            right.append(-1)
            if parent >= 0:
                (left if which == 0 else right)[parent] = t
            if ids.size == 1:
                self.perm[start] = ids[0]
                continue
            side = _bisect(adjacency[ids][:, ids])
            a, b = ids[~side], ids[side]
            stack.append((b, start + a.size, t, 1))
            stack.append((a, start, t, 0))  # popped first: preorder numbering
        self.lo, self.hi = np.array(lo, np.int64), np.array(hi, np.int64)
        self.left, self.right = np.array(left, np.int64), np.array(right, np.int64)
        self.pos = np.empty(nc, np.int64)
        self.pos[self.perm] = np.arange(nc)
        self.leaf_of = np.empty(nc, np.int64)
        leaves = np.flatnonzero(self.left < 0)
        self.leaf_of[self.perm[self.lo[leaves]]] = leaves

    def lowest_common(self, pmin: np.ndarray, pmax: np.ndarray) -> np.ndarray:
        """Deepest node whose range holds positions pmin..pmax (arrays of the same shape)."""
        node = np.zeros(pmin.shape, np.int64)
        while True:
            moved = False
            for child in (self.left, self.right):
                c = child[node]
                ok = (c >= 0)
                cc = np.where(ok, c, 0)
                ok &= (self.lo[cc] <= pmin) & (pmax < self.hi[cc])
                if np.any(ok):
                    node = np.where(ok, cc, node)
                    moved = True
            if not moved:
                return node


class _Front:
    """Elimination of the block E from a front ``[[F_EE, F_ER], [F_RE, F_RR]]``.

    Positive definite F_EE (no multiplier): Cholesky ``F_EE = L Lᵀ``, ``V = L⁻¹ F_ER`` and the update
    ``F_RR − Vᵀ V``; otherwise LU with ``W = F_EE⁻¹ F_ER`` and ``F_RR − F_RE W``.  Keeps what the solves need.
    """

    def __init__(self, F: np.ndarray, e: int, what: str):
        FEE, FER = F[:e, :e], F[:e, e:]
        self.chol = True
        try:
            self.L = sla.cholesky(FEE, lower=True, check_finite=False)
            d = np.diag(self.L) ** 2
        except np.linalg.LinAlgError:
            self.chol = False
            self.lu = sla.lu_factor(FEE, check_finite=False)
            d = np.abs(np.diag(self.lu[0]))
        if not d.min() > 1e-14 * d.max():
            raise Fem2TmmError(f"{what} is singular at a front of {e} unknowns "
                               f"(smallest/largest pivot {d.min():.2e}/{d.max():.2e})")
        if self.chol:
            self.V = sla.solve_triangular(self.L, FER, lower=True, check_finite=False)
            U = F[e:, e:] - self.V.T @ self.V
        else:
            self.W = sla.lu_solve(self.lu, FER, check_finite=False)
            U = F[e:, e:] - F[e:, :e] @ self.W
        self.update = 0.5 * (U + U.T)

    def forward(self, bE: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(F_EE⁻¹ b_E, F_RE F_EE⁻¹ b_E)."""
        if self.chol:
            y = sla.solve_triangular(self.L, bE, lower=True, check_finite=False)
            return sla.solve_triangular(self.L, y, lower=True, trans="T", check_finite=False), self.V.T @ y
        return sla.lu_solve(self.lu, bE, check_finite=False), self.W.T @ bE

    def back(self, xR: np.ndarray) -> np.ndarray:
        """F_EE⁻¹ F_ER x_R."""
        if self.chol:
            return sla.solve_triangular(self.L, self.V @ xR, lower=True, trans="T", check_finite=False)
        return self.W @ xR

    @property
    def nbytes(self) -> int:
        return (self.L.nbytes + self.V.nbytes) if self.chol else (self.lu[0].nbytes + self.W.nbytes)


class Frontal:
    """Multifrontal elimination of the unknowns ≥ ``n_keep`` of a sum of dense symmetric blocks.

    ``blocks`` list over clusters of ``(idx (k,), values (k, k))``; ``tree`` a :class:`ClusterTree`;
    ``elim_node`` (n_star,) tree node at which each unknown is eliminated (−1 for kept unknowns < n_keep).
    After construction ``K`` (n_keep, n_keep) is the condensed matrix; ``forward`` / ``backward`` solve with it.
    Each front is ordered [eliminated E, remaining R] before assembly, so its blocks are contiguous.
    """

    def __init__(self, blocks, tree: ClusterTree, elim_node: np.ndarray, n_keep: int, what: str):
        self.n_keep = n_keep
        self.steps = []  # (E, R, _Front) in processing order
        self.nbytes = 0
        n_nodes = tree.lo.size
        members: list = [None] * n_nodes  # per pending node: list of (idx, values) still to be summed
        for c, (idx, val) in enumerate(blocks):
            members[tree.leaf_of[c]] = [(idx, val)]
        for t in range(n_nodes - 1, -1, -1):
            if tree.left[t] >= 0:
                parts = members[tree.left[t]] + members[tree.right[t]]
                members[tree.left[t]] = members[tree.right[t]] = None
            else:
                parts = members[t]
            front = unique(np.concatenate([idx for idx, _ in parts]))
            elim = elim_node[front] == t
            if not np.any(elim):  # nothing to eliminate here: pass the pieces up unsummed
                members[t] = parts
                continue
            E, R = front[elim], front[~elim]
            ordered = np.concatenate([E, R])
            rank = np.empty(front.size, np.int64)
            rank[np.concatenate([np.flatnonzero(elim), np.flatnonzero(~elim)])] = np.arange(front.size)
            F = np.zeros((front.size, front.size))
            for idx, val in parts:
                _scatter_add(F, rank[np.searchsorted(front, idx)], val)
            del parts
            e = E.size
            fr = _Front(F, e, what)
            del F
            members[t] = [(ordered[e:], fr.update)]
            fr.update = None
            self.steps.append((E, R, fr))
            self.nbytes += fr.nbytes
        parts = members[0] if n_nodes else []
        self.K = np.zeros((n_keep, n_keep))
        for idx, val in parts:
            if np.any(idx >= n_keep):
                raise InternalError(f"{what}: unknowns {idx[idx >= n_keep][:10]} were never eliminated")
            _scatter_add(self.K, idx, val)

    def forward(self, b: np.ndarray) -> np.ndarray:
        """In place on b (n_star, r): eliminated rows become F_EE⁻¹ b_E, kept rows b_S − K_SF K_FF⁻¹ b_F."""
        for E, R, fr in self.steps:
            b[E], upd = fr.forward(b[E])
            b[R] -= upd
        return b

    def backward(self, b: np.ndarray, x_keep: np.ndarray) -> np.ndarray:
        """Solution (n_star, r) of the eliminated unknowns from the forward result b and the kept values."""
        x = b.copy()
        x[:self.n_keep] = x_keep
        for E, R, fr in reversed(self.steps):
            x[E] -= fr.back(x[R])
        return x


def elimination_nodes(tree: ClusterTree, var: np.ndarray, cluster: np.ndarray, n_star: int, n_keep: int,
                      multipliers: dict[int, np.ndarray]) -> np.ndarray:
    """Tree node at which each unknown is eliminated (n_star,), −1 for the kept ones (< n_keep).

    ``var``, ``cluster`` (p,) pairs "unknown var appears in the block of cluster"; an unknown is eliminated at
    the lowest node holding all its clusters.  ``multipliers`` maps the unknown of a cluster without interior
    node to its condensed interface unknowns: it is eliminated where all of them are.
    """
    pos = tree.pos[cluster]
    pmin = np.full(n_star, np.iinfo(np.int64).max)
    pmax = np.full(n_star, -1)
    np.minimum.at(pmin, var, pos)
    np.maximum.at(pmax, var, pos)
    for mu, nodes in multipliers.items():
        pmin[mu] = min(pmin[mu], pmin[nodes].min(initial=pmin[mu]))
        pmax[mu] = max(pmax[mu], pmax[nodes].max(initial=pmax[mu]))
    node = np.full(n_star, -1, np.int64)
    f = np.arange(n_keep, n_star)
    node[f] = tree.lowest_common(pmin[f], pmax[f])
    return node


__all__ = ["ClusterTree", "Frontal", "elimination_nodes"]
