"""Monte Carlo ray tracing of radiative exchange factors (REFs): bounce loop, group tallies, accuracy control.

Thesis: MCRT without branching §1.3 (l. 664), coupled 4-D Halton sampling §2.3.5, reciprocity/closure and accuracy
control §2.5.1, super faces ch. 5.  DESIGN §3.5 and §4.4.

Two additions to the thesis' coupled sampling (both keep every ray's random numbers marginally uniform, so the
estimator n_ij / n_i is unchanged):

* the event at a ray's first hit (absorbed / reflected / transmitted) is decided by numbers stratified within each
  (source group, side hit) pair instead of independent ones;
* the direction of a ray's first diffuse reflection/transmission takes coordinates 5-6 of its Halton point.

(measurements: docs/design-notes.md, radiation/tracer.py)

Layers:

* :func:`trace_paths` - the bounce loop over a batch of rays (numpy over the batch, the scene for intersections).
  It knows nothing about groups or sources: it returns where each ray ended (side index, space, blocked, capped).
  Exchange factors (below) and, later, parallel-ray solar sources feed it their own origins and directions.
* :func:`trace_exchange` - REFs between groups of sides (FE faces or super faces) of a :class:`Surface`.
* :func:`exchange_factors` - the public convenience function of DESIGN §4.4 (front sides only).
"""

from __future__ import annotations

import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from numba import njit

from .. import _validation as check
from ..errors import Fem2TmmError
from ..progress import report
from .sampling import HALTON_BASES, ScrambledHalton
# the END_* constants are part of trace_paths' contract and re-exported here
from ._tracer_kernels import (END_BLOCKED, END_CAPPED, END_SPACE, bounce, empty_pages, hit_sides,  # noqa: F401
                      random_state, uniform)
from .smoothing import (RECIPROCITY_METHODS, close_exchange, convergence_rate, dense_columns, refs_from_gr, rms,
                        scale_rows)
from .surfaces import GroupEmitters, SideOptics, Surface, TriangleScene, pack_ints, unpack_ints

MAX_BOUNCES = 1000
SAMPLINGS = ("halton", "random")
#: coordinates of the coupled Halton point of an emitted ray: origin (2), direction (2), and the direction of its
#: first diffuse reflection or transmission (2)
HALTON_DIMS = 6
BATCH = 1 << 17
_NO_NUMBERS = (np.zeros(0), np.zeros((0, 2)))  # bounce draws its own
#: random start offsets of the groups in the Halton sequence lie in [0, HALTON_SKIP)
HALTON_SKIP = 1 << 20
PILOT_RAYS = (100, 400)
#: at most this many extrapolated runs after the pilots (the LSE rate measured at 100-400 rays is often steeper
#: than further on, so one extrapolation can fall short; the next one uses the last two runs)
EXTRAPOLATIONS = 3


_HASH = np.int64(0x61C8864680B583EB)  # an odd 64-bit constant (golden-ratio hashing)


@njit(cache=True, nogil=True)
def _first_hit_numbers(side, strata, st):
    """Event numbers (r,) of first hits stratified within each (source group, side hit) pair: the m rays of a pair
    get (rank + φ)/m, rank a random permutation of 0..m-1 and φ one uniform phase per pair (systematic sampling in
    random order), so each number is marginally U[0, 1) and the fraction of a pair's rays below any threshold p is
    within 1/m of p.  ``side`` (r,) the side each ray hit (-1: a miss, number 0), ``strata`` (r,) the
    non-decreasing source group of each ray, ``st`` the state of the kernels' generator
    (:func:`~fem2tmm.radiation._tracer_kernels.uniform`).  Linear time, run by run of equal source group (no global sort):
    the sides of a run are counted in an open-addressing table twice the run's length, the run is visited in a
    random (Fisher-Yates) order, and each ray gets the number of rays of its pair visited before it as its rank."""
    n = side.shape[0]
    u = np.zeros(n)
    order = np.empty(n, np.int64)
    slot_of = np.empty(n, np.int64)
    cap = 8
    tkey = np.empty(cap, np.int64)
    tcount = np.zeros(cap, np.int64)
    tseen = np.zeros(cap, np.int64)
    tphase = np.zeros(cap)
    used = np.zeros(cap, np.bool_)
    a = 0
    while a < n:
        b = a + 1
        while b < n and strata[b] == strata[a]:
            b += 1
        m = b - a
        while cap < 2 * m:
            cap *= 2
            tkey = np.empty(cap, np.int64)
            tcount = np.zeros(cap, np.int64)
            tseen = np.zeros(cap, np.int64)
            tphase = np.zeros(cap)
            used = np.zeros(cap, np.bool_)
        mask = cap - 1
        for i in range(a, b):  # count the rays of each side hit
            key = side[i]
            if key < 0:
                slot_of[i] = -1
                continue
            h = ((key * _HASH) >> 29) & mask  # multiplicative hashing (wrapping int64 product)
            while used[h] and tkey[h] != key:
                h = (h + 1) & mask
            if not used[h]:
                used[h] = True
                tkey[h] = key
                tcount[h] = 0
                tseen[h] = 0
                tphase[h] = uniform(st)
            tcount[h] += 1
            slot_of[i] = h
        for i in range(m):  # random visiting order of the run
            order[a + i] = a + i
        for i in range(m - 1, 0, -1):
            j = int(uniform(st) * (i + 1))
            order[a + i], order[a + j] = order[a + j], order[a + i]
        for t in range(a, b):
            i = order[t]
            h = slot_of[i]
            if h >= 0:
                u[i] = (tseen[h] + tphase[h]) / tcount[h]
                tseen[h] += 1
        for i in range(a, b):  # clear the table for the next run
            if slot_of[i] >= 0:
                used[slot_of[i]] = False
        a = b
    return u


