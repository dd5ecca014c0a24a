"""Property tests of the clustering (issue 3): exact counts, contiguity and never-longer smoothing on random
and structured tri, quad, tet and hex meshes.

The reference for contiguity is independent of the package: element adjacency rebuilt with Python dicts
(``naive_links`` in test_cluster.py) and connectivity checked with networkx.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from fem2tmm.cluster import PartInput, cluster_parts, partition
from fem2tmm.mesh.elements import TYPE_CODE
from test_cluster import assert_partition_ok, cut_length

SETTINGS = settings(max_examples=25, deadline=None)


def random_tri(seed: int, n: int):
    rng = np.random.default_rng(seed)
    P = rng.random((n, 2))
    tri = Delaunay(P).simplices
    # flat: Delaunay hull slivers on a curved surface may really tilt by more than the feature angle
    return np.c_[P, np.zeros(n)], tri


def jittered_quads(seed: int, nx: int, ny: int):
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0), indexing="ij")
    P = np.c_[x.ravel(), y.ravel()] + rng.uniform(-0.25, 0.25, ((nx + 1) * (ny + 1), 2))
    g = np.arange(P.shape[0]).reshape(nx + 1, ny + 1)
    quads = np.stack([g[:-1, :-1], g[1:, :-1], g[1:, 1:], g[:-1, 1:]], -1).reshape(-1, 4)
    return np.c_[P, 0.02 * P[:, 0] ** 2], quads  # a gently curved surface


def random_tets(seed: int, n: int):
    rng = np.random.default_rng(seed)
    P = rng.random((n, 3))
    return P, Delaunay(P).simplices


def jittered_hexes(seed: int, nx: int, ny: int, nz: int):
    rng = np.random.default_rng(seed)
    x, y, z = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0), np.arange(nz + 1.0), indexing="ij")
    P = np.c_[x.ravel(), y.ravel(), z.ravel()] + rng.uniform(-0.2, 0.2, (x.size, 3))
    g = np.arange(x.size).reshape(x.shape)
    c = [g[:-1, :-1, :-1], g[1:, :-1, :-1], g[1:, 1:, :-1], g[:-1, 1:, :-1],
         g[:-1, :-1, 1:], g[1:, :-1, 1:], g[1:, 1:, 1:], g[:-1, 1:, 1:]]
    return P, np.stack(c, -1).reshape(-1, 8)


@SETTINGS
@given(seed=st.integers(0, 10**6), n=st.integers(6, 80), frac=st.floats(0, 1))
def test_random_triangles(seed, n, frac):
    pts, tri = random_tri(seed, n)
    k = 1 + int(frac * (min(len(tri), 25) - 1))
    assert_partition_ok(pts, tri, partition(pts, tri, k, seed=seed), k)


@SETTINGS
@given(seed=st.integers(0, 10**6), nx=st.integers(1, 12), ny=st.integers(1, 12), frac=st.floats(0, 1))
def test_structured_quads(seed, nx, ny, frac):
    pts, quads = jittered_quads(seed, nx, ny)
    k = 1 + int(frac * (len(quads) - 1))  # up to one cluster per element
    assert_partition_ok(pts, quads, partition(pts, quads, k, seed=seed), k)


@SETTINGS
@given(seed=st.integers(0, 10**6), n=st.integers(8, 50), frac=st.floats(0, 1))
def test_random_tets(seed, n, frac):
    pts, tets = random_tets(seed, n)
    k = 1 + int(frac * (min(len(tets), 20) - 1))
    assert_partition_ok(pts, tets, partition(pts, tets, k, kind="solid", seed=seed), k, kind="solid")


@SETTINGS
@given(seed=st.integers(0, 10**6), nx=st.integers(1, 5), ny=st.integers(1, 5), nz=st.integers(1, 4),
       frac=st.floats(0, 1))
def test_structured_hexes(seed, nx, ny, nz, frac):
    pts, hexes = jittered_hexes(seed, nx, ny, nz)
    k = 1 + int(frac * (len(hexes) - 1))
    assert_partition_ok(pts, hexes, partition(pts, hexes, k, kind="solid", seed=seed), k, kind="solid")


@SETTINGS
@given(seed=st.integers(0, 10**6), n=st.integers(20, 150), k=st.integers(2, 12), layers=st.integers(1, 3))
def test_smoothing_never_lengthens_the_boundary(seed, n, k, layers):
    pts, tri = random_tri(seed, n)
    k = min(k, len(tri))
    part = PartInput("t", "shell", np.arange(len(tri)), np.c_[tri, -np.ones((len(tri), 5), int)],
                     np.full(len(tri), TYPE_CODE["tri3"], np.int8), k)
    res = cluster_parts(pts, [part], len(tri), seed=seed, smoothing_layers=layers)
    rep = res.report["parts"][0]
    raw = cluster_parts(pts, [part], len(tri), seed=seed, smoothing_layers=0)
    # before = the cut of the unsmoothed growing (same seeds), recomputed naively; after <= before
    assert abs(rep["boundary_before"] - cut_length(pts, tri, raw.labels)) < 1e-9
    assert abs(rep["boundary_after"] - cut_length(pts, tri, res.labels)) < 1e-9
    assert rep["boundary_after"] <= rep["boundary_before"] + 1e-12
    assert_partition_ok(pts, tri, res.labels, k)
