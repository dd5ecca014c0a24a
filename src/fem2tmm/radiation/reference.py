"""Deterministic reference values for the ray tracer: view factors and radiative exchange factors (REFs) between a
few mutually visible planar convex polygons (what the tests and the κ studies of the checkout's ``benchmarks/``
compare against).

Everything here is pure numpy/scipy and independent of the tracer (no Embree, no Halton, no ``Surface``).

* Closed forms (Howell's catalogue, cases C-11 and C-14, and the differential element at the corner of a parallel
  rectangle): :func:`parallel_rectangles_view_factor`, :func:`perpendicular_rectangles_view_factor`,
  :func:`point_rectangle_view_factor`.
* :func:`point_polygon_view_factor`: exact view factor from a differential area to a polygon (Lambert's contour
  formula, a sum over the polygon's edges).
* :func:`polygon_view_factor`: F₁₂ between two polygons by the Mitalas-Stephenson contour double integral
  A₁F₁₂ = 1/(2π) ∮∮ ln r dr₁·dr₂, inner edge integral in closed form, outer one by Gauss-Legendre after a sigmoidal
  change of variable at the points where the two contours touch: exact to ~1e-13 also for polygons sharing an edge.
* :func:`gebhart_polygons`: the REF matrix ℱ (fraction of the power emitted by polygon i, diffuse and uniform, that
  is finally absorbed by polygon j after any number of diffuse reflections) by a Nyström discretisation of the
  integral equation for the point-wise irradiance: Gauss-Legendre points on each polygon, the kernel
  cosθ₁cosθ₂/(πr²) between all points of different polygons, one dense linear solve.  Exponentially convergent in
  the order when no two polygons touch (smooth kernel); the reflected radiance is resolved point-wise, not assumed
  uniform per face.

The κ studies that use these references (jittered and ball-indicator estimators) live in the checkout's
``benchmarks/kappa.py``, not in the package.

The thesis case (L. Jacques 2016, §2.3.5) is :data:`TWO_QUADS` with ε = 0.8, ρ = 0.2; :func:`two_quads_ref`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


__all__ = ["TWO_QUADS", "GebhartResult", "parallel_rectangles_view_factor", "perpendicular_rectangles_view_factor",
           "point_rectangle_view_factor", "point_polygon_view_factor", "polygon_quadrature", "polygon_view_factor",
           "gebhart_polygons", "gebhart_convergence", "two_quads_ref", "polygon_plane"]

#: Thesis §2.3.5: face 1 (normal +z) and face 2 (normal +x), vertices in metres, counter-clockwise about the normal.
TWO_QUADS = (
    np.array([[1.0, 0.0, 0.0], [6.0, -1.0, 0.0], [6.0, 5.5, 0.0], [1.0, 5.0, 0.0]]),
    np.array([[0.0, 0.0, 0.5], [0.0, 4.0, 0.5], [0.0, 5.0, 4.5], [0.0, -1.0, 4.5]]),
)


# ----------------------------------------------------------------------------------------------------------------
# closed forms
# ----------------------------------------------------------------------------------------------------------------

def parallel_rectangles_view_factor(a: float, b: float, c: float) -> float:
    """F between two directly opposed, aligned a x b rectangles at distance c (Howell C-11)."""
    x, y = a / c, b / c
    sx, sy = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
    return float(2 / (np.pi * x * y) * (np.log(sx * sy / np.sqrt(1 + x * x + y * y)) + x * sy * np.arctan(x / sy)
                                        + y * sx * np.arctan(y / sx) - x * np.arctan(x) - y * np.arctan(y)))


def perpendicular_rectangles_view_factor(w: float, h: float, length: float) -> float:
    """F₁₂ from a rectangle of width ``w`` to a perpendicular one of height ``h`` sharing an edge of ``length``
    (Howell C-14); unit squares: 0.200044 (thesis eq. 1.35)."""
    W, H = w / length, h / length
    W2, H2 = W * W, H * H
    s = np.sqrt(W2 + H2)
    log_term = (np.log((1 + W2) * (1 + H2) / (1 + W2 + H2)) + W2 * np.log(W2 * (1 + W2 + H2) / ((1 + W2) * (W2 + H2)))
                + H2 * np.log(H2 * (1 + W2 + H2) / ((1 + H2) * (W2 + H2))))
    return float((W * np.arctan(1 / W) + H * np.arctan(1 / H) - s * np.arctan(1 / s) + 0.25 * log_term) / (np.pi * W))


def point_rectangle_view_factor(a: float, b: float, c: float) -> float:
    """F from a differential area to a parallel a x b rectangle at distance c, the area's normal passing through a
    corner of the rectangle (Howell B-3)."""
    A, B = a / c, b / c
    sa, sb = np.sqrt(1 + A * A), np.sqrt(1 + B * B)
    return float((A / sa * np.arctan(B / sa) + B / sb * np.arctan(A / sb)) / (2 * np.pi))


# ----------------------------------------------------------------------------------------------------------------
# polygons
# ----------------------------------------------------------------------------------------------------------------

def polygon_plane(vertices) -> tuple[np.ndarray, np.ndarray, float]:
    """Checked (k, 3) vertices, the unit right-hand normal and the area of a planar convex polygon."""
    v = np.asarray(vertices, float)
    if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3:
        raise ValueError("a polygon is a (k >= 3, 3) array of vertices")
    c = v.mean(axis=0)
    vec = np.cross(v - c, np.roll(v, -1, axis=0) - c).sum(axis=0)  # 2 x vector area
    area = 0.5 * np.linalg.norm(vec)
    if area <= 0:
        raise ValueError("degenerate polygon")
    n = vec / (2 * area)
    size = np.ptp(v, axis=0).max()
    if np.abs((v - c) @ n).max() > 1e-9 * size:
        raise ValueError("polygon is not planar")
    turns = np.cross(np.roll(v, -1, axis=0) - v, np.roll(v, -2, axis=0) - np.roll(v, -1, axis=0)) @ n
    if turns.min() < -1e-12 * size * size:
        raise ValueError("polygon is not convex (or its vertices are not ordered)")
    return v, n, float(area)


def polygon_quadrature(vertices, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gauss-Legendre rule on a planar convex polygon: ``(points (q, 3), weights (q,) in m², unit normal (3,))``.

    A quadrangle is one bilinear patch x(u, v) (``order`` x ``order`` points, weight |x_u x x_v| du dv, linear in u
    and v for a planar quad, so the area is exact); any other polygon is a fan of triangles, each a collapsed
    square (Duffy) x = a + u(b - a) + uv(c - b) with Jacobian 2 A u.  Exact for polynomials of degree 2·order - 1 in
    the parameters; spectrally accurate for smooth (analytic) integrands."""
    v, n, _ = polygon_plane(vertices)
    g, gw = np.polynomial.legendre.leggauss(int(order))
    g, gw = 0.5 * (g + 1), 0.5 * gw
    U, V = np.meshgrid(g, g, indexing="ij")
    U, V = U.ravel()[:, None], V.ravel()[:, None]
    Wuv = np.outer(gw, gw).ravel()
    if len(v) == 4:
        p0, p1, p2, p3 = v
        x = (1 - U) * (1 - V) * p0 + U * (1 - V) * p1 + U * V * p2 + (1 - U) * V * p3
        xu = (1 - V) * (p1 - p0) + V * (p2 - p3)
        xv = (1 - U) * (p3 - p0) + U * (p2 - p1)
        return x, Wuv * np.abs(np.cross(xu, xv) @ n), n
    pts, wts = [], []
    for k in range(1, len(v) - 1):
        a, b, c = v[0], v[k], v[k + 1]
        pts.append(a + U * (b - a) + U * V * (c - b))
        wts.append(Wuv * U[:, 0] * np.linalg.norm(np.cross(b - a, c - a)))
    return np.concatenate(pts), np.concatenate(wts), n


