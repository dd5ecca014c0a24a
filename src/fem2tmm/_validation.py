"""Checks of the arguments of public functions, one helper per kind of argument.

Public functions validate their arguments with these helpers and raise :class:`~fem2tmm.errors.Fem2TmmError`
naming the argument and what was expected; private functions assume valid input.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .errors import Fem2TmmError


def choice(name: str, value, choices: Sequence[str]) -> str:
    """``value`` if it is one of ``choices``, else a :class:`Fem2TmmError` listing them."""
    if value not in choices:
        allowed = " or ".join(map(repr, choices)) if len(choices) == 2 else f"one of {tuple(choices)}"
        raise Fem2TmmError(f"{name} must be {allowed}, got {value!r}")
    return value


def positive_int(name: str, value) -> int:
    """``value`` as an int if it is an integer >= 1."""
    if not (isinstance(value, int | np.integer) and not isinstance(value, bool) and value >= 1):
        raise Fem2TmmError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def nonnegative(name: str, value, unit: str) -> float:
    """``value`` as a float if it is finite and >= 0 (``unit`` names what it measures in the message)."""
    v = float(value)
    if not (math.isfinite(v) and v >= 0.0):
        raise Fem2TmmError(f"{name} must be a finite {unit} >= 0, got {value}")
    return v


def per_face(name: str, value, m: int) -> np.ndarray:
    """(m,) float64: a scalar broadcast to every face, or one value per face."""
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        return np.full(m, float(a))
    if a.shape != (m,):
        raise Fem2TmmError(f"{name} must be a scalar or one value per face ({m},), got shape {a.shape}")
    return a


def side_groups(groups, n_faces: int) -> tuple[np.ndarray, int]:
    """``(groups (2 n_faces,) int64, number of groups)`` of a per-side group array (-1: no group); None: every side
    its own group."""
    if groups is None:
        return np.arange(2 * n_faces, dtype=np.int64), 2 * n_faces
    groups = np.asarray(groups)
    if groups.shape != (2 * n_faces,) or not np.issubdtype(groups.dtype, np.integer):
        raise Fem2TmmError(
            f"groups must be an int array with one entry per side ({2 * n_faces},), got {groups.shape} {groups.dtype}"
        )
    groups = groups.astype(np.int64)
    if groups.size and groups.min() < -1:
        raise Fem2TmmError("group ids must be >= 0, or -1 for sides that are not REF nodes")
    return groups, int(groups.max()) + 1 if groups.size else 0


def ray_budget(rays_per_group, ray_density, area: np.ndarray, emitting: np.ndarray) -> np.ndarray:
    """(g,) int64 rays per group: ``rays_per_group`` (int or (g,) ints; default 1000) or ``ray_density`` rays per m²
    of ``area`` (g,) m²; zero for groups that do not emit (``emitting`` (g,) bool)."""
    g = len(area)
    if rays_per_group is not None and ray_density is not None:
        raise Fem2TmmError("give either rays_per_group (rays_per_face) or ray_density, not both")
    if ray_density is not None:
        if not ray_density > 0:
            raise Fem2TmmError(f"ray_density must be > 0 rays per m², got {ray_density}")
        rays = np.ceil(ray_density * area).astype(np.int64)
    else:
        rays = np.broadcast_to(np.asarray(1000 if rays_per_group is None else rays_per_group), (g,))
        if np.any(rays < 0) or not np.issubdtype(rays.dtype, np.integer) and np.any(rays != np.round(rays)):
            raise Fem2TmmError("rays per group must be non-negative integers")
        rays = rays.astype(np.int64)
    return np.where(emitting, rays, 0)
