"""Planet albedo and infrared heat fluxes by planet-focused Halton sampling (PFHS, thesis §2.4.2-2.4.3).

Thesis (``seeds/jacques-2016-reduced-fe-space-thermal.txt`` l. 1400-1560): the flux a face receives from a diffuse
planet is eq. 2.23 (albedo) / 2.24 (infrared), an integral over the part of the planet the face sees (inside the
spacecraft's horizon, above the face's plane, and, for albedo, on the sunlit side of the terminator).  PFHS traces
it like the solar flux: origins on the face, directions only towards the planet's visible cap, one 4-D scrambled
Halton point per ray coupling direction (2 coordinates) and origin (2), each ray carrying the energy of the planet
surface element it comes from.

The estimator, per emitting unit (a group of sides: one FE side, or a super face):

* origins are spread over the member sides that can see the planet (n · nadir > -sin θ_max) in proportion to their
  area A, by the group's cumulative area and the area-preserving triangle map (Halton coordinates 2-3);
* from an origin at distance ρ = h_r R from the planet centre the planet is a cap of half-angle θ_max,
  sin θ_max = 1/h_r.  Directions are uniform on the cap's projection onto the plane normal to nadir (eq. 2.38:
  sin θ_n = √ξ / h_r, φ = 2π ξ_φ; Halton coordinates 0-1, the best-distributed pair (bases 2 and 3): over a
  spacecraft the planet's radiance varies with direction far more than with position; measurements: docs/design-notes.md,
  radiation/planet.py), so their density is
  cos θ_n / (π sin² θ_max) per steradian;
* the ray meets the planet at x (exact ray-sphere root); the radiance there is L = a C max(x̂ · ŝ, 0) / π for
  albedo (terminator test: the night side sends nothing) or L = M / π for infrared (M the planet's exitance);
* a ray carries w = (A / n) L (n · d)⁺ π sin² θ_max / cos θ_n = (A / n) L π (n · d)⁺ / (h_r² cos θ_n): eq. 2.41
  / 2.42 with the thesis' factor f = 1 / (h_r² cos θ_n) written through θ_n instead of θ_z (the solid angle dω =
  cos θ_z dS / |r|² replaces the planet-surface element; same number, tested against eq. 2.43);
* a shadow ray towards the planet decides whether the spacecraft hides the origin; an unshadowed ray arrives on
  the side and is followed by the solar tracer's energy-splitting bounce loop (:func:`~.solar.arrivals`) in the
  solar band (albedo: absorptivity) or the infrared band (emissivity), so incident = absorbed + escaped + blocked +
  capped to round-off.

``focus="hemisphere"`` samples cosine-law directions over the side's whole hemisphere instead (the plain sampling
of REF tracing; rays missing the planet are wasted; each hit carries (A / n) π L): the baseline PFHS is measured
against.  Halton coordinates 4-6 drive the first reflection event and its diffuse direction, as for solar rays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _validation as check
from ..errors import Fem2TmmError
from ..orbit import EARTH, SOLAR_CONSTANT, Planet
from .sampling import HALTON_BASES, ScrambledHalton
from .solar import RayBalance, arrivals, gather, sun_unit, triangle_emitters
from .surfaces import SideOptics, Surface, TriangleScene, pack_ints, pad_faces, unpack_ints
from .tracer import BATCH, HALTON_SKIP, MAX_BOUNCES, SAMPLINGS, map_batches

#: Halton coordinates of a planet ray: origin (2), direction (2), first event (1), first diffuse direction (2)
PLANET_DIMS = 7
KINDS = ("albedo", "ir")


@dataclass(frozen=True, eq=False)
class PlanetResult(RayBalance):
    """Planet albedo or infrared power on the sides of a surface, and its energy balance (all powers in W).

    ``incident_side`` (2f,) power arriving directly from the planet on each side (unshadowed), ``incident_face``
    (f,) both sides summed, ``incident_group`` (g,); ``absorbed_side`` / ``absorbed_face`` / ``absorbed_group``
    after absorption, reflections and transmissions in the band of ``kind`` (albedo: solar band, ir: infrared).
    Totals: ``incident`` Σ incident_side, ``shadowed`` power hidden by the spacecraft itself, ``escaped`` left to
    space after reflections, ``blocked`` reaching inactive sides, ``capped`` left in rays stopped early;
    incident = absorbed + escaped + blocked + capped.  ``rays_group`` (g,) origins per group, ``rays`` in all,
    ``segments`` intersection queries (shadow rays included), ``kind``, ``focus``, ``sampling``, ``engine``.
    """

    incident_side: np.ndarray
    incident_face: np.ndarray
    incident_group: np.ndarray
    absorbed_side: np.ndarray
    absorbed_face: np.ndarray
    absorbed_group: np.ndarray
    rays_group: np.ndarray
    kind: str
    focus: str
    sampling: str
    engine: str

    @property
    def absorbed(self) -> float:
        """Total absorbed power (W)."""
        return float(self.absorbed_side.sum())


def check_position(position, planet: Planet, what: str = "position") -> np.ndarray:
    """``position`` (3,) m as a float array outside the planet; raises :class:`Fem2TmmError` otherwise."""
    r = np.asarray(position, dtype=float)
    if r.shape != (3,) or not np.all(np.isfinite(r)):
        raise Fem2TmmError(f"{what} must be a finite vector [x, y, z] (m) from the planet centre to the mesh origin, "
                           f"got {np.asarray(position).tolist()}")
    if not np.linalg.norm(r) > planet.radius:
        raise Fem2TmmError(f"{what} {r.tolist()} lies inside the planet (radius {planet.radius:g} m); positions are "
                           f"in m from the planet centre")
    return r


def _frame(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (r, 3) completing the unit vectors ``c`` (r, 3) to orthonormal frames (Duff et al. 2017)."""
    x, y, z = c[:, 0], c[:, 1], c[:, 2]
    sg = np.where(z >= 0.0, 1.0, -1.0)
    a = -1.0 / (sg + z)
    b = x * y * a
    e1 = np.stack([1.0 + sg * x * x * a, sg * b, -sg * x], axis=1)
    e2 = np.stack([b, sg + y * y * a, -y], axis=1)
    return e1, e2


