"""Sharing a part's super-node budget among its regions (thesis §5.4 / §6.3).

The thesis distributes the clusters of a part "proportionally to the area and characteristic length of
each region" (p. 2466, 2570 of the seed) without a formula; what it shows is that small regions get one
cluster each and that narrow annular regions end up "divided only angularly" (Fig. 6.9).  The rule
implemented here produces exactly that and reduces to "proportional to area" for wide regions.

The rule
--------
Clusters should be roughly squares of side ``h`` (cubes for solids).  A region narrower than ``h`` cannot
hold a square; its clusters span its whole width ``w`` and have length ``h`` along it.  A shell region of
area ``A`` and width ``w`` therefore wants

    n(h) = A / (h · min(w, h))          (= A/h² if w >= h, = L/h with L = A/w if w < h),

i.e. clusters in proportion to its area when it is wide and to its *characteristic length* L when it is
narrow.  A solid region of volume ``V`` and thickness ``t`` wants ``V / (h² · min(t, h))``.  The quota of
a region is ``max(ρ n(h), 1)`` (at least one cluster each) where ρ is the region's mean weight per unit
area relative to the part's (1 with the default area/volume weights), and ``h`` is the one length for the
whole part that makes the quotas add up to the requested count (bisection; the sum is continuous and
decreasing in h).  Quotas are rounded by the largest-remainder (Hamilton) method so that the total is
exact, and a region never gets more clusters than it has elements (the surplus goes to the others).

Width and characteristic length
-------------------------------
A shell region is replaced by the *equivalent rectangle* with the same area A and perimeter P:
``L + w = P/2, L·w = A`` (a square when the region is more compact than a square, P² < 16A).  This is
exact for a straight strip and right to first order in w/L for a curved one (a narrow annulus of radii
r1 < r2 gives w ≈ r2 - r1 and L ≈ π(r1 + r2): it has no end edges), and a closed surface (no perimeter)
counts as compact.  A solid region is replaced by the
*equivalent square slab* a × a × t with the same volume V and surface S (``V = a²t``, ``S = 2a² + 4at``, a
cube when S <= 6 V^(2/3)).  Holes add perimeter, so a plate with many holes looks narrower than it is; this
only matters when a part has several regions.

Flux-driven allocation (``shape=False``)
----------------------------------------
When the super faces carry lumped solar loads (thesis §6.3, ``solar_on = "super_faces"``) the conduction
reduction is exact and the error comes from spreading each cluster's absorbed power uniformly over it: a
zero-mean load δq over a cluster of size h in a sheet of conductance kt leaves a temperature error of order
δq h²/(kt) (Poisson), i.e. proportional to the cluster's *area* and its flux deviation, not to its aspect
ratio.  The driver then passes ``shape=False`` (quotas in proportion to area only: narrow annuli are not
given clusters for their length, which is also what the thesis shows at 10 super nodes, "5 of the 6 regions
are left undivided") and a weight ``A_r (1 + σ_r/σ)`` (σ_r the region's area-weighted flux deviation, σ the
part's), which equidistributes ``(σ_r + σ) h²`` among the clusters: a cluster on a half-lit region is made
smaller than one on a uniformly lit (or dark) region.
"""

from __future__ import annotations

import numpy as np

from ..errors import Fem2TmmError


