"""Direct solar heat fluxes by parallel-ray tracing: shadow rays, absorption by energy splitting, reflections and
transmissions in the solar band.

Thesis (``seeds/jacques-2016-reduced-fe-space-thermal.txt``): §2.4.1 (l. 1350-1362) - shadow rays from each face
towards the Sun; an unshadowed origin receives S cos θ dA; the ray is then reverted and followed through the model
until its energy falls below a relative threshold.  §3.3.3: convergence of the absorbed fluxes on the EUI baffle,
Halton against crude Monte Carlo.  DESIGN §3.5 and §4.4 (``solar_fluxes``).

The estimator, per emitting unit (a group of sides: one FE side, or a super face):

* origins are spread over the member sides that face the Sun (n_side · s > 0) in proportion to their projected
  area A cos θ (one 1-D inverse-CDF step through the group's cumulative projected area, then the area-preserving
  triangle map, driven by one scrambled Halton point per ray), so every ray stands for the same beam cross-section
  and carries P_group / n_rays with P_group = S Σ A cos θ - the sampled power is exact;
* a shadow ray towards the Sun decides whether the origin is lit (any hit shadows it; a transmissive shadowing side
  passes its share on through its own interaction, so nothing is counted twice);
* a lit ray arrives along -s: the side absorbs the fraction α of the carried power deterministically, the rest is
  reflected / transmitted (specularly or diffusely, one uniform number in the proportions of the side's solar
  optics) and traced to the next hit, which absorbs α of what arrives, and so on.  A ray ends when it escapes to
  space, reaches an inactive side (the skin of an opaque volume: its power is *blocked*), falls below
  ``min_weight`` x its initial power or exceeds ``max_bounces`` segments (*capped*).

Deterministic absorption makes a lit side absorb exactly α S A cos θ whatever the number of rays, and the totals
balance exactly: incident = absorbed + escaped + blocked + capped.  Coordinates of the Halton point: 0-1 place the
origin, 2 picks the first reflection/transmission event, 3-4 drive its diffuse direction; later bounces use
pseudo-random numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from .. import _validation as check
from ..arrays import unique
from ..errors import Fem2TmmError
from .sampling import HALTON_BASES, ScrambledHalton
from .surfaces import (GroupEmitters, SideOptics, Surface, TriangleScene, TriangleWeights, pack_ints, pad_faces,
                       unpack_ints)
from .tracer import BATCH, HALTON_SKIP, MAX_BOUNCES, SAMPLINGS, map_batches

#: coordinates of the Halton point of a solar ray: origin (2), first event (1), first diffuse direction (2)
SOLAR_DIMS = 5


@dataclass(frozen=True, eq=False)
class RayBalance:
    """The energy balance of one tracing of an external source (W): ``incident`` lit power arriving on the sampled
    sides, ``shadowed`` hidden by the model itself, ``escaped`` left to space after reflections/transmissions,
    ``blocked`` reaching inactive sides, ``capped`` left in rays stopped early; incident = absorbed + escaped +
    blocked + capped.  ``rays`` origins traced, ``segments`` intersection queries (shadow rays included)."""

    incident: float
    shadowed: float
    escaped: float
    blocked: float
    capped: float
    rays: int
    segments: int


@dataclass(frozen=True, eq=False)
class SolarResult(RayBalance):
    """Absorbed solar power and the energy balance of one solar tracing (all powers in W).

    ``absorbed_side`` (2f,) per side (2i front, 2i+1 back), ``absorbed_face`` (f,) both sides summed,
    ``absorbed_group`` (g,) summed over the sides of each group.  ``power_group`` (g,) = S Σ A cos θ over the
    Sun-facing members of each group (the power the group would intercept without shadowing), ``rays_group`` (g,)
    origins traced per group.  Totals: ``incident`` lit (unshadowed) power intercepted by the sampled sides,
    ``shadowed`` the rest of Σ power_group, ``escaped`` left to space after reflections/transmissions,
    ``blocked`` power reaching inactive sides (directly or after reflections), ``capped`` power left in rays stopped
    by ``min_weight`` / ``max_bounces`` (or lost to an unresolvable self hit); incident = absorbed + escaped +
    blocked + capped.  ``rays`` origins traced, ``segments`` intersection queries (shadow rays included),
    ``sun_direction`` (3,) unit vector towards the Sun, ``solar_flux`` W/m², ``engine``, ``sampling``;
    ``incident_side`` (2f,) lit power arriving directly from the Sun on each side (before absorption).
    """

    absorbed_side: np.ndarray
    absorbed_face: np.ndarray
    absorbed_group: np.ndarray
    power_group: np.ndarray
    rays_group: np.ndarray
    sun_direction: np.ndarray
    solar_flux: float
    engine: str
    sampling: str
    incident_side: np.ndarray | None = None

    @property
    def absorbed(self) -> float:
        """Total absorbed power (W)."""
        return float(self.absorbed_side.sum())


def sun_unit(sun_direction) -> np.ndarray:
    """``sun_direction`` (3,) (from the model towards the Sun, any length > 0) as a unit vector; raises
    :class:`Fem2TmmError` on a wrong shape, a non-finite or a zero vector."""
    s = np.asarray(sun_direction, dtype=float)
    n = float(np.linalg.norm(s)) if s.shape == (3,) and np.all(np.isfinite(s)) else 0.0
    if n == 0.0:
        raise Fem2TmmError(
            f"sun_direction must be a finite non-zero vector [x, y, z] pointing from the model towards the Sun, "
            f"got {np.asarray(sun_direction).tolist()}"
        )
    return s / n


def sunlit_emitters(scene: TriangleScene, groups: np.ndarray, n_groups: int, sun: np.ndarray) -> GroupEmitters:
    """Emission tables of the Sun-facing member sides of each group, weighted by projected area A |cos θ|.

    ``groups`` (2f,) int group per side (-1: not sampled), ``sun`` (3,) unit.  Built by
    :meth:`GroupEmitters.build` on a view of the scene in which every triangle is its own "face" whose two sides
    weigh their projected areas facing the Sun (:meth:`TriangleScene.facing_areas`: A |n · s| on the side facing
    the Sun and 0 on the other for a flat triangle; both may be positive on a curved one).  ``weight`` = ``area``
    (g,) is the projected area (m²) of each group; ``entry_prim`` are triangle ids of ``scene``.
    """
    return triangle_emitters(scene, groups, n_groups, scene.facing_areas(sun))


def triangle_emitters(scene: TriangleScene, groups: np.ndarray, n_groups: int, weights: np.ndarray) -> GroupEmitters:
    """Emission tables of the sides of each group with sampling weights per triangle side: ``weights`` (t, 2) m²
    (front, back) of the triangles of ``scene`` (e.g. projected areas facing the Sun, or areas of the sides that
    see a planet); ``groups`` (2f,) int group per side (-1: not sampled).  ``weight`` = ``area`` (g,) is the sum of
    the weights of each group; ``entry_prim`` are triangle ids of ``scene``."""
    t = len(scene.tri_face)
    total = weights.sum(axis=1)
    view = TriangleWeights(tri_face=np.arange(t), tri_area=total)
    sid = 2 * np.repeat(scene.tri_face, 2) + np.tile([0, 1], t)  # side of the real face, per (triangle, side)
    share = np.divide(weights, total[:, None], out=np.zeros_like(weights), where=total[:, None] > 0).ravel()
    em = GroupEmitters.build(view, groups[sid], share, n_groups)
    return replace(em, area=em.weight)


def sun_origins(scene: TriangleScene, emitters: GroupEmitters, group: np.ndarray, U: np.ndarray, sun: np.ndarray):
    """Origins of solar rays of groups ``group`` (r,) from unit-square samples ``U`` (r, >= 2) (``emitters`` from
    :func:`sunlit_emitters`), and their shadow test towards ``sun`` (3,) unit.

    Returns ``(prim (r,) triangle, side (r,) Sun-facing side index, points (r, 3) on the surface, front normals
    (r, 3), shadow-ray origins (r, 3) offset off the Sun-facing side, lit (r,) bool)``.
    """
    return _sun_origins(scene, emitters, group, U, sun)[:6]


def _sun_origins(scene: TriangleScene, emitters: GroupEmitters, group: np.ndarray, U: np.ndarray, sun: np.ndarray):
    """:func:`sun_origins` plus the relative power of each ray (r,) (None: uniform; see
    :meth:`TriangleScene.sample_facing`)."""
    entry, u0 = emitters.locate(group, U[:, 0])
    prim = emitters.entry_prim[entry]
    back = emitters.entry_side[entry]
    sign = 1.0 - 2.0 * back
    p, nrm, w = scene.sample_facing(prim, sign, u0, U[:, 1], sun)
    o = scene.offset(prim, p.copy(), sign)
    hit, _ = scene.intersect(o, np.broadcast_to(sun, o.shape), prim)
    return prim, 2 * scene.tri_face[prim] + back, p, nrm, o, hit < 0, w


def _follow(scene: TriangleScene, optics: SideOptics, side, prim, p, nrm, d, w, floor, rng, qmc, max_bounces):
    """Energy-splitting bounce loop for rays that have just arrived, along ``d`` (r, 3), at points ``p`` (r, 3) of
    primitives ``prim`` (r,) on the *active* sides ``side`` (r,) (front normals ``nrm`` (r, 3)), carrying ``w``
    (r,) W; ``floor`` (r,) W is the capping threshold.  ``qmc`` (r, 3) or None: quasi-random numbers for the first
    event and its diffuse direction.

    Returns ``(sides (k,), powers (k,) absorbed, escaped, blocked, capped, segments)``.
    """
    absorb, cum, active = optics.absorb, optics.cum, optics.active
    got_s, got_w = [], []
    escaped = blocked = capped = 0.0
    segments = 0
    for bounce in range(max_bounces + 1):
        if side.size == 0:  # nothing (left) to follow
            break
        a = absorb[side]
        taken = a * w
        got_s.append(side)
        got_w.append(taken)
        w = w - taken
        go = (w > 0.0) & (w >= floor)
        if bounce == max_bounces:
            go[:] = False
        if not go.all():
            capped += float(w[~go].sum())
            k = np.flatnonzero(go)
            if k.size == 0:
                break
            side, prim, p, nrm, d, w, floor, a = side[k], prim[k], p[k], nrm[k], d[k], w[k], floor[k], a[k]
            qmc = None if qmc is None else qmc[k]
        # event among the non-absorbed fraction: x uniform on [α, 1) against the side's cumulative solar optics
        u = qmc[:, 0] if qmc is not None else rng.random(side.size)
        x = a + u * (1.0 - a)
        c = cum[side]
        mirror = x < c[:, 1]
        through = (x >= c[:, 1]) & (x < c[:, 3])
        lambert = x >= c[:, 2]
        dn = np.einsum("ij,ij->i", d, nrm)
        # leaving side: the arrival side (normal -sign(d.n) n), the opposite one after a transmission
        out_sign = np.where((dn < 0.0) ^ through, 1.0, -1.0)
        d = d - (2.0 * dn * mirror)[:, None] * nrm
        if lambert.any():
            j = np.flatnonzero(lambert)
            uv = qmc[j, 1:3] if qmc is not None else rng.random((j.size, 2))
            d[j] = scene.scatter(prim[j], nrm[j], out_sign[j], uv[:, 0], uv[:, 1])
        o = scene.offset(prim, p, out_sign)
        hit, t = scene.intersect(o, d, prim)
        segments += side.size
        qmc = None
        miss = hit < 0
        if miss.any():
            escaped += float(w[miss & (t > 0)].sum())
            capped += float(w[miss & ~(t > 0)].sum())  # t = -1: ray lost to an unresolvable self hit
            k = np.flatnonzero(~miss)
            if k.size == 0:
                break
            hit, t, o, d, w, floor = hit[k], t[k], o[k], d[k], w[k], floor[k]
        face, p, nrm = scene.hit_geometry(hit, o, d, t)
        side = 2 * face + (np.einsum("ij,ij->i", d, nrm) > 0.0)
        prim = hit
        dead = ~active[side]
        if dead.any():
            blocked += float(w[dead].sum())
            k = np.flatnonzero(~dead)
            if k.size == 0:
                break
            side, prim, p, nrm, d, w, floor = side[k], prim[k], p[k], nrm[k], d[k], w[k], floor[k]
    empty = np.zeros(0)
    sides = np.concatenate(got_s) if got_s else empty.astype(np.int64)
    powers = np.concatenate(got_w) if got_w else empty
    return sides, powers, escaped, blocked, capped, segments


class Arrivals(NamedTuple):
    """What one batch of source rays delivered (:func:`arrivals`), as sparse vectors over the 2f sides: the sides it
    touched and their powers, so a batch result scales with its rays, not with the model (it is what a Dask worker
    sends back).  ``absorbed`` = ``(sides (k,) int32 or int64 sorted distinct, powers (k,) W)``, ``incident`` the
    same for the lit arrivals, ``totals`` (5,) = (incident, shadowed, escaped, blocked, capped) W, ``segments``
    intersection queries.  :func:`gather` sums the batches."""

    absorbed: tuple
    incident: tuple
    totals: np.ndarray
    segments: int


def side_sums(index: np.ndarray, weights: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The non-empty bins of ``np.bincount(index, weights, minlength=n)`` as ``(bins (k,) sorted distinct, int32
    when n < 2**31 else int64, sums (k,))``, bit-for-bit the dense values (each bin sums its weights in array order,
    as bincount does), in O(r log r) for r = len(index) whatever n.  ``index`` (r,) ints in [0, n), ``weights``
    (r,) float."""
    bins, inverse = unique(index, return_inverse=True)
    sums = np.bincount(inverse.ravel(), weights=weights, minlength=bins.size)
    return bins.astype(np.int32 if n < 2**31 else np.int64), sums


