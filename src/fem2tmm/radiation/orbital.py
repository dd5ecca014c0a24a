"""Orbital heat fluxes along an orbit: direct solar (parallel rays, off in eclipse, scaled by the lit fraction of
the solar disc in penumbra), planet albedo and planet infrared (planet-focused Halton sampling), with shadowing and
multiple reflections by the spacecraft itself (thesis §2.4).

One position at a time the Sun, the spacecraft's position and the nadir are expressed in the mesh frame through
the :class:`~fem2tmm.orbit.Attitude`, and the tracers of :mod:`~fem2tmm.radiation.solar` and
:mod:`~fem2tmm.radiation.planet` run on one ray scene.  Each distinct true anomaly is traced once: the two rows of
an eclipse boundary share their albedo and infrared, and their solar power is the lit one scaled by the lit
fraction (the solar tracer is linear in the flux).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import Fem2TmmError
from ..orbit import Attitude, Orbit, OrbitPositions
from .planet import optics_surface, planet_job
from .solar import solar_job
from .surfaces import Surface, TriangleScene, pad_faces
from .tracer import MAX_BOUNCES, map_jobs

KINDS = ("solar", "albedo", "ir")
#: traces (position x kind) whose batches run together in one map: enough units to keep the threads or Dask
#: workers busy, while bounding what lives at once (each trace's emission tables, ~ tens of bytes per triangle)
ORBIT_JOBS = 24


@dataclass(frozen=True, eq=False)
class OrbitalFluxes:
    """Heat fluxes at the k positions of an orbit on n emitting units (sides, faces or groups), all powers in W.

    ``positions`` the orbit's :class:`~fem2tmm.orbit.OrbitPositions` (true anomaly, time, lit fraction,
    eclipse flag, event); ``sun`` (k, 3) and ``nadir`` (k, 3) unit vectors in the mesh frame, ``position`` (k, 3)
    m the mesh origin from the planet centre in the mesh frame, ``attitude`` (k, 3, 3) mesh -> inertial rotations.
    ``incident[kind]`` (k, n) power arriving directly from the source (Sun, lit planet, planet IR) and
    ``absorbed[kind]`` (k, n) power absorbed after reflections and transmissions, for each kind of ``kinds``;
    ``lost[kind]`` (k,) power that left (escaped to space, blocked by inactive sides or capped):
    Σ incident = Σ absorbed + lost per position.  ``escaped[kind]`` (k,) the part that escaped to space.
    ``rays[kind]`` (k,) origins traced, ``segments`` intersection queries in all.
    """

    positions: OrbitPositions
    sun: np.ndarray
    nadir: np.ndarray
    position: np.ndarray
    attitude: np.ndarray
    kinds: tuple
    incident: dict
    absorbed: dict
    lost: dict
    escaped: dict
    rays: dict
    segments: int

    @property
    def true_anomaly(self) -> np.ndarray:
        return self.positions.true_anomaly

    @property
    def time(self) -> np.ndarray:
        return self.positions.time

    def total(self, what: str = "absorbed") -> np.ndarray:
        """(k, n) sum over the kinds of ``what`` ("absorbed" or "incident")."""
        table = getattr(self, what)
        return sum(table[k] for k in self.kinds)


def mesh_frame(orbit: Orbit, attitude: Attitude, positions: OrbitPositions):
    """``(sun (k, 3), nadir (k, 3), position (k, 3) m, rotations (k, 3, 3))`` in the mesh frame at the orbit's
    ``positions`` (rotations: mesh -> inertial)."""
    M = attitude.matrices(orbit, positions.position, positions.velocity)
    sun = np.einsum("kji,j->ki", M, orbit.sun)
    pos = np.einsum("kji,kj->ki", M, positions.position)
    nadir = -pos / np.linalg.norm(pos, axis=1, keepdims=True)
    return sun, nadir, pos, M


def check_kinds(kinds) -> tuple:
    kinds = (kinds,) if isinstance(kinds, str) else tuple(kinds)
    bad = [k for k in kinds if k not in KINDS]
    if bad or not kinds or len(set(kinds)) != len(kinds):
        raise Fem2TmmError(f"kinds must be distinct names among {', '.join(KINDS)}, got {list(kinds)}")
    return kinds


def trace_orbit(surface: Surface, orbit: Orbit, attitude: Attitude, kinds=KINDS, groups=None, rays_per_group=None,
                ray_density: float | None = None, sampling: str = "halton", seed: int = 0,
                max_bounces: int = MAX_BOUNCES, scene: TriangleScene | None = None, threads: int = 2,
                per: str = "side", solar_rays_per_group=None, focus: str = "planet") -> OrbitalFluxes:
    """Solar, albedo and planet-infrared powers on the sides of ``surface`` at every position of ``orbit``.

    ``groups`` (2f,) emitting unit of each side (-1: no origins there; default every side its own), as for
    :func:`~fem2tmm.radiation.solar.trace_solar`; ``rays_per_group`` / ``ray_density`` the planet rays' budget,
    ``solar_rays_per_group`` the solar one (default the same).  ``per`` "side" (n = 2f), "face" (n = f, both sides
    summed) or "group" (n = groups).  ``focus`` "planet" (PFHS) or "hemisphere" (plain sampling, for
    comparison).  Position j of the orbit traces with the seed entropy [``seed``..., j'] (j' the index of its
    distinct true anomaly; ``seed`` an int or a list of ints).  The batches of the traces (position x kind) run
    together, ``ORBIT_JOBS`` traces per :func:`~.tracer.map_jobs` call, so that many short traces spread over the
    ``threads`` or the Dask workers (results in batch order: the same numbers as one trace after the other).
    Returns :class:`OrbitalFluxes`.
    """
    kinds = check_kinds(kinds)
    if per not in ("side", "face", "group"):
        raise Fem2TmmError(f"per must be 'side', 'face' or 'group', got {per!r}")
    if scene is None:
        scene = TriangleScene(surface)
    positions = orbit.positions()
    sun, nadir, pos, M = mesh_frame(orbit, attitude, positions)
    f = surface.n_faces
    g = 2 * f if groups is None else int(np.max(groups)) + 1

    def pick(res, side_values):
        if per == "side":
            return side_values
        if per == "face":
            return side_values.reshape(f, 2).sum(axis=1)
        gr = np.arange(2 * f) if groups is None else np.asarray(groups)
        mine = gr >= 0
        return np.bincount(gr[mine], weights=side_values[mine], minlength=g)

    n = {"side": 2 * f, "face": f, "group": g}[per]
    k = len(positions)
    incident = {kind: np.zeros((k, n)) for kind in kinds}
    absorbed = {kind: np.zeros((k, n)) for kind in kinds}
    lost = {kind: np.zeros(k) for kind in kinds}
    escaped = {kind: np.zeros(k) for kind in kinds}
    rays = {kind: np.zeros(k, np.int64) for kind in kinds}
    segments = 0
    distinct, first = np.unique(positions.true_anomaly, return_index=True)
    base_seed = [int(x) for x in np.atleast_1d(seed)]  # an int or SeedSequence entropy [seed, k, ...]
    solar_budget = rays_per_group if solar_rays_per_group is None else solar_rays_per_group
    sunlight = surface.optics("solar")  # one copy per band, shared by the jobs (and sent to the workers once)
    band = {"solar": sunlight, "albedo": sunlight, "ir": surface.optics("ir")}
    traces = []  # (distinct position, kind): the traces of the orbit, run ORBIT_JOBS at a time
    for jd, j0 in enumerate(first):  # loop over the distinct positions of the orbit
        for kind in kinds:
            if kind == "solar" and (not (positions.lit[positions.true_anomaly == distinct[jd]] > 0).any()
                                    or orbit.solar_flux == 0):
                continue
            traces.append((jd, j0, kind))

    def job(jd, j0, kind):
        if kind == "solar":
            return solar_job(surface, sun[j0], orbit.solar_flux, groups=groups, rays_per_group=solar_budget,
                             ray_density=ray_density, sampling=sampling, seed=base_seed + [jd],
                             max_bounces=max_bounces, scene=scene, optics=band[kind])
        return planet_job(surface, pos[j0], sun[j0], kind=kind, planet=orbit.planet, groups=groups,
                          rays_per_group=rays_per_group, ray_density=ray_density, sampling=sampling,
                          seed=base_seed + [jd], solar_flux=orbit.solar_flux, max_bounces=max_bounces,
                          scene=scene, focus=focus, optics=band[kind])

    for c in range(0, len(traces), ORBIT_JOBS):  # loop over chunks of traces
        chunk = traces[c:c + ORBIT_JOBS]
        built = [job(*t) for t in chunk]
        parts = map_jobs([b[0] for b in built], [b[1] for b in built], threads,
                         what=f"orbit ray batches, traces {c + 1}-{c + len(chunk)} of {len(traces)}")
        for (jd, j0, kind), (_, _, finish), p in zip(chunk, built, parts):
            res = finish(p)
            rows = np.flatnonzero(positions.true_anomaly == distinct[jd])
            lit = positions.lit[rows] if kind == "solar" else np.ones(len(rows))
            scale = lit[:, None]
            incident[kind][rows] = scale * pick(res, res.incident_side)[None, :]
            absorbed[kind][rows] = scale * pick(res, res.absorbed_side)[None, :]
            lost[kind][rows] = lit * (res.escaped + res.blocked + res.capped)
            escaped[kind][rows] = lit * res.escaped
            rays[kind][rows] = res.rays
            segments += res.segments
    return OrbitalFluxes(positions=positions, sun=sun, nadir=nadir, position=pos, attitude=M, kinds=kinds,
                         incident=incident, absorbed=absorbed, lost=lost, escaped=escaped, rays=rays,
                         segments=segments)


def orbital_fluxes(points, faces, orbit: Orbit, attitude: Attitude, kinds=KINDS, absorptivity=0.2, emissivity=0.8,
                   rays_per_face=1000, seed=0, *, specular=0.0, ray_density=None, sampling="halton",
                   threads=2) -> OrbitalFluxes:
    """Solar, albedo and planet-infrared powers on the front side of each face along an orbit (DESIGN §4.5).

    ``points`` (n, 3) m, ``faces`` (m, 3) or (m, 4) int (front side = right-hand normal; front sides absorb and
    reflect, back sides stop rays).  ``orbit`` an :class:`~fem2tmm.orbit.Orbit` (``Orbit.make``),
    ``attitude`` an :class:`~fem2tmm.orbit.Attitude` (``Attitude.make``).  ``kinds`` any of "solar",
    "albedo", "ir".  ``absorptivity`` (solar band: direct solar and albedo), ``emissivity`` (infrared band: planet
    IR), ``specular`` fraction of the reflected energy: scalars or (m,).  ``rays_per_face`` origins per face and
    position (or ``ray_density`` rays per m²); ``sampling`` "halton" or "random"; ``seed``.

    Returns :class:`OrbitalFluxes` with ``incident[kind]`` and ``absorbed[kind]`` (k, m) W per position and face
    and the position table (``positions.true_anomaly`` deg, ``positions.time`` s, ``positions.eclipse``, ``sun``
    and ``nadir`` (k, 3) in the mesh frame).

    Parameters
    ----------
    points : (n, 3) float, m
    faces : (m, 3) or (m, 4) int
    orbit : Orbit
    attitude : Attitude
    kinds : sequence of {"solar", "albedo", "ir"}
    absorptivity, emissivity, specular : float or (m,) float
        Solar absorptivity, infrared emissivity, specular fraction of the reflected energy (dimensionless).
    rays_per_face : int
        Ray origins per face and orbit position.
    seed : int
    ray_density : float, optional
        Rays per m² instead of ``rays_per_face``.
    sampling : {"halton", "random"}
    threads : int

    Returns
    -------
    OrbitalFluxes
        ``incident[kind]``, ``absorbed[kind]`` (k, m) W for k orbit positions; ``positions`` table.

    Raises
    ------
    Fem2TmmError
        Array of the wrong shape, unknown kind, or optical property out of range.
    """
    faces = pad_faces(faces)
    m = len(faces)
    surface = optics_surface(points, faces, absorptivity, emissivity, specular, m)
    groups = np.stack([np.arange(m), np.full(m, -1)], axis=1).ravel()
    if ray_density is not None:
        rays_per_face = None
    return trace_orbit(surface, orbit, attitude, kinds=kinds, groups=groups, rays_per_group=rays_per_face,
                       ray_density=ray_density, sampling=sampling, seed=seed, threads=threads, per="group")


def _wrapped(times: np.ndarray, values: np.ndarray, period: float):
    """The table closed over one period: times (k + 1,) ending at times[0] + period, values (k + 1, ...)."""
    t = np.asarray(times, float)
    v = np.asarray(values, float)
    if t.ndim != 1 or len(t) == 0 or v.shape[0] != len(t) or np.any(np.diff(t) < 0):
        raise Fem2TmmError("orbit table: times must be a non-decreasing (k,) array with one row of values per time")
    if not (period > 0 and t[-1] - t[0] <= period):
        raise Fem2TmmError(f"orbit table: the times span {t[-1] - t[0]:g} s, more than the period {period:g} s")
    return np.append(t, t[0] + period), np.concatenate([v, v[:1]])


def period_average(times, values, period: float) -> np.ndarray:
    """Time average over one period of a periodic table: ``values`` (k, ...) at ``times`` (k,) s (non-decreasing,
    within one period; repeated times mark a jump) joined by straight lines, the last row back to the first one
    period later.  Exact for the piecewise-linear load the orbit transient interpolates."""
    t, v = _wrapped(times, values, period)
    dt = np.diff(t)
    mid = 0.5 * (v[1:] + v[:-1])
    return np.tensordot(dt, mid, axes=(0, 0)) / period


def period_integral(times, values, period: float, a: float, b: float) -> float:
    """∫_a^b of the periodic piecewise-linear table (``times`` (k,) s, ``values`` (k,), repeated times a jump; the
    table's time 0 at t = 0) for any a <= b (s): whole periods by the period average, the rest exactly, piece by
    piece in the table's own time (no breakpoint is shifted onto the wrong side of a jump)."""
    tt, v = _wrapped(times, values, period)
    area = np.concatenate([[0.0], np.cumsum(np.diff(tt) * 0.5 * (v[1:] + v[:-1]))])  # ∫ from tt[0] to tt[i]

    def cum(x: float) -> float:  # ∫ from tt[0] to tt[0] + x, 0 <= x <= period
        x = tt[0] + min(max(x, 0.0), period)
        i = int(np.clip(np.searchsorted(tt, x, side="right") - 1, 0, len(tt) - 2))
        dt = tt[i + 1] - tt[i]
        w = (x - tt[i]) / dt if dt > 0 else 0.0
        return float(area[i] + (x - tt[i]) * 0.5 * (v[i] + (1.0 - w) * v[i] + w * v[i + 1]))

    ma, ra = divmod(a - tt[0], period)
    mb, rb = divmod(b - tt[0], period)
    return float((mb - ma) * area[-1] + cum(rb) - cum(ra))


def periodic_values(times, values, period: float, t) -> np.ndarray:
    """Values (m, ...) of the periodic piecewise-linear table (``times`` (k,) s, ``values`` (k, ...)) at times ``t``
    (m,) s (any real times; wrapped into the period).  At a repeated time (a jump: an eclipse boundary) the value
    just after the jump is returned."""
    tt, v = _wrapped(times, values, period)
    x = tt[0] + np.mod(np.asarray(t, float) - tt[0], period)
    i = np.clip(np.searchsorted(tt, x, side="right") - 1, 0, len(tt) - 2)
    dt = tt[i + 1] - tt[i]
    w = np.divide(x - tt[i], dt, out=np.zeros_like(x), where=dt > 0)
    w = w.reshape(w.shape + (1,) * (v.ndim - 1))
    return (1.0 - w) * v[i] + w * v[i + 1]


def hat_basis(times, period: float, jump: float = 1e-6):
    """The periodic piecewise-linear interpolation of a position table as a basis of hat functions.

    ``times`` (k,) s non-decreasing in [0, period) (a repeated time is a jump: an eclipse boundary).  Returns
    ``(nodes (m,) s strictly increasing from 0 to period, H (m, k))``: the value at node i of any table ``V`` (k,
    ...) is ``H[i] @ V`` and values in between are linear, so ``H[:, j]`` sampled at ``nodes`` is the time function
    of position j.  The second row of a jump is moved ``jump`` x period later (the load then ramps over that
    time, ~6 ms for a 100-minute orbit); nodes at 0 and at the period close the table periodically (the segment
    from the last position to the first one a period later)."""
    t = np.array(times, float)
    k = len(t)
    _wrapped(t, np.zeros(k), period)  # validates
    for i in range(1, k):  # loop over the positions: separate repeated times
        if t[i] <= t[i - 1]:
            t[i] = t[i - 1] + jump * period
    if t[-1] >= period or (k > 1 and t[0] + period <= t[-1]):
        raise Fem2TmmError("orbit table: the positions' times do not fit in one period")
    eye = np.eye(k)
    gap = t[0] + period - t[-1]
    a = (period - t[-1]) / gap  # weight of the first position at time = period (and at 0)
    edge = (1.0 - a) * eye[-1] + a * eye[0]
    rows, nodes = [], []
    if t[0] > 0:
        nodes.append(0.0)
        rows.append(edge)
    nodes += list(t)
    rows += list(eye)
    nodes.append(period)
    rows.append(edge if t[0] > 0 else eye[0])
    return np.array(nodes), np.array(rows)


def average_weights(times, period: float) -> np.ndarray:
    """Weights (k,) with :func:`period_average` (times, V, period) = weights @ V for any table V (k, ...)."""
    k = len(times)
    return period_average(times, np.eye(k), period)