def equivalent_width(kind: str, measure: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """Width (m) of the equivalent rectangle (shells) or thickness of the equivalent square slab (solids).

    ``measure`` (r,) area m² / volume m³ of each region, ``boundary`` (r,) perimeter m / surface m².
    """
    M = np.asarray(measure, float)
    B = np.asarray(boundary, float)
    if kind == "shell":
        half = B / 2
        disc = half**2 - 4 * M
        length = np.where(disc > 0, (half + np.sqrt(np.maximum(disc, 0))) / 2, np.sqrt(M))
        length = np.maximum(length, np.sqrt(M))
        return M / length
    # solid: largest root a of f(a) = 2a² + 4V/a - S, which is increasing for a > V^(1/3)
    c = np.cbrt(M)
    slab = B > 6 * c**2
    lo, hi = c.copy(), np.maximum(c, np.sqrt(np.maximum(B, 0) / 2))  # f(hi) >= 0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        f = 2 * mid**2 + 4 * M / np.maximum(mid, 1e-300) - B
        lo = np.where(f < 0, mid, lo)
        hi = np.where(f < 0, hi, mid)
    a = np.where(slab, hi, c)
    return M / a**2


def quotas(h: float, measure: np.ndarray, width: np.ndarray, density: np.ndarray, dim: int) -> np.ndarray:
    """Real-valued cluster quota of each region for the cluster size ``h`` (see the module docstring)."""
    n = density * measure / (h ** (dim - 1) * np.minimum(width, h))
    return np.maximum(n, 1.0)


def _solve_h(target: float, measure, width, density, dim) -> np.ndarray:
    """Quotas whose sum is ``target`` (>= number of regions), by bisection on log h."""
    total = lambda h: quotas(h, measure, width, density, dim).sum()  # noqa: E731
    if target <= len(measure):
        return np.ones(len(measure))
    h = float((np.sum(density * measure) / target) ** (1.0 / dim))
    lo, hi = h, h
    while total(lo) < target:
        lo /= 2
    while total(hi) > target:
        hi *= 2
    for _ in range(100):
        mid = np.sqrt(lo * hi)
        if total(mid) > target:
            lo = mid
        else:
            hi = mid
        if hi / lo < 1 + 1e-13:
            break
    q = quotas(hi, measure, width, density, dim)
    return q * (target / q.sum())


def _round(q: np.ndarray, total: int) -> np.ndarray:
    """Largest-remainder rounding of quotas ``q`` (each >= ~1) to integers >= 1 summing to ``total``."""
    base = np.maximum(np.floor(q + 1e-9), 1).astype(np.int64)
    frac = q - base
    r = total - int(base.sum())
    if r > 0:
        order = np.argsort(-frac, kind="stable")
        base[order[:r]] += 1
    while r < 0:  # only after round-off in pathological cases
        cand = np.flatnonzero(base > 1)
        i = cand[np.argmin(frac[cand])]
        base[i] -= 1
        frac[i] += 1
        r += 1
    return base


def allocate(n_clusters: int, kind: str, measure: np.ndarray, boundary: np.ndarray, n_elements: np.ndarray,
             weight: np.ndarray | None = None, part: str = "", shape: bool = True) -> np.ndarray:
    """Number of clusters of each region of a part.

    Parameters
    ----------
    n_clusters : clusters requested for the part
    kind : "shell" or "solid"
    measure : (r,) area (m²) or volume (m³) of each region
    boundary : (r,) perimeter (m) or bounding surface (m²) of each region
    n_elements : (r,) number of elements of each region
    weight : (r,) total clustering weight of each region (default: ``measure``)
    part : the part's name, for error messages
    shape : False: ignore the regions' widths (quotas in proportion to weight only, see "Flux-driven
        allocation" above)

    Returns
    -------
    (r,) int64, each in [1, n_elements[i]], summing to ``n_clusters``.

    Raises
    ------
    Fem2TmmError
        if ``n_clusters`` is smaller than the number of regions or larger than the number of elements.
    """
    measure = np.asarray(measure, float)
    n_elements = np.asarray(n_elements, np.int64)
    r = len(measure)
    unit = {"shell": "m²", "solid": "m³", "line": "m"}[kind]
    where = f"part {part!r}: " if part else ""
    if n_clusters > n_elements.sum():
        raise Fem2TmmError(
            f"{where}{n_clusters} super nodes requested but the part has only {int(n_elements.sum())} elements; "
            f"ask for at most {int(n_elements.sum())}"
        )
    if n_clusters < r:
        order = np.argsort(-measure, kind="stable")
        listed = "; ".join(f"region {i}: {n_elements[i]} elements, {measure[i]:.4g} {unit}" for i in order[:10])
        more = f"; … ({r} in all)" if r > 10 else ""
        cause = {"shell": "sharp edges, junctions, changes of material/thickness/optics and disconnected pieces",
                 "solid": "changes of material and disconnected pieces",
                 "line": "junctions of more than two bars, changes of section/material and disconnected bars"}[kind]
        raise Fem2TmmError(
            f"{where}{n_clusters} super nodes requested but the part splits into {r} regions ({cause}); "
            f"each region needs at least one super node, so ask for at least {r}. Regions: {listed}{more}"
        )
    width = equivalent_width(kind, measure, boundary) if shape and kind != "line" else np.full(r, np.inf)
    w = measure if weight is None else np.asarray(weight, float)
    density = (w / measure) / (w.sum() / measure.sum())
    dim = {"shell": 2, "solid": 3, "line": 1}[kind]
    out = np.zeros(r, np.int64)
    free = np.ones(r, bool)
    budget = int(n_clusters)
    while True:
        q = _solve_h(budget, measure[free], width[free], density[free], dim)
        n = _round(q, budget)
        over = n > n_elements[free]
        idx = np.flatnonzero(free)
        if not over.any():
            out[idx] = n
            return out
        capped = idx[over]
        out[capped] = n_elements[capped]
        budget -= int(n_elements[capped].sum())
        free[capped] = False
