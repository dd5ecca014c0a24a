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

from ..mesh.elements import RULES, SHELL_TYPES, SOLID_TYPES
from ..mesh.geometry import inverse3, shell_metric, solid_jacobian


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
        """The entries of ``parts`` in order; a single non-empty part is returned as it is, not copied (the arrays
        are never written in place; at 10⁶ quads the copy of 1.6·10⁷ entries took ~1 s)."""
        if not parts:
            z = np.zeros(0, np.int64)
            return ElementCOO(z, z, np.zeros(0), z)
        full = [p for p in parts if len(p.rows)]
        if len(full) == 1:
            return full[0]
        return ElementCOO(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("rows", "cols", "vals", "elem")))


@dataclass(frozen=True)
class BlockGeometry:
    """Geometry of one element block at its quadrature points, computed once and reused.

    ``measure`` (m, q): dA (shells, m²) or |det J| (solids, m³) per unit reference measure;
    ``metric`` (m, q, 3): shells, inverse surface metric entries (g⁻¹₀₀, g⁻¹₀₁, g⁻¹₁₁);
    ``Jinv`` (m, q, 3, 3): solids, dξ/dX; ``normal`` (m, q, 3) shells, un-normalised; ``det`` (m, q) solids, signed.
    """

    etype: str
    measure: np.ndarray
    metric: np.ndarray | None = None
    Jinv: np.ndarray | None = None
    normal: np.ndarray | None = None
    det: np.ndarray | None = None


def block_geometry(points: np.ndarray, cells: np.ndarray, etype: str, need_gradients: bool = True) -> BlockGeometry:
    """Quadrature-point geometry of ``cells`` (m, k) of type ``etype``."""
    rule = RULES[etype]
    if etype in SHELL_TYPES:
        J, dA, n = shell_metric(points, cells, etype, rule)
        metric = None
        if need_gradients:
            a, b = J[..., 0], J[..., 1]
            g00 = np.einsum("...c,...c->...", a, a)
            g01 = np.einsum("...c,...c->...", a, b)
            g11 = np.einsum("...c,...c->...", b, b)
            det = np.where(dA > 0, dA * dA, 1.0)
            metric = np.stack([g11 / det, -g01 / det, g00 / det], axis=-1)
        return BlockGeometry(etype, dA, metric=metric, normal=n)
    J, det = solid_jacobian(points, cells, etype, rule)
    Jinv = inverse3(J, np.where(det != 0, det, 1.0)) if need_gradients else None
    return BlockGeometry(etype, np.abs(det), Jinv=Jinv, det=det)


def tensor33(tensor: np.ndarray) -> np.ndarray:
    """(m, 3, 3) symmetric conductivity tensors from (m, 6) rows (kxx, kxy, kxz, kyy, kyz, kzz)."""
    t = np.asarray(tensor, float)
    return t[:, [[0, 1, 2], [1, 3, 4], [2, 4, 5]]]


