"""Quadric super faces: Taubin fit, foot-point projection, exact ray-quadric intersection and the ray scene that
traces tagged FE regions against their fitted quadrics (thesis ch. 5, l. 2311-2500; DESIGN §3.5).

Conventions.  A quadric is f(x) = c0 + c1 x + c2 y + c3 z + c4 x² + c5 xy + c6 xz + c7 y² + c8 yz + c9 z² (thesis
eq. 5.2, monomials in that order) in *local* coordinates x = p - ``center`` (m): fitted regions far from the origin
keep their digits.  Written as f(x) = xᵀAx + b·x + c0 with A symmetric, the gradient is 2Ax + b.  A fitted quadric
is scaled so that the mean |∇f| over its vertices is 1, so f is close to a signed distance in metres near the
surface, and oriented so that ∇f agrees (on average) with the FE face normals it was fitted to.

* **Fit** (:func:`fit_quadric`, eq. 5.3-5.5).  Taubin's method minimises Σf²/Σ|∇f|², the generalised eigenproblem
  M c = λ N c.  N is singular (the constant monomial has no gradient): c0 is eliminated exactly (it is the mean
  of the other monomials, so M becomes the covariance of the centred monomials), the points are centred and scaled
  to the unit ball for conditioning, and the problem is solved as a singular value decomposition of the design
  matrix whitened by the square root of N (restricted to N's range), never forming M or squaring a condition
  number: the fit is exact to round-off (1e-15 of the size) on exact meshes.  When several quadrics fit the
  vertices equally well (a plane; two node rings of a cylinder; a 90° strip of a cylinder three elements wide,
  whose four generators lie on a family of quadrics) the one whose gradient best matches the face normals is
  taken (least squares within the near-null space).
* **Projection** (§5.2.2, :meth:`Quadric.project`).  The foot point p of p0 (f(p) = 0, p - p0 ∥ ∇f(p)) solves
  p - p0 = μ∇f(p); in the eigenbasis of A each coordinate is (y0ᵢ + μβᵢ)/(1 - 2μaᵢ), so Newton runs on the
  scalar μ (the thesis' F0, F1, F2 system in one unknown, robust where a component of ∇f vanishes).
* **Intersection** (§5.2.3, :meth:`Quadric.intersect`): both roots of a t² + b t + c = 0 in order, by the stable
  formula; a ≈ 0 (rays parallel to a generator, planes) is the linear case.

The scene (:class:`QuadricScene`) traces flat faces with Embree and every quadric region exactly.  A region's
*patch* is the part of its quadric whose normal line crosses one of the region's FE faces (the thesis' membership
by projection along the quadric normal): adjacent regions on the same quadric tile it without gap or overlap
(the normal-line test runs in one watertight Embree scene of all quadric facets), and the facets themselves are
never hit, so nothing depends on how the facets and the curved surface differ near silhouettes.  Emission samples
the FE faces with the coupled Halton scheme, projects the origins onto the quadric along its normal and rotates
the directions from the facet normal to the quadric normal; the rays carry energy in proportion to the local ratio
of quadric to facet area (the area Jacobian of the projection), so the emission is exactly uniform over the true
area, and emitting areas are the true curved areas (quadrature of that Jacobian).  Two second-order (in the element
size) effects of defining patches through the FE chords remain: where a quadric region borders a flat face or another
quadric along a curved edge, the crescent between the chord and the curves is open (rays may pass through it); and at
a free edge along which the surface normal is tilted against the boundary curve's plane (the end rings of a cone, the
rim of a paraboloid) the patch boundary moves by ~sagitta x sin(tilt) (measurements: docs/design-notes.md,
radiation/quadric.py).  Emission and absorption
use the same patches, so the energy bookkeeping stays exact.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from ..errors import Fem2TmmError, format_ids
from .engine import make_engine
from .surfaces import Surface, TriangleScene, pad_faces

#: a region whose largest vertex-to-quadric distance exceeds FIT_TOL x its size is not a quadric
FIT_TOL = 1e-3
#: whitened singular values (≈ RMS distance / scale) below max(AMBIGUITY, 3 x the smallest) fit equally well
AMBIGUITY = 1e-8
#: Newton iterations of the foot-point projection (3-5 are typical near the surface)
NEWTON_MAX = 50
#: a face whose normal is more than 60° from its quadric's normal is refused
MIN_ALIGNMENT = 0.5

# 7-point degree-5 rule on a triangle (Radon 1948): barycentric points (7, 3) and weights summing to 1
_S15 = np.sqrt(15.0)
_A1, _B1 = (6 - _S15) / 21, (9 + 2 * _S15) / 21
_A2, _B2 = (6 + _S15) / 21, (9 - 2 * _S15) / 21
RULE7 = (
    np.array([[1 / 3, 1 / 3, 1 / 3], [_A1, _A1, _B1], [_A1, _B1, _A1], [_B1, _A1, _A1],
              [_A2, _A2, _B2], [_A2, _B2, _A2], [_B2, _A2, _A2]]),
    np.array([9 / 40] + [(155 - _S15) / 1200] * 3 + [(155 + _S15) / 1200] * 3),
)


def subdivided_rule(m: int) -> tuple[np.ndarray, np.ndarray]:
    """:data:`RULE7` on each of the m² triangles of a uniform m-subdivision of a triangle: barycentric points
    (7 m², 3) and weights (7 m²,) summing to 1."""
    bary, w = RULE7
    tris = []
    for i in range(m):  # loop over the subdivision grid (m <= 16)
        for j in range(m - i):
            tris.append([(i, j), (i + 1, j), (i, j + 1)])
            if i + j <= m - 2:
                tris.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])
    uv = np.array(tris, float) / m  # (m², 3 corners, 2) coordinates along edges 0->1 and 0->2
    corners = np.stack([1 - uv[..., 0] - uv[..., 1], uv[..., 0], uv[..., 1]], axis=-1)  # (m², 3, 3) barycentric
    pts = np.einsum("qc,tcb->tqb", bary, corners).reshape(-1, 3)
    return pts, np.tile(w, len(tris)) / len(tris)


# ------------------------------------------------------------------------------------------------------ kernels
def _monomials(X: np.ndarray) -> np.ndarray:
    """(n, 10) monomials [1, x, y, z, x², xy, xz, y², yz, z²] of points X (n, 3)."""
    x, y, z = X.T
    return np.stack([np.ones_like(x), x, y, z, x * x, x * y, x * z, y * y, y * z, z * z], axis=1)


def _monomial_gradients(X: np.ndarray) -> np.ndarray:
    """(n, 3, 10) gradients of the monomials (thesis ∇f below eq. 5.4)."""
    n = len(X)
    x, y, z = X.T
    G = np.zeros((n, 3, 10))
    G[:, 0, 1] = G[:, 1, 2] = G[:, 2, 3] = 1.0
    G[:, 0, 4], G[:, 0, 5], G[:, 0, 6] = 2 * x, y, z
    G[:, 1, 5], G[:, 1, 7], G[:, 1, 8] = x, 2 * y, z
    G[:, 2, 6], G[:, 2, 8], G[:, 2, 9] = x, y, 2 * z
    return G


def _split(coef: np.ndarray):
    """(A (3, 3) symmetric, b (3,), c0) of coefficients (10,)."""
    c = coef
    A = np.array([[c[4], c[5] / 2, c[6] / 2], [c[5] / 2, c[7], c[8] / 2], [c[6] / 2, c[8] / 2, c[9]]])
    return A, np.array(c[1:4], float), float(c[0])


def _join(A: np.ndarray, b: np.ndarray, c0: float) -> np.ndarray:
    return np.array([c0, b[0], b[1], b[2], A[0, 0], 2 * A[0, 1], 2 * A[0, 2], A[1, 1], 2 * A[1, 2], A[2, 2]])


# The kernels below work on the columns of (r, 3) arrays (measurements: docs/design-notes.md, radiation/quadric.py).
def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products (r,) of (r, 3) arrays."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _affine(M: np.ndarray, v: np.ndarray, b=(0.0, 0.0, 0.0)) -> np.ndarray:
    """M v + b (r, 3) for one matrix M (3, 3), rows v (r, 3) and b (3,)."""
    out = np.empty((len(v), 3))
    v0, v1, v2 = v[:, 0], v[:, 1], v[:, 2]
    for i in range(3):  # loop over x, y, z
        out[:, i] = M[i, 0] * v0 + M[i, 1] * v1 + M[i, 2] * v2 + b[i]
    return out


def _qform(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """vᵀMv (r,) for a symmetric M (3, 3) and rows v (r, 3)."""
    v0, v1, v2 = v[:, 0], v[:, 1], v[:, 2]
    return (v0 * (M[0, 0] * v0 + 2.0 * M[0, 1] * v1 + 2.0 * M[0, 2] * v2) + v1 * (M[1, 1] * v1 + 2.0 * M[1, 2] * v2)
            + M[2, 2] * v2 * v2)


def _value(A, b, c, x) -> np.ndarray:
    """f(x) (r,) at local points x (r, 3) of the quadric xᵀAx + b·x + c (A (3, 3), b (3,), c scalar)."""
    return c + _qform(A, x) + b[0] * x[:, 0] + b[1] * x[:, 1] + b[2] * x[:, 2]


def _gradient(A, b, x) -> np.ndarray:
    """∇f = 2Ax + b (r, 3) at local points x (r, 3)."""
    return _affine(2.0 * A, x, b)


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.sqrt(_dot(v, v))
    return v / np.where(n > 0, n, 1.0)[:, None]


def _foot(Q, ev, beta, c, x, tol):
    """Foot points (r, 3) of local points x (r, 3) on the quadric with eigenvectors Q (3, 3) (columns) and
    eigenvalues ev (3,) of A, β = Qᵀb (3,) and c0: Newton on μ in y(μ) = (y0 + μβ)/(1 - 2μa), f(y(μ)) = 0, from
    μ = 0, keeping 1 - 2μa > 0 (the branch of the closest point); a point stops when its foot point moves less than
    ``tol`` (m).  Returns ``(foot points (r, 3), converged (r,) bool)``."""
    r = len(x)
    y0 = np.ascontiguousarray(_affine(Q.T, x).T)  # (3, r) eigen-coordinates, one contiguous row per axis
    a0, a1, a2 = (float(v) for v in ev)
    b0, b1, b2 = (float(v) for v in beta)
    mu = np.zeros(r)
    live = np.arange(r)
    done = np.zeros(r, bool)
    for _ in range(NEWTON_MAX):
        if live.size == 0:
            break
        m = mu[live]
        Y = y0[:, live] if live.size < r else y0
        d0, d1, d2 = 1.0 - 2.0 * a0 * m, 1.0 - 2.0 * a1 * m, 1.0 - 2.0 * a2 * m
        y_0, y_1, y_2 = (Y[0] + m * b0) / d0, (Y[1] + m * b1) / d1, (Y[2] + m * b2) / d2
        g0, g1, g2 = 2.0 * a0 * y_0 + b0, 2.0 * a1 * y_1 + b1, 2.0 * a2 * y_2 + b2
        phi = c + (a0 * y_0 + b0) * y_0 + (a1 * y_1 + b1) * y_1 + (a2 * y_2 + b2) * y_2
        dphi = g0 * g0 / d0 + g1 * g1 / d1 + g2 * g2 / d2
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dphi > 0, -phi / dphi, np.nan)  # dphi <= 0: off the closest-point branch, fails
        for _ in range(60):  # halve steps that would cross a pole 1 - 2μa = 0 (never near the surface)
            bad = (d0 - 2.0 * a0 * step <= 0.0) | (d1 - 2.0 * a1 * step <= 0.0) | (d2 - 2.0 * a2 * step <= 0.0)
            if not bad.any():
                break
            step[bad] *= 0.5
        mu[live] = m + step
        conv = np.abs(step) * np.sqrt(g0 * g0 + g1 * g1 + g2 * g2) <= tol
        done[live[conv]] = True
        live = live[~conv]
    y = (y0 + mu * beta[:, None]) / (1.0 - 2.0 * mu * ev[:, None])
    return _affine(Q, y.T), done


def _roots(A, b, c, x, d):
    """Both roots (t1 <= t2) of f(x + t d) = 0 for local origins x (r, 3) and directions d (r, 3) (thesis eq. 5.6),
    NaN where there is none: a t² + bq t + cq with a = dᵀAd, bq = ∇f(x)·d, cq = f(x), by the stable formula
    q = -(bq + sign(bq)√disc)/2, t = q/a and cq/q.  a = 0 (a ray parallel to a generator of a cylinder or cone,
    or a plane) leaves the one linear root -cq/bq in t1 and NaN in t2."""
    a = _qform(A, d)
    bq = _dot(_gradient(A, b, x), d)
    cq = _value(A, b, c, x)
    disc = bq * bq - 4.0 * a * cq
    with np.errstate(divide="ignore", invalid="ignore"):
        q = -0.5 * (bq + np.copysign(np.sqrt(np.maximum(disc, 0.0)), bq))
        r1 = q / a
        r2 = cq / q
    none = disc < 0.0
    r1[none | ~np.isfinite(r1)] = np.nan
    r2[none | ~np.isfinite(r2)] = np.nan
    t1 = np.fmin(r1, r2)
    t2 = np.where(np.isnan(r1) | np.isnan(r2), np.nan, np.maximum(r1, r2))
    return t1, t2


class QuadricParts(NamedTuple):
    """A quadric f(x) = xᵀAx + bᵀx + c0 in local coordinates x = p - center (m), with A = Q diag(ev) Qᵀ and
    β = Qᵀb."""

    A: np.ndarray  # (3, 3)
    b: np.ndarray  # (3,)
    c0: float
    Q: np.ndarray  # (3, 3) eigenvectors of A (columns)
    ev: np.ndarray  # (3,) eigenvalues of A
    beta: np.ndarray  # (3,)


class _Traced(NamedTuple):
    """What the ray queries of one quadric use: its parts, cof(A) (3, 3) and its center (3,) m."""

    A: np.ndarray
    b: np.ndarray
    c0: float
    Q: np.ndarray
    ev: np.ndarray
    beta: np.ndarray
    cof: np.ndarray
    center: np.ndarray


def _cofactor(H: np.ndarray) -> np.ndarray:
    """Cofactor matrix (3, 3) of a symmetric 3x3 matrix (= its adjugate)."""
    return np.stack([np.cross(H[1], H[2]), np.cross(H[2], H[0]), np.cross(H[0], H[1])])


def _area_jacobian(A, cof, g, plane_normal, delta) -> np.ndarray:
    """Ratio dA_quadric / dA_plane (r,) of the projection along the quadric normal of a plane (unit normal
    ``plane_normal`` (r, 3)) onto the quadric, at foot points with gradient g (r, 3) and signed distance
    ``delta`` (r,) (plane point = foot + δ ∇f/|∇f|): |n_plane·n| / |1 + δ tr W + δ² det W| with the shape operator
    W of the surface (tr W = (tr H - nᵀHn)/|g|, det W = nᵀ cof(H) n / |g|², H = 2A; A (3, 3), cof = cof(A))."""
    gn = np.sqrt(_dot(g, g))
    n = g / gn[:, None]
    trW = (2.0 * np.trace(A) - 2.0 * _qform(A, n)) / gn
    detW = 4.0 * _qform(cof, n) / (gn * gn)  # cof(2A) = 4 cof(A)
    return np.abs(_dot(plane_normal, n)) / np.abs(1.0 + delta * trW + delta * delta * detW)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products (r, 3)."""
    out = np.empty((len(a), 3))
    a0, a1, a2, b0, b1, b2 = a[:, 0], a[:, 1], a[:, 2], b[:, 0], b[:, 1], b[:, 2]
    out[:, 0] = a1 * b2 - a2 * b1
    out[:, 1] = a2 * b0 - a0 * b2
    out[:, 2] = a0 * b1 - a1 * b0
    return out


