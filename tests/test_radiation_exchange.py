"""Radiative exchange factors by quasi-Monte Carlo ray tracing, checked against closed forms and the thesis.

Thesis = seeds/jacques-2016-reduced-fe-space-thermal.txt.  Statistical tolerances are derived from the expected
error at the ray counts used (noted beside each assertion); seeds are fixed.
"""

from __future__ import annotations

import numpy as np
import pytest

from fem2tmm.errors import Fem2TmmError
from fem2tmm.radiation import HAS_EMBREE, Surface, exchange_factors, trace_exchange
from fem2tmm.radiation.smoothing import enforce_reciprocity

pytestmark = pytest.mark.skipif(not HAS_EMBREE, reason="performance-sized tests need embreex")


# ----------------------------------------------------------------------------------------------- closed forms
def point_to_rectangle(x0, x1, y0, y1, h):
    """View factor from a point (normal +z) to the parallel rectangle [x0, x1] x [y0, y1] at height h: sum of
    signed corner quadrants of F = 1/2π (X/√(1+X²) atan(Y/√(1+X²)) + Y/√(1+Y²) atan(X/√(1+Y²))) (thesis §2.2.5)."""

    def corner(x, y):
        X, Y = abs(x) / h, abs(y) / h
        f = (X / np.sqrt(1 + X * X) * np.arctan(Y / np.sqrt(1 + X * X))
             + Y / np.sqrt(1 + Y * Y) * np.arctan(X / np.sqrt(1 + Y * Y))) / (2 * np.pi)
        return np.sign(x) * np.sign(y) * f

    return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0)


def perpendicular_rectangles(w1, w2, l):
    """Thesis eq. 1.35: rectangles w1 x l and w2 x l in perpendicular planes sharing the edge of length l."""
    W1, W2 = w1 / l, w2 / l
    W = np.hypot(W1, W2)
    log = np.log((1 + W1**2) * (1 + W2**2) / (1 + W**2)
                 * (W1**2 * (1 + W**2) / ((1 + W1**2) * W**2)) ** (W1**2)
                 * (W2**2 * (1 + W**2) / ((1 + W2**2) * W**2)) ** (W2**2))
    return (W1 * np.arctan(1 / W1) + W2 * np.arctan(1 / W2) - W * np.arctan(1 / W) + 0.25 * log) / (np.pi * W1)


def parallel_squares(a, h):
    """Directly opposed parallel squares of side a at distance h (standard closed form)."""
    X = a / h
    r = np.sqrt(1 + X * X)
    return 2 / (np.pi * X * X) * (np.log(r * r / np.sqrt(1 + 2 * X * X)) + 2 * X * r * np.arctan(X / r)
                                  - 2 * X * np.arctan(X))


def test_closed_forms_reproduce_the_printed_values():
    # thesis §2.2.5 and eq. 1.35 print these values; parallel unit squares: 0.1998 (standard tables)
    assert abs(point_to_rectangle(-3, 2, -4, 3, 5) - 0.295578) < 5e-7
    assert abs(point_to_rectangle(0.1, 0.5, -0.6, 0.6, 5) - 0.006004) < 5e-7
    assert abs(perpendicular_rectangles(1, 1, 1) - 0.200044) < 5e-7
    assert abs(4 * perpendicular_rectangles(1, 1, 1) + parallel_squares(1, 1) - 1.0) < 1e-6


# ----------------------------------------------------------------------------------------------- geometry
def tiny_emitter(size=1e-4):
    """Square of side ``size`` m at the origin, normal +z (its front emits)."""
    h = size / 2
    return np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]], float)


def quad_facing(corners, normal):
    """The four corners ordered so that the right-hand normal is along ``normal``."""
    c = np.asarray(corners, float)
    n = np.cross(c[2] - c[0], c[3] - c[1])
    return c if np.dot(n, normal) > 0 else c[::-1]


def one_sided(n_faces, emitting_groups):
    """(active, groups) for faces whose front only is active, groups per face (-1 for none)."""
    active = np.stack([np.ones(n_faces, bool), np.zeros(n_faces, bool)], 1)
    groups = np.stack([np.asarray(emitting_groups), np.full(n_faces, -1)], 1).ravel()
    return active, groups


def unit_cube(n=1):
    from test_radiation_engine import grid_box

    return grid_box(n)


