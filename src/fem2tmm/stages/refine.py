"""The error-driven refinement of the clustering (``[clustering] refine``): its residual and one round.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..case import Case
from ..constants import SIGMA
from ..cluster import Clustering
from ..fem.model import FEModel
from ..radiation import Surface
from ..radiation.ir_absorption import IRAbsorption
from ..radiation.tracer import trace_absorption
from ..reduce.network import ReducedModel, face_owner
from .radiation import role_seed, tracer_settings


@dataclass
class Refinement:
    """State of the error-driven refinement across its rounds (:func:`refinement_step`).

    ``history`` one dict per round (``round``, ``n_super_nodes``, ``estimated_rms_K``, ``split_clusters``,
    ``seconds``); ``labels`` the clustering of every round (n_elements,) int; ``side_absorption`` the estimator's
    FE side-to-side IR tally ``(C (g, 2f) csr, side (g,) the FE side of each emitting group, eps_area (g,) m²,
    B = C S W (g, n_dof): what each side's emission deposits on the DOFs, E (g, n_dof): each side's temperature
    from the DOFs)``, traced once (it does not depend on the clusters); ``stop`` why the loop ended.
    """

    history: list = dataclasses.field(default_factory=list)
    labels: list = dataclasses.field(default_factory=list)
    side_absorption: tuple | None = None
    stop: str | None = None


def _element_links(model: FEModel, clustering: Clustering) -> tuple[np.ndarray, np.ndarray]:
    """Global element pairs sharing an edge (face) inside one part and one region of ``clustering``."""
    from ..cluster.adjacency import dual_graph

    la, lb = [], []
    for p, info in enumerate(model.parts):
        rows = np.flatnonzero(model.element_part == p)
        if not len(rows):
            continue
        g = dual_graph(model.mesh.points, model.element_cells[rows], model.element_types[rows], info.kind)
        a, b = model.elements[rows][g.a], model.elements[rows][g.b]
        same = clustering.regions[a] == clustering.regions[b]
        la.append(a[same])
        lb.append(b[same])
    cat = lambda x: np.concatenate(x) if x else np.zeros(0, np.int64)  # noqa: E731
    return cat(la), cat(lb)


def side_tally(model: FEModel, case: Case, surface: Surface, scene=None, rays_per_face: int | None = None,
               role: str = "refine", share: float = 1.0, strata: np.ndarray | None = None) -> tuple:
    """The estimator's FE side-to-side IR tally (:attr:`Refinement.side_absorption`): ``(C (g, 2f) csr, side (g,),
    eps_area (g,) m², B (g, n_dof), E (g, n_dof))``, every active side emitting ``rays_per_face`` rays (default
    ``[reduction] refine_rays_per_face``) from the random stream ``role``
    (:data:`~fem2tmm.stages.radiation.SEED_ROLES`).

    ``share`` < 1: only a random sample of that share of the active sides emits, drawn from the same role's seed
    without replacement in each stratum (``strata`` (2f,) int, e.g. the super face of each side; None: one
    stratum), at least one side per stratum; each emitting side's row of C is weighted by its stratum's
    sides / emitting sides (Horvitz-Thompson: each stratum's absorbed power ``Cᵀ p`` stays unbiased, so the
    stratum totals, which carry the field's global modes, keep the full tally's accuracy; all sides still
    absorb).  ``side`` lists the emitting sides only."""
    f = model.faces
    active = f.active.ravel()
    side = np.flatnonzero(active)
    weight = None
    if share < 1.0 and side.size:
        rng = np.random.default_rng(np.random.SeedSequence(role_seed(case.radiation.seed, role), spawn_key=(1,)))
        st = np.zeros(side.size, np.int64) if strata is None else np.asarray(strata, np.int64)[side]
        st = np.unique(st, return_inverse=True)[1].ravel()
        order = np.lexsort((rng.random(side.size), st))  # each stratum's sides in a random order
        n_s = np.bincount(st)
        m_s = np.maximum(1, np.round(share * n_s)).astype(np.int64)
        start = np.concatenate([[0], np.cumsum(n_s)[:-1]])
        rank = np.arange(side.size) - start[st[order]]  # position of each side in its stratum's random order
        keep = order[rank < m_s[st[order]]]
        keep.sort()
        weight, side = (n_s / m_s)[st[keep]], side[keep]
    groups = np.full(2 * f.n, -1, np.int64)
    groups[side] = np.arange(side.size)
    C, _, eps = trace_absorption(surface, groups, scene=scene,
                                 rays_per_group=rays_per_face or case.reduction.refine_rays_per_face,
                                 **tracer_settings(case, exchange=False, role=role))
    if weight is not None:
        C = (sp.diags(weight) @ C).tocsr()
    to_face = sp.csr_matrix((np.ones(2 * f.n), (np.arange(2 * f.n), np.arange(2 * f.n) // 2)), shape=(2 * f.n, f.n))
    emit = sp.csr_matrix((np.ones(len(side)), (np.arange(len(side)), side // 2)), shape=(len(side), f.n))
    return C, side, eps, (C @ to_face @ f.W).tocsr(), (emit @ f.W).tocsr()


def uses_side_tally(model: FEModel, case: Case, ir: IRAbsorption | None, surface: Surface | None) -> bool:
    """Whether :func:`refinement_residual` reads the side-to-side tally for a network with IR absorption ``ir``
    (radiation traced, and the model's absorbed IR not already per FE side)."""
    return (surface is not None and case.radiation.enabled and bool(model.faces.active.any())
            and not (ir is not None and ir.face is not None))


def refinement_residual(model: FEModel, case: Case, clustering: Clustering, rm: ReducedModel, T_sn: np.ndarray,
                        T: np.ndarray, q_recover: np.ndarray, q_lumped: np.ndarray, ir: IRAbsorption | None,
                        state: Refinement,
                        surface: Surface | None = None, scene=None) -> tuple:
    """``(r, h, source, feedback)``: the residual of the recovered field ``T`` under the true loads, split in a DOF part
    ``r`` (n_dof,) W and, with ``ir_on = "detailed"``, the misplaced emission ``source = (B, dp, owner)`` of
    :func:`~fem2tmm.reduce.refine.global_estimate` (total residual ``r + Bᵀ dp``); ``h = 4σ e T³`` (n_dof,) W/K;
    ``feedback`` the linearised re-absorption ``(B, 4σεA T³ per side, E)`` when radiation is traced, else None.
    Arguments as for :func:`refinement_step`; the side-to-side tally is traced into ``state`` on first use."""
    from ..reduce.radiative import emission_weights
    from ..reduce.refine import emission_residual

    f = model.faces
    T_sn_full = np.where(rm.fixed, rm.T_fixed, T_sn)
    owner_face = face_owner(model, rm.supernodes, rm.element_cluster)
    # loads known on the detailed mesh, plus those lumped per super node spread as the model assumes (A' q_SN)
    q = np.asarray(q_recover, float) + np.asarray(rm.supernodes.A.T @ np.asarray(q_lumped, float)).ravel()
    source = feedback = None
    if ir is not None:
        T4_face = None if ir.face is None else np.asarray(f.W @ T**4).ravel()  # "faces": FE sides emit at T
        q += np.asarray(f.W.T @ ir.face_power(T_sn_full, model.T_sink, T4_face)).ravel()
    # ``ir_on = "faces"``: the model's absorbed IR already follows the recovered field, nothing is misplaced
    if uses_side_tally(model, case, ir, surface):
        if state.side_absorption is None:
            state.side_absorption = side_tally(model, case, surface, scene)
        C, side, eps, B, E = state.side_absorption
        face = side // 2
        s4 = model.T_sink**4
        T_face = np.asarray(f.W @ T).ravel()[face]
        p_fe = SIGMA * eps * (T_face**4 - s4)
        feedback = (B, 4.0 * SIGMA * eps * T_face**3, E)
        if ir is not None:  # the model absorbs what super faces emit at T_SN: only the difference is missing
            source = (B, p_fe - SIGMA * eps * (T_sn_full[owner_face[face]] ** 4 - s4),
                      clustering.labels[f.element[face]])
        else:  # the model's absorbed IR is lumped per super node: the whole FE-resolved absorption is the load
            q += np.asarray(B.T @ p_fe).ravel()
    e = emission_weights(f.W, f.eps_area)
    if model.extra_space is not None:
        e = e + model.extra_space
    r, h = emission_residual(model.K, T, q, e, model.T_sink)
    return r, h, source, feedback


def error_estimate(model: FEModel, clustering: Clustering, case: Case, rm: ReducedModel, T_sn: np.ndarray,
                   T: np.ndarray, q_recover: np.ndarray, q_lumped: np.ndarray, ir: IRAbsorption | None,
                   state: Refinement, surface: Surface | None = None, scene=None) -> tuple[float, np.ndarray]:
    """``(rms K, e2 (k,))``: the a-posteriori estimate of the recovered field's RMS error and each cluster's share
    (``[reduction] refine_estimator``), without a detailed reference.  Arguments as for :func:`refinement_step`
    (``rm`` any reduced model: the thesis' or the radiation-aware; ``ir`` its IR absorption or None)."""
    from ..reduce.refine import cluster_errors, global_estimate, interior_dofs, local_error, owner_dofs

    el_cluster = clustering.labels[model.elements]
    k = int(len(clustering.cluster_part))
    r, h, source, feedback = refinement_residual(model, case, clustering, rm, T_sn, T, q_recover, q_lumped, ir, state,
                                                 surface, scene)
    weight = np.bincount(model.node_dof[model.node_dof >= 0], minlength=model.n_dof).astype(float)
    if case.reduction.refine_estimator == "local":
        if source is not None:
            r = r + np.asarray(source[0].T @ source[1]).ravel()
        dof_cluster = interior_dofs(model.element_dofs, el_cluster, model.n_dof, model.fixed_mask)
        e2, rms = cluster_errors(local_error(model.K, h, r, dof_cluster), dof_cluster, k, weight)
    else:
        owner = owner_dofs(model.element_dofs, el_cluster, model.n_dof, model.fixed_mask)
        dT, e2 = global_estimate(model.K, h, r, ~model.fixed_mask, weight, owner, k, source, feedback)
        rms = float(np.sqrt((weight * dT**2).sum() / weight.sum()))
    return float(rms), e2


def error_field(model: FEModel, clustering: Clustering, case: Case, rm: ReducedModel, T_sn: np.ndarray,
                T: np.ndarray, q_recover: np.ndarray, q_lumped: np.ndarray, ir: IRAbsorption | None,
                state: Refinement, surface: Surface | None = None, scene=None,
                cache: dict | None = None, tol: float | None = None,
                reabsorb: bool = True, pre: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(δT (n_dof,) K, weight (n_dof,))``: the global estimator's error field of the recovered field ``T`` (one
    detailed linear solve, no cluster shares: :func:`~fem2tmm.reduce.refine.global_estimate`) and the RMS weights
    (mesh nodes per DOF).  Arguments as for :func:`error_estimate`; ``cache`` a dict that keeps the factorised
    ``K + diag(h)`` for another call at the same field ``T`` (another tally), or None; ``tol`` the re-absorption
    solve's relative tolerance (:func:`~fem2tmm.reduce.refine.global_estimate`); ``reabsorb`` False leaves the
    linearised re-absorption G out of the Newton step (``K'⁻¹ r``: linear in the tally); ``pre`` factorisations at
    other fields that may stand for this one's (:func:`~fem2tmm.reduce.refine.global_estimate`), or None."""
    from ..reduce.refine import global_estimate

    r, h, source, feedback = refinement_residual(model, case, clustering, rm, T_sn, T, q_recover, q_lumped, ir, state,
                                                 surface, scene)
    weight = np.bincount(model.node_dof[model.node_dof >= 0], minlength=model.n_dof).astype(float)
    dT, _ = global_estimate(model.K, h, r, ~model.fixed_mask, weight, np.full(model.n_dof, -1), 0, source,
                            feedback if reabsorb else None, shares=False, cache=cache, tol=tol, pre=pre)
    return dT, weight


def refinement_step(model: FEModel, clustering: Clustering, case: Case, rm: ReducedModel, T_sn: np.ndarray,
                    T: np.ndarray, q_recover: np.ndarray, q_lumped: np.ndarray, ir: IRAbsorption | None,
                    state: Refinement,
                    surface: Surface | None = None, scene=None) -> np.ndarray | None:
    """One round of the error-driven refinement (:mod:`fem2tmm.reduce.refine`): estimate, then split or stop.

    The true loads of the estimator are the recovery's (``q_recover``: heaters, detailed solar) plus the absorbed
    IR.  With radiation traced, the absorbed IR is that of the FE faces emitting at their own recovered
    temperatures, through a side-to-side tally traced once with ``[reduction] refine_rays_per_face`` rays per FE
    side (its own random stream): with ``ir_on = "detailed"`` as the model's absorbed IR (the super faces
    emitting at T_SN) plus ``C'(P_FE − P_SF)`` through that tally, so that its ray noise scales with the
    difference only; otherwise ``C' P_FE`` itself.

    Parameters
    ----------
    model, clustering, case : the run's FE model, this round's clustering and the case
    rm : the radiation-aware reduced model of this round (``rm.radiative`` set)
    T_sn : (n,) K its network solution; ``T`` (n_dof,) K the recovered field
    q_recover : (n_dof,) W loads known on the detailed mesh
    q_lumped : (n,) W loads lumped per super node (super-face solar), spread by the super-node weights A
    ir : the super faces' IR absorption (``ir_on = "detailed"``) or None
    state : :class:`Refinement`, updated in place (history, labels, the traced tally)
    surface, scene : the radiation surface and ray scene (None: no radiation traced)

    Returns
    -------
    The next round's labels (n_elements,) int64, or None when the loop stops (``state.stop`` says why).
    """
    import time

    from ..reduce.refine import mark, split_clusters

    t0 = time.perf_counter()
    red = case.reduction
    labels = clustering.labels
    el_cluster = labels[model.elements]
    k = int(len(clustering.cluster_part))
    rms, e2 = error_estimate(model, clustering, case, rm, T_sn, T, q_recover, q_lumped, ir, state, surface, scene)
    entry = {"round": len(state.history), "n_super_nodes": k, "estimated_rms_K": rms, "split_clusters": []}
    state.history.append(entry)
    state.labels.append(labels.copy())
    nxt = None
    if rms <= red.target_rms:
        state.stop = "target met"
    elif entry["round"] >= red.refine_rounds:
        state.stop = "refine_rounds reached"
    else:
        budget = (red.max_super_nodes - k) if red.max_super_nodes is not None else k
        split = mark(e2, np.bincount(el_cluster[el_cluster >= 0], minlength=k), budget)
        if not split.size:
            state.stop = "max_super_nodes reached" if budget <= 0 else "no cluster left to split"
        else:
            link_a, link_b = _element_links(model, clustering)
            n_el = model.mesh.n_elements
            cells = model.element_cells
            ok = cells >= 0
            cent = np.zeros((n_el, 3))
            cent[model.elements] = ((model.mesh.points[np.maximum(cells, 0)] * ok[..., None]).sum(axis=1)
                                    / ok.sum(axis=1)[:, None])
            wts = np.ones(n_el)
            wts[model.elements] = np.maximum(model.volume_shares.sum(axis=1), 1e-300)
            nxt = split_clusters(labels, split, cent, wts, link_a, link_b, clustering.cluster_part,
                                 seed=case.clustering.seed)
            entry["split_clusters"] = [int(c) for c in split]
            if int(nxt.max()) + 1 == k:
                state.stop, nxt = "no cluster left to split", None
    entry["seconds"] = time.perf_counter() - t0
    return nxt