@njit(cache=True, nogil=True)
def _batch_rays(lo, hi, start, offsets):
    """Rays lo..hi-1 of a run (rays of group g are start[g]..start[g + 1]-1): their group (r,) and their index in
    the group's Halton sequence, offsets[g] + rank within the group (r,) (``offsets`` empty: zeros)."""
    n = hi - lo
    grp = np.empty(n, np.int64)
    hidx = np.zeros(n, np.int64)
    g = np.searchsorted(start, lo, side="right") - 1
    with_offsets = offsets.shape[0] > 0
    for k in range(n):
        ray = lo + k
        while start[g + 1] <= ray:
            g += 1
        grp[k] = g
        if with_offsets:
            hidx[k] = offsets[g] + (ray - start[g])
    return grp, hidx


def trace_paths(scene: TriangleScene, optics: SideOptics, origins: np.ndarray, directions: np.ndarray,
                leaving: np.ndarray, rng: np.random.Generator, max_bounces: int = MAX_BOUNCES,
                strata: np.ndarray | None = None, first_scatter: np.ndarray | None = None, copy: bool = True):
    """Follow rays until they are absorbed, leave the model or reach ``max_bounces`` segments.

    ``origins`` (r, 3) m already offset off their surface, ``directions`` (r, 3) unit, ``leaving`` (r,) the
    primitive each ray leaves (-1 for rays from outside the model), ``optics`` of the band traced.  At each hit the
    side hit is the front when the ray travels against the face normal; an inactive side stops the ray
    (``END_BLOCKED``); otherwise one uniform number picks absorption, specular reflection, specular transmission,
    diffuse transmission or diffuse reflection in the proportions of that side's optics (thesis l. 664); diffuse
    directions follow the cosine law about the normal of the side the ray leaves.  With ``strata`` (r,) int (the
    source group of each ray), the uniform numbers of the *first* hit are stratified within each (source, side)
    pair (:func:`_first_hit_numbers`): the number of first-hit absorptions of a pair is then within one of its
    expectation instead of binomial, so the low-discrepancy emission is not drowned by absorption noise; each
    ray's number stays marginally uniform, so the estimator is unchanged.  ``first_scatter`` (r, 2) uniform
    numbers give the direction of each ray's first diffuse reflection/transmission (the last two coordinates of the
    coupled Halton point); later events draw from a generator seeded from ``rng`` inside the compiled bounce
    (:func:`~fem2tmm.radiation._tracer_kernels.uniform`).  Each bounce is one intersection query for the whole batch
    (:meth:`TriangleScene.intersect`: compiled calls of Embree's C API where available, self hits re-traced) and
    one compiled pass (:func:`fem2tmm.radiation._tracer_kernels.bounce`) that compacts the surviving rays in place
    (measurements: docs/design-notes.md, radiation/tracer.py).

    ``copy`` False lets the kernels work in ``origins`` and ``directions`` themselves (C-contiguous float64 arrays
    the caller gives up).

    Returns ``(ends (r,) int64, segments int)``: ends[k] = side index (2 face + back) that absorbed ray k, or
    ``END_SPACE`` / ``END_BLOCKED`` / ``END_CAPPED``; segments = number of intersection queries made.
    """
    n = len(origins)
    ends = np.full(n, END_CAPPED, np.int64)
    own = np.array if copy else np.ascontiguousarray  # the kernels update them in place
    o = own(origins, dtype=np.float64)
    d = own(directions, dtype=np.float64)
    last = np.ascontiguousarray(leaving, dtype=np.int64)
    rows = scene.hit_rows(optics)
    st = random_state(rng)  # the compiled kernels' own generator, seeded from rng

    idx = np.arange(n)
    # query outputs: two prim buffers in turn, as each query reads the previous one's (compacted) hits as `last`
    prim_bufs, t_buf = (np.empty(n, np.int64), np.empty(n, np.int64)), np.empty(n)
    segments = 0
    for b in range(max_bounces):
        m = idx.size
        if m == 0:
            break
        segments += m
        prim, t = scene.intersect(o, d, last, out=(prim_bufs[b % 2][:m], t_buf[:m]))
        prim = np.asarray(prim, np.int64)  # own copy when the engine's type differs; compacted in place below
        nrm = scene.hit_normals(prim, o, d, t)
        u, r2 = _NO_NUMBERS  # empty: bounce draws its own
        if b == 0 and strata is not None:  # first hit: stratified event numbers per (source, side)
            side = hit_sides(prim, d, rows, nrm)
            u = _first_hit_numbers(side, np.ascontiguousarray(strata, dtype=np.int64), st)
        if b == 0 and first_scatter is not None:
            r2 = np.asarray(first_scatter, dtype=np.float64)
        alive = bounce(prim, t, o, d, idx, ends, u, r2, st, rows, nrm, scene.eps)
        idx, o, d, last = idx[:alive], o[:alive], d[:alive], prim[:alive]
    return ends, segments