# ------------------------------------------------------------------------------------------ point-wise (§2.2.5)
@pytest.mark.parametrize("rect, ref", [((2, -3, 3, -4), 0.295578), ((0.5, 0.1, 0.6, -0.6), 0.006004)])
def test_pointwise_view_factor_to_rectangles(rect, ref):
    # thesis §2.2.5: 1e-4 m square under the rectangles; 10^6 coupled-Halton rays, within 0.5 % (the thesis'
    # Halton error at 10^6 rays is ~0.05 % (Fig. 2.7) and ~0.3 % (Fig. 2.8, F = 0.006))
    x1, x0, y1, y0 = rect
    target = quad_facing([[x1, y1, 5], [x0, y1, 5], [x0, y0, 5], [x1, y0, 5]], [0, 0, -1])
    pts = np.vstack([tiny_emitter(), target])
    active, groups = one_sided(2, [0, 1])
    surf = Surface(pts, [[0, 1, 2, 3], [4, 5, 6, 7]], emissivity=1.0, active=active)
    res = trace_exchange(surf, groups, rays_per_group=[1_000_000, 0], seed=0)
    assert abs(res.F_raw[0, 1] / ref - 1) < 5e-3
    assert abs(res.F[0, 1] / ref - 1) < 5e-3  # the target traced no ray: reciprocity keeps the emitter's estimate


def test_pointwise_view_factor_to_disc():
    # disc of radius 1 at height 1.5: F = R²/(R² + h²) = 1/(1 + 1.5²) = 0.307692 (Nusselt); a 2048-gon deviates
    # from the disc by (2π/2048)²/6 = 1.6e-6 relative.  10^6 Halton rays, within 0.5 %.
    m = 2048
    th = 2 * np.pi * np.arange(m) / m
    rim = np.stack([np.cos(th), np.sin(th), np.full(m, 1.5)], 1)
    pts = np.vstack([tiny_emitter(), [[0, 0, 1.5]], rim])
    fan = np.stack([np.full(m, 4), 5 + (np.arange(m) + 1) % m, 5 + np.arange(m), np.full(m, -1)], 1)  # normal -z
    faces = np.vstack([[0, 1, 2, 3], fan])
    active, groups = one_sided(m + 1, np.r_[0, np.ones(m, int)])
    surf = Surface(pts, faces, emissivity=1.0, active=active)
    res = trace_exchange(surf, groups, rays_per_group=[1_000_000, 0], seed=0)
    assert abs(res.F_raw[0, 1] / (1 / (1 + 1.5**2)) - 1) < 5e-3


# ------------------------------------------------------------------------------------------ finite surfaces
def test_perpendicular_unit_squares():
    # eq. 1.35: F12 = 0.200044; 10^5 rays per face, within 0.3 %
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 1]], float)
    res = exchange_factors(pts, [[0, 1, 2, 3], [0, 3, 5, 4]], emissivity=1.0, rays_per_face=100_000)
    ref = perpendicular_rectangles(1, 1, 1)
    assert abs(res.F[0, 1] / ref - 1) < 3e-3 and abs(res.F[1, 0] / ref - 1) < 3e-3
    np.testing.assert_allclose(res.F[0, 2], 1 - res.F[0, 1], rtol=1e-12)  # closure through space
    # same configuration with the slow numpy engine (platforms without embreex): 2x10^4 rays, within 1.5 %
    res_np = trace_exchange(Surface(pts, [[0, 1, 2, 3], [0, 3, 5, 4]], emissivity=1.0,
                                    active=np.array([[1, 0], [1, 0]], bool)),
                            np.array([0, -1, 1, -1]), rays_per_group=20_000, backend="numpy")
    assert res_np.engine == "numpy" and abs(res_np.F[0, 1] / ref - 1) < 1.5e-2


