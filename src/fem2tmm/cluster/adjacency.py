"""Dual graph of a part: which elements share an edge (shells) or a face (solids).

Shell elements are linked through a mesh edge shared by exactly two of them; an edge shared by more
than two elements is a *junction* and links nobody (the regions stop there).  Solid elements are
linked through a face (matched as the sorted tuple of its nodes, triangles and quadrangles apart)
shared by exactly two of them.  Everything is vectorised: sides are keyed, sorted once and split
into runs of equal keys.

Indices in this module are *local* to the part (0..m-1) unless said otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..mesh.elements import ELEMENT_TYPES, SHELL_EDGES, SOLID_FACES, TYPE_CODE


@dataclass(frozen=True)
class DualGraph:
    """Links between elements of one part.

    Attributes
    ----------
    a, b : (p,) int64
        The two elements of each link (a < b).
    measure : (p,) float64
        Length of the shared edge (shells, m) or area of the shared face (solids, m²).
    consistent : (p,) bool
        Shells: True when both elements run through the shared edge in opposite directions, i.e. their
        right-hand normals are consistently oriented across it.  Solids: all True.
    side_total : (m,) float64
        Sum of the edge lengths (m) / face areas (m²) of each element: ``side_total - 2·Σ kept links``
        summed over a region gives its perimeter (surface).
    shared : (m,) bool
        The element shares at least one edge (face) with another element of the part, junctions included.
    n_junctions : int
        Number of shell edges shared by more than two elements (non-manifold faces for solids).
    """

    a: np.ndarray
    b: np.ndarray
    measure: np.ndarray
    consistent: np.ndarray
    side_total: np.ndarray
    shared: np.ndarray
    n_junctions: int


def _runs(sorted_keys: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Start index and length of each run of equal rows in lexicographically sorted key columns."""
    n = len(sorted_keys[0])
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    new = np.zeros(n, bool)
    new[0] = True
    for k in sorted_keys:
        new[1:] |= k[1:] != k[:-1]
    starts = np.flatnonzero(new)
    return starts, np.diff(np.append(starts, n))


def _sides(points: np.ndarray, cells: np.ndarray, types: np.ndarray, kind: str):
    """All sides (edges of shells, faces of solids) of all elements.

    Returns ``(nodes, elem, measure, forward)``: nodes (s, 4) int64 sorted node indices padded with -1
    at the front, elem (s,) owning element, measure (s,) length or area, forward (s,) bool (shells: the
    element runs through the edge from its smaller to its larger node).
    """
    out_nodes, out_elem, out_meas, out_fwd = [], [], [], []
    for t in ELEMENT_TYPES:
        sel = np.flatnonzero(types == TYPE_CODE[t])
        if len(sel) == 0:
            continue
        c = cells[sel]
        if kind == "line":  # bars meet at nodes: the "side" is an end node, of unit measure
            for i in range(2):
                nodes = np.full((len(sel), 4), -1, np.int64)
                nodes[:, 3] = c[:, i]
                out_nodes.append(nodes)
                out_elem.append(sel)
                out_meas.append(np.ones(len(sel)))
                out_fwd.append(np.ones(len(sel), bool))
        elif kind == "shell":
            for i, j in SHELL_EDGES[t]:
                p, q = c[:, i], c[:, j]
                nodes = np.full((len(sel), 4), -1, np.int64)
                nodes[:, 2] = np.minimum(p, q)
                nodes[:, 3] = np.maximum(p, q)
                out_nodes.append(nodes)
                out_elem.append(sel)
                out_meas.append(np.linalg.norm(points[p] - points[q], axis=1))
                out_fwd.append(p < q)
        else:
            for face in SOLID_FACES[t]:
                f = c[:, list(face)]
                nodes = np.full((len(sel), 4), -1, np.int64)
                nodes[:, 4 - len(face):] = np.sort(f, axis=1)
                X = points[f]
                if len(face) == 3:
                    area = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
                else:  # vector area of a (possibly warped) quadrangle
                    area = 0.5 * np.linalg.norm(np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1]), axis=1)
                out_nodes.append(nodes)
                out_elem.append(sel)
                out_meas.append(area)
                out_fwd.append(np.ones(len(sel), bool))
    if not out_nodes:
        z = np.zeros(0, np.int64)
        return np.zeros((0, 4), np.int64), z, np.zeros(0), np.zeros(0, bool)
    return (np.concatenate(out_nodes), np.concatenate(out_elem), np.concatenate(out_meas),
            np.concatenate(out_fwd))