@njit(cache=True, nogil=True)
def _batch_tally(grp, ends, side_col, ncol, w, cols, counts):
    """The (energy-weighted) ray counts of a batch, row by row: for each distinct source group of the batch in turn,
    its destination columns (sorted) and counts, written to the start of ``cols`` and ``counts`` (>= r,); returns
    ``(groups, lengths)``, the distinct source groups in order (k,) and the number of distinct columns of each
    (k,).  ``grp`` (r,) non-decreasing source group, ``ends`` (r,) as returned by :func:`trace_paths`,
    ``side_col`` (2f,) the column of each absorbing side; columns g, g + 1, g + 2 (g = ncol - 3) are space,
    blocked and capped.  ``w`` (r,) ray energies, or empty for unit rays.  Each group's destinations are sorted in
    place (short runs, no global sort)."""
    r = grp.shape[0]
    g = ncol - 3
    weighted = w.shape[0] == r
    groups = np.empty(r, np.int64)
    lengths = np.empty(r, np.int64)
    dest = np.empty(r, np.int64)
    m = 0
    n_groups = 0
    a = 0
    while a < r:
        b = a + 1
        while b < r and grp[b] == grp[a]:
            b += 1
        for i in range(a, b):
            e = ends[i]
            dest[i] = side_col[e] if e >= 0 else g - 1 - e  # -1 space, -2 blocked, -3 capped
        first = m
        prev = -1
        if weighted:
            o = np.argsort(dest[a:b], kind="mergesort") + a
            for i in o:
                c = dest[i]
                if c == prev:
                    counts[m - 1] += w[i]
                else:
                    cols[m] = c
                    counts[m] = w[i]
                    m += 1
                    prev = c
        else:
            run = dest[a:b]
            run.sort()  # in place
            for c in run:
                if c == prev:
                    counts[m - 1] += 1.0
                else:
                    cols[m] = c
                    counts[m] = 1.0
                    m += 1
                    prev = c
        groups[n_groups] = grp[a]
        lengths[n_groups] = m - first
        n_groups += 1
        a = b
    return groups[:n_groups].copy(), lengths[:n_groups].copy()


@njit(cache=True, nogil=True)
def runs_to_csr(groups, lengths, starts, cols, vals, g, itmpl):
    """CSR arrays ``(indptr (g + 1,), columns, values)`` of the g-row matrix whose rows come as runs in row order:
    run k holds ``lengths[k]`` sorted, distinct columns of row ``groups[k]`` (k,) at ``cols[starts[k]:]`` with
    their values in ``vals`` (runs in increasing, non-overlapping positions, gaps allowed: the batch tallies, each
    written at its batch's first ray); the runs of a row are consecutive (a group may straddle batches).  Rows of
    one run are taken as they are; the runs of a straddling row are merged (duplicates summed).  Works in place:
    ``cols``/``vals`` are compacted and returned as their first indptr[g] entries (views, no copy)."""
    indptr = np.zeros(g + 1, itmpl.dtype)
    k_runs = groups.shape[0]
    w = 0  # write position (never past the read position: runs are in order and do not overlap)
    k = 0
    while k < k_runs:
        row = groups[k]
        e = k + 1
        total = lengths[k]
        while e < k_runs and groups[e] == row:
            total += lengths[e]
            e += 1
        if e == k + 1:  # one run: already sorted and distinct
            rd = starts[k]
            if w != rd:
                for i in range(total):
                    cols[w + i] = cols[rd + i]
                    vals[w + i] = vals[rd + i]
            w += total
        else:  # several runs: merge them
            seg_c = np.empty(total, cols.dtype)
            seg_v = np.empty(total)
            n = 0
            for q in range(k, e):
                for i in range(lengths[q]):
                    seg_c[n] = cols[starts[q] + i]
                    seg_v[n] = vals[starts[q] + i]
                    n += 1
            o = np.argsort(seg_c, kind="mergesort")
            start = w
            for i in o:
                if w > start and cols[w - 1] == seg_c[i]:
                    vals[w - 1] += seg_v[i]
                else:
                    cols[w] = seg_c[i]
                    vals[w] = seg_v[i]
                    w += 1
        indptr[row + 1] = w
        k = e
    for r in range(g):  # rows without runs
        if indptr[r + 1] < indptr[r]:
            indptr[r + 1] = indptr[r]
    return indptr, cols[:w], vals[:w]


def map_batches(job, n_batches: int, threads: int, what: str = "ray batches") -> list:
    """``[job(0), ..., job(n_batches - 1)]``, results in batch order, so a job that seeds its generator from its
    batch index gives output independent of where and in which order the batches ran.  In this process
    (the default, :mod:`fem2tmm.compute` serial) ``threads`` Python threads run the batches (numpy and Embree
    release the GIL); on a Dask executor (:func:`fem2tmm.compute.using`) a ``job`` marked ``distributable`` (a
    picklable object, e.g. :class:`_ExchangeBatches`) goes to the workers without its ray scenes
    (:func:`_detach_scenes`; the scenes once per executor, :meth:`~fem2tmm.compute.DaskExecutor.keep`) and every
    batch is one task; other jobs (closures) run here.  Progress is reported after each batch."""
    from ..compute import current

    ex = current()
    if ex.distributed and n_batches and getattr(job, "distributable", False):
        blob, scenes = _detach_scenes(job)
        kept = {f"scene{i}": ex.keep(("scene", token), scene) for i, (token, scene) in enumerate(scenes.items())}
        return ex.map(_call_detached, range(n_batches),
                      shared={"blob": (blob, {t: f"scene{i}" for i, t in enumerate(scenes)}), **kept}, what=what)
    out = []
    if threads > 1 and n_batches > 1:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            for b, r in enumerate(pool.map(job, range(n_batches))):
                out.append(r)
                report(b + 1, n_batches, what)
        return out
    for b in range(n_batches):
        out.append(job(b))
        report(b + 1, n_batches, what)
    return out


def _detach_scenes(job) -> tuple[bytes, dict]:
    """``job`` pickled with every ray scene in it replaced by its geometry digest, and those scenes by digest: the
    scenes go to the workers once per executor (:meth:`fem2tmm.compute.DaskExecutor.keep`), the rest of the job
    (optics, emitters, seeds) with each trace.  The bytes start with a random key under which each worker keeps
    the job it unpickled (:func:`_call_detached`)."""
    import io
    import pickle

    from .surfaces import TriangleScene

    scenes: dict = {}

    class _Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            if isinstance(obj, TriangleScene):
                scenes[obj.geometry_token] = obj
                return ("scene", obj.geometry_token)
            return None

    buf = io.BytesIO()
    buf.write(os.urandom(16))
    _Pickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(job)
    return buf.getvalue(), scenes