def test_black_cube_rows_close_and_reciprocity_is_enforced():
    pts, faces = unit_cube()
    res = exchange_factors(pts, faces, emissivity=1.0, rays_per_face=100_000)
    F_raw = res.F_raw.toarray()
    # each ray ends somewhere: raw rows sum to 1 to round-off, and nothing reaches space from inside a closed box
    np.testing.assert_allclose(F_raw.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(F_raw[:, -1] == 0)
    # raw reciprocity A_i F_ij = A_j F_ji (equal areas) within 1e-3 before smoothing (10^5 Halton rays per face:
    # RMS error of F_ij ~2e-4 over seeds 0-4); exact after
    assert np.abs(F_raw[:, :6] - F_raw[:, :6].T).max() < 1e-3
    GR = res.GR.toarray()[:, :6]
    assert np.array_equal(GR, GR.T)
    np.testing.assert_allclose(res.F.toarray().sum(axis=1), 1.0, rtol=0, atol=1e-12)
    # and the values: adjacent 0.200044 (eq. 1.35), opposite 0.199825; within 1 %
    F = res.F.toarray()[:, :6]
    opposite = np.abs(np.einsum("ij,kj->ik", faces_normals(pts, faces), faces_normals(pts, faces))) > 0.5
    np.fill_diagonal(opposite, False)
    adjacent = ~opposite & ~np.eye(6, dtype=bool)
    np.testing.assert_allclose(F[adjacent], perpendicular_rectangles(1, 1, 1), rtol=1e-2)
    np.testing.assert_allclose(F[opposite], parallel_squares(1, 1), rtol=1e-2)
    assert np.all(np.diag(F) == 0)


def faces_normals(pts, faces):
    n = np.cross(pts[faces[:, 2]] - pts[faces[:, 0]], pts[faces[:, 3]] - pts[faces[:, 1]])
    return n / np.linalg.norm(n, axis=1)[:, None]


# --------------------------------------------------------------------------------- two quadrangles (§2.3.5)
TWO_QUADS = (np.array([[1, 0, 0], [6, -1, 0], [6, 5.5, 0], [1, 5, 0],
                       [0, 0, 0.5], [0, 4, 0.5], [0, 5, 4.5], [0, -1, 4.5]], float),
             np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))
F12_TWO_QUADS = 0.0868  # thesis §2.3.5, ESARAD with 10^9 rays (±0.00005 from rounding)


def _two_quads_errors(n, sampling, seeds=50):
    pts, faces = TWO_QUADS
    f = [exchange_factors(pts, faces, emissivity=0.8, rays_per_face=n, sampling=sampling, seed=s, threads=1).F[0, 1]
         for s in range(seeds)]
    return np.abs(np.array(f) / F12_TWO_QUADS - 1)


def test_two_quadrangles_coupled_halton_beats_crude_monte_carlo():
    # ε = 0.8, diffuse reflectance 0.2: ℱ12 = 0.0868.  Coupled Halton with 10^4 rays per face: mean relative error
    # over 50 seeds below 1 % and the mean estimate within 0.2 % (unbiased);  crude Monte Carlo with 5x more rays
    # (5x10^4) still has a larger mean error (thesis Fig. 2.18: ~10x fewer rays for 1 %)
    e_halton = _two_quads_errors(10_000, "halton")
    e_random = _two_quads_errors(50_000, "random")
    assert e_halton.mean() < 1e-2
    assert e_random.mean() > e_halton.mean()


def test_two_quadrangles_converge_to_the_exact_ref():
    # the exact ℱ12 = 0.0867892370 (Nyström quadrature of the reflection integral equation, converged to 13 digits,
    # fem2tmm.radiation.reference; the thesis' 0.0868 is its rounding): 20 seeds of 10^5 coupled-Halton rays are
    # unbiased within 4 standard errors of their mean and their mean error is below 0.2 % (at 10^5 rays the
    # benchmark measures ~0.07 %)
    from fem2tmm.radiation.reference import two_quads_ref

    exact = two_quads_ref(order=24).ref[0, 1]
    pts, faces = TWO_QUADS
    f = np.array([exchange_factors(pts, faces, emissivity=0.8, rays_per_face=100_000, seed=s).F[0, 1]
                  for s in range(20)])
    assert abs(f.mean() - exact) < 4 * f.std(ddof=1) / np.sqrt(len(f))
    assert np.abs(f / exact - 1).mean() < 2e-3


# ------------------------------------------------------------------------------ three quadrangles (§2.3.6)
THREE_QUADS = (np.array([[5, -5, 1.8], [4, -1, 0], [-1, -1, 0], [0, -5, 1.8],
                         [4, 0, 0], [5, 5, 0], [-1, 4, 0], [0, 0, 0],
                         [4, -4, 2], [-1, -3, 2], [-2, 3, 2], [5, 4, 2]], float), np.arange(12).reshape(3, 4))