class _SolarBatches:
    """The batches of one solar run as a picklable callable (the scene rebuilds itself where it is unpickled):
    ``job(b)`` traces rays b·batch .. (b + 1)·batch - 1, its generator seeded from (seed, 7, 1, b) only, and returns
    its :func:`arrivals`."""

    distributable = True  # map_batches may send it to Dask workers

    def __init__(self, scene, optics, em, rays, per_ray, sun, sampling, seed, batch, min_weight, max_bounces,
                 groups=None):
        """``groups`` (2f,) the group of each side that built ``em`` (:func:`sunlit_emitters`): given, the job is
        pickled without its emitter tables and its Halton tables, which are rebuilt where it is unpickled (a Dask
        worker) from the scene, ``groups`` and the seed: the same arrays, a third of the bytes."""
        self.scene, self.optics, self.em, self.per_ray, self.sun = scene, optics, em, per_ray, sun
        self.seed, self.batch, self.min_weight, self.max_bounces = seed, batch, min_weight, max_bounces
        self.sampling, self.groups = sampling, groups
        self.start = np.concatenate([[0], np.cumsum(rays)])
        self.total = int(self.start[-1])
        self._sampling_tables()

    def _sampling_tables(self):
        setup = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(7,)))
        self.halton = self.offsets = None
        if self.sampling == "halton":
            self.halton = ScrambledHalton(setup, bases=HALTON_BASES[:SOLAR_DIMS])
            self.offsets = setup.integers(0, HALTON_SKIP, size=len(self.start) - 1)

    def __getstate__(self):
        state = {**self.__dict__, "halton": None, "offsets": None}
        if self.groups is not None:
            state.update(em=None, groups=pack_ints(self.groups))
        return state

    def __setstate__(self, state):
        self.__dict__.update({**state, "groups": unpack_ints(state["groups"])})
        self._sampling_tables()

    def __call__(self, b: int):
        if self.em is None:  # unpickled: the emitter tables, built once (concurrent first batches build the same)
            self.em = sunlit_emitters(self.scene, self.groups, len(self.per_ray), self.sun)
        scene, start, halton, batch = self.scene, self.start, self.halton, self.batch
        ray = np.arange(b * batch, min((b + 1) * batch, self.total), dtype=np.int64)
        grp = np.searchsorted(start, ray, side="right") - 1
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(7, 1, b)))
        if halton is not None:
            U = halton.points(self.offsets[grp] + (ray - start[grp]))
        else:
            U = rng.random((ray.size, SOLAR_DIMS))
        prim, side, p, nrm, _, lit, wr = _sun_origins(scene, self.em, grp, U, self.sun)
        w0 = self.per_ray[grp] if wr is None else self.per_ray[grp] * wr
        return arrivals(scene, self.optics, side, prim, p, nrm, np.broadcast_to(-self.sun, (ray.size, 3)), w0, lit,
                        rng, U[:, 2:] if halton is not None else None, self.min_weight, self.max_bounces, ray.size)