#: jobs unpickled on this worker by :func:`_call_detached`, most recent last (a trace's batches share one)
_DETACHED: dict = {}
_DETACHED_MAX = 8
_DETACHED_LOCK = threading.Lock()


def _call_detached(b: int, blob, **scenes):
    """Batch ``b`` of the job that :func:`_detach_scenes` pickled; ``blob`` is ``(bytes, {digest: name})`` and
    ``scenes`` the scattered scenes by name."""
    import io
    import pickle

    data, names = blob
    key = data[:16]
    with _DETACHED_LOCK:
        job = _DETACHED.get(key)
    if job is None:
        class _Unpickler(pickle.Unpickler):
            def persistent_load(self, pid):
                kind, token = pid
                if kind != "scene":
                    raise pickle.UnpicklingError(f"unknown persistent id {pid!r}")
                return scenes[names[token]]

        job = _Unpickler(io.BytesIO(data[16:])).load()
        with _DETACHED_LOCK:
            _DETACHED[key] = job
            while len(_DETACHED) > _DETACHED_MAX:
                _DETACHED.pop(next(iter(_DETACHED)))
    return job(b)


class _Jobs:
    """Several batch jobs as one: batch k of the whole is batch k - first[j] of job j (the jobs in order)."""

    def __init__(self, jobs, counts):
        self.jobs = list(jobs)
        self.first = np.concatenate([[0], np.cumsum(counts, dtype=np.int64)])
        self.distributable = all(getattr(job, "distributable", False) for job in self.jobs)

    def __call__(self, k: int):
        j = int(np.searchsorted(self.first, k, side="right")) - 1
        return self.jobs[j](k - int(self.first[j]))


def map_jobs(jobs, counts, threads: int, what: str = "ray batches") -> list[list]:
    """The batches of several jobs (``jobs[j]`` with ``counts[j]`` batches, e.g. the traces of every position of
    an orbit) run as one :func:`map_batches` call, so that they spread over the threads or the Dask workers
    together (a trace of one batch alone keeps one worker busy); returns each job's results in batch order, the
    same as ``[map_batches(job, n, threads) for job, n in zip(jobs, counts)]``.  The jobs are sent to the workers
    once, in one piece: objects they share (the scene, the optics) travel once."""
    whole = _Jobs(jobs, counts)
    parts = map_batches(whole, int(whole.first[-1]), threads, what)
    return [parts[int(whole.first[j]):int(whole.first[j + 1])] for j in range(len(whole.jobs))]


@dataclass(frozen=True, eq=False)
class ExchangeResult:
    """Radiative exchange factors between g groups of sides (super faces) plus space.

    ``GR`` (g, g + 1) csr m²: εA_i ℱ_ij after reciprocity and closure, symmetric g x g block, last column space.
    ``space`` (g,) ℱ to space after closure.  ``tally`` (g, g + 3) raw ray counts (columns: groups, space,
    blocked, capped; each row sums to ``rays``).  ``eps_area`` (g,) m² emissive area εA, ``area`` (g,) m² emitting
    area, ``rays`` (g,) rays traced (last run), ``lse`` (g,) line-sum error after reciprocity and before closure,
    ``lse_rms`` over the groups that traced rays, ``kappa`` convergence rate from accuracy control (None without
    ``target_lse``), ``pilot`` ((rays, lse_rms), ...) of the pilot runs, ``capped_energy_fraction`` /
    ``blocked_fraction`` (fractions of the emitted energy), ``escaped`` (g,) raw fraction of each group's rays
    that left to space, ``blocked`` (g,) raw blocked fraction, ``segments`` number of intersection queries,
    ``engine`` "embree" or "numpy", ``sampling``.

    ``F`` and ``F_raw`` are computed on first use (the pipeline needs GR only, and at 10^6 faces each REF matrix
    holds 10^8 non-zeros): ``F`` (g, g + 1) the REFs after reciprocity and closure (GR_ij / εA_i, space column
    ``space``; rows of groups with εA = 0 empty), ``F_raw`` (g, g + 1) ray counts / rays traced.
    """

    GR: sp.csr_matrix
    space: np.ndarray
    tally: sp.csr_matrix
    eps_area: np.ndarray
    area: np.ndarray
    rays: np.ndarray
    lse: np.ndarray
    lse_rms: float
    kappa: float | None
    pilot: tuple
    capped_energy_fraction: float
    blocked_fraction: float
    escaped: np.ndarray
    blocked: np.ndarray
    segments: int
    engine: str
    sampling: str

    @property
    def n_groups(self) -> int:
        return self.GR.shape[0]

    @cached_property
    def F(self) -> sp.csr_matrix:
        return refs_from_gr(self.GR, self.eps_area, self.space)

    @cached_property
    def F_raw(self) -> sp.csr_matrix:
        g = self.n_groups
        t = self.tally
        inv_n = np.where(self.rays > 0, 1.0 / np.maximum(self.rays, 1), 0.0)
        fp, fi, fv = _raw_refs(t.indptr, t.indices, t.data, g, inv_n,
                               np.empty(0, np.int32 if t.nnz < 2**31 - 1 else np.int64))
        return sp.csr_matrix((fv, fi, fp), shape=(g, g + 1))


