"""The orbit stages: orbital fluxes per position on the FE faces and super faces, their period average, and the
steady solves at each position.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..case import Case
from ..errors import Fem2TmmError
from ..fem.model import FEModel
from ..radiation import Surface
from ..reduce.network import ReducedModel, super_faces
from ..solve.problems import reduced_problem
from ..solve.steady import SteadyProblem, solve_steady
from ..timefunc import Series, Table
from .radiation import radiation_surface, tracer_settings
from .solar import sides_to_super_nodes


# ------------------------------------------------------------------------------------------------ orbit
def _orbit_trace(model: FEModel, case: Case, surface: Surface | None, scene, groups, rays, per: str,
                 role: str = "reduced"):
    from ..radiation.orbital import trace_orbit

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
        from ..radiation.orbital import average_weights, hat_basis

        nodes, H = hat_basis(self.times, self.period)
        w = average_weights(self.times, self.period)
        tables = tuple(Table(start + nodes, H[:, j], period=self.period, start=start) for j in range(len(w)))
        return Series(series.base - w @ loads, series.patterns + tuple(loads), series.tables + tables)


def orbit_average(fluxes, q: np.ndarray) -> np.ndarray:
    """Orbit average (n,) of loads ``q`` (k, n) given at the positions of the run's orbital ``fluxes`` (an
    :class:`~fem2tmm.radiation.orbital.OrbitalFluxes`; piecewise linear in time, jumps at eclipse boundaries,
    :func:`~fem2tmm.radiation.orbital.period_average`)."""
    from ..radiation.orbital import period_average

    return period_average(fluxes.positions.time, q, fluxes.positions.period)


def orbit_positions_reduced(rm: ReducedModel, q_recover: np.ndarray, q_sn: np.ndarray, q_dof: np.ndarray | None,
                            T0: np.ndarray, case: Case, exported=None, T_ref: np.ndarray | None = None) -> np.ndarray:
    """Steady reduced solves with the loads of each orbit position, recovered on the detailed mesh.

    ``rm`` the network with ``q_sn`` (k, n) W added to its loads at position j (the thesis': ``rm`` without orbital
    loads and the positions' loads; the radiation-aware network: its loads at the orbit average and each
    position's departure from that average, through its own Y'), recovered with ``q_recover`` + ``q_dof[j]`` (the
    exact distribution; (k, n_dof) W) or ``q_recover`` alone (super-face loads, uniform over each super node); the
    radiation-aware network with ``exported`` (its :class:`~fem2tmm.reduce.exported.ExportedRecovery`, given when it
    is the method's own recovery; each position's orbital loads, as its transient and ``fem2tmm recover``), started
    from the recovery about its linearisation, or with ``T_ref`` (n_dof,) K, the recovered design field, through the
    saddles :meth:`~fem2tmm.reduce.exported.ExportedRecovery.recover_about` shares between the positions
    (examples/satellite's 16 positions: one saddle factorisation instead of 16).
    Starts from ``T0``; returns (k, n_dof) K."""
    ra = rm.radiative
    recover = ra.recover_linearised if ra is not None and ra.T_lin is not None else rm.reduction.recover
    out = []
    T = T0
    for j in range(len(q_sn)):  # loop over the orbit positions (a few tens)
        sol = solve_steady(reduced_problem(dataclasses.replace(rm, Q=rm.Q + q_sn[j])), T0=T, tol=case.solver.tolerance,
                           max_iter=case.solver.max_iterations)
        T = sol.T
        # the recovery about the network's linearisation, formed where it is needed (half the positions' time on
        # examples/satellite where recover_about does not start from it)
        linear = (lambda T=T, j=j: recover(T, q_recover if q_dof is None else q_recover + q_dof[j]))  # noqa: E731
        if exported is None:
            T_rec = linear()
        else:
            position = j if q_dof is not None else None
            try:
                T_rec = (exported.recover(T, T0=linear(), positions=None if position is None else np.array([position]))
                         if T_ref is None else exported.recover_about(T_ref, T, position=position))
            except Fem2TmmError as exc:  # no quasi-static field above 0 K: keep the linearised one, say so
                import warnings

                warnings.warn(f"orbit position {j}: the exported recovery has no solution ({exc}); the position "
                              "keeps the recovery about the network's linearisation", stacklevel=2)
                T_rec = linear()
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
