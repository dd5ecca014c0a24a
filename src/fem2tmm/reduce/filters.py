"""Filtering of the reduced conductive links (TMRT "filters") and the list of negative links.

The reduced conduction matrix is dense (every super node of a connected part is linked to every other one);
TMRT lets the user drop the insignificant links.  A link is the pair (i, j), i ≠ j, with conductance
``GL_ij = −K_ij`` W/K.

Rule (symmetric): the link is removed when ``|K_ij| < threshold · min(|K_ii|, |K_jj|)``, i.e. when it is
insignificant for *both* of its nodes.  The weaker rule "insignificant for either node" would cut the only
link of a small node hanging on a big one (a kept node, a small cluster) and leave it floating, making the
reduced model singular.  With this rule a node keeps at least one link whenever ``threshold < 1/degree``,
because its links add up to at least its diagonal.  All decisions use the original matrix, so the result does
not depend on an order.  The conductance removed goes back onto both diagonals (``K_ii += K_ij``), so the
filtered matrix is symmetric with zero row sums, like the input.

Positive off-diagonal terms (negative GL) are physically odd but exact consequences of the reduction
(DESIGN §3.2): they are kept unless filtered like any link, and :func:`negative_links` lists them.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import connected_components

from ..errors import Fem2TmmError


def _square(K) -> np.ndarray:
    K = np.asarray(K, float)
    if K.ndim != 2 or K.shape[0] != K.shape[1]:
        raise Fem2TmmError(f"conduction matrix must be square, got shape {K.shape}")
    return K


def _n_parts(K: np.ndarray) -> int:
    return connected_components(K != 0, directed=False)[0]


def filter_links(K: np.ndarray, threshold: float) -> tuple[np.ndarray, dict]:
    """Remove links weaker than ``threshold`` relative to both of their nodes' diagonals.

    ``K`` (n, n) symmetric reduced conduction matrix in W/K with zero row sums; ``threshold`` in [0, 1).
    Returns the filtered matrix (n, n) W/K and a report ``{"links_removed", "links_kept",
    "conductance_removed_W_per_K" (Σ |GL| removed), "max_relative_removed" (largest |K_ij| / min(K_ii, K_jj)
    removed), "parts_before", "parts_after" (connected parts of the link graph)}``.
    """
    K = _square(K)
    if not 0.0 <= threshold < 1.0:
        raise Fem2TmmError(f"filter threshold {threshold} must be in [0, 1) (a fraction of the diagonal)")
    d = np.abs(np.diag(K))
    ref = np.minimum(d[:, None], d[None, :])
    mag = np.abs(K)
    drop = np.triu((mag < threshold * ref) & (K != 0), k=1)
    drop |= drop.T
    out = K.copy()
    out[drop] = 0.0
    out[np.diag_indices_from(out)] += np.where(drop, K, 0.0).sum(axis=1)
    iu = np.triu(drop, k=1)
    kept = np.triu(K != 0, k=1) & ~iu
    with np.errstate(divide="ignore", invalid="ignore"):
        relmag = np.where(iu, mag / np.where(ref > 0, ref, np.inf), 0.0)
    report = {
        "links_removed": int(np.count_nonzero(iu)),
        "links_kept": int(np.count_nonzero(kept)),
        "conductance_removed_W_per_K": float(mag[iu].sum()),
        "max_relative_removed": float(relmag.max(initial=0.0)),
        "parts_before": int(_n_parts(K)),
        "parts_after": int(_n_parts(out)),
    }
    return out, report


def negative_links(K: np.ndarray, rtol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Links with negative conductance (positive off-diagonal K_ij).

    ``K`` (n, n) W/K; entries below ``rtol · sqrt(|K_ii K_jj|)`` count as round-off zeros.
    Returns ``pairs`` (k, 2) int with i < j and ``GL`` (k,) W/K (negative); the count is ``len(pairs)``.
    """
    K = _square(K)
    d = np.abs(np.diag(K))
    neg = np.triu(K > rtol * np.sqrt(np.outer(d, d)), k=1)
    i, j = np.nonzero(neg)
    return np.c_[i, j].astype(np.int64), -K[i, j]


__all__ = ["filter_links", "negative_links"]