class _ExchangeTracer:
    """Everything one exchange-factor run needs, shared read-only by the batch workers."""

    def __init__(self, surface: Surface, groups: np.ndarray, n_groups: int, backend: str,
                 scene: TriangleScene | None = None, per_side: bool = False):
        scene = TriangleScene.of(surface, scene, "trace_exchange", backend)
        self.scene = scene
        self.optics = surface.optics("ir")
        scene.hit_rows(self.optics)  # built once here, not by the first batch of every worker thread
        self._emit = np.where(surface.active, surface.emissivity, 0.0)
        self.emitters = GroupEmitters.build(self.scene, groups, self._emit, n_groups)
        self.groups = groups
        self.g = n_groups
        # tally columns: the absorbing side's group (REFs), or the side itself (per_side: absorbed-IR maps)
        self.n_cols = 2 * surface.n_faces if per_side else n_groups
        self.per_side = per_side

    def __getstate__(self):
        """Pickled (to a Dask worker) without the emitter tables, rebuilt there from the scene, ``groups`` and the
        emissive weights on first use (the same arrays)."""
        state = {k: v for k, v in self.__dict__.items() if k != "emitters"}
        return {**state, "groups": pack_ints(self.groups)}

    def __setstate__(self, state):
        self.__dict__.update({**state, "groups": unpack_ints(state["groups"])})

    def __getattr__(self, name):
        if name == "emitters" and "_emit" in self.__dict__:  # unpickled: built on first use
            self.emitters = GroupEmitters.build(self.scene, self.groups, self._emit, self.g)
            return self.emitters
        raise AttributeError(name)

    def run(self, rays: np.ndarray, sampling: str, seed, stream: int, batch: int, threads: int, max_bounces: int):
        g = self.g
        job = _ExchangeBatches(self, rays, sampling, seed, stream, batch, max_bounces)
        total = job.total
        # the batch tallies go straight into one buffer, each at its batch's first ray (a batch has at most one
        # distinct entry per ray); allocated by the compiled code: 4 KB pages, see empty_pages
        cols_buf, vals_buf = empty_pages(total, job.itmpl), empty_pages(total, np.empty(0))
        job.buffers = (cols_buf, vals_buf)
        parts = map_batches(job, job.n_batches, threads)
        job.buffers = None
        for b, p in enumerate(parts):  # tallies of batches traced elsewhere (another process): copied in place
            if p[3] is not None:
                lo_, m = b * batch, p[3][0].size
                cols_buf[lo_:lo_ + m], vals_buf[lo_:lo_ + m] = p[3]
        cat = lambda k: np.concatenate([p[0][k] for p in parts]) if parts else np.zeros(0, np.int64)  # noqa: E731
        segments = int(sum(p[1] for p in parts))
        # batches are in group order: each row's entries are consecutive runs (several when it straddles batches)
        indptr, c, v = runs_to_csr(cat(0), cat(1), cat(2), cols_buf, vals_buf, g, job.itmpl)
        if c.size < 0.9 * total:  # release the unused room
            c, v = c.copy(), v.copy()
        del cols_buf, vals_buf
        tally = sp.csr_matrix((v, c, indptr), shape=(g, job.ncol))
        rays = job.rays
        if any(p[2] is not None for p in parts):
            # weighted rays: scale each group's row so that it sums to its ray count (self-normalised estimator)
            wsum = np.zeros(g)
            for p in parts:  # loop over batches
                np.add.at(wsum, p[2][0], p[2][1])
            tally = scale_rows(tally, np.divide(rays, wsum, out=np.zeros(g), where=wsum > 0))
        return rays, tally, segments


class _ExchangeBatches:
    """The batches of one exchange run as a picklable callable: ``job(b)`` traces batch b (rays b·batch ..
    (b + 1)·batch - 1 of the run, its generator seeded from (seed, stream, b) only) and writes its tally rows into
    ``buffers`` (set by the caller in its own process), or, where unpickled (a Dask worker; the scene rebuilds
    itself there), returns them.  Returns ``((groups, lengths, starts), segments, weight sums or None, (cols,
    vals) or None)``."""

    distributable = True  # map_batches may send it to Dask workers

    def __init__(self, tracer: "_ExchangeTracer", rays, sampling: str, seed, stream: int, batch: int,
                 max_bounces: int):
        self.tracer, self.seed, self.stream, self.batch, self.max_bounces = tracer, seed, stream, batch, max_bounces
        self.rays = np.where(tracer.emitters.weight > 0, rays, 0).astype(np.int64)
        self.start = np.concatenate([[0], np.cumsum(self.rays)])
        self.total = int(self.start[-1])
        self.n_batches = math.ceil(self.total / batch) if self.total else 0
        self.sampling = sampling
        self._tables()
        self.ncol = tracer.n_cols + 3
        # column index type of the tally: int32 when it fits (scipy keeps such arrays without a copy)
        self.itmpl = np.empty(0, np.int32 if self.total < 2**31 - 1 and self.ncol < 2**31 - 1 else np.int64)
        self.buffers = None

    def _tables(self):
        """The Halton tables and start offsets (from the seed) and each side's tally column (from the groups):
        built here and again where the job is unpickled, instead of travelling with it."""
        tracer, g = self.tracer, self.tracer.g
        ss = np.random.SeedSequence(self.seed, spawn_key=(self.stream,))
        setup = np.random.default_rng(ss.spawn(1)[0])
        self.halton = self.offsets = None
        self.dims = 4
        if self.sampling == "halton":
            self.halton = ScrambledHalton(setup, bases=HALTON_BASES[:HALTON_DIMS])
            self.offsets = setup.integers(0, HALTON_SKIP, size=g)
            # coordinates 5-6 (a first diffuse direction) only when some side scatters diffusely
            self.dims = HALTON_DIMS if tracer.optics.scatters_diffusely else 4
        # destination column of an absorbing side: its group, or "blocked" when it is not a REF node (per_side: the
        # side itself, for absorbed-IR maps)
        self.side_col = (np.arange(tracer.groups.size) if tracer.per_side
                         else np.where(tracer.groups >= 0, tracer.groups, g + 1))

    def __getstate__(self):
        return {**self.__dict__, "buffers": None, "halton": None, "offsets": None, "side_col": None}

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._tables()

    def __call__(self, b: int):
        tr, batch, halton = self.tracer, self.batch, self.halton
        lo_, hi_ = b * batch, min((b + 1) * batch, self.total)
        grp, hidx = _batch_rays(lo_, hi_, self.start, np.zeros(0, np.int64) if self.offsets is None else self.offsets)
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(self.stream, 1, b)))
        U = halton.points(hidx, self.dims) if halton is not None else rng.random((grp.size, 4))
        o, d, prim, w = tr.scene.emit_group_rays(tr.emitters, grp, U)
        ends, segs = trace_paths(tr.scene, tr.optics, o, d, prim, rng, self.max_bounces,
                                 strata=grp if halton is not None else None,
                                 first_scatter=U[:, 4:6] if self.dims > 4 else None, copy=False)
        # w: relative ray energies of curved emitters (None: every ray counts 1)
        wsum = None
        if w is not None:
            g0, span = int(grp[0]), int(grp[-1]) - int(grp[0]) + 1
            wsum = (np.arange(g0, g0 + span), np.bincount(grp - g0, weights=w, minlength=span))
        here = self.buffers is not None
        cols = self.buffers[0][lo_:hi_] if here else np.empty(hi_ - lo_, self.itmpl.dtype)
        vals = self.buffers[1][lo_:hi_] if here else np.empty(hi_ - lo_)
        groups, lengths = _batch_tally(grp, ends, self.side_col, self.ncol, np.ones(0) if w is None else w, cols, vals)
        starts = lo_ + np.cumsum(lengths) - lengths
        m = int(lengths.sum())
        return (groups, lengths, starts), segs, wsum, None if here else (cols[:m].copy(), vals[:m].copy())


