"""The stages of a run as plain functions ``(case, model, ...) -> plain data``, called in order by
:mod:`fem2tmm.pipeline` and by the reduction methods of :mod:`fem2tmm.reductors`.

Each function adapts a stage package (clustering, radiation, solar, quadrics, steady solve) to the case: it
reads the case's settings and the FE model and returns arrays or the stage's own result type.  A new stage
(transient, orbit fluxes, load cases) is one more function here and one more call in
:func:`fem2tmm.pipeline._run`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .cache import digest
from .case import Case, RadiationSettings
from .constants import SIGMA
from .cluster import Clustering, PartInput, cluster_parts, from_labels
from .cluster.contact import join_dependent
from .errors import Fem2TmmError, InternalError
from .fem.model import FEModel, boundary_load
from .radiation import ExchangeResult, Surface, trace_exchange
from .radiation.tracer import trace_absorption
from .radiation.quadric import QuadricScene, fit_regions
from .radiation.solar import SolarResult, trace_solar
from .reduce.network import ReducedModel, determined_elements, face_owner, kept_dofs, super_faces
from .radiation.ir_absorption import IRAbsorption
from .solve.problems import detailed_problem, reduced_problem
from .solve.steady import FacedRadiation, SteadyProblem, solve_steady
from .solve.transient import (TransientProblem, TransientRun, TransientSettings, recover_series,
                              solve_transient)
from .timefunc import Series, Table

PREPASS_RAYS_PER_FACE = 5  # (measurements: docs/design-notes.md, stages.py)


# ------------------------------------------------------------------------------------------- clustering
def cluster_model(model: FEModel, case: Case, progress=None, flux: np.ndarray | None = None,
                  labels: np.ndarray | None = None, weights: np.ndarray | None = None,
                  weights_report: dict | None = None) -> Clustering:
    """Cluster every part of ``model`` with its requested number of super nodes.

    ``labels`` (n_elements,) int: a user partition instead (:func:`fem2tmm.cluster.from_labels`; the parts'
    ``super_nodes`` are then ignored).
    Elements fully determined by fixed-temperature nodes (e.g. a face held at a temperature) are not
    clustered: every requested super node goes to elements with unknowns.  They get the label -1.
    ``flux`` (n_elements,) absorbed flux (W/m², e.g. :func:`solar_prepass`) the clusters should follow, or None.
    ``weights`` (m,) clustering weight of each model element (m²; NaN: the part keeps area/volume weights), e.g.
    :func:`biot_weights`; its ``weights_report`` goes into the clustering report as ``allocation``.
    """
    args, kw = _cluster_inputs(model, case, flux, check_counts=labels is None, weights=weights)
    if labels is not None:
        return from_labels(*args, labels, feature_angle=kw["feature_angle"], where="run(labels=...)")
    index = kw.pop("part_index")
    clustering = cluster_parts(*args, **kw, progress=progress)
    clustering = _independent(model, clustering, kw["one_node"], index)
    clustering.report["allocation"] = {"method": case.clustering.allocation, **(weights_report or {})}
    return clustering


def _independent(model: FEModel, clustering: Clustering, one_node: np.ndarray, index: np.ndarray) -> Clustering:
    """Model part indices for the clusters, and clusters whose super-node rows would repeat others' merged into
    their best-connected neighbour (:func:`fem2tmm.cluster.contact.join_dependent`; the report's
    ``merged_dependent``), so that the reduction never meets linearly dependent super nodes."""
    cluster_part = index[clustering.cluster_part]
    rows = np.flatnonzero(clustering.labels[model.elements] >= 0)
    shares = model.capacity_shares if model.capacity_shares is not None else model.volume_shares
    lab, kept, merges = join_dependent(clustering.labels[model.elements[rows]], cluster_part,
                                       model.element_dofs[rows], shares[rows], one_node)
    report = clustering.report
    if not merges:
        return dataclasses.replace(clustering, cluster_part=cluster_part)
    labels = clustering.labels.copy()
    labels[model.elements[rows]] = lab
    report["merged_dependent"] = [{"cluster": int(a), "into": int(b), "part": model.parts[int(cluster_part[a])].name,
                                   "into_part": model.parts[int(cluster_part[b])].name} for a, b in merges]
    return dataclasses.replace(clustering, labels=labels, cluster_part=cluster_part[kept],
                               cluster_region=clustering.cluster_region[kept], report=report)


def _cluster_inputs(model: FEModel, case: Case, flux: np.ndarray | None, check_counts: bool = True,
                    weights: np.ndarray | None = None) -> tuple[tuple, dict]:
    """The arguments of :func:`~fem2tmm.cluster.cluster_parts` for ``model`` (what the clustering depends on);
    ``check_counts``: refuse impossible super-node counts first (:func:`_check_count`)."""
    kept = kept_dofs(model, case)
    determined = determined_elements(model, kept)
    one_node = np.zeros(model.n_dof, bool)  # DOFs that are super nodes of their own (fixed groups, kept nodes)
    one_node[[g.dof for g in model.fixed]] = True
    one_node[kept] = True
    parts, part_weights, index = [], [], []
    for p, info in enumerate(model.parts):
        rows = np.flatnonzero((model.element_part == p) & ~determined)
        if not len(rows):
            continue  # the whole part is held at fixed temperatures
        if check_counts:
            _check_count(case, info, model.element_dofs[rows], one_node)
        w = None if weights is None else weights[rows]
        part_weights.append(w if w is not None and np.isfinite(w).all() else None)
        index.append(p)
        parts.append(PartInput(name=info.name, kind=info.kind, elements=model.elements[rows],
                               cells=model.element_cells[rows], types=model.element_types[rows],
                               n_clusters=info.super_nodes, attribute=model.element_attribute[rows],
                               ids=model.mesh.element_ids[model.elements[rows]],
                               flux=None if (flux is None or info.kind == "line")
                               else np.nan_to_num(flux[model.elements[rows]]),
                               dofs=model.element_dofs[rows]))
    cs = case.clustering
    kw = {"feature_angle": cs.feature_angle, "seed": cs.seed, "smoothing_layers": cs.smoothing_layers,
          "balance": cs.balance, "method": cs.method, "one_node": one_node,
          "part_index": np.asarray(index, np.int64)}
    if any(w is not None for w in part_weights):
        kw["weights"] = part_weights
    return (model.mesh.points, parts, model.mesh.n_elements), kw


def check_super_node_counts(model: FEModel, case: Case) -> None:
    """Refuse super-node counts that cannot give independent super nodes (:func:`_check_count`), e.g. before a
    pre-solve that precedes the clustering."""
    _cluster_inputs(model, case, None, check_counts=True)


def _check_count(case: Case, info, element_dofs: np.ndarray, one_node: np.ndarray) -> None:
    """Refuse, before clustering, a super-node count that cannot give independent super nodes: the part's
    clusters and the one-node super nodes among its DOFs all average over the part's DOFs, so more of them than
    DOFs are linearly dependent."""
    dofs = np.unique(element_dofs[element_dofs >= 0])
    free = int(np.count_nonzero(~one_node[dofs]))
    if info.super_nodes > free:
        raise Fem2TmmError(
            f"{case.source}: [[parts]] {info.name!r} asks for {info.super_nodes} super nodes, but its elements have "
            f"only {free} nodes with an unknown temperature ({len(dofs)} nodes, {len(dofs) - free} of them fixed or "
            f"kept): more super nodes than that repeat each other's mean temperature (linearly dependent).  Use at "
            f"most {free}; a useful reduction has far fewer (each super node should hold several elements)")


# -------------------------------------------------------------------------------------------- radiation
def radiation_surface(model: FEModel) -> Surface:
    """The model's radiating faces as a ray-tracing :class:`~fem2tmm.radiation.Surface` (sides 2i front, 2i+1 back)."""
    f = model.faces
    return Surface(points=model.mesh.points, faces=f.nodes, emissivity=f.emissivity, absorptivity=f.absorptivity,
                   specular=f.specular, transmissivity=f.transmissivity,
                   transmission_specular=f.transmission_specular, active=f.active)


