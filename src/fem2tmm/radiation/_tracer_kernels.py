"""Compiled per-ray kernels of the ray tracer (numba, GIL released): cosine-law directions, origin offsets and the
work a bounce does between two intersection queries.

Compiled because the twenty-odd small operations a ray needs between two intersection queries cost as much as the
query itself as numpy passes (measurements: docs/design-notes.md, radiation/_tracer_kernels.py).  Every function here has one implementation, used by the exchange-factor
bounce loop, emission, solar tracing and the quadric scene alike.

Conventions (shared with :mod:`fem2tmm.radiation.surfaces`): a *side* index is ``2 * face + back``; a ray leaving a
side of sign ``s`` (+1 front, -1 back) leaves along ``s`` times the face's front normal; cosine-law directions are
built in the Duff et al. (2017) orthonormal frame of the *front* normal with the polar component multiplied by ``s``
(Malley's method, thesis §2.2.1); origins are pushed ``eps`` along ``s`` times the normal and, on flat triangles,
moved a fixed fraction of the way towards the triangle's centroid, at most ``eps`` (so an origin on a shared edge
still starts inside its own face).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .engine import prefetch


@njit(cache=True, nogil=True)
def empty_pages(n, template):
    """An uninitialised (n,) array of ``template``'s dtype allocated by the compiled runtime (malloc), for the large
    short-lived arrays of the tracer and of REF smoothing, avoiding the first-touch cost of the transparent huge
    pages numpy uses for arrays >= 4 MB (measurements: docs/design-notes.md, radiation/_tracer_kernels.py)."""
    return np.empty(n, template.dtype)


#: ends of a ray path besides "absorbed by side s >= 0" (see :func:`fem2tmm.radiation.tracer.trace_paths`)
END_SPACE, END_BLOCKED, END_CAPPED = -1, -2, -3


@njit(cache=True, nogil=True, inline="always")
def _lift(nx, ny, nz, x, y, z):
    """Malley's method: the unit-disc point (x, y) lifted onto the hemisphere, z = ±√(1 - x² - y²) along the front
    normal (nx, ny, nz) (a uniform disc point gives a cosine-law direction), in the Duff et al. frame of that
    normal."""
    sg = 1.0 if nz >= 0.0 else -1.0
    a = -1.0 / (sg + nz)
    b = nx * ny * a
    # t1 = (1 + sg nx² a, sg b, -sg nx), t2 = (b, sg + ny² a, -ny)
    dx = x * (1.0 + sg * nx * nx * a) + y * b + z * nx
    dy = x * (sg * b) + y * (sg + ny * ny * a) + z * ny
    dz = -x * sg * nx - y * ny + z * nz
    return dx, dy, dz


_OCTANT_COS = np.cos((np.arange(8) + 0.5) * math.pi / 4)
_OCTANT_SIN = np.sin((np.arange(8) + 0.5) * math.pi / 4)


@njit(cache=True, nogil=True, inline="always")
def cos_sin_turn(v):
    """(cos 2πv, sin 2πv) for v in [0, 1): the octant's centre angle (q + ½)π/4 from a table, the remainder
    |r| <= π/8 by its Taylor series to r^13 / r^14 (truncation < 1e-18), combined by the angle-sum formulas.
    Within 1e-15 of libm's cos/sin of the rounded 2πv, at ~2 ns instead of ~25 ns."""
    x = 8.0 * v
    q = min(int(x), 7)
    r = (x - q - 0.5) * (math.pi / 4)
    r2 = r * r
    sr = r * (1.0 + r2 * (-1.0 / 6 + r2 * (1.0 / 120 + r2 * (-1.0 / 5040 + r2 * (1.0 / 362880 + r2 * (
        -1.0 / 39916800 + r2 * (1.0 / 6227020800)))))))
    cr = 1.0 + r2 * (-0.5 + r2 * (1.0 / 24 + r2 * (-1.0 / 720 + r2 * (1.0 / 40320 + r2 * (-1.0 / 3628800 + r2 * (
        1.0 / 479001600 + r2 * (-1.0 / 87178291200)))))))
    return _OCTANT_COS[q] * cr - _OCTANT_SIN[q] * sr, _OCTANT_SIN[q] * cr + _OCTANT_COS[q] * sr


