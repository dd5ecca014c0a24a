"""The reduced thermal network: clustering -> super nodes -> reduced conduction -> radiation -> solve.

Pipeline-level glue (it knows the stage order, like :mod:`fem2tmm.pipeline`): it turns an
:class:`~fem2tmm.fem.model.FEModel` and a clustering into a :class:`ReducedModel` of plain arrays that
the steady solver, the recovery and the exporters consume.

Super-node order: the clusters (part by part), then one boundary node per fixed-temperature group, then
the nodes the user keeps.  The space node is not a super node; it is the sink of ``g_space`` and the
last row/column of ``GR``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .cluster import Clustering, PartInput, cluster_parts, from_labels
from .errors import Fem2TmmError, format_ids
from .fem.model import FEModel
from .reduce import (ConductiveReduction, RadiationAware, SuperNodes, build_supernodes, emission_entries,
                     emission_weights, equivalent_capacitance, filter_links, negative_links, reduce_conduction,
                     split_radiative, supernode_capacitance)
from .solve.steady import FacedRadiation, SteadyProblem


@dataclass(frozen=True)
class ReducedModel:
    """A reduced network.  Shapes: n = n_SN super nodes (clusters, then boundary, then kept nodes).

    ``K`` (n, n) W/K dense (after the optional filter); ``C`` (n,) J/K or None; ``Q`` (n,) W = Y q;
    ``g_space`` (n,) m² εA to the sink; ``GR`` (n, n) m² node-to-node radiative couplings or None;
    ``fixed`` (n,) bool, ``T_fixed`` (n,) K; ``names`` (n,) str; ``part`` (n,) part index or -1.
    """

    names: np.ndarray
    kind: np.ndarray
    part: np.ndarray
    K: np.ndarray
    C: np.ndarray | None
    Q: np.ndarray
    g_space: np.ndarray
    fixed: np.ndarray
    T_fixed: np.ndarray
    T_sink: float
    supernodes: SuperNodes
    reduction: ConductiveReduction
    element_cluster: np.ndarray  # (m,) reduced cluster id of each model element (-1: fully determined element)
    GR: np.ndarray | None = None
    area: np.ndarray | None = None  # (n,) m² radiating area of each super node (both sides, active)
    report: dict = field(default_factory=dict)
    radiative: RadiationAware | None = None  # radiation-aware reduction (K is then K̃ = K'_SN − diag(H_SN))

    @property
    def n(self) -> int:
        return len(self.names)

    def problem(self) -> SteadyProblem:
        return SteadyProblem(K=self.K, Q=self.Q, fixed=self.fixed, T_fixed=self.T_fixed, g_space=self.g_space,
                             T_sink=self.T_sink, GR=self.GR, names=tuple(self.names))


def determined_elements(model: FEModel, kept: np.ndarray | None = None) -> np.ndarray:
    """(m,) bool: model elements whose nodes are all fixed-temperature (or kept) DOFs — no unknown inside."""
    one_node = np.zeros(model.n_dof, bool)
    one_node[[g.dof for g in model.fixed]] = True
    if kept is not None:
        one_node[kept] = True
    ed = model.element_dofs
    return np.where(ed >= 0, one_node[np.maximum(ed, 0)], True).all(axis=1)


def cluster_model(model: FEModel, case, progress=None, flux: np.ndarray | None = None,
                  labels: np.ndarray | None = None) -> Clustering:
    """Cluster every part of ``model`` with its requested number of super nodes.

    ``labels`` (n_elements,) int: a user partition instead (:func:`fem2tmm.cluster.from_labels`; the parts'
    ``super_nodes`` are then ignored).
    Elements fully determined by fixed-temperature nodes (e.g. a face held at a temperature) are not
    clustered: every requested super node goes to elements with unknowns.  They get the label -1.
    ``flux`` (n_elements,) absorbed flux (W/m², e.g. :func:`solar_prepass`) the clusters should follow, or None.
    """
    determined = determined_elements(model, kept_dofs(model, case))
    parts = []
    for p, info in enumerate(model.parts):
        rows = np.flatnonzero((model.element_part == p) & ~determined)
        if not len(rows):
            continue  # the whole part is held at fixed temperatures
        parts.append(PartInput(name=info.name, kind=info.kind, elements=model.elements[rows],
                               cells=model.element_cells[rows], types=model.element_types[rows],
                               n_clusters=info.super_nodes, attribute=model.element_attribute[rows],
                               ids=model.mesh.element_ids[model.elements[rows]],
                               flux=None if flux is None else np.nan_to_num(flux[model.elements[rows]])))
    cs = case.clustering
    if labels is not None:
        return from_labels(model.mesh.points, parts, model.mesh.n_elements, labels, feature_angle=cs.feature_angle,
                           where="run(labels=...)")
    return cluster_parts(model.mesh.points, parts, model.mesh.n_elements, feature_angle=cs.feature_angle,
                         seed=cs.seed, smoothing_layers=cs.smoothing_layers, progress=progress,
                         balance=cs.balance, method=cs.method)


def kept_dofs(model: FEModel, case) -> np.ndarray:
    """DOFs of ``[reduction] keep_nodes`` (original node ids)."""
    ids = np.asarray(case.reduction.keep_nodes, np.int64)
    if not len(ids):
        return np.zeros(0, np.int64)
    idx = model.mesh.node_index(ids, where=f"{case.source}: [reduction] keep_nodes")
    dofs = model.node_dof[idx]
    outside = ids[dofs < 0]
    if len(outside):
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: nodes {format_ids(outside)} belong to no thermal element")
    fixed = np.isin(dofs, [g.dof for g in model.fixed])
    if fixed.any():
        raise Fem2TmmError(f"{case.source}: [reduction] keep_nodes: nodes {format_ids(ids[fixed])} are in a "
                           "fixed-temperature boundary (already a boundary node)")
    return np.unique(dofs)


def build_reduced(model: FEModel, clustering: Clustering, case, T_ref: np.ndarray | None = None) -> ReducedModel:
    """Super nodes, exact reduced conduction, capacitance, loads and (space-only) radiation.

    ``T_ref`` (n_dof,) K: reduce ``K + diag(h)`` with the emission linearised about it (radiation-aware
    reduction, :mod:`fem2tmm.reduce.radiative`): ``K`` is then K̃ (zero row sums) and ``radiative`` holds
    H_SN, h and the reduction of K' for the correction load and the recovery.
    """
    labels_all = clustering.labels[model.elements]
    boundary = np.array([g.dof for g in model.fixed], np.int64)
    kept = kept_dofs(model, case)
    # Elements whose nodes are all boundary/kept DOFs have no unknown: their conduction links those
    # one-node super nodes directly, and a cluster made only of them is dropped (it is fully determined).
    ed = model.element_dofs
    determined = determined_elements(model, kept) | (labels_all < 0)
    rows = np.flatnonzero(~determined)
    used_clusters = np.unique(labels_all[rows])
    new_id = np.full(len(clustering.cluster_part), -1, np.int64)
    new_id[used_clusters] = np.arange(len(used_clusters))
    cluster_part = clustering.cluster_part[used_clusters]
    labels = new_id[labels_all[rows]]
    n_cl = len(used_clusters)
    shares = model.capacity_shares if model.capacity_shares is not None else model.volume_shares
    sn = build_supernodes(model.n_dof, ed[rows], shares[rows], labels, boundary=boundary, kept=kept,
                          n_clusters=n_cl)
    keep_entry = ~determined[model.coo.elem]
    coo = model.coo.select(keep_entry)
    h = None
    if T_ref is not None:
        elem_row = np.full(model.mesh.n_elements, -1, np.int64)
        elem_row[model.elements] = np.arange(len(model.elements))
        f = model.faces
        face_row = elem_row[f.element]  # conduction entries are numbered by model element row
        emis = emission_entries(f.W, face_row, f.eps_area, T_ref, keep_face=~determined[face_row])
        h = np.bincount(emis.rows, emis.vals, minlength=model.n_dof)
        coo = type(coo).concatenate([coo, emis])
    red = reduce_conduction(coo, sn, labels, elements=rows, method=case.reduction.method,
                            zero_row_sums=T_ref is None)
    K = red.K.copy()
    row_of_dof = _row_of_dof(sn, model.n_dof)
    if determined.any():
        direct = model.coo.select(~keep_entry)
        np.add.at(K, (row_of_dof[direct.rows], row_of_dof[direct.cols]), direct.vals)
    radiative = None
    if T_ref is not None:
        K, H = split_radiative(K)
        radiative = RadiationAware(reduction=red, K=K, H=H, e=emission_weights(model.faces.W, model.faces.eps_area),
                                   h=h, T_sink=model.T_sink)
    report = {"method": red.method, "diagnostics": dict(red.diagnostics),
              "determined_elements": int(determined.sum()), "dropped_clusters": int(len(clustering.cluster_part) - n_cl)}
    if case.reduction.filter > 0:
        K, frep = filter_links(K, case.reduction.filter)
        report["filter"] = frep
    # capacitance
    C = None
    if model.capacity_shares is not None:
        if case.reduction.capacitance == "equivalent":
            C = equivalent_capacitance(red, model.capacity)
        else:
            C = supernode_capacitance(sn, model.capacity_shares[rows], labels)
    Q = red.distribute(model.Q)
    # space-only radiation: each super node radiates through the εA of its faces' active sides
    f = model.faces
    n = sn.n_sn
    element_cluster = np.full(len(model.elements), -1, np.int64)
    element_cluster[rows] = labels
    owner = face_owner(model, sn, element_cluster)
    g_space = np.bincount(owner, weights=f.eps_area, minlength=n).astype(float)
    area = np.bincount(owner, weights=f.active_area, minlength=n).astype(float)
    # names, kinds, fixed values
    names, part = [], np.full(n, -1, np.int64)
    counters = {}
    fixed = np.zeros(n, bool)
    T_fixed = np.zeros(n)
    fixed_by_dof = {g.dof: g for g in model.fixed}
    first_node = np.full(model.n_dof, -1, np.int64)  # the lowest mesh node of each DOF (names of kept nodes)
    in_model = np.flatnonzero(model.node_dof >= 0)
    first_node[model.node_dof[in_model[::-1]]] = in_model[::-1]
    for i in range(n):
        if sn.cluster[i] >= 0:
            p = int(cluster_part[sn.cluster[i]])
            part[i] = p
            counters[p] = counters.get(p, 0) + 1
            names.append(f"{model.parts[p].name}_{counters[p]}")
        elif int(sn.dof[i]) in fixed_by_dof:
            g = fixed_by_dof[int(sn.dof[i])]
            names.append(g.name)
            fixed[i] = True
            T_fixed[i] = g.T
        else:
            names.append(f"node_{int(model.mesh.node_ids[first_node[sn.dof[i]]])}")
    pairs, gl = negative_links(K)
    report["negative_links"] = int(len(pairs))
    report["negative_GL_W_per_K"] = float(gl.sum()) if len(gl) else 0.0
    return ReducedModel(names=np.array(names), kind=np.asarray(sn.kind), part=part, K=K, C=C, Q=Q,
                        g_space=g_space, fixed=fixed, T_fixed=T_fixed, T_sink=model.T_sink, supernodes=sn,
                        reduction=red, element_cluster=element_cluster, GR=None, area=area, report=report,
                        radiative=radiative)


OUTER_TOLERANCE = 1e-3  # K: outer iterations stop early once the recovered field moves less than this


def radiation_aware_network(model: FEModel, clustering: Clustering, case, rm: ReducedModel, q_detailed: np.ndarray,
                            q_lumped: np.ndarray, T_ref: np.ndarray, solve):
    """The radiation-aware reduced network and its outer iterations (:mod:`fem2tmm.reduce.radiative`).

    Parameters
    ----------
    model, clustering, case : as for :func:`build_reduced`
    rm : the thesis' reduced model with its radiation (``GR``, ``g_space``), used for the couplings
    q_detailed : (n_dof,) W loads known on the detailed mesh (heaters, detailed solar): distributed by Y'
    q_lumped : (n,) W loads already lumped per super node (super-face solar)
    T_ref : (n_dof,) K the pre-solve's recovered field (the emission is linearised about it, then about each
        outer iteration's field: ``[reduction] outer_iterations`` reductions and network solves at most, fewer
        once the field moves less than :data:`OUTER_TOLERANCE`)
    solve : ``solve(problem) -> SteadySolution`` (the steady solver with the case's settings)

    Returns
    -------
    ``(rm', solution, T, history)``: the network (``K`` = K̃, ``Q`` = Y'q + q_lumped + Q_corr at the last
    reference), its solution, the recovered field (n_dof,) K and one dict per outer iteration
    (``max_dT_K``, ``rms_dT_K``: change of the recovered field; ``correction_W``: Σ|Q_corr|).
    """
    import dataclasses

    n_iter = max(int(case.reduction.outer_iterations), 1)
    ra_rm = dataclasses.replace(build_reduced(model, clustering, case, T_ref=T_ref), GR=rm.GR, g_space=rm.g_space)
    ra = ra_rm.radiative
    e_sn = rm.g_space + (0.0 if rm.GR is None else np.asarray(rm.GR).sum(axis=1))
    base = ra.reduction.distribute(q_detailed) + q_lumped
    A = ra_rm.supernodes.A
    history = []
    from .reduce.conduction import blas_threads

    for it in range(n_iter):
        if it > 0:  # re-linearise about the latest field (Newton-like: the steps shrink quadratically)
            ra_rm = dataclasses.replace(build_reduced(model, clustering, case, T_ref=T_ref), GR=rm.GR,
                                        g_space=rm.g_space)
            ra = ra_rm.radiative
            base = ra.reduction.distribute(q_detailed) + q_lumped
        T_sn_ref = np.where(ra_rm.fixed, ra_rm.T_fixed, A @ T_ref)
        corr = ra.correction(T_ref, T_sn_ref, e_sn)
        ra_rm = dataclasses.replace(ra_rm, Q=base + corr)
        with blas_threads(1):  # a ~100-node dense Newton: threads only contend on a shared machine
            sol = solve(ra_rm.problem())
        T = ra.recover(sol.T, q_detailed, T_ref)
        d = T - T_ref
        history.append({"iteration": it + 1, "max_dT_K": float(np.abs(d).max(initial=0.0)),
                        "rms_dT_K": float(np.sqrt(np.mean(d**2))) if d.size else 0.0,
                        "correction_W": float(np.abs(corr).sum())})
        T_ref = T
        if history[-1]["max_dT_K"] < OUTER_TOLERANCE:
            break
    ra.history = history
    return ra_rm, sol, T, history


def conductive_links(K: np.ndarray, rtol: float = 0.0) -> int:
    """Number of non-zero off-diagonal pairs (GL) of a symmetric K."""
    iu = np.triu_indices(len(K), 1)
    return int(np.count_nonzero(np.abs(K[iu]) > rtol * np.abs(np.diag(K)).max(initial=0.0)))


# ------------------------------------------------------------------------------------------------ radiation
def radiation_surface(model: FEModel):
    """The model's radiating faces as a ray-tracing :class:`~fem2tmm.radiation.Surface` (sides 2i front, 2i+1 back)."""
    from .radiation import Surface

    f = model.faces
    return Surface(points=model.mesh.points, faces=f.nodes, emissivity=f.emissivity, absorptivity=f.absorptivity,
                   specular=f.specular, transmissivity=f.transmissivity,
                   transmission_specular=f.transmission_specular, active=f.active)


def _budget(settings, n_groups: int):
    """(rays_per_group, ray_density) from a settings object with rays_per_face / ray_density."""
    if getattr(settings, "ray_density", None):
        return None, float(settings.ray_density)
    return int(settings.rays_per_face or 1000), None


def detailed_radiation(model: FEModel, case, surface=None, rays_per_face=None, ray_density=None, scene=None):
    """Face-to-face REFs of the detailed model: every active side is a REF node.

    Returns ``(faced, g_space, result)``: :class:`FacedRadiation` (side -> DOF weights, side couplings m²),
    ``g_space`` (n_dof,) m² to the sink, and the :class:`~fem2tmm.radiation.ExchangeResult`.
    """
    from .radiation import trace_exchange

    surface = radiation_surface(model) if surface is None else surface
    f = model.faces
    active = np.flatnonzero(f.active)
    groups = np.full(2 * f.n, -1, np.int64)
    groups[active] = np.arange(len(active))
    rs = case.radiation
    if rays_per_face is None and ray_density is None:
        rays_per_face, ray_density = _budget(rs, len(active))
    res = trace_exchange(surface, groups, rays_per_group=rays_per_face, ray_density=ray_density,
                         sampling=rs.sampling, seed=rs.seed, max_bounces=rs.max_bounces, target_lse=rs.target_lse,
                         scene=scene)
    Ws = f.W[active // 2]  # each side takes its face's nodal weights
    g = len(active)
    GR = sp_csr(res.GR)
    faced = FacedRadiation(W=Ws.tocsr(), G=GR[:, :g].tocsr())
    g_space = np.asarray(Ws.T @ np.asarray(GR[:, g].todense()).ravel()).ravel()
    return faced, g_space, res


def _row_of_dof(sn: SuperNodes, n_dof: int) -> np.ndarray:
    """(n_dof,) the super-node row of each one-node (boundary/kept) DOF, -1 elsewhere."""
    row = np.full(n_dof, -1, np.int64)
    row[sn.dof[sn.dof >= 0]] = np.flatnonzero(sn.dof >= 0)
    return row


def face_owner(model: FEModel, sn: SuperNodes, element_cluster: np.ndarray) -> np.ndarray:
    """(f,) the super-node row each radiating face belongs to: its element's cluster, or, for a face of a
    fully determined element (cluster -1), the one-node super node of its largest nodal share."""
    f = model.faces
    elem_row = np.full(model.mesh.n_elements, -1, np.int64)
    elem_row[model.elements] = np.arange(len(model.elements))
    cl = element_cluster[elem_row[f.element]]
    row_of_cluster = np.full(max(int(sn.cluster.max(initial=-1)) + 1, 0), -1, np.int64)
    row_of_cluster[sn.cluster[sn.cluster >= 0]] = np.flatnonzero(sn.cluster >= 0)
    owner = np.full(f.n, -1, np.int64)
    live = cl >= 0
    owner[live] = row_of_cluster[cl[live]]
    if (~live).any():
        owner[~live] = _row_of_dof(sn, model.n_dof)[f.dofs[~live, np.argmax(f.shares[~live], axis=1)]]
    return owner


def super_faces(model: FEModel, rm: ReducedModel) -> tuple[np.ndarray, np.ndarray]:
    """Super faces: the active sides of each super node, grouped by super node and side (front/back).

    Returns ``groups`` (2f,) super-face index of each side (-1 inactive) and ``owner`` (n_sf,) the super-node
    row of each super face.  Sides of fully determined elements belong to the one-node super node of the
    face's largest nodal share.
    """
    f = model.faces
    owner_face = face_owner(model, rm.supernodes, rm.element_cluster)
    side_owner = np.repeat(owner_face, 2)
    side = np.tile([0, 1], f.n)
    key = np.where(f.active, side_owner * 2 + side, -1)
    uniq, inv = np.unique(key[key >= 0], return_inverse=True)
    groups = np.full(2 * f.n, -1, np.int64)
    groups[key >= 0] = inv.ravel()
    return groups, uniq // 2


def reduced_radiation(model: FEModel, rm: ReducedModel, case, surface=None, scene=None, sf=None):
    """REFs between super faces summed into GR between super nodes.

    Returns ``(GR, g_space, result, n_super_faces)``: GR (n, n) m² (zero diagonal), g_space (n,) m².
    ``sf``: the :func:`super_faces` of ``rm`` if already computed.
    """
    import scipy.sparse as sp

    from .radiation import trace_exchange

    surface = radiation_surface(model) if surface is None else surface
    groups, owner = super_faces(model, rm) if sf is None else sf
    n_sf = len(owner)
    rays_per_group, ray_density = _budget(case.radiation, n_sf)
    rs = case.radiation
    res = trace_exchange(surface, groups, rays_per_group=rays_per_group, ray_density=ray_density,
                         sampling=rs.sampling, seed=rs.seed, max_bounces=rs.max_bounces, target_lse=rs.target_lse,
                         scene=scene)
    S = sp.csr_matrix((np.ones(n_sf), (np.arange(n_sf), owner)), shape=(n_sf, rm.n))
    GRsf = sp_csr(res.GR)
    GR = np.asarray((S.T @ GRsf[:, :n_sf] @ S).todense())
    np.fill_diagonal(GR, 0.0)
    GR = 0.5 * (GR + GR.T)
    g_space = np.asarray(S.T @ np.asarray(GRsf[:, n_sf].todense()).ravel()).ravel()
    return GR, g_space, res, n_sf


def sp_csr(M):
    import scipy.sparse as sp

    return sp.csr_matrix(M)


# ---------------------------------------------------------------------------------------------------- solar
def has_sun(case) -> bool:
    env = case.environment
    return env.sun_direction is not None and env.solar_flux > 0


def detailed_solar(model: FEModel, case, surface=None, scene=None):
    """Solar power absorbed by every FE face side, traced on the detailed mesh.

    Returns ``(q, result)``: nodal loads q (n_dof,) W (face power spread by the face's area shares) and the
    :class:`~fem2tmm.radiation.solar.SolarResult`.
    """
    from .radiation.solar import trace_solar

    surface = radiation_surface(model) if surface is None else surface
    env, rs = case.environment, case.radiation
    res = trace_solar(surface, env.sun_direction, env.solar_flux, rays_per_group=env.solar_rays_per_face,
                      sampling=rs.sampling, seed=rs.seed, max_bounces=rs.max_bounces, scene=scene)
    q = np.asarray(model.faces.W.T @ res.absorbed_face).ravel()
    return q, res


PREPASS_RAYS_PER_FACE = 5  # measured on the baffle: 2, 5 and 20 give the same clusters' errors within 0.05 K


def solar_aware(case) -> bool:
    """Whether the clustering follows a solar pre-pass: ``[clustering] solar_aware``, by default on when the
    super faces carry lumped solar loads (``solar_on = "super_faces"``) and there is a Sun."""
    flag = case.clustering.solar_aware
    if flag is None:
        flag = case.environment.solar_on == "super_faces"
    return bool(flag) and has_sun(case)


def solar_prepass(model: FEModel, case, surface=None, scene=None) -> np.ndarray:
    """A cheap solar map for the clustering: absorbed flux (n_elements,) W/m² of every mesh element (NaN outside
    the model), traced on the flat FE faces with :data:`PREPASS_RAYS_PER_FACE` rays per face on average (one
    emitting group, origins uniform over the Sun's cross-section), shadowing and reflections included.  ``scene``:
    a flat :class:`~fem2tmm.radiation.surfaces.TriangleScene` of ``surface`` to reuse."""
    from .radiation.solar import trace_solar

    surface = radiation_surface(model) if surface is None else surface
    env, rs = case.environment, case.radiation
    f = model.faces
    res = trace_solar(surface, env.sun_direction, env.solar_flux, groups=np.zeros(2 * f.n, np.int64),
                      rays_per_group=PREPASS_RAYS_PER_FACE * f.n, sampling=rs.sampling, seed=rs.seed,
                      max_bounces=rs.max_bounces, scene=scene)
    return face_flux_per_element(model, res.absorbed_face)


def super_face_solar(model: FEModel, rm: ReducedModel, case, surface=None, scene=None, sf=None):
    """The thesis' super-face solar loads: origins sampled over each super face as a whole (equal ray
    density to the detailed tracing), absorbed power summed per super node (uniform over it).

    Returns ``(q_sn, result, groups)``: q_sn (n,) W per super node.  ``sf``: the :func:`super_faces` of ``rm``
    if already computed.
    """
    from .radiation.solar import trace_solar

    surface = radiation_surface(model) if surface is None else surface
    groups, owner = super_faces(model, rm) if sf is None else sf
    n_sf = len(owner)
    faces_per_group = np.bincount(groups[groups >= 0], minlength=n_sf)
    env, rs = case.environment, case.radiation
    res = trace_solar(surface, env.sun_direction, env.solar_flux, groups=groups,
                      rays_per_group=np.maximum(faces_per_group * env.solar_rays_per_face, 1),
                      sampling=rs.sampling, seed=rs.seed, max_bounces=rs.max_bounces, scene=scene)
    # the power absorbed by each side, wherever its origin was, belongs to the super face of that side
    side_power = res.absorbed_side
    q_sn = np.zeros(rm.n)
    ok = groups >= 0
    np.add.at(q_sn, owner[groups[ok]], side_power[ok])
    lost = side_power[~ok].sum()  # power absorbed by inactive sides is impossible (they block): keep the books
    if lost > 1e-12 * max(side_power.sum(), 1e-300):
        raise Fem2TmmError("internal: solar power absorbed by a side outside every super face")
    return q_sn, res, groups


def face_flux_per_element(model: FEModel, face_power: np.ndarray) -> np.ndarray:
    """Absorbed flux (n_elements,) W/m² of every mesh element from per-face powers (W); NaN outside the model."""
    f = model.faces
    n = model.mesh.n_elements
    p = np.bincount(f.element, weights=face_power, minlength=n)
    a = np.bincount(f.element, weights=f.area, minlength=n)
    return np.divide(p, a, out=np.full(n, np.nan), where=a > 0)


# ------------------------------------------------------------------------------------------------- quadrics
def quadric_scene(model: FEModel, case, surface, clustering: Clustering | None = None):
    """The ray scene with fitted quadrics for the parts tagged ``quadric = true`` (or the groups listed in
    ``quadric = [...]``), or None.

    One quadric is fitted per region of the tagged faces (regions: the clustering's, i.e. split at sharp edges
    and junctions, restricted to the tagged groups; without a clustering, one per part).  A region that is not a quadric is refused with a
    clear error (see :func:`fem2tmm.radiation.quadric.fit_quadric`).  Returns ``(scene, report)``.
    """
    if not any(p.quadric for p in case.parts):
        return None, None
    from .radiation.quadric import QuadricScene, fit_regions

    f = model.faces
    mesh = model.mesh
    tagged_el = np.zeros(mesh.n_elements, bool)
    for p, info in zip(case.parts, model.parts):
        if p.quadric is True:
            tagged_el[info.elements] = True
        elif p.quadric:
            for g in p.quadric:
                tagged_el[np.intersect1d(mesh.group(g).elements, info.elements)] = True
    in_tagged = tagged_el[f.element]
    if clustering is not None:
        region = clustering.regions[f.element]
        region_of_face = np.where(in_tagged & (region >= 0), region, -1)
        # determined elements carry no cluster/region: give them their part's id beyond the region ids
        rest = in_tagged & (region < 0)
        region_of_face[rest] = int(clustering.regions.max(initial=-1)) + 1 + f.part[rest]
    else:
        region_of_face = np.where(in_tagged, f.part, -1)
    names = {}
    for r in np.unique(region_of_face[region_of_face >= 0]):
        part = case.parts[int(f.part[np.flatnonzero(region_of_face == r)[0]])].name
        names[int(r)] = f"part {part!r} region {int(r)}"
    quadrics, qof = fit_regions(model.mesh.points, f.nodes, region_of_face, names=names)
    report = [{"region": names[int(r)], "max_distance_m": float(q.max_distance), "rms_distance_m": float(q.rms_distance),
               "size_m": float(q.size)} for r, q in zip(sorted(names), quadrics)]
    return QuadricScene(surface, qof, quadrics), report