def test_three_quadrangles_see_each_other_front_to_front():
    # with the printed vertex orders the right-hand normals are (0, 18, 40)/|.|, +z and -z: faces 1 and 2 look up,
    # face 3 looks down, so all front sides face each other and back sides may be inactive
    pts, faces = THREE_QUADS
    n = faces_normals(pts, faces)
    np.testing.assert_allclose(n[0], np.array([0, 18, 40]) / np.hypot(18, 40))
    np.testing.assert_allclose(n[1], [0, 0, 1])
    np.testing.assert_allclose(n[2], [0, 0, -1])


# thesis §2.3.6 prints ℱ12 = 0.0108 / 0.0228 / 0.0132 "for 0.1 / 0.5 / 0.9"; our tracer and an independent
# brute-force Monte Carlo (test below, slow) give 0.01322 / 0.02285 / 0.01079: the printed 0.1 and 0.9 labels are
# swapped (the figure order a, c, e = 0.9, 0.5, 0.1 suggests how).  The reference here is the thesis value with the
# labels swapped (3 significant digits: ±0.4 %).
@pytest.mark.parametrize("rho, ref", [(0.1, 0.0132), (0.5, 0.0228), (0.9, 0.0108)])
def test_three_quadrangles_diffuse(rho, ref):
    pts, faces = THREE_QUADS
    runs = [exchange_factors(pts, faces, emissivity=1 - rho, rays_per_face=1_000_000, seed=s) for s in range(4)]
    # 4 seeds x 10^6 coupled-Halton rays per face.  One run scatters by 0.3 % (ρ = 0.1) to 0.6 % (ρ = 0.9: the
    # multiple reflections are crude Monte Carlo), so the mean of 4 is within ~0.3 % (1σ); within 1 %
    mean = np.mean([r.F[0, 1] for r in runs])
    assert abs(mean / ref - 1) < 1e-2
    assert max(r.capped_energy_fraction for r in runs) < 1e-6


@pytest.mark.parametrize("rho", [0.1, 0.5, 0.9])
def test_three_quadrangles_specular_reciprocity_and_closure(rho):
    pts, faces = THREE_QUADS
    res = exchange_factors(pts, faces, emissivity=1 - rho, specular=1.0, rays_per_face=20_000)
    GR = res.GR.toarray()
    assert np.array_equal(GR[:, :3], GR[:, :3].T)  # reciprocity exact after smoothing
    np.testing.assert_allclose(res.F.toarray().sum(axis=1), 1.0, atol=1e-12)  # closure through space
    np.testing.assert_allclose(GR, res.eps_area[:, None] * res.F.toarray(), rtol=1e-12)
    np.testing.assert_allclose(res.tally.toarray().sum(axis=1), res.rays)  # every ray accounted for
    assert res.lse_rms < 0.01 and res.capped_energy_fraction < 1e-6


# ------------------------------------------------------------------------ specular / transmissive physics
def test_mirror_reflection_by_image_method():
    # tiny emitter at the origin, a specular mirror (ε = 0.4, ρ_s = 0.6, not a REF node) at z = 2.5, receiver
    # [0.1, 0.5] x [-0.6, 0.6] in the plane z = 0.  Image method: ℱ = 0.6 x F(point -> receiver image at z = 5)
    # = 0.6 x 0.006004; the mirror absorbs 0.4 x F(point -> mirror) into the "blocked" bucket.
    mirror = quad_facing([[-2, -2, 2.5], [2, -2, 2.5], [2, 2, 2.5], [-2, 2, 2.5]], [0, 0, -1])
    recv = quad_facing([[0.1, -0.6, 0], [0.5, -0.6, 0], [0.5, 0.6, 0], [0.1, 0.6, 0]], [0, 0, 1])
    pts = np.vstack([tiny_emitter(), mirror, recv])
    faces = np.arange(12).reshape(3, 4)
    surf = Surface(pts, faces, emissivity=np.array([1.0, 0.4, 1.0]), specular=1.0,
                   active=np.array([[1, 0], [1, 0], [1, 0]], bool))
    groups = np.array([0, -1, -1, -1, 1, -1])
    n = 4_000_000
    res = trace_exchange(surf, groups, rays_per_group=[n, 0], seed=0)
    ref = 0.6 * point_to_rectangle(0.1, 0.5, -0.6, 0.6, 5.0)
    # the mirror absorbs exactly 40 % of its first hits (stratified), but which 60 % reflect is random: the count
    # reaching the receiver is hypergeometric, σ = √(0.4 / (0.6 n F_image)) = 0.53 % at 4x10^6 rays (1.85 % measured
    # over 30 seeds at 4x10^5, as predicted); within 2 % (3.8 σ)
    assert abs(res.F_raw[0, 1] / ref - 1) < 2e-2
    blocked = 0.4 * point_to_rectangle(-2, 2, -2, 2, 2.5)
    assert abs(res.blocked[0] / blocked - 1) < 2e-3
    assert res.tally.toarray()[0].sum() == n


