"""Orbit mechanics for orbital heat fluxes: the planet, Keplerian orbits, the Sun (β angle, inertial vector or a
low-precision ephemeris), eclipses (cylindrical or conical shadow with penumbra) and spacecraft attitudes.

Thesis §2.4 (``seeds/jacques-2016-reduced-fe-space-thermal.txt`` l. 1338-1610): the Earth of the orbit cases of
§2.4.4 (equatorial radius 6 378.136 km, EGM2008), solar constant 1 366.1 W/m² (ASTM E490), diffuse albedo 0.3,
black-body infrared at 288 K.

Frames.  *Inertial*: planet-centred, equatorial (x towards the vernal equinox, z along the spin axis).  *Mesh*:
the frame of the spacecraft's mesh; an :class:`Attitude` gives the rotation from the mesh frame to the inertial
frame at each position.  Angles are in degrees at the interface, lengths in m, times in s.

Why our own ephemeris instead of astropy: the Sun's direction to 0.01° (Astronomical Almanac's low-precision
formula, valid 1950-2050) is ten lines of arithmetic; astropy (tens of MB, frequent IERS downloads) would be a
heavy runtime dependency for a quantity whose 0.01° error is far below what a thermal model resolves.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from .constants import SIGMA
from .errors import Fem2TmmError

#: m, IAU 2012
ASTRONOMICAL_UNIT = 149_597_870_700.0
#: m, IAU 2015 nominal solar radius
SUN_RADIUS = 6.957e8
#: W/m² at 1 au, ASTM E490 (thesis §2.4.1)
SOLAR_CONSTANT = 1366.1
#: true-anomaly grid that brackets eclipse boundaries before root finding
_ECLIPSE_GRID = 2048
_XTOL = 1e-12  # rad, root-finding tolerance on the true anomaly


@dataclass(frozen=True)
class Planet:
    """A spherical planet with uniform diffuse albedo and infrared exitance.

    ``radius`` m, ``mu`` gravitational parameter m³/s², ``albedo`` (diffuse reflectance of sunlight, 0..1),
    infrared: a grey body at ``ir_temperature`` K with ``ir_emissivity``, or a given exitance ``ir_flux`` W/m² at
    the planet's surface (overrides the temperature).  Defaults: the Earth of thesis §2.4.4.
    """

    radius: float = 6_378_136.0
    mu: float = 3.986004418e14
    albedo: float = 0.3
    ir_temperature: float = 288.0
    ir_emissivity: float = 1.0
    ir_flux: float | None = None

    def __post_init__(self):
        for name, lo, hi in (("radius", 0.0, math.inf), ("mu", 0.0, math.inf), ("albedo", 0.0, 1.0),
                             ("ir_temperature", 0.0, math.inf), ("ir_emissivity", 0.0, 1.0)):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi) or (
                    name in ("radius", "mu") and v <= 0):
                raise Fem2TmmError(f"planet {name} must be a number in [{lo}, {hi}]{' (> 0)' if lo == 0 else ''}, "
                                   f"got {v!r}")
        if self.ir_flux is not None and not (math.isfinite(self.ir_flux) and self.ir_flux >= 0):
            raise Fem2TmmError(f"planet ir_flux must be a finite exitance >= 0 W/m², got {self.ir_flux!r}")

    @property
    def exitance(self) -> float:
        """Infrared power emitted per m² of planet surface (W/m²): ``ir_flux`` or σ ε T⁴."""
        if self.ir_flux is not None:
            return float(self.ir_flux)
        return SIGMA * self.ir_emissivity * self.ir_temperature**4


EARTH = Planet()


def julian_date(when) -> float:
    """Julian date (UTC taken as TT: the 69 s difference moves the Sun by 0.0008°) of ``when``: a
    :class:`datetime.datetime` / :class:`datetime.date` (naive = UTC) or an ISO 8601 string."""
    if isinstance(when, str):
        try:
            when = _dt.datetime.fromisoformat(when.replace("Z", "+00:00"))
        except ValueError as exc:
            raise Fem2TmmError(f"date {when!r} is not an ISO 8601 date (e.g. 2026-03-20T14:46:00)") from exc
    if isinstance(when, _dt.date) and not isinstance(when, _dt.datetime):
        when = _dt.datetime(when.year, when.month, when.day)
    if not isinstance(when, _dt.datetime):
        raise Fem2TmmError(f"date must be an ISO 8601 string or a datetime, got {when!r}")
    if when.tzinfo is not None:
        when = when.astimezone(_dt.timezone.utc).replace(tzinfo=None)
    j2000 = _dt.datetime(2000, 1, 1, 12, 0, 0)
    return 2451545.0 + (when - j2000).total_seconds() / 86400.0


def sun_ephemeris(jd: float) -> tuple[np.ndarray, float]:
    """Unit vector (3,) from the planet (Earth) towards the Sun in the mean equatorial frame of date, and the Sun's
    distance in au, at Julian date ``jd``: the Astronomical Almanac's low-precision formula (section C, "Sun":
    0.01° in 1950-2050)."""
    n = jd - 2451545.0
    L = 280.460 + 0.9856474 * n
    g = math.radians((357.528 + 0.9856003 * n) % 360.0)
    lam = math.radians((L + 1.915 * math.sin(g) + 0.020 * math.sin(2 * g)) % 360.0)
    eps = math.radians(23.439 - 0.0000004 * n)
    R = 1.00014 - 0.01671 * math.cos(g) - 0.00014 * math.cos(2 * g)
    return np.array([math.cos(lam), math.cos(eps) * math.sin(lam), math.sin(eps) * math.sin(lam)]), R


def _rot3(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _rot1(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@dataclass(frozen=True)
class OrbitPositions:
    """The positions of an orbit at which fluxes are computed (k rows, in time order).

    ``true_anomaly`` (k,) deg in [0, 360), ``time`` (k,) s since perigee (Kepler's equation), ``lit`` (k,)
    fraction of the solar disc visible (1 sunlit, 0 umbra, in between penumbra), ``eclipse`` (k,) bool lit < 1,
    ``event`` (k,) str: "" for a sampled position, "entry" / "exit" for the cylindrical shadow's boundaries,
    "penumbra_entry", "umbra_entry", "umbra_exit", "penumbra_exit" for the conical one.  A cylindrical boundary is
    listed twice at the same time, lit then dark (entry) or dark then lit (exit): the solar load jumps there.
    ``position`` / ``velocity`` (k, 3) inertial, m and m/s; ``sun`` (3,) unit inertial vector towards the Sun;
    ``solar_flux`` W/m² (unshadowed); ``period`` s.
    """

    true_anomaly: np.ndarray
    time: np.ndarray
    lit: np.ndarray
    eclipse: np.ndarray
    event: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    sun: np.ndarray
    solar_flux: float
    period: float

    def __len__(self) -> int:
        return len(self.time)


@dataclass(frozen=True)
class Orbit:
    """A Keplerian orbit around ``planet`` with the Sun fixed in the inertial frame during one revolution.

    ``semi_major_axis`` m, ``eccentricity`` [0, 1), ``inclination``, ``raan`` (right ascension of the ascending
    node), ``argument_of_perigee`` in degrees.  ``sun`` (3,) unit inertial vector towards the Sun, ``sun_distance``
    au (for the conical shadow), ``solar_flux`` W/m² at the spacecraft.  ``true_anomalies`` (k,) degrees of the
    sampled positions.  ``eclipse`` "cylindrical" (the planet's shadow is a cylinder of its radius: lit or not) or
    "conical" (umbra and penumbra cones of the Sun's finite disc; the lit fraction of the solar disc).

    Build one with :meth:`Orbit.make` (altitude or semi-major axis, Sun by β angle, date or vector).
    """

    semi_major_axis: float
    eccentricity: float = 0.0
    inclination: float = 0.0
    raan: float = 0.0
    argument_of_perigee: float = 0.0
    sun: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    sun_distance: float = 1.0
    solar_flux: float = SOLAR_CONSTANT
    true_anomalies: np.ndarray = field(default_factory=lambda: np.arange(24) * 15.0)
    eclipse: str = "cylindrical"
    planet: Planet = EARTH

    @classmethod
    def make(cls, planet: Planet | None = None, *, altitude=None, semi_major_axis=None, eccentricity=0.0,
             inclination=0.0, raan=0.0, argument_of_perigee=0.0, beta=None, sun_argument=0.0, date=None,
             sun_direction=None, solar_flux=SOLAR_CONSTANT, positions=24, eclipse="cylindrical",
             where: str = "[orbit]") -> "Orbit":
        """An orbit from user-facing parameters (angles in degrees, lengths in m).

        Size: ``altitude`` (m above the planet's radius; circular unless ``eccentricity``: then the perigee
        altitude) or ``semi_major_axis`` (m).  The Sun: ``beta`` (angle between the Sun and the orbital plane, deg,
        positive towards the orbit normal), its projection onto the orbital plane at argument of latitude
        ``sun_argument`` (deg from the ascending node, default 0: orbit noon at the node); or ``date`` (ISO 8601 /
        datetime, :func:`sun_ephemeris`) with the orbit's ``raan``; or ``sun_direction`` (3,) inertial.  Default: β
        = 0.  ``solar_flux`` W/m² or "distance" (1 366.1 W/m² scaled by the ephemeris' Sun distance, needs
        ``date``).  ``positions``: number of equally spaced true anomalies from 0, or a list of true anomalies
        (deg).  ``where`` names the case-file table in error messages.
        """
        planet = EARTH if planet is None else planet
        bad = lambda key, msg: Fem2TmmError(f"{where}.{key}: {msg}")  # noqa: E731
        e = float(eccentricity)
        if not (math.isfinite(e) and 0.0 <= e < 1.0):
            raise bad("eccentricity", f"must lie in [0, 1) (closed orbits), got {eccentricity!r}")
        if (altitude is None) == (semi_major_axis is None):
            raise bad("altitude", "give exactly one of altitude or semi_major_axis")
        if altitude is not None:
            alt = float(altitude)
            if not (math.isfinite(alt) and alt > 0):
                raise bad("altitude", f"must be > 0 m above the planet's surface, got {altitude!r}")
            a = (planet.radius + alt) / (1.0 - e)
        else:
            a = float(semi_major_axis)
            if not (math.isfinite(a) and a * (1.0 - e) > planet.radius):
                raise bad("semi_major_axis", f"the perigee a (1 - e) must lie above the planet's radius "
                                             f"{planet.radius:g} m, got a = {semi_major_axis!r}, e = {e}")
        angles = {"inclination": inclination, "raan": raan, "argument_of_perigee": argument_of_perigee,
                  "sun_argument": sun_argument}
        for k, v in angles.items():
            if not (isinstance(v, int | float) and math.isfinite(v)):
                raise bad(k, f"must be an angle in degrees, got {v!r}")
        if not 0.0 <= inclination <= 180.0:
            raise bad("inclination", f"must lie in [0, 180] degrees, got {inclination!r}")
        given = [k for k, v in (("beta", beta), ("date", date), ("sun_direction", sun_direction)) if v is not None]
        if len(given) > 1:
            raise bad(given[1], f"give one of beta, date or sun_direction, not {' and '.join(given)}")
        distance = 1.0
        if date is not None:
            sun, distance = sun_ephemeris(julian_date(date))
        elif sun_direction is not None:
            s = np.asarray(sun_direction, float)
            if s.shape != (3,) or not np.all(np.isfinite(s)) or not np.linalg.norm(s) > 0:
                raise bad("sun_direction", f"must be a non-zero inertial vector [x, y, z], got {sun_direction!r}")
            sun = s / np.linalg.norm(s)
        else:
            b = 0.0 if beta is None else beta
            if not (isinstance(b, int | float) and -90.0 <= b <= 90.0):
                raise bad("beta", f"must lie in [-90, 90] degrees, got {beta!r}")
            node, across, normal = _plane_axes(math.radians(inclination), math.radians(raan))
            u, br = math.radians(sun_argument), math.radians(b)
            sun = math.cos(br) * (math.cos(u) * node + math.sin(u) * across) + math.sin(br) * normal
        if isinstance(solar_flux, str):
            if solar_flux != "distance":
                raise bad("solar_flux", f"must be a number (W/m²) or \"distance\", got {solar_flux!r}")
            if date is None:
                raise bad("solar_flux", "\"distance\" scales the solar constant by the Sun's distance on a date: "
                                        "give date")
            flux = SOLAR_CONSTANT / distance**2
        else:
            flux = float(solar_flux)
            if not (math.isfinite(flux) and flux >= 0):
                raise bad("solar_flux", f"must be a finite flux >= 0 W/m², got {solar_flux!r}")
        if np.ndim(positions) == 0:
            if not (isinstance(positions, int | np.integer) and positions >= 1):
                raise bad("positions", f"must be a number of positions >= 1 or a list of true anomalies (deg), "
                                       f"got {positions!r}")
            nu = np.arange(int(positions)) * (360.0 / int(positions))
        else:
            nu = np.asarray(positions, float)
            if nu.ndim != 1 or nu.size == 0 or not np.all(np.isfinite(nu)):
                raise bad("positions", "must be a non-empty list of true anomalies in degrees")
            nu = np.unique(np.mod(nu, 360.0))
        if eclipse not in ("cylindrical", "conical"):
            raise bad("eclipse", f"must be \"cylindrical\" or \"conical\", got {eclipse!r}")
        return cls(semi_major_axis=a, eccentricity=e, inclination=float(inclination), raan=float(raan),
                   argument_of_perigee=float(argument_of_perigee), sun=np.asarray(sun, float),
                   sun_distance=float(distance), solar_flux=flux, true_anomalies=nu, eclipse=eclipse, planet=planet)

    # ---------------------------------------------------------------------------------------------- geometry
    @property
    def period(self) -> float:
        """Orbital period (s), 2π √(a³/μ)."""
        return 2.0 * math.pi * math.sqrt(self.semi_major_axis**3 / self.planet.mu)

    @property
    def normal(self) -> np.ndarray:
        """Unit orbit normal (3,) in the inertial frame (along the angular momentum)."""
        return _plane_axes(math.radians(self.inclination), math.radians(self.raan))[2]

    @property
    def beta(self) -> float:
        """β angle (deg): the Sun's elevation above the orbital plane, towards the orbit normal."""
        return math.degrees(math.asin(float(np.clip(self.sun @ self.normal, -1.0, 1.0))))

    def _perifocal(self) -> np.ndarray:
        """Rotation (3, 3) perifocal -> inertial: R3(Ω) R1(i) R3(ω)."""
        return _rot3(math.radians(self.raan)) @ _rot1(math.radians(self.inclination)) @ _rot3(
            math.radians(self.argument_of_perigee))

    def state(self, true_anomaly) -> tuple[np.ndarray, np.ndarray]:
        """Inertial position (k, 3) m and velocity (k, 3) m/s at true anomalies ``true_anomaly`` (k,) rad."""
        nu = np.atleast_1d(np.asarray(true_anomaly, float))
        e, a, mu = self.eccentricity, self.semi_major_axis, self.planet.mu
        p = a * (1.0 - e * e)
        r = p / (1.0 + e * np.cos(nu))
        zero = np.zeros_like(nu)
        pos = np.stack([r * np.cos(nu), r * np.sin(nu), zero], axis=1)
        vel = math.sqrt(mu / p) * np.stack([-np.sin(nu), e + np.cos(nu), zero], axis=1)
        Q = self._perifocal()
        return pos @ Q.T, vel @ Q.T

    def time(self, true_anomaly) -> np.ndarray:
        """Time since perigee (k,) s at true anomalies (k,) rad in [0, 2π] (Kepler's equation M = E - e sin E)."""
        nu = np.asarray(true_anomaly, float)
        e = self.eccentricity
        E = 2.0 * np.arctan2(math.sqrt(1.0 - e) * np.sin(nu / 2), math.sqrt(1.0 + e) * np.cos(nu / 2))
        M = np.mod(E - e * np.sin(E), 2.0 * math.pi)
        M = np.where((nu >= 2.0 * math.pi - 1e-15) & (M < 1.0), M + 2.0 * math.pi, M)  # 2π itself: one period
        return M / (2.0 * math.pi) * self.period

    def lit_fraction(self, positions) -> np.ndarray:
        """Fraction (k,) of the solar disc seen from inertial ``positions`` (k, 3) m: cylindrical shadow 0 / 1;
        conical shadow with penumbra: 1 - (area of the solar disc hidden by the planet's disc) / (solar disc), the
        discs' angular radii and separation as seen from the spacecraft (Montenbruck & Gill, Satellite Orbits,
        §3.4.2)."""
        r = np.atleast_2d(np.asarray(positions, float))
        R = self.planet.radius
        if self.eclipse == "cylindrical":
            along = r @ self.sun
            across = np.linalg.norm(r - along[:, None] * self.sun, axis=1)
            return np.where((along < 0) & (across < R), 0.0, 1.0)
        a, b, c = self._discs(r)
        lit = np.ones(len(r))
        umbra = c <= b - a
        annular = c <= a - b
        partial = (c < a + b) & ~umbra & ~annular
        lit[umbra] = 0.0
        lit[annular] = 1.0 - (b[annular] / a[annular]) ** 2
        if partial.any():
            aa, bb, cc = a[partial], b[partial], c[partial]
            x = (cc * cc + aa * aa - bb * bb) / (2.0 * cc)
            y = np.sqrt(np.maximum(aa * aa - x * x, 0.0))
            hidden = (aa * aa * np.arccos(np.clip(x / aa, -1, 1)) + bb * bb * np.arccos(np.clip((cc - x) / bb, -1, 1))
                      - cc * y)
            lit[partial] = 1.0 - hidden / (math.pi * aa * aa)
        return np.clip(lit, 0.0, 1.0)

    def _discs(self, r: np.ndarray):
        """Angular radii of the Sun (k,) and of the planet (k,) and their separation (k,) (rad) seen from ``r``."""
        s = self.sun * (self.sun_distance * ASTRONOMICAL_UNIT)
        to_sun = s - r
        ds = np.linalg.norm(to_sun, axis=1)
        dr = np.linalg.norm(r, axis=1)
        a = np.arcsin(SUN_RADIUS / ds)
        b = np.arcsin(np.minimum(self.planet.radius / dr, 1.0))
        c = np.arccos(np.clip(-np.einsum("ij,ij->i", r, to_sun) / (dr * ds), -1.0, 1.0))
        return a, b, c

    def _shadow_functions(self):
        """(name, g(ν)) pairs whose sign changes mark the eclipse boundaries: g > 0 outside that shadow."""
        R = self.planet.radius
        if self.eclipse == "cylindrical":
            def cyl(nu):
                r = self.state(nu)[0]
                along = r @ self.sun
                across = np.linalg.norm(r - along[:, None] * self.sun, axis=1)
                return np.where(along < 0, across - R, np.linalg.norm(r, axis=1))  # > 0 on the day side
            return [("", cyl)]

        def cone(sign):
            def g(nu):
                a, b, c = self._discs(self.state(nu)[0])
                return c - (b + sign * a)
            return g
        return [("penumbra", cone(1.0)), ("umbra", cone(-1.0))]

    def eclipse_events(self) -> list[tuple[float, str]]:
        """Eclipse boundaries along one revolution: [(true anomaly rad in [0, 2π), event), ...] sorted by true
        anomaly; events "entry" / "exit" (cylindrical) or "penumbra_entry", "umbra_entry", "umbra_exit",
        "penumbra_exit" (conical).  Bracketed on a 2048-point grid of true anomaly (plus a bounded minimisation
        around the grid's minimum, so a grazing eclipse shorter than the grid step is not missed) and refined by
        Brent's method to 1e-12 rad."""
        grid = np.linspace(0.0, 2.0 * math.pi, _ECLIPSE_GRID + 1)
        out = []
        for name, g in self._shadow_functions():
            vals = g(grid)
            roots = []
            cross = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
            if cross.size == 0:
                k = int(np.argmin(vals))
                lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, _ECLIPSE_GRID)]
                f1 = lambda x: float(g(np.array([x]))[0])  # noqa: E731
                m = minimize_scalar(f1, bounds=(lo, hi), method="bounded", options={"xatol": 1e-10})
                if m.fun < 0:
                    roots = [(brentq(f1, lo, m.x, xtol=_XTOL), "entry"), (brentq(f1, m.x, hi, xtol=_XTOL), "exit")]
            else:
                for k in cross:
                    f1 = lambda x: float(g(np.array([x]))[0])  # noqa: E731
                    x = brentq(f1, grid[k], grid[k + 1], xtol=_XTOL)
                    roots.append((x, "entry" if vals[k] > 0 else "exit"))
            for x, kind in roots:
                out.append((float(np.mod(x, 2.0 * math.pi)), f"{name}_{kind}" if name else kind))
        return sorted(out)

    def positions(self) -> OrbitPositions:
        """The sampled true anomalies plus the eclipse boundaries, in time order (:class:`OrbitPositions`)."""
        nu = np.radians(self.true_anomalies)
        events = self.eclipse_events()
        rows = [(float(x), "", None) for x in nu]
        for x, kind in events:
            if self.eclipse == "cylindrical":
                first, second = (1.0, 0.0) if kind == "entry" else (0.0, 1.0)
                rows += [(x, kind, first), (x, kind, second)]
            else:
                rows.append((x, kind, None))
        order = sorted(range(len(rows)), key=lambda k: (rows[k][0], k))
        rows = [rows[k] for k in order]
        # a sampled position on an event (within the root tolerance) is the event itself
        keep = [k for k, (x, kind, _) in enumerate(rows)
                if kind or not any(abs(x - y) < 1e-9 and kk for y, kk, _ in rows)]
        rows = [rows[k] for k in keep]
        nus = np.array([r[0] for r in rows])
        pos, vel = self.state(nus)
        lit = self.lit_fraction(pos)
        forced = np.array([np.nan if r[2] is None else r[2] for r in rows])
        lit = np.where(np.isnan(forced), lit, forced)
        return OrbitPositions(
            true_anomaly=np.degrees(nus), time=self.time(nus), lit=lit, eclipse=lit < 1.0,
            event=np.array([r[1] for r in rows], dtype=object), position=pos, velocity=vel, sun=self.sun.copy(),
            solar_flux=self.solar_flux, period=self.period)


def _plane_axes(inc: float, raan: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit vectors (3,) of the orbital plane: towards the ascending node, 90° ahead of it in the plane, and the
    orbit normal, for inclination ``inc`` and RAAN ``raan`` (rad)."""
    node = np.array([math.cos(raan), math.sin(raan), 0.0])
    normal = np.array([math.sin(inc) * math.sin(raan), -math.sin(inc) * math.cos(raan), math.cos(inc)])
    return node, np.cross(normal, node), normal


# ------------------------------------------------------------------------------------------------------ attitude
_AXES = {"+x": (1, 0, 0), "x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "y": (0, 1, 0), "-y": (0, -1, 0),
         "+z": (0, 0, 1), "z": (0, 0, 1), "-z": (0, 0, -1)}


def mesh_axis(value, key: str = "axis", where: str = "[orbit.attitude]") -> np.ndarray:
    """A mesh direction from "+x", "-y", ... or a 3-vector, as a unit vector (3,)."""
    if isinstance(value, str):
        if value.lower() not in _AXES:
            raise Fem2TmmError(f"{where}.{key}: {value!r} is not an axis; use +x, -x, +y, -y, +z, -z or [x, y, z]")
        return np.array(_AXES[value.lower()], float)
    v = np.asarray(value, float)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v) > 0:
        raise Fem2TmmError(f"{where}.{key}: must be +x, -x, ... or a non-zero vector [x, y, z], got {value!r}")
    return v / np.linalg.norm(v)


def rotation_matrix(value, key: str = "rotation", where: str = "[orbit.attitude]") -> np.ndarray:
    """A fixed rotation (3, 3) from a 3x3 proper orthogonal matrix or a list of [axis, degrees] steps applied in
    order (e.g. [["z", 30], ["x", -10]]: 30° about z, then -10° about x, both about the fixed mesh axes)."""
    if value is None:
        return np.eye(3)
    a = np.asarray(value, dtype=object)
    try:
        M = np.asarray(value, float)
        if M.shape == (3, 3):
            if not (np.allclose(M @ M.T, np.eye(3), atol=1e-9) and np.linalg.det(M) > 0):
                raise Fem2TmmError(f"{where}.{key}: a 3x3 rotation must be orthogonal with determinant +1")
            return M
    except (TypeError, ValueError):
        pass
    if a.ndim != 2 or a.shape[1] != 2:
        raise Fem2TmmError(f"{where}.{key}: give a 3x3 rotation matrix or a list of [axis, degrees] pairs, "
                           f"got {value!r}")
    R = np.eye(3)
    for axis, deg in value:
        u = mesh_axis(axis, key, where)
        t = math.radians(float(deg))
        K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
        R = (np.eye(3) + math.sin(t) * K + (1 - math.cos(t)) * K @ K) @ R
    return R


@dataclass(frozen=True)
class Attitude:
    """Which mesh directions point where along the orbit.

    ``kind``:

    * "nadir": mesh direction ``primary`` (default -z) towards nadir, ``secondary`` (default +x) as close as
      possible to the velocity;
    * "sun": ``primary`` (default +z) towards the Sun, ``secondary`` (default +y) as close as possible to the orbit
      normal;
    * "inertial": the mesh's ``primary`` (default +x) and ``secondary`` (default +y) directions are the inertial
      vectors ``axes`` (2, 3) (the second orthogonalised against the first).

    ``rotation`` (3, 3): the mesh is mounted rotated by this fixed rotation in the frame the rules above define
    (a mesh vector x points along R_rule · rotation · x); default identity.  ``primary`` and ``secondary`` may be
    "+x", "-y", ... or vectors; ``secondary`` is orthogonalised against ``primary``.
    """

    kind: str = "nadir"
    primary: np.ndarray | None = None
    secondary: np.ndarray | None = None
    axes: np.ndarray | None = None
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))

    @classmethod
    def make(cls, kind="nadir", primary=None, secondary=None, axes=None, rotation=None,
             where: str = "[orbit.attitude]") -> "Attitude":
        """An attitude from user-facing values (see the class); raises :class:`Fem2TmmError` naming the key."""
        defaults = {"nadir": ("-z", "+x"), "sun": ("+z", "+y"), "inertial": ("+x", "+y")}
        if kind not in defaults:
            raise Fem2TmmError(f"{where}.kind: must be \"nadir\", \"sun\" or \"inertial\", got {kind!r}")
        p = mesh_axis(defaults[kind][0] if primary is None else primary, "primary", where)
        s = mesh_axis(defaults[kind][1] if secondary is None else secondary, "secondary", where)
        s = s - (s @ p) * p
        if np.linalg.norm(s) < 1e-9:
            raise Fem2TmmError(f"{where}.secondary: must not be parallel to primary")
        ax = None
        if kind == "inertial":
            if axes is None:
                raise Fem2TmmError(f"{where}.axes: an inertial attitude needs the inertial directions of the "
                                   f"primary and secondary mesh axes, axes = [[x, y, z], [x, y, z]]")
            ax = np.asarray(axes, float)
            if ax.shape != (2, 3) or not np.all(np.isfinite(ax)) or np.linalg.norm(np.cross(ax[0], ax[1])) < 1e-9:
                raise Fem2TmmError(f"{where}.axes: must be two non-parallel inertial vectors [[x, y, z], [x, y, z]]")
        elif axes is not None:
            raise Fem2TmmError(f"{where}.axes: only an inertial attitude takes axes")
        return cls(kind=kind, primary=p, secondary=s / np.linalg.norm(s), axes=ax,
                   rotation=rotation_matrix(rotation, "rotation", where))

    def matrices(self, orbit: Orbit, position: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """Rotations (k, 3, 3) from the mesh frame to the inertial frame at inertial ``position`` / ``velocity``
        (k, 3): inertial vector = M[k] @ mesh vector."""
        k = len(position)
        if self.kind == "nadir":
            t1 = -_unit(position)
            ref = velocity
        elif self.kind == "sun":
            t1 = np.broadcast_to(orbit.sun, (k, 3))
            ref = np.broadcast_to(orbit.normal, (k, 3))
        else:
            t1 = np.broadcast_to(_unit(self.axes[0]), (k, 3))
            ref = np.broadcast_to(self.axes[1], (k, 3))
        t2 = ref - np.einsum("ij,ij->i", ref, t1)[:, None] * t1
        n2 = np.linalg.norm(t2, axis=1)
        if np.any(n2 < 1e-9 * np.linalg.norm(ref, axis=1)):
            raise Fem2TmmError(f"attitude {self.kind!r}: the secondary reference is parallel to the primary "
                               f"direction at some position (e.g. a Sun-pointing attitude with the Sun along the "
                               f"orbit normal); choose another attitude")
        t2 = t2 / n2[:, None]
        T = np.stack([t1, t2, np.cross(t1, t2)], axis=2)  # columns: target directions
        A = np.stack([self.primary, self.secondary, np.cross(self.primary, self.secondary)], axis=1)
        return T @ A.T @ self.rotation
