"""Vectorised element geometry: Jacobians at quadrature points, areas, normals, volumes, centroids.

All functions take ``points`` (n, 3) float in metres and ``cells`` (m, k) int node indices of one
element type and return plain arrays; nothing loops over elements in Python.  Small dense products
are written as one large matrix product (BLAS) rather than ``einsum`` so that 10⁶ elements take
seconds.
"""

from __future__ import annotations

import numpy as np

from .elements import RULES, Rule, centroid_rule


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (faster than ``np.cross`` on large stacks)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def tangents(points: np.ndarray, cells: np.ndarray, dN: np.ndarray) -> np.ndarray:
    """dX/dξ at every quadrature point: (m, q, 3, d) from ``dN`` (q, k, d)."""
    m, k = cells.shape
    q, _, d = dN.shape
    Xt = points[cells].transpose(0, 2, 1).reshape(m * 3, k)  # (m·3, k)
    J = Xt @ dN.transpose(1, 0, 2).reshape(k, q * d)  # one GEMM
    return J.reshape(m, 3, q, d).transpose(0, 2, 1, 3)


def shell_metric(points: np.ndarray, cells: np.ndarray, etype: str, rule: Rule | None = None):
    """Surface Jacobians of shells at the points of ``rule`` (default: the element's quadrature).

    Returns ``(J, dA, n)``: ``J`` (m, q, 3, 2) tangent vectors dX/dξ, ``dA`` (m, q) surface measure
    |dX/dr x dX/ds| (m² per unit reference area), ``n`` (m, q, 3) the un-normalised right-hand normal.
    """
    rule = RULES[etype] if rule is None else rule
    J = tangents(points, cells, rule.dN)
    n = cross(J[..., 0], J[..., 1])
    return J, np.sqrt(np.einsum("...c,...c->...", n, n)), n


def solid_jacobian(points: np.ndarray, cells: np.ndarray, etype: str, rule: Rule | None = None):
    """Volume Jacobians of solids: ``(J, detJ)`` with J (m, q, 3, 3) = dX/dξ and detJ (m, q)."""
    rule = RULES[etype] if rule is None else rule
    J = tangents(points, cells, rule.dN)
    det = np.einsum("...c,...c->...", J[..., 0], cross(J[..., 1], J[..., 2]))
    return J, det


def inverse3(J: np.ndarray, det: np.ndarray) -> np.ndarray:
    """Inverse of stacked 3x3 matrices (..., 3, 3) by cofactors, given their determinants."""
    c0 = cross(J[..., 1], J[..., 2])  # rows of the inverse are cofactor columns / det
    c1 = cross(J[..., 2], J[..., 0])
    c2 = cross(J[..., 0], J[..., 1])
    # J columns are dX/dξ_d; inverse[d, c] = cofactor column d ... assemble (…, 3(d), 3(c))
    inv = np.stack([c0, c1, c2], axis=-2)
    return inv / det[..., None, None]


def shell_areas(points: np.ndarray, cells: np.ndarray, etype: str) -> np.ndarray:
    """Area of each shell element (m,) in m² (exact for tri3, 2x2 Gauss for warped quad4)."""
    rule = RULES[etype]
    _, dA, _ = shell_metric(points, cells, etype, rule)
    return dA @ rule.w


def shell_normals(points: np.ndarray, cells: np.ndarray, etype: str) -> np.ndarray:
    """Unit right-hand normal of each shell at its centroid (m, 3); the front side points along it."""
    _, _, n = shell_metric(points, cells, etype, centroid_rule(etype))
    n = n[:, 0, :]
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)


def solid_volumes(points: np.ndarray, cells: np.ndarray, etype: str) -> np.ndarray:
    """Signed volume of each solid element (m,) in m³ (negative for a mirrored node order)."""
    rule = RULES[etype]
    _, det = solid_jacobian(points, cells, etype, rule)
    return det @ rule.w


def centroids(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Mean of the element's nodes (m, 3)."""
    return points[cells].mean(axis=1)
