"""The ray scene of quadric super faces (:class:`QuadricScene`): flat faces traced with Embree and every tagged FE
region exactly against its fitted quadric (:mod:`fem2tmm.radiation.quadric`: the conventions, the patches, the
emission and absorption on them).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..arrays import unique
from ..errors import Fem2TmmError, format_ids
from .engine import make_engine
from .quadric import (FIT_TOL, MIN_ALIGNMENT, RULE7, _Traced, _area_jacobian, _cofactor, _dot, _foot, _gradient,
                      _roots, _rotate, _unit, _value, face_frames, fit_regions, subdivided_rule)
from .surfaces import Surface, TriangleScene


# -------------------------------------------------------------------------------------------------------- scene
class QuadricScene(TriangleScene):
    """Ray scene of a :class:`Surface` whose faces ``quadric_of_face`` (f,) int (-1: flat; k: quadric k of
    ``quadrics``, one per fitted region) are traced against their fitted quadrics (thesis §5.2; module docstring).

    Flat faces go through Embree (with the base class' offsets and self-hit rejection).  Regions whose quadrics
    coincide (adjacent regions on which each other's quadric fits as well as their own, within max(1e-9 x the scene
    diagonal, twice their fit distance): per-super-face fits of one cone) are traced as one *surface* with the first
    one's quadric.  For each surface, rays that cross the bounding box of its patches get both exact roots; a root
    is a hit when the surface's normal line there crosses one of its facets within ±``reach`` (twice the largest
    facet-to-quadric distance plus 16 origin offsets), found by Embree in one scene of all quadric facets; the
    closest hit over flat faces and surfaces wins, and the facet found names the face hit.  The hit normal is the
    quadric normal, oriented per face like the FE face normal (front/back sides keep their meaning; the faces of a
    region may be oriented either way); specular and diffuse directions use it.

    Emission (:meth:`emit_weighted`): origins sampled on the facets, projected onto the quadric along its normal,
    directions rotated from the facet normal to the quadric normal, and ray weights J(x) / (mean J over the
    triangle) with J the area Jacobian of the projection.  ``tri_area`` holds the area of each triangle's patch on
    its quadric (quadrature of J, see :meth:`_setup_areas`; ``tri_area_fe`` the facet areas), so emission tables,
    ``area`` and ``eps_area`` of the tracers are true curved areas.  Solar sampling (:meth:`facing_areas`,
    :meth:`sample_facing`) weighs the quadric's own projected area facing the Sun.  ``weighted=False`` gives every ray
    of a triangle the same energy (the thesis' assumption that projected samples stay uniform).
    Cost: the bounce loop pays one slab test per ray and surface, so keep the number of distinct surfaces small.
    """

    def __init__(self, surface: Surface, quadric_of_face, quadrics, backend: str = "auto", weighted: bool = True):
        super().__init__(surface, backend, engine=False)
        self._args = (surface, quadric_of_face, quadrics, backend, weighted)
        f = surface.n_faces
        qf = np.asarray(quadric_of_face)
        K = len(quadrics)
        bad = qf.shape != (f,) or not np.issubdtype(qf.dtype, np.integer)
        if bad or (qf.size and (qf.min() < -1 or qf.max() >= K)):
            raise Fem2TmmError(f"quadric_of_face must be one int per face ({f},) in -1..{K - 1}, got {qf.shape} "
                               f"{qf.dtype}")
        self.quadrics = tuple(quadrics)
        self.quadric_of_face = qf.astype(np.int64)
        self.weighted = bool(weighted)
        self.tri_quadric = self.quadric_of_face[self.tri_face]
        self.tri_area_fe = self.tri_area
        self._facing_cache = {}
        # traced parameters per quadric; merged regions share them
        self._params = [_Traced(*q.parts, _cofactor(q.parts.A), q.center) for q in self.quadrics]
        self._tol = [1e-14 * max(q.size, self.diagonal) for q in self.quadrics]
        # flat faces: a scene of their own (same triangle order as this one's flat triangles)
        self._flat_tri = np.flatnonzero(self.tri_quadric < 0)
        self._quad_tri = np.flatnonzero(self.tri_quadric >= 0)
        self._flat = None
        if self._flat_tri.size:
            flat_faces = np.flatnonzero(self.quadric_of_face < 0)
            self._flat = TriangleScene(Surface(surface.points, surface.faces[flat_faces]), backend)
            self._flat.eps = self.eps
            if not np.array_equal(self._flat.tri_vertices, self.tri_vertices[self._flat_tri]):
                raise AssertionError("flat sub-scene triangles out of order")  # pragma: no cover - invariant
        self._flat_local = np.full(len(self.tri_face), -1, np.int64)
        self._flat_local[self._flat_tri] = np.arange(self._flat_tri.size)
        self._facets = make_engine(self.tri_vertices[self._quad_tri], backend) if self._quad_tri.size else None
        self.engine = self._flat.engine if self._flat is not None else self._facets
        self._tri_sign = np.ones(len(self.tri_face))
        self._ratio = np.ones(len(self.tri_face))
        self.surface_of_quadric = np.arange(K)
        if self._quad_tri.size:
            self._setup_surfaces()
            self._setup_areas()

    def _init_args(self) -> tuple:
        return self._args  # fitted quadrics included; see TriangleScene.__reduce__

    @classmethod
    def from_regions(cls, surface: Surface, region_of_face, names=None, tol: float = FIT_TOL, backend: str = "auto",
                     weighted: bool = True) -> "QuadricScene":
        """Fit one quadric per region (:func:`fit_regions`; ``region_of_face`` (f,) int, -1 flat) and build the
        scene."""
        quadrics, qf = fit_regions(surface.points, surface.faces, region_of_face, names=names, tol=tol)
        return cls(surface, qf, quadrics, backend=backend, weighted=weighted)

    @property
    def n_surfaces(self) -> int:
        """Number of distinct traced quadric surfaces (after merging coinciding regions)."""
        return len(self._surfaces)

    # ------------------------------------------------------------------------------------------------ kernels
    def _by_quadric(self, prim: np.ndarray):
        """[(k, rows)]: the rows of ``prim`` (quadric triangles) on each quadric k (a loop over quadrics then uses
        shared 3 x 3 matrices)."""
        k = self.tri_quadric[prim]
        if len(self.quadrics) == 1 or (k.size and k.min() == k.max()):
            return [(int(k[0]) if k.size else 0, slice(None))]
        order = np.argsort(k, kind="stable")
        cuts = np.flatnonzero(np.diff(k[order])) + 1
        return [(int(k[rows[0]]), rows) for rows in np.split(order, cuts) if rows.size]

    def _lift(self, prim: np.ndarray, p: np.ndarray, check: bool = True):
        """Points p (r, 3) on quadric triangles ``prim`` (r,): ``(foot points (r, 3), unit front normals (r, 3),
        area Jacobian (r,), distance |p - foot| (r,))``."""
        q = np.empty_like(p)
        n = np.empty_like(p)
        J = np.empty(len(p))
        dist = np.empty(len(p))
        for k, rows in self._by_quadric(prim):  # loop over quadrics
            A, b, c0, Q, ev, beta, cof, o = self._params[k]  # a _Traced
            x = p[rows] - o
            qk, ok = _foot(Q, ev, beta, c0, x, self._tol[k])
            if check and not ok.all():
                bad = unique(self.tri_face[prim[rows][~ok]])
                raise Fem2TmmError(f"faces {format_ids(bad)}: points on them do not project onto their quadric; the "
                                   "quadric does not fit these faces")
            g = _gradient(A, b, qk)
            nk = _unit(g)
            delta = _dot(x - qk, nk)
            J[rows] = _area_jacobian(A, cof, g, self.tri_normal[prim[rows]], delta)
            q[rows] = qk + o
            n[rows] = nk * self._tri_sign[prim[rows]][:, None]
            dist[rows] = np.where(ok, np.abs(delta), np.inf)
        return q, n, J, dist

    def _front_normals(self, prim: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Unit front normals (r, 3) of quadric triangles ``prim`` (r,) at points p (r, 3) on their quadric."""
        n = np.empty_like(p)
        for k, rows in self._by_quadric(prim):  # loop over quadrics
            A, b, o = self._params[k].A, self._params[k].b, self._params[k].center
            n[rows] = _unit(_gradient(A, b, p[rows] - o))
        return n * self._tri_sign[prim][:, None]

    def _rule_points(self, tris: np.ndarray, rule):
        """Foot points (t, q, 3), area Jacobians (t, q) and facet-to-quadric distances (t, q) at the points of a
        barycentric ``rule`` on quadric triangles ``tris`` (t,)."""
        bary = rule[0]
        X = np.einsum("qb,tbc->tqc", bary, self.tri_vertices[tris]).reshape(-1, 3)
        q, _, J, dist = self._lift(np.repeat(tris, len(bary)), X)
        return q.reshape(len(tris), len(bary), 3), J.reshape(len(tris), -1), dist.reshape(len(tris), -1)

    # ------------------------------------------------------------------------------------------------- set-up
    def _setup_surfaces(self):
        """Merge coinciding quadrics into traced surfaces, then orient every quadric face like its FE normal."""
        K = len(self.quadrics)
        sf = self.surface
        faces = unique(self.tri_face[self._quad_tri])
        first_tri = np.searchsorted(self.tri_face, faces)
        cen, nrm = face_frames(sf.points, sf.faces[faces])
        kf = self.quadric_of_face[faces]
        foot, _, _, dist = self._lift(first_tri, cen, check=False)
        bad = ~np.isfinite(dist)
        if bad.any():
            raise Fem2TmmError(f"faces {format_ids(faces[bad])} do not project onto their quadric: the quadric does "
                               "not fit them; check the region or untag it")
        # probe points of each region: its vertices and its face centroids projected onto its own quadric
        fn = sf.faces[faces]
        probe_pts = np.concatenate([foot, sf.points[fn[fn >= 0]]])
        probe_k = np.concatenate([kf, np.repeat(kf, (fn >= 0).sum(axis=1))])
        # candidate pairs: regions sharing a node
        rows = fn[fn >= 0]
        cols = np.repeat(kf, (fn >= 0).sum(axis=1))
        R = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(len(sf.points), K))
        P = sp.triu(R.T @ R, k=1).tocoo()
        parent = np.arange(K)

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        def fits(i, j):
            """Quadric j fits region i's probes as well as i's own quadric does."""
            pts = probe_pts[probe_k == i]
            tq = self._params[j]
            A, b, c0, o = tq.A, tq.b, tq.c0, tq.center
            x = pts - o
            d = np.abs(_value(A, b, c0, x)) / np.sqrt(_dot(*(2 * [_gradient(A, b, x)])))
            return float(d.max()) <= max(1e-9 * self.diagonal, 2.0 * self.quadrics[i].max_distance)

        for i, j in zip(P.row.tolist(), P.col.tolist()):  # loop over adjacent region pairs
            ri, rj = find(i), find(j)
            if ri != rj and fits(i, j) and fits(j, i) and fits(i, rj) and fits(j, ri):
                parent[max(ri, rj)] = min(ri, rj)
        rep = np.array([find(i) for i in range(K)])  # loop over quadrics
        for k in np.flatnonzero(rep != np.arange(K)):  # merged regions trace their representative's quadric
            self._params[k] = self._params[rep[k]]
            self._tol[k] = self._tol[rep[k]]
        self._surfaces, self.surface_of_quadric = unique(rep, return_inverse=True)
        self.surface_of_quadric = self.surface_of_quadric.ravel()
        # orientation per face: sign of (facet normal . traced quadric normal) at the projected face centroid
        _, n, _, _ = self._lift(first_tri, cen)
        cos = _dot(n, nrm)
        bad = np.abs(cos) < MIN_ALIGNMENT
        if bad.any():
            raise Fem2TmmError(f"faces {format_ids(faces[bad])} are more than 60° off their quadric's normal: the "
                               "quadric does not fit them; check the region or untag it")
        face_sign = np.ones(sf.n_faces)
        face_sign[faces] = np.where(cos >= 0, 1.0, -1.0)
        self._tri_sign = face_sign[self.tri_face]

    def _setup_areas(self):
        """Quadric area of each triangle's patch, membership reach and bounding boxes of the traced surfaces.

        Area: quadrature of the projection's area Jacobian J, 7-point rule; its error falls as (element size /
        curvature radius)^6 (80-triangle icosphere 3e-5, 320: 5e-7), so on triangles whose facet-to-quadric gap
        exceeds 0.2 % of their longest edge (size / radius > ~0.03) it is repeated on a 2 x 2 subdivision, and on a
        4 x 4 one where the two differ by more than 6e-9 (estimated error 1e-10; 80-triangle icosphere 5e-9)."""
        qt = self._quad_tri
        V = self.tri_vertices[qt]
        A_fe = self.tri_area[qt]
        Xq, J, dist = self._rule_points(qt, RULE7)
        aq = A_fe * (J @ RULE7[1])
        gap = dist.max(axis=1)  # facet-to-quadric gap at the rule points (largest inside a facet, 0 at vertices)
        edge = np.linalg.norm(V - V[:, [1, 2, 0]], axis=2).max(axis=1)
        coarse = np.flatnonzero(gap > 2e-3 * edge)
        if coarse.size:
            rule2 = subdivided_rule(2)
            a2 = A_fe[coarse] * (self._rule_points(qt[coarse], rule2)[1] @ rule2[1])
            fine = coarse[np.abs(aq[coarse] - a2) > 6e-9 * a2]
            aq[coarse] = a2
            if fine.size:
                rule4 = subdivided_rule(4)
                aq[fine] = A_fe[fine] * (self._rule_points(qt[fine], rule4)[1] @ rule4[1])
        self._ratio[qt] = np.divide(aq, A_fe, out=np.ones_like(aq), where=A_fe > 0)
        self.tri_area = self.tri_area.copy()
        self.tri_area[qt] = aq
        # per traced surface: reach of the membership test (twice the largest gap plus 16 origin offsets) and the
        # bounding box of its patches (vertices and rule-point feet, padded by the reach)
        S = self.n_surfaces
        st = self.surface_of_quadric[self.tri_quadric[qt]]
        reach = np.zeros(S)
        np.maximum.at(reach, st, gap)
        self.reach = 2.0 * reach + 16.0 * self.eps
        lo = np.minimum(V.min(axis=1), Xq.min(axis=1))
        hi = np.maximum(V.max(axis=1), Xq.max(axis=1))
        box = np.empty((S, 2, 3))
        box[:, 0], box[:, 1] = np.inf, -np.inf
        np.minimum.at(box[:, 0], st, lo)
        np.maximum.at(box[:, 1], st, hi)
        pad = (self.reach + self.eps)[:, None]
        box[:, 0] -= pad
        box[:, 1] += pad
        self._box = box

    # ----------------------------------------------------------------------------------------------- queries
    def _member(self, s: int, q: np.ndarray) -> np.ndarray:
        """Triangle (r,) of traced surface s under points q (r, 3) on it along its normal line, -1 outside s."""
        k = int(self._surfaces[s])
        A, b, o = self._params[k].A, self._params[k].b, self._params[k].center
        n = _unit(_gradient(A, b, q - o))
        h = self.reach[s]
        hit, tm = self._facets.intersect(q - h * n, n)
        hit = np.asarray(hit, np.int64)
        ok = (hit >= 0) & (tm <= 2.0 * h)
        out = np.full(len(q), -1, np.int64)
        g = self._quad_tri[hit[ok]]
        mine = self.surface_of_quadric[self.tri_quadric[g]] == s
        out[np.flatnonzero(ok)[mine]] = g[mine]
        return out

    def intersect(self, origins: np.ndarray, directions: np.ndarray, leaving: np.ndarray, out=None):
        """Closest hit over flat faces (Embree) and quadric patches (exact roots): ``(prim (r,), t (r,))`` with
        the same conventions as :meth:`TriangleScene.intersect` (prim -1 on a miss, t = -1 for a lost ray; origins of
        flat rays re-traced after a self hit are updated in place); t is float64 and exact on quadric hits.  ``out``
        is not used."""
        r = len(origins)
        prim = np.full(r, -1, np.int64)
        best = np.full(r, np.inf)
        lost = np.zeros(r, bool)
        if self._flat is not None:
            lv = np.where(leaving >= 0, self._flat_local[np.maximum(leaving, 0)], -1)
            pl, tl = self._flat.intersect(origins, directions, lv)
            pl = np.asarray(pl, np.int64)
            hit = pl >= 0
            prim[hit] = self._flat_tri[pl[hit]]
            best[hit] = tl[hit]
            lost = ~hit & (tl == -1)
            best[lost] = -np.inf  # nothing is closer: the ray stays lost
        if self._facets is not None and r:
            O = np.ascontiguousarray(origins.T)
            with np.errstate(divide="ignore"):
                inv = np.ascontiguousarray(1.0 / directions.T)
            for s in range(self.n_surfaces):  # loop over traced surfaces
                tn, tf = _slab(O, inv, self._box[s])
                cand = np.flatnonzero((tf >= tn) & (tn < best))
                if cand.size == 0:
                    continue
                k = int(self._surfaces[s])
                tq = self._params[k]
                A, b, c0, o = tq.A, tq.b, tq.c0, tq.center
                d = directions[cand]
                for root in _roots(A, b, c0, origins[cand] - o, d):  # t1 then t2
                    with np.errstate(invalid="ignore"):
                        ok = (root > 0.0) & (root < best[cand]) & (root <= tf[cand] + self.eps)
                    if not ok.any():
                        continue
                    sel = cand[ok]
                    tt = root[ok]
                    m = self._member(s, origins[sel] + tt[:, None] * directions[sel])
                    acc = m >= 0
                    best[sel[acc]] = tt[acc]
                    prim[sel[acc]] = m[acc]
        t = np.where(prim >= 0, best, np.inf)
        t[lost] = -1.0
        return prim, t

    def hit_geometry(self, prim, origins, directions, t):
        face = self.tri_face[prim]
        p = origins + t[:, None] * directions
        nrm = self.tri_normal[prim]
        m = self.tri_quadric[prim] >= 0
        if m.any():
            nrm[m] = self._front_normals(prim[m], p[m])
        return face, p, nrm

    def hit_normals(self, prim, origins, directions, t):
        """Quadric front normals at the hit points of rays hitting quadric patches (the triangles' own elsewhere)."""
        hit = prim >= 0
        q = np.flatnonzero(hit & (self.tri_quadric[np.maximum(prim, 0)] >= 0))
        if q.size == 0:
            return super().hit_normals(prim, origins, directions, t)
        nrm = self.tri_normal[np.maximum(prim, 0)]
        p = origins[q] + t[q, None] * directions[q]
        nrm[q] = self._front_normals(prim[q], p)
        return nrm

    def _curved_triangles(self) -> np.ndarray:
        return self.tri_quadric >= 0

    def offset(self, prim, points, sign, normals=None):
        if normals is None:
            m = np.flatnonzero(self.tri_quadric[prim] >= 0)
            normals = self.tri_normal[prim]
            if m.size:
                normals[m] = self._front_normals(prim[m], points[m])
        return super().offset(prim, points, sign, normals)

    def sample(self, prim, u, v):
        p, n, _ = self._sample(prim, u, v)
        return p, n

    def sample_weighted(self, prim, u, v):
        """Points on the quadric (or facets), front normals and weights J / (mean J over the triangle) on quadric
        triangles (1 elsewhere; None when the batch has none or the scene is unweighted)."""
        p, n, J = self._sample(prim, u, v)
        j = np.flatnonzero(self.tri_quadric[prim] >= 0)
        if j.size == 0 or not self.weighted:
            return p, n, None
        w = np.ones(len(prim))
        w[j] = J[j] / self._ratio[prim[j]]
        return p, n, w

    def _sample(self, prim, u, v):
        """Points and front normals on the quadric (quadric triangles) or facets, and the area Jacobian (r,)."""
        p, n = super().sample(prim, u, v)
        J = np.ones(len(prim))
        j = np.flatnonzero(self.tri_quadric[prim] >= 0)
        if j.size:
            p[j], n[j], J[j], _ = self._lift(prim[j], p[j])
        return p, n, J

    def emit(self, prim, sign, U):
        return self.emit_weighted(prim, sign, U)[:2]

    def emit_group_rays(self, emitters, group, U):
        """:meth:`TriangleScene.emit_group_rays` through :meth:`emit_weighted` (projected origins, rotated
        directions, Jacobian weights)."""
        entry, U[:, 0] = emitters.locate(group, U[:, 0])
        prim = emitters.entry_prim[entry]
        o, d, w = self.emit_weighted(prim, 1.0 - 2.0 * emitters.entry_side[entry], U)
        return o, d, prim, w

    def emit_weighted(self, prim, sign, U):
        """Rays as :meth:`TriangleScene.emit`; on quadric triangles the origin is projected onto the quadric along
        its normal, the direction rotated from the facet normal to the quadric normal and the weight (r,) is
        J / (mean J over the triangle) (1 on flat triangles; all 1 when ``weighted`` is False)."""
        sign = np.broadcast_to(np.asarray(sign, float), (len(prim),))
        # the base class' emission, step by step: point, cosine direction in the facet frame, offset origin
        o, nt = TriangleScene.sample(self, prim, U[:, 0], U[:, 1])
        d = TriangleScene.scatter(self, prim, nt, sign, U[:, 2], U[:, 3])
        w = np.ones(len(prim))
        quad = self.tri_quadric[prim] >= 0
        j = np.flatnonzero(~quad)
        if j.size:
            o[j] = TriangleScene.offset(self, prim[j], o[j], sign[j])
        j = np.flatnonzero(quad)
        if j.size:
            pj = prim[j]
            q, n, J, _ = self._lift(pj, o[j])
            s = sign[j][:, None]
            d[j] = _rotate(d[j], nt[j] * s, n * s)
            o[j] = q + self.eps * s * n
            if self.weighted:
                w[j] = J / self._ratio[pj]
        return o, d, w

    def facing_areas(self, direction):
        """As :meth:`TriangleScene.facing_areas`; on a quadric triangle, ∫ max(±n·s, 0) dA over its patch (7-point
        rule of n·s J over the facet, on a 8 x 8 subdivision for triangles whose patch straddles the terminator).
        Cached per direction."""
        return self._facing(direction)[0].copy()

    def _facing(self, direction):
        """(facing areas (t, 2) m², their means over each facet (t, 2)), cached per direction."""
        direction = np.asarray(direction, float)
        key = tuple(direction.tolist())
        if key not in self._facing_cache:
            out = super().facing_areas(direction)
            qt = self._quad_tri
            if qt.size:
                out[qt] = self._facing_integral(qt, direction, RULE7)
                bary = np.vstack([RULE7[0], np.eye(3)])
                X = np.einsum("qb,tbc->tqc", bary, self.tri_vertices[qt]).reshape(-1, 3)
                cos_v = _dot(self._lift(np.repeat(qt, len(bary)), X)[1], direction[None]).reshape(len(qt), -1)
                split = (cos_v.max(axis=1) > 0) & (cos_v.min(axis=1) < 0)
                if split.any():
                    out[qt[split]] = self._facing_integral(qt[split], direction, subdivided_rule(8))
            mean = np.divide(out, self.tri_area_fe[:, None], out=np.zeros_like(out),
                             where=self.tri_area_fe[:, None] > 0)
            self._facing_cache[key] = (out, mean)
        return self._facing_cache[key]

    def _facing_integral(self, tris, direction, rule):
        bary, w = rule
        X = np.einsum("qb,tbc->tqc", bary, self.tri_vertices[tris]).reshape(-1, 3)
        _, n, J, _ = self._lift(np.repeat(tris, len(w)), X)
        c = (_dot(n, direction[None]) * J).reshape(len(tris), -1)
        return np.stack([np.maximum(c, 0.0) @ w, np.maximum(-c, 0.0) @ w], axis=1) * self.tri_area_fe[tris][:, None]

    def sample_facing(self, prim, sign, u, v, direction):
        """Points on the quadric (or facets), front normals, and weights (r,) max(±n·s, 0) J / (mean of that over
        the triangle's side) on quadric triangles (None when the batch has none)."""
        p, n, J = self._sample(prim, u, v)
        j = np.flatnonzero(self.tri_quadric[prim] >= 0)
        if j.size == 0:
            return p, n, None
        sign = np.broadcast_to(np.asarray(sign, float), (len(prim),))
        w = np.ones(len(prim))
        pj = prim[j]
        mean = self._facing(direction)[1][pj, (sign[j] < 0).astype(np.int64)]
        local = np.maximum(sign[j] * _dot(n[j], np.asarray(direction, float)[None]), 0.0) * J[j]
        w[j] = np.divide(local, mean, out=np.zeros_like(local), where=mean > 0)
        return p, n, w


def _slab(O: np.ndarray, inv: np.ndarray, box: np.ndarray):
    """Entry and exit distances (r,) of rays (origins O (3, r), inverse directions inv (3, r)) through the box
    (2, 3) (lo, hi); entry clipped at 0; axes where 0 x inf gives NaN are ignored."""
    tn = np.zeros(O.shape[1])
    tf = np.full(O.shape[1], np.inf)
    with np.errstate(invalid="ignore"):
        for c in range(3):  # loop over x, y, z
            a = (box[0, c] - O[c]) * inv[c]
            b = (box[1, c] - O[c]) * inv[c]
            np.fmax(tn, np.fmin(a, b), out=tn)
            np.fmin(tf, np.fmax(a, b), out=tf)
    return tn, tf
