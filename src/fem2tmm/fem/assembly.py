"""Vectorised finite-element assembly: conduction, lumped capacity and nodal areas.

Element matrices are computed for whole blocks at once with ``einsum`` and returned in COO form with
the owning element of every entry, so that later stages (the local reduction) can split them by cluster
without re-integrating.  No Python loop runs over elements.

Units: conductivity W/(m K), thickness m, coordinates m -> conduction W/K; volume weights m³;
areas m².
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .elements import RULES, SHELL_TYPES, SOLID_TYPES
from .geometry import shell_metric, solid_jacobian


@dataclass(frozen=True)
class ElementCOO:
    """Element matrices in coordinate form.

    ``rows``, ``cols``, ``vals`` (nnz,) and ``elem`` (nnz,) the global element each entry comes from.
    Entries are not summed; :meth:`tocsr` sums duplicates.
    """

    rows: np.ndarray
    cols: np.ndarray
    vals: np.ndarray
    elem: np.ndarray

    def tocsr(self, n: int) -> sp.csr_matrix:
        return sp.csr_matrix((self.vals, (self.rows, self.cols)), shape=(n, n))

    def renumber(self, node_map: np.ndarray) -> "ElementCOO":
        """The same entries with node indices mapped through ``node_map`` (e.g. isothermal merging)."""
        return ElementCOO(node_map[self.rows], node_map[self.cols], self.vals, self.elem)

    def select(self, mask: np.ndarray) -> "ElementCOO":
        return ElementCOO(self.rows[mask], self.cols[mask], self.vals[mask], self.elem[mask])

    @staticmethod
    def concatenate(parts: list["ElementCOO"]) -> "ElementCOO":
        if not parts:
            z = np.zeros(0, np.int64)
            return ElementCOO(z, z, np.zeros(0), z)
        return ElementCOO(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("rows", "cols", "vals", "elem")))


def conduction_matrices(points: np.ndarray, cells: np.ndarray, etype: str, k: np.ndarray,
                        thickness: np.ndarray | None = None) -> np.ndarray:
    """Element conduction matrices (m, nk, nk) in W/K.

    Shells: ``t k ∫ ∇ₛNᵢ·∇ₛNⱼ dA`` with the surface gradient of the (possibly warped) element;
    solids: ``k ∫ ∇Nᵢ·∇Nⱼ dV``.  ``k`` (m,) W/(m K); ``thickness`` (m,) m for shells.
    """
    rule = RULES[etype]
    if etype in SHELL_TYPES:
        J, dA, _ = shell_metric(points, cells, etype, rule)
        G = np.einsum("mqcd,mqce->mqde", J, J)
        Ginv = np.linalg.inv(G)
        Ke = np.einsum("q,mq,qad,mqde,qbe->mab", rule.w, dA, rule.dN, Ginv, rule.dN)
        return Ke * (np.asarray(k) * np.asarray(thickness))[:, None, None]
    J, det = solid_jacobian(points, cells, etype, rule)
    Jinv = np.linalg.inv(J)  # dxi/dX
    grad = np.einsum("qkd,mqdc->mqkc", rule.dN, Jinv)
    Ke = np.einsum("q,mq,mqac,mqbc->mab", rule.w, np.abs(det), grad, grad)
    return Ke * np.asarray(k)[:, None, None]


def volume_shares(points: np.ndarray, cells: np.ndarray, etype: str,
                  thickness: np.ndarray | None = None) -> np.ndarray:
    """Row-sum lumped volume of each element node, ``∫ Nᵢ dV`` (m, nk) in m³ (shells: x thickness).

    Rows sum to the element volume; tri3/tet4 and undistorted quad4/hex8/wedge6 give equal shares.
    """
    rule = RULES[etype]
    if etype in SHELL_TYPES:
        _, dA, _ = shell_metric(points, cells, etype, rule)
        return np.einsum("q,mq,qk->mk", rule.w, dA, rule.N) * np.asarray(thickness)[:, None]
    _, det = solid_jacobian(points, cells, etype, rule)
    return np.einsum("q,mq,qk->mk", rule.w, np.abs(det), rule.N)


def area_shares(points: np.ndarray, cells: np.ndarray, etype: str) -> np.ndarray:
    """``∫ Nᵢ dA`` over shell (or face) elements (m, nk) in m²; rows sum to the element area."""
    rule = RULES[etype]
    _, dA, _ = shell_metric(points, cells, etype, rule)
    return np.einsum("q,mq,qk->mk", rule.w, dA, rule.N)


def to_coo(cells: np.ndarray, Ke: np.ndarray, elem: np.ndarray) -> ElementCOO:
    """Scatter element matrices (m, k, k) of elements ``elem`` (m,) into an :class:`ElementCOO`."""
    m, nk = cells.shape
    rows = np.repeat(cells, nk, axis=1).ravel()
    cols = np.tile(cells, (1, nk)).ravel()
    return ElementCOO(rows.astype(np.int64), cols.astype(np.int64), Ke.ravel(),
                      np.repeat(np.asarray(elem, np.int64), nk * nk))


def scatter_shares(cells: np.ndarray, shares: np.ndarray, n: int, weights: np.ndarray | None = None) -> np.ndarray:
    """Sum per-element nodal shares (m, k) (optionally x ``weights`` (m,)) into a nodal vector (n,)."""
    vals = shares if weights is None else shares * np.asarray(weights)[:, None]
    return np.bincount(cells.ravel(), weights=vals.ravel(), minlength=n)


__all__ = [
    "ElementCOO",
    "conduction_matrices",
    "volume_shares",
    "area_shares",
    "to_coo",
    "scatter_shares",
    "SHELL_TYPES",
    "SOLID_TYPES",
]