def line_matrices(points: np.ndarray, cells: np.ndarray, k: np.ndarray, area: np.ndarray,
                  tensor: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Conduction matrices (m, 2, 2) W/K and lengths (m,) m of 2-node line elements (bars, rods).

    ``k A / L [[1, -1], [-1, 1]]``: conduction along the axis only; ``k`` (m,) W/(m K), ``area`` (m,) m²;
    with ``tensor`` (m, 6) (rows not NaN) the axial conductivity is ``eᵀ K e`` (e the unit axis).
    """
    d = points[cells[:, 1]] - points[cells[:, 0]]
    L = np.linalg.norm(d, axis=1)
    k = np.asarray(k, float).copy()
    if tensor is not None:
        aniso = ~np.isnan(tensor).any(axis=1)
        if aniso.any():
            e = d[aniso] / L[aniso, None]
            k[aniso] = np.einsum("mi,mij,mj->m", e, tensor33(tensor[aniso]), e)
    g = k * np.asarray(area, float) / L
    Ke = np.empty((len(cells), 2, 2))
    Ke[:, 0, 0] = Ke[:, 1, 1] = g
    Ke[:, 0, 1] = Ke[:, 1, 0] = -g
    return Ke, L


def conduction_matrices(points: np.ndarray, cells: np.ndarray, etype: str, k: np.ndarray,
                        thickness: np.ndarray | None = None, geom: BlockGeometry | None = None,
                        tensor: np.ndarray | None = None) -> np.ndarray:
    """Element conduction matrices (m, nk, nk) in W/K.

    Shells: ``t k ∫ ∇ₛNᵢ·∇ₛNⱼ dA`` with the surface gradient of the (possibly warped) element;
    solids: ``k ∫ ∇Nᵢ·∇Nⱼ dV``.  ``k`` (m,) W/(m K); ``thickness`` (m,) m for shells.  ``tensor`` (m, 6)
    anisotropic conductivities (kxx, kxy, kxz, kyy, kyz, kzz) W/(m K) in the basic system: rows that are
    not NaN replace ``k`` by ``∫ ∇Nᵢᵀ K ∇Nⱼ`` (shells: the tangential part, ∇ₛ lying in the surface).
    """
    rule = RULES[etype]
    geom = block_geometry(points, cells, etype) if geom is None else geom
    if tensor is not None and not np.isnan(tensor).all():
        aniso = ~np.isnan(tensor).any(axis=1)
        Ke = conduction_matrices(points, cells, etype, np.where(aniso, 1.0, k), thickness, geom)
        sel = np.flatnonzero(aniso)
        Ke[sel] = _anisotropic(points, cells[sel], etype, tensor33(tensor[sel]),
                               None if thickness is None else np.asarray(thickness)[sel])
        return Ke
    m, nk = cells.shape
    q = len(rule.w)
    wm = geom.measure * rule.w  # (m, q)
    if etype in SHELL_TYPES:
        # K_ab = Σ_q w dA Σ_de dN_ad g⁻¹_de dN_be: three (m, q) x (q, k²) products
        dN = rule.dN
        P00 = np.einsum("qa,qb->qab", dN[..., 0], dN[..., 0]).reshape(q, nk * nk)
        P11 = np.einsum("qa,qb->qab", dN[..., 1], dN[..., 1]).reshape(q, nk * nk)
        P01 = np.einsum("qa,qb->qab", dN[..., 0], dN[..., 1])
        P01 = (P01 + P01.transpose(0, 2, 1)).reshape(q, nk * nk)
        g = geom.metric
        Ke = (wm * g[..., 0]) @ P00 + (wm * g[..., 1]) @ P01 + (wm * g[..., 2]) @ P11
        Ke = Ke.reshape(m, nk, nk)
        return Ke * (np.asarray(k) * np.asarray(thickness))[:, None, None]
    Ke = np.zeros((m, nk, nk))
    for i in range(q):
        grad = np.matmul(rule.dN[i][None, :, :], geom.Jinv[:, i])  # (m, k, 3) = dN/dξ · dξ/dX
        Ke += wm[:, i, None, None] * np.matmul(grad, grad.transpose(0, 2, 1))
    return Ke * np.asarray(k)[:, None, None]


def _anisotropic(points, cells, etype, K3, thickness):
    """``∫ ∇Nᵢᵀ K ∇Nⱼ`` (x thickness for shells) with the 3-D (surface) gradient, (m, nk, nk)."""
    rule = RULES[etype]
    m, nk = cells.shape
    Ke = np.zeros((m, nk, nk))
    if etype in SHELL_TYPES:
        J, dA, _ = shell_metric(points, cells, etype, rule)
        for i in range(len(rule.w)):
            a, b = J[:, i, :, 0], J[:, i, :, 1]
            g = np.stack([np.stack([(a * a).sum(1), (a * b).sum(1)], 1), np.stack([(a * b).sum(1), (b * b).sum(1)], 1)], 1)
            G = np.matmul(J[:, i], np.linalg.inv(g))  # (m, 3, 2): ∇ₛ = G · ∂/∂ξ
            grad = np.matmul(rule.dN[i][None], G.transpose(0, 2, 1))  # (m, k, 3)
            Ke += (rule.w[i] * dA[:, i])[:, None, None] * np.matmul(np.matmul(grad, K3), grad.transpose(0, 2, 1))
        return Ke * np.asarray(thickness)[:, None, None]
    J, det = solid_jacobian(points, cells, etype, rule)
    Jinv = inverse3(J, det)
    for i in range(len(rule.w)):
        grad = np.matmul(rule.dN[i][None, :, :], Jinv[:, i])
        Ke += (rule.w[i] * np.abs(det[:, i]))[:, None, None] * np.matmul(np.matmul(grad, K3), grad.transpose(0, 2, 1))
    return Ke


def volume_shares(points: np.ndarray, cells: np.ndarray, etype: str,
                  thickness: np.ndarray | None = None, geom: BlockGeometry | None = None) -> np.ndarray:
    """Row-sum lumped volume of each element node, ``∫ Nᵢ dV`` (m, nk) in m³ (shells: x thickness).

    Rows sum to the element volume; tri3/tet4 and undistorted quad4/hex8/wedge6 give equal shares.
    """
    rule = RULES[etype]
    geom = block_geometry(points, cells, etype, need_gradients=False) if geom is None else geom
    sh = (geom.measure * rule.w) @ rule.N
    if etype in SHELL_TYPES:
        return sh * np.asarray(thickness)[:, None]
    return sh


def area_shares(points: np.ndarray, cells: np.ndarray, etype: str, geom: BlockGeometry | None = None) -> np.ndarray:
    """``∫ Nᵢ dA`` over shell (or face) elements (m, nk) in m²; rows sum to the element area."""
    rule = RULES[etype]
    geom = block_geometry(points, cells, etype, need_gradients=False) if geom is None else geom
    return (geom.measure * rule.w) @ rule.N


def capacity_matrices(points: np.ndarray, cells: np.ndarray, etype: str, geom: BlockGeometry | None = None) -> np.ndarray:
    """Consistent (mass-type) element matrices ``∫ NᵢNⱼ dA`` (shells, m²) or ``∫ NᵢNⱼ dV`` (solids, m³), (m, nk, nk).

    Multiply by ρ·c (and the thickness for shells) for the consistent capacitance in J/K; row sums equal
    :func:`area_shares` / :func:`volume_shares` (the lumped capacitance), since Σⱼ Nⱼ = 1.
    """
    rule = RULES[etype]
    geom = block_geometry(points, cells, etype, need_gradients=False) if geom is None else geom
    NN = np.einsum("qa,qb->qab", rule.N, rule.N).reshape(len(rule.w), -1)  # (q, k²)
    m, nk = cells.shape
    return ((geom.measure * rule.w) @ NN).reshape(m, nk, nk)


def to_coo(cells: np.ndarray, Ke: np.ndarray, elem: np.ndarray) -> ElementCOO:
    """Scatter element matrices (m, k, k) of elements ``elem`` (m,) into an :class:`ElementCOO`."""
    m, nk = cells.shape
    rows = np.repeat(cells, nk, axis=1).ravel()
    cols = np.tile(cells, (1, nk)).ravel()
    return ElementCOO(rows.astype(np.int64, copy=False), cols.astype(np.int64, copy=False), Ke.ravel(),
                      np.repeat(np.asarray(elem, np.int64), nk * nk))


def scatter_shares(cells: np.ndarray, shares: np.ndarray, n: int, weights: np.ndarray | None = None) -> np.ndarray:
    """Sum per-element nodal shares (m, k) (optionally x ``weights`` (m,)) into a nodal vector (n,);
    padded entries (cells < 0) are ignored."""
    vals = shares if weights is None else shares * np.asarray(weights)[:, None]
    ok = cells >= 0
    return np.bincount(cells[ok], weights=vals[ok], minlength=n)


__all__ = [
    "ElementCOO",
    "BlockGeometry",
    "block_geometry",
    "conduction_matrices",
    "line_matrices",
    "tensor33",
    "volume_shares",
    "capacity_matrices",
    "area_shares",
    "to_coo",
    "scatter_shares",
    "SHELL_TYPES",
    "SOLID_TYPES",
]
