"""Quadric super faces (thesis ch. 5): Taubin fit, projection, ray-quadric roots, the quadric ray scene, and the
thesis' physics cases (Fig. 5.1 focusing, curvature in REFs, §5.4 perpendicular cylinders).

Thesis = seeds/jacques-2016-reduced-fe-space-thermal.txt.  References are closed forms, brute-force computations
written here, or finer faceted meshes; every tolerance says where it comes from.  Seeds are fixed.
"""

from __future__ import annotations

from math import factorial

import numpy as np
import pytest

from fem2tmm.mesh import shapes
from fem2tmm.errors import Fem2TmmError
from fem2tmm.radiation import HAS_EMBREE, Surface, exchange_factors, trace_exchange
from scenarios import cylinder_super_faces, cylinder_surface, read_cylinders
from fem2tmm.radiation.quadric import RULE7, Quadric, face_frames, fit_quadric, fit_regions, subdivided_rule
from fem2tmm.radiation.quadric_scene import QuadricScene
from fem2tmm.radiation.smoothing import convergence_rate
from fem2tmm.radiation.solar import trace_solar
from fem2tmm.radiation.surfaces import TriangleScene

pytestmark = pytest.mark.skipif(not HAS_EMBREE, reason="ray-traced tests need embreex")


# ---------------------------------------------------------------------------------------------------- geometry
def icosphere(subdivisions: int, radius: float = 1.0, center=(0.0, 0.0, 0.0)):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions, radius=radius)
    return np.asarray(s.vertices) + np.asarray(center), np.asarray(s.faces)


def paraboloid(n: int, element: str = "tri3"):
    """z = (x² + y²)/4 over [-1, 1]² (2 m square, f = 1), n x n cells; front side +z (the concave side)."""
    m = shapes.plate(2, 2, n, n, element=element, origin=(-1, -1, 0))
    p = m.points.copy()
    p[:, 2] = (p[:, 0] ** 2 + p[:, 1] ** 2) / 4
    return p, m.blocks[0].cells


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def exact_surfaces():
    """(name, points, faces, sampler): exact meshes and a sampler of points on the true surface (not vertices)."""
    rng = np.random.default_rng(1)
    R = random_rotation(rng)
    t = np.array([0.3, -1.2, 2.0])
    cyl = shapes.cylinder(0.05, 0.5, 24, 10)
    cone = shapes.cone(0.05, 0.15, 0.3, 36, 12)
    sph_p, sph_f = icosphere(2, 0.7, (3.0, 2.0, 1.0))
    par_p, par_f = paraboloid(12)

    def on_cylinder(u, v):  # rotated and translated: general position
        th, z = 2 * np.pi * u, 0.5 * v
        return np.c_[0.05 * np.cos(th), 0.05 * np.sin(th), z] @ R.T + t

    def on_cone(u, v):
        th, z = 2 * np.pi * u, 0.3 * v
        r = 0.05 + 0.1 * z / 0.3
        return np.c_[r * np.cos(th), r * np.sin(th), z]

    def on_sphere(u, v):
        z = 2 * u - 1
        s = np.sqrt(1 - z * z)
        return 0.7 * np.c_[s * np.cos(2 * np.pi * v), s * np.sin(2 * np.pi * v), z] + [3.0, 2.0, 1.0]

    def on_paraboloid(u, v):
        x, y = 2 * u - 1, 2 * v - 1
        return np.c_[x, y, (x * x + y * y) / 4]

    return [("cylinder", cyl.points @ R.T + t, cyl.blocks[0].cells, on_cylinder),
            ("cone", cone.points, cone.blocks[0].cells, on_cone),
            ("sphere", sph_p, sph_f, on_sphere),
            ("paraboloid", par_p, par_f, on_paraboloid)]


# ---------------------------------------------------------------------------------------------------------- fit
@pytest.mark.parametrize("name, points, faces, sampler", exact_surfaces(),
                         ids=lambda v: v if isinstance(v, str) else "")
def test_fit_of_exact_meshes_recovers_the_surface(name, points, faces, sampler):
    cen, nrm = face_frames(points, faces)
    q = fit_quadric(points, nrm, cen, name=name)
    # thesis Fig. 5.2: fit error below 1 nm on the EUI baffle; issue: < 1e-9 of the size on exact meshes
    assert q.max_distance < 1e-9 * q.size
    assert q.rms_distance <= q.max_distance
    assert q.size == pytest.approx(np.linalg.norm(np.ptp(points, axis=0)), rel=1e-12)
    # the fitted zero set is the true surface between the vertices too: points sampled on the closed-form surface
    # (first-order distance |f|/|∇f|, exact to second order at these distances), within 1e-9 of the size
    uv = np.random.default_rng(0).random((500, 2))
    p = sampler(uv[:, 0], uv[:, 1])
    assert np.max(np.abs(q.value(p)) / np.linalg.norm(q.gradient(p), axis=1)) < 1e-9 * q.size
    # orientation: ∇f agrees with the FE face normals it was fitted to (module convention)
    assert np.all(np.einsum("ij,ij->i", q.normal(q.project(cen)), nrm) > 0.9)


