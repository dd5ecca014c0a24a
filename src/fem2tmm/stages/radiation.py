"""The radiation stages: the FE model's radiating surface, the tracer settings and random streams of ``[radiation]``,
the detailed and super-face REFs, the reference noise, and the IR absorbed on the FE sides.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..case import Case, RadiationSettings
from ..constants import SIGMA
from ..fem.model import FEModel
from ..radiation import ExchangeResult, Surface, trace_exchange
from ..radiation.ir_absorption import IRAbsorption
from ..radiation.tracer import side_fractions, trace_absorption
from ..reduce.network import ReducedModel, super_faces
from ..solve.steady import FacedRadiation


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
              "refine": 5, "estimate_a": 6, "estimate_b": 7}


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
        unblocked, to_space = side_fractions(emitters, res.blocked, res.space)
        return IRAbsorption(A=A, owner=np.asarray(owner, np.int64)[groups[side]], eps_area=eps, face=side // 2,
                            unblocked=unblocked, to_space=to_space)
    faces_per_group = np.bincount(groups[groups >= 0], minlength=len(owner))
    A, rest, eps = trace_absorption(surface, groups, scene=scene,
                                 rays_per_group=np.maximum(faces_per_group * case.radiation.ir_rays_per_face, 1),
                                 **tracer_settings(case, exchange=False, role="absorption"))
    unblocked, to_space = side_fractions(groups, rest[:, 1], rest[:, 0])
    return IRAbsorption(A=A, owner=np.asarray(owner, np.int64), eps_area=eps, unblocked=unblocked, to_space=to_space)


#: the run warns when a network's radiation to space and the traced emission of its recovered field differ by more
#: than this fraction (issue 42: a network that emits a blocked share radiated 442 W for 384 W)
EMISSION_MISMATCH = 0.01


def traced_area(scene, model: FEModel) -> np.ndarray | None:
    """(f,) m² each FE face's emitting area as the ray scene traces it, or None where the scene traces the facets
    themselves (no quadric fitted): on a :class:`~fem2tmm.radiation.quadric_scene.QuadricScene` the area of its
    patch on the fitted quadric, which the traced exchange factors (and so the detailed reference and both
    networks) emit from; what :meth:`~fem2tmm.fem.model.FEModel.with_unblocked` gives the model's emission.

    A balance drawn from the FE model's own areas must use the same area: on examples/cylinders (12 facets around
    each tube) the facets are 1.15 % smaller than the cylinders, 0.80 W of their 67 W.  From the facets, the
    a-posteriori estimate of the detailed reference's own field was 1.06 K RMS, 10x the networks' measured error, the
    emission check put the radiation-aware network 1.07 % from its field, over its 1 % warning, and that network was
    0.073 K off at the design state and 0.51 K at all high (from the traced area: 0.026 and 0.059 K; 2026-12-07)."""
    flat = getattr(scene, "tri_area_fe", None)
    if flat is None:
        return None
    n, face = model.faces.n, np.asarray(scene.tri_face, np.int64)
    traced = np.bincount(face, weights=scene.tri_area, minlength=n)
    facets = np.bincount(face, weights=flat, minlength=n)
    return model.faces.area * np.where(facets > 0, traced / np.maximum(facets, 1e-300), 1.0)


def space_emission(model: FEModel, T: np.ndarray, to_space: np.ndarray) -> float:
    """The traced emission to space of a detailed field, W: Σ over FE sides of σ εA ℱ_space (W T⁴ − T_s⁴).

    ``T`` (n_dof,) K, ``to_space`` (2f,) each side's traced fraction of its emission εA that leaves to space
    (:func:`~fem2tmm.radiation.tracer.side_fractions`); deck faces radiating to the sink (``extra_space``) count
    with their own εA; A is each face's :attr:`~fem2tmm.fem.model.Faces.emitting_area` (the traced area where the
    model carries it: :func:`traced_area`).  At a network's solution this is what its recovered field radiates to
    space; a network whose emission misses a blocked share (issue 42) radiates more than it."""
    f = model.faces
    T = np.asarray(T, float)
    s4 = model.T_sink**4
    eA = (f.emissivity * f.active * np.asarray(to_space, float)).reshape(-1, 2).sum(axis=1) * f.emitting_area
    out = float(np.dot(eA, np.asarray(f.W @ T**4).ravel() - s4))
    if model.extra_space is not None:
        out += float(np.dot(model.extra_space, T**4 - s4))
    return SIGMA * out


def emission_check(model: FEModel, network_W: float, T: np.ndarray, to_space: np.ndarray | None,
                   blocked: np.ndarray | None = None, eps_area: np.ndarray | None = None,
                   part: np.ndarray | None = None, warn: bool = True) -> dict | None:
    """The network's radiation to space against the traced emission to space of its recovered field.

    ``network_W`` what the network radiates at its solution (its couplings to space, plus what a radiation-aware
    network's correction load radiates), ``T`` (n_dof,) K its recovered field, ``to_space`` (2f,) per side traced
    space fraction (None: no face-to-face tracing, nothing to check).  ``blocked``, ``eps_area``, ``part`` (g,) per
    super face: its blocked fraction, εA and part index, for the blocked fraction per part.  Returns
    ``{"network_W", "traced_W", "relative", "blocked_by_part"}`` and, with ``warn``, warns when ``relative``
    exceeds :data:`EMISSION_MISMATCH` (for the radiation-aware network, whose fixed point makes the two equal up to
    the ray noise; the thesis' network differs by its uniform-load error).  ``model`` carries the traced emitting
    areas (:meth:`~fem2tmm.fem.model.FEModel.with_unblocked`)."""
    if to_space is None:
        return None
    traced = space_emission(model, T, to_space)
    rel = abs(network_W - traced) / max(abs(traced), 1e-300)
    out = {"network_W": float(network_W), "traced_W": traced, "relative": float(rel)}
    if blocked is not None:
        ea = np.asarray(eps_area, float)
        p = np.asarray(part, np.int64)
        ok = p >= 0
        tot = np.bincount(p[ok], ea[ok], minlength=len(model.parts))
        blk = np.bincount(p[ok], ea[ok] * np.asarray(blocked, float)[ok], minlength=len(model.parts))
        out["blocked_by_part"] = {model.parts[i].name: float(blk[i] / tot[i]) for i in range(len(model.parts))
                                  if tot[i] > 0}
    if warn:
        warn_emission(out)
    return out


def warn_emission(check: dict | None) -> None:
    """Warn when an :func:`emission_check` record's ``relative`` exceeds :data:`EMISSION_MISMATCH`."""
    if check is None or check["relative"] <= EMISSION_MISMATCH:
        return
    import warnings

    warnings.warn(f"the network radiates {check['network_W']:.4g} W to space at its solution, but its recovered field "
                  f"emits {check['traced_W']:.4g} W to space by the traced exchange factors "
                  f"({100 * check['relative']:.2g} % apart, above {100 * EMISSION_MISMATCH:g} %): the network and the "
                  "field it recovers disagree on the heat lost to space (summary.json reduced.emission_check); more "
                  "super nodes reduce it", stacklevel=3)
