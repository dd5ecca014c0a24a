"""Radiating surfaces: two-sided FE faces with per-side optics, their triangulation, the ray scene and the
emission tables of super faces (groups of sides).

Conventions (DESIGN §3.5, thesis §1.3 and §3.1):

* ``faces`` (f, 4) int node indices, padded with -1 for triangles.  Side ``2 i`` is the *front* of face i (the
  side its right-hand normal points to), side ``2 i + 1`` its *back*.  Every per-side array has length 2f.
* A quad is split into the triangles (0, 1, 2) and (0, 2, 3); each triangle keeps the face's sides.
* IR: absorptance = emittance ``emissivity``; reflectance = 1 - ε - τ.  Solar: ``absorptivity`` and
  ``solar_transmissivity`` (= ``transmissivity`` unless given).  ``specular`` is the specular fraction of the
  *reflected* energy, ``transmission_specular`` the specular fraction of the *transmitted* energy.
* An inactive side emits nothing and stops every ray that reaches it (the skin of an opaque volume).

Extension points for later issues: :class:`TriangleScene` is the only object the bounce loop talks to for geometry
(``intersect``, ``hit_geometry``, ``sample``); quadric super faces subclass it to replace intersections, hit
normals and emission points of their members.  Parallel-ray sources build their own origins and call the bounce
loop directly.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from ..errors import Fem2TmmError, format_ids
from .engine import MISS, make_engine
from ._tracer_kernels import (cosine_directions, emit_groups, emit_rays, locate_entries, offset_points,
                      sample_points)

FRONT, BACK = 0, 1
#: retries with a 4x larger offset when a ray hits the triangle it leaves (float32 round-off)
SELF_HIT_RETRIES = 4
#: relative size (to the scene's bounding-box diagonal) of the offset of ray origins off their surface
ORIGIN_OFFSET = 2e-6


def _per_side(value, n_faces: int, name: str, dtype=float) -> np.ndarray:
    """Broadcast a scalar, (f,), (f, 2) or (2f,) per-side property to a (2f,) array (side 2i front, 2i+1 back)."""
    a = np.asarray(value, dtype=dtype)
    if a.ndim == 0:
        return np.full(2 * n_faces, a, dtype=dtype)
    if a.shape == (n_faces, 2):
        return a.reshape(-1).copy()
    if a.shape == (2 * n_faces,):
        return a.copy()
    if a.shape == (n_faces,):
        return np.repeat(a, 2)
    raise Fem2TmmError(
        f"optical property {name!r} has shape {a.shape}; give a scalar, one value per face ({n_faces},), "
        f"one per face and side ({n_faces}, 2) or one per side ({2 * n_faces},)"
    )


def _side_label(sides: np.ndarray) -> str:
    names = ["front", "back"]
    return ", ".join(f"{s // 2} ({names[s % 2]})" for s in sides[:10]) + (
        f", … ({len(sides)} in all)" if len(sides) > 10 else ""
    )


def pad_faces(faces) -> np.ndarray:
    """Faces as an (f, 4) int64 array padded with -1 for triangles; accepts (f, 3) or (f, 4) input."""
    f = np.asarray(faces)
    if f.ndim != 2 or f.shape[1] not in (3, 4):
        raise Fem2TmmError(f"faces must be an (m, 3) or (m, 4) array of node indices, got shape {f.shape}")
    f = f.astype(np.int64)
    if f.shape[1] == 3:
        f = np.concatenate([f, np.full((len(f), 1), -1, np.int64)], axis=1)
    return f


@dataclass(frozen=True)
class Triangles:
    """Triangulation of the faces: ``vertices`` (t, 3, 3) m, ``face`` (t,) owning face, ``normal`` (t, 3) unit
    right-hand normal (front side), ``area`` (t,) m²."""

    vertices: np.ndarray
    face: np.ndarray
    normal: np.ndarray
    area: np.ndarray


@dataclass(frozen=True, eq=False)
class SideOptics:
    """Per-side optics of one band, ready for the bounce loop.

    ``cum`` (2f, 4): cumulative probabilities of (absorbed, specularly reflected, specularly transmitted,
    diffusely transmitted); the remainder up to 1 is diffuse reflection (thesis l. 664).  ``active`` (2f,) bool.
    ``absorb`` (2f,) is the absorptance of the band (ε for IR, α for solar).
    """

    absorb: np.ndarray
    cum: np.ndarray
    active: np.ndarray

    def __getstate__(self):  # pickled without the cached tables (rebuilt on first use where unpickled)
        return {k: v for k, v in self.__dict__.items() if k in ("absorb", "cum", "active")}

    @cached_property
    def rows(self) -> np.ndarray:
        """(2f, 4) per side, as the compiled bounce reads it: stop probability (the absorptance, or 2 on an inactive
        side, which stops every ray), then the cumulative probabilities of specular reflection, specular
        transmission and diffuse transmission (``cum[:, 1:4]``)."""
        out = np.empty((len(self.active), 4))
        out[:, 0] = np.where(self.active, self.cum[:, 0], 2.0)
        out[:, 1:4] = self.cum[:, 1:4]
        return out

    @cached_property
    def scatters_diffusely(self) -> bool:
        """True when some active side reflects or transmits part of what it does not absorb diffusely (the
        tracer's Halton points then carry the two coordinates of a first diffuse direction)."""
        return bool(np.any(self.active & (self.cum[:, 2] < 1.0)))


@dataclass(frozen=True, eq=False)
class Surface:
    """Two-sided radiating faces with per-side optics.

    ``points`` (n, 3) m; ``faces`` (f, 3) or (f, 4) node indices (stored (f, 4), -1 padded).  Optical arguments
    are scalars, (f,) (both sides alike), (f, 2) or (2f,) per side; they are stored as (2f,) float arrays:
    ``emissivity`` (IR absorptance), ``absorptivity`` (solar), ``specular`` (specular fraction of the reflected
    energy), ``transmissivity`` (IR), ``solar_transmissivity`` (defaults to ``transmissivity``),
    ``transmission_specular`` (specular fraction of the transmitted energy, default 1), ``active`` (bool).
    Raises :class:`Fem2TmmError` naming the faces on a negative reflectance, a value outside [0, 1], a node index
    out of range or a face of zero area.
    """

    points: np.ndarray
    faces: np.ndarray
    emissivity: np.ndarray = 0.8
    absorptivity: np.ndarray = 0.2
    specular: np.ndarray = 0.0
    transmissivity: np.ndarray = 0.0
    solar_transmissivity: np.ndarray | None = None
    transmission_specular: np.ndarray = 1.0
    active: np.ndarray = True

    def __post_init__(self):
        pts = np.asarray(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
            raise Fem2TmmError(f"points must be a finite (n, 3) array of coordinates in m, got shape {pts.shape}")
        faces = pad_faces(self.faces)
        f = len(faces)
        bad = np.nonzero((faces[:, :3] < 0).any(axis=1) | (faces >= len(pts)).any(axis=1) | (faces < -1).any(axis=1))[0]
        if bad.size:
            raise Fem2TmmError(f"faces {format_ids(bad)} refer to nodes outside 0..{len(pts) - 1}; fix the connectivity")
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen dataclass normalisation
        set_("points", pts)
        set_("faces", faces)
        for name in ("emissivity", "absorptivity", "specular", "transmissivity", "transmission_specular"):
            set_(name, _per_side(getattr(self, name), f, name))
        sol = self.transmissivity if self.solar_transmissivity is None else self.solar_transmissivity
        set_("solar_transmissivity", _per_side(sol, f, "solar_transmissivity"))
        set_("active", _per_side(self.active, f, "active", dtype=bool))
        for name in ("emissivity", "absorptivity", "specular", "transmissivity", "solar_transmissivity",
                     "transmission_specular"):
            a = getattr(self, name)
            out = np.nonzero(~np.isfinite(a) | (a < 0) | (a > 1))[0]
            if out.size:
                raise Fem2TmmError(f"{name} must lie in [0, 1]; faces (side) {_side_label(out)} do not")
        for absorb, trans, band in ((self.emissivity, self.transmissivity, "IR: emissivity + transmissivity"),
                                    (self.absorptivity, self.solar_transmissivity,
                                     "solar: absorptivity + solar_transmissivity")):
            neg = np.nonzero(absorb + trans > 1.0 + 1e-12)[0]
            if neg.size:
                raise Fem2TmmError(
                    f"negative reflectance ({band} > 1) on faces (side) {_side_label(neg)}; lower one of them"
                )
        tri = self.triangles
        face_area = np.bincount(tri.face, weights=tri.area, minlength=f)
        scale = float(np.ptp(pts, axis=0).max()) if len(pts) else 0.0
        flat = np.nonzero(face_area <= 1e-14 * max(scale, 1e-300) ** 2)[0]
        if flat.size:
            raise Fem2TmmError(f"faces {format_ids(flat)} have zero area; remove or repair them")

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @cached_property
    def triangles(self) -> Triangles:
        """Triangulation (quads split into (0, 1, 2) and (0, 2, 3)); zero-area halves of collapsed quads are kept
        (they are never sampled and never hit)."""
        f = self.faces
        quad = f[:, 3] >= 0
        tri_nodes = np.concatenate([f[:, [0, 1, 2]], f[quad][:, [0, 2, 3]]])
        tri_face = np.concatenate([np.arange(len(f)), np.nonzero(quad)[0]])
        order = np.argsort(tri_face, kind="stable")
        tri_nodes, tri_face = tri_nodes[order], tri_face[order]
        v = self.points[tri_nodes]
        c = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        norm = np.linalg.norm(c, axis=1)
        n = np.divide(c, norm[:, None], out=np.zeros_like(c), where=norm[:, None] > 0)
        return Triangles(vertices=v, face=tri_face, normal=n, area=0.5 * norm)

    @cached_property
    def face_areas(self) -> np.ndarray:
        """Area of each face (f,) m² (sum of its triangles)."""
        t = self.triangles
        return np.bincount(t.face, weights=t.area, minlength=self.n_faces)

    def optics(self, band: str = "ir") -> SideOptics:
        """Bounce-loop optics of ``band`` "ir" (emissivity, transmissivity) or "solar" (absorptivity,
        solar_transmissivity)."""
        if band == "ir":
            a, tau = self.emissivity, self.transmissivity
        elif band == "solar":
            a, tau = self.absorptivity, self.solar_transmissivity
        else:
            raise ValueError(f"unknown band {band!r}: use 'ir' or 'solar'")
        rho = np.clip(1.0 - a - tau, 0.0, None)
        ts = self.transmission_specular
        cum = np.cumsum(np.stack([a, self.specular * rho, ts * tau, (1.0 - ts) * tau], axis=1), axis=1)
        return SideOptics(absorb=a, cum=cum, active=self.active)


class TriangleScene:
    """Ray-scene of a :class:`Surface`: robust closest-hit queries, emission and diffuse scattering on its
    triangles.  This is the only geometry object the bounce loop talks to; curved super faces (quadrics) subclass
    it and override :meth:`intersect`, :meth:`hit_geometry`, :meth:`hit_normals` (the curved normal at a hit),
    :meth:`offset`, the curved triangles of :meth:`bounce_tables`
    (:meth:`_curved_triangles`), and the emission methods (:meth:`emit`, :meth:`emit_weighted`,
    :meth:`emit_group_rays`, :meth:`facing_areas`, :meth:`sample_facing`, for non-uniform sampling of their true
    area; see :class:`fem2tmm.radiation.quadric.QuadricScene`).  The per-ray work is done by the compiled kernels
    of :mod:`fem2tmm.radiation._tracer_kernels`.

    ``backend``: "auto" (Embree when importable), "embree", "embreex" or "numpy" (:func:`~.engine.make_engine`).
    Origins are offset by ``eps = ORIGIN_OFFSET x (bounding-box diagonal)`` along the normal of the side a ray
    leaves; a hit on the very triangle the ray leaves (float32 round-off) is rejected and re-traced from a 4x larger
    offset.
    """

    @classmethod
    def of(cls, surface: Surface, scene: "TriangleScene | None", caller: str, backend: str = "auto") -> "TriangleScene":
        """``scene`` if it was built for ``surface`` or for a surface of the same geometry (same points and faces:
        the scene's structures do not depend on the optics, which come with each trace, so the load cases of a run
        share one scene), a new scene of ``surface`` if it is None; an error naming ``caller`` otherwise (the
        argument check of every tracer that accepts a ready scene)."""
        if scene is None:
            return cls(surface, backend)
        if scene.surface is not surface and not same_geometry(scene.surface, surface):
            raise Fem2TmmError(f"{caller}: `scene` was built for another surface; pass the scene of this surface")
        return scene

    def __init__(self, surface: Surface, backend: str = "auto", *, engine: bool = True):
        """``engine=False`` skips building the ray engine over all triangles (``self.engine`` is None): for
        subclasses that trace part of the triangles with engines of their own."""

        self.surface = surface
        self._backend = backend
        tri = surface.triangles
        self.tri_vertices = tri.vertices
        self.tri_face = tri.face
        self.tri_normal = tri.normal
        self.tri_area = tri.area
        lo, hi = surface.points.min(axis=0), surface.points.max(axis=0)
        self.diagonal = float(np.linalg.norm(hi - lo))
        self.eps = ORIGIN_OFFSET * max(self.diagonal, 1e-300)
        self.engine = make_engine(tri.vertices, backend) if engine else None
        v = tri.vertices
        # one row per triangle: p0 (0:3), p1 - p0 (3:6), p2 - p0 (6:9), unit front normal (9:12)
        self._geom = np.ascontiguousarray(np.concatenate([v[:, 0], v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], tri.normal],
                                                         axis=1))
        self._tables = None
        self._rows = None

    def __reduce__(self):
        """Pickled as its constructor's arguments: the ray engine (C pointers) is rebuilt where it is unpickled,
        e.g. on a Dask worker (:mod:`fem2tmm.compute`), once per geometry (:func:`_rebuild_scene`); the rebuilt
        scene gives the same hits."""
        return (_rebuild_scene, (self.geometry_token, type(self), self._init_args()))

    def _init_args(self) -> tuple:
        return (self.surface, self._backend)

    @property
    def geometry_token(self) -> str:
        """Digest of what the scene's structures depend on (the geometry, not the optics): scenes with the same
        token are interchangeable for tracing (the optics come with each trace)."""
        if getattr(self, "_token", None) is None:
            from ..cache import digest

            args = self._init_args()
            self._token = digest(type(self).__name__, args[0].points, args[0].faces, *args[1:])
        return self._token

    def sample(self, prim: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points on primitives ``prim`` (r,) from unit-square samples ``u``, ``v`` (r,) by the area-preserving
        map (1 - √u, √u (1 - v), √u v) (thesis eq. 2.18): returns ``(points (r, 3) m, unit front normals (r, 3))``."""
        return sample_points(np.asarray(prim), np.ascontiguousarray(u, dtype=np.float64),
                             np.ascontiguousarray(v, dtype=np.float64), self._geom)

    def sample_weighted(self, prim: np.ndarray, u: np.ndarray, v: np.ndarray):
        """:meth:`sample` plus the relative density correction of each point (r,) (mean 1 over a primitive) or
        None when the map is uniform over the true area (planar triangles); curved scenes return their area
        Jacobian over its mean."""
        p, n = self.sample(prim, u, v)
        return p, n, None

    def emit(self, prim: np.ndarray, sign: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Emitted rays from primitives ``prim`` (r,), side ``sign`` (r,) +1 front / -1 back, driven by the
        unit-hypercube samples ``U`` (r, >= 4): U[:, 0:2] place the origin by the area-preserving map (eq. 2.18),
        U[:, 2:4] give a cosine-law direction about the side's normal (Malley: radius √u₃, angle 2πu₄).
        Returns ``(origins (r, 3) offset off the surface, unit directions (r, 3))``."""
        tables = TriangleScene.bounce_tables(self)
        sign = np.ascontiguousarray(np.broadcast_to(np.asarray(sign, float), (len(prim),)))
        return emit_rays(np.asarray(prim), sign, np.ascontiguousarray(U, dtype=np.float64), self._geom, tables[2],
                         tables[3], self.eps)

    def emit_weighted(self, prim: np.ndarray, sign: np.ndarray, U: np.ndarray):
        """:meth:`emit` plus the relative energy of each ray (r,), with mean 1 over the rays of a primitive, or None
        when all rays of a primitive carry the same energy (planar triangles).  Curved surfaces whose sampling is
        not uniform over their true area return importance weights here; the tracer normalises them per group."""
        o, d = self.emit(prim, sign, U)
        return o, d, None

    def emit_group_rays(self, emitters: "GroupEmitters", group: np.ndarray, U: np.ndarray):
        """Emitted rays of the super faces ``group`` (r,) of ``emitters`` from their samples ``U`` (r, >= 4): U[:, 0]
        picks the emitting triangle and side through the group's cumulative ε·A (:meth:`GroupEmitters.locate`; it
        is rescaled within the triangle), the rest as in :meth:`emit`.  Returns ``(origins (r, 3), directions
        (r, 3), triangles (r,), relative energies (r,) or None)``; here one compiled pass
        (:func:`~fem2tmm.radiation._tracer_kernels.emit_groups`), every ray with the same energy."""
        _, _, centroid, shrink = self.bounce_tables()
        o, d, prim = emit_groups(np.ascontiguousarray(group, dtype=np.int64), U, emitters.start, emitters.lo,
                                 emitters.hi, emitters.entry_prim, emitters.entry_side, self._geom, centroid, shrink,
                                 self.eps)
        return o, d, prim, None

    def facing_areas(self, direction: np.ndarray) -> np.ndarray:
        """(t, 2) area (m²) of each triangle's front (column 0) and back (column 1) side projected onto a plane
        normal to the unit vector ``direction`` (3,), counting only the parts whose side faces ``direction``."""
        cos = self.tri_normal @ direction
        return np.stack([self.tri_area * np.maximum(cos, 0.0), self.tri_area * np.maximum(-cos, 0.0)], axis=1)

    def sample_facing(self, prim: np.ndarray, sign: np.ndarray, u: np.ndarray, v: np.ndarray,
                      direction: np.ndarray):
        """:meth:`sample` of points on the sides ``sign`` (r,) (+1 front, -1 back) of ``prim`` (r,) for rays
        arriving against the unit vector ``direction`` (3,): ``(points (r, 3), front normals (r, 3), weights)``,
        weights (r,) the relative power of each ray (mean 1 over a primitive's side, in proportion to the local
        projected area that faces ``direction``) or None when uniform (planar triangles)."""
        p, n = self.sample(prim, u, v)
        return p, n, None

    def scatter(self, prim: np.ndarray, normals: np.ndarray, sign: np.ndarray, u: np.ndarray, v: np.ndarray):
        """Cosine-law directions (r, 3) about ``sign`` (r,) x the front normal of the hit primitives ``prim`` (r,)
        (diffuse reflection or transmission); ``normals`` (r, 3) are the unit front normals at the hit points, as
        returned by :meth:`hit_geometry` (:func:`fem2tmm.radiation._tracer_kernels.cosine_directions`)."""
        r = len(prim)
        return cosine_directions(np.ascontiguousarray(normals, dtype=np.float64),
                                 np.ascontiguousarray(np.broadcast_to(np.asarray(sign, float), (r,))),
                                 np.ascontiguousarray(u, dtype=np.float64), np.ascontiguousarray(v, dtype=np.float64))

    def hit_geometry(self, prim, origins, directions, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For hits on ``prim`` (r,) at distance ``t`` (r,): ``(face (r,), point (r, 3), unit front normal (r, 3))``.

        The point o + t d carries the float32 error of t (~1e-7 of the scene size), far below the origin offset."""
        return self.tri_face[prim], origins + t[:, None] * directions, self.tri_normal[prim]

    def intersect(self, origins: np.ndarray, directions: np.ndarray, leaving: np.ndarray, out=None):
        """Closest hit of rays leaving primitives ``leaving`` (r,) (-1: none): ``(prim (r,), t (r,))``, prim -1 on a
        miss.  A hit on the primitive a ray leaves (float32 round-off) is re-traced from its origin pushed 4, 16, 64,
        256 x ``eps`` off that triangle, on the side the ray travels to, and that origin is written back into
        ``origins`` (so origin + t x direction is the hit point); a ray still hitting itself after
        ``SELF_HIT_RETRIES`` pushes keeps its origin and is returned as prim -1 with t = -1 (lost).  The one
        self-hit rule of the package, for every engine.  ``out``: optional ``(prim, t)`` arrays for the engine
        (:meth:`~fem2tmm.radiation.engine.EmbreeEngine.intersect`)."""
        prim, t = self.engine.intersect(origins, directions, out)
        bad = np.flatnonzero((prim == leaving) & (prim >= 0))
        if bad.size == 0:
            return prim, t
        o0, d = origins[bad], directions[bad]
        n = self.tri_normal[leaving[bad]]
        side = np.where(np.einsum("ij,ij->i", d, n) >= 0.0, 1.0, -1.0)
        push, todo = self.eps, np.arange(bad.size)
        for _ in range(SELF_HIT_RETRIES):  # loop over the retries of the (few) rays that hit themselves
            push *= 4.0
            o2 = o0[todo] + (push * side[todo])[:, None] * n[todo]
            p2, t2 = self.engine.intersect(o2, d[todo])
            k = bad[todo]
            prim[k], t[k] = p2, t2
            done = (p2 != leaving[k]) | (p2 < 0)
            origins[k[done]] = o2[done]
            todo = todo[~done]
            if todo.size == 0:
                break
        if todo.size:
            prim[bad[todo]], t[bad[todo]] = MISS, -1.0
        return prim, t

    def offset(self, prim: np.ndarray, points: np.ndarray, sign: np.ndarray, normals: np.ndarray | None = None
               ) -> np.ndarray:
        """Origins for rays leaving ``points`` (r, 3) on primitives ``prim`` (r,) into side ``sign`` (r,) (+1 front,
        -1 back): pushed ``eps`` along that side's normal (``normals`` (r, 3) unit front normals at the points,
        default the triangles' own) and, on flat triangles, ``eps`` towards the primitive's centroid, so an origin
        on (or a float32 ulp beyond) an edge shared with another face still starts inside the model.
        ``points`` (float64, C-contiguous) is modified in place and returned."""
        r = len(prim)
        tables = self.bounce_tables()
        if normals is None:
            normals = tables[1][prim]
        return offset_points(np.asarray(prim), points, np.ascontiguousarray(np.broadcast_to(np.asarray(sign, float), (r,))),
                             np.ascontiguousarray(normals, dtype=np.float64), tables[2], tables[3], self.eps)

    def bounce_tables(self):
        """Per-triangle tables of the compiled bounce kernels: ``(face (t,) int64, unit front normal (t, 3),
        centroid (t, 3), shrink (t,))``.  ``shrink`` is the fraction of the way towards the centroid that an origin
        on the triangle moves before its push off the surface: eps / (largest centroid-vertex distance), so the move
        is at most ``eps`` (at most half way on triangles smaller than ``eps``), and an origin on an edge moves
        inwards by at least eps x (that edge's distance to the centroid) / (that largest distance); 0 on curved
        triangles (their origins lie on the quadric, their hits take the quadric's normal) and degenerate ones."""
        if self._tables is None:
            c = self.tri_vertices.mean(axis=1)
            reach = np.linalg.norm(self.tri_vertices - c[:, None, :], axis=2).max(axis=1)
            shrink = np.minimum(np.divide(self.eps, reach, out=np.zeros(len(reach)), where=reach > 0), 0.5)
            shrink[self._curved_triangles()] = 0.0
            self._tables = (np.ascontiguousarray(self.tri_face, dtype=np.int64),
                            np.ascontiguousarray(self.tri_normal, dtype=np.float64), np.ascontiguousarray(c), shrink)
        return self._tables

    def hit_rows(self, optics: SideOptics) -> np.ndarray:
        """(t, 16) one row per triangle for the compiled bounce (:data:`~fem2tmm.radiation._tracer_kernels.HIT_ROW`): unit
        front normal, owning face, the optics rows of its front and back sides (``optics`` of the band traced,
        :attr:`SideOptics.rows`), centroid, shrink (see :meth:`bounce_tables`).  A hit reads one 128-byte row, which
        starts on a 128-byte boundary (two cache lines).  The last table built is kept for the same ``optics`` (or
        optics with the same rows: the two half tallies of the auto choice's estimate, 0.35 s each at 266 832 quads)."""
        if self._rows is not None and (self._rows[0] is optics or np.array_equal(self._rows[0].rows, optics.rows)):
            return self._rows[1]
        face, normal, centroid, shrink = self.bounce_tables()
        t = len(face)
        buf = np.empty(t * 16 + 16)
        start = (-buf.ctypes.data % 128) // 8  # first float on a 128-byte boundary
        rows = buf[start:start + t * 16].reshape(t, 16)
        rows[:, 0:3] = normal
        rows[:, 3] = face
        rows[:, 4:8] = optics.rows[2 * face]
        rows[:, 8:12] = optics.rows[2 * face + 1]
        rows[:, 12:15] = centroid
        rows[:, 15] = shrink
        self._rows = (optics, rows)
        return rows

    def _curved_triangles(self) -> np.ndarray:
        return np.zeros(len(self.tri_face), bool)

    def hit_normals(self, prim: np.ndarray, origins: np.ndarray, directions: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Unit front normals (r, 3) at the hit points of rays that hit curved primitives, or an empty (0, 3) array
        when every normal is the hit triangle's own (planar scenes); rows of misses are not used."""
        return _NO_NORMALS


_NO_NORMALS = np.zeros((0, 3))


class TriangleWeights(NamedTuple):
    """Triangles as :meth:`GroupEmitters.build` reads them from a scene: ``tri_face`` (t,) the face of each triangle
    and ``tri_area`` (t,) its area (m²) or weight."""

    tri_face: np.ndarray
    tri_area: np.ndarray


@dataclass(frozen=True)
class GroupEmitters:
    """Emission tables of groups of sides (super faces), sampled as a whole through their cumulative ε·A.

    ``entry_prim`` (e,) triangle, ``entry_side`` (e,) 0 front / 1 back, ``entry_group`` (e,), ``lo``/``hi`` (e,)
    bounds of each entry in the keyed cumulative distribution: group g occupies [g, g + 1), entry k of g spans
    [g + C_{k-1}, g + C_k) with C the normalised cumulative ε·A of the group; ``start`` (g + 1,) the first entry
    of each group.  ``weight`` (g,) = Σ ε·A (m²) of the emitting sides of each group, ``area`` (g,) their area (m²).
    """

    entry_prim: np.ndarray
    entry_side: np.ndarray
    entry_group: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    weight: np.ndarray
    area: np.ndarray
    start: np.ndarray

    _COMPACT = {"entry_prim": np.int32, "entry_side": np.int8, "entry_group": np.int32}

    def __getstate__(self):
        """Pickled with the entry indices in the smallest exact integer types (a trace's job travels to the Dask
        workers with them: 17 instead of 24 bytes per entry); restored to the build's dtypes on unpickling."""
        return {k: pack_ints(v, self._COMPACT[k]) if k in self._COMPACT else v for k, v in self.__dict__.items()}

    def __setstate__(self, state):
        self.__dict__.update({k: unpack_ints(v) if k in self._COMPACT else v for k, v in state.items()})

    @classmethod
    def build(cls, scene: TriangleScene | TriangleWeights, groups: np.ndarray, emit: np.ndarray,
              n_groups: int) -> "GroupEmitters":
        """Tables for ``groups`` (2f,) int group per side (-1: none) with emissive power weights ``emit`` (2f,)
        (ε for IR, 0 on inactive sides)."""
        t = len(scene.tri_face)
        prim = np.repeat(np.arange(t), 2)
        side = np.tile(np.array([FRONT, BACK]), t)
        sid = 2 * scene.tri_face[prim] + side
        w = emit[sid] * scene.tri_area[prim]
        g = groups[sid]
        keep = (w > 0) & (g >= 0)
        prim, side, g, w = prim[keep], side[keep], g[keep], w[keep]
        order = np.argsort(g, kind="stable")
        prim, side, g, w = prim[order], side[order], g[order], w[order]
        weight = np.bincount(g, weights=w, minlength=n_groups)
        area = np.bincount(g, weights=scene.tri_area[prim], minlength=n_groups)
        start = np.concatenate([[0], np.cumsum(np.bincount(g, minlength=n_groups))])
        csum = np.cumsum(w)
        before = np.concatenate([[0.0], csum])[start[g]]  # cumulative weight before the group's first entry
        hi = (csum - before) / weight[g]
        lo = np.concatenate([[0.0], hi[:-1]])
        lo[start[g] == np.arange(len(g))] = 0.0
        last = np.append(g[1:] != g[:-1], True) if len(g) else np.zeros(0, bool)
        hi[last] = 1.0
        return cls(entry_prim=prim, entry_side=side, entry_group=g, lo=g + lo, hi=g + hi, weight=weight, area=area,
                   start=start.astype(np.int64))

    def locate(self, group: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Entry and rescaled coordinate in [0, 1) for rays of ``group`` (r,) with first sample coordinate ``u``:
        the 1-D inverse-CDF step that keeps the low-discrepancy structure across the whole super face."""
        return locate_entries(np.ascontiguousarray(group, dtype=np.int64), np.ascontiguousarray(u, dtype=np.float64),
                              self.start, self.lo, self.hi)


#: scenes rebuilt in this process from pickles, by geometry token (a Dask worker keeps the last few)
_REBUILT: dict[str, TriangleScene] = {}
_REBUILT_MAX = 4


def pack_ints(a: np.ndarray, small=np.int32):
    """An integer array for pickling: ``(dtype, a as small)`` when every value fits ``small`` exactly, else ``a``;
    :func:`unpack_ints` restores the original dtype (jobs sent to Dask workers carry per-side index arrays)."""
    info = np.iinfo(small)
    if a.size and info.min <= a.min() and a.max() <= info.max:
        return (a.dtype.str, a.astype(small))
    return a


def unpack_ints(x) -> np.ndarray:
    """The array that :func:`pack_ints` packed, in its original dtype."""
    return x[1].astype(np.dtype(x[0])) if isinstance(x, tuple) else x


def same_geometry(a: Surface, b: Surface) -> bool:
    """Whether two surfaces have the same points (n, 3) and faces (f, 4): a scene of one traces the other."""
    return all(x is y or (x.shape == y.shape and np.array_equal(x, y))
               for x, y in ((a.points, b.points), (a.faces, b.faces)))


def _rebuild_scene(token: str, cls: type, args: tuple) -> TriangleScene:
    """The scene of ``token``: one rebuilt earlier in this process, or ``cls(*args)`` (kept for the next traces;
    its structures depend only on the geometry, so a later trace with other optics reuses it)."""
    scene = _REBUILT.pop(token, None)
    if scene is None:
        scene = cls(*args)
        scene._token = token
    _REBUILT[token] = scene  # most recent last
    while len(_REBUILT) > _REBUILT_MAX:
        _REBUILT.pop(next(iter(_REBUILT)))
    return scene