@pytest.mark.parametrize("ts", [1.0, 0.0])
def test_semi_transparent_sheet(ts):
    # tiny emitter under a sheet (the §2.2.5 rectangle) with ε = 0.7, τ = 0.3, ρ = 0: the sheet absorbs
    # 0.7 x 0.295578, every transmitted ray (specular or diffuse) leaves to space
    sheet = quad_facing([[2, 3, 5], [-3, 3, 5], [-3, -4, 5], [2, -4, 5]], [0, 0, -1])
    pts = np.vstack([tiny_emitter(), sheet])
    surf = Surface(pts, [[0, 1, 2, 3], [4, 5, 6, 7]], emissivity=np.array([[1.0, 0.0], [0.7, 0.7]]),
                   transmissivity=np.array([[0.0, 0.0], [0.3, 0.3]]), transmission_specular=ts,
                   active=np.array([[1, 0], [1, 1]], bool))
    res = trace_exchange(surf, np.array([0, -1, 1, 1]), rays_per_group=[200_000, 0], seed=0)
    ref = 0.7 * 0.295578
    # Halton direction sampling + binomial absorption: σ ≈ sqrt(0.7 0.3 0.296 / 2e5) / 0.207 = 0.27 %; within 1.5 %
    assert abs(res.F_raw[0, 1] / ref - 1) < 1.5e-2
    assert res.F_raw[0, 1] + res.escaped[0] == pytest.approx(1.0, abs=1e-12)


def test_energy_is_conserved_with_specular_and_transmissive_sides():
    # a box (inner sides) with a semi-transparent specular lid and an inner baffle transmitting diffusely
    pts, faces = unit_cube(2)
    baffle = np.array([[0.2, 0.2, 0.5], [0.8, 0.2, 0.5], [0.8, 0.8, 0.5], [0.2, 0.8, 0.5]])
    pts = np.vstack([pts, baffle])
    faces = np.vstack([faces, [len(pts) - 4 + np.arange(4)]])
    f = len(faces)
    lid = np.isclose(pts[faces[:, 0], 2], 1.0) & np.isclose(pts[faces[:, 2], 2], 1.0)
    eps = np.where(lid, 0.2, 0.5)
    tau = np.where(lid, 0.5, 0.0)
    eps[-1], tau[-1] = 0.3, 0.4
    surf = Surface(pts, faces, emissivity=np.stack([eps, eps], 1), specular=0.6, transmissivity=np.stack([tau, tau], 1),
                   transmission_specular=np.where(np.arange(f) == f - 1, 0.0, 1.0),
                   active=np.stack([np.ones(f, bool), np.arange(f) == f - 1], 1))
    groups = np.where(np.stack([np.ones(f, bool), np.arange(f) == f - 1], 1), np.arange(2 * f).reshape(f, 2), -1)
    _, groups = np.unique(groups.ravel(), return_inverse=True)
    groups = groups - 1  # -1 stays -1 (it sorts first)
    res = trace_exchange(surf, groups, rays_per_group=3000, seed=5)
    T = res.tally.toarray()
    # integer ray counts: emitted = absorbed by REF nodes + escaped + blocked + capped, exactly, per group
    np.testing.assert_array_equal(T.sum(axis=1), res.rays)
    assert res.escaped.min() > 0  # the transparent lid lets some energy out
    np.testing.assert_allclose(res.F_raw.toarray().sum(axis=1) + res.blocked, 1.0, atol=1e-12)