@njit(cache=True, nogil=True, inline="always")
def _cosine_dir(nx, ny, nz, s, u, v):
    """Cosine-law unit direction about ``s`` x (nx, ny, nz) from the unit-square sample (u, v): disc point at radius
    √u, angle 2πv (area preserving, so stratified or low-discrepancy samples stay so), lifted by :func:`_lift`."""
    r = math.sqrt(u)
    c, sn = cos_sin_turn(v)
    return _lift(nx, ny, nz, r * c, r * sn, s * math.sqrt(max(1.0 - u, 0.0)))


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1, _MIX2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)


def random_state(rng: np.random.Generator) -> np.ndarray:
    """State (1,) uint64 of the kernels' generator (:func:`uniform`), seeded from the numpy Generator ``rng``."""
    return np.array([rng.integers(0, 2**64, dtype=np.uint64)], np.uint64)


@njit(cache=True, nogil=True, inline="always")
def uniform(st):
    """Next uniform number in [0, 1) of the SplitMix64 generator whose state is ``st`` (1,) uint64 (Steele, Lea &
    Flood 2014: a Weyl sequence through a 64-bit finaliser; period 2^64, passes BigCrush).  About 1 ns per number
    inlined in a kernel, against ~6 ns for a numpy Generator called from compiled code, whose bit generator is
    reached through a function pointer."""
    z = st[0] + _GOLDEN
    st[0] = z
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    z ^= z >> _S31
    return np.float64(z >> _S11) * (1.0 / 9007199254740992.0)  # top 53 bits / 2^53


@njit(cache=True, nogil=True, inline="always")
def _random_cosine_dir(nx, ny, nz, s, st):
    """Cosine-law unit direction about ``s`` x (nx, ny, nz) from the generator state ``st`` (:func:`uniform`): a
    uniform disc point by rejection from the square (no trigonometry; 2.55 numbers on average), lifted by
    :func:`_lift`."""
    while True:
        x = 2.0 * uniform(st) - 1.0
        y = 2.0 * uniform(st) - 1.0
        if x * x + y * y < 1.0:
            return _lift(nx, ny, nz, x, y, s * math.sqrt(1.0 - x * x - y * y))


@njit(cache=True, nogil=True, inline="always")
def _offset_one(px, py, pz, nx, ny, nz, s, cx, cy, cz, shrink, eps):
    """Origin moved the fraction ``shrink`` of the way towards the triangle's centroid (cx, cy, cz) (at most
    ``eps``; 0 on curved triangles, see :meth:`~fem2tmm.radiation.surfaces.TriangleScene.bounce_tables`), then
    pushed ``eps`` along ``s`` x normal."""
    e = eps * s
    return (px + shrink * (cx - px) + e * nx, py + shrink * (cy - py) + e * ny, pz + shrink * (cz - pz) + e * nz)


@njit(cache=True, nogil=True, inline="always")
def _triangle_point(geom, j, u, v):
    """Area-preserving map (thesis eq. 2.18) of the unit-square sample (u, v) onto triangle j of ``geom`` (t, 12)
    (p0, p1 - p0, p2 - p0, unit front normal): the point (1 - √u) p0 + √u (1 - v) p1 + √u v p2."""
    s = math.sqrt(u)
    a, b = s * (1.0 - v), s * v
    return (geom[j, 0] + a * geom[j, 3] + b * geom[j, 6], geom[j, 1] + a * geom[j, 4] + b * geom[j, 7],
            geom[j, 2] + a * geom[j, 5] + b * geom[j, 8])


@njit(cache=True, nogil=True)
def sample_points(prim, u, v, geom):
    """Points (r, 3) on triangles ``prim`` (r,) of ``geom`` (t, 12) from unit-square samples ``u``, ``v`` (r,) by
    the area-preserving map (thesis eq. 2.18), and the triangles' unit front normals (r, 3)."""
    r = prim.shape[0]
    p = np.empty((r, 3))
    n = np.empty((r, 3))
    for k in range(r):
        j = prim[k]
        p[k, 0], p[k, 1], p[k, 2] = _triangle_point(geom, j, u[k], v[k])
        n[k, 0], n[k, 1], n[k, 2] = geom[j, 9], geom[j, 10], geom[j, 11]
    return p, n


