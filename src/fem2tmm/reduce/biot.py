"""Biot numbers ``Bi = h_rad A / (k t)`` of the FE elements and of the clusters, from a linearised emission, and
the clustering weights of ``[clustering] allocation = "biot"`` built on them."""

from __future__ import annotations

import numpy as np

from ..constants import SIGMA
from ..fem.model import FEModel
from ..mesh.elements import SHELL_TYPES, TYPE_CODE
from .network import ReducedModel


def element_biot(model: FEModel, h_dof: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Biot number ``Bi = h_rad A / (k t)`` of every element from a linearised emission lumped to the DOFs.

    ``h_dof`` (n_dof,) W/K: the linearised emission 4σεA·T³ of each DOF (:class:`RadiationAware` ``h``).  An
    element's ``k t`` is read off its conduction matrix (a bilinear quad's diagonal is 2/3 k t, a linear
    triangle's about the same: ``k t ≈ 1.5 · trace(K_e) / n_nodes``); its ``h_rad A`` is its nodes' h shared by
    their nodal volume shares.  Returns ``(h_rad A (m,) W/K, k t (m,) W/K, shell (m,) bool)``; ``Bi = h_rad A /
    (k t)`` where ``shell`` (a conducting shell element); an element whose nodes are all one DOF (an isothermal
    joint ties them) conducts nothing of its own: its h_rad A is 0 (Bi 0).
    """
    coo = model.coo
    m = len(model.elements)
    diag = coo.rows == coo.cols
    trace = np.bincount(coo.elem[diag], coo.vals[diag], minlength=m)
    n_nodes = np.count_nonzero(model.element_dofs >= 0, axis=1)
    kt = 1.5 * trace / np.maximum(n_nodes, 1)
    # h per element: each DOF's h shared among its elements by their nodal volume shares
    shares = model.volume_shares
    ed = model.element_dofs
    ok = ed >= 0
    tot = np.bincount(ed[ok], shares[ok], minlength=model.n_dof)
    frac = np.where(ok, shares / np.where(ok, tot[np.maximum(ed, 0)], 1.0), 0.0)
    h_el = (frac * np.where(ok, h_dof[np.maximum(ed, 0)], 0.0)).sum(axis=1)
    # an element whose nodes are all one DOF (its corners tied by an isothermal joint, issue 42) has no conduction
    # of its own (its k t above is round-off, 1e-17 W/K): no Biot number (0, like a non-radiating element)
    lo = np.where(ok, ed, np.iinfo(np.int64).max).min(axis=1)
    hi = np.where(ok, ed, -1).max(axis=1)
    h_el = np.where(hi > lo, h_el, 0.0)
    shell = np.isin(model.element_types, [TYPE_CODE[t] for t in SHELL_TYPES]) & (kt > 0)
    return h_el, kt, shell


def biot_numbers(model: FEModel, rm: ReducedModel, h_dof: np.ndarray) -> dict:
    """Biot numbers ``Bi = h_rad A / (k t)`` of the shell elements and of the clusters, from the linearised emission.

    ``h_dof`` (n_dof,) W/K: the linearised emission 4σεA·T³ lumped to the DOFs (:class:`RadiationAware` ``h``);
    the elements' Bi are :func:`element_biot`'s.  A cluster's Bi is Σ h_rad A over its elements / its mean k t:
    ``(size / fin length)²``, the number the uniform-load assumption of the thesis' reduction needs small.
    Elements with Bi > 1 mean the mesh itself does not resolve the fin length √(k t / h_rad).  Returns
    ``{"element_max", "elements_over_1", "cluster_max", "cluster_median"}`` (shell elements only; None without
    any).
    """
    h_el, kt, shell = element_biot(model, h_dof)
    live = shell & (rm.element_cluster >= 0)
    if not live.any():
        return {"element_max": None, "elements_over_1": 0, "cluster_max": None, "cluster_median": None}
    bi_el = h_el[live] / kt[live]
    cl = rm.element_cluster[live]
    k = int(cl.max()) + 1
    cnt = np.bincount(cl, minlength=k)
    bi_cl = np.bincount(cl, h_el[live], minlength=k) / np.maximum(np.bincount(cl, kt[live], minlength=k) / np.maximum(cnt, 1), 1e-300)
    bi_cl = bi_cl[cnt > 0]
    return {"element_max": float(bi_el.max()), "elements_over_1": int((bi_el > 1).sum()),
            "cluster_max": float(bi_cl.max()), "cluster_median": float(np.median(bi_cl))}


def warn_coarse_mesh(n_over: int, bi_max: float | None) -> None:
    """Warn (once per call) when ``n_over`` shell elements have a Biot number above 1 (largest ``bi_max``)."""
    if n_over:
        import warnings

        warnings.warn(f"{n_over} shell elements have a Biot number h_rad A/(k t) > 1 (max {bi_max:.3g}): the mesh "
                      "does not resolve the fin length sqrt(k t / h_rad) of its thin radiating panels; refine it "
                      "there", stacklevel=3)


#: ``[clustering] allocation = "biot"``: an element's clustering weight is its area times (Bi / B̄)^BIOT_EXPONENT
#: (B̄ the part's area-weighted mean Bi), floored at BIOT_FLOOR × B̄.  The exponent minimises the RMS error of
#: uniform-load super nodes: a super node of area a where the fin length is L errs by ~ a / L² = Bi_cluster
#: (small Bi), so RMS² ∝ ∫ (a / L²)² dA with ∫ dA / a = n_SN fixed gives a ∝ L^(4/3), i.e. super nodes per unit
#: area ∝ (h_rad / k t)^(2/3).  The floor keeps non-emitting elements (Bi = 0) clusterable.
BIOT_EXPONENT = 2.0 / 3.0


BIOT_FLOOR = 0.01


def biot_weights(model: FEModel, T: np.ndarray) -> tuple[np.ndarray, dict]:
    """Clustering weight per element for ``[clustering] allocation = "biot"`` and the Biot numbers behind it.

    ``T`` (n_dof,) K: a pre-solve's field (:func:`presolve_space`).  The elements' Bi come from
    :func:`element_biot` with ``h = 4σ εA T³`` (both active sides, to space); the weight of a shell element is its
    area × ``max(Bi / B̄, BIOT_FLOOR)^BIOT_EXPONENT`` with B̄ its part's area-weighted mean Bi (see
    :data:`BIOT_EXPONENT`); other elements (solids, bars, parts that do not radiate) keep their area/volume, i.e.
    weight None for the part.  Returns ``(weights (m,) m² or NaN outside weighted parts, report)`` with the
    report ``{part: {"mean", "max", "elements_over_1"}}`` of each shell part's element Bi.
    """
    h = 4.0 * SIGMA * model.space_coupling() * np.asarray(T, float) ** 3
    h_el, kt, shell = element_biot(model, h)
    bi = np.where(shell, h_el / np.where(shell, kt, 1.0), 0.0)
    area = model.mesh.element_areas(model.elements)
    weights = np.full(len(bi), np.nan)
    report = {}
    for p, info in enumerate(model.parts):
        rows = np.flatnonzero((model.element_part == p) & shell)
        if not len(rows):
            continue
        a, b = area[rows], bi[rows]
        mean = float(np.dot(a, b) / a.sum())
        report[info.name] = {"mean": mean, "max": float(b.max()), "elements_over_1": int((b > 1).sum())}
        if mean > 0:
            # densities to 9 digits: the round-off of a uniform field must not move cluster boundaries (ties)
            weights[rows] = a * np.round(np.maximum(b / mean, BIOT_FLOOR) ** BIOT_EXPONENT, 9)
    return weights, report
