"""What every reduction method shares: its inputs (:class:`ReductionInputs`) and the three things it does; its
output is :class:`fem2tmm.result.Reduced`.

A reduction method is one :class:`Reductor` (in the manner of pyMOR's reductors): ``reduce`` builds the network
from the run's thesis network and loads and solves it, ``export`` writes the recovery that travels with that network
(:class:`~fem2tmm.reduce.exported.ExportedRecovery`, the ``recovery_*`` arrays of ``reduced.npz``), and
``reconstruct`` maps super-node temperatures back onto the FE DOFs as that recovery does.  The pipeline runs the
thesis' method first (its field is every other method's starting point and the automatic choice's input), then
the chosen one; a new method is a new module with one :class:`Reductor` subclass and a line in
:data:`fem2tmm.reductors.REDUCTORS`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np
import scipy.sparse as sp

from ..case import Case
from ..cluster import Clustering
from ..fem.model import FEModel, boundary_load, consistent_capacity
from ..reduce.exported import ExportedRecovery
from ..reduce.network import ReducedModel
from ..result import Reduced


@dataclass(frozen=True)
class ReductionInputs:
    """What a reduction method starts from.

    Attributes
    ----------
    model : the FE model; ``case`` the case with ``[reduction] radiation_aware`` and ``[radiation] ir_on``
        resolved (:func:`fem2tmm.reductors.choose_reduction`)
    clustering : the clustering the super nodes come from
    network : the thesis' reduced model with this case's loads, boundary temperatures, sink, traced radiation
        (``GR``, ``g_space``) and the loads lumped per super node already in ``Q``
    q_recover : (n_dof,) W loads known on the detailed mesh (boundary loads, detailed solar, orbit average): what
        the recovery and an exact power distribution take
    q_lumped : (n,) W loads traced per super node (super-face solar, orbit average), already in ``network.Q``
    orbit : ``(q (k, n_dof) W, times (k,) s, period s)`` of orbital loads traced on the FE faces, or None
    linearised_at : (n_dof,) K a case set's shared linearisation (:func:`fem2tmm.keys.network_group`) or None
    trace_ir : ``trace_ir(case) -> IRAbsorption``: traces where the emitted IR is absorbed on the FE sides
        (:func:`fem2tmm.stages.radiation.ir_absorption`), or None when nothing is traced
    ir_on_asked : the case file's ``[radiation] ir_on`` before "auto" was resolved
    unblocked, to_space : (2f,) per FE side, the fraction of its emission not stopped by inactive sides and the
        fraction that leaves to space, from the super faces' tracing (:func:`fem2tmm.radiation.tracer.side_fractions`),
        or None without face-to-face radiation: a method that emits from the FE sides emits εA·unblocked
        (:meth:`fem2tmm.fem.model.FEModel.with_unblocked`), as the traced REFs close on it
    advise : False where ``"auto"``'s estimates chose the method (:mod:`fem2tmm.stages.choice`): no advice to set
        ``radiation_aware`` otherwise (the radiation-aware reduction's low-Biot warning)
    traced_area : (f,) m² the area each FE face emits from as the rays are traced (a fitted quadric's patch), or
        None (the facets'): a method that emits from the FE sides emits from it, as the traced REFs do
    """

    model: FEModel
    case: Case
    clustering: Clustering
    network: ReducedModel
    q_recover: np.ndarray
    q_lumped: np.ndarray
    orbit: tuple | None = None
    linearised_at: np.ndarray | None = None
    trace_ir: Callable | None = None
    ir_on_asked: str = "auto"
    unblocked: np.ndarray | None = None
    to_space: np.ndarray | None = None
    advise: bool = True
    traced_area: np.ndarray | None = None


class Reductor:
    """A reduction method: ``reduce`` → :class:`Reduced`, ``export`` → its recovery, ``reconstruct`` → a field.

    Subclasses set :attr:`name` and implement :meth:`reduce`; :meth:`export` writes the linear recovery
    (``T = X q + Yᵀ T_SN``) unless a method recovers otherwise.  ``prog`` (a :class:`fem2tmm.progress.Progress`) times
    and announces the method's stages.
    """

    name: ClassVar[str] = ""
    #: True when the run's field is re-recovered by the exported recovery once written (:meth:`deliver`)
    field_from_export: ClassVar[bool] = False

    def reduce(self, inputs: ReductionInputs, prog, start: Reduced | None = None) -> Reduced:
        """Build, solve and recover the network.  ``start``: the thesis' reduction of the same inputs (the other
        methods' starting point), or None for the thesis itself."""
        raise NotImplementedError

    def export(self, inputs: ReductionInputs, reduction: Reduced) -> ExportedRecovery:
        """The recovery written into ``reduced.npz`` with the network (:func:`exported_arrays`, linear mode)."""
        return ExportedRecovery(**exported_arrays(inputs, reduction.network))

    def deliver(self, inputs: ReductionInputs, reduction: Reduced, prog) -> Reduced:
        """The reduction handed over: ``reduction`` with its exported recovery (stage "recovery"), and with
        :attr:`field_from_export` its field recovered by it from the network's solution."""
        with prog.stage("recovery", "the recovery that travels with the network"):
            reduction.recovery = self.export(inputs, reduction)
            if self.field_from_export:
                reduction.T_recovered = self.reconstruct(reduction, reduction.solution.T, T0=reduction.T_recovered)
        return reduction

    def reconstruct(self, reduction: Reduced, T_sn: np.ndarray, loads: dict | None = None,
                    T0: np.ndarray | None = None) -> np.ndarray:
        """(n_dof,) K: the field recovered from super-node temperatures ``T_sn`` (n,) K with the design loads, or
        the named loads at ``loads`` {name: value} (:meth:`ExportedRecovery.recover`); ``T0`` (n_dof,) K a start
        for an iterative recovery.  The linear recovery of the network's own reduction operator by default."""
        if loads:
            return reduction.recovery.recover(T_sn, loads=loads)
        return reduction.network.reduction.recover(np.asarray(T_sn, float), reduction.q_recover)


def exported_arrays(inputs: ReductionInputs, rm: ReducedModel) -> dict:
    """The fields of :class:`~fem2tmm.reduce.exported.ExportedRecovery` every method shares, in linear mode, for
    the network ``rm`` (its super-node weights A and names).

    ``inputs.q_recover`` (n_dof,) W: the detailed loads the run recovers with (boundary loads, detailed solar,
    orbit average); each power/flux ``[[boundary]]`` becomes a named unit pattern (its value scales it), the rest is
    the constant part.  Orbital loads traced on the FE faces (``inputs.orbit``) are carried with the time functions
    of :meth:`fem2tmm.stages.orbit.OrbitLoads.add` from ``[transient] start`` (or 0).
    """
    model, case = inputs.model, inputs.case
    names, pats, vals = [], [], []
    q0 = np.array(inputs.q_recover, float)
    for b in case.boundaries:
        if b.kind not in ("power", "flux"):
            continue
        pat = boundary_load(model, case, dataclasses.replace(b, value=1.0))
        names.append(b.name)
        pats.append(pat)
        vals.append(b.value)
        q0 = q0 - b.value * pat
    load_q = sp.csr_matrix(np.array(pats)) if pats else sp.csr_matrix((0, model.n_dof))
    ms = model.mesh.midside
    return dict(K=model.K.tocsr(), A=rm.supernodes.A.tocsr(), names=np.asarray(rm.names).astype(str), q0=q0,
                load_names=np.array(names, dtype=str), load_q=load_q, load_values=np.array(vals, float),
                node_dof=np.asarray(model.node_dof, np.int64), node_ids=np.asarray(model.mesh.node_ids, np.int64),
                midside=np.zeros((0, 3), np.int64) if ms is None else np.asarray(ms, np.int64),
                T_sink=float(model.T_sink), C=_capacitance(model, case), **_orbit_recovery(case, inputs.orbit),
                load_tables=tuple((b.name, b.table.t, b.table.v) for b in case.boundaries
                                  if b.kind in ("power", "flux") and b.table is not None),
                sink_table=None if case.environment.sink_table is None
                else (case.environment.sink_table.t, case.environment.sink_table.v))


def _capacitance(model: FEModel, case: Case) -> sp.csr_matrix | None:
    """The detailed capacitance the recovery in time integrates with (J/K, as the run's detailed transient:
    consistent where ``[transient] capacitance = "consistent"``, lumped otherwise); None without one."""
    if model.capacity is None:
        return None
    if case.transient is not None and case.transient.capacitance == "consistent":
        return consistent_capacity(model)
    return sp.diags(np.asarray(model.capacity, float)).tocsr()


def _orbit_recovery(case: Case, orbit: tuple | None) -> dict:
    """The orbit_* fields of :class:`~fem2tmm.reduce.exported.ExportedRecovery` (none without orbital loads)."""
    if orbit is None:
        return {}
    from ..radiation.orbital import average_weights, hat_basis

    q, times, period = orbit
    start = case.transient.start if case.transient is not None else 0.0
    nodes, H = hat_basis(times, period)
    return {"orbit_q": sp.csr_matrix(np.asarray(q, float)), "orbit_nodes": start + nodes, "orbit_H": H,
            "orbit_weights": average_weights(times, period), "orbit_period": float(period),
            "orbit_start": float(start)}