@njit(cache=True, nogil=True, inline="always")
def _emit_one(j, sign, u0, u1, u2, u3, geom, centroid, shrink, eps):
    """One emitted ray from side ``sign`` of flat triangle ``j``: origin by the area-preserving map of (u0, u1)
    (thesis eq. 2.18), offset off the side; cosine-law direction from (u2, u3).  Returns (origin, direction)."""
    px, py, pz = _triangle_point(geom, j, u0, u1)
    nx, ny, nz = geom[j, 9], geom[j, 10], geom[j, 11]
    dx, dy, dz = _cosine_dir(nx, ny, nz, sign, u2, u3)
    ox, oy, oz = _offset_one(px, py, pz, nx, ny, nz, sign, centroid[j, 0], centroid[j, 1], centroid[j, 2], shrink[j],
                             eps)
    return ox, oy, oz, dx, dy, dz


@njit(cache=True, nogil=True)
def emit_rays(prim, sign, U, geom, centroid, shrink, eps):
    """Emitted rays from flat triangles ``prim`` (r,), sides ``sign`` (r,), driven by the unit-hypercube samples
    ``U`` (r, >= 4): origins by the area-preserving map of U[:, 0:2] (thesis eq. 2.18), offset off the side;
    cosine-law directions from U[:, 2:4].  ``geom`` (t, 12): per-triangle p0, p1 - p0, p2 - p0 and the unit front
    normal.  Returns ``(origins (r, 3) m, unit directions (r, 3))``."""
    r = prim.shape[0]
    o = np.empty((r, 3))
    d = np.empty((r, 3))
    for k in range(r):
        o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2] = _emit_one(prim[k], sign[k], U[k, 0], U[k, 1], U[k, 2],
                                                                         U[k, 3], geom, centroid, shrink, eps)
    return o, d


_ONE_MINUS = float(np.nextafter(1.0, 0.0))


@njit(cache=True, nogil=True, inline="always")
def _locate_one(g, u, start, lo, hi):
    """Entry of group ``g`` whose keyed interval [lo[k], hi[k]) holds g + u (binary search within the group's
    entries ``start[g]:start[g + 1]``), and u rescaled to [0, 1) within it."""
    x = g + u
    a, b = start[g], start[g + 1] - 1  # first entry with hi > x, at most the group's last
    while a < b:
        mid = (a + b) // 2
        if hi[mid] > x:
            b = mid
        else:
            a = mid + 1
    w = hi[a] - lo[a]
    v = (x - lo[a]) / w if w > 0.0 else 0.0
    return a, min(max(v, 0.0), _ONE_MINUS)


@njit(cache=True, nogil=True)
def locate_entries(group, u, start, lo, hi):
    """Inverse-CDF step of super-face emission: for rays of ``group`` (r,) with first sample coordinate ``u`` (r,),
    the entry k of the group whose keyed interval [lo[k], hi[k]) holds group + u (binary search within the
    group's entries ``start[g]:start[g + 1]``) and u rescaled to [0, 1) within it.  Returns ``(k (r,), u (r,))``."""
    r = group.shape[0]
    k_out = np.empty(r, np.int64)
    u_out = np.empty(r)
    for i in range(r):
        k_out[i], u_out[i] = _locate_one(group[i], u[i], start, lo, hi)
    return k_out, u_out


@njit(cache=True, nogil=True)
def emit_groups(group, U, start, lo, hi, entry_prim, entry_side, geom, centroid, shrink, eps):
    """:func:`locate_entries` and :func:`emit_rays` in one pass: rays of super faces ``group`` (r,) from their
    samples ``U`` (r, >= 4) (U[:, 0] picks the emitting triangle and side through the group's cumulative ε·A and is
    rescaled within it, U[:, 1] the position, U[:, 2:4] the direction).  Returns ``(origins (r, 3), directions
    (r, 3), triangles (r,))``."""
    r = group.shape[0]
    o = np.empty((r, 3))
    d = np.empty((r, 3))
    prim = np.empty(r, np.int64)
    for k in range(r):
        e, u0 = _locate_one(group[k], U[k, 0], start, lo, hi)
        j = entry_prim[e]
        prim[k] = j
        o[k, 0], o[k, 1], o[k, 2], d[k, 0], d[k, 1], d[k, 2] = _emit_one(j, 1.0 - 2.0 * entry_side[e], u0, U[k, 1],
                                                                         U[k, 2], U[k, 3], geom, centroid, shrink,
                                                                         eps)
    return o, d, prim