def test_fit_without_normals_needs_an_unambiguous_region():
    # a 90° strip of the 12 x 20 cylinder, 3 elements wide: its 4 generators lie on a family of quadrics
    # (a + b cos θ + c sin θ + d cos 2θ + e sin 2θ vanishes on 4 angles), so Taubin alone is ambiguous
    m = shapes.cylinder(0.05, 0.5, 12, 5)
    faces = m.blocks[0].cells
    cen, nrm = face_frames(m.points, faces)
    strip = np.flatnonzero(np.arctan2(cen[:, 1], cen[:, 0]) % (2 * np.pi) < np.pi / 2)
    nodes = np.unique(faces[strip])
    with pytest.raises(Fem2TmmError, match="independent quadrics"):
        fit_quadric(m.points[nodes], name="strip")
    # with the face normals the cylinder is picked: radius 0.05 on random points of the true surface (1e-12 m)
    q = fit_quadric(m.points[nodes], nrm[strip], cen[strip], name="strip")
    th = np.random.default_rng(2).uniform(0, np.pi / 2, 50)
    p = np.c_[0.05 * np.cos(th), 0.05 * np.sin(th), np.linspace(0, 0.5, 50)]
    assert np.max(np.abs(q.value(p))) < 1e-12
    # a plane: z(a + bx + cy) = 0 fits any planar vertex set; the normals pick the plane itself, f = z (unit ∇f)
    pl = shapes.plate(1, 1, 4, 4)
    c2, n2 = face_frames(pl.points, pl.blocks[0].cells)
    qp = fit_quadric(pl.points, n2, c2, name="plate")
    np.testing.assert_allclose(qp.world_coefficients, [0, 0, 0, 1, 0, 0, 0, 0, 0, 0], atol=1e-12)


def test_a_region_that_is_not_a_quadric_is_refused_by_name():
    p, f = paraboloid(10)
    p[:, 2] += 0.05 * np.sin(3 * p[:, 0]) * np.cos(2 * p[:, 1])  # a bumpy sheet: 5 cm waves over 2 m
    with pytest.raises(Fem2TmmError, match="super face 0 is not a quadric"):
        exchange_factors(p, f, super_faces=np.zeros(len(f), int), quadric=True, rays_per_face=10)
    with pytest.raises(Fem2TmmError, match="'mirror'"):
        fit_regions(p, f, np.zeros(len(f), int), names={0: "'mirror'"})
    # too few vertices
    with pytest.raises(Fem2TmmError, match="at least 9 vertices"):
        fit_quadric(p[:5], name="tiny")
    # a quadric that does not fit the faces it is given: a sphere far away
    far = Quadric(np.array([-1.0, 0, 0, 0, 1, 0, 0, 1, 0, 1]), center=(10.0, 0, 0), name="far")
    with pytest.raises(Fem2TmmError, match="faces"):
        QuadricScene(Surface(p, f), np.zeros(len(f), int), [far])


