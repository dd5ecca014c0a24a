"""Reciprocity and closure enforcement of raw radiative exchange factors, line-sum error, convergence rate.

Thesis §2.5.1 (eq. 2.45-2.46) and §1.3.3 (eq. 1.47).  All matrices are scipy.sparse; nothing is quadratic in the
number of groups except through the non-zeros that ray tracing actually produced.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from numba import njit

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


@njit(cache=True, nogil=True)
def _linear_gr(indptr, indices, data, row_scale, g, a, traced, exponent):
    """CSR arrays of GR = M + Mᵀ (g x g), M_ij = w_ij S_ij, S_ij = row_scale_i x the entries of columns j < g of a
    CSR matrix (sorted columns, no duplicates; later columns are ignored): Mᵀ by a counting sort on the columns,
    then row i of M and of Mᵀ merged (both sorted), zeros dropped.  Every entry is M_ij + M_ji (one commutative
    addition), so GR is symmetric to the last bit.  ``gi``, ``gv`` are returned with spare room at their end (the
    first gp[g] entries are the matrix)."""
    mp = np.zeros(g + 1, np.int64)
    tp = np.zeros(g + 1, np.int64)
    for i in range(g):
        c = 0
        for q in range(indptr[i], indptr[i + 1]):
            if indices[q] < g:
                c += 1
                tp[indices[q] + 1] += 1
        mp[i + 1] = mp[i] + c
    for j in range(g):
        tp[j + 1] += tp[j]
    nnz = mp[g]
    mi = np.empty(nnz, np.int64)
    mv = np.empty(nnz)
    ti = np.empty(nnz, np.int64)
    tv = np.empty(nnz)
    slot = tp[:-1].copy()
    m = 0
    for i in range(g):  # rows in order: each column of Mᵀ comes out sorted
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j >= g:
                continue
            v = row_scale[i] * data[q] * _linear_weight(i, j, a, traced, exponent)
            mi[m] = j
            mv[m] = v
            m += 1
            ti[slot[j]] = i
            tv[slot[j]] = v
            slot[j] += 1
    gp = np.zeros(g + 1, np.int64)
    gi = np.empty(2 * nnz, np.int64)  # at most nnz(M) + nnz(Mᵀ) entries; the caller only reads gp[g] of them
    gv = np.empty(2 * nnz)
    k = 0
    for i in range(g):
        p, pe = mp[i], mp[i + 1]
        t, te = tp[i], tp[i + 1]
        while p < pe or t < te:
            if t >= te or (p < pe and mi[p] < ti[t]):
                col, val = mi[p], mv[p] + 0.0
                p += 1
            elif p >= pe or ti[t] < mi[p]:
                col, val = ti[t], 0.0 + tv[t]
                t += 1
            else:
                col, val = mi[p], mv[p] + tv[t]
                p += 1
                t += 1
            if val != 0.0:
                gi[k] = col
                gv[k] = val
                k += 1
        gp[i + 1] = k
    return gp, gi, gv


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
                        exponent: float = 0.4) -> sp.csr_matrix:
    """Symmetric GR (g, g) m² from the raw exchange S_ij = (εA)_i F̃_ij (g, g) m² by linear averaging.

    GR_ij = w_ij S_ij + w_ji S_ji with w_ij + w_ji = 1; ``method`` "linear": w_ij = ½(1 + sign(X)|X|^exponent),
    X = (a_j - a_i)/(a_j + a_i), a = εA/n_rays (thesis eq. 2.45-2.46: the estimate carried by the less energetic
    rays weighs more), or "fractional_variance": w_ij = σ²_ji/(σ²_ij + σ²_ji) with binomial variances.
    ``eps_area`` (g,) m², ``rays`` (g,) rays traced per group (0 allowed: that group's estimates get no weight).
    Written as GR = M + Mᵀ with M = S∘W, so the result is symmetric to the last bit.
    """
    S = sp.csr_matrix(S, dtype=float)
    S.sum_duplicates()
    eps_area = np.asarray(eps_area, float)
    rays = np.asarray(rays, float)
    if method == "linear":
        S.sort_indices()
        g = S.shape[0]
        gp, gi, gv = _linear_gr(S.indptr, S.indices, S.data, np.ones(g), g, eps_area / np.maximum(rays, 1), rays > 0,
                                float(exponent))
        return sp.csr_matrix((gv[:gp[g]].copy(), gi[:gp[g]].copy(), gp), shape=S.shape)
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


def smooth(F_raw: sp.spmatrix, eps_area: np.ndarray, rays: np.ndarray, blocked: np.ndarray | None = None,
           method: str = "linear", exponent: float = 0.4):
    """Reciprocity, then closure through the space column; returns ``(F, GR, lse)``.

    ``F_raw`` (g, g + 1) raw REFs (last column space), ``eps_area`` (g,) m², ``rays`` (g,), ``blocked`` (g,) the
    fraction of each group's rays stopped by sides that are not REF nodes (default 0).  The line-sum error is
    LSE_i = 1 - blocked_i - Σ_j F_ij after reciprocity and before the closure adjustment (thesis eq. 1.47); the
    space column then absorbs it so every row of ``F`` sums to 1 - blocked_i.  ``F`` (g, g + 1), ``GR``
    (g, g + 1) m² with GR = diag(εA) F (symmetric g x g block), ``lse`` (g,).  Rows of groups with εA = 0 are 0.
    """
    F_raw = sp.csr_matrix(F_raw)
    F_raw.sum_duplicates()  # also sorts the columns
    g = F_raw.shape[0]
    eps_area = np.asarray(eps_area, float)
    rays = np.asarray(rays, float)
    blocked = np.zeros(g) if blocked is None else np.asarray(blocked, float)
    if method == "linear":  # S = diag(εA) F_raw[:, :g] is formed inside the compiled kernel
        gp, gi, gv = _linear_gr(F_raw.indptr, F_raw.indices, F_raw.data, eps_area, g, eps_area / np.maximum(rays, 1),
                                rays > 0, float(exponent))
    else:
        GRb = enforce_reciprocity(scale_rows(F_raw[:, :g], eps_area), eps_area, rays, method, exponent)
        GRb.sort_indices()
        gp, gi, gv = GRb.indptr, GRb.indices, GRb.data
    with np.errstate(divide="ignore"):
        inv = np.where(eps_area > 0, 1.0 / np.where(eps_area > 0, eps_area, 1.0), 0.0)
    space_raw = _column(F_raw.indptr, F_raw.indices, F_raw.data, g)
    lse = np.where(eps_area > 0, 1.0 - blocked - inv * _row_sums(gp, gv) - space_raw, 0.0)
    space = np.where(eps_area > 0, space_raw + lse, 0.0)
    F = _append_arrays(gp, gi, gv, space, g, inv)
    GR = _append_arrays(gp, gi, gv, eps_area * space, g, np.ones(g))
    return F, GR, lse


@njit(cache=True, nogil=True)
def _row_sums(indptr, data):
    g = indptr.shape[0] - 1
    out = np.zeros(g)
    for i in range(g):
        for q in range(indptr[i], indptr[i + 1]):
            out[i] += data[q]
    return out


@njit(cache=True, nogil=True)
def _column(indptr, indices, data, j):
    """Column ``j`` (g,) of a CSR matrix (sorted columns, no duplicates) as a dense vector."""
    g = indptr.shape[0] - 1
    out = np.zeros(g)
    for i in range(g):
        for q in range(indptr[i], indptr[i + 1]):
            if indices[q] == j:
                out[i] = data[q]
    return out


def append_column(A: sp.spmatrix, column: np.ndarray, row_scale: np.ndarray | None = None) -> sp.csr_matrix:
    """csr (g, k + 1): diag(``row_scale``) ``A`` (g, k) (default: A) with ``column`` (g,) appended as its last
    column, zeros dropped, in one pass over the non-zeros."""
    A = sp.csr_matrix(A)
    A.sort_indices()
    g, k = A.shape
    scale = np.ones(g) if row_scale is None else np.asarray(row_scale, np.float64)
    return _append_arrays(A.indptr, A.indices, A.data, column, k, scale)


def _append_arrays(indptr, indices, data, column, k, scale) -> sp.csr_matrix:
    """:func:`append_column` on the CSR arrays of A (g, k); index arrays int32 when they fit (scipy keeps them)."""
    g = len(indptr) - 1
    itype = np.int32 if int(indptr[-1]) + g < 2**31 - 1 and k + 1 < 2**31 - 1 else np.int64
    out_data, out_ind, out_ptr = _append_column(indptr, indices, data, np.asarray(column, np.float64), k, scale,
                                                np.empty(0, itype))
    return sp.csr_matrix((out_data, out_ind, out_ptr), shape=(g, k + 1))


@njit(cache=True, nogil=True)
def _append_column(indptr, indices, data, column, k, scale, itmpl):
    """CSR arrays of [diag(scale) A | column] (column index k) without the zeros of either, in one pass."""
    g = indptr.shape[0] - 1
    n = 0
    for r in range(g):
        for j in range(indptr[r], indptr[r + 1]):
            n += scale[r] * data[j] != 0.0
        n += column[r] != 0.0
    out_data = np.empty(n)
    out_ind = np.empty(n, itmpl.dtype)
    out_ptr = np.empty(g + 1, itmpl.dtype)
    m = 0
    out_ptr[0] = 0
    for r in range(g):
        for j in range(indptr[r], indptr[r + 1]):
            v = scale[r] * data[j]
            if v != 0.0:
                out_data[m] = v
                out_ind[m] = indices[j]
                m += 1
        if column[r] != 0.0:
            out_data[m] = column[r]
            out_ind[m] = k
            m += 1
        out_ptr[r + 1] = m
    return out_data, out_ind, out_ptr


def rms(values: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Root mean square of ``values`` (over ``mask`` when given); 0 for an empty selection."""
    v = np.asarray(values, float)
    if mask is not None:
        v = v[mask]
    return float(np.sqrt(np.mean(v**2))) if v.size else 0.0


def convergence_rate(n1: float, e1: float, n2: float, e2: float) -> float:
    """κ in e ∝ n^-κ from two (rays, error) points (log-log slope, thesis §2.5.1); nan if undefined."""
    if not (n1 > 0 and n2 > 0 and e1 > 0 and e2 > 0 and n1 != n2):
        return float("nan")
    return float(-np.log(e2 / e1) / np.log(n2 / n1))
