"""Sampling kernels of the ray tracer: scrambled Halton, area-preserving triangle map, cosine-law directions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from fem2tmm.radiation._tracer_kernels import cosine_directions
from fem2tmm.radiation.sampling import HALTON_BASES, ScrambledHalton
from fem2tmm.radiation.surfaces import Surface, TriangleScene


def test_unscrambled_halton_is_scipys_sequence():
    # independent source: scipy.stats.qmc.Halton(scramble=False) is the plain radical-inverse sequence (index 0 first)
    h = ScrambledHalton(scramble=False, bases=HALTON_BASES[:6])
    ref = qmc.Halton(d=6, scramble=False).random(5000)
    np.testing.assert_allclose(h.points(np.arange(5000)), ref, rtol=0, atol=1e-15)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_scrambled_halton_keeps_elementary_box_stratification(seed):
    # Halton property (exact): n = 2^3 3^2 consecutive indices have distinct residues mod 8 and mod 9, so the first
    # three base-2 digits and first two base-3 digits take every combination once -> one point per 1/8 x 1/9 box.
    # A digit permutation per position maps elementary intervals onto elementary intervals, so scrambling and the
    # random start must keep it.
    rng = np.random.default_rng(seed)
    h = ScrambledHalton(rng)
    start = int(rng.integers(0, 2**30))
    U = h.points(start + np.arange(72))
    boxes = np.floor(U[:, 0] * 8).astype(int) * 9 + np.floor(U[:, 1] * 9).astype(int)
    assert np.array_equal(np.sort(boxes), np.arange(72))
    U = h.points(start + np.arange(175))  # 5^2 x 7 in the direction coordinates
    boxes = np.floor(U[:, 2] * 25).astype(int) * 7 + np.floor(U[:, 3] * 7).astype(int)
    assert np.array_equal(np.sort(boxes), np.arange(175))
    U = h.points(start + np.arange(121))  # 11^2 in the first-event coordinate
    assert np.array_equal(np.sort(np.floor(U[:, 4] * 121).astype(int)), np.arange(121))
    assert U.min() >= 0.0 and U.max() < 1.0


def test_scrambled_halton_discrepancy_matches_scipy_and_beats_random():
    # centred L2 discrepancy of 4-D point sets of 2048 points: ours (random start 0..2^20, as the tracer uses it)
    # must be as uniform as scipy's scrambled Halton (within 30 %) and far below pseudo-random points (> 20x).
    n, d = 2048, 4
    ours = [qmc.discrepancy(ScrambledHalton(np.random.default_rng(s), bases=HALTON_BASES[:d]).points(
        np.arange(n) + int(np.random.default_rng(100 + s).integers(0, 2**20)))) for s in range(8)]
    scipy_h = [qmc.discrepancy(qmc.Halton(d=d, seed=s).random(n)) for s in range(8)]
    rand = [qmc.discrepancy(np.random.default_rng(s).random((n, d))) for s in range(8)]
    assert np.mean(ours) < 1.3 * np.mean(scipy_h)
    assert np.mean(ours) < np.mean(rand) / 20


def test_triangle_map_is_area_preserving():
    # uniform density over the triangle: the corner sub-triangle {λ0 > 1/2} holds 1/4 of the area, and the mean of
    # the points is the centroid.  10^5 pseudo-random samples: binomial σ = sqrt(0.25 0.75 / 1e5) = 1.4e-3 -> 4σ.
    rng = np.random.default_rng(3)
    n = 100_000
    tri = np.array([[0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [1.0, 2.0, 1.0]])
    scene = TriangleScene(Surface(tri, [[0, 1, 2]]), backend="numpy")
    p, nrm = scene.sample(np.zeros(n, np.int64), rng.random(n), rng.random(n))
    np.testing.assert_allclose(nrm, np.broadcast_to(np.cross(tri[1] - tri[0], tri[2] - tri[0]), (n, 3))
                               / np.linalg.norm(np.cross(tri[1] - tri[0], tri[2] - tri[0])), atol=1e-15)
    # barycentric coordinate of p0 from the solve p = p0 + b1 e1 + b2 e2
    e = np.stack([tri[1] - tri[0], tri[2] - tri[0]], axis=1)
    b = np.linalg.lstsq(e, (p - tri[0]).T, rcond=None)[0].T
    lam0 = 1 - b.sum(axis=1)
    assert lam0.min() > -1e-12 and b.min() > -1e-12
    assert abs(np.mean(lam0 > 0.5) - 0.25) < 4 * np.sqrt(0.25 * 0.75 / n)
    spread = np.sqrt(np.var(p, axis=0) / n)
    assert np.all(np.abs(p.mean(axis=0) - tri.mean(axis=0)) < 5 * spread)


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_cosine_directions_follow_lamberts_law(side):
    # cosine law (thesis eq. 1.41) about side x normal: E[cos θ] = 2/3 and P(θ < 60°) = sin² 60° = 3/4, for any
    # normal (including normals along ±z, where the tangent frame switches branch)
    rng = np.random.default_rng(4)
    n = 200_000
    normals = rng.normal(size=(n, 3))
    normals[:100] = [0.0, 0.0, 1.0]
    normals[100:200] = [0.0, 0.0, -1.0]
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    d = cosine_directions(normals, np.full(n, side), rng.random(n), rng.random(n))
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    c = side * np.einsum("ij,ij->i", d, normals)
    assert c.min() >= 0.0
    assert abs(c.mean() - 2 / 3) < 4 * np.sqrt(1 / 18 / n)  # Var[cos θ] = 1/2 - 4/9 = 1/18
    assert abs(np.mean(c > 0.5) - 0.75) < 4 * np.sqrt(0.75 * 0.25 / n)
    # u = 0: along the (signed) normal; u -> 1, any v: in the tangent plane
    np.testing.assert_allclose(cosine_directions(normals[:50], np.full(50, side), np.zeros(50), rng.random(50)),
                               side * normals[:50], atol=1e-15)
    t = cosine_directions(normals[:300], np.full(300, side), np.ones(300), rng.random(300))
    np.testing.assert_allclose(np.einsum("ij,ij->i", t, normals[:300]), 0.0, atol=1e-12)
