"""A lumped-parameter thermal network (LPM) as read from an ESATAN / SINDA deck or fem2tmm's ``reduced.npz``.

Nodes carry a number (the deck's), a label, a kind — ``D`` diffusion (C = 0: arithmetic), ``B`` boundary (fixed
temperature), ``X`` inactive (not part of the solution; its conductors are ignored) —, a temperature T (K: the
fixed value of a boundary node, the initial value otherwise), a capacitance C (J/K), an area A (m²), solar
absorptance ALP, IR emittance EPS and a dissipation QI (W).  Couplings are two sparse symmetric matrices with zero
diagonal: GL (W/K) and GR (m², ``σ·GR_ij·(T_i⁴ − T_j⁴)`` W).  Space, where it exists, is simply a boundary node
with GR couplings.  Coordinates (n, 3) m are optional (NaN rows: unknown), for the automatic grouping's sizing
matrix.

A load case (:class:`LoadCase`) replaces QI and the boundary temperatures (hot / cold cases of one network).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ..errors import Fem2TmmError, format_ids

KINDS = ("D", "B", "X")


def symmetric_couplings(n: int, a: np.ndarray, b: np.ndarray, g: np.ndarray) -> sp.csr_matrix:
    """Sparse symmetric (n, n) coupling matrix from pair lists: ``M_ab = M_ba = Σ g`` over repeated pairs.

    ``a``, ``b`` (k,) node indices (a ≠ b), ``g`` (k,) values.  Self couplings (a == b) are dropped (they carry no
    heat).  Duplicates are summed, as a thermal solver sums parallel conductors.
    """
    a = np.asarray(a, np.int64)
    b = np.asarray(b, np.int64)
    g = np.asarray(g, float)
    off = a != b
    a, b, g = a[off], b[off], g[off]
    M = sp.coo_matrix((np.r_[g, g], (np.r_[a, b], np.r_[b, a])), shape=(n, n)).tocsr()
    M.sum_duplicates()
    M.eliminate_zeros()
    return M


def couplings_from_lists(n: int, a: list, b: list, g: list) -> sp.csr_matrix:
    """:func:`symmetric_couplings` of lists of index / value arrays (as readers collect them line by line)."""
    cat = lambda v, dt: np.concatenate(v).astype(dt) if v else np.zeros(0, dt)  # noqa: E731
    return symmetric_couplings(n, cat(a, np.int64), cat(b, np.int64), cat(g, float))


def laplacian(G: sp.spmatrix) -> sp.csr_matrix:
    """``diag(G·1) − G`` (n, n): the conduction (or radiation) operator of a coupling matrix, zero row sums."""
    G = sp.csr_matrix(G)
    return (sp.diags(np.asarray(G.sum(axis=1)).ravel()) - G).tocsr()


@dataclass(frozen=True)
class LoadCase:
    """One steady load case: dissipation ``Q`` (n,) W on every node and temperatures ``T_boundary`` (n,) K (used on
    the boundary nodes only)."""

    name: str
    Q: np.ndarray
    T_boundary: np.ndarray


@dataclass(frozen=True)
class Network:
    """A thermal network; n nodes.  See the module docstring for the meaning and units of each field.

    ``numbers`` (n,) int64 unique; ``labels`` (n,) str; ``kind`` (n,) one of D/B/X; ``T``, ``C``, ``A``, ``alp``,
    ``eps``, ``QI`` (n,) float; ``GL``, ``GR`` (n, n) CSR symmetric, zero diagonal; ``coordinates`` (n, 3) m or
    None; ``source`` the file it came from (for messages); ``notes`` what the reader skipped or assumed.
    """

    numbers: np.ndarray
    labels: np.ndarray
    kind: np.ndarray
    T: np.ndarray
    C: np.ndarray
    A: np.ndarray
    alp: np.ndarray
    eps: np.ndarray
    QI: np.ndarray
    GL: sp.csr_matrix
    GR: sp.csr_matrix
    coordinates: np.ndarray | None = None
    source: str = "network"
    notes: tuple = field(default_factory=tuple)
    #: conductors GR(i, j) that follow node k's temperature: ``(i, j, k, x (m,) K, y (m,) m²)`` row indices and a
    #: table (piecewise linear, constant outside); their ``GR`` entry holds the value at the deck's T
    gr_tables: tuple = ()

    def __post_init__(self):
        n = len(self.numbers)
        for name in ("labels", "kind", "T", "C", "A", "alp", "eps", "QI"):
            if len(getattr(self, name)) != n:
                raise Fem2TmmError(f"{self.source}: network field {name} has {len(getattr(self, name))} entries "
                                   f"for {n} nodes")
        u, c = np.unique(self.numbers, return_counts=True)
        if (c > 1).any():
            raise Fem2TmmError(f"{self.source}: node numbers defined twice: {format_ids(u[c > 1])}")
        bad = ~np.isin(self.kind, KINDS)
        if bad.any():
            raise Fem2TmmError(f"{self.source}: nodes {format_ids(self.numbers[bad])} have an unknown kind "
                               f"{sorted(set(self.kind[bad]))} (expected D, B or X)")
        for name in ("GL", "GR"):
            M = getattr(self, name)
            if M.shape != (n, n):
                raise Fem2TmmError(f"{self.source}: {name} has shape {M.shape} for {n} nodes")

    # ------------------------------------------------------------------ basic views
    @property
    def n(self) -> int:
        return len(self.numbers)

    @property
    def boundary(self) -> np.ndarray:
        """(n,) bool: fixed-temperature nodes."""
        return self.kind == "B"

    def index(self, numbers, where: str = "") -> np.ndarray:
        """Row indices of node ``numbers``; one error listing every unknown number."""
        numbers = np.asarray(numbers, np.int64).ravel()
        order = np.argsort(self.numbers)
        pos = np.searchsorted(self.numbers, numbers, sorter=order)
        pos = np.minimum(pos, max(self.n - 1, 0))
        idx = order[pos] if self.n else np.zeros(0, np.int64)
        bad = (self.numbers[idx] != numbers) if self.n else np.ones(len(numbers), bool)
        if bad.any():
            raise Fem2TmmError(f"{where or self.source}: unknown node numbers {format_ids(np.unique(numbers[bad]))}")
        return idx

    def K(self) -> sp.csr_matrix:
        """Conduction matrix (n, n) W/K: ``diag(GL·1) − GL`` (symmetric, zero row sums)."""
        return laplacian(self.GL)

    def default_case(self, name: str = "deck") -> LoadCase:
        """The load case the deck itself defines: QI and the boundary nodes' T."""
        return LoadCase(name=name, Q=self.QI.astype(float).copy(), T_boundary=self.T.astype(float).copy())

    def active(self) -> "Network":
        """The network without its inactive (X) nodes and their conductors."""
        keep = self.kind != "X"
        if keep.all():
            return self
        idx = np.flatnonzero(keep)
        dropped_gl = int(self.GL[~keep].nnz)
        dropped_gr = int(self.GR[~keep].nnz)
        notes = self.notes + (f"{int((~keep).sum())} inactive (X) nodes left out with {dropped_gl} GL and "
                              f"{dropped_gr} GR couplings to them",)
        return self.subset(idx, notes=notes)

    def subset(self, idx: np.ndarray, notes: tuple | None = None) -> "Network":
        """The network restricted to rows ``idx`` (couplings to other nodes dropped)."""
        idx = np.asarray(idx, np.int64)
        take = lambda v: np.asarray(v)[idx]  # noqa: E731
        return replace(self, numbers=take(self.numbers), labels=take(self.labels), kind=take(self.kind),
                       T=take(self.T), C=take(self.C), A=take(self.A), alp=take(self.alp), eps=take(self.eps),
                       QI=take(self.QI), GL=self.GL[idx][:, idx].tocsr(), GR=self.GR[idx][:, idx].tocsr(),
                       coordinates=None if self.coordinates is None else self.coordinates[idx],
                       notes=self.notes if notes is None else notes)

    def with_coordinates(self, numbers, xyz, where: str = "coordinates") -> "Network":
        """A copy with node coordinates (m) set for ``numbers`` (k,) from ``xyz`` (k, 3); others stay unknown."""
        idx = self.index(numbers, where=where)
        X = np.full((self.n, 3), np.nan) if self.coordinates is None else np.array(self.coordinates, float)
        X[idx] = np.asarray(xyz, float)
        return replace(self, coordinates=X)

    def describe(self, idx) -> str:
        """'nodes 12, 13 (labels …)' for messages."""
        idx = np.asarray(idx, np.int64)
        return f"nodes {format_ids(self.numbers[idx])}"


__all__ = ["KINDS", "LoadCase", "Network", "couplings_from_lists", "laplacian", "symmetric_couplings"]