def point_polygon_view_factor(points, normals, vertices) -> np.ndarray:
    """Exact view factor from differential areas (``points`` (q, 3), unit ``normals`` (q, 3) or (3,)) to a polygon
    (Lambert: F = -1/(2π) Σ_k Γ_k n·(a_k x a_{k+1})/|a_k x a_{k+1}|, a_k = v_k - x, Γ_k the angle between them, for
    vertices counter-clockwise about the polygon's front normal).  Valid when the whole polygon is above the area's
    tangent plane and shows it its front side (no horizon clipping, no occlusion)."""
    v, _, _ = polygon_plane(vertices)
    x = np.atleast_2d(np.asarray(points, float))
    nrm = np.broadcast_to(np.asarray(normals, float), x.shape)
    a = v[None, :, :] - x[:, None, :]
    b = np.roll(a, -1, axis=1)
    cr = np.cross(a, b)
    s = np.linalg.norm(cr, axis=2)
    gamma = np.arctan2(s, np.einsum("qkd,qkd->qk", a, b))
    unit = np.where(s[..., None] > 0, cr / np.where(s > 0, s, 1.0)[..., None], 0.0)
    return -np.einsum("qk,qkd,qd->q", gamma, unit, nrm) / (2 * np.pi)


# ----------------------------------------------------------------------------------------------------------------
# contour-integral view factor (Mitalas-Stephenson)
# ----------------------------------------------------------------------------------------------------------------