#: Random streams of a run, all derived from ``[radiation] seed``: the reduced model's tracings use the seed
#: itself; every other role gets its own ``numpy.random.SeedSequence`` entropy ``(seed, role)``, so the reference
#: never draws the reduced model's random numbers (issue 21: otherwise their ray noise is correlated and the
#: error metric does not see it).
SEED_ROLES = {"reduced": None, "reference": 1, "reference_b": 2, "prepass": 3, "absorption": 4,
              "refine": 5}


def role_seed(seed: int, role: str):
    """The seed (an int, or SeedSequence entropy ``[seed, k]``) of one random-number role of a run."""
    k = SEED_ROLES[role]
    return int(seed) if k is None else [int(seed), k]


def tracer_settings(case: Case, rays_per_face: int | None = None, ray_density: float | None = None,
                    exchange: bool = True, role: str = "reduced", fraction: float = 1.0) -> dict:
    """Keyword arguments of :func:`~fem2tmm.radiation.trace_exchange` (``exchange``) or of
    :func:`~fem2tmm.radiation.solar.trace_solar` (not ``exchange``: no budget, no target) from the case's
    ``[radiation]`` section.

    The exchange budget is ``rays_per_face`` per group or ``ray_density`` rays/m² when one is given, else the
    ``[radiation]`` budget (``ray_density`` if set, else ``rays_per_face``).  ``role`` picks the random stream
    (:data:`SEED_ROLES`); ``fraction`` scales the exchange budget (two half-budget references)."""
    rs = case.radiation
    kw = {"sampling": rs.sampling, "seed": role_seed(rs.seed, role), "max_bounces": rs.max_bounces}
    if not exchange:
        return kw
    if rays_per_face is None and ray_density is None:
        if rs.ray_density:
            ray_density = float(rs.ray_density)
        else:
            rays_per_face = int(rs.rays_per_face or RadiationSettings.rays_per_face)
    if fraction != 1.0:
        rays_per_face = None if rays_per_face is None else max(1, int(np.ceil(rays_per_face * fraction)))
        ray_density = None if ray_density is None else ray_density * fraction
    return {**kw, "rays_per_group": rays_per_face, "ray_density": ray_density, "target_lse": rs.target_lse}