# ------------------------------------------------------------------------------------------ projection, roots
def test_projection_matches_closed_forms_and_brute_force():
    rng = np.random.default_rng(3)
    c, R = np.array([3.0, 2.0, 1.0]), 0.7
    sph = fit_quadric(*icosphere(2, R, c)[:1], name="sphere")
    u = rng.normal(size=(200, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    p0 = c + u * R * rng.uniform(0.8, 1.2, (200, 1))
    # sphere: the foot point is c + R (p - c)/|p - c| (1e-12 of the size: round-off)
    np.testing.assert_allclose(sph.project(p0), c + R * u, atol=1e-12 * sph.size)
    np.testing.assert_allclose(sph.distance(p0), np.abs(np.linalg.norm(p0 - c, axis=1) - R), atol=1e-12)
    # paraboloid z = (x² + y²)/4: brute force minimises |p(x, y) - p0| with scipy (converged to 1e-10 m)
    from scipy.optimize import minimize

    par = fit_quadric(paraboloid(8)[0], name="paraboloid")
    p0 = np.c_[rng.uniform(-1, 1, (20, 2)), np.zeros(20)]
    p0[:, 2] = (p0[:, 0] ** 2 + p0[:, 1] ** 2) / 4 + rng.uniform(-0.05, 0.05, 20)
    feet = par.project(p0)
    for k in range(20):  # loop over 20 test points (reference optimisations)
        res = minimize(lambda xy: np.sum((np.r_[xy, (xy @ xy) / 4] - p0[k]) ** 2), p0[k, :2], tol=1e-14,
                       method="BFGS", options={"gtol": 1e-13})
        ref = np.r_[res.x, (res.x @ res.x) / 4]
        assert np.linalg.norm(feet[k] - ref) < 1e-7  # BFGS's own accuracy on x, y
        # and the foot point satisfies the thesis' system (f = 0, p - p0 ∥ ∇f) to round-off
        assert abs(par.value(feet[k])) < 1e-14
        assert np.linalg.norm(np.cross(feet[k] - p0[k], par.normal(feet[k]))) < 1e-13


def test_ray_roots_both_in_order_and_the_linear_cases():
    # unit sphere: o = (0, 0, -3), d = +z: t = 2 and 4 (closed form)
    sph = Quadric(np.array([-1.0, 0, 0, 0, 1, 0, 0, 1, 0, 1]))
    t1, t2 = sph.intersect([[0, 0, -3.0], [0, 0, -3.0], [2.0, 0, 0]], [[0, 0, 1.0], [0, 0, -1.0], [0, 0, 1.0]])
    np.testing.assert_allclose(t1[:2], [2.0, -4.0])
    np.testing.assert_allclose(t2[:2], [4.0, -2.0])
    assert np.isnan(t1[2]) and np.isnan(t2[2])  # a miss: negative discriminant
    # cone x² + y² = z²: a ray parallel to a generator (a_q = 0) meets it once: o = (0, 0, 1), d = -(1, 0, 1)/√2
    cone = Quadric(np.array([0.0, 0, 0, 0, 1, 0, 0, 1, 0, -1]))
    t1, t2 = cone.intersect([[0, 0, 1.0]], [[-1 / np.sqrt(2), 0, -1 / np.sqrt(2)]])
    np.testing.assert_allclose(t1, [1 / np.sqrt(2)])
    assert np.isnan(t2[0])
    # cylinder x² + y² = 1: rays along the axis never meet it (a_q = b_q = 0)
    cyl = Quadric(np.array([-1.0, 0, 0, 0, 1, 0, 0, 1, 0, 0]))
    t1, t2 = cyl.intersect([[0.5, 0, 0.0]], [[0, 0, 1.0]])
    assert np.isnan(t1[0]) and np.isnan(t2[0])
    # a plane (linear quadric) z = 0 from (0, 0, 1) along -z: t = 1, one root
    t1, t2 = Quadric(np.array([0.0, 0, 0, 1, 0, 0, 0, 0, 0, 0])).intersect([[0, 0, 1.0]], [[0, 0, -1.0]])
    assert t1[0] == pytest.approx(1.0) and np.isnan(t2[0])


# --------------------------------------------------------------------------------------------------- areas
def test_radon_rule_and_patch_areas():
    # the 7-point rule integrates x^i y^j (i + j <= 5) exactly over the unit triangle: i! j! / (i + j + 2)!
    for rule in (RULE7, subdivided_rule(3)):
        bary, w = rule
        for i in range(6):
            for j in range(6 - i):
                got = 0.5 * np.sum(w * bary[:, 1] ** i * bary[:, 2] ** j)
                assert got == pytest.approx(factorial(i) * factorial(j) / factorial(i + j + 2), rel=1e-13)
    # true curved areas (closed forms) against the facet areas
    pts, faces = icosphere(1, 0.5)  # 80 triangles: facets 7 % short of 4πr²
    sc = QuadricScene.from_regions(Surface(pts, faces), np.zeros(len(faces), int))
    assert sc.tri_area.sum() == pytest.approx(np.pi, rel=1e-8)  # quadrature error 5e-9 (module docstring)
    assert sc.tri_area_fe.sum() < 0.95 * np.pi
    cyl = shapes.cylinder(0.05, 0.5, 12, 20)  # the thesis' 12 x 20 cylinder: facets 1.1 % short of 2πRL
    sc = QuadricScene.from_regions(Surface(cyl.points, cyl.blocks[0].cells), np.zeros(240, int))
    assert sc.tri_area.sum() == pytest.approx(2 * np.pi * 0.05 * 0.5, rel=2e-9)  # measured 5e-10
    # a cone frustum's free end rings: the patch ends where the cone normal through the FE chord meets it, and
    # the cone normal is tilted against the ring plane, so the boundary moves by ~sagitta x sin(tilt): a deficit
    # ∝ n_θ^-2 (measured 0.114 %, 0.029 %, 0.007 % at 24, 48, 96 around; the facets' own deficit is 3.2x larger)
    true = np.pi * 0.2 * np.hypot(0.1, 0.3)  # lateral area π (r0 + r1) slant
    deficit = []
    for n in (24, 48):
        cone = shapes.cone(0.05, 0.15, 0.3, n, 6)
        sc = QuadricScene.from_regions(Surface(cone.points, cone.blocks[0].cells), np.zeros(6 * n, int))
        deficit.append(1 - sc.tri_area.sum() / true)
        assert 0 < deficit[-1] < 0.4 * (1 - sc.tri_area_fe.sum() / true)
    assert deficit[0] / deficit[1] == pytest.approx(4.0, rel=0.02)  # second order in the element size


def test_patch_areas_against_brute_force_subdivision():
    # per-triangle quadric area of a coarse paraboloid (32 triangles, 0.5 m elements) against an independent
    # estimate: each facet split into n x n sub-triangles whose vertices are projected onto the quadric, flat areas
    # summed (error ∝ n^-2), Richardson-extrapolated from n = 32 and 64 (error ~1e-8 relative)
    p, f = paraboloid(4)
    sc = QuadricScene.from_regions(Surface(p, f), np.zeros(len(f), int))
    q = sc.quadrics[0]

    def brute(n):
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        bary = np.c_[n - i[keep] - j[keep], i[keep], j[keep]] / n
        idx = -np.ones((n + 1, n + 1), int)
        idx[keep] = np.arange(keep.sum())
        a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        up = (a + b <= n - 1)
        dn = (a + b <= n - 2)
        tri = np.r_[np.c_[idx[a[up], b[up]], idx[a[up] + 1, b[up]], idx[a[up], b[up] + 1]],
                    np.c_[idx[a[dn] + 1, b[dn]], idx[a[dn] + 1, b[dn] + 1], idx[a[dn], b[dn] + 1]]]
        out = []
        for V in sc.tri_vertices:  # loop over the 32 facets
            X = q.project(bary @ V)
            out.append(0.5 * np.linalg.norm(np.cross(X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]]),
                                            axis=1).sum())
        return np.array(out)

    ref = (4 * brute(64) - brute(32)) / 3
    np.testing.assert_allclose(sc.tri_area, ref, rtol=1e-7)
    assert np.all(sc.tri_area > sc.tri_area_fe)  # the curved patch is larger than its chord facet