@njit(cache=True, nogil=True)
def _raw_refs(indptr, indices, data, g, inv_n, itmpl):
    """From the ray tally (CSR, g x (g + 3), sorted columns): the raw REFs F_raw = diag(inv_n) tally[:, :g + 1]
    as CSR arrays ``(indptr, indices, values)``, zeros dropped."""
    fp = np.zeros(g + 1, itmpl.dtype)
    for i in range(g):
        c = 0
        for q in range(indptr[i], indptr[i + 1]):
            if indices[q] <= g and data[q] != 0.0:
                c += 1
        fp[i + 1] = fp[i] + c
    fi = np.empty(fp[g], itmpl.dtype)
    fv = np.empty(fp[g])
    m = 0
    for i in range(g):
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j <= g and data[q] != 0.0:
                fi[m] = j
                fv[m] = inv_n[i] * data[q]
                m += 1
    return fp, fi, fv


def _result(tracer, rays, tally, segments, method, exponent, kappa, pilot, engine, sampling) -> ExchangeResult:
    """The smoothed result of one run: reciprocity and closure straight from the ray ``tally`` (S = diag(εA/n)
    counts); the REFs F and F_raw are derived on first use (:class:`ExchangeResult`)."""
    g = tracer.g
    w = tracer.emitters.weight
    inv_n = np.where(rays > 0, 1.0 / np.maximum(rays, 1), 0.0)
    # ray counts of the space, blocked and capped columns
    escaped_n, blocked_n, capped_n = dense_columns(tally.indptr, tally.indices, tally.data, g, 3)
    blocked, capped = blocked_n * inv_n, capped_n * inv_n
    GR, space, lse = close_exchange(tally, w * inv_n, inv_n, w, rays, blocked, method, exponent)
    traced = (rays > 0) & (w > 0)
    wt = w[traced].sum()
    frac = lambda x: float((w[traced] * x[traced]).sum() / wt) if wt > 0 else 0.0  # noqa: E731
    return ExchangeResult(
        GR=GR, space=space, tally=tally, eps_area=w, area=tracer.emitters.area, rays=rays, lse=lse,
        lse_rms=rms(lse, traced), kappa=kappa, pilot=tuple(pilot), capped_energy_fraction=frac(capped),
        blocked_fraction=frac(blocked), escaped=escaped_n * inv_n, blocked=blocked, segments=segments,
        engine=engine, sampling=sampling,
    )