def trace_solar(surface: Surface, sun_direction, solar_flux: float, groups=None, rays_per_group=None,
                ray_density: float | None = None, sampling: str = "halton", seed: int = 0,
                max_bounces: int = MAX_BOUNCES, min_weight: float = 1e-12, scene: TriangleScene | None = None,
                batch: int = BATCH, threads: int = 2) -> SolarResult:
    """Absorbed solar power on every side of ``surface`` lit by parallel rays (thesis §2.4.1).

    ``sun_direction`` (3,) from the model towards the Sun (normalised here), ``solar_flux`` S in W/m².
    ``groups`` (2f,) int emitting unit of each side (-1: no origins on that side, it still reflects, absorbs and
    shadows); default every side its own group.  A group's origins are spread over its Sun-facing sides in
    proportion to A cos θ and each carries S Σ A cos θ / n_rays.  Sun-facing *inactive* sides may be sampled: their
    lit power is reported as ``blocked``.  Ray budget per group: ``rays_per_group`` (int or (g,) ints; default
    1000) or ``ray_density`` (rays per m² of area projected onto a plane normal to the Sun: each ray then carries
    about S / ray_density W).  ``sampling`` "halton" (one scrambled 5-D Halton point per ray, a random start per
    group) or "random" (crude Monte Carlo).  ``max_bounces`` segments after the origin, ``min_weight`` relative
    power below which a ray is capped.  ``scene``: the ray scene of ``surface`` (default
    ``TriangleScene(surface)``; curved super faces pass a subclass, e.g. a
    :class:`~fem2tmm.radiation.quadric.QuadricScene`, whose origins lie on the true surface and whose rays may carry
    unequal powers, :meth:`TriangleScene.sample_facing`); every geometric query goes through it.
    ``batch`` rays per batch, ``threads`` batches in parallel; the result depends only on the inputs, ``seed`` and
    ``batch``.  Returns a :class:`SolarResult`.
    """
    job, n_batches, finish = solar_job(surface, sun_direction, solar_flux, groups, rays_per_group, ray_density,
                                       sampling, seed, max_bounces, min_weight, scene, batch)
    return finish(map_batches(job, n_batches, threads))


