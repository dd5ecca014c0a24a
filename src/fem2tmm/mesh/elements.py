"""Element library: node orderings, faces, edges, shape functions and quadrature.

Supported element types (node ordering as in VTK / meshio and Nastran):

========  =====  ======  =========================================================
type      nodes  dim     quadrature
========  =====  ======  =========================================================
tri3      3      2       1 point (exact for the constant-gradient element)
quad4     4      2       2 x 2 Gauss
tet4      4      3       1 point
hex8      8      3       2 x 2 x 2 Gauss
wedge6    6      3       3-point triangle x 2-point Gauss line
line2     2      1       2-point Gauss (bars, rods, beams: conduction along the axis)
========  =====  ======  =========================================================

Shells (tri3, quad4) have a front side: the side their right-hand normal (nodes 0 -> 1 -> 2) points to.
Solid faces are listed with outward right-hand normals for a positively oriented element.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SHELL_TYPES = ("tri3", "quad4")
SOLID_TYPES = ("tet4", "hex8", "wedge6")
LINE_TYPES = ("line2",)
ELEMENT_TYPES = SHELL_TYPES + SOLID_TYPES + LINE_TYPES
N_NODES = {"tri3": 3, "quad4": 4, "tet4": 4, "hex8": 8, "wedge6": 6, "line2": 2}
DIM = {"tri3": 2, "quad4": 2, "tet4": 3, "hex8": 3, "wedge6": 3, "line2": 1}
#: integer code of each type, used in padded (m, 8) cell arrays
TYPE_CODE = {name: i for i, name in enumerate(ELEMENT_TYPES)}

#: faces of solids, outward right-hand normals for a positively oriented element; triangles have 3 entries
SOLID_FACES: dict[str, tuple[tuple[int, ...], ...]] = {
    "tet4": ((0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)),
    "hex8": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)),
    "wedge6": ((0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (1, 2, 5, 4), (2, 0, 3, 5)),
}

#: edges of shells (used for shell adjacency, sharp edges and junctions)
SHELL_EDGES: dict[str, tuple[tuple[int, int], ...]] = {
    "tri3": ((0, 1), (1, 2), (2, 0)),
    "quad4": ((0, 1), (1, 2), (2, 3), (3, 0)),
}

#: corner-node pairs of the edges that carry the mid-side nodes of the quadratic variants, in Nastran's
#: (and VTK's) order of the mid-side nodes (CTRIA6 G4-G6, CQUAD8 G5-G8, CTETRA G5-G10, CHEXA G9-G20,
#: CPENTA G7-G15)
MIDSIDE_EDGES: dict[str, tuple[tuple[int, int], ...]] = {
    "tri3": ((0, 1), (1, 2), (2, 0)),
    "quad4": ((0, 1), (1, 2), (2, 3), (3, 0)),
    "tet4": ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)),
    "hex8": ((0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 5), (2, 6), (3, 7), (4, 5), (5, 6), (6, 7), (7, 4)),
    "wedge6": ((0, 1), (1, 2), (2, 0), (0, 3), (1, 4), (2, 5), (3, 4), (4, 5), (5, 3)),
}

#: node permutation that mirrors a solid element (turns a negatively oriented element positive)
MIRROR: dict[str, tuple[int, ...]] = {
    "tet4": (0, 2, 1, 3),
    "hex8": (0, 3, 2, 1, 4, 7, 6, 5),
    "wedge6": (0, 2, 1, 3, 5, 4),
}


@dataclass(frozen=True)
class Rule:
    """Quadrature rule on the reference element with shape functions evaluated at its points.

    ``N`` (q, k) shape functions, ``dN`` (q, k, d) derivatives w.r.t. the d reference coordinates,
    ``w`` (q,) weights (sum = reference measure).
    """

    N: np.ndarray
    dN: np.ndarray
    w: np.ndarray


def _tri3(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r, s = xi[:, 0], xi[:, 1]
    N = np.stack([1 - r - s, r, s], axis=1)
    dN = np.broadcast_to(np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]), (len(xi), 3, 2)).copy()
    return N, dN


def _quad4(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r, s = xi[:, 0], xi[:, 1]
    sr = np.array([-1.0, 1.0, 1.0, -1.0])
    ss = np.array([-1.0, -1.0, 1.0, 1.0])
    N = 0.25 * (1 + sr * r[:, None]) * (1 + ss * s[:, None])
    dN = np.stack([0.25 * sr * (1 + ss * s[:, None]), 0.25 * ss * (1 + sr * r[:, None])], axis=2)
    return N, dN


def _tet4(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r, s, t = xi[:, 0], xi[:, 1], xi[:, 2]
    N = np.stack([1 - r - s - t, r, s, t], axis=1)
    d = np.array([[-1.0, -1.0, -1.0], [1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    return N, np.broadcast_to(d, (len(xi), 4, 3)).copy()


def _hex8(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r, s, t = xi[:, 0:1], xi[:, 1:2], xi[:, 2:3]
    sr = np.array([-1.0, 1, 1, -1, -1, 1, 1, -1])
    ss = np.array([-1.0, -1, 1, 1, -1, -1, 1, 1])
    st = np.array([-1.0, -1, -1, -1, 1, 1, 1, 1])
    a, b, c = 1 + sr * r, 1 + ss * s, 1 + st * t
    N = a * b * c / 8
    dN = np.stack([sr * b * c / 8, ss * a * c / 8, st * a * b / 8], axis=2)
    return N, dN


def _wedge6(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r, s, t = xi[:, 0:1], xi[:, 1:2], xi[:, 2:3]
    tri = np.concatenate([1 - r - s, r, s], axis=1)
    dtri = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    lo, hi = (1 - t) / 2, (1 + t) / 2
    N = np.concatenate([tri * lo, tri * hi], axis=1)
    q = len(xi)
    dN = np.empty((q, 6, 3))
    dN[:, :3, 0] = dtri[None, :, 0] * lo
    dN[:, :3, 1] = dtri[None, :, 1] * lo
    dN[:, 3:, 0] = dtri[None, :, 0] * hi
    dN[:, 3:, 1] = dtri[None, :, 1] * hi
    dN[:, :3, 2] = -tri / 2
    dN[:, 3:, 2] = tri / 2
    return N, dN


def _line2(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r = xi[:, 0]
    N = np.stack([(1 - r) / 2, (1 + r) / 2], axis=1)
    dN = np.broadcast_to(np.array([[[-0.5], [0.5]]]), (len(xi), 2, 1)).copy()
    return N, dN


_G2 = 1.0 / np.sqrt(3.0)


def _rule(etype: str) -> Rule:
    if etype == "tri3":
        xi, w = np.array([[1 / 3, 1 / 3]]), np.array([0.5])
        N, dN = _tri3(xi)
    elif etype == "quad4":
        g = np.array([-_G2, _G2])
        xi = np.array([[a, b] for b in g for a in g])
        w = np.ones(4)
        N, dN = _quad4(xi)
    elif etype == "tet4":
        xi, w = np.array([[0.25, 0.25, 0.25]]), np.array([1 / 6])
        N, dN = _tet4(xi)
    elif etype == "hex8":
        g = np.array([-_G2, _G2])
        xi = np.array([[a, b, c] for c in g for b in g for a in g])
        w = np.ones(8)
        N, dN = _hex8(xi)
    elif etype == "wedge6":
        tri = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
        xi = np.array([[p[0], p[1], c] for c in (-_G2, _G2) for p in tri])
        w = np.full(6, 1 / 6)
        N, dN = _wedge6(xi)
    elif etype == "line2":
        xi, w = np.array([[-_G2], [_G2]]), np.ones(2)
        N, dN = _line2(xi)
    else:  # pragma: no cover - guarded by callers
        raise KeyError(etype)
    return Rule(N=N, dN=dN, w=w)


RULES: dict[str, Rule] = {t: _rule(t) for t in ELEMENT_TYPES}


def centroid_rule(etype: str) -> Rule:
    """One-point rule at the reference centroid (for orientation and normals)."""
    xi = {
        "tri3": np.array([[1 / 3, 1 / 3]]),
        "quad4": np.array([[0.0, 0.0]]),
        "tet4": np.array([[0.25, 0.25, 0.25]]),
        "hex8": np.array([[0.0, 0.0, 0.0]]),
        "wedge6": np.array([[1 / 3, 1 / 3, 0.0]]),
        "line2": np.array([[0.0]]),
    }[etype]
    f = {"tri3": _tri3, "quad4": _quad4, "tet4": _tet4, "hex8": _hex8, "wedge6": _wedge6, "line2": _line2}[etype]
    N, dN = f(xi)
    return Rule(N=N, dN=dN, w=np.ones(1))
