"""κ studies: how fast any sampler can converge on the discontinuous integrands of the ray tracer.

* :func:`jittered_view_factor_errors`: mean |relative error| of a jittered (one uniform point per cell of an m^d
  grid) or plain random estimator of the direct view factor of the two quadrangles of thesis §2.3.5, and the
  log-log slope κ (an independent numpy implementation, no ray tracer);
* :func:`ball_indicator_errors`: scrambled Halton (and iid) points on the indicator of a 4-D and a 2-D ball of
  known volume (the sampler alone).

Used by ``fem2tmm bench rays`` (:func:`benchmarks.radiation.bench_convergence`) and checked in
``tests/test_radiation_reference.py``.
"""

from __future__ import annotations

import numpy as np

from fem2tmm.radiation.reference import TWO_QUADS, point_polygon_view_factor, polygon_plane, polygon_view_factor
from fem2tmm.radiation.smoothing import fitted_rate


# ----------------------------------------------------------------------------------------------------------------
# κ oracle: stratified estimators of the direct view factor of the two quadrangles
# ----------------------------------------------------------------------------------------------------------------

def _frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    return t, np.cross(n, t)


def _hits(origins: np.ndarray, dirs: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Whether rays (origin (r, 3) or (3,), direction (r, 3)) hit the front of the convex polygon ``target``."""
    v, n, _ = polygon_plane(target)
    den = dirs @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((v[0] - origins) @ n) / den
    ok = (den < 0) & (t > 0)
    p = origins + np.where(ok, t, 0.0)[:, None] * dirs
    for k in range(len(v)):
        edge = v[(k + 1) % len(v)] - v[k]
        ok &= np.cross(edge, p - v[k]) @ n >= 0
    return ok


def _samples(rng: np.random.Generator, m: int, dim: int, sampling: str) -> np.ndarray:
    """m^dim points in [0, 1)^dim: one uniform point in each cell of the m^dim grid (``jittered``), or iid."""
    count = m**dim
    if sampling == "random":
        return rng.random((count, dim))
    if sampling != "jittered":
        raise ValueError("sampling is 'jittered' or 'random'")
    cells = np.indices((m,) * dim).reshape(dim, -1).T
    return (cells + rng.random((count, dim))) / m


def _quad_origins(u0: np.ndarray, u1: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Uniform points on a convex quadrangle from (u0, u1) in [0,1)²: u0 picks triangle (v0 v1 v2) or (v0 v2 v3)
    in proportion to area and is rescaled to [0, 1) inside it, then the area-preserving map
    x = a + √s (1 - t)(b - a) + √s t (c - a) (thesis eq. 2.18).  Measure-preserving: the estimator is unbiased."""
    A1 = 0.5 * np.linalg.norm(np.cross(v[1] - v[0], v[2] - v[0]))
    A2 = 0.5 * np.linalg.norm(np.cross(v[2] - v[0], v[3] - v[0]))
    f = A1 / (A1 + A2)
    first = u0 < f
    s = np.where(first, u0 / f, (u0 - f) / (1 - f))
    b = np.where(first[:, None], v[1], v[2])
    c = np.where(first[:, None], v[2], v[3])
    r = np.sqrt(s)[:, None]
    return v[0] + r * (1 - u1)[:, None] * (b - v[0]) + r * u1[:, None] * (c - v[0])


def _malley(u: np.ndarray, w: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Cosine-distributed directions about n: disc point r = √u, φ = 2πw, lifted to the hemisphere."""
    t1, t2 = _frame(n)
    r, phi = np.sqrt(u), 2 * np.pi * w
    z = np.sqrt(np.maximum(1 - r * r, 0.0))
    return (r * np.cos(phi))[:, None] * t1 + (r * np.sin(phi))[:, None] * t2 + z[:, None] * n


def view_factor_estimates(m: int, seeds, sampling: str = "jittered", emitter: str = "face",
                          polygons=TWO_QUADS) -> np.ndarray:
    """Estimates of the direct view factor from ``polygons[0]`` to ``polygons[1]`` with n = m⁴ rays, one per seed.

    ``emitter="face"``: 4-D sampling (origin on face 1 by :func:`_quad_origins`, direction by Malley), ``sampling``
    jittered on the m⁴ grid or iid.  ``emitter="point"``: the emitter shrunk to the centroid of face 1 (only the
    direction matters, a 2-D integrand), jittered on the (m²)² grid, same n; the exact value is then
    :func:`point_polygon_view_factor` at the centroid."""
    v1, n1, _ = polygon_plane(polygons[0])
    out = []
    for seed in np.atleast_1d(seeds):
        rng = np.random.default_rng(int(seed))
        if emitter == "face":
            U = _samples(rng, m, 4, sampling)
            o = _quad_origins(U[:, 0], U[:, 1], v1)
            d = _malley(U[:, 2], U[:, 3], n1)
        elif emitter == "point":
            U = _samples(rng, m * m, 2, sampling)
            o = v1.mean(axis=0)[None, :]
            d = _malley(U[:, 0], U[:, 1], n1)
        else:
            raise ValueError("emitter is 'face' or 'point'")
        out.append(_hits(o, d, polygons[1]).mean())
    return np.array(out)


def jittered_view_factor_errors(ms=(4, 6, 8, 11, 16), seeds=range(200), sampling: str = "jittered",
                                emitter: str = "face") -> dict:
    """Mean |relative error| over ``seeds`` of :func:`view_factor_estimates` for n = m⁴ rays, against the exact
    direct view factor of the two quadrangles (:func:`polygon_view_factor`; for ``emitter="point"`` the Lambert
    value at the centroid of face 1), with the fitted log-log slope κ (error ∝ n^-κ), its bootstrap standard error
    over the seeds (``kappa_se``) and the local slopes.  ``sampling="random"``: iid points instead (same n).
    About 10 s for the defaults (200 seeds, n = 256 ... 65536).

    Expected: jittered 4-D κ → 1/2 + 1/8 = 0.625 (variance O(n^-(1+1/d)) for an indicator with a piecewise smooth
    boundary), random κ = 0.5, jittered 2-D (``emitter="point"``) κ → 0.75."""
    v1, n1, _ = polygon_plane(TWO_QUADS[0])
    if emitter == "point":
        exact = float(point_polygon_view_factor(v1.mean(axis=0), n1, TWO_QUADS[1])[0])
    else:
        exact = polygon_view_factor(*TWO_QUADS, order=32)
    seeds = list(seeds)
    ns = np.array([m**4 for m in ms], float)
    errs, means, sems, per_seed = [], [], [], []
    for m in ms:
        est = view_factor_estimates(m, seeds, sampling, emitter)
        per_seed.append(np.abs(est / exact - 1))
        errs.append(float(per_seed[-1].mean()))
        means.append(float(est.mean()))
        sems.append(float(est.std(ddof=1) / np.sqrt(len(est))))
    kappa, local = fitted_rate(ns, errs)
    # bootstrap over the seeds (independently per n) for the standard error of the fitted slope
    boot = np.random.default_rng(12345)
    kb = [fitted_rate(ns, [e[boot.integers(0, len(e), len(e))].mean() for e in per_seed])[0] for _ in range(200)]
    return {"sampling": sampling, "emitter": emitter, "dim": 4 if emitter == "face" else 2, "exact": exact,
            "m": list(ms), "n": [int(x) for x in ns], "seeds": len(seeds), "mean_rel_error": errs,
            "mean_estimate": means, "sem_estimate": sems, "kappa": kappa, "kappa_se": float(np.std(kb, ddof=1)),
            "kappa_local": local}


def ball_indicator_errors(dim: int, ns=(250, 1000, 4000, 16000, 64000, 256000), seeds=range(100),
                          radius: float = 0.4) -> dict:
    """The sampler alone, on an integrand with a known integral: mean |relative error| over ``seeds`` of the
    fraction of n points of the unit cube inside the ``dim``-ball of ``radius`` at its centre (volume
    π^(d/2) r^d / Γ(d/2 + 1)), for the tracer's scrambled Halton points (:class:`~fem2tmm.radiation.sampling.
    ScrambledHalton`, first ``dim`` coordinates, a random start in the sequence per seed as the tracer draws for each
    group) and for iid uniform points, with the fitted log-log slopes κ.  Like the hit/miss integrand of ray
    tracing, an indicator with a smooth curved boundary: the best rate any sampling that does not know the set can
    reach is n^-(1/2 + 1/(2d)) (0.625 in 4-D, 0.75 in 2-D), and this measures where our sampler stands against it
    with no ray tracer involved."""
    from math import gamma, pi

    from fem2tmm.radiation.sampling import HALTON_BASES, ScrambledHalton

    exact = pi ** (dim / 2) * radius**dim / gamma(dim / 2 + 1)
    ns = list(ns)
    out = {}
    for sampling in ("halton", "random"):
        errs = []
        for n in ns:
            e = []
            for s in seeds:
                rng = np.random.default_rng(np.random.SeedSequence(s, spawn_key=(n,)))
                if sampling == "halton":
                    h = ScrambledHalton(rng, bases=HALTON_BASES[:dim])
                    U = h.points(rng.integers(0, 1 << 20) + np.arange(n))
                else:
                    U = rng.random((n, dim))
                inside = np.count_nonzero(((U - 0.5) ** 2).sum(axis=1) < radius**2)
                e.append(abs(inside / n / exact - 1))
            errs.append(float(np.mean(e)))
        kappa, local = fitted_rate(ns, errs)
        out[sampling] = {"mean_rel_error": errs, "kappa": kappa, "kappa_local": local}
    return {"dim": dim, "radius": radius, "exact": exact, "n": ns, "seeds": len(list(seeds)), **out}