def solar_job(surface: Surface, sun_direction, solar_flux: float, groups=None, rays_per_group=None,
              ray_density: float | None = None, sampling: str = "halton", seed: int = 0,
              max_bounces: int = MAX_BOUNCES, min_weight: float = 1e-12, scene: TriangleScene | None = None,
              batch: int = BATCH, optics: SideOptics | None = None):
    """:func:`trace_solar` (same arguments) split into ``(job, n_batches, finish)``: the picklable batch job,
    its number of batches, and ``finish(parts)`` that turns the batch results (in batch order) into the
    :class:`SolarResult`; for callers that run the batches of several traces together
    (:func:`~.tracer.map_jobs`).  ``optics``: the solar :class:`SideOptics` of ``surface`` when the caller already
    has it (shared by its jobs instead of one copy each)."""
    check.choice("sampling", sampling, SAMPLINGS)
    check.positive_int("max_bounces", max_bounces)
    if not 0.0 <= float(min_weight) < 1.0:
        raise Fem2TmmError(f"min_weight must lie in [0, 1), got {min_weight}")
    flux = check.nonnegative("solar_flux", solar_flux, "power density (W/m²)")
    sun = sun_unit(sun_direction)
    f = surface.n_faces
    groups, g = check.side_groups(groups, f)
    scene = TriangleScene.of(surface, scene, "trace_solar")
    optics = surface.optics("solar") if optics is None else optics
    em = sunlit_emitters(scene, groups, g, sun)
    rays = check.ray_budget(rays_per_group, ray_density, em.area, em.weight > 0)
    power = flux * em.weight
    per_ray = np.divide(power, rays, out=np.zeros(g), where=rays > 0)
    job = _SolarBatches(scene, optics, em, rays, per_ray, sun, sampling, seed, batch, min_weight, max_bounces,
                        groups=groups)
    total = job.total

    def finish(parts) -> SolarResult:
        absorbed, incident, totals, segments = gather(parts, 2 * f)
        mine = groups >= 0
        return SolarResult(
            absorbed_side=absorbed, absorbed_face=absorbed.reshape(f, 2).sum(axis=1),
            absorbed_group=np.bincount(groups[mine], weights=absorbed[mine], minlength=g), power_group=power,
            rays_group=rays, incident=float(totals[0]), shadowed=float(totals[1]), escaped=float(totals[2]),
            blocked=float(totals[3]), capped=float(totals[4]), rays=total, segments=int(segments),
            sun_direction=sun, solar_flux=flux, engine=scene.engine.name, sampling=sampling, incident_side=incident,
        )

    return job, math.ceil(total / batch) if total else 0, finish