def planet_rays(scene: TriangleScene, prim, sign, p, nrm, U, position, sun, kind: str, planet: Planet,
                solar_flux: float, focus: str = "planet"):
    """Directions towards the planet and relative ray energies for origins ``p`` (r, 3) m (mesh frame) on sides
    ``sign`` (r,) of primitives ``prim`` (r,) with front normals ``nrm`` (r, 3), from the unit-square samples
    ``U`` (r, 2) (ξ_θ, ξ_φ).  ``position`` (3,) m mesh origin from the planet centre, ``sun`` (3,) unit.

    Returns ``(d (r, 3) unit directions towards the planet, e (r,) W/m²)``: a ray from an origin of area share
    A / n carries (A / n) e; e = 0 for directions behind the side, rays missing the planet (hemisphere sampling)
    or meeting its night side (albedo)."""
    ro = position[None, :] + p
    rho = np.linalg.norm(ro, axis=1)
    R = planet.radius
    n_side = nrm * sign[:, None]
    if focus == "planet":
        c = -ro / rho[:, None]
        hr2 = (rho / R) ** 2
        sin_t = np.sqrt(U[:, 0] / hr2)
        cos_t = np.sqrt(np.maximum(1.0 - U[:, 0] / hr2, 0.0))
        phi = 2.0 * math.pi * U[:, 1]
        e1, e2 = _frame(c)
        d = cos_t[:, None] * c + (sin_t * np.cos(phi))[:, None] * e1 + (sin_t * np.sin(phi))[:, None] * e2
        factor = math.pi / (hr2 * cos_t)  # π sin² θ_max / cos θ_n: inverse of the direction density
    else:
        d = scene.scatter(prim, nrm, sign, U[:, 0], U[:, 1])
        factor = np.full(len(p), math.pi)  # inverse of the cosine-law density cos θ / π, times cos θ
    cos_face = np.einsum("ij,ij->i", n_side, d)
    b = np.einsum("ij,ij->i", ro, d)
    disc = b * b - (rho * rho - R * R)
    hits = (b < 0.0) & (disc >= 0.0) & (cos_face > 0.0)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    x = ro + t[:, None] * d
    if kind == "albedo":
        radiance = planet.albedo * solar_flux * np.maximum(x @ sun / R, 0.0) / math.pi
    else:
        radiance = np.full(len(p), planet.exitance / math.pi)
    if focus == "planet":
        e = radiance * factor * cos_face
    else:
        e = radiance * factor
    return d, np.where(hits, e, 0.0)