def dual_graph(points: np.ndarray, cells: np.ndarray, types: np.ndarray, kind: str) -> DualGraph:
    """Build the :class:`DualGraph` of one part.

    ``points`` (n, 3) m; ``cells`` (m, 8) int64 node indices padded with -1; ``types`` (m,) int8 type
    codes; ``kind`` "shell" (link through edges), "solid" (link through faces) or "line" (bars linked
    through an end node shared by exactly two of them; a node shared by more is a junction).
    """
    m = len(cells)
    nodes, elem, meas, fwd = _sides(points, cells, types, kind)
    side_total = np.bincount(elem, meas, minlength=m)
    cols = [nodes[:, i] for i in range(4)]
    order = np.lexsort(cols[::-1])
    starts, counts = _runs([k[order] for k in cols])
    pairs = starts[counts == 2]
    i, j = order[pairs], order[pairs + 1]
    ea, eb = elem[i], elem[j]
    a, b = np.minimum(ea, eb), np.maximum(ea, eb)
    # an element meeting itself (a degenerate cell, rejected earlier by the driver) is not a link
    ok = a != b
    a, b = a[ok], b[ok]
    measure = meas[i][ok]
    consistent = (fwd[i] != fwd[j])[ok] if kind == "shell" else np.ones(len(a), bool)
    multi = np.repeat(counts >= 2, counts)
    shared = np.zeros(m, bool)
    shared[elem[order[multi]]] = True
    o = np.lexsort((b, a))
    return DualGraph(a=a[o], b=b[o], measure=measure[o], consistent=consistent[o], side_total=side_total,
                     shared=shared, n_junctions=int(np.count_nonzero(counts > 2)))


def to_csr(n: int, a: np.ndarray, b: np.ndarray, data: np.ndarray) -> sp.csr_matrix:
    """Symmetric (n, n) CSR matrix with ``data`` on (a, b) and (b, a); rows sorted, duplicates summed."""
    g = sp.csr_matrix((np.concatenate([data, data]), (np.concatenate([a, b]), np.concatenate([b, a]))),
                      shape=(n, n))
    g.sum_duplicates()
    g.sort_indices()
    return g


def gather_rows(indptr: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions in a CSR ``indices``/``data`` array of all entries of ``rows``, and the row of each.

    Returns ``(pos, owner)``: ``pos`` (q,) int64 positions, ``owner`` (q,) index into ``rows``.
    Cost O(len(rows) + q), independent of the matrix size.
    """
    rows = np.asarray(rows, np.int64)
    start = indptr[rows].astype(np.int64)
    deg = indptr[rows + 1].astype(np.int64) - start
    owner = np.repeat(np.arange(len(rows)), deg)
    first = np.cumsum(deg) - deg
    pos = np.arange(int(deg.sum()), dtype=np.int64) - np.repeat(first, deg) + np.repeat(start, deg)
    return pos, owner


def induced_csr(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray, nodes: np.ndarray,
                scratch: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The subgraph on ``nodes`` of a CSR graph, numbered 0..len(nodes)-1 in the order of ``nodes``.

    ``scratch`` is an (n,) int64 array of -1 of the full graph's size; it is used and restored, so
    that the cost is O(size of the subgraph) rather than O(n).  Returns ``(indptr, indices, data)``.
    """
    scratch[nodes] = np.arange(len(nodes))
    pos, owner = gather_rows(indptr, nodes)
    col = scratch[indices[pos]]
    keep = col >= 0
    scratch[nodes] = -1
    counts = np.bincount(owner[keep], minlength=len(nodes))
    sub_ptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return sub_ptr, col[keep], data[pos[keep]]


def is_connected(indptr: np.ndarray, indices: np.ndarray, nodes: np.ndarray, scratch: np.ndarray) -> bool:
    """True if ``nodes`` (non-empty) form one connected piece of the CSR graph (see :func:`induced_csr`)."""
    from scipy.sparse.csgraph import breadth_first_order

    if len(nodes) <= 1:
        return len(nodes) == 1
    ptr, ind, _ = induced_csr(indptr, indices, np.zeros(len(indices)), nodes, scratch)
    g = sp.csr_matrix((np.ones(len(ind), np.int8), ind, ptr), shape=(len(nodes), len(nodes)))
    return len(breadth_first_order(g, 0, directed=True, return_predecessors=False)) == len(nodes)
