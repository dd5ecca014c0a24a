"""Reciprocity and closure enforcement of raw radiative exchange factors, line-sum error, convergence rate.

Thesis §2.5.1 (eq. 2.45-2.46) and §1.3.3 (eq. 1.47).  All matrices are scipy.sparse; nothing is quadratic in the
number of groups except through the non-zeros that ray tracing actually produced.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp
from numba import njit

from ._tracer_kernels import empty_pages

RECIPROCITY_METHODS = ("linear", "fractional_variance")


def _fractional_variance_weights(rows, cols, eps_area, rays, pooled):
    """Weight w_ij = σ²_ji/(σ²_ij + σ²_ji) of the (i -> j) estimate S_ij in GR_ij = w_ij S_ij + w_ji S_ji at the
    positions (rows, cols), ``pooled`` (k,) = (S_ij + S_ji)/2 there: binomial variances of the two estimates of
    GR_ij, both evaluated at the pooled value so that a pair seen from one side only is not given zero variance on
    the unseen side (thesis §2.5.1, [300])."""
    ea_i, ea_j = eps_area[rows], eps_area[cols]
    n_i, n_j = rays[rows], rays[cols]
    with np.errstate(divide="ignore", invalid="ignore"):
        fi = np.where(ea_i > 0, pooled / ea_i, 0.0)
        fj = np.where(ea_j > 0, pooled / ea_j, 0.0)
        var_i = np.where(n_i > 0, ea_i**2 * fi * (1 - fi) / np.maximum(n_i, 1), np.inf)
        var_j = np.where(n_j > 0, ea_j**2 * fj * (1 - fj) / np.maximum(n_j, 1), np.inf)
        w = var_j / (var_i + var_j)
    w = np.where(np.isinf(var_i) & ~np.isinf(var_j), 0.0, w)
    w = np.where(np.isinf(var_j) & ~np.isinf(var_i), 1.0, w)
    return np.where(np.isfinite(w), w, 0.5)


@njit(cache=True, nogil=True, inline="always")
def _linear_weight(i, j, a, traced, exponent):
    """w_ij = ½(1 + sign(X)|X|^exponent), X = (a_j - a_i)/(a_j + a_i); X = -1 when only j traced rays, +1 when
    only i did, 0 when neither did."""
    if traced[i] and traced[j]:
        den = a[i] + a[j]
        X = (a[j] - a[i]) / den if den > 0.0 else 0.0
    elif traced[j]:
        X = -1.0
    elif traced[i]:
        X = 1.0
    else:
        X = 0.0
    return 0.5 + 0.5 * math.copysign(abs(X) ** exponent, X) if X != 0.0 else 0.5


# ---------------------------------------------------------------------------------------------------------------
# Linear reciprocity and closure in compiled passes over row ranges: column counts, weights + transposition, then
# one merge that writes GR (space column included) directly.  Every pass reads whole inputs but writes only what
# belongs to its rows r0..r1-1, so the rows are split over threads (the kernels release the GIL); the results do
# not depend on the split.  Notation: S (g, g) m² the raw exchange, M = S∘W
# (g, g) its weighted part, GR = M + Mᵀ.  M keeps the index arrays (indptr, indices) of its input with values mv;
# Mᵀ is (tp, ti, tv) in CSR form (row j of Mᵀ = column j of M, sorted).


@njit(cache=True, nogil=True)
def _column_counts(indptr, indices, g, r0, r1, counts):
    """counts (g,) int64 += number of stored entries of each column j < g in rows r0..r1-1 of a CSR matrix."""
    for q in range(indptr[r0], indptr[r1]):
        j = indices[q]
        if j < g:
            counts[j] += 1


@njit(cache=True, nogil=True)
def _weigh_transpose(indptr, indices, data, row_scale, space_scale, g, a, traced, exponent, r0, r1, slot, mv, ti,
                     tv, space_raw):
    """Rows r0..r1-1 of M_ij = w_ij (row_scale_i x_ij) for the entries x_ij of columns j < g of a CSR matrix
    (sorted columns, no duplicates), into ``mv`` (>= nnz,) at the positions of x, and scattered into Mᵀ: entry
    (i, j) goes to ``ti``/``tv`` (>= nnz(Mᵀ),) at slot[j], which is then incremented (``slot`` (g,) int64: where
    this row range starts in each row of Mᵀ; rows are visited in order, so every row of Mᵀ comes out sorted).
    The entry of column g, if any, times ``space_scale[i]`` goes to ``space_raw`` (g,) (0 when absent); later
    columns are ignored.  Per row, the weights are computed in one loop and scattered in a second one (faster than
    one fused loop)."""
    for i in range(r0, r1):
        q0, q1 = indptr[i], indptr[i + 1]
        space_raw[i] = 0.0
        while q1 > q0 and indices[q1 - 1] >= g:  # columns sorted: g and beyond come last
            if indices[q1 - 1] == g:
                space_raw[i] = space_scale[i] * data[q1 - 1]
            q1 -= 1
        si = row_scale[i]
        for q in range(q0, q1):
            mv[q] = si * data[q] * _linear_weight(i, indices[q], a, traced, exponent)
        for q in range(q0, q1):
            j = indices[q]
            s = slot[j]
            ti[s] = i
            tv[s] = mv[q]
            slot[j] = s + 1


@njit(cache=True, nogil=True)
def _merge_rows(indptr, indices, mv, tp, ti, tv, g, r0, r1, closure, eps_area, inv, blocked, space_raw, start, gp,
                gi, gv, space, lse):
    """Rows r0..r1-1 of GR = M + Mᵀ (M: ``indptr``, ``indices`` with values ``mv``, entries of columns >= g
    ignored; Mᵀ: ``tp``, ``ti``, ``tv``): row i of M and of Mᵀ (both sorted) merged, every entry M_ij + M_ji (one
    commutative addition, so GR is symmetric to the last bit; M_ij + 0 or 0 + M_ji where only one side is
    stored), zeros dropped.  ``mv`` and ``tv`` carry one extra last element 0.0 and ``ti`` one extra element: the
    merge picks the value of the side that is not at the current column from there, and steps past the end of a
    side, by index arithmetic rather than branches (which would be mispredicted about every other entry).

    With ``closure`` the rows are closed through a space column g (thesis eq. 1.47): Σ_i = Σ_j GR_ij in column
    order, LSE_i = 1 - blocked_i - inv_i Σ_i - space_raw_i and space_i = space_raw_i + LSE_i when εA_i > 0 (0
    otherwise); ``lse`` (g,) and ``space`` (g,) receive them and GR (g, g + 1) gets εA_i space_i in column g
    (``inv`` (g,) = 1/εA, 0 where εA = 0).  Without ``closure`` only the g x g GR is formed.

    The rows are written one after the other into ``gi``, ``gv`` from position ``start`` (room for at most
    nnz(M rows) + nnz(Mᵀ rows) + one space entry per row must be there), row i from gp[i]; returns the position
    after the last entry written."""
    zm, zt = mv.shape[0] - 1, tv.shape[0] - 1  # where the 0.0 sentinels are
    lastq = max(indices.shape[0] - 1, 0)  # indices is not padded: its reads are clamped
    kg = start
    for i in range(r0, r1):
        gp[i] = kg
        p, pe = indptr[i], indptr[i + 1]
        while pe > p and indices[pe - 1] >= g:
            pe -= 1
        t, te = tp[i], tp[i + 1]
        s = 0.0
        while p < pe or t < te:
            cm = np.int64(indices[min(p, lastq)])  # column of each side, g past its end
            ct = np.int64(ti[t])
            cm += (g - cm) * np.int64(p >= pe)
            ct += (g - ct) * np.int64(t >= te)
            col = min(cm, ct)
            on_m = np.int64(cm == col)
            on_t = np.int64(ct == col)
            val = mv[p * on_m + zm * (1 - on_m)] + tv[t * on_t + zt * (1 - on_t)]
            p += on_m
            t += on_t
            if val != 0.0:
                s += val
                gi[kg] = col
                gv[kg] = val
                kg += 1
        if closure:
            pos = eps_area[i] > 0.0
            lse_i = 1.0 - blocked[i] - inv[i] * s - space_raw[i] if pos else 0.0
            sp_i = space_raw[i] + lse_i if pos else 0.0
            gspace = eps_area[i] * sp_i
            if gspace != 0.0:
                gi[kg] = g
                gv[kg] = gspace
                kg += 1
            lse[i] = lse_i
            space[i] = sp_i
    return kg


def _split(cum: np.ndarray, parts: int) -> list[tuple[int, int]]:
    """``parts`` contiguous row ranges of about equal work, ``cum`` (g + 1,) the cumulative work per row."""
    g = len(cum) - 1
    cuts = np.searchsorted(cum, np.linspace(0, cum[-1], parts + 1)[1:-1]).clip(0, g) if parts > 1 else []
    b = [0, *(int(c) for c in cuts), g]
    return [(b[k], b[k + 1]) for k in range(parts)]


def _run(job, ranges: list[tuple[int, int]]) -> list:
    """``[job(k, r0, r1) for each range]``, one Python thread per range (the kernels release the GIL)."""
    if len(ranges) == 1:
        return [job(0, *ranges[0])]
    with ThreadPoolExecutor(max_workers=len(ranges)) as ex:
        return list(ex.map(lambda k: job(k, *ranges[k]), range(len(ranges))))


def _linear(A: sp.csr_matrix, row_scale, space_scale, eps_area, rays, exponent, closure, blocked, threads):
    """``(GR, space, lse)``: linear reciprocity of S = diag(``row_scale``) A[:, :g] (w_ij from ``eps_area``,
    ``rays`` (g,), ``exponent``), with ``closure`` also closed through the space column as in :func:`_merge_rows`
    (space, lse None without closure).  ``A`` (g, >= g) csr with sorted columns and no duplicates; with ``closure``
    its column g times ``space_scale`` (g,) is the raw space fraction (``blocked`` (g,)); later columns are
    ignored.  ``threads`` >= 1 Python threads; the result does not depend on it.  Scratch: M (nnz(A) + 1,) and Mᵀ
    (nnz(S) + 1,) values, Mᵀ row indices (int32)."""
    indptr, indices, data = A.indptr, A.indices, A.data
    g = A.shape[0]
    a, traced = eps_area / np.maximum(rays, 1), rays > 0
    ranges = _split(indptr, max(1, min(int(threads), g)))
    counts = np.zeros((len(ranges), g), np.int64)  # column counts of each range
    _run(lambda k, r0, r1: _column_counts(indptr, indices, g, r0, r1, counts[k]), ranges)
    tp = np.zeros(g + 1, np.int64)
    np.cumsum(counts.sum(axis=0), out=tp[1:])
    slots = tp[:-1] + np.cumsum(counts, axis=0) - counts  # where each range starts in each row of Mᵀ
    nt = int(tp[g])
    f8 = np.empty(0)
    mv = empty_pages(len(data) + 1, f8)  # + the 0.0 sentinel of _merge_rows
    mv[-1] = 0.0
    ti = empty_pages(nt + 1, np.empty(0, np.int32 if g < 2**31 - 1 else np.int64))  # + a readable last element
    ti[-1] = 0
    tv = empty_pages(nt + 1, f8)
    tv[-1] = 0.0
    space_raw = np.empty(g)
    _run(lambda k, r0, r1: _weigh_transpose(indptr, indices, data, row_scale, space_scale, g, a, traced,
                                            float(exponent), r0, r1, slots[k], mv, ti, tv, space_raw), ranges)
    del counts, slots
    return _assemble(indptr, indices, mv, tp, ti, tv, g, A.shape[1], closure, eps_area, blocked, space_raw, threads)


def _inverse(eps_area: np.ndarray) -> np.ndarray:
    """1/εA (g,), 0 where εA = 0."""
    with np.errstate(divide="ignore"):
        return np.where(eps_area > 0, 1.0 / np.where(eps_area > 0, eps_area, 1.0), 0.0)


def _assemble(indptr, indices, mv, tp, ti, tv, g, ncol, closure, eps_area, blocked, space_raw, threads):
    """``(GR, space, lse)`` from M and Mᵀ (arrays as :func:`_merge_rows` takes them) in one row-parallel merge
    pass: each row range writes into its own part of arrays sized for the most it can produce (nnz(M rows) +
    nnz(Mᵀ rows) + one space entry per row; pages never written are never touched), then the parts are moved
    together.  GR (g, ``ncol``) without closure (space, lse None); (g, g + 1) with it.  Index arrays int32 when
    they fit."""
    inv = _inverse(eps_area)
    m_rows = np.diff(indptr).astype(np.int64)  # an upper bound on each row's entries of M (columns >= g included)
    work = np.zeros(g + 1, np.int64)
    np.cumsum(m_rows + np.diff(tp) + (1 if closure else 0), out=work[1:])
    ranges = _split(work, max(1, min(int(threads), g)))
    gp = np.zeros(g + 1, np.int64)
    space, lse = (np.zeros(g), np.zeros(g)) if closure else (np.empty(0), np.empty(0))
    bound = int(work[g])
    itype = np.int32 if bound < 2**31 - 1 and g + 1 < 2**31 - 1 else np.int64
    gi, gv = empty_pages(bound, np.empty(0, itype)), empty_pages(bound, np.empty(0))
    ends = _run(lambda k, r0, r1: _merge_rows(indptr, indices, mv, tp, ti, tv, g, r0, r1, closure, eps_area, inv,
                                              blocked, space_raw, int(work[r0]), gp, gi, gv, space, lse), ranges)
    n = ends[0] - int(work[ranges[0][0]])
    for (r0, r1), end in zip(ranges[1:], ends[1:]):  # move each part down behind the previous one
        first = int(work[r0])
        if first != n:
            gi[n:n + end - first] = gi[first:end]
            gv[n:n + end - first] = gv[first:end]
            gp[r0:r1] -= first - n
        n += end - first
    gp[g] = n
    if n < 0.9 * bound:  # release the unused room (it is small when few pairs are seen from both sides)
        gi, gv = gi[:n].copy(), gv[:n].copy()
    else:
        gi, gv = gi[:n], gv[:n]
    GR = sp.csr_matrix((gv, gi, gp.astype(itype)), shape=(g, g + 1) if closure else (g, ncol))
    return (GR, space, lse) if closure else (GR, None, None)


@njit(cache=True, nogil=True)
def _refs_rows(indptr, indices, data, inv, space, g, write, fp, fi, fv):
    """Rows of F = diag(``inv``) GR[:, :g] with ``space`` (g,) as column g, zeros dropped: ``write`` False counts
    the entries of row i into fp[i + 1]; ``write`` True fills ``fi``, ``fv`` from the row pointers ``fp``."""
    for i in range(g):
        k = fp[i] if write else 0
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j < g:
                v = inv[i] * data[q]
                if v != 0.0:
                    if write:
                        fi[k] = j
                        fv[k] = v
                    k += 1
        if space[i] != 0.0:
            if write:
                fi[k] = g
                fv[k] = space[i]
            k += 1
        if not write:
            fp[i + 1] = k


@njit(cache=True, nogil=True)
def _refs_on_pattern(indptr, indices, data, inv, space, g, fv):
    """F on GR's own pattern when it is the same: fv[q] = inv_i GR_ij (j < g) or space_i (j = g).  Returns False
    (fv incomplete) as soon as an entry of F would be zero (a row with εA = 0, an underflow) or a row's space
    entry is missing from GR."""
    for i in range(g):
        has_space = False
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j < g:
                v = inv[i] * data[q]
                if v == 0.0:
                    return False
                fv[q] = v
            elif j == g:
                if space[i] == 0.0:
                    return False
                fv[q] = space[i]
                has_space = True
        if space[i] != 0.0 and not has_space:
            return False
    return True


def refs_from_gr(GR: sp.csr_matrix, eps_area: np.ndarray, space: np.ndarray) -> sp.csr_matrix:
    """The REFs F (g, g + 1) of a closed exchange: F_ij = GR_ij / εA_i for j < g and F_ig = ``space`` (g,), rows
    with εA = 0 empty, zeros dropped (sorted columns; index arrays of GR's type).  ``GR`` (g, >= g) csr with sorted
    columns.  When F has GR's pattern (every row with entries has εA > 0, the usual case) F shares GR's index
    arrays, as read-only views, and only its values are new."""
    g = GR.shape[0]
    inv = _inverse(np.asarray(eps_area, float))
    space = np.asarray(space, float)
    itype = GR.indices.dtype
    if GR.shape == (g, g + 1):
        fv = empty_pages(GR.nnz, np.empty(0))
        if _refs_on_pattern(GR.indptr, GR.indices, GR.data, inv, space, g, fv):
            ind, ptr = GR.indices.view(), GR.indptr.view()
            ind.flags.writeable = False
            ptr.flags.writeable = False
            return sp.csr_matrix((fv, ind, ptr), shape=(g, g + 1))
    fp = np.zeros(g + 1, np.int64)
    empty_i, empty_v = np.empty(0, itype), np.empty(0)
    _refs_rows(GR.indptr, GR.indices, GR.data, inv, space, g, False, fp, empty_i, empty_v)
    np.cumsum(fp, out=fp)
    fi, fv = empty_pages(fp[g], empty_i), empty_pages(fp[g], empty_v)
    _refs_rows(GR.indptr, GR.indices, GR.data, inv, space, g, True, fp, fi, fv)
    return sp.csr_matrix((fv, fi, fp.astype(itype)), shape=(g, g + 1))


@njit(cache=True, nogil=True)
def csr_rows(indptr):
    """Row index (nnz,) int64 of every stored entry of a CSR matrix with row pointers ``indptr`` (g + 1,) (empty
    rows allowed); one compiled pass (``np.repeat(arange(g), diff(indptr))`` is slow for many short rows)."""
    out = np.empty(indptr[-1], np.int64)
    for r in range(indptr.shape[0] - 1):
        for k in range(indptr[r], indptr[r + 1]):
            out[k] = r
    return out


def scale_rows(A: sp.spmatrix, x: np.ndarray) -> sp.csr_matrix:
    """diag(x) A as csr (same pattern as ``A``, whose index arrays it shares; ``x`` (g,)), in one pass."""
    A = sp.csr_matrix(A)
    return sp.csr_matrix((_scale_rows(A.indptr, A.data, np.asarray(x, np.float64)), A.indices, A.indptr),
                         shape=A.shape)


@njit(cache=True, nogil=True)
def _scale_rows(indptr, data, x):
    out = np.empty(data.shape[0])
    for r in range(indptr.shape[0] - 1):
        for q in range(indptr[r], indptr[r + 1]):
            out[q] = x[r] * data[q]
    return out


def enforce_reciprocity(S: sp.spmatrix, eps_area: np.ndarray, rays: np.ndarray, method: str = "linear",
                        exponent: float = 0.4, threads: int = 2) -> sp.csr_matrix:
    """Symmetric GR (g, g) m² from the raw exchange S_ij = (εA)_i F̃_ij (g, g) m² by linear averaging.

    GR_ij = w_ij S_ij + w_ji S_ji with w_ij + w_ji = 1; ``method`` "linear": w_ij = ½(1 + sign(X)|X|^exponent),
    X = (a_j - a_i)/(a_j + a_i), a = εA/n_rays (thesis eq. 2.45-2.46: the estimate carried by the less energetic
    rays weighs more), or "fractional_variance": w_ij = σ²_ji/(σ²_ij + σ²_ji) with binomial variances.
    ``eps_area`` (g,) m², ``rays`` (g,) rays traced per group (0 allowed: that group's estimates get no weight).
    Written as GR = M + Mᵀ with M = S∘W, so the result is symmetric to the last bit.  ``threads`` Python threads
    for the linear method (the result does not depend on it).
    """
    S = sp.csr_matrix(S, dtype=float)
    S.sum_duplicates()
    eps_area = np.asarray(eps_area, float)
    rays = np.asarray(rays, float)
    if method == "linear":
        S.sort_indices()
        g = S.shape[0]
        GR, _, _ = _linear(S, np.ones(g), np.ones(g), eps_area, rays, exponent, False, np.empty(0), threads)
        return GR
    if method != "fractional_variance":
        raise ValueError(f"unknown reciprocity method {method!r}: use one of {RECIPROCITY_METHODS}")
    U = (S + S.T).tocsr()  # pattern of S and S^T; data = S_ij + S_ji
    U.sum_duplicates()
    W = U.copy()
    W.data = _fractional_variance_weights(csr_rows(U.indptr), U.indices, eps_area, rays, 0.5 * U.data)
    M = S.multiply(W).tocsr()
    GR = (M + M.T).tocsr()
    GR.eliminate_zeros()
    return GR


def close_exchange(A: sp.spmatrix, row_scale: np.ndarray, space_scale: np.ndarray, eps_area: np.ndarray,
                   rays: np.ndarray, blocked: np.ndarray | None = None, method: str = "linear",
                   exponent: float = 0.4, threads: int = 2):
    """Reciprocity, then closure through the space column, from raw exchange data; returns ``(GR, space, lse)``.

    ``A`` (g, >= g + 1) csr: raw data whose row i scaled by ``row_scale[i]`` is the raw exchange S_i· (m²) in its
    first g columns, and whose column g scaled by ``space_scale[i]`` is the raw fraction of group i's emission
    that left to space; later columns are ignored.  (The raw REFs F_raw with row_scale = εA and space_scale = 1,
    or the ray tally with row_scale = εA/n and space_scale = 1/n.)  ``eps_area`` (g,) m², ``rays`` (g,),
    ``blocked`` (g,) the fraction of each group's rays stopped by sides that are not REF nodes (default 0).

    GR_ij = w_ij S_ij + w_ji S_ji (:func:`enforce_reciprocity`, ``method`` and ``exponent``); the line-sum error
    LSE_i = 1 - blocked_i - Σ_j GR_ij/εA_i - space_raw_i after reciprocity and before the closure adjustment
    (thesis eq. 1.47).  Closure (:func:`balance_closure`): Σ_j GR_ij/εA_i + space_i = 1 - blocked_i with every
    space_i >= 0, exactly 0 for the groups that traced rays of which none escaped (GR is then scaled symmetrically
    rather than given a fake exchange with space); otherwise space_i = space_raw_i + LSE_i where that is >= 0.
    Returns ``GR`` (g, g + 1) m² (symmetric g x g block, column g = εA_i space_i), ``space`` (g,) and ``lse`` (g,)
    (both 0 for groups with εA = 0, whose GR rows hold the other groups' share M_ji).  The REFs themselves are
    :func:`refs_from_gr`.  ``threads`` Python threads (the result does not depend on it).

    Linear method: S is weighed and transposed in one pass, then GR (with its space column) is written directly by
    one merge of M and Mᵀ (:func:`_merge_rows`).
    """
    A = sp.csr_matrix(A)
    A.sum_duplicates()  # also sorts the columns (a no-op check on canonical input)
    g = A.shape[0]
    eps_area = np.asarray(eps_area, float)
    rays = np.asarray(rays, float)
    row_scale = np.ascontiguousarray(row_scale, dtype=float)
    space_scale = np.ascontiguousarray(space_scale, dtype=float)
    blocked = np.zeros(g) if blocked is None else np.asarray(blocked, float)
    space_raw = space_scale * dense_columns(A.indptr, A.indices, A.data, g, 1)[0]
    if method == "linear":
        GR, space, lse = _linear(A, row_scale, space_scale, eps_area, rays, exponent, True, blocked, threads)
    else:
        GRb = enforce_reciprocity(scale_rows(A[:, :g], row_scale), eps_area, rays, method, exponent)
        GRb.sort_indices()  # merged with an empty transposed part
        GR, space, lse = _assemble(GRb.indptr, GRb.indices, np.append(GRb.data, 0.0), np.zeros(g + 1, np.int64),
                                   np.zeros(1, np.int32), np.zeros(1), g, g, True, eps_area, blocked, space_raw,
                                   threads)
    GR, space = balance_closure(GR, space, eps_area, blocked, closed=(rays > 0) & (space_raw == 0))
    return GR, space, lse


# ---------------------------------------------------------------------------------------------------------------
# Closure without a fake exchange with space.  After reciprocity the rows of GR rarely sum to what the rays say
# (1 - blocked); closing every row through the space column put that residual into space, negative for about half
# the rows of a closed enclosure.  Instead GR is scaled symmetrically, GR' = D GR D (D diagonal > 0, so GR' stays
# symmetric to the last bit and keeps its zeros), such that every row that lost no ray to space sums to exactly
# εA_i (1 - blocked_i) with a space REF of exactly 0; rows that did lose rays keep their estimates (d_i = 1) and
# close through space, unless that would make their space REF negative, in which case they are scaled too, down to
# a space REF of 0.  The scale factors solve d_i Σ_j GR_ij d_j = t_i by Newton's method in log d: each step solves
# (diag(R) + D GR D) x = t - R on the scaled rows (symmetric, positive definite unless a component is bipartite,
# and well conditioned: its Jacobi-scaled spectrum lies in (0, 2]) by preconditioned conjugate gradients.

#: rows whose relative closure error is below this are closed (Newton stops there)
CLOSURE_RTOL = 1e-14
#: no closure scale factor leaves [1/SCALE_BOUND, SCALE_BOUND] (consistent ray data needs about 1 ± LSE)
SCALE_BOUND = 8.0


@njit(cache=True, nogil=True)
def _scaled_matvec(indptr, indices, data, d, g, rows, v, out):
    """out[k] = d_r Σ_{j<g} GR_rj d_j v_j for r = rows[k]; ``v`` (g,) (zero outside the rows of interest)."""
    for k in range(rows.shape[0]):
        r = rows[k]
        s = 0.0
        for q in range(indptr[r], indptr[r + 1]):
            j = indices[q]
            if j < g:
                s += data[q] * (d[j] * v[j])
        out[k] = d[r] * s


@njit(cache=True, nogil=True)
def _scaled_row_sums(indptr, indices, data, d, g, rows, out):
    """out[k] = d_r Σ_{j<g} GR_rj d_j for r = rows[k] (GR in CSR form): :func:`_scaled_matvec` with v = 1."""
    _scaled_matvec(indptr, indices, data, d, g, rows, np.ones(g), out)


@njit(cache=True, nogil=True)
def _scaled_diagonal(indptr, indices, data, d, rows, out):
    """out[k] = d_r² GR_rr for r = rows[k]."""
    for k in range(rows.shape[0]):
        r = rows[k]
        out[k] = 0.0
        for q in range(indptr[r], indptr[r + 1]):
            if indices[q] == r:
                out[k] = data[q] * d[r] * d[r]


@njit(cache=True, nogil=True)
def _apply_scaling(indptr, indices, data, d, g, eps_area, blocked, inv, zero_space, space):
    """GR_ij *= d_i d_j (j < g) in place; then space_i = 0 where ``zero_space`` or εA_i = 0, else
    max(0, 1 - blocked_i - Σ_j GR_ij / εA_i), written to ``space`` (g,) and, times εA_i, to the stored entry of
    column g.  Returns the number of rows whose space value is non-zero but has no stored entry."""
    missing = 0
    for i in range(g):
        s = 0.0
        sq = -1
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j < g:
                v = data[q] * (d[i] * d[j])
                data[q] = v
                s += v
            elif j == g:
                sq = q
        sp_i = 0.0
        if eps_area[i] > 0.0 and not zero_space[i]:
            sp_i = max(0.0, 1.0 - blocked[i] - inv[i] * s)
        space[i] = sp_i
        if sq >= 0:
            data[sq] = eps_area[i] * sp_i
        elif sp_i != 0.0:
            missing += 1
    return missing


@njit(cache=True, nogil=True)
def _dot(a, b):
    """Σ a_i b_i in one compiled loop (no BLAS call: its threads contend with the tracer's on a busy machine)."""
    s = 0.0
    for i in range(a.shape[0]):
        s += a[i] * b[i]
    return s


@njit(cache=True, nogil=True)
def _pcg(indptr, indices, data, d, g, rows, R, pre, b, rtol, maxiter, v, x):
    """Jacobi-preconditioned conjugate gradients for (diag(R) + D GR D) x = b on ``rows`` (k,) (the Newton system
    of :func:`_newton_scaling`): ``R``, ``pre`` (the inverse diagonal), ``b``, ``x`` (k,); stops when
    |r| <= rtol |b| or after ``maxiter`` steps.  ``v`` (g,) zero scratch (left zero).  Returns the steps taken."""
    k = rows.shape[0]
    r = b.copy()
    x[:] = 0.0
    z = pre * r
    p = z.copy()
    q = np.empty(k)
    rz = _dot(r, z)
    stop = rtol * math.sqrt(_dot(b, b))
    it = 0
    while it < maxiter and math.sqrt(_dot(r, r)) > stop:
        for m in range(k):
            v[rows[m]] = p[m]
        _scaled_matvec(indptr, indices, data, d, g, rows, v, q)
        pq = 0.0
        for m in range(k):
            q[m] += R[m] * p[m]
            pq += p[m] * q[m]
        if not pq > 0.0:
            break
        alpha = rz / pq
        rz_new = 0.0
        for m in range(k):
            x[m] += alpha * p[m]
            r[m] -= alpha * q[m]
            z[m] = pre[m] * r[m]
            rz_new += r[m] * z[m]
        beta = rz_new / rz
        for m in range(k):
            p[m] = z[m] + beta * p[m]
        rz = rz_new
        it += 1
    for m in range(k):
        v[rows[m]] = 0.0
    return it


def _newton_scaling(GR: sp.csr_matrix, d: np.ndarray, rows: np.ndarray, target: np.ndarray) -> None:
    """Scale ``d`` (g,) on ``rows`` (k,) in place towards d_r Σ_j GR_rj d_j = ``target`` (k,) > 0 (the other d
    fixed): inexact Newton in y = log d, each step a compiled conjugate-gradient solve of (diag(R) + D GR D) x =
    t - R to a relative accuracy about the current residual (so the early steps take few matrix products and the
    convergence stays quadratic), with a backtracking line search on the RMS relative residual (steps limited to a
    factor e² per scale, every scale kept within [1/``SCALE_BOUND``, ``SCALE_BOUND``]), so that an infeasible
    target (e.g. a closed row whose only partner is a closed row with a smaller target, which consistent ray data
    cannot produce) ends at a bounded compromise instead of diverging."""
    g = GR.shape[0]
    ip, ix, dv = GR.indptr, GR.indices, GR.data
    k = rows.size
    R, diag, x = np.empty(k), np.empty(k), np.empty(k)
    v = np.zeros(g)

    def residual(scales):
        d[rows] = scales
        _scaled_row_sums(ip, ix, dv, d, g, rows, R)
        return (target - R) / target

    base = d[rows].copy()
    res = residual(base)
    for _ in range(50):
        worst = float(np.max(np.abs(res)))
        if worst <= CLOSURE_RTOL:
            return
        _scaled_diagonal(ip, ix, dv, d, rows, diag)
        pre = 1.0 / np.maximum(R + diag, np.finfo(float).tiny)
        _pcg(ip, ix, dv, d, g, rows, R, pre, target - R, min(0.1, max(worst, 1e-12)), 500, v, x)
        if not np.all(np.isfinite(x)):
            break
        step = min(1.0, 2.0 / max(float(np.max(np.abs(x))), 1e-300))
        phi = float(np.sum(res**2))
        for _ in range(40):  # backtracking
            trial = residual(np.clip(base * np.exp(step * x), 1.0 / SCALE_BOUND, SCALE_BOUND))
            if float(np.sum(trial**2)) < phi:
                break
            step *= 0.5
        else:  # no decrease: the closest closure reachable (round-off, or an infeasible target)
            break
        base, res = d[rows].copy(), trial
    residual(base)


def balance_closure(GR: sp.csr_matrix, space: np.ndarray, eps_area: np.ndarray, blocked: np.ndarray,
                    closed: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray]:
    """Close the rows of a reciprocal exchange without a fake exchange with space; returns ``(GR, space)``.

    ``GR`` (g, g + 1) csr m² with sorted columns (symmetric g x g block, column g = εA_i space_i) and ``space``
    (g,) as closed through the space column (space_i = 1 - blocked_i - Σ_j GR_ij/εA_i, any sign); ``eps_area``
    (g,) m², ``blocked`` (g,) fractions, ``closed`` (g,) bool: the rows that traced rays of which none left to
    space.  Afterwards (GR modified in place unless a row needs a new space entry):

    * GR_ij ← d_i GR_ij d_j with d > 0, so the g x g block stays symmetric to the last bit and keeps its pattern;
    * every ``closed`` row with εA > 0 sums to εA_i (1 - blocked_i) with space_i = 0 exactly;
    * every other row with εA > 0 keeps d_i = 1 and closes through space, space_i = 1 - blocked_i - Σ_j GR_ij/εA_i,
      unless that is negative: then it is scaled too, to space_i = 0;
    * rows with 1 - blocked_i = 0 exchange nothing (d_i = 0); rows with εA = 0 are not constrained.

    The scaling is the nearest multiplicative correction that keeps reciprocity: each closure residual is spread
    over the row's REFs about in proportion to their size, shared with the rows they reach.  A row that must close
    but exchanges nothing with the other groups (all its rays capped) cannot be closed; its sum stays below, as do
    rows of an infeasible block (a pattern no consistent ray data produces, see :func:`_newton_scaling`).  When no
    row needs scaling, GR and space are returned unchanged.
    """
    g = GR.shape[0]
    eps_area = np.asarray(eps_area, float)
    blocked = np.asarray(blocked, float)
    pos = eps_area > 0
    target = eps_area * (1.0 - blocked)
    closed = np.asarray(closed, bool) & pos
    dead = pos & ~(target > 0)
    if not (closed | dead).any() and not (pos & (space < 0)).any():
        return GR, space
    GR.sort_indices()
    d = np.where(dead, 0.0, 1.0)
    every = np.arange(g)
    R = np.empty(g)
    _scaled_row_sums(GR.indptr, GR.indices, GR.data, d, g, every, R)
    fixed = closed & ~dead & (R > 0)
    capped = pos & ~closed & ~dead & (R > target)
    for _ in range(10):  # active set: open rows enter when their space REF would be negative, leave when d > 1
        rows = np.flatnonzero(fixed | capped)
        if rows.size:
            _newton_scaling(GR, d, rows, target[rows])
        _scaled_row_sums(GR.indptr, GR.indices, GR.data, d, g, every, R)
        leave = capped & (d > 1)
        enter = pos & ~closed & ~dead & ~capped & (R > target * (1 + CLOSURE_RTOL))
        if not (leave.any() or enter.any()):
            break
        d[leave] = 1.0
        capped = (capped & ~leave) | enter
    new_space = np.empty(g)
    missing = _apply_scaling(GR.indptr, GR.indices, GR.data, d, g, eps_area, blocked, _inverse(eps_area),
                             closed | capped | dead, new_space)
    if missing:
        GR = sp.hstack([GR[:, :g], sp.csr_matrix((eps_area * new_space)[:, None])], format="csr")
    GR.eliminate_zeros()
    return GR, new_space


def smooth(F_raw: sp.spmatrix, eps_area: np.ndarray, rays: np.ndarray, blocked: np.ndarray | None = None,
           method: str = "linear", exponent: float = 0.4, threads: int = 2):
    """Reciprocity, then closure through the space column, of raw REFs; returns ``(F, GR, lse)``.

    ``F_raw`` (g, g + 1) raw REFs (last column space), ``eps_area`` (g,) m², ``rays`` (g,), ``blocked`` (g,) as
    in :func:`close_exchange`.  Every row of ``F`` (g, g + 1) sums to 1 - blocked_i; ``GR`` (g, g + 1) m² =
    diag(εA) F (symmetric g x g block); ``lse`` (g,) is the line-sum error before the closure adjustment.  The rows
    of F and lse of groups with εA = 0 are 0.
    """
    F_raw = sp.csr_matrix(F_raw)
    g = F_raw.shape[0]
    eps_area = np.asarray(eps_area, float)
    GR, space, lse = close_exchange(F_raw, eps_area, np.ones(g), eps_area, rays, blocked, method, exponent,
                                    threads)
    return refs_from_gr(GR, eps_area, space), GR, lse


@njit(cache=True, nogil=True)
def dense_columns(indptr, indices, data, first, count):
    """Columns ``first`` .. ``first + count - 1`` of a CSR matrix (g rows) as a dense (count, g) array (duplicate
    entries summed)."""
    g = indptr.shape[0] - 1
    out = np.zeros((count, g))
    for i in range(g):
        for q in range(indptr[i], indptr[i + 1]):
            k = indices[q] - first
            if 0 <= k < count:
                out[k, i] += data[q]
    return out


def rms(values: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Root mean square of ``values`` (over ``mask`` when given); 0 for an empty selection."""
    v = np.asarray(values, float)
    if mask is not None:
        v = v[mask]
    return float(np.sqrt(np.mean(v**2))) if v.size else 0.0


def fitted_rate(n, errors) -> tuple[float, list[float]]:
    """κ in e ∝ n^-κ fitted by least squares to (rays ``n``, ``errors``) in log-log scale, and the local rates
    between consecutive points (:func:`convergence_rate`)."""
    n, e = np.asarray(n, float), np.asarray(errors, float)
    kappa = float(-np.polyfit(np.log(n), np.log(e), 1)[0])
    return kappa, [convergence_rate(n[k], e[k], n[k + 1], e[k + 1]) for k in range(len(n) - 1)]


def convergence_rate(n1: float, e1: float, n2: float, e2: float) -> float:
    """κ in e ∝ n^-κ from two (rays, error) points (log-log slope, thesis §2.5.1); nan if undefined."""
    if not (n1 > 0 and n2 > 0 and e1 > 0 and e2 > 0 and n1 != n2):
        return float("nan")
    return float(-np.log(e2 / e1) / np.log(n2 / n1))
