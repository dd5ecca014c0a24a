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

from ..arrays import unique
from ..errors import Fem2TmmError, format_ids
from .surfaces import pad_faces

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
    ids, qf = unique(reg, return_inverse=True)
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
        nodes = unique(f[mine])
        nodes = nodes[nodes >= 0]
        name = (names[rid] if names is not None else f"region {rid}")
        quadrics.append(fit_quadric(pts[nodes], nrm[mine], cen[mine], name=name, tol=tol))
    return quadrics, qf.astype(np.int64)