def trace_exchange(surface: Surface, groups, rays_per_group=None, ray_density: float | None = None,
                   sampling: str = "halton", seed: int = 0, max_bounces: int = MAX_BOUNCES, batch: int = BATCH,
                   threads: int = 2, target_lse: float | None = None, reciprocity: str = "linear",
                   exponent: float = 0.4, backend: str = "auto",
                   scene: TriangleScene | None = None) -> ExchangeResult:
    """Radiative exchange factors between groups of sides of ``surface`` by quasi-Monte Carlo ray tracing.

    ``groups`` (2f,) int: the group (super face, REF node) of each side, -1 for sides that are not REF nodes; a
    group emits from its active member sides in proportion to ε·A, so the REF is a fraction of the group's emitted
    energy.  Ray budget: ``rays_per_group`` (int or (g,) ints) or ``ray_density`` (rays per m² of emitting area);
    default 1000 per group.  ``sampling`` "halton" (one scrambled Halton point per emitted ray: coordinates 1-2 pick
    the triangle and position through the cumulative ε·A of the group (area-preserving map), 3-4 a cosine direction
    by Malley's method, 5-6 the direction of the first diffuse reflection; a random start in the sequence per
    group; first-hit events stratified per (group, side)) or "random" (crude Monte Carlo, same estimator).  Later
    events use pseudo-random numbers.
    ``reciprocity`` "linear" (thesis eq. 2.45-2.46 with ``exponent``) or "fractional_variance".
    ``target_lse``: accuracy control (thesis end of §2.5.1): two pilot runs at mean 100 and 400 rays per group
    (the budget's shape is kept) give the convergence rate κ of the RMS line-sum error (log-log slope, clipped to
    [0.5, 1]); the budget is extrapolated to reach ``target_lse`` and traced; if the LSE reached is still above the
    target, the rate of the last two runs extrapolates again (at most ``EXTRAPOLATIONS`` runs).  The result is the
    last run; ``kappa`` is the rate of the last extrapolation and ``pilot`` lists (rays, lse_rms) of the earlier
    runs.  ``threads`` batches run concurrently; ``batch`` rays per batch.  The result depends only on the inputs,
    ``seed`` and ``batch`` (not on ``threads``).
    ``scene``: the ray scene of ``surface`` (default ``TriangleScene(surface, backend)``); curved super faces pass
    a :class:`~fem2tmm.radiation.quadric.QuadricScene`, whose emitting areas (``area``, ``eps_area``) are the true
    curved areas and whose rays may carry unequal energies (the tally of a group is then the energy-weighted count,
    scaled so that the row still sums to the rays traced).
    Returns an :class:`ExchangeResult`.
    """
    check.choice("sampling", sampling, SAMPLINGS)
    check.choice("reciprocity", reciprocity, RECIPROCITY_METHODS)
    check.positive_int("max_bounces", max_bounces)
    groups, g = check.side_groups(groups, surface.n_faces)
    tracer = _ExchangeTracer(surface, groups, g, backend, scene)
    engine = tracer.scene.engine.name
    em = tracer.emitters
    base = check.ray_budget(rays_per_group, ray_density, em.area, em.weight > 0)
    run = lambda rays, stream: tracer.run(rays, sampling, seed, stream, int(batch), int(threads), max_bounces)  # noqa: E731
    kappa, pilot = None, []
    if target_lse is None:
        rays, tally, segs = run(base, 0)
        return _result(tracer, rays, tally, segs, reciprocity, exponent, None, pilot, engine, sampling)
    if not target_lse > 0:
        raise Fem2TmmError(f"target_lse must be > 0, got {target_lse}")
    live = base > 0
    if not live.any():
        raise Fem2TmmError("no group emits: accuracy control needs at least one group with ε·A > 0")
    shape = base / base[live].mean()
    runs = []
    for k, mean_rays in enumerate(PILOT_RAYS):
        rays = np.where(live, np.maximum(1, np.round(shape * mean_rays)), 0).astype(np.int64)
        runs.append(_result(tracer, *run(rays, k + 1), reciprocity, exponent, None, [], engine, sampling))
    for k in range(EXTRAPOLATIONS):
        a, b = runs[-2], runs[-1]
        kappa = convergence_rate(a.rays.sum(), a.lse_rms, b.rays.sum(), b.lse_rms)
        kappa = 0.5 if not np.isfinite(kappa) else float(np.clip(kappa, 0.5, 1.0))
        if b.lse_rms <= target_lse:
            break
        factor = (b.lse_rms / target_lse) ** (1.0 / kappa)
        rays = np.where(live, np.ceil(b.rays * factor), 0).astype(np.int64)
        runs.append(_result(tracer, *run(rays, len(PILOT_RAYS) + 1 + k), reciprocity, exponent, None, [], engine,
                            sampling))
    last = runs[-1]
    pilot = [(int(r.rays.sum()), r.lse_rms) for r in runs[:-1]]
    return _result(tracer, last.rays, last.tally, last.segments, reciprocity, exponent, kappa, pilot, engine,
                   sampling)


def trace_absorption(surface: Surface, groups, rays_per_group=None, ray_density: float | None = None,
                     sampling: str = "halton", seed: int = 0, max_bounces: int = MAX_BOUNCES, batch: int = BATCH,
                     threads: int = 2, backend: str = "auto", scene: TriangleScene | None = None,
                     stream: int = 7) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """Where each group's emitted IR is absorbed, side by side: the per-side counterpart of the REFs.

    The groups (super faces) emit as in :func:`trace_exchange` (origins ∝ ε·A over the group, cosine directions,
    the same estimator), but each ray is tallied on the *side* that absorbs it rather than on that side's group,
    so the absorbed power can be placed on the detailed mesh where it lands (issue 21; the IR counterpart of
    ``solar_on = "detailed"``).  ``stream`` keeps these rays independent of the REF tracing of the same groups.

    Returns
    -------
    A : (g, 2f) csr, fraction of group i's emitted energy absorbed by side k (raw: ray counts / rays traced)
    rest : (g, 3) fractions that escaped to space, were blocked by inactive sides, or were capped
    eps_area : (g,) m², the emitting εA of each group
    """
    check.choice("sampling", sampling, SAMPLINGS)
    groups, g = check.side_groups(groups, surface.n_faces)
    tracer = _ExchangeTracer(surface, groups, g, backend, scene, per_side=True)
    em = tracer.emitters
    base = check.ray_budget(rays_per_group, ray_density, em.area, em.weight > 0)
    rays, tally, _ = tracer.run(base, sampling, seed, stream, int(batch), int(threads), int(max_bounces))
    inv_n = np.where(rays > 0, 1.0 / np.maximum(rays, 1), 0.0)
    frac = sp.diags(inv_n) @ tally.tocsr()
    ns = tracer.n_cols
    return frac[:, :ns].tocsr(), np.asarray(frac[:, ns:].todense()), tracer.emitters.weight.copy()


