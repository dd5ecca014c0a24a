"""Vectorised element geometry: Jacobians at quadrature points, areas, normals, volumes, centroids.

All functions take ``points`` (n, 3) float in metres and ``cells`` (m, k) int node indices of one
element type and return plain arrays; nothing loops over elements in Python.
"""

from __future__ import annotations

import numpy as np

from .elements import DIM, RULES, Rule, centroid_rule


def shell_metric(points: np.ndarray, cells: np.ndarray, etype: str, rule: Rule | None = None):
    """Surface Jacobians of shells at the points of ``rule`` (default: the element's quadrature).

    Returns ``(J, dA, n)``: ``J`` (m, q, 3, 2) tangent vectors dX/dxi, ``dA`` (m, q) surface measure
    |dX/dr x dX/ds| (m² per unit reference area), ``n`` (m, q, 3) the un-normalised right-hand normal.
    """
    rule = RULES[etype] if rule is None else rule
    X = points[cells]  # (m, k, 3)
    J = np.einsum("mkc,qkd->mqcd", X, rule.dN)
    n = np.cross(J[..., 0], J[..., 1])
    return J, np.linalg.norm(n, axis=-1), n


def solid_jacobian(points: np.ndarray, cells: np.ndarray, etype: str, rule: Rule | None = None):
    """Volume Jacobians of solids: ``(J, detJ)`` with J (m, q, 3, 3) = dX/dxi and detJ (m, q)."""
    rule = RULES[etype] if rule is None else rule
    X = points[cells]
    J = np.einsum("mkc,qkd->mqcd", X, rule.dN)
    return J, np.linalg.det(J)


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


def dimension(etype: str) -> int:
    return DIM[etype]
