"""The solar stages: the detailed and super-face Sun loads and the solar pre-pass of the solar-aware clustering.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..case import Case
from ..errors import InternalError
from ..fem.model import FEModel
from ..radiation import Surface
from ..radiation.solar import SolarResult, trace_solar
from ..reduce.network import ReducedModel, super_faces
from .radiation import radiation_surface, tracer_settings


PREPASS_RAYS_PER_FACE = 5  # (measurements: docs/design-notes.md, stages/solar.py)


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