def arrivals(scene: TriangleScene, optics: SideOptics, side, prim, p, nrm, travel, w0, lit, rng, qmc,
             min_weight: float, max_bounces: int, queries: int) -> Arrivals:
    """Energy bookkeeping of one batch of source rays (parallel sunlight, planet albedo or infrared) arriving at
    points ``p`` (r, 3) of primitives ``prim`` (r,) on sides ``side`` (r,) (front normals ``nrm`` (r, 3)), travelling
    along ``travel`` (r, 3) unit, carrying ``w0`` (r,) W; ``lit`` (r,) False where the shadow ray towards the source
    hit the model.  Lit rays on active sides are followed by :func:`_follow` (absorbed fraction per hit, the rest
    reflected / transmitted in the band of ``optics``); lit rays on inactive sides are blocked.  ``qmc`` (r, 3) or
    None: quasi-random numbers of the first event and its diffuse direction.  ``queries`` intersection queries
    already made for the batch (shadow rays).

    Returns :class:`Arrivals`; incident = absorbed + escaped + blocked + capped."""
    n_sides = len(optics.active)
    incident_side = side_sums(side[lit], w0[lit], n_sides)
    shadowed = float(w0[~lit].sum())
    incident = float(w0[lit].sum())
    live = lit & optics.active[side]
    blocked = float(w0[lit & ~live].sum())
    k = np.flatnonzero(live)
    out = _follow(scene, optics, side[k], prim[k], p[k], nrm[k], np.array(travel[k], dtype=float), w0[k],
                  min_weight * w0[k], rng, None if qmc is None else qmc[k], max_bounces)
    sides, powers, escaped, blocked2, capped, segs = out
    absorbed = side_sums(sides, powers, n_sides)
    return Arrivals(absorbed, incident_side, np.array([incident, shadowed, escaped, blocked + blocked2, capped]),
                    segs + queries)