# ------------------------------------------------------------------------------------------------ the scene
def test_closed_sphere_of_several_regions_is_watertight_and_exact():
    # icosphere (320 facets) split into 8 octant regions, each fitted separately; rays from random interior
    # points in random directions must all hit the true sphere (|p| = R to round-off), none lost in a seam
    R = 0.8
    pts, faces = icosphere(2, R)
    cen, _ = face_frames(pts, faces)
    region = (cen[:, 0] > 0) + 2 * (cen[:, 1] > 0) + 4 * (cen[:, 2] > 0)
    sc = QuadricScene.from_regions(Surface(pts, faces), region)
    assert sc.n_surfaces == 1  # the 8 fits coincide (to 1e-15): traced as one surface
    rng = np.random.default_rng(4)
    n = 20_000
    o = rng.normal(size=(n, 3))
    o *= (0.7 * R * rng.random((n, 1)) ** (1 / 3)) / np.linalg.norm(o, axis=1)[:, None]
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    prim, t = sc.intersect(o, d, np.full(n, -1))
    assert np.all(prim >= 0)
    face, p, nrm = sc.hit_geometry(prim, o, d, t)
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), R, atol=1e-14)
    # outward FE normals -> front normal = p/R; the face hit is the one under p along the normal (brute force:
    # the facet whose plane crossing of the ray from 0 through p lies inside it, numpy engine)
    np.testing.assert_allclose(nrm, p / R, atol=1e-12)
    from fem2tmm.radiation.engine import NumpyEngine

    under, _ = NumpyEngine(sc.tri_vertices).intersect(np.zeros((2000, 3)), p[:2000] / R)
    assert np.mean(sc.tri_face[under] == face[:2000]) > 0.999  # ties only on edges (float rounding)
    # rays grazing the sphere (impact parameter 0.99 R to R, random directions) all hit the quadric, while the
    # inscribed facets (inradius ~0.985 R at this refinement) let most of them through (measured: 16 % hit)
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    u = np.cross(d, rng.normal(size=(2000, 3)))
    u /= np.linalg.norm(u, axis=1)[:, None]
    g = u * R * rng.uniform(0.99, 1.0, (2000, 1)) - 2 * d
    assert np.all(sc.intersect(g, d, np.full(2000, -1))[0] >= 0)
    assert np.mean(TriangleScene(Surface(pts, faces)).intersect(g, d, np.full(2000, -1))[0] >= 0) < 0.3