def test_inactive_sides_block_rays():
    # black cube whose top inner side is inactive: every other face loses exactly its view factor to the top
    pts, faces = unit_cube()
    top = np.flatnonzero(np.isclose(pts[faces].mean(axis=1)[:, 2], 1.0))[0]
    active = np.stack([np.arange(6) != top, np.zeros(6, bool)], 1)
    groups = np.where(active, np.cumsum(active.ravel()).reshape(6, 2) - 1, -1).ravel()
    surf = Surface(pts, faces, emissivity=1.0, active=active)
    res = trace_exchange(surf, groups, rays_per_group=20_000)
    bottom = np.isclose(pts[faces[np.arange(6) != top]].mean(axis=1)[:, 2], 0.0)
    # 2x10^4 Halton rays: within 1 % of 0.199825 (opposite) and 0.200044 (adjacent)
    np.testing.assert_allclose(res.blocked[bottom], parallel_squares(1, 1), rtol=1e-2)
    np.testing.assert_allclose(res.blocked[~bottom], perpendicular_rectangles(1, 1, 1), rtol=1e-2)
    np.testing.assert_allclose(res.F.toarray().sum(axis=1), 1 - res.blocked, atol=1e-12)


def test_bounce_statistics_and_cap():
    # closed grey box, ε = 0.05: every segment ends on a wall, absorbed with p = 0.05 -> mean segments per ray
    # 1/ε = 20 (geometric law; σ of the mean = sqrt(0.95)/0.05/sqrt(n));  P(> 50 bounces) = 0.95^50 = 0.0769
    pts, faces = unit_cube()
    n = 12_000
    res = exchange_factors(pts, faces, emissivity=0.05, rays_per_face=n // 6)
    assert abs(res.segments / n - 20) < 4 * np.sqrt(0.95) / 0.05 / np.sqrt(n)
    assert res.capped_energy_fraction == 0.0  # default cap 1000: 0.95^1000 = 5e-23
    capped = exchange_factors(pts, faces, emissivity=0.05, rays_per_face=n // 6, max_bounces=50)
    assert abs(capped.capped_energy_fraction - 0.95**50) < 4 * np.sqrt(0.95**50 * (1 - 0.95**50) / n)


# ------------------------------------------------------------------------------------- super faces, control
def test_super_faces_match_the_analytic_cube():
    # each cube face meshed 3 x 3 and grouped back into one super face: the super-face REFs are the 6-face values
    pts, faces = unit_cube(3)
    labels = np.argmax(np.abs(faces_normals(pts, faces)), axis=1) * 2 + (faces_normals(pts, faces).sum(axis=1) < 0)
    res = exchange_factors(pts, faces, emissivity=1.0, super_faces=labels, rays_per_face=20_000)
    F = res.F.toarray()[:, :6]
    opp = labels.reshape(-1)  # labels 2k, 2k+1 are opposite faces of axis k
    for i in range(6):
        for j in range(6):
            if i == j:
                assert F[i, j] == 0
                continue
            ref = parallel_squares(1, 1) if i // 2 == j // 2 else perpendicular_rectangles(1, 1, 1)
            assert abs(F[i, j] / ref - 1) < 1e-2, (i, j)  # 2x10^4 Halton rays per super face: within 1 %
    assert len(opp) == 54 and res.n_groups == 6


def test_super_face_with_non_uniform_emissivity_weights_members_by_eps_area():
    # a super face made of two members with ε 0.9 and 0.1 emits 9:1 from them, so its REF to a black target is
    # the ε·A-weighted mean of the members' view factors.  Members: A = [0, 1] x [0, 0.5] and B = [0, 1] x [0.5, 1]
    # in z = 0; target T = {x = 0, y in [0, 0.5], z in [0, 1]}.  Closed forms (eq. 1.35 and additivity):
    # F(A -> T) = F⊥(w1 = 1, w2 = 1, l = 0.5); by symmetry F(B -> T) = F(A -> T') with T' the other half, and
    # F⊥(1, 1, 1) = F(A -> T) + F(A -> T')  =>  F(B -> T) = F⊥(1, 1, 1) - F⊥(1, 1, 0.5).
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 0.5, 0], [0, 0.5, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [0, 0.5, 1]],
                   float)
    target = quad_facing(pts[[0, 3, 7, 6]], [1, 0, 0])
    pts = np.vstack([pts, target])
    faces = np.array([[0, 1, 2, 3], [3, 2, 4, 5], [8, 9, 10, 11]])
    assert np.allclose(faces_normals(pts, faces)[:2], [0, 0, 1])
    res = exchange_factors(pts, faces, emissivity=np.array([0.9, 0.1, 1.0]), super_faces=np.array([0, 0, 1]),
                           rays_per_face=200_000)
    f_a = perpendicular_rectangles(1, 1, 0.5)
    f_b = perpendicular_rectangles(1, 1, 1) - f_a
    expected = 0.9 * f_a + 0.1 * f_b  # equal member areas
    assert abs(res.F_raw[0, 1] / expected - 1) < 1e-2  # 2x10^5 Halton rays: ~0.2 %; within 1 %
    # with equal emissivities the super face would see the plain area-weighted mean: a different number
    assert abs(0.5 * (f_a + f_b) / expected - 1) > 0.2