def _planet_emitters(scene, groups: np.ndarray, g: int, position: np.ndarray, planet, focus: str):
    """Emission tables of the sides that can see the planet: the normal within 90° + θ_max of nadir (seen from the
    mesh origin; the margin covers the mesh's extent); curved triangles are kept whole.  ``position`` (3,) m."""
    rho = float(np.linalg.norm(position))
    points = scene.surface.points
    reach = float(np.linalg.norm(points, axis=1).max()) if len(points) else 0.0
    nadir = -position / rho
    cos_n = scene.tri_normal @ nadir
    limit = -planet.radius / rho - (reach / (rho - planet.radius) + 1e-9 if focus == "planet" else 0.0)
    sees = np.stack([cos_n > limit, -cos_n > limit], axis=1) if focus == "planet" else np.ones((len(cos_n), 2), bool)
    sees[scene._curved_triangles()] = True
    return triangle_emitters(scene, groups, g, scene.tri_area[:, None] * sees)


class _PlanetBatches:
    """The batches of one planet (albedo or IR) run as a picklable callable (the scene rebuilds itself where it is
    unpickled, e.g. on a Dask worker): ``job(b)`` traces rays b·batch .. (b + 1)·batch - 1, its generator seeded
    from (seed, stream, 1, b) only, and returns its :func:`~.solar.arrivals` (the sides it touched)."""

    distributable = True  # map_batches may send it to Dask workers

    def __init__(self, scene, optics, em, per_ray, start, seed, stream, sampling, batch, position, sun, kind,
                 planet, flux, focus, min_weight, max_bounces, groups):
        """``groups`` (2f,) the group of each side that built ``em`` (:func:`_planet_emitters`): the job is pickled
        without its emitter and Halton tables, rebuilt where it is unpickled (a Dask worker) from the scene, the
        groups and the seed (the same arrays)."""
        self.scene, self.optics, self.em, self.per_ray, self.start = scene, optics, em, per_ray, start
        self.seed, self.stream, self.sampling, self.batch = seed, stream, sampling, batch
        self.position, self.sun, self.kind, self.planet = position, sun, kind, planet
        self.flux, self.focus = flux, focus
        self.min_weight, self.max_bounces, self.groups = min_weight, max_bounces, groups
        self.total = int(start[-1])
        self._sampling_tables()

    def _sampling_tables(self):
        setup = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=self.stream))
        self.halton = self.offsets = None
        if self.sampling == "halton":
            self.halton = ScrambledHalton(setup, bases=HALTON_BASES + (17,))
            self.offsets = setup.integers(0, HALTON_SKIP, size=len(self.per_ray))

    def __getstate__(self):
        return {**self.__dict__, "em": None, "halton": None, "offsets": None, "groups": pack_ints(self.groups)}

    def __setstate__(self, state):
        self.__dict__.update({**state, "groups": unpack_ints(state["groups"])})
        self._sampling_tables()

    def __call__(self, b: int):
        if self.em is None:  # unpickled: the emitter tables, built once (concurrent first batches build the same)
            self.em = _planet_emitters(self.scene, self.groups, len(self.per_ray), self.position, self.planet,
                                       self.focus)
        scene, em, start, halton, offsets = self.scene, self.em, self.start, self.halton, self.offsets
        batch = self.batch
        ray = np.arange(b * batch, min((b + 1) * batch, self.total), dtype=np.int64)
        grp = np.searchsorted(start, ray, side="right") - 1
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=self.stream + (1, b)))
        if halton is not None:
            U = halton.points(offsets[grp] + (ray - start[grp]))
        else:
            U = rng.random((ray.size, PLANET_DIMS))
        entry, u0 = em.locate(grp, U[:, 2])
        prim = em.entry_prim[entry]
        back = em.entry_side[entry]
        sign = 1.0 - 2.0 * back
        p, nrm, wr = scene.sample_weighted(prim, u0, U[:, 3])
        d, e = planet_rays(scene, prim, sign, p, nrm, U[:, :2], self.position, self.sun, self.kind, self.planet,
                           self.flux, self.focus)
        w0 = self.per_ray[grp] * e if wr is None else self.per_ray[grp] * e * wr
        lit = np.zeros(ray.size, bool)
        k = np.flatnonzero(w0 > 0.0)
        o = scene.offset(prim[k], p[k].copy(), sign[k], nrm[k])
        hit, _ = scene.intersect(o, np.ascontiguousarray(d[k]), prim[k])
        lit[k] = hit < 0
        side = 2 * scene.tri_face[prim] + back
        return arrivals(scene, self.optics, side[k], prim[k], p[k], nrm[k], -d[k], w0[k], lit[k], rng,
                        U[k, 4:] if halton is not None else None, self.min_weight, self.max_bounces, k.size)


