"""The transient stage: the case's ``[transient]`` to load, sink and boundary series and the run of the transient
solver on the reduced network or the FE model.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..case import Case
from ..errors import Fem2TmmError, NetworkRefusal, either
from ..fem.model import FEModel, boundary_load
from ..reduce.network import ReducedModel, negative_loads
from ..solve.steady import SteadyProblem
from ..solve.transient import TransientProblem, TransientRun, TransientSettings, recover_series, solve_transient
from ..timefunc import Series, Table
from .orbit import OrbitLoads


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
    temperatures ``T_sn`` (n_t, n_SN) K at ``times`` (n_t,) s, with the named loads' and the sink's table values
    and (``orbital``) the orbital loads of each time, as ``fem2tmm recover`` gives them from a CSV with those rows;
    ``T0`` (n_t, n_dof) K starts each column's Newton.  With the capacitance (a case with density and specific
    heat) and no periodic repetition: in time (:meth:`~fem2tmm.reduce.exported.ExportedRecovery.recover_transient`,
    ``fem2tmm recover --in-time``) with the run's scheme and step, from the steady start or the uniform
    ``initial_temperature``; otherwise each time on its own (quasi-static)."""
    def at(table: Table) -> np.ndarray:
        tab = table.periodic(settings.start, settings.end - settings.start) if settings.periodic else table
        return np.array([float(tab(t)) for t in times])

    named = [b for b in case.boundaries
             if b.table is not None and b.kind != "temperature" and b.name in set(exported.load_names)]
    T_sn = np.asarray(T_sn, float)
    if exported.C is not None and not settings.periodic and len(times) > 1:
        # in time: the heat each super node stores inside it moves as the detailed equations say (the recovery's
        # own capacitance), the loads and the sink at every sub-step from the time tables reduced.npz carries (the
        # case's), as fem2tmm recover --in-time does
        spec = case.transient
        initial = (None if spec.initial_temperature == "steady"
                   else np.full(exported.n_dof, float(spec.initial_temperature)))
        step = settings.step if settings.step is not None else float(np.min(np.diff(times))) / 10.0
        try:
            return exported.recover_transient(T_sn.T, times, step=step, scheme=settings.method, orbital=orbital,
                                              T0=None if T0 is None else T0[0], initial=initial).T
        except Fem2TmmError as exc:  # (a 0 °C start under hundreds of watts, tests/test_robustness.py)
            import warnings

            warnings.warn(f"{exc}; each output time is recovered on its own instead (the quasi-static field, "
                          "fem2tmm recover without --in-time)", stacklevel=2)
    loads = {b.name: at(b.table) for b in named}
    sinks = at(sink)
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
    from ..fem.model import consistent_capacity

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
                                GR=rm.GR, names=tuple(rm.names), g_table=rm.g_space_table)
        run.reduced_problem = prob
        try:
            try:
                run.reduced = solve_transient(prob, settings, initial(T_reduced))
            except Fem2TmmError as exc:
                if prob.g_table is None:
                    raise
                # the deck's couplings to space, tables of each super node's temperature, have no solution along
                # this history (a 0 °C start under a strong heater, tests/test_robustness.py): say so, and integrate
                # the design couplings, as the run did before 2026-12-06
                import warnings

                warnings.warn(f"the network's couplings to space that follow each super node's temperature (the "
                              f"deck's INTRP1 tables) have no solution along this transient ({exc}); the run "
                              "integrates their design values instead, and the deck's own transient will stop as "
                              "this did", stacklevel=2)
                prob = run.reduced_problem = dataclasses.replace(prob, g_table=None)
                run.reduced = solve_transient(prob, settings, initial(T_reduced))
        except Fem2TmmError as exc:
            negative = int(rm.report.get("negative_links", 0))
            if not negative:
                raise
            import re

            when = re.search(r"at t = (\S+) s", str(exc))
            # measured on a generated model (tests/test_robustness.py): the linear thesis network, integrated
            # without the solver's positivity damping, drops below 0 K at the very time the Newton steps fail.
            # The advice names only what can change the network: the radiation-aware reduction where something
            # emits (with nothing emitting, "auto" and true keep the thesis' network, and a box of that kind
            # refused again with true: tests/test_robustness.py), the positive network where the thesis' is used
            # (and the positive network only where the loads' exact distribution has no negative share: it keeps
            # the loads, reduce.network.negative_loads)
            emits = bool(np.any(model.faces.eps_area > 0)) if model.faces is not None else False
            aware = case.reduction.radiation_aware is True
            positive = [] if negative_loads(rm)[1] else (
                ['[reduction] radiation_aware = false with network = "positive"'] if aware else
                ['[reduction] network = "positive"'])
            fixes = positive + (["radiation_aware = true"] if emits and not aware else []) + ["more super nodes"]
            raise NetworkRefusal(
                f"{case.source}: the reduced network has {negative} negative conductances (the exact condensation "
                "of the thesis' reduction), which break the maximum principle: in this transient they drive super "
                f"nodes towards 0 K{'' if when is None else ' (at t = ' + when.group(1) + ' s)'}: the network's "
                f"property, not the physics'; use {either(fixes)}") from None
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
