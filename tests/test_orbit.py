"""Orbital heat fluxes (issue 18, thesis §2.4): orbit mechanics (Kepler, eclipses, Sun ephemeris, attitudes),
planet-focused Halton sampling (PFHS) of albedo and planet infrared against the thesis' closed forms (eq. 2.32-2.34)
and against an independent quadrature of eq. 2.23 along the two orbit cases of §2.4.4, the plain hemisphere
sampling baseline, and the energy balance per position."""

from __future__ import annotations

import dataclasses

import math

import numpy as np
import pytest
from scipy.integrate import quad

from fem2tmm import Fem2TmmError, meshes
from fem2tmm.constants import SIGMA
from fem2tmm.orbit import (ASTRONOMICAL_UNIT, EARTH, SUN_RADIUS, Attitude, Orbit, Planet, julian_date,
                                     sun_ephemeris)
from fem2tmm.radiation.orbital import orbital_fluxes, trace_orbit
from fem2tmm.radiation.planet import planet_fluxes, planet_rays
from fem2tmm.radiation.surfaces import Surface, TriangleScene

R = EARTH.radius  # 6 378.136 km (EGM2008, thesis §2.4.4)
A_C = 0.3 * 1366.1  # albedo x solar constant of the thesis' examples, W/m²
SQUARE = np.array([[-0.5, -0.5, 0.0], [0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [-0.5, 0.5, 0.0]])
UP, DOWN = np.array([[0, 1, 2, 3]]), np.array([[0, 3, 2, 1]])  # unit square, normal +z / -z


def rot(axis: int, deg: float) -> np.ndarray:
    """Rotation matrix by ``deg`` about coordinate axis ``axis`` (0 x, 1 y, 2 z), right-handed."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    M = np.eye(3)
    M[i, i] = M[j, j] = c
    M[i, j], M[j, i] = -s, s
    return M


# ------------------------------------------------------------------------------------------ closed forms (eq. 2.3x)
def q_albedo_full(hr: float, gamma: float, theta_sun: float, phi_sun: float = 0.0) -> float:
    """Thesis eq. 2.32: albedo flux (W/m²) on a face whose plane does not cut the visible cap, all of it lit."""
    c1, c2, c3 = hr - 1, hr + 1, 1 + 2 * hr**2 - 3 * hr**4
    g, ts = math.radians(gamma), math.radians(theta_sun)
    log = math.log(c2 / c1)
    return A_C / (16 * hr**3) * (2 * c2 * math.cos(g) * math.cos(ts) * (4 + 2 * hr * c1 - c1**2 * c2 * log)
                                 + math.sin(g) * math.cos(math.radians(phi_sun)) * math.sin(ts)
                                 * (4 + 2 * hr - 6 * hr**3 - c3 * log))


def q_albedo_subsolar_nadir(hr: float) -> float:
    """Thesis eq. 2.34 (γ = 0, Sun at the zenith)."""
    c1, c2 = hr - 1, hr + 1
    return A_C * c2 / (8 * hr**3) * (4 + 2 * hr * c1 - c1**2 * c2 * math.log(c2 / c1))


def quadrature_eq_2_23(r_sc, normal, sun, n: int = 400, exitance: float | None = None) -> float:
    """Independent reference: eq. 2.23 (albedo; eq. 2.24 with ``exitance``) integrated over the planet cap the
    spacecraft at ``r_sc`` (3,) m sees, by the midpoint rule on n x n cells in (θ_z, φ_z) about the sub-satellite
    point, Richardson-extrapolated from n/2 (the integrand has kinks at the terminator and the face plane: the midpoint
    error is O(h²)).  No ray, no sampling, no code of the package."""

    def midpoint(k):
        rho = float(np.linalg.norm(r_sc))
        z = np.asarray(r_sc, float) / rho
        e1 = np.cross(z, [1.0, 0, 0] if abs(z[0]) < 0.9 else [0, 1.0, 0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(z, e1)
        tmax = math.acos(R / rho)
        th = (np.arange(k) + 0.5) * tmax / k
        ph = (np.arange(k) + 0.5) * 2 * math.pi / k
        T, P = np.meshgrid(th, ph, indexing="ij")
        xh = (np.cos(T)[..., None] * z + (np.sin(T) * np.cos(P))[..., None] * e1
              + (np.sin(T) * np.sin(P))[..., None] * e2)
        u = np.asarray(r_sc, float) - R * xh
        du = np.linalg.norm(u, axis=-1)
        uh = u / du[..., None]
        src = A_C * np.maximum(xh @ sun, 0.0) if exitance is None else exitance
        val = (src * np.maximum(np.einsum("ijk,ijk->ij", xh, uh), 0.0) / (math.pi * du**2)
               * np.maximum(-(uh @ normal), 0.0) * R * R * np.sin(T))
        return val.sum() * (tmax / k) * (2 * math.pi / k)

    return (4.0 * midpoint(n) - midpoint(n // 2)) / 3.0


def test_quadrature_reference_against_closed_forms():
    # the test's own reference against eq. 2.34 and 2.32 (2000 km, γ = 30°, Sun 20° off the zenith): both are
    # within 1e-6 (the Richardson-extrapolated midpoint rule at n = 400 is ~1e-7 off on these smooth integrands)
    hr = 1 + 800e3 / R
    q = quadrature_eq_2_23([0, 0, R + 800e3], np.array([0, 0, -1.0]), np.array([0, 0, 1.0]))
    assert q == pytest.approx(q_albedo_subsolar_nadir(hr), rel=1e-6)
    g, ts = math.radians(30), math.radians(20)
    q = quadrature_eq_2_23([0, 0, R + 2000e3], np.array([math.sin(g), 0, -math.cos(g)]),
                           np.array([math.sin(ts), 0, math.cos(ts)]))
    assert q == pytest.approx(q_albedo_full(1 + 2000e3 / R, 30, 20), rel=1e-6)


def test_pfhs_ray_energy_is_thesis_eq_2_43():
    # the ray energy factor of eq. 2.41/2.42, f(ξ, h_r) of eq. 2.43, against planet_rays: for infrared the energy
    # per unit area share is σT⁴ f (n · d) (thesis eq. 2.42); the code writes f as 1 / (h_r² cos θ_n)
    hr = 1.125
    xi = np.array([0.01, 0.3, 0.6, 0.9, 0.99])
    c1 = np.sqrt((1 - xi) / (hr**2 - xi))
    c2 = np.sqrt(hr**2 * (1 - xi) - xi * (1 - 2 * xi - 2 * np.sqrt((1 - xi) * (hr**2 - xi))))
    f = (c1 - 1) * (1 - 2 * xi + c1 * (2 * xi - hr**2)) * (c2 - 1) / (c1 * c2 * hr * (1 + hr**2 - 2 * c2) ** 1.5)
    surface = Surface(SQUARE, DOWN)
    scene = TriangleScene(surface)
    r = len(xi)
    U = np.column_stack([xi, np.full(r, 0.2)])
    nrm = np.tile([0.0, 0.0, -1.0], (r, 1))
    d, e = planet_rays(scene, np.zeros(r, np.int64), np.ones(r), np.zeros((r, 3)), nrm, U,
                       np.array([0.0, 0.0, hr * R]), np.array([0, 0, 1.0]), "ir", EARTH, 1366.1)
    cos_face = d @ np.array([0, 0, -1.0])
    np.testing.assert_allclose(e / (EARTH.exitance * cos_face), f, rtol=1e-12)


def test_albedo_above_subsolar_point_nadir_face():
    # thesis §2.4.4: unit square 800 km above the subsolar point, normal to nadir: eq. 2.34 = 319.9 W/m² (ESARAD
    # 319.6).  Issue tolerance 0.3 % at 1e5 rays; PFHS measured 1e-7..1e-5 over seeds here, asserted at 1e-4
    hr = 1 + 800e3 / R
    exact = q_albedo_subsolar_nadir(hr)
    assert round(exact, 1) == 319.9
    for seed in range(3):
        q = planet_fluxes(SQUARE, DOWN, [0, 0, R + 800e3], [0, 0, 1], "albedo", rays_per_face=100_000, seed=seed)
        assert q[0] == pytest.approx(exact, rel=1e-4)
    # the face turned away from the planet receives nothing
    assert planet_fluxes(SQUARE, UP, [0, 0, R + 800e3], [0, 0, 1], "albedo", rays_per_face=1000)[0] == 0.0


def test_inclined_face_albedo_eq_2_32_and_ir_eq_2_33():
    # γ = 30°, Sun 20° off the zenith: at 800 km the face plane would cut the visible cap (θ_z,max = 27.3° < γ),
    # outside eq. 2.32's domain; at 2000 km θ_z,max = 40.4° > γ and θ_sun < 90° - θ_z,max: all visible planet lit.
    # Issue tolerance 0.3 % at 1e5 rays; measured scatter over seeds ~1e-5, asserted at 1e-4
    h = 2000e3
    hr = 1 + h / R
    tilt = SQUARE @ rot(1, -30).T  # normal of DOWN tilted from -z towards +x: n = (sin γ, 0, -cos γ)
    n = np.cross(tilt[3] - tilt[0], tilt[2] - tilt[0])
    np.testing.assert_allclose(n / np.linalg.norm(n), [0.5, 0, -math.sqrt(3) / 2], atol=1e-12)
    sun = [math.sin(math.radians(20)), 0, math.cos(math.radians(20))]
    for seed in range(2):
        qa = planet_fluxes(tilt, DOWN, [0, 0, R + h], sun, "albedo", rays_per_face=100_000, seed=seed)[0]
        assert qa == pytest.approx(q_albedo_full(hr, 30, 20), rel=1e-4)
        qe = planet_fluxes(tilt, DOWN, [0, 0, R + h], sun, "ir", rays_per_face=100_000, seed=seed)[0]
        assert qe == pytest.approx(SIGMA * 288.0**4 * math.cos(math.radians(30)) / hr**2, rel=1e-4)
    # a given planet exitance instead of the 288 K black body
    mars_like = Planet(radius=3_389_500.0, mu=4.282837e13, albedo=0.25, ir_flux=120.0)
    qe = planet_fluxes(SQUARE, DOWN, [0, 0, 3_389_500.0 + 400e3], sun, "ir", planet=mars_like, rays_per_face=1000)[0]
    # a nadir face gets M / h_r² from every ray, up to the tilt of the local nadir over the face (x / ρ ~ 1e-7 rad)
    # times the sampling noise of sin θ cos φ (~1e-3 at 1000 rays)
    assert qe == pytest.approx(120.0 / (1 + 400e3 / 3_389_500.0) ** 2, rel=1e-9)


# ------------------------------------------------------------------------------------------ orbit cases (§2.4.4)
def square_both_sides():
    """Unit square in the mesh xy plane, both sides black (absorptance 1) and active: side 0 is +z, side 1 -z."""
    return Surface(SQUARE, UP, emissivity=1.0, absorptivity=1.0, active=True)


def thesis_case(case: int, positions: int = 24):
    """The two orbit cases of thesis §2.4.4 (orbit, attitude, inertial position and +z normal per position)."""
    if case == 1:
        # circular equatorial 800 km, vernal equinox (Sun along +X, in the orbital plane), +z 130° from the Sun and
        # 50° from the orbital plane: Sun-pointing with the mesh's Sun direction and orbit normal given as vectors
        orbit = Orbit.make(altitude=800e3, inclination=0.0, beta=0.0, positions=positions)
        c, s = math.cos(math.radians(130)), math.sin(math.radians(130))
        att = Attitude.make("sun", primary=[s, 0, c], secondary=[-c, 0, s])
        normal = lambda r: c * np.array([1.0, 0, 0]) + s * np.array([0, 0, 1.0])  # noqa: E731
    else:
        # i = 98°, RAAN 60°, Sun along +X; +z always away from the Sun, x in the orbital plane
        orbit = Orbit.make(altitude=800e3, inclination=98.0, raan=60.0, sun_direction=[1, 0, 0], positions=positions)
        att = Attitude.make("sun", primary="-z", secondary="+y")
        normal = lambda r: np.array([-1.0, 0, 0])  # noqa: E731
    return orbit, att, normal


def inertial_positions(orbit: Orbit, nu_deg: np.ndarray) -> np.ndarray:
    """Circular-orbit positions from the elements by rotation matrices R3(Ω) R1(i) (independent of Orbit.state)."""
    Q = rot(2, orbit.raan) @ rot(0, orbit.inclination)
    nu = np.radians(nu_deg)
    return (Q @ (orbit.semi_major_axis * np.stack([np.cos(nu), np.sin(nu), np.zeros_like(nu)]))).T


def case_reference(case: int, positions: int = 24, n: int = 200):
    orbit, att, normal = thesis_case(case, positions)
    nu = orbit.true_anomalies
    r = inertial_positions(orbit, nu)
    sun = np.array([1.0, 0, 0])
    ref = np.array([[quadrature_eq_2_23(ri, normal(ri), sun, n), quadrature_eq_2_23(ri, -normal(ri), sun, n)]
                    for ri in r])
    return orbit, att, ref


def case_delta(orbit, att, ref, rays: int, runs, focus: str = "planet", sampling: str = "halton") -> float:
    """δ of thesis eq. 2.44: RMS error over the sampled positions, both faces and the runs (W/m², unit area)."""
    surface = square_both_sides()
    scene = TriangleScene(surface)
    err = []
    for run in runs:  # loop over independent runs (seeds)
        fl = trace_orbit(surface, orbit, att, kinds=("albedo",), rays_per_group=rays, seed=run, scene=scene,
                         per="side", sampling=sampling, focus=focus)
        sampled = fl.positions.event == ""
        err.append(fl.incident["albedo"][sampled] - ref)
    return float(np.sqrt(np.mean(np.square(err))))


@pytest.fixture(scope="module")
def case_refs():
    return {c: case_reference(c) for c in (1, 2)}


def test_thesis_orbit_cases_reference_maxima(case_refs):
    # thesis §2.4.4 case 2: maxima 81 W/m² on +z and 21 W/m² on -z (read from Fig. 2.33(a), to the unit)
    _, _, ref2 = case_refs[2]
    dense = case_reference(2, positions=72)[2]  # 5° steps: the maxima fall between the 15° samples
    assert round(dense[:, 0].max()) == 81 and round(dense[:, 1].max()) == 21
    # case 1: symmetric about the subsolar point (true anomaly 0), maximum there (thesis Fig. 2.31(a))
    _, _, ref1 = case_refs[1]
    np.testing.assert_allclose(ref1[1:], ref1[:0:-1], rtol=1e-9, atol=1e-9)
    assert ref1[:, 0].argmax() == 0
    assert ref2.shape == (24, 2)


@pytest.mark.parametrize("case", [1, 2])
def test_thesis_orbit_cases_delta_100_rays(case_refs, case):
    # δ (eq. 2.44) over 24 positions, both faces and 20 runs at 100 rays per face: ≤ 1.5 W/m² (issue; thesis
    # PFHS 1.0 W/m², ESARAD 7.5 W/m²)
    orbit, att, ref = case_refs[case]
    assert case_delta(orbit, att, ref, 100, range(20)) <= 1.5


@pytest.mark.parametrize("case", [1, 2])
def test_thesis_orbit_cases_delta_1e4_rays(case_refs, case):
    # δ ≤ 0.1 W/m² at 1e4 rays per face (issue; thesis Fig. 2.31(b)/2.33(b)); 4 runs by default (the 20-run
    # version is the slow test below)
    orbit, att, ref = case_refs[case]
    assert case_delta(orbit, att, ref, 10_000, range(4)) <= 0.1


@pytest.mark.slow
@pytest.mark.parametrize("case", [1, 2])
def test_thesis_orbit_cases_delta_1e4_rays_20_runs(case_refs, case):
    orbit, att, ref = case_refs[case]
    assert case_delta(orbit, att, ref, 10_000, range(20)) <= 0.1


def test_pfhs_needs_20x_fewer_rays_than_hemisphere_sampling(case_refs):
    # issue: rays needed for δ = 0.1 W/m² at least 20x fewer with PFHS than with plain hemisphere sampling in the
    # same tracer.  Case 1: PFHS reaches δ <= 0.1 with 1 500 rays per face (measured ~1 050); plain sampling
    # (crude Monte Carlo, cosine law over the hemisphere, as ESARAD's rays; δ ∝ n^-1/2) is still far above 0.1 with
    # 20 x 1 500 = 30 000 (measured δ(1e5) = 0.20, so it needs ~4e5).  `fem2tmm bench orbit` measures the ratio,
    # and against hemisphere sampling with the same Halton points (~7x)
    orbit, att, ref = case_refs[1]
    assert case_delta(orbit, att, ref, 1500, range(2)) <= 0.1
    assert case_delta(orbit, att, ref, 30_000, range(1), focus="hemisphere", sampling="random") > 0.2


# ------------------------------------------------------------------------------------------------ orbit mechanics
@pytest.mark.parametrize("beta,omega", [(0.0, 0.0), (20.0, 0.0), (45.0, 130.0)])
def test_eclipse_entry_exit_cylindrical_closed_form(beta, omega):
    # circular orbit, cylindrical shadow: the spacecraft at argument of latitude u (from the Sun's projection) is
    # shadowed while a cos β cos u < -√(a² - R²): the boundaries are u = π ∓ arccos(√(1 - (R/a)²) / cos β);
    # the true anomaly is u - ω (Sun projection at argument of latitude 0).  Issue tolerance 0.01°.
    a = R + 700e3
    orbit = Orbit.make(altitude=700e3, inclination=98.0, raan=30.0, argument_of_perigee=omega, beta=beta)
    half = math.acos(math.sqrt(1 - (R / a) ** 2) / math.cos(math.radians(beta)))
    ev = dict((k, v) for v, k in orbit.eclipse_events())
    entry = math.degrees(math.pi - half) - omega
    exit_ = math.degrees(math.pi + half) - omega
    assert abs((math.degrees(ev["entry"]) - entry + 180) % 360 - 180) < 0.01
    assert abs((math.degrees(ev["exit"]) - exit_ + 180) % 360 - 180) < 0.01
    # beyond the critical beta there is no eclipse
    assert Orbit.make(altitude=700e3, beta=math.degrees(math.acos(math.sqrt(1 - (R / a) ** 2))) + 0.5
                      ).eclipse_events() == []


def test_positions_table_eclipse_rows_and_kepler_time():
    orbit = Orbit.make(altitude=700e3, eccentricity=0.05, inclination=51.6, raan=10, argument_of_perigee=40,
                       beta=10.0, positions=12)
    pos = orbit.positions()
    events = list(pos.event)
    assert events.count("entry") == 2 and events.count("exit") == 2  # each boundary twice: lit then dark
    i = events.index("entry")
    assert pos.lit[i] == 1.0 and pos.lit[i + 1] == 0.0 and pos.time[i] == pos.time[i + 1]
    assert np.all(np.diff(pos.time) >= 0) and pos.time[-1] < orbit.period
    # time since perigee against dt/dν = r² / h integrated numerically (independent of Kepler's equation)
    e, a, mu = orbit.eccentricity, orbit.semi_major_axis, EARTH.mu
    p = a * (1 - e * e)
    h = math.sqrt(mu * p)
    for nu, t in zip(np.radians(pos.true_anomaly), pos.time):
        ref = quad(lambda x: (p / (1 + e * math.cos(x))) ** 2 / h, 0.0, nu, epsabs=1e-9, epsrel=1e-12)[0]
        assert t == pytest.approx(ref, rel=1e-9, abs=1e-6)
    # the energy integral: v² = μ (2/r - 1/a) at every position
    r = np.linalg.norm(pos.position, axis=1)
    v = np.linalg.norm(pos.velocity, axis=1)
    np.testing.assert_allclose(v**2, mu * (2 / r - 1 / a), rtol=1e-12)
    assert orbit.period == pytest.approx(2 * math.pi * math.sqrt(a**3 / mu), rel=1e-15)


def test_conical_shadow_lit_fraction_against_disc_sampling():
    # lit fraction of the solar disc from the closed-form circle overlap against counting points of a fine grid on
    # the solar disc whose line of sight misses the planet (no shared code); the penumbra brackets the
    # cylindrical boundary and the umbra lies within it
    orbit = Orbit.make(altitude=700e3, beta=10.0, eclipse="conical")
    ev = orbit.eclipse_events()
    assert [k for _, k in ev] == ["penumbra_entry", "umbra_entry", "umbra_exit", "penumbra_exit"]
    evd = {k: v for v, k in ev}
    cyl = {k: v for v, k in Orbit.make(altitude=700e3, beta=10.0).eclipse_events()}
    assert evd["penumbra_entry"] < cyl["entry"] < evd["umbra_entry"]
    assert evd["umbra_exit"] < cyl["exit"] < evd["penumbra_exit"]
    nus = np.linspace(evd["penumbra_entry"], evd["umbra_entry"], 7)[1:-1]
    r = orbit.state(nus)[0]
    lit = orbit.lit_fraction(r)
    sun_c = orbit.sun * orbit.sun_distance * ASTRONOMICAL_UNIT
    k = 400
    g = (np.arange(k) + 0.5) / k * 2 - 1
    X, Y = np.meshgrid(g, g)
    inside = X**2 + Y**2 < 1
    e1 = np.cross(orbit.sun, [0, 0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(orbit.sun, e1)
    pts = sun_c + SUN_RADIUS * (X[inside][:, None] * e1 + Y[inside][:, None] * e2)
    for ri, li in zip(r, lit):
        d = pts - ri
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        b = d @ ri
        miss = (b > 0) | (b * b - (ri @ ri - R * R) < 0)
        assert li == pytest.approx(miss.mean(), abs=3e-3)  # grid of 1.26e5 points: boundary error ~ 1/400
    assert np.all(np.diff(lit) < 0)  # entering: less and less lit


def test_sun_ephemeris_against_published_equinox_and_solstice():
    # USNO / IMCCE: March equinox 2026-03-20 14:46 UTC (declination 0), June solstice 2026-06-21 08:24 UTC
    # (declination = obliquity 23.436°), perihelion 2026-01-03 17:15 UTC at 0.98330 au; formula accuracy 0.01°
    s, _ = sun_ephemeris(julian_date("2026-03-20T14:46:00"))
    assert math.degrees(math.asin(s[2])) == pytest.approx(0.0, abs=0.01)
    assert s[0] > 0.99
    s, _ = sun_ephemeris(julian_date("2026-06-21T08:24:00Z"))
    assert math.degrees(math.asin(s[2])) == pytest.approx(23.436, abs=0.01)
    _, dist = sun_ephemeris(julian_date("2026-01-03T17:15:00"))
    assert dist == pytest.approx(0.98330, abs=2e-5)
    o = Orbit.make(altitude=700e3, date="2026-01-03T17:15:00", solar_flux="distance")
    assert o.solar_flux == pytest.approx(1366.1 / 0.98330**2, rel=5e-5)


def test_attitudes_point_the_given_axes():
    orbit = Orbit.make(altitude=700e3, inclination=98.0, raan=60.0, beta=25.0, positions=8)
    pos = orbit.positions()
    nad = Attitude.make("nadir", primary="-z", secondary="+x")
    M = nad.matrices(orbit, pos.position, pos.velocity)
    np.testing.assert_allclose(np.einsum("kij,kjl->kil", M.transpose(0, 2, 1), M), np.tile(np.eye(3), (len(M), 1, 1)),
                               atol=1e-12)
    np.testing.assert_allclose(M @ [0, 0, -1.0], -pos.position / np.linalg.norm(pos.position, axis=1)[:, None],
                               atol=1e-12)
    v = pos.velocity / np.linalg.norm(pos.velocity, axis=1)[:, None]
    assert np.all(np.einsum("ki,ki->k", M @ [1.0, 0, 0], v) > 0.999)  # circular: velocity ⟂ nadir
    # a fixed rotation: the mesh mounted turned 90° about z, so its +y now does what +x did
    rotd = Attitude.make("nadir", primary="-z", secondary="+x", rotation=[["z", -90]])
    np.testing.assert_allclose(rotd.matrices(orbit, pos.position, pos.velocity) @ [0, 1.0, 0], M @ [1.0, 0, 0],
                               atol=1e-12)
    # thesis case 1: +z 130° from the Sun and 50° from the orbital plane at every position
    orbit1, att1, _ = thesis_case(1)
    p1 = orbit1.positions()
    z = att1.matrices(orbit1, p1.position, p1.velocity) @ [0, 0, 1.0]
    np.testing.assert_allclose(np.degrees(np.arccos(z @ orbit1.sun)), 130.0, atol=1e-9)
    np.testing.assert_allclose(np.degrees(np.arcsin(z @ orbit1.normal)), 50.0, atol=1e-9)
    # inertial: fixed axes
    inert = Attitude.make("inertial", axes=[[0, 1.0, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(inert.matrices(orbit, pos.position, pos.velocity) @ [1.0, 0, 0],
                               np.tile([0, 1.0, 0], (len(pos), 1)), atol=1e-12)


def test_bad_orbit_and_attitude_input_names_the_key():
    with pytest.raises(Fem2TmmError, match="eccentricity"):
        Orbit.make(altitude=700e3, eccentricity=1.2)
    with pytest.raises(Fem2TmmError, match="altitude"):
        Orbit.make()
    with pytest.raises(Fem2TmmError, match="beta"):
        Orbit.make(altitude=700e3, beta=20.0, date="2026-03-20")
    with pytest.raises(Fem2TmmError, match="solar_flux"):
        Orbit.make(altitude=700e3, solar_flux="distance")
    with pytest.raises(Fem2TmmError, match="semi_major_axis"):
        Orbit.make(semi_major_axis=6000e3)
    with pytest.raises(Fem2TmmError, match="primary"):
        Attitude.make("nadir", primary="+w")
    with pytest.raises(Fem2TmmError, match="inside the planet"):
        planet_fluxes(SQUARE, DOWN, [0, 0, 1000.0], [0, 0, 1])
    with pytest.raises(Fem2TmmError, match="kind"):
        planet_fluxes(SQUARE, DOWN, [0, 0, R + 1e6], [0, 0, 1], kind="visible")


# ------------------------------------------------------------------------------------------------ orbital fluxes
def test_orbital_fluxes_energy_balance_shadowing_and_eclipse():
    # an open box (five walls, reflective inside: specular and diffuse) with a plate above its opening, nadir
    # pointing in a 700 km orbit at β = 20°: per position and kind, Σ incident = Σ absorbed + lost to 1e-12; no
    # solar power in the umbra, solar power scaled by the lit fraction at the boundaries
    box = meshes.box(0.5, 0.4, 0.3, 5, 4, 3)
    pts, faces = box.points, box.blocks[0].cells
    keep = ~np.all(np.isclose(pts[faces][:, :, 2], 0.3), axis=1)  # drop the top wall: open towards +z
    faces = faces[keep][:, ::-1]  # front sides inward: the inside reflects, the outside stops rays
    orbit = Orbit.make(altitude=700e3, inclination=98.0, beta=20.0, positions=6)
    att = Attitude.make("nadir", primary="+z", secondary="+x")  # the opening faces nadir
    fl = orbital_fluxes(pts, faces, orbit, att, absorptivity=0.4, emissivity=0.7, specular=0.5, rays_per_face=200,
                        seed=3)
    for kind in fl.kinds:
        inc = fl.incident[kind].sum(axis=1)
        out = fl.absorbed[kind].sum(axis=1) + fl.lost[kind]
        np.testing.assert_allclose(out, inc, rtol=1e-12, atol=1e-12 * max(inc.max(), 1.0))
        assert np.all(fl.absorbed[kind] >= 0)
    dark = fl.positions.lit == 0
    assert dark.any() and np.all(fl.incident["solar"][dark] == 0)
    assert np.any(fl.incident["solar"][~dark].sum(axis=1) > 0)  # sunlight enters the opening near orbit noon
    assert np.all(fl.incident["ir"].sum(axis=1) > 0)
    # a nadir-pointing box sees the same planet IR at every position of a circular orbit (up to sampling noise)
    ir = fl.incident["ir"].sum(axis=1)
    assert ir.std() / ir.mean() < 0.02
    # mesh-frame directions: nadir is +z (the attitude's primary axis)
    np.testing.assert_allclose(fl.nadir, np.tile([0, 0, 1.0], (len(fl.nadir), 1)), atol=1e-12)


# ---------------------------------------------------------------------------------------------- case file, pipeline
def orbit_case(transient=None, **orbit):
    from conftest import make_case

    o = {"altitude": 700e3, "inclination": 98.0, "beta": 20.0, "positions": 6, "rays_per_face": 50,
         "steady": "positions", "attitude": {"kind": "nadir", "primary": "-z", "secondary": "+x"}}
    o.update(orbit)
    return make_case(
        [{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
          "back": "black", "super_nodes": 1}],
        materials={"al": {"conductivity": 1e5, "density": 2700.0, "specific_heat": 900.0}},
        environment={"sink_temperature": -270.15}, orbit=o, **({} if transient is None else {"transient": transient}))


def test_orbit_pipeline_isothermal_plate_per_position_and_average():
    # a near-isothermal black plate (k = 1e5 W/(m K)) facing nadir, both sides radiating to a 3 K sink: at each
    # position T⁴ = (Q_abs / (2 σ A) + T_sink⁴), Q_abs the orbital power the run absorbed there; the steady case
    # takes the orbit-average of the loads (time-weighted, eclipse jumps included).  Reduced (1 super node) =
    # detailed to the conduction gradients (ΔT ~ Q L² / (k t A) ~ 1e-3 K here).
    from fem2tmm import run
    from fem2tmm.radiation.orbital import period_average

    mesh = meshes.plate(0.5, 0.5, 4, 4)
    res = run(orbit_case(), mesh=mesh)
    fl = res.orbit.detailed
    Q = fl.total("absorbed").sum(axis=1)
    area = 0.25
    T_exact = (Q / (2 * SIGMA * area) + 3.0**4) ** 0.25
    T_pos = res.orbit.T_positions.mean(axis=1)
    np.testing.assert_allclose(T_pos, T_exact, rtol=2e-5)
    np.testing.assert_allclose(res.orbit.T_positions_detailed.mean(axis=1), T_exact, rtol=2e-5)
    Q_avg = period_average(fl.positions.time, Q, fl.positions.period)
    assert res.reduced.solution.T[0] == pytest.approx((Q_avg / (2 * SIGMA * area) + 3.0**4) ** 0.25, rel=2e-5)
    # the eclipse rows: no solar power in the shadow, albedo and IR unchanged across the boundary
    ev = list(fl.positions.event)
    i = ev.index("entry")
    assert fl.total("absorbed")[i].sum() > fl.total("absorbed")[i + 1].sum()
    np.testing.assert_array_equal(fl.absorbed["ir"][i], fl.absorbed["ir"][i + 1])
    s = res.summary["orbit"]
    assert s["positions"] == len(fl.positions) and s["kinds"]["ir"]["max_relative_imbalance"] < 1e-12


@pytest.mark.parametrize("fluxes_on", ["detailed", "super_faces"])
def test_orbit_positions_with_the_radiation_aware_network(fluxes_on):
    # steady = "positions" with the radiation-aware network: each position solves the network handed over (its loads
    # at the orbit average plus that position's departure from it, through its own Y') and recovers about its
    # linearisation.  The near-isothermal black plate gives T⁴ = Q_abs / (2 σ A) + T_sink⁴ at every position (the
    # closed form of the test above): a departure counted twice or not at all would miss it by tens of kelvin.
    from fem2tmm import run

    mesh = meshes.plate(0.5, 0.5, 4, 4)
    case = orbit_case(fluxes_on=fluxes_on)
    case = dataclasses.replace(case, reduction=dataclasses.replace(case.reduction, radiation_aware=True))
    res = run(case, mesh=mesh)
    assert res.reduced.network.radiative is not None
    fl = res.orbit.detailed if fluxes_on == "detailed" else res.orbit.super_faces
    Q = fl.total("absorbed").sum(axis=1)
    T_exact = (Q / (2 * SIGMA * 0.25) + 3.0**4) ** 0.25
    # super-face loads: the super face's own (noisier) trace, so the closed form uses its absorbed power
    np.testing.assert_allclose(res.orbit.T_positions.mean(axis=1), T_exact, rtol=2e-5)


def test_orbit_pipeline_super_faces_and_outputs(tmp_path):
    # fluxes on the super faces: the plate is one super face, so its absorbed power per position equals the FE
    # faces' sum up to ray noise (50 rays per face, 16 faces: ~1 %); outputs orbit.npz and the plots
    from fem2tmm import run

    mesh = meshes.plate(0.5, 0.5, 4, 4)
    res = run(orbit_case(fluxes_on="super_faces"), mesh=mesh, out=tmp_path / "out")
    det = res.orbit.detailed.total("absorbed").sum(axis=1)
    sf = res.orbit.super_faces.total("absorbed").sum(axis=1)
    np.testing.assert_allclose(sf, det, rtol=0.03)
    data = np.load(tmp_path / "out" / "orbit.npz", allow_pickle=False)
    assert data["temperature_C"].shape == (len(res.orbit.super_faces.positions), mesh.n_nodes)
    assert data["super_faces_absorbed_solar_W"].shape[0] == len(data["time_s"])
    assert (tmp_path / "out" / "orbit_fluxes.png").exists() and (tmp_path / "out" / "orbit_temperatures.png").exists()


def test_orbit_case_errors():
    with pytest.raises(Fem2TmmError, match=r"\[orbit\].*eccentricity"):
        orbit_case(eccentricity=1.5)
    with pytest.raises(Fem2TmmError, match=r"\[orbit.attitude\].*primary"):
        orbit_case(attitude={"kind": "nadir", "primary": "+q"})
    with pytest.raises(Fem2TmmError, match="unknown key"):
        orbit_case(altitud=5.0)
    from conftest import make_case

    with pytest.raises(Fem2TmmError, match=r"\[environment\].*set by \[orbit\]"):
        make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                    "back": "black", "super_nodes": 1}],
                  environment={"sun_direction": [0, 0, 1], "solar_flux": 1000.0}, orbit={"altitude": 7e5})


def test_orbit_transient_periodic_isothermal_plate_against_ode():
    # [transient] periodic = true with [orbit]: the period is the orbital period, the loads follow the positions'
    # table in time (linear between positions, jumps at the eclipse boundaries).  A near-isothermal black plate
    # (k = 1e5 W/(m K)): C dT/dt = Q(t) - 2 σ A (T⁴ - T_sink⁴), Q(t) the run's absorbed totals interpolated in
    # time, integrated independently by scipy's Radau over 8 periods (time constant ~350 s << period 5 926 s).
    # Adaptive Crank-Nicolson (local error 1e-3 K; its steps end at every position and eclipse boundary) against
    # Radau at rtol 1e-9: measured 6e-3 K, asserted 0.02 K.  Reduced (1 super node) = detailed to the conduction gradients.
    from scipy.integrate import solve_ivp

    from fem2tmm import run

    mesh = meshes.plate(0.5, 0.5, 2, 2)
    case = orbit_case(steady="average", transient={"periodic": True, "tolerance": 1e-3, "step": 20.0,
                                                   "output_every": 100.0, "periodic_tolerance": 1e-3})
    res = run(case, mesh=mesh)
    fl = res.orbit.detailed
    P = fl.positions.period
    assert case.transient.end == pytest.approx(P, rel=1e-12)
    Q = fl.total("absorbed").sum(axis=1)
    t_tab = np.append(fl.positions.time, fl.positions.time[0] + P)
    q_tab = np.append(Q, Q[0])
    # after a repeated time (eclipse boundary) np.interp takes the later row: the load right after the jump
    load = lambda t: np.interp(np.mod(t, P), t_tab, q_tab)  # noqa: E731
    area, C = 0.25, 2700.0 * 900.0 * 1e-3 * 0.25
    rhs = lambda t, T: (load(t) - 2 * SIGMA * area * (T**4 - 3.0**4)) / C  # noqa: E731
    jumps = fl.positions.time[fl.positions.event != ""]
    T0 = (Q.mean() / (2 * SIGMA * area)) ** 0.25
    t_eval = res.transient.times
    T = np.array([T0])
    for k in range(8):  # periods, split at the jumps so the integrator never steps over one
        edges = np.unique(np.concatenate([[0.0], jumps, [P]]))
        for a, b in zip(edges[:-1], edges[1:]):
            sol = solve_ivp(rhs, (k * P + a, k * P + b), T, method="Radau", rtol=1e-9, atol=1e-9,
                            dense_output=True)
            T = sol.y[:, -1]
            if k == 7:
                m = (t_eval >= a) & (t_eval <= b)
                T_ref_part = sol.sol(7 * P + t_eval[m])[0]
                np.testing.assert_allclose(res.transient.T_recovered[m].mean(axis=1), T_ref_part, atol=0.02)
                np.testing.assert_allclose(res.transient.detailed.T[m].mean(axis=1), T_ref_part, atol=0.02)
    assert res.transient.reduced.stats["periods"] >= 2


def test_orbit_stages_are_cached_by_exactly_their_inputs(tmp_path):
    # issue 19: the orbit tracings are keyed by what they read (geometry, both bands' optics, orbit, attitude,
    # kinds, rays, seeds): a heater change reuses them; an orbit, attitude or absorptivity change traces again.
    # Reuse is checked on the numbers too: a reused tracing gives the identical absorbed powers (0 W apart).
    from conftest import make_case

    from fem2tmm import run

    mesh = meshes.plate(0.5, 0.5, 4, 4)

    def case(power=1.0, absorptivity=1.0, beta=20.0, primary="-z"):
        o = {"altitude": 700e3, "inclination": 98.0, "beta": beta, "positions": 4, "rays_per_face": 20,
             "fluxes_on": "super_faces", "attitude": {"kind": "nadir", "primary": primary, "secondary": "+x"}}
        return make_case(
            [{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
              "back": "black", "super_nodes": 2}],
            boundary=[{"name": "heater", "kind": "power", "groups": ["plate"], "value": power}],
            optics={"black": {"emissivity": 1.0, "absorptivity": absorptivity}},
            environment={"sink_temperature": -270.15}, orbit=o, reference={"detailed": True})

    cache = tmp_path / "cache"
    first = run(case(), mesh=mesh, cache=cache)
    assert first.cache["orbit_detailed"] == first.cache["orbit"] == "computed"
    heater = run(case(power=3.0), mesh=mesh, cache=cache)
    assert heater.cache["orbit_detailed"] == heater.cache["orbit"] == "reused"
    np.testing.assert_array_equal(heater.orbit.detailed.total("absorbed"), first.orbit.detailed.total("absorbed"))
    np.testing.assert_array_equal(heater.orbit.super_faces.total("absorbed"),
                                  first.orbit.super_faces.total("absorbed"))
    assert heater.reduced.solution.T.mean() > first.reduced.solution.T.mean()  # the heater itself did change
    for changed in (case(beta=40.0), case(primary="+z"), case(absorptivity=0.5)):
        r = run(changed, mesh=mesh, cache=cache)
        assert r.cache["orbit_detailed"] == r.cache["orbit"] == "computed"