@njit(cache=True, nogil=True)
def cosine_directions(normals, sign, u, v):
    """Cosine-law unit directions (r, 3) about ``sign`` (r,) (+1 / -1) times the unit front ``normals`` (r, 3),
    from the unit-square samples ``u``, ``v`` (r,)."""
    r = normals.shape[0]
    out = np.empty((r, 3))
    for k in range(r):
        out[k, 0], out[k, 1], out[k, 2] = _cosine_dir(normals[k, 0], normals[k, 1], normals[k, 2], sign[k], u[k],
                                                      v[k])
    return out


@njit(cache=True, nogil=True)
def offset_points(prim, points, sign, normals, centroid, shrink, eps):
    """Ray origins (r, 3) for rays leaving ``points`` (r, 3) of primitives ``prim`` (r,) into side ``sign`` (r,):
    pushed ``eps`` (m) along sign x ``normals`` (r, 3) after moving the fraction ``shrink[prim]`` (t,) of the way
    towards ``centroid[prim]`` (t, 3).  ``points`` is overwritten and returned."""
    for k in range(prim.shape[0]):
        j = prim[k]
        points[k, 0], points[k, 1], points[k, 2] = _offset_one(
            points[k, 0], points[k, 1], points[k, 2], normals[k, 0], normals[k, 1], normals[k, 2], sign[k],
            centroid[j, 0], centroid[j, 1], centroid[j, 2], shrink[j], eps)
    return points


#: one row per triangle for the compiled bounce (:meth:`~fem2tmm.radiation.surfaces.TriangleScene.hit_rows`), 16
#: floats (128 bytes, aligned: two cache lines): unit front normal (0:3), owning face (3), the front side's optics
#: (4:8) and the back side's (8:12), each (stop probability, cumulative probabilities of specular reflection,
#: specular transmission, diffuse transmission) (:attr:`~fem2tmm.radiation.surfaces.SideOptics.rows`), centroid
#: (12:15), shrink (15).  An inactive side's stop probability is 2: it stops every ray.
HIT_ROW = 16
_FACE, _OPTICS, _CENTROID, _SHRINK = 3, 4, 12, 15
#: rays ahead whose hit rows :func:`bounce` and :func:`hit_sides` prefetch (one random row per ray)
PREFETCH_AHEAD = 16


@njit(cache=True, nogil=True, inline="always")
def _prefetch_hit(rows, prim, k):
    """Prefetch both cache lines of the hit row of ray k + PREFETCH_AHEAD."""
    if k + PREFETCH_AHEAD < prim.shape[0]:
        ahead = prim[k + PREFETCH_AHEAD]
        if ahead >= 0:
            prefetch(rows, ahead, 0)
            prefetch(rows, ahead, 8)


@njit(cache=True, nogil=True)
def hit_sides(prim, d, rows, ray_normal):
    """Side index (r,) hit by each ray (2 face + 1 when it arrives on the back, i.e. along the front normal), -1 on
    a miss; ``rows`` the scene's hit rows (t, 16), ``ray_normal`` (r, 3) overrides the triangle normals when it has
    r rows (curved hits)."""
    r = prim.shape[0]
    own = ray_normal.shape[0] == r
    out = np.full(r, -1, np.int64)
    for k in range(r):
        _prefetch_hit(rows, prim, k)
        j = prim[k]
        if j < 0:
            continue
        if own:
            c = d[k, 0] * ray_normal[k, 0] + d[k, 1] * ray_normal[k, 1] + d[k, 2] * ray_normal[k, 2]
        else:
            c = d[k, 0] * rows[j, 0] + d[k, 1] * rows[j, 1] + d[k, 2] * rows[j, 2]
        out[k] = 2 * np.int64(rows[j, _FACE]) + (1 if c > 0.0 else 0)
    return out