def detailed_radiation(model: FEModel, case: Case, surface: Surface | None = None, rays_per_face: int | None = None,
                       ray_density: float | None = None, scene=None, role: str = "reference", fraction: float = 1.0
                       ) -> tuple[FacedRadiation, np.ndarray, ExchangeResult]:
    """Face-to-face REFs of the detailed model: every active side is a REF node.

    ``role``, ``fraction``: random stream and budget fraction (:func:`tracer_settings`).

    Returns ``(faced, g_space, result)``: :class:`FacedRadiation` (side -> DOF weights, side couplings m²),
    ``g_space`` (n_dof,) m² to the sink, and the :class:`~fem2tmm.radiation.ExchangeResult`.
    """
    surface = radiation_surface(model) if surface is None else surface
    f = model.faces
    active = np.flatnonzero(f.active)
    groups = np.full(2 * f.n, -1, np.int64)
    groups[active] = np.arange(len(active))
    res = trace_exchange(surface, groups, scene=scene,
                         **tracer_settings(case, rays_per_face, ray_density, role=role, fraction=fraction))
    Ws = f.W[active // 2]  # each side takes its face's nodal weights
    g = len(active)
    GR = sp.csr_matrix(res.GR)
    faced = FacedRadiation(W=Ws.tocsr(), G=GR[:, :g].tocsr())
    g_space = np.asarray(Ws.T @ np.asarray(GR[:, g].todense()).ravel()).ravel()
    return faced, g_space, res


def mean_faced(parts: list[FacedRadiation]) -> FacedRadiation:
    """The mean of independent face-to-face radiation estimates of one model (same ``W``)."""
    return FacedRadiation(W=parts[0].W, G=(sum(p.G for p in parts) / len(parts)).tocsr())


def reference_noise(model: FEModel, Ta: np.ndarray, Tb: np.ndarray) -> dict:
    """Noise of a reference that is the mean of two independent half references with solutions ``Ta``, ``Tb``
    (n_dof,) K: the difference of two independent estimates has twice the variance of one, the mean half of
    one, so the mean's error is estimated by ``(Ta − Tb)/2`` node by node (over the mesh nodes of the model).
    Returns ``{"rms_K", "max_K"}``."""
    d = 0.5 * (model.node_temperatures(Ta) - model.node_temperatures(Tb))[model.node_dof >= 0]
    return {"rms_K": float(np.sqrt(np.mean(d**2))), "max_K": float(np.abs(d).max(initial=0.0))}


def reduced_radiation(model: FEModel, rm: ReducedModel, case: Case, surface: Surface | None = None, scene=None,
                      sf: tuple[np.ndarray, np.ndarray] | None = None
                      ) -> tuple[np.ndarray, np.ndarray, ExchangeResult, int]:
    """REFs between super faces summed into GR between super nodes.

    Returns ``(GR, g_space, result, n_super_faces)``: GR (n, n) m² (zero diagonal), g_space (n,) m².
    ``sf``: the :func:`~fem2tmm.reduce.network.super_faces` of ``rm`` if already computed.
    """
    surface = radiation_surface(model) if surface is None else surface
    groups, owner = super_faces(model, rm) if sf is None else sf
    n_sf = len(owner)
    res = trace_exchange(surface, groups, scene=scene, **tracer_settings(case))
    S = sp.csr_matrix((np.ones(n_sf), (np.arange(n_sf), owner)), shape=(n_sf, rm.n))
    GRsf = sp.csr_matrix(res.GR)
    GR = np.asarray((S.T @ GRsf[:, :n_sf] @ S).todense())
    np.fill_diagonal(GR, 0.0)
    GR = 0.5 * (GR + GR.T)
    g_space = np.asarray(S.T @ np.asarray(GRsf[:, n_sf].todense()).ravel()).ravel()
    return GR, g_space, res, n_sf


# ------------------------------------------------------------------------------------------------ solar
def detailed_solar(model: FEModel, case: Case, surface: Surface | None = None, scene=None, role: str = "reference"
                   ) -> tuple[np.ndarray, SolarResult]:
    """Solar power absorbed by every FE face side, traced on the detailed mesh (the reference's; with
    ``solar_on = "detailed"`` the reduced model takes the same loads).  ``role``: random stream.

    Returns ``(q, result)``: nodal loads q (n_dof,) W (face power spread by the face's area shares) and the
    :class:`~fem2tmm.radiation.solar.SolarResult`.
    """
    surface = radiation_surface(model) if surface is None else surface
    env = case.environment
    res = trace_solar(surface, env.sun_direction, env.solar_flux, rays_per_group=env.solar_rays_per_face,
                      scene=scene, **tracer_settings(case, exchange=False, role=role))
    q = np.asarray(model.faces.W.T @ res.absorbed_face).ravel()
    return q, res


def solar_prepass(model: FEModel, case: Case, surface: Surface | None = None, scene=None) -> np.ndarray:
    """A cheap solar map for the clustering: absorbed flux (n_elements,) W/m² of every mesh element (NaN outside
    the model), traced on the flat FE faces with :data:`PREPASS_RAYS_PER_FACE` rays per face on average (one
    emitting group, origins uniform over the Sun's cross-section), shadowing and reflections included.  ``scene``:
    a flat :class:`~fem2tmm.radiation.surfaces.TriangleScene` of ``surface`` to reuse."""
    surface = radiation_surface(model) if surface is None else surface
    env = case.environment
    f = model.faces
    res = trace_solar(surface, env.sun_direction, env.solar_flux, groups=np.zeros(2 * f.n, np.int64),
                      rays_per_group=PREPASS_RAYS_PER_FACE * f.n, scene=scene,
                      **tracer_settings(case, exchange=False, role="prepass"))
    return face_flux_per_element(model, res.absorbed_face)


def super_face_solar(model: FEModel, rm: ReducedModel, case: Case, surface: Surface | None = None, scene=None,
                     sf: tuple[np.ndarray, np.ndarray] | None = None
                     ) -> tuple[np.ndarray, SolarResult, np.ndarray]:
    """The thesis' super-face solar loads: origins sampled over each super face as a whole (equal ray
    density to the detailed tracing), absorbed power summed per super node (uniform over it).

    Returns ``(q_sn, result, groups)``: q_sn (n,) W per super node.  ``sf``: the
    :func:`~fem2tmm.reduce.network.super_faces` of ``rm`` if already computed.
    """
    surface = radiation_surface(model) if surface is None else surface
    groups, owner = super_faces(model, rm) if sf is None else sf
    n_sf = len(owner)
    faces_per_group = np.bincount(groups[groups >= 0], minlength=n_sf)
    env = case.environment
    res = trace_solar(surface, env.sun_direction, env.solar_flux, groups=groups,
                      rays_per_group=np.maximum(faces_per_group * env.solar_rays_per_face, 1), scene=scene,
                      **tracer_settings(case, exchange=False))
    # the power absorbed by each side, wherever its origin was, belongs to the super face of that side
    return sides_to_super_nodes(res.absorbed_side, groups, owner, rm.n, "solar"), res, groups


def sides_to_super_nodes(side_power: np.ndarray, groups: np.ndarray, owner: np.ndarray, n: int, what: str
                         ) -> np.ndarray:
    """Power absorbed per side ``side_power`` (2f,) or (k, 2f) W summed per super node (n,) or (k, n): the power
    of each side, wherever its ray started, belongs to the super node owning its super face (``groups`` (2f,)
    super face per side, ``owner`` super node per super face).  Power on a side outside every super face is
    impossible (inactive sides block, they do not absorb): :class:`InternalError` naming ``what``."""
    ok = groups >= 0
    side_power = np.asarray(side_power, float)
    lost = np.abs(side_power[..., ~ok]).sum()
    if lost > 1e-12 * max(np.abs(side_power).sum(), 1e-300):
        raise InternalError(f"{what} power absorbed by a side outside every super face")
    S = sp.csr_matrix((np.ones(int(ok.sum())), (np.flatnonzero(ok), owner[groups[ok]])), shape=(len(groups), n))
    return np.asarray((S.T @ side_power.T).T)


# ------------------------------------------------------------------------------------------------ orbit
def _orbit_trace(model: FEModel, case: Case, surface: Surface | None, scene, groups, rays, per: str,
                 role: str = "reduced"):
    from .radiation.orbital import trace_orbit

    surface = radiation_surface(model) if surface is None else surface
    o = case.orbit
    return trace_orbit(surface, o.orbit, o.attitude, kinds=o.kinds, groups=groups, rays_per_group=rays,
                       scene=scene, per=per, **tracer_settings(case, exchange=False, role=role))


def detailed_orbit(model: FEModel, case: Case, surface: Surface | None = None, scene=None):
    """Orbital fluxes (``[orbit]``: solar, albedo, planet IR at every position) traced on the FE face sides.

    Returns ``(q, fluxes)``: nodal absorbed power q (k, n_dof) W per position (face power spread by the face's
    area shares) and the :class:`~fem2tmm.radiation.orbital.OrbitalFluxes` per FE face (incident and absorbed W
    (k, n_faces) per kind)."""
    active = model.faces.active
    groups = np.where(active, np.arange(len(active)), -1)  # every active side its own group
    # the reference's own random stream (like detailed_solar): with fluxes_on = "super_faces" the reduced model
    # traces the orbit itself and must not share these random numbers
    fl = _orbit_trace(model, case, surface, scene, groups, case.orbit.rays_per_face, "face", role="reference")
    q = np.asarray(model.faces.W.T @ fl.total("absorbed").T).T
    return q, fl


def super_face_orbit(model: FEModel, rm: ReducedModel, case: Case, surface: Surface | None = None, scene=None,
                     sf: tuple[np.ndarray, np.ndarray] | None = None):
    """Orbital fluxes traced on the super faces (origins over each super face as a whole, the same ray density as
    the detailed tracing), absorbed power summed per super node (uniform over it).

    Returns ``(q_sn, fluxes)``: q_sn (k, n) W per position and super node, and the
    :class:`~fem2tmm.radiation.orbital.OrbitalFluxes` per side (k, 2 n_faces)."""
    groups, owner = super_faces(model, rm) if sf is None else sf
    faces_per_group = np.bincount(groups[groups >= 0], minlength=len(owner))
    rays = np.maximum(faces_per_group * case.orbit.rays_per_face, 1)
    fl = _orbit_trace(model, case, surface, scene, groups, rays, "side")
    return sides_to_super_nodes(fl.total("absorbed"), groups, owner, rm.n, "orbital"), fl


@dataclasses.dataclass(frozen=True)
class OrbitLoads:
    """Orbital loads in time for the transient: ``times`` (k,) s of the positions from perigee (repeated at
    eclipse boundaries), ``period`` s, ``q_sn`` (k, n) W per super node, ``q_dof`` (k, n_dof) W on the detailed
    mesh or None, ``recover_dof``: the recovery takes ``q_dof`` (loads traced on the FE faces and distributed
    exactly) or not (super-face loads, uniform over each super node)."""

    times: np.ndarray
    period: float
    q_sn: np.ndarray | None
    q_dof: np.ndarray | None
    recover_dof: bool

    def add(self, series: Series, loads: np.ndarray, start: float) -> Series:
        """``series`` whose base holds the orbit average of ``loads`` (k, n), turned into the loads in time: one
        pattern per position with its periodic hat function (:func:`~fem2tmm.radiation.orbital.hat_basis`, the
        orbit's time 0 at ``start``), the average taken out of the base."""
        from .radiation.orbital import average_weights, hat_basis

        nodes, H = hat_basis(self.times, self.period)
        w = average_weights(self.times, self.period)
        tables = tuple(Table(start + nodes, H[:, j], period=self.period, start=start) for j in range(len(w)))
        return Series(series.base - w @ loads, series.patterns + tuple(loads), series.tables + tables)


def orbit_average(fluxes, q: np.ndarray) -> np.ndarray:
    """Orbit average (n,) of loads ``q`` (k, n) given at the positions of the run's orbital ``fluxes`` (an
    :class:`~fem2tmm.radiation.orbital.OrbitalFluxes`; piecewise linear in time, jumps at eclipse boundaries,
    :func:`~fem2tmm.radiation.orbital.period_average`)."""
    from .radiation.orbital import period_average

    return period_average(fluxes.positions.time, q, fluxes.positions.period)


def orbit_positions_reduced(rm: ReducedModel, q_recover: np.ndarray, q_sn: np.ndarray, q_dof: np.ndarray | None,
                            T0: np.ndarray, case: Case, exported=None) -> np.ndarray:
    """Steady reduced solves with the loads of each orbit position, recovered on the detailed mesh.

    ``rm`` the network with ``q_sn`` (k, n) W added to its loads at position j (the thesis': ``rm`` without orbital
    loads and the positions' loads; the radiation-aware network: its loads at the orbit average and each
    position's departure from that average, through its own Y'), recovered with ``q_recover`` + ``q_dof[j]`` (the
    exact distribution; (k, n_dof) W) or ``q_recover`` alone (super-face loads, uniform over each super node); the
    radiation-aware network with ``exported`` (its :class:`~fem2tmm.reduce.exported.ExportedRecovery`, given when it
    is the method's own recovery; each position's orbital loads, as its transient and ``fem2tmm recover``), started
    from the recovery about its linearisation.
    Starts from ``T0``; returns (k, n_dof) K."""
    ra = rm.radiative
    recover = ra.recover_linearised if ra is not None and ra.T_lin is not None else rm.reduction.recover
    out = []
    T = T0
    for j in range(len(q_sn)):  # loop over the orbit positions (a few tens)
        sol = solve_steady(reduced_problem(dataclasses.replace(rm, Q=rm.Q + q_sn[j])), T0=T, tol=case.solver.tolerance,
                           max_iter=case.solver.max_iterations)
        T = sol.T
        T_rec = recover(T, q_recover if q_dof is None else q_recover + q_dof[j])
        if exported is not None:
            try:
                T_rec = exported.recover(T, T0=T_rec, positions=np.array([j]) if q_dof is not None else None)
            except Fem2TmmError as exc:  # no quasi-static field above 0 K: keep the linearised one, say so
                import warnings

                warnings.warn(f"orbit position {j}: the exported recovery has no solution ({exc}); the position "
                              "keeps the recovery about the network's linearisation", stacklevel=2)
        out.append(T_rec)
    return np.array(out)


def orbit_positions_detailed(problem: SteadyProblem, q_dof: np.ndarray, T0: np.ndarray, case: Case) -> np.ndarray:
    """Steady detailed solves with the loads ``q_dof`` (k, n_dof) W of each orbit position added to ``problem``;
    starts from ``T0``; returns (k, n_dof) K."""
    out = []
    T = T0
    for j in range(len(q_dof)):  # loop over the orbit positions
        T = solve_steady(dataclasses.replace(problem, Q=problem.Q + q_dof[j]), T0=T, tol=case.solver.tolerance,
                         max_iter=case.solver.max_iterations).T
        out.append(T)
    return np.array(out)


def face_flux_per_element(model: FEModel, face_power: np.ndarray) -> np.ndarray:
    """Absorbed flux (n_elements,) W/m² of every mesh element from per-face powers (W); NaN outside the model."""
    f = model.faces
    n = model.mesh.n_elements
    p = np.bincount(f.element, weights=face_power, minlength=n)
    a = np.bincount(f.element, weights=f.area, minlength=n)
    return np.divide(p, a, out=np.full(n, np.nan), where=a > 0)


def absorbed_solar_maps(model: FEModel, solar: SolarResult) -> tuple[np.ndarray, np.ndarray]:
    """Absorbed solar flux maps of a solar trace: (n_faces,) W/m² per FE face and (n_elements,) W/m² per mesh
    element (NaN outside the model)."""
    return solar.absorbed_face / model.faces.area, face_flux_per_element(model, solar.absorbed_face)


# --------------------------------------------------------------------------------------------- quadrics
def quadric_scene(model: FEModel, case: Case, surface: Surface, clustering: Clustering | None = None):
    """The ray scene with fitted quadrics for the parts tagged ``quadric = true`` (or the groups listed in
    ``quadric = [...]``), or None.

    One quadric is fitted per region of the tagged faces (regions: the clustering's, i.e. split at sharp edges
    and junctions, restricted to the tagged groups; without a clustering, one per part).  A region that is not a quadric is refused with a
    clear error (see :func:`fem2tmm.radiation.quadric.fit_quadric`).  Returns ``(scene, report)``.
    """
    if not any(p.quadric for p in case.parts):
        return None, None
    quadrics, qof, report = fit_quadrics(*quadric_regions(model, case, clustering))
    return QuadricScene(surface, qof, quadrics), report


def quadric_regions(model: FEModel, case: Case, clustering: Clustering | None = None):
    """What the quadric fits depend on: ``(points (n, 3), faces (f, 4), region_of_face (f,) int (-1: flat),
    names {region: label})`` (see :func:`quadric_scene`)."""
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
    return model.mesh.points, f.nodes, region_of_face, names


def fit_quadrics(points, faces, region_of_face, names):
    """``(quadrics, quadric_of_face, report)``: one fitted quadric per region (:func:`quadric_regions`) and the
    fit report of each (summary.json "quadrics")."""
    quadrics, qof = fit_regions(points, faces, region_of_face, names=names)
    report = [{"region": names[int(r)], "max_distance_m": float(q.max_distance), "rms_distance_m": float(q.rms_distance),
               "size_m": float(q.size)} for r, q in zip(sorted(names), quadrics)]
    return quadrics, qof, report


def cluster_key(model: FEModel, case: Case, flux: np.ndarray | None = None, labels: np.ndarray | None = None,
                weights: np.ndarray | None = None) -> str:
    """Key of :func:`cluster_model`: the points, every part's elements, cells, types, attributes, flux and
    weights, the clustering settings and the user's ``labels``."""
    args, kw = _cluster_inputs(model, case, flux, check_counts=labels is None, weights=weights)
    return digest("cluster", *args, kw, labels)


# -------------------------------------------------------------------------------------------- transient
def check_transient(model: FEModel, case: Case) -> None:
    """Refuse a ``[transient]`` whose model has no capacitance (before any long computation)."""
    if case.transient is None:
        return
    if model.capacity is not None:
        return
    missing = sorted({p.name for p in case.parts if p.material is None or case.materials[p.material].density is None
                      or case.materials[p.material].specific_heat is None})
    raise Fem2TmmError(f"{case.source}: [transient] needs the capacitance of every part: give density and "
                       f"specific_heat to the materials of parts {', '.join(map(repr, missing)) or '(from the mesh)'}")


def transient_settings(case: Case) -> TransientSettings:
    """The solver settings of ``[transient]``."""
    t = case.transient
    return TransientSettings(end=t.end, start=t.start, step=t.step, tolerance=t.tolerance,
                             output_every=t.output_every, method=t.method, periodic=t.periodic,
                             periodic_tolerance=t.periodic_tolerance)


def load_tables(model: FEModel, case: Case) -> list[tuple[np.ndarray, Table, float]]:
    """(pattern (n_dof,) W per unit value, table, value at start) of every power/flux boundary whose value is a
    time table."""
    out = []
    for b in case.boundaries:
        if b.table is not None and b.kind != "temperature":
            out.append((boundary_load(model, case, dataclasses.replace(b, value=1.0)), b.table, b.value))
    return out


def load_series(Q_start: np.ndarray, tables, distribute=None) -> Series:
    """Loads in time from the loads at the start ``Q_start`` (which hold every table at its start value) and the
    ``tables`` of :func:`load_tables`; ``distribute`` maps detailed patterns to super nodes (Y)."""
    pats = [p if distribute is None else distribute(p) for p, _, _ in tables]
    base = np.array(Q_start, float)
    for p, (_, _, v) in zip(pats, tables):
        base -= v * p
    return Series(base, tuple(pats), tuple(t for _, t, _ in tables))


def exported_series(exported, case: Case, T_sn: np.ndarray, times: np.ndarray, sink: Table,
                    settings: TransientSettings, orbital: bool, T0: np.ndarray | None = None) -> np.ndarray:
    """(n_t, n_dof) K: the exported recovery (:class:`~fem2tmm.reduce.exported.ExportedRecovery`) of the super-node
    temperatures ``T_sn`` (n_t, n_SN) K at ``times`` (n_t,) s, each column with the named loads' and the sink's
    table values at its time and (``orbital``) that time's orbital loads, as ``fem2tmm recover`` gives them from a
    CSV with those rows; ``T0`` (n_t, n_dof) K starts each column's Newton."""
    def at(table: Table) -> np.ndarray:
        tab = table.periodic(settings.start, settings.end - settings.start) if settings.periodic else table
        return np.array([float(tab(t)) for t in times])

    loads = {b.name: at(b.table) for b in case.boundaries
             if b.table is not None and b.kind != "temperature" and b.name in set(exported.load_names)}
    sinks = at(sink)
    T_sn = np.asarray(T_sn, float)
    out = np.array(T0, float) if T0 is not None else np.zeros((len(times), exported.n_dof))
    failed = []
    for i, t in enumerate(times):  # loop over the output times: one constrained solve each
        try:
            out[i] = exported.recover(T_sn[i], loads={k: v[i] for k, v in loads.items()}, T_sink=sinks[i],
                                      times=np.array([t]) if orbital else None,
                                      T0=None if T0 is None else out[i])
        except Fem2TmmError:
            if T0 is None:
                raise
            failed.append(float(t))  # kept: the recovery about the network's linearisation
    if failed:
        import warnings

        warnings.warn(f"the exported recovery has no solution at t = {', '.join(format(t, 'g') for t in failed[:5])}"
                      f"{' ...' if len(failed) > 5 else ''} s ({len(failed)} of {len(times)} output times): its "
                      "super-node means and loads need temperatures at or below 0 K in the quasi-static field (a "
                      "cold start under a strong load); those times keep the recovery about the network's "
                      "linearisation, which fem2tmm recover does not reproduce", stacklevel=2)
    return out


def fixed_series(T_fixed: np.ndarray, rows: dict[str, int], case: Case) -> Series:
    """Fixed temperatures in time (K): ``T_fixed`` at the start with each table boundary's row (``rows``: boundary
    name -> row) following its table."""
    base = np.array(T_fixed, float)
    pats, tabs = [], []
    for b in case.boundaries:
        if b.table is not None and b.kind == "temperature" and b.name in rows:
            e = np.zeros_like(base)
            e[rows[b.name]] = 1.0
            base[rows[b.name]] = 0.0
            pats.append(e)
            tabs.append(b.table)
    return Series(base, tuple(pats), tuple(tabs))


class _Clock:
    """Wall and CPU time of one part of a stage into ``timings[name]`` and ``timings[name + "_cpu"]`` (s)."""

    def __init__(self, timings: dict, name: str):
        import time

        self.timings, self.name, self.time = timings, name, time
        self.wall, self.cpu = time.perf_counter(), time.process_time()

    def stop(self) -> None:
        self.timings[self.name] = self.time.perf_counter() - self.wall
        self.timings[self.name + "_cpu"] = self.time.process_time() - self.cpu


def run_transient(case: Case, model: FEModel, rm: ReducedModel | None = None, T_reduced: np.ndarray | None = None,
                  q_recover: np.ndarray | None = None, detailed: SteadyProblem | None = None,
                  T_detailed: np.ndarray | None = None, orbit: "OrbitLoads | None" = None,
                  exported=None) -> TransientRun:
    """The ``[transient]`` stage: the reduced model in time with recovery at every output time, and the detailed
    model when ``detailed`` (its steady problem, radiation and solar loads included) is given.  ``timings`` get
    the wall and CPU seconds of each part (``reduced``, ``recover``, ``detailed``, and ``..._cpu``).

    ``T_reduced`` / ``T_detailed`` (K) the steady solutions, used when ``initial_temperature = "steady"``;
    ``q_recover`` (n_dof,) W the detailed loads at the start that the recovery uses (applied + detailed solar).
    ``orbit``: the orbital loads (:class:`OrbitLoads`); the steady loads hold their orbit average, the transient
    follows them in time (periodic with the orbital period from ``[transient] start``).  ``exported``: the
    network's :class:`~fem2tmm.reduce.exported.ExportedRecovery` when the reduction method's field is that
    recovery's (:attr:`fem2tmm.reductors.base.Reductor.field_from_export`: the radiation-aware one): every output
    time is recovered with it (:func:`exported_series`), as a user's run of the deck through ``fem2tmm recover`` is;
    None: the network's linear recovery (about its linearisation, for a radiation-aware network).
    """
    from .fem.model import consistent_capacity

    spec = case.transient
    settings = transient_settings(case)
    tables = load_tables(model, case)
    sink = case.environment.sink_table or Table.constant(model.T_sink)
    run = TransientRun(times=settings.output_times(), settings=settings)

    def initial(T_steady):
        return T_steady if spec.initial_temperature == "steady" else spec.initial_temperature

    if rm is not None:
        clock = _Clock(run.timings, "reduced")
        rows = {str(rm.names[i]): int(i) for i in np.flatnonzero(rm.fixed)}
        Q_sn = load_series(rm.Q, tables, rm.reduction.distribute)
        if orbit is not None:
            Q_sn = orbit.add(Q_sn, orbit.q_sn, spec.start)
        prob = TransientProblem(K=rm.K, C=rm.C, Q=Q_sn, fixed=rm.fixed,
                                T_fixed=fixed_series(rm.T_fixed, rows, case), g_space=rm.g_space, T_sink=sink,
                                GR=rm.GR, names=tuple(rm.names))
        run.reduced_problem = prob
        try:
            run.reduced = solve_transient(prob, settings, initial(T_reduced))
        except Fem2TmmError as exc:
            negative = int(rm.report.get("negative_links", 0))
            if not negative:
                raise
            import re

            when = re.search(r"at t = (\S+) s", str(exc))
            # measured on a generated model (tests/test_robustness.py): the linear thesis network, integrated
            # without the solver's positivity damping, drops below 0 K at the very time the Newton steps fail
            raise Fem2TmmError(
                f"{case.source}: the reduced network has {negative} negative conductances (the exact condensation "
                "of the thesis' reduction), which break the maximum principle: in this transient they drive super "
                f"nodes towards 0 K{'' if when is None else ' (at t = ' + when.group(1) + ' s)'}: the network's "
                "property, not the physics'; use " + ("more super nodes" if case.reduction.radiation_aware else
                                                         "[reduction] network = \"positive\", radiation_aware = "
                                                         "true, or more super nodes")) from None
        clock.stop()
        clock = _Clock(run.timings, "recover")
        q = load_series(model.Q if q_recover is None else q_recover, tables)
        if orbit is not None and orbit.recover_dof:
            q = orbit.add(q, orbit.q_dof, spec.start)
        if settings.periodic:
            q = q.periodic(settings.start, settings.end - settings.start)
        ra = rm.radiative
        # the radiation-aware network: recovered about its own linearisation (its correction load is that state's)
        recover = ra.recover_linearised if ra is not None and ra.T_lin is not None else rm.reduction.recover
        run.T_recovered = recover_series(recover, run.reduced.T, q, run.times)
        if exported is not None:
            # what the user's own run of the deck recovers to: the exported recovery (reduced.npz, fem2tmm recover)
            # at every output time, with that time's named loads, sink and orbital loads (from the linearised one)
            run.T_recovered = exported_series(exported, case, run.reduced.T, run.times, sink, settings,
                                              orbit is not None and orbit.recover_dof, run.T_recovered)
        clock.stop()
    if detailed is not None:
        clock = _Clock(run.timings, "detailed")
        C = model.capacity if spec.capacitance == "lumped" else consistent_capacity(model)
        rows = {g.name: g.dof for g in model.fixed}
        Q_det = load_series(detailed.Q, tables)
        if orbit is not None:
            Q_det = orbit.add(Q_det, orbit.q_dof, spec.start)
        prob = TransientProblem(K=detailed.K, C=C, Q=Q_det, fixed=detailed.fixed,
                                T_fixed=fixed_series(detailed.T_fixed, rows, case), g_space=detailed.g_space,
                                T_sink=sink, GR=detailed.GR, faced=detailed.faced)
        run.detailed = solve_transient(prob, settings, initial(T_detailed))
        clock.stop()
    return run


# -------------------------------------------------------------------------------- IR absorbed on the FE sides

def ir_absorption(model: FEModel, rm: ReducedModel, case: Case, surface: Surface | None = None, scene=None,
                  sf: tuple[np.ndarray, np.ndarray] | None = None) -> IRAbsorption:
    """Trace the super faces once more (own random stream; ``[radiation] ir_rays_per_face`` rays per FE face of each
    super face, so every FE side receives enough rays for its own absorbed power) and tally each ray on the FE side
    that absorbs it (:func:`~fem2tmm.radiation.tracer.trace_absorption`).  ``ir_on = "faces"``: every active FE
    face side is an emitter of its own (the same number of rays: ``ir_rays_per_face`` per side), so the emission
    follows the recovered field inside a super face; its REFs are traced by
    :func:`~fem2tmm.radiation.trace_exchange` with reciprocity and closure, as the detailed reference's (own
    random stream), which halves the variance of a raw tally; A has up to (rays per side) entries per side."""
    surface = radiation_surface(model) if surface is None else surface
    groups, owner = super_faces(model, rm) if sf is None else sf
    if case.radiation.ir_on == "faces":
        # every active side a REF node of its own, traced like the detailed reference's REFs (own random stream):
        # reciprocity and closure halve the variance of the raw tally (measured on examples/composite: own noise
        # 0.45 K with the raw per-side tally, 100 rays per side)
        side = np.flatnonzero(groups >= 0)
        emitters = np.full(len(groups), -1, np.int64)
        emitters[side] = np.arange(len(side))
        res = trace_exchange(surface, emitters, scene=scene,
                             **tracer_settings(case, rays_per_face=case.radiation.ir_rays_per_face,
                                               role="absorption"))
        g = len(side)
        eps = res.eps_area
        F = (sp.diags(np.where(eps > 0, 1.0 / np.maximum(eps, 1e-300), 0.0)) @ sp.csr_matrix(res.GR)[:, :g]).tocsr()
        F.sort_indices()
        A = sp.csr_matrix((F.data, side[F.indices], F.indptr), shape=(g, len(groups)))  # group j -> its side
        return IRAbsorption(A=A, owner=np.asarray(owner, np.int64)[groups[side]], eps_area=eps, face=side // 2)
    faces_per_group = np.bincount(groups[groups >= 0], minlength=len(owner))
    A, _, eps = trace_absorption(surface, groups, scene=scene,
                                 rays_per_group=np.maximum(faces_per_group * case.radiation.ir_rays_per_face, 1),
                                 **tracer_settings(case, exchange=False, role="absorption"))
    return IRAbsorption(A=A, owner=np.asarray(owner, np.int64), eps_area=eps)


def presolve_space(model: FEModel, case: Case) -> np.ndarray:
    """(n_dof,) K: the detailed steady field with every active side radiating to space only (no face-to-face
    exchange, no ray tracing) and the case's power loads — the cheap pre-solve of ``[clustering] allocation =
    "biot"``: sparse Newton on the FE mesh (one sparse LU per iteration), stopped at 0.1 K, since only T³ is used.
    It underestimates the temperatures of faces that see each other (their exchange is left out)."""
    return solve_steady(detailed_problem(model), tol=0.1, max_iter=case.solver.max_iterations).T


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
    from .cluster.adjacency import dual_graph

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


def refinement_residual(model: FEModel, case: Case, clustering: Clustering, rm: ReducedModel, T_sn: np.ndarray,
                        T: np.ndarray, q_recover: np.ndarray, q_lumped: np.ndarray, ir: IRAbsorption | None,
                        state: Refinement,
                        surface: Surface | None = None, scene=None) -> tuple:
    """``(r, h, source, feedback)``: the residual of the recovered field ``T`` under the true loads, split in a DOF part
    ``r`` (n_dof,) W and, with ``ir_on = "detailed"``, the misplaced emission ``source = (B, dp, owner)`` of
    :func:`~fem2tmm.reduce.refine.global_estimate` (total residual ``r + Bᵀ dp``); ``h = 4σ e T³`` (n_dof,) W/K;
    ``feedback`` the linearised re-absorption ``(B, 4σεA T³ per side, E)`` when radiation is traced, else None.
    Arguments as for :func:`refinement_step`; the side-to-side tally is traced into ``state`` on first use."""
    from .reduce.radiative import emission_weights
    from .reduce.refine import emission_residual

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
    per_face = ir is not None and ir.face is not None
    if surface is not None and case.radiation.enabled and f.active.any() and not per_face:
        if state.side_absorption is None:
            active = f.active.ravel()
            groups = np.full(2 * f.n, -1, np.int64)
            groups[active] = np.arange(int(active.sum()))
            C, _, eps = trace_absorption(surface, groups, scene=scene,
                                         rays_per_group=case.reduction.refine_rays_per_face,
                                         **tracer_settings(case, exchange=False, role="refine"))
            side = np.flatnonzero(active)
            to_face = sp.csr_matrix((np.ones(2 * f.n), (np.arange(2 * f.n), np.arange(2 * f.n) // 2)),
                                    shape=(2 * f.n, f.n))
            emit = sp.csr_matrix((np.ones(len(side)), (np.arange(len(side)), side // 2)), shape=(len(side), f.n))
            state.side_absorption = (C, side, eps, (C @ to_face @ f.W).tocsr(), (emit @ f.W).tocsr())
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

    from .reduce.refine import (cluster_errors, global_estimate, interior_dofs, local_error, mark, owner_dofs,
                                split_clusters)

    t0 = time.perf_counter()
    red = case.reduction
    labels = clustering.labels
    el_cluster = labels[model.elements]
    k = int(len(clustering.cluster_part))
    r, h, source, feedback = refinement_residual(model, case, clustering, rm, T_sn, T, q_recover, q_lumped, ir, state,
                                                 surface, scene)
    weight = np.bincount(model.node_dof[model.node_dof >= 0], minlength=model.n_dof).astype(float)
    if red.refine_estimator == "local":
        if source is not None:
            r = r + np.asarray(source[0].T @ source[1]).ravel()
        dof_cluster = interior_dofs(model.element_dofs, el_cluster, model.n_dof, model.fixed_mask)
        e2, rms = cluster_errors(local_error(model.K, h, r, dof_cluster), dof_cluster, k, weight)
    else:
        owner = owner_dofs(model.element_dofs, el_cluster, model.n_dof, model.fixed_mask)
        dT, e2 = global_estimate(model.K, h, r, ~model.fixed_mask, weight, owner, k, source, feedback)
        rms = float(np.sqrt((weight * dT**2).sum() / weight.sum()))
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