def trace_planet(surface: Surface, position, sun_direction, kind: str = "albedo", planet: Planet | None = None,
                 groups=None, rays_per_group=None, ray_density: float | None = None, sampling: str = "halton",
                 focus: str = "planet", seed=0, solar_flux: float = SOLAR_CONSTANT, max_bounces: int = MAX_BOUNCES,
                 min_weight: float = 1e-12, scene: TriangleScene | None = None, batch: int = BATCH,
                 threads: int = 2) -> PlanetResult:
    """Planet albedo (``kind="albedo"``) or infrared (``kind="ir"``) power on every side of ``surface``.

    ``position`` (3,) m: the mesh origin relative to the planet centre, in the mesh frame; ``sun_direction`` (3,)
    towards the Sun in the mesh frame (normalised here; used by albedo); ``planet`` (default the Earth,
    :data:`~fem2tmm.orbit.EARTH`); ``solar_flux`` C (W/m²) lighting the planet (albedo).  ``groups``
    (2f,) int emitting unit of each side (-1: no origins there; it still shadows, reflects and absorbs); default
    every side its own group.  Budget per group: ``rays_per_group`` (int or (g,) ints, default 1000) or
    ``ray_density`` (rays per m² of the sides that see the planet).  ``sampling`` "halton" (one scrambled 7-D
    Halton point per ray: direction, origin, first event, first diffuse direction; a random start per group) or
    "random"; ``focus`` "planet" (PFHS: directions only towards the planet's cap) or "hemisphere" (cosine-law
    over the side's hemisphere).  ``seed`` int or tuple of
    ints.  ``scene``: the ray scene of ``surface`` (curved super faces pass their
    :class:`~fem2tmm.radiation.quadric.QuadricScene`).  Returns a :class:`PlanetResult`.
    """
    job, n_batches, finish = planet_job(surface, position, sun_direction, kind, planet, groups, rays_per_group,
                                        ray_density, sampling, focus, seed, solar_flux, max_bounces, min_weight,
                                        scene, batch)
    return finish(map_batches(job, n_batches, threads))


def planet_job(surface: Surface, position, sun_direction, kind: str = "albedo", planet: Planet | None = None,
               groups=None, rays_per_group=None, ray_density: float | None = None, sampling: str = "halton",
               focus: str = "planet", seed=0, solar_flux: float = SOLAR_CONSTANT, max_bounces: int = MAX_BOUNCES,
               min_weight: float = 1e-12, scene: TriangleScene | None = None, batch: int = BATCH,
               optics: SideOptics | None = None):
    """:func:`trace_planet` (same arguments) split into ``(job, n_batches, finish)``: the picklable batch job, its
    number of batches, and ``finish(parts)`` that turns the batch results (in batch order) into the
    :class:`PlanetResult` (see :func:`~.solar.solar_job`).  ``optics``: the :class:`SideOptics` of the band of
    ``kind`` when the caller already has it (shared by its jobs)."""
    if kind not in KINDS:
        raise Fem2TmmError(f"kind must be 'albedo' or 'ir', got {kind!r}")
    check.choice("sampling", sampling, SAMPLINGS)
    check.choice("focus", focus, ("planet", "hemisphere"))
    check.positive_int("max_bounces", max_bounces)
    flux = check.nonnegative("solar_flux", solar_flux, "power density (W/m²)")
    planet = EARTH if planet is None else planet
    position = check_position(position, planet)
    sun = sun_unit(sun_direction)
    f = surface.n_faces
    groups, g = check.side_groups(groups, f)
    scene = TriangleScene.of(surface, scene, "trace_planet")
    optics = surface.optics("solar" if kind == "albedo" else "ir") if optics is None else optics
    em = _planet_emitters(scene, groups, g, position, planet, focus)
    rays = check.ray_budget(rays_per_group, ray_density, em.area, em.weight > 0)
    per_ray = np.divide(em.weight, rays, out=np.zeros(g), where=rays > 0)  # m² of side per origin
    start = np.concatenate([[0], np.cumsum(rays)])
    total = int(start[-1])
    stream = (11, KINDS.index(kind))
    job = _PlanetBatches(scene, optics, em, per_ray, start, seed, stream, sampling, batch, position, sun,
                         kind, planet, flux, focus, min_weight, max_bounces, groups)

    def finish(parts) -> PlanetResult:
        absorbed, incident, totals, segments = gather(parts, 2 * f)
        mine = groups >= 0
        per_group = lambda x: np.bincount(groups[mine], weights=x[mine], minlength=g)  # noqa: E731
        return PlanetResult(
            incident_side=incident, incident_face=incident.reshape(f, 2).sum(axis=1),
            incident_group=per_group(incident), absorbed_side=absorbed,
            absorbed_face=absorbed.reshape(f, 2).sum(axis=1), absorbed_group=per_group(absorbed),
            rays_group=rays, incident=float(totals[0]), shadowed=float(totals[1]), escaped=float(totals[2]),
            blocked=float(totals[3]), capped=float(totals[4]), rays=total, segments=int(segments), kind=kind,
            focus=focus, sampling=sampling, engine=scene.engine.name,
        )

    return job, math.ceil(total / batch) if total else 0, finish