def test_second_root_through_a_hole():
    # cylinder r = 0.05 with a window (faces removed): a ray through the window meets the near wall's quadric
    # outside the patch (first root rejected) and hits the far wall at the second root
    m = shapes.cylinder(0.05, 0.5, 24, 10)
    f = m.blocks[0].cells
    cen, _ = face_frames(m.points, f)
    window = (np.abs(np.arctan2(cen[:, 1], cen[:, 0])) < 0.3) & (np.abs(cen[:, 2] - 0.25) < 0.06)
    f = f[~window]
    sc = QuadricScene.from_regions(Surface(m.points, f), np.zeros(len(f), int))
    o = np.array([[1.0, 0.0, 0.25], [1.0, 0.0, 0.05]])
    d = np.array([[-1.0, 0, 0], [-1.0, 0, 0]])
    prim, t = sc.intersect(o, d, np.full(2, -1))
    np.testing.assert_allclose(t, [1.05, 0.95], atol=1e-12)  # far wall at x = -0.05; near wall at x = +0.05
    _, _, nrm = sc.hit_geometry(prim, o, d, t)
    np.testing.assert_allclose(nrm, [[-1, 0, 0], [1, 0, 0]], atol=1e-12)  # outward front normals of each wall


def test_emission_on_the_quadric():
    # coarse sphere: origins on the true sphere (offset by eps), directions cosine-distributed about the true
    # normal (E[d·n] = 2/3 for the cosine law), weights of mean 1 over each triangle
    pts, faces = icosphere(1, 0.5)
    sc = QuadricScene.from_regions(Surface(pts, faces), np.zeros(len(faces), int))
    n = 40_000
    U = np.random.default_rng(5).random((n, 6))
    prim = np.repeat(np.arange(len(faces)), n // len(faces))
    o, d, w = sc.emit_weighted(prim, np.ones(n), U)
    r = np.linalg.norm(o, axis=1)
    np.testing.assert_allclose(r, 0.5 + sc.eps, atol=1e-13)
    cos = np.einsum("ij,ij->i", d, o / r[:, None])
    assert cos.min() > 0.0
    assert cos.mean() == pytest.approx(2 / 3, abs=5e-3)  # 4 σ of a mean of 4e4 cosines (σ = 0.24/√n)
    means = np.bincount(prim, weights=w) / np.bincount(prim)
    np.testing.assert_allclose(means, 1.0, atol=0.01)  # 500 pseudo-random points per triangle, J spread ~±8 %


# ------------------------------------------------------------------------------------------ thesis physics
def _spot(scene, n=20_000, seed=0):
    """RMS radius (m) in the focal plane z = 1 of rays falling along -z on [-1, 1]² and reflected specularly."""
    rng = np.random.default_rng(seed)
    o = np.c_[rng.uniform(-1, 1, (n, 2)), np.full(n, 3.0)]
    d = np.tile([0, 0, -1.0], (n, 1))
    prim, t = scene.intersect(o, d, np.full(n, -1))
    assert np.all(prim >= 0)
    _, p, nrm = scene.hit_geometry(prim, o, d, np.asarray(t, float))
    r = d - 2 * np.einsum("ij,ij->i", d, nrm)[:, None] * nrm
    x = p + ((1 - p[:, 2]) / r[:, 2])[:, None] * r
    return float(np.sqrt(np.mean(x[:, 0] ** 2 + x[:, 1] ** 2)))


def test_focusing_paraboloid_fig_5_1():
    # thesis Fig. 5.1: 2 m square paraboloid z = (x² + y²)/4f, f = 1, parallel rays along the axis.  3 200
    # triangles.  Faceted: the spot shrinks like 1/√n, ~1 cm at 20 000 triangles (Fig. 5.1b), so 2-3 cm here
    # (measured 2.6 cm).  Quadric: the exact focal point, RMS < 1e-6 m (measured ~1e-15 m: round-off)
    p, f = paraboloid(40)
    surf = Surface(p, f)
    sc = QuadricScene.from_regions(surf, np.zeros(len(f), int))
    faceted, quadric = _spot(TriangleScene(surf)), _spot(sc)
    assert 0.015 < faceted < 0.04
    assert quadric < 1e-6


def test_focusing_through_trace_solar_onto_a_1_mm_disc():
    # the same mirror (specular reflectance 1) under the Sun along +z, a black 1 mm disc at the focus facing the
    # mirror: with the quadric every reflected ray meets the disc; the faceted mirror puts ~(1 mm / 2.6 cm)² of it
    # there.  Energy balance incident = absorbed + escaped + blocked + capped holds to round-off in both.
    p, f = paraboloid(40)
    k = 16
    th = np.linspace(0, 2 * np.pi, k, endpoint=False)
    pts = np.vstack([p, [[0, 0, 1.0]], np.c_[1e-3 * np.cos(th), 1e-3 * np.sin(th), np.ones(k)]])
    c = len(p)
    fan = np.c_[np.full(k, c), c + 1 + (np.arange(k) + 1) % k, c + 1 + np.arange(k)]  # normal -z
    faces = np.vstack([f, fan])
    m, nm = len(faces), len(f)
    surf = Surface(pts, faces, absorptivity=np.c_[np.r_[np.zeros(nm), np.ones(k)], np.zeros(m)], specular=1.0,
                   active=np.c_[np.ones(m, bool), np.zeros(m, bool)])
    groups = np.c_[np.r_[np.zeros(nm, int), -np.ones(k, int)], -np.ones(m, int)].ravel()
    out = {}
    for name, sc in (("faceted", TriangleScene(surf)),
                     ("quadric", QuadricScene.from_regions(surf, np.r_[np.zeros(nm, int), -np.ones(k, int)]))):
        r = trace_solar(surf, [0, 0, 1], 1000.0, groups=groups, rays_per_group=20_000, scene=sc)
        assert r.incident == pytest.approx(r.absorbed + r.escaped + r.blocked + r.capped, rel=1e-12)
        out[name] = r.absorbed_face[nm:].sum() / r.incident
    assert out["quadric"] > 1 - 1e-9
    assert out["faceted"] < 0.01  # measured 0.0011


def two_spheres(sub_in=1, sub_out=2):
    """Black sphere r = 0.5 (coarse icosphere, outward normals) inside a black sphere r = 1 (inward normals)."""
    a_p, a_f = icosphere(sub_in, 0.5)
    b_p, b_f = icosphere(sub_out, 1.0)
    faces = np.vstack([a_f, b_f[:, ::-1] + len(a_p)])
    return np.vstack([a_p, b_p]), faces, np.r_[np.zeros(len(a_f), int), np.ones(len(b_f), int)]


def test_curvature_in_refs_concentric_spheres():
    # F(outer -> inner) = A_inner / A_outer = 0.25 for concentric spheres (reciprocity with F(inner -> outer) = 1).
    # With quadric super faces: within 0.5 % (issue; measured 0.25000, raw ray estimate 0.24996 at 2x10^4 rays:
    # binomial σ = 0.0031 relative, the Halton error is lower).  Faceted (80-triangle inner sphere, 7 % short of
    # its area): biased low by its smaller area (measured 0.2365)
    pts, faces, sf = two_spheres()
    quad = exchange_factors(pts, faces, emissivity=1.0, super_faces=sf, rays_per_face=20_000, quadric=True)
    flat = exchange_factors(pts, faces, emissivity=1.0, super_faces=sf, rays_per_face=20_000)
    assert quad.F[1, 0] == pytest.approx(0.25, rel=5e-3)
    assert quad.F_raw[1, 0] == pytest.approx(0.25, rel=1e-2)  # 3 σ of the raw binomial estimate
    np.testing.assert_allclose(quad.area, [np.pi, 4 * np.pi], rtol=1e-7)  # true areas (quadrature, 5e-9)
    # the inner sphere sees only the outer one: no ray leaks through a seam (one leaked ray in 2e4 would be 5e-5; the
    # row is an energy-weighted count renormalised to the rays traced, exact to round-off)
    assert quad.escaped[0] == 0.0 and quad.blocked[0] == 0.0
    assert quad.F_raw[0, 1] == pytest.approx(1.0, abs=1e-12)
    assert flat.F[1, 0] < 0.245  # > 2 % low: visibly biased
    assert abs(flat.F[1, 0] - 0.25) > 5 * abs(quad.F[1, 0] - 0.25)


# ----------------------------------------------------------------------------- perpendicular cylinders (§5.4)
def built_cylinders(n_theta, n_z):
    """The same two cylinders built finer with shapes.cylinder (nodes on the true circle, angle 0 included)."""
    m = shapes.cylinder(0.05, 0.5, n_theta, n_z)
    p, c = m.points, m.blocks[0].cells
    a = np.c_[p[:, 0] - 0.075, p[:, 2] - 0.25, -p[:, 1]]  # a rotation: axis z -> y, outward normals kept
    b = np.c_[p[:, 0] + 0.075, p[:, 1], p[:, 2] - 0.25]
    return np.vstack([a, b]), np.vstack([c, c + len(p)]), np.r_[np.ones(len(c), int), 2 * np.ones(len(c), int)]


def F12(res, n=16):
    """REF from cylinder 1 (super faces 0..15) to cylinder 2 (16..31) as a whole."""
    GR = res.GR.toarray()
    return GR[:n, n:2 * n].sum() / res.eps_area[:n].sum()


def _cylinder_runs(rays, seeds, samplings=("halton",), quadric=True):
    pts, faces, cyl = read_cylinders()
    sf = cylinder_super_faces(pts, faces, cyl)
    surf = cylinder_surface(pts, faces)
    groups = np.c_[sf, -np.ones(len(faces), int)].ravel()
    scene = QuadricScene.from_regions(surf, sf, names=[f"super face {i}" for i in range(32)]) if quadric else None
    out = {}
    for s in samplings:
        for n in rays:
            out[s, n] = [trace_exchange(surf, groups, rays_per_group=n, scene=scene, seed=seed, sampling=s)
                         for seed in seeds]
    return out, scene


def test_perpendicular_cylinders_quadric_super_faces():
    # thesis §3.2/§5.4: 2 x 240 shells (12 around x 20 along), 16 quadric super faces per cylinder, each fitted on
    # its own 24 vertices (a 90° strip: the face normals resolve the family of quadrics through them)
    pts, faces, cyl = read_cylinders()
    assert len(faces) == 480
    sf = cylinder_super_faces(pts, faces, cyl)
    assert np.all(np.bincount(sf) == 15)
    runs, scene = _cylinder_runs([16_000], [0])
    assert scene.n_surfaces == 2  # the 16 fits of each cylinder coincide and are traced as one surface
    np.testing.assert_allclose([q.max_distance for q in scene.quadrics], 0, atol=1e-15)
    quad = runs["halton", 16_000][0]
    np.testing.assert_allclose(quad.area.reshape(2, 16).sum(axis=1), 2 * np.pi * 0.05 * 0.5, rtol=2e-9)
    # faceting error of the committed mesh: the same REF on the 12 x 20 facets, and on 48 x 80 facets (area
    # 0.07 % short instead of 1.1 %: the true-geometry reference, its own faceting error ~15x smaller)
    facet = exchange_factors(pts, faces, emissivity=0.5, specular=1.0, super_faces=sf, rays_per_face=16_000)
    fp, ff, fc = built_cylinders(48, 80)
    fine = exchange_factors(fp, ff, emissivity=0.5, specular=1.0, super_faces=cylinder_super_faces(fp, ff, fc),
                            rays_per_face=16_000)
    f_q, f_c, f_f = F12(quad), F12(facet), F12(fine)
    # measured: quadric 0.0419, faceted 12 x 20 0.0411, faceted 48 x 80 0.0418; seed-to-seed σ of F12 at 1.6e4
    # rays per super face ~1e-4 (4 seeds)
    faceting_error = abs(f_c - f_f)
    assert faceting_error > 5e-4  # the coarse facets are visibly off (1.7 %)
    assert abs(f_q - f_c) < faceting_error + 3e-4  # quadric vs FE faces: within the faceting error (+3 σ)
    assert abs(f_q - f_f) < 3e-4  # and on the true geometry (3 σ)


def test_perpendicular_cylinders_lse_convergence_fig_5_9():
    # thesis Fig. 5.9: the coupled Halton sampling keeps its rate on quadric super faces.  RMS LSE (mean over 3
    # seeds) at 10^3 and 1.6x10^4 rays per super face: measured κ = 0.70 (Halton) against 0.52 (crude Monte Carlo,
    # theory 0.5), and a 3x lower LSE at 1.6x10^4 rays; the faceted super faces give κ = 0.70 too
    runs, _ = _cylinder_runs([1000, 16_000], [0, 1, 2], ("halton", "random"))
    lse = {k: np.mean([r.lse_rms for r in v]) for k, v in runs.items()}
    k_h = convergence_rate(1000, lse["halton", 1000], 16_000, lse["halton", 16_000])
    k_r = convergence_rate(1000, lse["random", 1000], 16_000, lse["random", 16_000])
    assert 0.6 < k_h < 1.0
    assert k_r < k_h
    assert lse["halton", 16_000] < 0.6 * lse["random", 16_000]
    flat, _ = _cylinder_runs([1000, 16_000], [0, 1, 2], quadric=False)
    lf = [np.mean([r.lse_rms for r in flat["halton", n]]) for n in (1000, 16_000)]
    assert abs(convergence_rate(1000, lf[0], 16_000, lf[1]) - k_h) < 0.15  # "almost identical" curves


def test_without_quadric_regions_the_scene_is_the_planar_one():
    # every hook of QuadricScene falls back to the base class on flat triangles: identical REFs and solar fluxes
    # (bit for bit) to TriangleScene on a model with specular and diffuse reflections and shadows
    pts, faces, sf = two_spheres(1, 1)
    surf = Surface(pts, faces, emissivity=0.6, absorptivity=0.4, specular=0.5)
    groups = np.repeat(sf, 2) * 2 + np.tile([0, 1], len(sf))
    flat = QuadricScene(surf, -np.ones(len(faces), int), [])
    a = trace_exchange(surf, groups, rays_per_group=2000)
    b = trace_exchange(surf, groups, rays_per_group=2000, scene=flat)
    assert (a.F != b.F).nnz == 0 and np.array_equal(a.area, b.area)
    sa = trace_solar(surf, [1.0, 0.2, 0.3], 1000.0, rays_per_group=50)
    sb = trace_solar(surf, [1.0, 0.2, 0.3], 1000.0, rays_per_group=50, scene=flat)
    assert np.array_equal(sa.absorbed_side, sb.absorbed_side) and sa.escaped == sb.escaped


def test_same_seed_same_numbers_whatever_the_threads():
    pts, faces, sf = two_spheres(1, 1)
    surf = Surface(pts, faces, emissivity=0.7, specular=0.5)
    groups = np.repeat(sf, 2) * 2 + np.tile([0, 1], len(sf))
    sc = QuadricScene.from_regions(surf, sf)
    a = trace_exchange(surf, groups, rays_per_group=3000, scene=sc, threads=1, batch=2000)
    b = trace_exchange(surf, groups, rays_per_group=3000, scene=sc, threads=2, batch=2000)
    assert (a.F != b.F).nnz == 0 and (a.tally != b.tally).nnz == 0


@pytest.mark.slow
def test_perpendicular_cylinders_per_super_face_and_rate_slow():
    # per super-face pair between the cylinders (the 44 GR entries above 5 % of the largest), 6.4x10^4 rays per
    # super face: the quadric (mean of seeds 0, 1) against 96 x 160 facets (true geometry; faceting error ~1e-4):
    # mean relative bias measured +0.3 % (its noise: 2 %/√44/√2 ≈ 0.2 %), RMS 2.2 % = ray noise (seed-to-seed RMS
    # 2.0 %); the 12 x 20 facets are biased -1.8 %
    pts, faces, cyl = read_cylinders()
    sf = cylinder_super_faces(pts, faces, cyl)
    runs, _ = _cylinder_runs([64_000], [0, 1])
    G = lambda r: r.GR.toarray()[:16, 16:32]  # noqa: E731
    Gq = 0.5 * (G(runs["halton", 64_000][0]) + G(runs["halton", 64_000][1]))
    Gc = G(exchange_factors(pts, faces, emissivity=0.5, specular=1.0, super_faces=sf, rays_per_face=64_000))
    fp, ff, fc = built_cylinders(96, 160)
    Gf = G(exchange_factors(fp, ff, emissivity=0.5, specular=1.0, super_faces=cylinder_super_faces(fp, ff, fc),
                            rays_per_face=64_000))
    big = Gf > 0.05 * Gf.max()
    assert abs(np.mean(Gq[big] / Gf[big] - 1)) < 0.008  # 4 σ
    assert np.mean(Gc[big] / Gf[big] - 1) < -0.01
    # Fig. 5.9 over 1.6 decades (10^3 .. 6.4x10^4 rays, 4 seeds): log-log slope of the mean RMS LSE, measured 0.7
    runs, _ = _cylinder_runs([1000, 4000, 16_000, 64_000], [0, 1, 2, 3])
    n = np.array([1000, 4000, 16_000, 64_000])
    lse = np.array([np.mean([r.lse_rms for r in runs["halton", k]]) for k in n])
    kappa = -np.polyfit(np.log(n), np.log(lse), 1)[0]
    assert 0.6 < kappa < 1.0
