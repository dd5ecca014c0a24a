"""Ray engine and scene robustness: Embree vs a brute-force Möller–Trumbore, no leaks out of closed boxes."""

from __future__ import annotations

import numpy as np
import pytest

from fem2tmm.radiation import HAS_EMBREE, Surface, TriangleScene, trace_exchange
from fem2tmm.radiation.engine import NumpyEngine, make_engine
from fem2tmm.radiation.tracer import END_CAPPED, END_SPACE, trace_paths

needs_embree = pytest.mark.skipif(not HAS_EMBREE, reason="embreex not importable")


def grid_box(n: int, size=1.0, inward=True):
    """Closed cube [0, size]^3 of n x n quads per face; right-hand normals inwards (or outwards)."""
    g = np.linspace(0.0, size, n + 1)
    pts, faces = [], []
    for axis in range(3):
        for hi in (0.0, size):
            a, b = [k for k in range(3) if k != axis]
            P = np.zeros((n + 1, n + 1, 3))
            P[..., a], P[..., b] = np.meshgrid(g, g, indexing="ij")
            P[..., axis] = hi
            base = sum(len(p) for p in pts)
            pts.append(P.reshape(-1, 3))
            i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
            q = np.stack([i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1], -1)
            q = q.reshape(-1, 4) + base
            # (a, b, axis) right-handed: this order's normal is +axis when (a, b) is cyclic after axis
            normal_sign = 1 if (a, b) in ((1, 2), (2, 0), (0, 1)) else -1
            wants = (1 if hi == 0.0 else -1) * (1 if inward else -1)
            faces.append(q if normal_sign == wants else q[:, ::-1])
    return np.concatenate(pts), np.concatenate(faces)


def rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_grid_box_normals_point_inwards():
    pts, faces = grid_box(2)
    s = Surface(pts, faces)
    tri = s.triangles
    to_centre = 0.5 - tri.vertices.mean(axis=1)
    assert np.all(np.einsum("ij,ij->i", tri.normal, to_centre) > 0)


@needs_embree
def test_embree_matches_brute_force_moller_trumbore():
    # independent check of the Embree wrapper (centring, float32) against the float64 numpy engine
    rng = np.random.default_rng(0)
    tri = rng.random((60, 3, 3)) * 2.0 + np.array([100.0, -50.0, 20.0])  # far from the origin: centring matters
    n = 4000
    o = rng.random((n, 3)) * 2.0 + np.array([100.0, -50.0, 20.0])
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    pn, tn = NumpyEngine(tri).intersect(o, d)
    assert (pn >= 0).sum() > n // 4  # the test actually hits things
    for backend in ("embree", "embreex"):  # Embree's C API (compiled kernels) and embreex's own wrapper
        pe, te = make_engine(tri, backend).intersect(o, d)
        same = pe == pn
        # a disagreement is only allowed where two hits are within float32 precision of each other
        assert same.mean() > 0.995
        hit = same & (pn >= 0)
        np.testing.assert_allclose(te[hit], tn[hit], rtol=2e-5, atol=1e-5)


@pytest.mark.parametrize("backend", ["embree", "embreex", "numpy"])
def test_rays_from_edges_and_corners_of_a_closed_box_never_leak(backend):
    if backend.startswith("embree") and not HAS_EMBREE:
        pytest.skip("embreex not importable")
    n = 4 if backend.startswith("embree") else 2
    pts, faces = grid_box(n)
    # rotate and move the box far away: float32 coordinates would be coarse without centring
    pts = pts @ rotation(1).T + np.array([1234.5, -987.0, 456.0])
    surf = Surface(pts, faces, emissivity=1.0, active=np.stack([np.ones(len(faces), bool),
                                                                 np.zeros(len(faces), bool)], 1))
    scene = TriangleScene(surf, backend)
    rng = np.random.default_rng(2)
    t = len(scene.tri_face)
    reps = 200 if backend.startswith("embree") else 20
    prim = np.repeat(np.arange(t), reps)
    # origins exactly on the vertices and edge midpoints of every triangle (the worst places), plus random points
    k = rng.integers(0, 4, prim.size)
    bary = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0]])[k]
    rnd = rng.random(prim.size) < 0.25
    bary[rnd] = rng.dirichlet([1, 1, 1], rnd.sum())
    p = np.einsum("rk,rkc->rc", bary, scene.tri_vertices[prim])
    sign = np.ones(prim.size)
    # directions: cosine law about the inward normal, a third of them grazing (1e-6 rad off the face plane)
    d = scene.scatter(prim, scene.tri_normal[prim], sign, rng.random(prim.size), rng.random(prim.size))
    graze = rng.random(prim.size) < 0.33
    nrm = scene.tri_normal[prim[graze]]
    tang = d[graze] - np.einsum("ij,ij->i", d[graze], nrm)[:, None] * nrm
    tang /= np.linalg.norm(tang, axis=1)[:, None]
    d[graze] = tang + 1e-6 * nrm
    d /= np.linalg.norm(d, axis=1)[:, None]
    o = scene.offset(prim, p, sign)
    ends, _ = trace_paths(scene, surf.optics("ir"), o, d, prim, rng, max_bounces=5)
    assert np.count_nonzero(ends == END_SPACE) == 0
    assert np.count_nonzero(ends == END_CAPPED) == 0
    # black inner sides absorb at the first hit, never on the emitting triangle itself
    assert np.all(ends >= 0)