def planet_fluxes(points, faces, position, sun_direction, kind="albedo", planet=None, rays_per_face=1000, seed=0, *,
                  solar_flux=SOLAR_CONSTANT, ray_density=None, sampling="halton", focus="planet",
                  threads=2) -> np.ndarray:
    """Albedo or planet-infrared power incident on the front side of each face (DESIGN §4.5), W.

    ``points`` (n, 3) m, ``faces`` (m, 3) or (m, 4) int (front side = right-hand normal; a face receives planet
    radiation on its front side only, back sides stop rays).  ``position`` (3,) m: the spacecraft (mesh origin)
    relative to the planet centre, ``sun_direction`` (3,) towards the Sun, both in the mesh frame.  ``kind``
    "albedo" or "ir"; ``planet`` a :class:`~fem2tmm.orbit.Planet` (None: the Earth, radius 6 378.136 km,
    albedo 0.3, black body at 288 K); ``solar_flux`` lighting the planet (W/m², albedo).  ``rays_per_face``
    origins on each face that sees the planet (or ``ray_density`` rays per m²); ``sampling`` "halton" or
    "random"; ``focus`` "planet" (planet-focused sampling, thesis §2.4.3) or "hemisphere".  Shadowing by the
    other faces is included; the returned power is what arrives, before absorption (faces are black here).
    Returns q (m,) W.

    Parameters
    ----------
    points : (n, 3) float, m
    faces : (m, 3) or (m, 4) int
    position : (3,) float, m
        Spacecraft relative to the planet centre, mesh frame.
    sun_direction : (3,) float
        Towards the Sun, mesh frame.
    kind : {"albedo", "ir"}
    planet : Planet, optional
        None: the Earth.
    rays_per_face : int
    seed : int
    solar_flux : float, W/m²
    ray_density : float, optional
        Rays per m² instead of ``rays_per_face``.
    sampling : {"halton", "random"}
    focus : {"planet", "hemisphere"}
    threads : int

    Returns
    -------
    q : (m,) float, W
        Incident albedo or planet-IR power per face (front side).

    Raises
    ------
    Fem2TmmError
        Array of the wrong shape, unknown ``kind``, or a ``position`` inside the planet.
    """
    faces = pad_faces(faces)
    m = len(faces)
    surface = optics_surface(points, faces, 1.0, 1.0, 0.0, m)
    groups = np.stack([np.arange(m), np.full(m, -1)], axis=1).ravel()
    if ray_density is not None:
        rays_per_face = None
    res = trace_planet(surface, position, sun_direction, kind=kind, planet=planet, groups=groups,
                       rays_per_group=rays_per_face, ray_density=ray_density, sampling=sampling, focus=focus,
                       seed=seed, solar_flux=solar_flux, threads=threads)
    return res.incident_face


def optics_surface(points, faces, absorptivity, emissivity, specular, m: int) -> Surface:
    """A :class:`Surface` of front-active faces with per-face solar ``absorptivity``, IR ``emissivity`` and
    ``specular`` fraction (scalars or (m,)); back sides inactive (they stop rays)."""
    zero = np.zeros(m)
    front = lambda v, name: np.stack([check.per_face(name, v, m), zero], axis=1)  # noqa: E731
    return Surface(points, faces, emissivity=front(emissivity, "emissivity"),
                   absorptivity=front(absorptivity, "absorptivity"), specular=front(specular, "specular"),
                   active=np.stack([np.ones(m, bool), np.zeros(m, bool)], axis=1))