def gather(parts: list[Arrivals], n_sides: int):
    """Sum the :func:`arrivals` of the batches, in batch order (deterministic sums): ``(absorbed (2f,), incident
    (2f,), totals (5,), segments)``.  Each batch adds its touched sides into the dense totals (its sides are
    distinct), so every side's sum runs over the batches in order: the same floats as adding dense per-batch
    arrays."""
    absorbed, incident, totals = np.zeros(n_sides), np.zeros(n_sides), np.zeros(5)
    segments = 0
    for part in parts:  # loop over batches
        absorbed[part.absorbed[0]] += part.absorbed[1]
        incident[part.incident[0]] += part.incident[1]
        totals += part.totals
        segments += part.segments
    return absorbed, incident, totals, segments


def solar_fluxes(points, faces, sun_direction, solar_flux, absorptivity=0.2, specular=0.0, rays_per_face=1000,
                 seed=0, *, transmissivity=0.0, ray_density=None, sampling="halton", max_bounces=MAX_BOUNCES,
                 threads=2) -> np.ndarray:
    """Absorbed solar power per face (DESIGN §4.4), shadowing and multiple reflections included.

    ``points`` (n, 3) m, ``faces`` (m, 3) or (m, 4) int (front side = right-hand normal; front sides absorb,
    reflect and transmit, back sides are inactive: they stop rays and absorb nothing).  ``sun_direction`` (3,) from
    the model towards the Sun, ``solar_flux`` W/m².  ``absorptivity`` (solar α), ``specular`` (specular fraction of
    the reflected energy), ``transmissivity`` (solar, specular): scalars or (m,) arrays.  ``rays_per_face`` origins
    on each lit front side, or ``ray_density`` rays per m² of area projected normal to the Sun.  ``sampling``
    "halton" or "random".  Returns q (m,) W.

    Parameters
    ----------
    points : (n, 3) float, m
    faces : (m, 3) or (m, 4) int
    sun_direction : (3,) float
        Towards the Sun (normalised here).
    solar_flux : float, W/m²
    absorptivity, specular, transmissivity : float or (m,) float
        Solar absorptivity, specular fraction of the reflected energy, solar transmissivity (dimensionless).
    rays_per_face : int
        Ray origins per lit front side.
    seed : int
    ray_density : float, optional
        Rays per m² of area projected normal to the Sun, instead of ``rays_per_face``.
    sampling : {"halton", "random"}
    max_bounces : int
    threads : int

    Returns
    -------
    q : (m,) float, W
        Absorbed solar power per face.

    Raises
    ------
    Fem2TmmError
        Array of the wrong shape or optical property out of range.
    """
    faces = pad_faces(faces)
    m = len(faces)
    zero = np.zeros(m)
    front = lambda v, name: np.stack([check.per_face(name, v, m), zero], axis=1)  # noqa: E731
    surface = Surface(points, faces, emissivity=0.0, absorptivity=front(absorptivity, "absorptivity"),
                      specular=front(specular, "specular"),
                      solar_transmissivity=front(transmissivity, "transmissivity"),
                      active=np.stack([np.ones(m, bool), np.zeros(m, bool)], axis=1))
    groups = np.stack([np.arange(m), np.full(m, -1)], axis=1).ravel()
    if ray_density is not None:
        rays_per_face = None
    res = trace_solar(surface, sun_direction, solar_flux, groups=groups, rays_per_group=rays_per_face,
                      ray_density=ray_density, sampling=sampling, seed=seed, max_bounces=max_bounces,
                      threads=threads)
    return res.absorbed_face