def _segment_log_integral(q: np.ndarray, a: np.ndarray, e: np.ndarray, length: float) -> np.ndarray:
    """∫_0^L ln |a + t e - q| dt for points q (s, 3), unit direction e, in closed form."""
    d = q - a
    tau = d @ e
    h2 = np.maximum(np.einsum("sd,sd->s", d, d) - tau * tau, 0.0)
    h = np.sqrt(h2)

    def G(u):  # antiderivative of ln sqrt(u² + h²)
        r2 = u * u + h2
        ulog = np.where(r2 > 0, 0.5 * u * np.log(np.where(r2 > 0, r2, 1.0)), 0.0)
        at = np.where(h > 0, h * np.arctan2(u, np.where(h > 0, h, 1.0)), 0.0)
        return ulog - u + at

    return G(length - tau) - G(-tau)


def _segment_distance(q: np.ndarray, a: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Distances from points q (s, 3) to the segment a + t d, t in [0, 1]."""
    t = np.clip((q - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(q - a - t[:, None] * d, axis=1)


def _collinear_log_integral(t0: float, sigma: float, L1: float, L2: float) -> float:
    """∫_0^{L1} ds ∫_0^{L2} dt ln |t0 + σ t - s| for two segments on one line (σ = ±1), in closed form."""

    def F(u):  # second antiderivative of ln|u|: u²/2 ln|u| - 3u²/4
        return 0.5 * u * u * np.log(abs(u)) - 0.75 * u * u if u != 0 else 0.0

    # inner: ∫_0^{L2} ln|t0 + σt - s| dt = σ [G(t0 + σ L2 - s) - G(t0 - s)], G(u) = u ln|u| - u, G' = ln|u|;
    # outer: ∫_0^{L1} G(c - s) ds = F(c) - F(c - L1)
    c1, c0 = t0 + sigma * L2, t0
    return float(sigma * ((F(c1) - F(c1 - L1)) - (F(c0) - F(c0 - L1))))


def _sigmoid_rule(order: int, k: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre on [0, 1] after s = u^k / (u^k + (1-u)^k): integrands with log-type end-point singularities
    become smooth to high order, so the rule keeps converging fast."""
    g, w = np.polynomial.legendre.leggauss(order)
    u = 0.5 * (g + 1)
    den = u**k + (1 - u) ** k
    s = u**k / den
    ds = k * (u * (1 - u)) ** (k - 1) / den**2
    return s, 0.5 * w * ds


def polygon_view_factor(poly1, poly2, order: int = 24) -> float:
    """Diffuse view factor F₁₂ between two planar convex polygons (vertices (k, 3) in m, counter-clockwise about
    their front normals), by the contour double integral A₁F₁₂ = 1/(2π) Σ_ij (ê_i·ê_j) ∫∫ ln r ds dt.

    The integral over each edge of polygon 2 is analytic; the one over each edge of polygon 1 is Gauss-Legendre
    (``order`` points) on sub-intervals split where the edge comes within 1e-9 of an end point of the other edge,
    with a sigmoidal change of variable on the sub-intervals that touch the other edge: shared edges and vertices
    (integrable log singularities) cost no accuracy.  No occlusion: each polygon must lie in front of the other."""
    v1, n1, A1 = polygon_plane(poly1)
    v2, n2, _ = polygon_plane(poly2)
    size = max(np.ptp(v1, axis=0).max(), np.ptp(v2, axis=0).max())
    if ((v2 - v1[0]) @ n1).min() < -1e-9 * size or ((v1 - v2[0]) @ n2).min() < -1e-9 * size:
        raise ValueError("the polygons are not fully in front of each other")
    g, gw = np.polynomial.legendre.leggauss(int(order))
    plain = (0.5 * (g + 1), 0.5 * gw)
    graded = _sigmoid_rule(int(order))
    total = 0.0
    for i in range(len(v1)):
        a1 = v1[i]
        d1 = v1[(i + 1) % len(v1)] - a1
        L1 = np.linalg.norm(d1)
        e1 = d1 / L1
        for j in range(len(v2)):
            a2 = v2[j]
            d2 = v2[(j + 1) % len(v2)] - a2
            L2 = np.linalg.norm(d2)
            e2 = d2 / L2
            c = e1 @ e2
            if abs(c) < 1e-15:
                continue
            off = a2 - a1
            if abs(abs(c) - 1) < 1e-14 and np.linalg.norm(off - (off @ e1) * e1) < 1e-12 * size:
                # collinear edges (e.g. a shared edge): analytic double integral
                total += c * _collinear_log_integral((a2 - a1) @ e1, np.sign(c), L1, L2)
                continue
            # split the outer edge where it touches an end point of the inner edge
            cuts = [0.0, 1.0]
            for p in (a2, a2 + d2):
                t = np.clip((p - a1) @ e1 / L1, 0.0, 1.0)
                if np.linalg.norm(a1 + t * d1 - p) < 1e-9 * size and 1e-12 < t < 1 - 1e-12:
                    cuts.append(float(t))
            cuts = np.unique(cuts)
            acc = 0.0
            for t0, t1 in zip(cuts[:-1], cuts[1:]):
                ends = a1 + np.array([t0, t1])[:, None] * d1
                touch = _segment_distance(ends, a2, d2).min() < 1e-9 * size
                s_rule, w_rule = graded if touch else plain
                t = t0 + (t1 - t0) * s_rule
                acc += (t1 - t0) * L1 * (w_rule @ _segment_log_integral(a1 + t[:, None] * d1, a2, e2, L2))
            total += c * acc
    # both contours counter-clockwise about their own front normals
    return float(total / (2 * np.pi * A1))


# ----------------------------------------------------------------------------------------------------------------
# Nyström REFs
# ----------------------------------------------------------------------------------------------------------------

@dataclass
class GebhartResult:
    """REFs between polygons.

    * ``ref`` (n, n): ℱ_ij, fraction of the power emitted (uniformly, diffusely) by polygon i finally absorbed by
      polygon j; the diagonal is not zero (emission of i that comes back to i after reflections);
    * ``space`` (n,): fraction lost to space, 1 - Σ_j ℱ_ij (includes the transmitted part 1 - ε - ρ, if any);
    * ``space_direct`` (n,): the same computed independently from the point-wise outgoing flux and the *exact*
      point-to-polygon view factors (Lambert) of each quadrature point: ``space - space_direct`` is a quadrature
      error estimate (energy closure);
    * ``view_factor`` (n, n): direct view factors F_ij by the same quadrature (ρ = 0, ε = 1);
    * ``areas`` (n,), ``order`` and the number of quadrature points ``n_points``.
    """

    ref: np.ndarray
    space: np.ndarray
    space_direct: np.ndarray
    view_factor: np.ndarray
    areas: np.ndarray
    order: int
    n_points: int


def gebhart_polygons(polygons, emissivity, reflectance, order: int = 32) -> GebhartResult:
    """REF matrix between mutually visible planar convex polygons with diffuse emission and diffuse reflection.

    ``polygons``: sequence of n (k_i, 3) vertex arrays (m), counter-clockwise about the front (active) normal; only
    front sides exchange, back sides are inactive and everything else is space.  ``emissivity``, ``reflectance``:
    scalars or (n,) (ε + ρ <= 1; the remainder 1 - ε - ρ is transmitted and lost to space).  ``order``:
    Gauss-Legendre points per parameter direction of each patch (:func:`polygon_quadrature`).

    Irradiance H(x) (W/m² per W emitted) solves H(x) = ∫ K(x, y) [E(y) + ρ(y) H(y)] dA_y, with K = cosθ_x cosθ_y /
    (π r²) between points of different polygons (self-exchange of a planar polygon is zero) and the emission
    E = 1/A_i on the emitter i; ℱ_ij = ε_j ∫_{A_j} H dA.  Nyström: (I - K W R) H = K W E, W the quadrature
    weights, R = diag(ρ), one dense solve for all n emitters (N = Σ points, memory 8 N² bytes).  The discrete
    result obeys the reciprocity ε_i A_i ℱ_ij = ε_j A_j ℱ_ji to round-off (K symmetric).  No occlusion test: the
    caller guarantees full mutual visibility (checked: every polygon in front of every other)."""
    polys = [polygon_plane(p) for p in polygons]
    n = len(polys)
    eps = np.broadcast_to(np.asarray(emissivity, float), (n,)).copy()
    rho = np.broadcast_to(np.asarray(reflectance, float), (n,)).copy()
    if (eps < 0).any() or (rho < 0).any() or (eps + rho > 1 + 1e-12).any():
        raise ValueError("need ε, ρ >= 0 and ε + ρ <= 1")
    for i, (vi, ni, _) in enumerate(polys):
        size = np.ptp(vi, axis=0).max()
        for j, (vj, _, _) in enumerate(polys):
            if i != j and ((vj - vi[0]) @ ni).min() < -1e-9 * size:
                raise ValueError(f"polygon {j} is (partly) behind polygon {i}")
    quads = [polygon_quadrature(v, order) for v, _, _ in polys]
    X = np.concatenate([q[0] for q in quads])
    Wt = np.concatenate([q[1] for q in quads])
    Nrm = np.concatenate([np.broadcast_to(q[2], q[0].shape) for q in quads])
    owner = np.concatenate([np.full(len(q[1]), i) for i, q in enumerate(quads)])
    N = len(Wt)
    areas = np.array([a for _, _, a in polys])

    K = np.zeros((N, N))
    for i in range(n):
        si = owner == i
        for j in range(i + 1, n):
            sj = owner == j
            d = X[sj][None, :, :] - X[si][:, None, :]  # from points of i to points of j
            r2 = np.einsum("abd,abd->ab", d, d)
            ci = np.maximum(d @ Nrm[si][0], 0.0)
            cj = np.maximum(-(d @ Nrm[sj][0]), 0.0)
            blk = ci * cj / (np.pi * r2 * r2)
            K[np.ix_(si, sj)] = blk
            K[np.ix_(sj, si)] = blk.T

    E = (owner[:, None] == np.arange(n)[None, :]) / areas[None, :]  # (N, n): emitter i's uniform emission
    KWE = K @ (Wt[:, None] * E)
    A = np.eye(N) - K * (Wt * rho[owner])[None, :]
    H = np.linalg.solve(A, KWE)  # (N, n): irradiance at each point for each emitter
    S = (owner[None, :] == np.arange(n)[:, None]) * Wt[None, :]  # (n, N): integration over each polygon
    ref = (eps[:, None] * (S @ H)).T  # ref[i, j] = ε_j ∫_j H_i
    view = (S @ KWE).T  # direct incidence = view factors
    space = 1.0 - ref.sum(axis=1)

    # independent energy closure with the exact point-to-polygon view factors
    Fpt = np.zeros((N, n))
    for k, (vk, _, _) in enumerate(polys):
        other = owner != k
        Fpt[other, k] = point_polygon_view_factor(X[other], Nrm[other], vk)
    B = E + rho[owner][:, None] * H  # outgoing (emitted + reflected) flux density
    tau = (1 - eps - rho)[owner]
    escape = (1.0 - Fpt.sum(axis=1))[:, None] * B + tau[:, None] * H
    space_direct = Wt @ escape
    return GebhartResult(ref=ref, space=space, space_direct=space_direct, view_factor=view, areas=areas,
                         order=int(order), n_points=N)


def gebhart_convergence(polygons, emissivity, reflectance, orders=(8, 12, 16, 20, 24, 32, 40, 48),
                        pair=(0, 1)) -> list[tuple[int, float]]:
    """ℱ[pair] for each quadrature order: [(order, value), ...] (the digits that stop changing are converged)."""
    i, j = pair
    return [(o, float(gebhart_polygons(polygons, emissivity, reflectance, order=o).ref[i, j])) for o in orders]


def two_quads_ref(order: int = 40, emissivity: float = 0.8, reflectance: float = 0.2) -> GebhartResult:
    """:func:`gebhart_polygons` on the thesis' two quadrangles (§2.3.5; ℱ₁₂ = ``.ref[0, 1]``)."""
    return gebhart_polygons(TWO_QUADS, emissivity, reflectance, order=order)