@needs_embree
def test_closed_box_exchange_has_no_escape_and_flat_plate_sees_only_space():
    # closed box, diffuse grey walls: every ray ends on a wall (escaped exactly 0)
    pts, faces = grid_box(6)
    f = len(faces)
    surf = Surface(pts @ rotation(3).T, faces, emissivity=0.3,
                   active=np.stack([np.ones(f, bool), np.zeros(f, bool)], 1))
    groups = np.stack([np.arange(f), np.full(f, -1)], 1).ravel()
    res = trace_exchange(surf, groups, rays_per_group=500, seed=1)
    assert res.escaped.max() == 0.0 and res.blocked_fraction == 0.0
    # a flat, finely meshed plate (tilted, far from the origin) cannot see itself: its REFs to itself are exactly 0
    g = np.linspace(0, 1, 21)
    X, Y = np.meshgrid(g, g, indexing="ij")
    P = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], 1) @ rotation(4).T + 300.0
    i, j = np.meshgrid(np.arange(20), np.arange(20), indexing="ij")
    q = np.stack([i * 21 + j, (i + 1) * 21 + j, (i + 1) * 21 + j + 1, i * 21 + j + 1], -1).reshape(-1, 4)
    plate = Surface(P, q, emissivity=0.5, active=True)
    groups = np.arange(2 * len(q))
    res = trace_exchange(plate, groups, rays_per_group=200, seed=2)
    assert res.F_raw[:, :-1].nnz == 0
    np.testing.assert_array_equal(res.F_raw[:, -1].toarray().ravel(), 1.0)


@needs_embree
def test_embreex_fallback_gives_the_same_exchange_factors_statistically():
    # the batch bounce loop over embreex's wrapper (the fallback when Embree's C API is not found) and the compiled
    # C-API queries trace the same physics: a closed grey box, 2000 rays per wall; rows sum to 1 in both and the
    # REFs agree within 4 binomial standard errors
    pts, faces = grid_box(1)
    f = len(faces)
    surf = Surface(pts, faces, emissivity=0.4, active=np.stack([np.ones(f, bool), np.zeros(f, bool)], 1))
    groups = np.stack([np.arange(f), np.full(f, -1)], 1).ravel()
    a = trace_exchange(surf, groups, rays_per_group=2000, seed=3, backend="embree")
    b = trace_exchange(surf, groups, rays_per_group=2000, seed=3, backend="embreex")
    for r in (a, b):
        np.testing.assert_allclose(r.F_raw.toarray().sum(axis=1), 1.0, atol=1e-12)
    fa, fb = a.F_raw.toarray()[:, :f], b.F_raw.toarray()[:, :f]
    se = np.sqrt(np.maximum(fa * (1 - fa), 1e-4) / 2000)
    assert np.all(np.abs(fa - fb) < 4 * np.sqrt(2) * se)


class _SelfHittingEngine:
    """A numpy engine that, like float32 round-off, reports a hit on triangle ``own`` for rays starting closer than
    ``depth`` to its plane (``always``: for every ray), and the true closest hit otherwise."""

    name = "stub"

    def __init__(self, vertices, own, depth, always=False):
        self.inner = NumpyEngine(vertices)
        v = np.asarray(vertices)[own]
        n = np.cross(v[1] - v[0], v[2] - v[0])
        self.p0, self.n, self.own, self.depth, self.always = v[0], n / np.linalg.norm(n), own, depth, always
        self.queries = 0

    def intersect(self, origins, directions, out=None):
        self.queries += 1
        prim, t = self.inner.intersect(origins, directions)
        near = np.abs((origins - self.p0) @ self.n) < self.depth
        fake = near | self.always
        prim[fake], t[fake] = self.own, 1e-7
        return prim, t


def test_self_hits_are_retraced_from_pushed_origins_written_back():
    # a floor (two triangles) and a ceiling at z = 1: rays leaving floor triangle 0 upwards from 1e-12 above it
    # "hit" it until their origin is >= 10 eps off the plane; the scene re-traces them from 4, 16, ... eps, so the
    # second retry (16 eps) succeeds: prim = the ceiling, origin + t d on the ceiling, the origin moved to 16 eps
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [0, 1, 1], [1, 1, 1], [1, 0, 1]], float)
    surf = Surface(pts, [[0, 1, 2, 3], [4, 5, 6, 7]])
    scene = TriangleScene(surf, backend="numpy")
    stub = _SelfHittingEngine(scene.tri_vertices, own=0, depth=10 * scene.eps)
    scene.engine = stub
    rng = np.random.default_rng(3)
    r = 50
    o = np.column_stack([rng.random(r) * 0.2 + 0.5, rng.random(r) * 0.4 + 0.05, np.full(r, 1e-12)])  # on triangle 0
    d = np.column_stack([0.2 * rng.random(r), 0.2 * rng.random(r), np.ones(r)])
    d /= np.linalg.norm(d, axis=1)[:, None]
    o_in = o.copy()
    prim, t = scene.intersect(o, d, np.zeros(r, np.int64))
    assert np.all(prim >= 0) and np.all(surf.triangles.face[prim] == 1)  # the ceiling
    np.testing.assert_allclose((o + t[:, None] * d)[:, 2], 1.0, atol=1e-12)
    np.testing.assert_allclose(o - o_in, np.tile([0, 0, 16 * scene.eps], (r, 1)), rtol=1e-9, atol=1e-18)
    assert stub.queries == 3  # the query, then two retries of the same rays
    # a ray that hits itself whatever the push is lost: prim -1, t = -1, its origin untouched
    scene.engine = _SelfHittingEngine(scene.tri_vertices, own=0, depth=0.0, always=True)
    o = o_in.copy()
    prim, t = scene.intersect(o, d, np.zeros(r, np.int64))
    assert np.all(prim == -1) and np.all(t == -1.0)
    np.testing.assert_array_equal(o, o_in)
    # rays leaving another triangle keep the engine's answer (a hit on 0 is then not a self hit)
    prim, t = scene.intersect(o_in.copy(), d, np.ones(r, np.int64))
    assert np.all(prim == 0)