def _rotate(v: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Vectors v (r, 3) rotated by the smallest rotations taking the unit vectors a (r, 3) onto b (r, 3)
    (Rodrigues; a·b > -1)."""
    w = _cross(a, b)
    c = _dot(a, b)
    return v * c[:, None] + _cross(w, v) + w * (_dot(w, v) / (1.0 + c))[:, None]


# ------------------------------------------------------------------------------------------------------ quadric
@dataclass(frozen=True, eq=False)
class Quadric:
    """A quadric surface f(p) = 0 with its fit diagnostics.

    ``coef`` (10,) coefficients of [1, x, y, z, x², xy, xz, y², yz, z²] in local coordinates x = p - ``center``
    (m; see the module docstring: a fitted quadric has mean |∇f| = 1 on its vertices and ∇f oriented like the FE
    face normals it was fitted to).  ``max_distance``, ``rms_distance`` (m): true distances |p - project(p)| of the
    fitted vertices; ``size`` (m): their bounding-box diagonal; ``name``: the region, for messages.
    """

    coef: np.ndarray
    center: np.ndarray = (0.0, 0.0, 0.0)
    max_distance: float = 0.0
    rms_distance: float = 0.0
    size: float = 1.0
    name: str = "quadric"

    def __post_init__(self):
        coef = np.asarray(self.coef, float)
        center = np.asarray(self.center, float)
        finite = np.all(np.isfinite(coef)) and np.all(np.isfinite(center))
        if coef.shape != (10,) or center.shape != (3,) or not finite:
            raise Fem2TmmError(f"quadric {self.name!r}: need 10 finite coefficients and a 3-vector center")
        if not np.any(coef[1:]):
            raise Fem2TmmError(f"quadric {self.name!r}: all non-constant coefficients are zero")
        object.__setattr__(self, "coef", coef)
        object.__setattr__(self, "center", center)

    @cached_property
    def parts(self) -> QuadricParts:
        """The quadric's :class:`QuadricParts` (A, b, c0, Q, ev, β) in local coordinates."""
        A, b, c0 = _split(self.coef)
        ev, Q = np.linalg.eigh(A)
        return QuadricParts(A, b, c0, Q, ev, Q.T @ b)

    @property
    def world_coefficients(self) -> np.ndarray:
        """(10,) coefficients of the same f in absolute coordinates p (m)."""
        A, b, c0 = self.parts[:3]
        o = self.center
        return _join(A, b - 2.0 * A @ o, c0 - b @ o + o @ A @ o)

    def _local(self, p):
        p = np.asarray(p, float)
        return np.atleast_2d(p) - self.center, p.ndim == 1

    def value(self, p) -> np.ndarray:
        """f(p) for points p (r, 3) or (3,) m; ≈ signed distance (m) near the surface of a fitted quadric."""
        x, one = self._local(p)
        A, b, c0 = self.parts[:3]
        v = _value(A, b, c0, x)
        return v[0] if one else v

    def gradient(self, p) -> np.ndarray:
        """∇f (r, 3) at points p (r, 3) (or (3,))."""
        x, one = self._local(p)
        A, b = self.parts[:2]
        g = _gradient(A, b, x)
        return g[0] if one else g

    def normal(self, p) -> np.ndarray:
        """Unit normals ∇f/|∇f| (r, 3) at points p (r, 3) (or (3,)): oriented like the FE face normals of the fit."""
        g = np.atleast_2d(self.gradient(p))
        n = _unit(g)
        return n[0] if np.ndim(p) == 1 else n

    def project(self, p) -> np.ndarray:
        """Foot points (r, 3) m of points p (r, 3) (or (3,)) on the quadric, along its normal (closest point near
        the surface; thesis §5.2.2).  Raises :class:`Fem2TmmError` if Newton does not converge (a point far from
        the surface, across a singular point)."""
        x, one = self._local(p)
        A, b, c0, Q, ev, beta = self.parts
        q, ok = _foot(Q, ev, beta, c0, x, 1e-14 * max(self.size, 1e-300))
        if not ok.all():
            raise Fem2TmmError(f"quadric {self.name!r}: projection of points {format_ids(np.flatnonzero(~ok))} "
                               "did not converge; they are too far from the surface")
        q = q + self.center
        return q[0] if one else q

    def distance(self, p) -> np.ndarray:
        """True distances |p - project(p)| (r,) m."""
        p2 = np.atleast_2d(np.asarray(p, float))
        d = np.linalg.norm(p2 - np.atleast_2d(self.project(p2)), axis=1)
        return d[0] if np.ndim(p) == 1 else d

    def intersect(self, origins, directions) -> tuple[np.ndarray, np.ndarray]:
        """Both ray parameters (t1 <= t2) (r,) where rays o + t d (origins (r, 3) m, directions (r, 3), any
        length) meet the quadric, NaN where there is none (one linear root in t1 when dᵀAd = 0)."""
        x, _ = self._local(origins)
        d = np.atleast_2d(np.asarray(directions, float))
        A, b, c0 = self.parts[:3]
        return _roots(A, b, c0, x, d)


def fit_quadric(points, normals=None, at=None, *, name: str = "region", tol: float = FIT_TOL) -> Quadric:
    """Taubin quadric fit of ``points`` (n, 3) m (n >= 9), thesis eq. 5.3-5.5 (see the module docstring).

    ``normals`` (k, 3): outward-of-the-front-side unit normals (FE face normals) at the points ``at`` (k, 3)
    (default: at ``points``, k = n).  They orient the quadric (mean ∇f·n > 0) and choose among quadrics that fit the
    points equally well; without them such an ambiguous fit raises :class:`Fem2TmmError`.  The fit is refused with a
    :class:`Fem2TmmError` naming ``name`` when the largest true vertex distance exceeds ``tol`` x the bounding-box
    diagonal (the region is not a quadric).  Returns a :class:`Quadric` with mean |∇f| = 1 on the points.
    """
    P = np.asarray(points, float)
    if P.ndim != 2 or P.shape[1] != 3 or not np.all(np.isfinite(P)):
        raise Fem2TmmError(f"{name}: quadric fit needs finite (n, 3) points, got shape {P.shape}")
    n = len(P)
    if n < 9:
        raise Fem2TmmError(f"{name}: a quadric fit needs at least 9 vertices, got {n}; enlarge the region")
    center = P.mean(axis=0)
    X = P - center
    scale = float(np.sqrt(np.max(np.sum(X * X, axis=1))))
    size = float(np.linalg.norm(np.ptp(P, axis=0)))
    if not scale > 0:
        raise Fem2TmmError(f"{name}: all vertices coincide; cannot fit a quadric")
    X /= scale
    D = _monomials(X)[:, 1:]
    mean = D.mean(axis=0)
    G = _monomial_gradients(X)[:, :, 1:].reshape(-1, 9) / np.sqrt(n)
    _, s, Wt = np.linalg.svd(G, full_matrices=False)
    keep = s > 1e-9 * s[0]
    B = Wt[keep].T / s[keep]  # (9, r): c_r = B y has cᵀNc = |y|²
    Aw = (D - mean) @ B / np.sqrt(n)
    _, sigma, Vt = np.linalg.svd(Aw, full_matrices=False)  # n >= 9 >= r: all r right singular vectors
    order = np.argsort(sigma, kind="stable")
    # several quadrics fit alike (only worth resolving when the best one fits: otherwise the distance check refuses)
    near = order[sigma[order] <= max(AMBIGUITY, 3.0 * sigma[order[0]])] if sigma[order[0]] <= tol else order[:1]
    C = np.zeros((10, near.size))
    C[1:] = B @ Vt[near].T
    C[0] = -mean @ C[1:]
    if normals is not None:
        Nn = np.asarray(normals, float)
        Xa = (P if at is None else np.asarray(at, float)) - center
        if Nn.ndim != 2 or Nn.shape[1] != 3 or Xa.shape != Nn.shape:
            raise Fem2TmmError(f"{name}: normals {Nn.shape} and their points {Xa.shape} must be (k, 3) alike")
        Ga = _monomial_gradients(Xa / scale) @ C  # (k, 3, m) gradients of the candidate quadrics
        if near.size > 1:
            a = np.linalg.lstsq(Ga.reshape(-1, near.size), Nn.ravel(), rcond=None)[0]
        else:
            a = np.array([1.0 if np.sum(Ga[:, :, 0] * Nn) >= 0 else -1.0])
    elif near.size > 1:
        raise Fem2TmmError(
            f"{name}: the vertices lie on {near.size} independent quadrics (a plane, two node rings of a "
            "cylinder, a strip only a few elements wide); pass the face normals (fit_regions does) or fit a "
            "larger region")
    else:
        a = np.ones(1)
    c = C @ a
    # back to metres: degree-k coefficients scale by scale^-k; then mean |∇f| = 1 on the vertices
    c[1:4] /= scale
    c[4:] /= scale * scale
    A, b, c0 = _split(c)
    gn = np.linalg.norm(_gradient(A, b, P - center), axis=1).mean()
    if not gn > 0:
        raise Fem2TmmError(f"{name}: degenerate quadric fit (zero gradient on the vertices)")
    q = Quadric(c / gn, center, size=size, name=name)
    A, b, c0, Qe, ev, beta = q.parts
    foot, ok = _foot(Qe, ev, beta, c0, P - center, 1e-14 * size)
    dist = np.linalg.norm(foot - (P - center), axis=1)
    dist[~ok] = np.inf
    dmax, drms = float(dist.max()), float(np.sqrt(np.mean(dist**2)))
    if not dmax <= tol * size:
        raise Fem2TmmError(
            f"{name} is not a quadric: its vertices are up to {dmax:.3g} m (RMS {drms:.3g} m) from the best-fitting "
            f"quadric, more than {tol:g} x its size {size:.3g} m; untag it (quadric = false) or split it into "
            "regions that are cones, cylinders, spheres or paraboloids")
    return Quadric(q.coef, center, max_distance=dmax, rms_distance=drms, size=size, name=name)


def face_frames(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area-weighted centroids (f, 3) and unit right-hand normals (f, 3) of faces (f, 3|4) (quads as the triangles
    (0, 1, 2) and (0, 2, 3))."""
    f = pad_faces(faces)
    p = np.asarray(points, float)
    p0, p1, p2 = p[f[:, 0]], p[f[:, 1]], p[f[:, 2]]
    c1 = np.cross(p1 - p0, p2 - p0)
    a1 = np.linalg.norm(c1, axis=1)
    cen = (p0 + p1 + p2) / 3 * a1[:, None]
    nrm, area = c1.copy(), a1.copy()
    quad = f[:, 3] >= 0
    if quad.any():
        p3 = p[f[quad, 3]]
        c2 = np.cross(p2[quad] - p0[quad], p3 - p0[quad])
        a2 = np.linalg.norm(c2, axis=1)
        cen[quad] += (p0[quad] + p2[quad] + p3) / 3 * a2[:, None]
        nrm[quad] += c2
        area[quad] += a2
    return cen / np.where(area > 0, area, 1.0)[:, None], _unit(nrm)


def fit_regions(points, faces, region_of_face, names=None, tol: float = FIT_TOL):
    """One :func:`fit_quadric` per region of faces.

    ``points`` (n, 3) m, ``faces`` (f, 3|4), ``region_of_face`` (f,) int (-1: not fitted; other values any ids).
    Each region is fitted on its vertices, with its face normals at its face centroids (orientation and
    disambiguation).  ``names``: a mapping or sequence id -> name for messages (default "region <id>").
    Returns ``(quadrics (list of K), quadric_of_face (f,) int in -1..K-1)``, regions in increasing id order.
    """
    f = pad_faces(faces)
    reg = np.asarray(region_of_face)
    if reg.shape != (len(f),) or not np.issubdtype(reg.dtype, np.integer):
        raise Fem2TmmError(f"region_of_face must be one int per face ({len(f)},), got {reg.shape} {reg.dtype}")
    ids, qf = np.unique(reg, return_inverse=True)
    qf = qf.ravel()
    if ids.size and ids[0] < 0:
        if ids[0] < -1:
            raise Fem2TmmError("region ids must be >= 0, or -1 for faces that are not fitted")
        ids, qf = ids[1:], qf - 1
    cen, nrm = face_frames(points, f)
    order = np.argsort(qf, kind="stable")
    start = np.searchsorted(qf[order], np.arange(len(ids) + 1))
    quadrics = []
    pts = np.asarray(points, float)
    for k, rid in enumerate(ids):  # loop over regions
        mine = order[start[k] : start[k + 1]]
        nodes = np.unique(f[mine])
        nodes = nodes[nodes >= 0]
        name = (names[rid] if names is not None else f"region {rid}")
        quadrics.append(fit_quadric(pts[nodes], nrm[mine], cen[mine], name=name, tol=tol))
    return quadrics, qf.astype(np.int64)


# -------------------------------------------------------------------------------------------------------- scene
class QuadricScene(TriangleScene):
    """Ray scene of a :class:`Surface` whose faces ``quadric_of_face`` (f,) int (-1: flat; k: quadric k of
    ``quadrics``, one per fitted region) are traced against their fitted quadrics (thesis §5.2; module docstring).

    Flat faces go through Embree (with the base class' offsets and self-hit rejection).  Regions whose quadrics
    coincide (adjacent regions on which each other's quadric fits as well as their own, within max(1e-9 x the scene
    diagonal, twice their fit distance): per-super-face fits of one cone) are traced as one *surface* with the first
    one's quadric.  For each surface, rays that cross the bounding box of its patches get both exact roots; a root
    is a hit when the surface's normal line there crosses one of its facets within ±``reach`` (twice the largest
    facet-to-quadric distance plus 16 origin offsets), found by Embree in one scene of all quadric facets; the
    closest hit over flat faces and surfaces wins, and the facet found names the face hit.  The hit normal is the
    quadric normal, oriented per face like the FE face normal (front/back sides keep their meaning; the faces of a
    region may be oriented either way); specular and diffuse directions use it.

    Emission (:meth:`emit_weighted`): origins sampled on the facets, projected onto the quadric along its normal,
    directions rotated from the facet normal to the quadric normal, and ray weights J(x) / (mean J over the
    triangle) with J the area Jacobian of the projection.  ``tri_area`` holds the area of each triangle's patch on
    its quadric (quadrature of J, see :meth:`_setup_areas`; ``tri_area_fe`` the facet areas), so emission tables,
    ``area`` and ``eps_area`` of the tracers are true curved areas.  Solar sampling (:meth:`facing_areas`,
    :meth:`sample_facing`) weighs the quadric's own projected area facing the Sun.  ``weighted=False`` gives every ray
    of a triangle the same energy (the thesis' assumption that projected samples stay uniform).
    Cost: the bounce loop pays one slab test per ray and surface, so keep the number of distinct surfaces small.
    """

    def __init__(self, surface: Surface, quadric_of_face, quadrics, backend: str = "auto", weighted: bool = True):
        super().__init__(surface, backend, engine=False)
        self._args = (surface, quadric_of_face, quadrics, backend, weighted)
        f = surface.n_faces
        qf = np.asarray(quadric_of_face)
        K = len(quadrics)
        bad = qf.shape != (f,) or not np.issubdtype(qf.dtype, np.integer)
        if bad or (qf.size and (qf.min() < -1 or qf.max() >= K)):
            raise Fem2TmmError(f"quadric_of_face must be one int per face ({f},) in -1..{K - 1}, got {qf.shape} "
                               f"{qf.dtype}")
        self.quadrics = tuple(quadrics)
        self.quadric_of_face = qf.astype(np.int64)
        self.weighted = bool(weighted)
        self.tri_quadric = self.quadric_of_face[self.tri_face]
        self.tri_area_fe = self.tri_area
        self._facing_cache = {}
        # traced parameters per quadric; merged regions share them
        self._params = [_Traced(*q.parts, _cofactor(q.parts.A), q.center) for q in self.quadrics]
        self._tol = [1e-14 * max(q.size, self.diagonal) for q in self.quadrics]
        # flat faces: a scene of their own (same triangle order as this one's flat triangles)
        self._flat_tri = np.flatnonzero(self.tri_quadric < 0)
        self._quad_tri = np.flatnonzero(self.tri_quadric >= 0)
        self._flat = None
        if self._flat_tri.size:
            flat_faces = np.flatnonzero(self.quadric_of_face < 0)
            self._flat = TriangleScene(Surface(surface.points, surface.faces[flat_faces]), backend)
            self._flat.eps = self.eps
            if not np.array_equal(self._flat.tri_vertices, self.tri_vertices[self._flat_tri]):
                raise AssertionError("flat sub-scene triangles out of order")  # pragma: no cover - invariant
        self._flat_local = np.full(len(self.tri_face), -1, np.int64)
        self._flat_local[self._flat_tri] = np.arange(self._flat_tri.size)
        self._facets = make_engine(self.tri_vertices[self._quad_tri], backend) if self._quad_tri.size else None
        self.engine = self._flat.engine if self._flat is not None else self._facets
        self._tri_sign = np.ones(len(self.tri_face))
        self._ratio = np.ones(len(self.tri_face))
        self.surface_of_quadric = np.arange(K)
        if self._quad_tri.size:
            self._setup_surfaces()
            self._setup_areas()

    def _init_args(self) -> tuple:
        return self._args  # fitted quadrics included; see TriangleScene.__reduce__

    @classmethod
    def from_regions(cls, surface: Surface, region_of_face, names=None, tol: float = FIT_TOL, backend: str = "auto",
                     weighted: bool = True) -> "QuadricScene":
        """Fit one quadric per region (:func:`fit_regions`; ``region_of_face`` (f,) int, -1 flat) and build the
        scene."""
        quadrics, qf = fit_regions(surface.points, surface.faces, region_of_face, names=names, tol=tol)
        return cls(surface, qf, quadrics, backend=backend, weighted=weighted)

    @property
    def n_surfaces(self) -> int:
        """Number of distinct traced quadric surfaces (after merging coinciding regions)."""
        return len(self._surfaces)

    # ------------------------------------------------------------------------------------------------ kernels
    def _by_quadric(self, prim: np.ndarray):
        """[(k, rows)]: the rows of ``prim`` (quadric triangles) on each quadric k (a loop over quadrics then uses
        shared 3 x 3 matrices)."""
        k = self.tri_quadric[prim]
        if len(self.quadrics) == 1 or (k.size and k.min() == k.max()):
            return [(int(k[0]) if k.size else 0, slice(None))]
        order = np.argsort(k, kind="stable")
        cuts = np.flatnonzero(np.diff(k[order])) + 1
        return [(int(k[rows[0]]), rows) for rows in np.split(order, cuts) if rows.size]

    def _lift(self, prim: np.ndarray, p: np.ndarray, check: bool = True):
        """Points p (r, 3) on quadric triangles ``prim`` (r,): ``(foot points (r, 3), unit front normals (r, 3),
        area Jacobian (r,), distance |p - foot| (r,))``."""
        q = np.empty_like(p)
        n = np.empty_like(p)
        J = np.empty(len(p))
        dist = np.empty(len(p))
        for k, rows in self._by_quadric(prim):  # loop over quadrics
            A, b, c0, Q, ev, beta, cof, o = self._params[k]  # a _Traced
            x = p[rows] - o
            qk, ok = _foot(Q, ev, beta, c0, x, self._tol[k])
            if check and not ok.all():
                bad = np.unique(self.tri_face[prim[rows][~ok]])
                raise Fem2TmmError(f"faces {format_ids(bad)}: points on them do not project onto their quadric; the "
                                   "quadric does not fit these faces")
            g = _gradient(A, b, qk)
            nk = _unit(g)
            delta = _dot(x - qk, nk)
            J[rows] = _area_jacobian(A, cof, g, self.tri_normal[prim[rows]], delta)
            q[rows] = qk + o
            n[rows] = nk * self._tri_sign[prim[rows]][:, None]
            dist[rows] = np.where(ok, np.abs(delta), np.inf)
        return q, n, J, dist

    def _front_normals(self, prim: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Unit front normals (r, 3) of quadric triangles ``prim`` (r,) at points p (r, 3) on their quadric."""
        n = np.empty_like(p)
        for k, rows in self._by_quadric(prim):  # loop over quadrics
            A, b, o = self._params[k].A, self._params[k].b, self._params[k].center
            n[rows] = _unit(_gradient(A, b, p[rows] - o))
        return n * self._tri_sign[prim][:, None]

    def _rule_points(self, tris: np.ndarray, rule):
        """Foot points (t, q, 3), area Jacobians (t, q) and facet-to-quadric distances (t, q) at the points of a
        barycentric ``rule`` on quadric triangles ``tris`` (t,)."""
        bary = rule[0]
        X = np.einsum("qb,tbc->tqc", bary, self.tri_vertices[tris]).reshape(-1, 3)
        q, _, J, dist = self._lift(np.repeat(tris, len(bary)), X)
        return q.reshape(len(tris), len(bary), 3), J.reshape(len(tris), -1), dist.reshape(len(tris), -1)

    # ------------------------------------------------------------------------------------------------- set-up
    def _setup_surfaces(self):
        """Merge coinciding quadrics into traced surfaces, then orient every quadric face like its FE normal."""
        K = len(self.quadrics)
        sf = self.surface
        faces = np.unique(self.tri_face[self._quad_tri])
        first_tri = np.searchsorted(self.tri_face, faces)
        cen, nrm = face_frames(sf.points, sf.faces[faces])
        kf = self.quadric_of_face[faces]
        foot, _, _, dist = self._lift(first_tri, cen, check=False)
        bad = ~np.isfinite(dist)
        if bad.any():
            raise Fem2TmmError(f"faces {format_ids(faces[bad])} do not project onto their quadric: the quadric does "
                               "not fit them; check the region or untag it")
        # probe points of each region: its vertices and its face centroids projected onto its own quadric
        fn = sf.faces[faces]
        probe_pts = np.concatenate([foot, sf.points[fn[fn >= 0]]])
        probe_k = np.concatenate([kf, np.repeat(kf, (fn >= 0).sum(axis=1))])
        # candidate pairs: regions sharing a node
        rows = fn[fn >= 0]
        cols = np.repeat(kf, (fn >= 0).sum(axis=1))
        R = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(len(sf.points), K))
        P = sp.triu(R.T @ R, k=1).tocoo()
        parent = np.arange(K)

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        def fits(i, j):
            """Quadric j fits region i's probes as well as i's own quadric does."""
            pts = probe_pts[probe_k == i]
            tq = self._params[j]
            A, b, c0, o = tq.A, tq.b, tq.c0, tq.center
            x = pts - o
            d = np.abs(_value(A, b, c0, x)) / np.sqrt(_dot(*(2 * [_gradient(A, b, x)])))
            return float(d.max()) <= max(1e-9 * self.diagonal, 2.0 * self.quadrics[i].max_distance)

        for i, j in zip(P.row.tolist(), P.col.tolist()):  # loop over adjacent region pairs
            ri, rj = find(i), find(j)
            if ri != rj and fits(i, j) and fits(j, i) and fits(i, rj) and fits(j, ri):
                parent[max(ri, rj)] = min(ri, rj)
        rep = np.array([find(i) for i in range(K)])  # loop over quadrics
        for k in np.flatnonzero(rep != np.arange(K)):  # merged regions trace their representative's quadric
            self._params[k] = self._params[rep[k]]
            self._tol[k] = self._tol[rep[k]]
        self._surfaces, self.surface_of_quadric = np.unique(rep, return_inverse=True)
        self.surface_of_quadric = self.surface_of_quadric.ravel()
        # orientation per face: sign of (facet normal . traced quadric normal) at the projected face centroid
        _, n, _, _ = self._lift(first_tri, cen)
        cos = _dot(n, nrm)
        bad = np.abs(cos) < MIN_ALIGNMENT
        if bad.any():
            raise Fem2TmmError(f"faces {format_ids(faces[bad])} are more than 60° off their quadric's normal: the "
                               "quadric does not fit them; check the region or untag it")
        face_sign = np.ones(sf.n_faces)
        face_sign[faces] = np.where(cos >= 0, 1.0, -1.0)
        self._tri_sign = face_sign[self.tri_face]

    def _setup_areas(self):
        """Quadric area of each triangle's patch, membership reach and bounding boxes of the traced surfaces.

        Area: quadrature of the projection's area Jacobian J, 7-point rule; its error falls as (element size /
        curvature radius)^6 (80-triangle icosphere 3e-5, 320: 5e-7), so on triangles whose facet-to-quadric gap
        exceeds 0.2 % of their longest edge (size / radius > ~0.03) it is repeated on a 2 x 2 subdivision, and on a
        4 x 4 one where the two differ by more than 6e-9 (estimated error 1e-10; 80-triangle icosphere 5e-9)."""
        qt = self._quad_tri
        V = self.tri_vertices[qt]
        A_fe = self.tri_area[qt]
        Xq, J, dist = self._rule_points(qt, RULE7)
        aq = A_fe * (J @ RULE7[1])
        gap = dist.max(axis=1)  # facet-to-quadric gap at the rule points (largest inside a facet, 0 at vertices)
        edge = np.linalg.norm(V - V[:, [1, 2, 0]], axis=2).max(axis=1)
        coarse = np.flatnonzero(gap > 2e-3 * edge)
        if coarse.size:
            rule2 = subdivided_rule(2)
            a2 = A_fe[coarse] * (self._rule_points(qt[coarse], rule2)[1] @ rule2[1])
            fine = coarse[np.abs(aq[coarse] - a2) > 6e-9 * a2]
            aq[coarse] = a2
            if fine.size:
                rule4 = subdivided_rule(4)
                aq[fine] = A_fe[fine] * (self._rule_points(qt[fine], rule4)[1] @ rule4[1])
        self._ratio[qt] = np.divide(aq, A_fe, out=np.ones_like(aq), where=A_fe > 0)
        self.tri_area = self.tri_area.copy()
        self.tri_area[qt] = aq
        # per traced surface: reach of the membership test (twice the largest gap plus 16 origin offsets) and the
        # bounding box of its patches (vertices and rule-point feet, padded by the reach)
        S = self.n_surfaces
        st = self.surface_of_quadric[self.tri_quadric[qt]]
        reach = np.zeros(S)
        np.maximum.at(reach, st, gap)
        self.reach = 2.0 * reach + 16.0 * self.eps
        lo = np.minimum(V.min(axis=1), Xq.min(axis=1))
        hi = np.maximum(V.max(axis=1), Xq.max(axis=1))
        box = np.empty((S, 2, 3))
        box[:, 0], box[:, 1] = np.inf, -np.inf
        np.minimum.at(box[:, 0], st, lo)
        np.maximum.at(box[:, 1], st, hi)
        pad = (self.reach + self.eps)[:, None]
        box[:, 0] -= pad
        box[:, 1] += pad
        self._box = box

    # ----------------------------------------------------------------------------------------------- queries
    def _member(self, s: int, q: np.ndarray) -> np.ndarray:
        """Triangle (r,) of traced surface s under points q (r, 3) on it along its normal line, -1 outside s."""
        k = int(self._surfaces[s])
        A, b, o = self._params[k].A, self._params[k].b, self._params[k].center
        n = _unit(_gradient(A, b, q - o))
        h = self.reach[s]
        hit, tm = self._facets.intersect(q - h * n, n)
        hit = np.asarray(hit, np.int64)
        ok = (hit >= 0) & (tm <= 2.0 * h)
        out = np.full(len(q), -1, np.int64)
        g = self._quad_tri[hit[ok]]
        mine = self.surface_of_quadric[self.tri_quadric[g]] == s
        out[np.flatnonzero(ok)[mine]] = g[mine]
        return out

    def intersect(self, origins: np.ndarray, directions: np.ndarray, leaving: np.ndarray, out=None):
        """Closest hit over flat faces (Embree) and quadric patches (exact roots): ``(prim (r,), t (r,))`` with
        the same conventions as :meth:`TriangleScene.intersect` (prim -1 on a miss, t = -1 for a lost ray; origins of
        flat rays re-traced after a self hit are updated in place); t is float64 and exact on quadric hits.  ``out``
        is not used."""
        r = len(origins)
        prim = np.full(r, -1, np.int64)
        best = np.full(r, np.inf)
        lost = np.zeros(r, bool)
        if self._flat is not None:
            lv = np.where(leaving >= 0, self._flat_local[np.maximum(leaving, 0)], -1)
            pl, tl = self._flat.intersect(origins, directions, lv)
            pl = np.asarray(pl, np.int64)
            hit = pl >= 0
            prim[hit] = self._flat_tri[pl[hit]]
            best[hit] = tl[hit]
            lost = ~hit & (tl == -1)
            best[lost] = -np.inf  # nothing is closer: the ray stays lost
        if self._facets is not None and r:
            O = np.ascontiguousarray(origins.T)
            with np.errstate(divide="ignore"):
                inv = np.ascontiguousarray(1.0 / directions.T)
            for s in range(self.n_surfaces):  # loop over traced surfaces
                tn, tf = _slab(O, inv, self._box[s])
                cand = np.flatnonzero((tf >= tn) & (tn < best))
                if cand.size == 0:
                    continue
                k = int(self._surfaces[s])
                tq = self._params[k]
                A, b, c0, o = tq.A, tq.b, tq.c0, tq.center
                d = directions[cand]
                for root in _roots(A, b, c0, origins[cand] - o, d):  # t1 then t2
                    with np.errstate(invalid="ignore"):
                        ok = (root > 0.0) & (root < best[cand]) & (root <= tf[cand] + self.eps)
                    if not ok.any():
                        continue
                    sel = cand[ok]
                    tt = root[ok]
                    m = self._member(s, origins[sel] + tt[:, None] * directions[sel])
                    acc = m >= 0
                    best[sel[acc]] = tt[acc]
                    prim[sel[acc]] = m[acc]
        t = np.where(prim >= 0, best, np.inf)
        t[lost] = -1.0
        return prim, t

    def hit_geometry(self, prim, origins, directions, t):
        face = self.tri_face[prim]
        p = origins + t[:, None] * directions
        nrm = self.tri_normal[prim]
        m = self.tri_quadric[prim] >= 0
        if m.any():
            nrm[m] = self._front_normals(prim[m], p[m])
        return face, p, nrm

    def hit_normals(self, prim, origins, directions, t):
        """Quadric front normals at the hit points of rays hitting quadric patches (the triangles' own elsewhere)."""
        hit = prim >= 0
        q = np.flatnonzero(hit & (self.tri_quadric[np.maximum(prim, 0)] >= 0))
        if q.size == 0:
            return super().hit_normals(prim, origins, directions, t)
        nrm = self.tri_normal[np.maximum(prim, 0)]
        p = origins[q] + t[q, None] * directions[q]
        nrm[q] = self._front_normals(prim[q], p)
        return nrm

    def _curved_triangles(self) -> np.ndarray:
        return self.tri_quadric >= 0

    def offset(self, prim, points, sign, normals=None):
        if normals is None:
            m = np.flatnonzero(self.tri_quadric[prim] >= 0)
            normals = self.tri_normal[prim]
            if m.size:
                normals[m] = self._front_normals(prim[m], points[m])
        return super().offset(prim, points, sign, normals)

    def sample(self, prim, u, v):
        p, n, _ = self._sample(prim, u, v)
        return p, n

    def sample_weighted(self, prim, u, v):
        """Points on the quadric (or facets), front normals and weights J / (mean J over the triangle) on quadric
        triangles (1 elsewhere; None when the batch has none or the scene is unweighted)."""
        p, n, J = self._sample(prim, u, v)
        j = np.flatnonzero(self.tri_quadric[prim] >= 0)
        if j.size == 0 or not self.weighted:
            return p, n, None
        w = np.ones(len(prim))
        w[j] = J[j] / self._ratio[prim[j]]
        return p, n, w

    def _sample(self, prim, u, v):
        """Points and front normals on the quadric (quadric triangles) or facets, and the area Jacobian (r,)."""
        p, n = super().sample(prim, u, v)
        J = np.ones(len(prim))
        j = np.flatnonzero(self.tri_quadric[prim] >= 0)
        if j.size:
            p[j], n[j], J[j], _ = self._lift(prim[j], p[j])
        return p, n, J

    def emit(self, prim, sign, U):
        return self.emit_weighted(prim, sign, U)[:2]

    def emit_group_rays(self, emitters, group, U):
        """:meth:`TriangleScene.emit_group_rays` through :meth:`emit_weighted` (projected origins, rotated
        directions, Jacobian weights)."""
        entry, U[:, 0] = emitters.locate(group, U[:, 0])
        prim = emitters.entry_prim[entry]
        o, d, w = self.emit_weighted(prim, 1.0 - 2.0 * emitters.entry_side[entry], U)
        return o, d, prim, w

    def emit_weighted(self, prim, sign, U):
        """Rays as :meth:`TriangleScene.emit`; on quadric triangles the origin is projected onto the quadric along
        its normal, the direction rotated from the facet normal to the quadric normal and the weight (r,) is
        J / (mean J over the triangle) (1 on flat triangles; all 1 when ``weighted`` is False)."""
        sign = np.broadcast_to(np.asarray(sign, float), (len(prim),))
        # the base class' emission, step by step: point, cosine direction in the facet frame, offset origin
        o, nt = TriangleScene.sample(self, prim, U[:, 0], U[:, 1])
        d = TriangleScene.scatter(self, prim, nt, sign, U[:, 2], U[:, 3])
        w = np.ones(len(prim))
        quad = self.tri_quadric[prim] >= 0
        j = np.flatnonzero(~quad)
        if j.size:
            o[j] = TriangleScene.offset(self, prim[j], o[j], sign[j])
        j = np.flatnonzero(quad)
        if j.size:
            pj = prim[j]
            q, n, J, _ = self._lift(pj, o[j])
            s = sign[j][:, None]
            d[j] = _rotate(d[j], nt[j] * s, n * s)
            o[j] = q + self.eps * s * n
            if self.weighted:
                w[j] = J / self._ratio[pj]
        return o, d, w

    def facing_areas(self, direction):
        """As :meth:`TriangleScene.facing_areas`; on a quadric triangle, ∫ max(±n·s, 0) dA over its patch (7-point
        rule of n·s J over the facet, on a 8 x 8 subdivision for triangles whose patch straddles the terminator).
        Cached per direction."""
        return self._facing(direction)[0].copy()

    def _facing(self, direction):
        """(facing areas (t, 2) m², their means over each facet (t, 2)), cached per direction."""
        direction = np.asarray(direction, float)
        key = tuple(direction.tolist())
        if key not in self._facing_cache:
            out = super().facing_areas(direction)
            qt = self._quad_tri
            if qt.size:
                out[qt] = self._facing_integral(qt, direction, RULE7)
                bary = np.vstack([RULE7[0], np.eye(3)])
                X = np.einsum("qb,tbc->tqc", bary, self.tri_vertices[qt]).reshape(-1, 3)
                cos_v = _dot(self._lift(np.repeat(qt, len(bary)), X)[1], direction[None]).reshape(len(qt), -1)
                split = (cos_v.max(axis=1) > 0) & (cos_v.min(axis=1) < 0)
                if split.any():
                    out[qt[split]] = self._facing_integral(qt[split], direction, subdivided_rule(8))
            mean = np.divide(out, self.tri_area_fe[:, None], out=np.zeros_like(out),
                             where=self.tri_area_fe[:, None] > 0)
            self._facing_cache[key] = (out, mean)
        return self._facing_cache[key]

    def _facing_integral(self, tris, direction, rule):
        bary, w = rule
        X = np.einsum("qb,tbc->tqc", bary, self.tri_vertices[tris]).reshape(-1, 3)
        _, n, J, _ = self._lift(np.repeat(tris, len(w)), X)
        c = (_dot(n, direction[None]) * J).reshape(len(tris), -1)
        return np.stack([np.maximum(c, 0.0) @ w, np.maximum(-c, 0.0) @ w], axis=1) * self.tri_area_fe[tris][:, None]

    def sample_facing(self, prim, sign, u, v, direction):
        """Points on the quadric (or facets), front normals, and weights (r,) max(±n·s, 0) J / (mean of that over
        the triangle's side) on quadric triangles (None when the batch has none)."""
        p, n, J = self._sample(prim, u, v)
        j = np.flatnonzero(self.tri_quadric[prim] >= 0)
        if j.size == 0:
            return p, n, None
        sign = np.broadcast_to(np.asarray(sign, float), (len(prim),))
        w = np.ones(len(prim))
        pj = prim[j]
        mean = self._facing(direction)[1][pj, (sign[j] < 0).astype(np.int64)]
        local = np.maximum(sign[j] * _dot(n[j], np.asarray(direction, float)[None]), 0.0) * J[j]
        w[j] = np.divide(local, mean, out=np.zeros_like(local), where=mean > 0)
        return p, n, w


def _slab(O: np.ndarray, inv: np.ndarray, box: np.ndarray):
    """Entry and exit distances (r,) of rays (origins O (3, r), inverse directions inv (3, r)) through the box
    (2, 3) (lo, hi); entry clipped at 0; axes where 0 x inf gives NaN are ignored."""
    tn = np.zeros(O.shape[1])
    tf = np.full(O.shape[1], np.inf)
    with np.errstate(invalid="ignore"):
        for c in range(3):  # loop over x, y, z
            a = (box[0, c] - O[c]) * inv[c]
            b = (box[1, c] - O[c]) * inv[c]
            np.fmax(tn, np.fmin(a, b), out=tn)
            np.fmin(tf, np.fmax(a, b), out=tf)
    return tn, tf