@njit(cache=True, nogil=True)
def bounce(prim, t, o, d, idx, ends, u, r2, st, rows, ray_normal, eps):
    """One bounce of a batch of rays, after their intersection query (thesis l. 664, MCRT without branching).

    ``prim`` (r,) primitive hit (-1: miss), ``t`` (r,) distance (m; a miss with t <= 0 is a ray lost to an
    unresolvable self hit and stays ``END_CAPPED``), ``o``/``d`` (r, 3) origins (m) and unit directions, ``idx``
    (r,) ray ids into ``ends`` (n,) (written for every ray that stops here).  Random numbers: ``u`` (r,) the event
    numbers and ``r2`` (r, 2) the numbers of a diffuse direction (:func:`_cosine_dir`); either, when empty, is
    drawn here from the generator state ``st`` (:func:`uniform`: the event number of each ray that hits, a
    rejection-sampled disc point for a diffuse event, :func:`_random_cosine_dir`).  Scene and optics: ``rows``
    (t, 16) one hit row per triangle (:data:`HIT_ROW`), ``ray_normal`` (r, 3) front normals at the hit points when
    it has r rows (curved hits; ignored otherwise), ``eps`` origin offset (m).

    At the hit: the side is the front when the ray travels against the normal; u < stop[side] ends the ray
    (absorbed by an active side, ``END_BLOCKED`` by an inactive one, whose stop probability is 2); otherwise u picks
    specular reflection, specular transmission, diffuse transmission or diffuse reflection; diffuse directions
    follow the cosine law about the normal of the side the ray leaves; the new origin is offset off that side.

    The surviving rays are compacted, in place and in order, into the first n_alive rows of ``idx``, ``o``, ``d``
    (offset origins, new directions) and ``prim`` (the primitive each one leaves); returns n_alive.  (Row m <= k is
    written only after row k was read, so compacting in place is safe.)  The hit row of the ray ``PREFETCH_AHEAD``
    places later is prefetched: with one random row per ray the loop otherwise waits on memory
    (measurements: docs/design-notes.md, radiation/_tracer_kernels.py).
    """
    r = prim.shape[0]
    own = ray_normal.shape[0] == r
    given = u.shape[0] == r
    given_dir = r2.shape[0] == r
    m = 0
    for k in range(r):
        _prefetch_hit(rows, prim, k)
        j = prim[k]
        if j < 0:
            if t[k] > 0.0:
                ends[idx[k]] = END_SPACE
            continue
        if own:
            nx, ny, nz = ray_normal[k, 0], ray_normal[k, 1], ray_normal[k, 2]
        else:
            nx, ny, nz = rows[j, 0], rows[j, 1], rows[j, 2]
        dx, dy, dz = d[k, 0], d[k, 1], d[k, 2]
        cos_in = dx * nx + dy * ny + dz * nz
        back = cos_in > 0.0
        c = _OPTICS + 4 if back else _OPTICS
        uk = u[k] if given else uniform(st)
        stop = rows[j, c]
        if uk < stop:
            ends[idx[k]] = 2 * np.int64(rows[j, _FACE]) + (1 if back else 0) if stop <= 1.0 else END_BLOCKED
            continue
        spec_r = uk < rows[j, c + 1]
        trans = (not spec_r) and uk < rows[j, c + 3]
        s = -1.0 if back != trans else 1.0
        if uk >= rows[j, c + 2]:  # diffuse reflection or transmission
            if given_dir:
                ex, ey, ez = _cosine_dir(nx, ny, nz, s, r2[k, 0], r2[k, 1])
            else:
                ex, ey, ez = _random_cosine_dir(nx, ny, nz, s, st)
        elif spec_r:
            c2 = 2.0 * cos_in
            ex, ey, ez = dx - c2 * nx, dy - c2 * ny, dz - c2 * nz
        else:  # specular transmission
            ex, ey, ez = dx, dy, dz
        tk = t[k]
        o[m, 0], o[m, 1], o[m, 2] = _offset_one(o[k, 0] + tk * dx, o[k, 1] + tk * dy, o[k, 2] + tk * dz, nx, ny, nz,
                                                s, rows[j, _CENTROID], rows[j, _CENTROID + 1],
                                                rows[j, _CENTROID + 2], rows[j, _SHRINK], eps)
        d[m, 0], d[m, 1], d[m, 2] = ex, ey, ez
        idx[m] = idx[k]
        prim[m] = j
        m += 1
    return m