def side_fractions(groups: np.ndarray, blocked: np.ndarray, space: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per FE side, the traced fates of its emission from those of the groups (emitters) it belongs to.

    ``groups`` (2f,) emitter of each side (-1: emits nothing), ``blocked`` (g,) fraction of each emitter's rays
    stopped by inactive sides (optics ``"none"``) and ``space`` (g,) fraction that left to space (after closure).
    Returns ``(unblocked (2f,), to_space (2f,))``: 1 − blocked and the space fraction of the side's emitter (1 and 0
    for sides that emit nothing).  A blocked ray counts as never emitted (the REFs close on 1 − blocked), so a
    side's emission is εA·unblocked (:meth:`fem2tmm.fem.model.FEModel.with_unblocked`) and its emission to space
    εA·to_space: the one emission the detailed reference, the thesis' network and the radiation-aware reduction
    share."""
    groups = np.asarray(groups, np.int64)
    on = groups >= 0
    unblocked, to_space = np.ones(len(groups)), np.zeros(len(groups))
    unblocked[on] = 1.0 - np.asarray(blocked, float)[groups[on]]
    to_space[on] = np.asarray(space, float)[groups[on]]
    return unblocked, to_space


def exchange_factors(points, faces, emissivity=0.8, specular=0.0, transmissivity=0.0, super_faces=None,
                     rays_per_face=10_000, ray_density=None, sampling="halton", seed=0, *,
                     target_lse=None, threads=2, max_bounces=MAX_BOUNCES, quadric=None) -> ExchangeResult:
    """REFs between the front sides of FE faces, or of super faces (DESIGN §4.4).

    ``points`` (n, 3) m, ``faces`` (m, 3) or (m, 4) int (front side = right-hand normal; only front sides emit and
    absorb, back sides are inactive and stop rays).  ``emissivity``, ``specular`` (specular fraction of the
    reflected energy), ``transmissivity``: scalars or (m,) arrays.  ``super_faces`` (m,) int groups faces (-1: not
    a REF node); ``rays_per_face`` counts rays per emitting super face when ``super_faces`` is given and per face
    otherwise; a ``ray_density`` in rays per m² may be given instead.  ``sampling`` "halton" or "random".
    ``quadric``: True, or one bool per super face (per face without ``super_faces``): fit a quadric to the
    vertices of each selected super face (Taubin, :func:`~fem2tmm.radiation.quadric.fit_regions`) and trace
    against it (thesis ch. 5); a super face that is not a quadric raises :class:`Fem2TmmError`.
    Returns an :class:`ExchangeResult` with ``.F`` (n_sf, n_sf + 1), last column space, ``.GR`` (m²) and
    ``.lse`` (n_sf,).

    Parameters
    ----------
    points : (n, 3) float, m
    faces : (m, 3) or (m, 4) int
        Node indices; tri3 or quad4 (a triangle padded with -1 in a 4-column table).
    emissivity, specular, transmissivity : float or (m,) float
        Infrared emissivity, specular fraction of the reflected energy, transmissivity (dimensionless).
    super_faces : (m,) int, optional
        Super face of each face, -1: not a REF node; None: one node per face.
    rays_per_face : int
        Rays per emitting super face (per face without ``super_faces``).
    ray_density : float, optional
        Rays per m² instead of ``rays_per_face``.
    sampling : {"halton", "random"}
    seed : int
    target_lse : float, optional
        Accuracy control: add rays until the rms line-sum error reaches this value.
    threads : int
    max_bounces : int
        Reflections followed before a ray's remaining energy is counted as capped.
    quadric : bool or (n_sf,) bool, optional
        Trace against fitted quadrics instead of the facets.

    Returns
    -------
    ExchangeResult
        ``F`` (n_sf, n_sf + 1) REFs (last column space), ``GR`` (n_sf, n_sf + 1) m², ``lse`` (n_sf,).

    Raises
    ------
    Fem2TmmError
        Array of the wrong shape or value out of range, ``super_faces`` not one int per face, or a selected
        super face that is not a quadric.
    """
    from .surfaces import pad_faces

    faces = pad_faces(faces)
    m = len(faces)
    eps = check.per_face("emissivity", emissivity, m)
    zero = np.zeros(m)
    surface = Surface(
        points, faces,
        emissivity=np.stack([eps, zero], axis=1),
        specular=np.stack([check.per_face("specular", specular, m), zero], axis=1),
        transmissivity=np.stack([check.per_face("transmissivity", transmissivity, m), zero], axis=1),
        active=np.stack([np.ones(m, bool), np.zeros(m, bool)], axis=1),
    )
    if super_faces is None:
        sf = np.arange(m)
    else:
        sf = np.asarray(super_faces)
        if sf.shape != (m,) or not np.issubdtype(sf.dtype, np.integer):
            raise Fem2TmmError(f"super_faces must be one int per face ({m},), got {sf.shape} {sf.dtype}")
    groups = np.stack([sf.astype(np.int64), np.full(m, -1, np.int64)], axis=1).ravel()
    if ray_density is not None:
        rays_per_face = None
    scene = None
    if quadric is not None and quadric is not False:
        from .quadric_scene import QuadricScene

        n_sf = int(sf.max()) + 1 if m else 0
        sel = np.full(n_sf, bool(quadric)) if np.ndim(quadric) == 0 else np.asarray(quadric)
        if sel.shape != (n_sf,) or sel.dtype != bool:
            raise Fem2TmmError(f"quadric must be True or one bool per super face ({n_sf},), got {sel.shape} "
                               f"{sel.dtype}")
        region = np.where((sf >= 0) & sel[np.maximum(sf, 0)], sf, -1)
        scene = QuadricScene.from_regions(surface, region, names=[f"super face {i}" for i in range(n_sf)])
    return trace_exchange(surface, groups, rays_per_group=rays_per_face, ray_density=ray_density,
                          sampling=sampling, seed=seed, threads=threads, target_lse=target_lse,
                          max_bounces=max_bounces, scene=scene)