def test_accuracy_control_reaches_the_target_lse():
    # pilots at mean 100 and 400 rays per group give κ (LSE ∝ n^-κ); the extrapolated run(s) must reach the target
    # RMS LSE (statistical: allow 20 % above it).  Reference rate: the LSE of this 54-face grey box falls from 0.022
    # to 0.0047 between 400 and 6400 rays (κ ≈ 0.55) but faster before, so one extrapolation may fall short.
    pts, faces = unit_cube(3)
    res = exchange_factors(pts, faces, emissivity=0.5, target_lse=2e-3)
    assert res.kappa is not None and 0.5 <= res.kappa <= 1.0
    assert [p[0] for p in res.pilot[:2]] == [54 * 100, 54 * 400]
    assert res.pilot[1][1] > 2e-3  # the pilots alone were not enough
    assert res.lse_rms < 1.2 * 2e-3
    assert res.rays.sum() > 54 * 400


def test_fractional_variance_reciprocity_is_symmetric_and_close_to_linear_averaging():
    pts, faces = unit_cube(2)
    surf = Surface(pts, faces, emissivity=0.7, active=np.stack([np.ones(24, bool), np.zeros(24, bool)], 1))
    groups = np.stack([np.arange(24), np.full(24, -1)], 1).ravel()
    lin = trace_exchange(surf, groups, rays_per_group=5000, seed=3)
    fv = trace_exchange(surf, groups, rays_per_group=5000, seed=3, reciprocity="fractional_variance")
    G = fv.GR.toarray()[:, :24]
    assert np.array_equal(G, G.T)
    # same rays, different weights: the two smoothings agree to the statistical error (5000 rays, F ~ 0.05: ~3 %)
    big = lin.F.toarray()[:, :24] > 0.02
    np.testing.assert_allclose(fv.F.toarray()[:, :24][big], lin.F.toarray()[:, :24][big], rtol=0.1)
    # linear averaging with unequal ray counts follows eq. 2.45-2.46 exactly
    S = np.array([[0.0, 0.3], [0.1, 0.0]])
    ea, n = np.array([1.0, 2.0]), np.array([100, 400])
    a = ea / n
    X = (a[1] - a[0]) / (a[1] + a[0])
    w = 0.5 * (1 + np.sign(X) * abs(X) ** 0.4)
    GR = enforce_reciprocity(S, ea, n).toarray()
    assert GR[0, 1] == pytest.approx(w * 0.3 + (1 - w) * 0.1, rel=1e-14) and GR[0, 1] == GR[1, 0]


def test_same_seed_same_numbers_whatever_the_threads():
    pts, faces = unit_cube(2)
    a = exchange_factors(pts, faces, emissivity=0.5, rays_per_face=3000, seed=7, threads=1)
    b = exchange_factors(pts, faces, emissivity=0.5, rays_per_face=3000, seed=7, threads=2)
    c = exchange_factors(pts, faces, emissivity=0.5, rays_per_face=3000, seed=8, threads=2)
    assert (a.F != b.F).nnz == 0 and a.segments == b.segments
    assert (a.F != c.F).nnz > 0


