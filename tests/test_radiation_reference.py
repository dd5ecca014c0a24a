"""Deterministic REF / view-factor references (fem2tmm.radiation.reference) against closed forms, and the stratified
κ oracle's estimator being unbiased."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.kappa import ball_indicator_errors, jittered_view_factor_errors, view_factor_estimates
from fem2tmm.radiation.reference import (TWO_QUADS, gebhart_polygons, parallel_rectangles_view_factor,
                                         perpendicular_rectangles_view_factor, point_polygon_view_factor,
                                         point_rectangle_view_factor, polygon_view_factor, two_quads_ref)


def rect_z(x0, y0, a, b, z, up=True):
    """a x b rectangle in the plane z, corner (x0, y0), counter-clockwise about +z (up) or -z."""
    v = np.array([[x0, y0, z], [x0 + a, y0, z], [x0 + a, y0 + b, z], [x0, y0 + b, z]], float)
    return v if up else v[::-1]


SQUARE = rect_z(0, 0, 1, 1, 0)
WALL = np.array([[0, 0, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1]], float)  # x = 0, normal +x, shares the edge x = z = 0


def test_closed_forms_match_the_tabulated_values():
    # Howell's catalogue / thesis eq. 1.35, tabulated to 6 digits
    assert parallel_rectangles_view_factor(1, 1, 1) == pytest.approx(0.199825, abs=5e-7)
    assert perpendicular_rectangles_view_factor(1, 1, 1) == pytest.approx(0.200044, abs=5e-7)
    # corner of a 1 x 1 square at distance 1: (1/π)(1/√2) atan(1/√2) = 0.1385316
    assert point_rectangle_view_factor(1, 1, 1) == pytest.approx(np.arctan(2**-0.5) / (np.pi * 2**0.5), abs=1e-15)
    assert point_rectangle_view_factor(1, 1, 1) == pytest.approx(0.1385316, abs=1e-7)


@pytest.mark.parametrize("a, b, c", [(1, 1, 1), (2, 3, 1.5), (0.5, 4, 0.3)])
def test_contour_view_factor_parallel_rectangles(a, b, c):
    # closed form Howell C-11 (directly opposed aligned rectangles); the contour integral converges spectrally
    # (the thin 0.5 x 4 pair at 0.3 needs order 32 for 1e-14, order 16 gives 4e-10)
    top = rect_z(0, 0, a, b, c, up=False)
    assert polygon_view_factor(rect_z(0, 0, a, b, 0), top, order=32) == pytest.approx(
        parallel_rectangles_view_factor(a, b, c), abs=1e-12)


@pytest.mark.parametrize("w, h, length", [(1, 1, 1), (1, 2, 1.5), (3, 0.5, 2)])
def test_contour_view_factor_perpendicular_rectangles_sharing_an_edge(w, h, length):
    # closed form Howell C-14 (unit squares: 0.200044, thesis eq. 1.35); the shared edge is a collinear edge pair
    # integrated analytically, so the singular kernel costs no accuracy: 1e-12
    f1 = np.array([[0, 0, 0], [w, 0, 0], [w, length, 0], [0, length, 0]], float)
    f2 = np.array([[0, 0, 0], [0, length, 0], [0, length, h], [0, 0, h]], float)
    ref = perpendicular_rectangles_view_factor(w, h, length)
    assert polygon_view_factor(f1, f2, order=16) == pytest.approx(ref, abs=1e-12)
    assert polygon_view_factor(f2, f1, order=16) * h == pytest.approx(ref * w, abs=1e-12)  # reciprocity


def test_contour_view_factor_with_touching_vertices_converges():
    # a 60° wedge of unit squares: the slanted edges touch the square's edges at a vertex with a non-zero
    # tangent product (log singularity at an end point, handled by the sigmoidal rule) -> self-convergence to 1e-12
    c, s = np.cos(np.pi / 3), np.sin(np.pi / 3)
    wedge = np.array([[0, 0, 0], [0, 1, 0], [c, 1, s], [c, 0, s]])
    f48, f64 = polygon_view_factor(SQUARE, wedge, 48), polygon_view_factor(SQUARE, wedge, 64)
    assert abs(f48 - f64) < 1e-12
    # independent: area integral of the exact point view factor over the square (log-type edge singularity:
    # algebraic convergence, ~1e-7 at 200 x 200 points)
    from fem2tmm.radiation.reference import polygon_quadrature
    x, wt, n = polygon_quadrature(SQUARE, 200)
    assert wt @ point_polygon_view_factor(x, n, wedge) == pytest.approx(f64, abs=1e-6)


def test_point_view_factor_against_corner_rectangles():
    # Howell B-3 (corner of a parallel rectangle), and an interior point as the sum of four corner rectangles
    assert point_polygon_view_factor([0, 0, 0], [0, 0, 1], rect_z(0, 0, 1, 2, 1.5, up=False))[0] == pytest.approx(
        point_rectangle_view_factor(1, 2, 1.5), abs=1e-14)
    p = np.array([[0.3, 0.7, 0.0]])
    total = sum(point_rectangle_view_factor(a, b, 0.8) for a in (0.3, 0.7) for b in (0.7, 1.3))
    assert point_polygon_view_factor(p, [0, 0, 1], rect_z(0, 0, 1, 2, 0.8, up=False))[0] == pytest.approx(
        total, abs=1e-14)


def test_quadrature_view_factor_matches_the_closed_form_and_the_contour_integral():
    # parallel unit squares at distance 1 (Howell C-11) by the Nyström area quadrature (ρ = 0): smooth kernel,
    # spectral convergence, 1e-10 at order 16
    r = gebhart_polygons([SQUARE, rect_z(0, 0, 1, 1, 1, up=False)], 1.0, 0.0, order=16)
    assert r.view_factor[0, 1] == pytest.approx(parallel_rectangles_view_factor(1, 1, 1), abs=1e-10)
    assert r.ref[0, 1] == pytest.approx(r.view_factor[0, 1], abs=1e-15)  # ε = 1, ρ = 0: REF = view factor
    # two quads of thesis §2.3.5: two independent methods (area quadrature, contour integral) agree to 1e-13
    q = two_quads_ref(order=24)
    assert q.view_factor[0, 1] == pytest.approx(polygon_view_factor(*TWO_QUADS, order=24), abs=1e-13)
    # triangles (Duffy fan) against the contour integral: a triangle over a pentagon
    tri = np.array([[0, 0, 0], [1, 0, 0], [0.2, 0.9, 0]], float)
    xy = np.array([[0, 0], [0.9, -0.1], [1.1, 0.6], [0.5, 1.2], [-0.2, 0.8]])
    pent = np.c_[xy, 1 + 0.2 * xy[:, 0] + 0.1 * xy[:, 1]][::-1]  # tilted plane above, facing down
    g = gebhart_polygons([tri, pent], 1.0, 0.0, order=20)
    assert g.view_factor[0, 1] == pytest.approx(polygon_view_factor(tri, pent, order=24), abs=1e-11)


def test_two_quads_ref_converges_with_the_order():
    # ℱ₁₂ (ε = 0.8, ρ = 0.2): the differences between successive orders shrink geometrically and the value stops
    # changing (to 1e-13) from order 24 on; thesis (ESARAD, 10^9 rays): 0.0868 (4 digits)
    vals = [two_quads_ref(order=o).ref[0, 1] for o in (8, 12, 16, 24, 32)]
    d = np.abs(np.diff(vals))
    assert d[0] > d[1] > d[2] and d[3] < 1e-13
    assert vals[-1] == pytest.approx(0.08678923698828, abs=1e-13)
    assert round(vals[-1], 4) == 0.0868


def test_reciprocity_and_energy_closure():
    # equal ε: A1 ℱ12 = A2 ℱ21; in general ε_i A_i ℱ_ij = ε_j A_j ℱ_ji (holds for the discrete solution to round-off)
    r = two_quads_ref(order=24)
    assert r.areas[0] == pytest.approx(28.75) and r.areas[1] == pytest.approx(20.0)
    assert r.areas[0] * r.ref[0, 1] == pytest.approx(r.areas[1] * r.ref[1, 0], rel=1e-13)
    # closure: the space fraction from 1 - row sum and from the escaping outgoing flux with the exact
    # (Lambert) point view factors agree to the quadrature error (1e-12 at order 24)
    np.testing.assert_allclose(r.ref.sum(axis=1) + r.space, 1.0, atol=1e-15)
    np.testing.assert_allclose(r.space, r.space_direct, atol=1e-12)
    # unequal optics with transmission (ε + ρ < 1), three polygons (one triangle)
    # in the plane x + z = 8 facing (-1, 0, -1): sees both quads, does not occlude them (they lie in x + z <= 6)
    tri = np.array([[4, 0, 4], [6, 2, 2], [3, 4, 5]], float)[::-1]
    polys = [TWO_QUADS[0], TWO_QUADS[1], tri]
    g = gebhart_polygons(polys, emissivity=[0.8, 0.5, 0.3], reflectance=[0.2, 0.4, 0.6], order=20)
    M = np.array([0.8, 0.5, 0.3])[:, None] * g.areas[:, None] * g.ref
    np.testing.assert_allclose(M, M.T, rtol=1e-12)
    np.testing.assert_allclose(g.space, g.space_direct, atol=1e-9)


@pytest.mark.parametrize("kw", [dict(sampling="jittered"), dict(sampling="random"), dict(emitter="point")])
def test_stratified_estimator_is_unbiased(kw):
    # exact: contour-integral F₁₂ (face emitter) or the Lambert point view factor at the centroid (point emitter)
    v1 = TWO_QUADS[0]
    n1 = np.array([0.0, 0.0, 1.0])
    exact = (point_polygon_view_factor(v1.mean(axis=0), n1, TWO_QUADS[1])[0] if kw.get("emitter") == "point"
             else polygon_view_factor(*TWO_QUADS))
    est = view_factor_estimates(4, range(400), **kw)  # 400 seeds x 256 rays
    sem = est.std(ddof=1) / np.sqrt(len(est))
    assert abs(est.mean() - exact) < 4 * sem


def test_jittered_errors_report_structure():
    r = jittered_view_factor_errors(ms=(3, 4), seeds=range(20))
    assert r["n"] == [81, 256] and len(r["mean_rel_error"]) == 2 and np.isfinite(r["kappa"])
    assert r["exact"] == pytest.approx(polygon_view_factor(*TWO_QUADS), abs=1e-14)


@pytest.mark.slow
def test_kappa_slopes():
    # n = 256 ... 65536, 200 seeds: jittered 4-D -> 0.625, random 0.5, jittered 2-D -> 0.75 (seed noise ~ ±0.03)
    assert 0.57 < jittered_view_factor_errors()["kappa"] < 0.69
    assert 0.45 < jittered_view_factor_errors(sampling="random")["kappa"] < 0.58
    assert 0.70 < jittered_view_factor_errors(emitter="point")["kappa"] < 0.84


def test_halton_sampler_on_ball_indicators_converges_at_the_rate_of_smooth_boundaries():
    # the tracer's scrambled Halton points with no ray tracing, on the indicator of a ball of known volume (a smooth
    # curved boundary like a ray's hit/miss): mean error ∝ n^-(1/2 + 1/(2d)) at best, 0.625 in 4-D and 0.75 in 2-D
    # (jittered-sampling variance O(n^-(1 + 1/d))); iid points 0.5.  40 seeds, n = 250 ... 64 000: over six sets of
    # 40 seeds the fitted slopes were 0.618 ± 0.028 (4-D) and 0.760 ± 0.034 (2-D); bounds at 3 σ
    r4 = ball_indicator_errors(4, ns=(250, 1000, 4000, 16000, 64000), seeds=range(40))
    r2 = ball_indicator_errors(2, ns=(250, 1000, 4000, 16000, 64000), seeds=range(40))
    assert r4["exact"] == pytest.approx(np.pi**2 * 0.4**4 / 2, rel=1e-15)
    assert 0.53 < r4["halton"]["kappa"] < 0.71
    assert 0.65 < r2["halton"]["kappa"] < 0.86
    assert 0.38 < r4["random"]["kappa"] < 0.62 and 0.38 < r2["random"]["kappa"] < 0.62
    # and the Halton errors are well below the iid ones at every n past the first (measured 0.52x at 1000, 0.28x at
    # 64 000 in 4-D)
    assert all(h < 0.7 * m for h, m in zip(r4["halton"]["mean_rel_error"][1:], r4["random"]["mean_rel_error"][1:]))