def test_bad_input_names_the_culprits():
    pts, faces = TWO_QUADS
    with pytest.raises(Fem2TmmError, match=r"negative reflectance.*faces \(side\) 1 \(front\)"):
        exchange_factors(pts, faces, emissivity=[0.5, 0.8], transmissivity=[0.1, 0.5])
    with pytest.raises(Fem2TmmError, match="zero area"):
        exchange_factors(np.vstack([pts, [[9, 9, 9]] * 4]), [[0, 1, 2, 3], [8, 9, 10, 11]])
    with pytest.raises(Fem2TmmError, match="outside"):
        exchange_factors(pts, [[0, 1, 2, 3], [4, 5, 6, 99]])
    with pytest.raises(Fem2TmmError, match="sampling"):
        exchange_factors(pts, faces, sampling="sobol")
    with pytest.raises(Fem2TmmError, match="super_faces"):
        exchange_factors(pts, faces, super_faces=[0, 1, 2])
    with pytest.raises(Fem2TmmError, match="groups"):
        trace_exchange(Surface(pts, faces), np.array([0, 1]))


# ----------------------------------------------------------------------- independent brute force (slow)
def brute_force_mc(quads, eps, specular, n_rays, seed, emitter=0):
    """Crude Monte Carlo in float64, written independently of the package: Möller–Trumbore against every
    triangle, origins by folded barycentric sampling, cosine directions as normal + uniform unit vector.
    Front sides only (back hits are counted as blocked).  Returns absorbed fractions per quad."""
    quads = np.asarray(quads, float)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    owner = np.r_[np.arange(len(quads)), np.arange(len(quads))]
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    nrm = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(nrm, axis=1)
    nrm /= (2 * area)[:, None]
    rng = np.random.default_rng(seed)

    def cosine(nv):
        v = rng.normal(size=nv.shape)
        d = nv + v / np.linalg.norm(v, axis=1)[:, None]
        return d / np.linalg.norm(d, axis=1)[:, None]

    mine = np.flatnonzero(owner == emitter)
    ti = rng.choice(mine, size=n_rays, p=area[mine] / area[mine].sum())
    u, v = rng.random(n_rays), rng.random(n_rays)
    fold = u + v > 1
    u[fold], v[fold] = 1 - u[fold], 1 - v[fold]
    o = tris[ti, 0] + u[:, None] * e1[ti] + v[:, None] * e2[ti]
    d, last = cosine(nrm[ti]), ti
    absorbed = np.zeros(len(quads))
    while len(o):
        O, D = o[:, None, :], d[:, None, :]
        p = np.cross(D, e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        with np.errstate(all="ignore"):
            s = O - tris[None, :, 0]
            uu = np.einsum("rtk,rtk->rt", s, p) / det
            q = np.cross(s, e1[None])
            vv = np.einsum("rtk,rtk->rt", D, q) / det
            t = np.einsum("rtk,tk->rt", q, e2) / det
        ok = (uu >= 0) & (vv >= 0) & (uu + vv <= 1) & (t > 1e-9)
        ok[np.arange(len(last)), last] = False  # a planar triangle cannot see itself
        t = np.where(ok, t, np.inf)
        j = np.argmin(t, axis=1)
        tj = t[np.arange(len(j)), j]
        keep = np.isfinite(tj)
        o, d, j, tj = o[keep], d[keep], j[keep], tj[keep]
        c = np.einsum("ij,ij->i", d, nrm[j])
        front = c < 0
        o, d, j, tj, c = o[front], d[front], j[front], tj[front], c[front]
        x = rng.random(len(o))
        ab = x < eps
        np.add.at(absorbed, owner[j[ab]], 1)
        go = ~ab
        o, d, j, tj, c = o[go] + tj[go, None] * d[go], d[go], j[go], tj[go], c[go]
        spec = rng.random(len(o)) < specular
        nd = cosine(nrm[j])
        nd[spec] = d[spec] - 2 * c[spec, None] * nrm[j][spec]
        d, last = nd, j
    return absorbed / n_rays


@pytest.mark.slow
@pytest.mark.parametrize("rho, spec", [(0.1, 0.0), (0.5, 0.0), (0.9, 0.0), (0.5, 1.0), (0.9, 1.0)])
def test_three_quadrangles_against_independent_brute_force(rho, spec):
    pts, faces = THREE_QUADS
    n = 2_000_000
    bf = brute_force_mc(pts[faces], 1 - rho, spec, n, seed=11)[1]
    ours = exchange_factors(pts, faces, emissivity=1 - rho, specular=spec, rays_per_face=2_000_000).F[0, 1]
    sigma = np.sqrt(bf * (1 - bf) / n)  # binomial standard error of the brute force
    assert abs(ours - bf) < 4 * sigma + 2e-3 * bf
