"""``run(case) -> Result``: the stages in order, timed, with progress, and the output folder.

This module knows only the order of the stages; each stage is one call to a function of
:mod:`fem2tmm.stages` (or of a stage package) that takes the case and plain data and returns plain data, and the
reduction is one call to a reduction method of :mod:`fem2tmm.reductors` (the thesis' first, then the one chosen).
The result is assembled from typed parts (:mod:`fem2tmm.result`: detailed, reduced, orbit, transient).
Nothing is written to the output folder until the whole run has succeeded (:func:`~fem2tmm.export.output.
write_outputs` writes a temporary folder next to it and renames it at the end).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from pathlib import Path

import numpy as np

from .case import Case
from .errors import Fem2TmmError, InternalError, NetworkRefusal
from .cache import digest
from .compute import SceneShelf, cached_stage, map_units, run_concurrently
from .constants import KELVIN
from .export.output import check_output_place, write_cases_outputs, write_outputs
from .export.summary import build_cases_summary, build_summary, network_radiated_W
from .fem.model import build_model
from .fem.plausibility import warn_implausible, warn_once_per_run
from .linalg import pinned_blas
from .mesh import Mesh
from .progress import Progress, report, reporting
from .radiation.compiled import compile_estimate
from .radiation.quadric_scene import QuadricScene
from .radiation.surfaces import TriangleScene
from .radiation.tracer import side_fractions
from .range_checks import deliver_and_verify
from .reduce.network import build_reduced, negative_loads, refresh_reduced, super_faces
from .reductors import ReductionInputs, choose_reduction, first_reductor, reductor_for
from .reductors.radiation_aware import parametric_corrections, parametric_states, set_parametric
from .result import CasesResult, Detailed, Orbit, Reduced, Result
from .solve.steady import check_solvable
from .keys import geometry_key, network_group, reduce_key, scene_key, trace_key
from .reduce.biot import biot_weights, warn_coarse_mesh
from .solve.problems import describe_nodes, detailed_problem, solve_case, solve_unit, solver_settings
from .stages.cluster import check_super_node_counts, cluster_key, cluster_model, load_weights, presolve_space
from .stages.orbit import (OrbitLoads, detailed_orbit, orbit_average, orbit_positions_detailed,
                           orbit_positions_reduced, super_face_orbit)
from .stages.quadrics import fit_quadrics, quadric_regions
from .stages.radiation import (detailed_radiation, emission_check, ir_absorption, mean_faced, radiation_surface,
                               reduced_radiation, reference_noise, traced_area, tracer_settings)
from .stages.choice import measured_choice, reduce_aware
from .stages.refine import Refinement, refinement_step
from .stages.solar import absorbed_solar_maps, detailed_solar, solar_prepass, super_face_solar
from .stages.transient import check_transient, run_transient

__all__ = ["CasesResult", "Result", "detailed_problem", "load_mesh", "run"]


def load_mesh(case: Case) -> Mesh:
    """The mesh of ``[mesh] file`` in ``[mesh] unit``."""
    from .io import read_mesh

    check_mesh_file(case)
    return read_mesh(case.mesh.file, unit=case.mesh.unit, **case.mesh.reader_options())


def check_mesh_file(case: Case) -> None:
    """Raise :class:`Fem2TmmError` naming the case file and its ``[mesh] file`` key where it gives no mesh file, or
    one that does not exist."""
    if case.mesh.file is None:
        raise Fem2TmmError(f"{case.source}: [mesh] file is missing")
    if not Path(case.mesh.file).exists():  # (relative paths are read from the case file's folder)
        raise Fem2TmmError(f"{case.source}: [mesh] file: {case.mesh.file} does not exist (the file is looked for "
                           "relative to the case file's folder): check its name, or export the mesh there")


def run(case: Case, out: str | Path | None = None, mesh: Mesh | None = None, quiet: bool = True,
        reference: bool | None = None, labels: np.ndarray | None = None,
        cache: str | Path | bool | None = None) -> Result | CasesResult:
    """Run ``case``; write the output folder ``out`` (if given) only once everything succeeded.

    ``mesh`` overrides ``[mesh] file`` (e.g. a mesh built with :mod:`fem2tmm.mesh.shapes`); ``reference``
    overrides ``[reference] detailed``.  ``labels`` (n_elements,) int: your own partition into super nodes
    (e.g. from METIS or another tool), one cluster per mesh element (-1 outside the parts), numbered 0 … K−1
    with every number used and each cluster within one part; it replaces the clustering (and the parts'
    ``super_nodes``).  Non-contiguous clusters are accepted with a warning.  A case file with ``[[cases]]`` or ``[sweep]``
    (:mod:`fem2tmm.loadcases`) runs every case and returns a :class:`~fem2tmm.result.CasesResult`
    (outputs: one folder per case in ``out`` and the envelope over the cases); otherwise a
    :class:`~fem2tmm.result.Result`.  Stage results are shared between cases and runs through the stage cache
    (:mod:`fem2tmm.cache`): ``cache`` a folder, default ``<out>/.cache`` (memory only without ``out``), False
    for none.  The work units run where ``[compute] scheduler`` says (:mod:`fem2tmm.compute`).

    Parameters
    ----------
    case : Case
        The validated case (:meth:`Case.from_toml` / :meth:`Case.from_dict`).
    out : str or Path, optional
        Output folder, written atomically once every stage succeeded; None writes nothing.
    mesh : Mesh, optional
        Mesh in metres replacing ``[mesh] file``.
    quiet : bool
        No progress lines on stderr.
    reference : bool, optional
        Overrides ``[reference] detailed`` (the detailed FE reference solve).
    labels : (n_elements,) int array, optional
        User partition into super nodes, -1 outside the parts.
    cache : str, Path or bool, optional
        Stage cache folder; None: ``<out>/.cache`` (memory only without ``out``); False: no cache.

    Returns
    -------
    Result or CasesResult
        Temperatures in K (``T_reduced`` (n_super_nodes,), recovered FE temperatures (n_nodes,)), the reduced
        network and ``summary``; a :class:`~fem2tmm.result.CasesResult` for multi-case files.

    Raises
    ------
    Fem2TmmError
        Bad input (case, mesh, labels, output place), raised before any long computation.
    """
    from .cache import CACHE_DIR, StageCache
    from .compute import executing
    from .case import load_cases

    out = None if out is None else check_output_place(out)  # before any computation
    cases = load_cases(case)  # every case validated before any computation
    warn_once_per_run()  # each unit warning once, whatever the number of cases
    explicit = cache not in (None, True, False)
    store = None if cache is False else StageCache(Path(cache) if explicit else None)
    if store is not None and not explicit and out is not None:
        store.folder = Path(out) / CACHE_DIR  # read from the previous run's outputs, written with the new ones
    meshes = {}
    shelf = SceneShelf()  # the cases' ray scenes, built once per geometry
    results = []
    t0 = time.perf_counter()
    with executing(case.compute.scheduler, case.compute.workers) as ex:
        workers = ex.workers
        jobs = []  # (case, its progress, its mesh), in case order
        for name, c, _ in cases:
            prog = Progress(quiet=quiet, label=name or None)
            key = repr(c.mesh)  # the file and every reader option: cases that share it read it once
            if mesh is None and key not in meshes:
                with prog.stage("read", "reading the mesh"):
                    meshes[key] = load_mesh(c)
            jobs.append((c, prog, mesh if mesh is not None else meshes[key]))
        # a set's cases with BLAS on one thread, serial or concurrent: the same bits on every scheduler
        with pinned_blas(1 if len(jobs) > 1 else None):
            linearised = _shared_linearisations(cases, jobs, store, labels, shelf)
            if not ex.distributed:  # in this process: one case after the other
                for c, prog, m in jobs:
                    with reporting(prog.callback()):
                        results.append(_run(c, prog, m, reference, store, labels, shelf=shelf,
                                            linearised=linearised))
            else:
                def one(c, prog, m, view):
                    return _run(c, prog, m, reference, view, labels, shelf=shelf, linearised=linearised)

                results = run_concurrently(ex, jobs, one, store, quiet)
    if len(cases) == 1 and not cases[0][0]:
        result = results[0]
        if out is not None:
            with prog.stage("write", f"writing the outputs to {out}"):
                result.out = write_outputs(result, out, timings=prog.timings, cache=None if explicit else store)
        if explicit:
            store.commit()
        return result
    if set_parametric(results):  # each deck of a shared network follows the constants between the set's cases
        from .export.summary import parametric_summary

        for r in results:
            if r.reduced is not None and r.reduced.parametric is not None:
                r.summary.setdefault("reduced", {})["parametric"] = parametric_summary(r)
                if r.reduced.parametric.get("from") == "the case set":  # a deck the validity check did not see
                    from .verify import superseded

                    r.reduced.verified = r.summary["reduced"]["verified"] = superseded(r.reduced.verified)
    multi = CasesResult(case=case, results={n: r for (n, _, _), r in zip(cases, results)},
                        parameters={n: p for n, _, p in cases})
    multi.summary = build_cases_summary(multi, {"scheduler": case.compute.scheduler, "workers": workers},
                                        time.perf_counter() - t0)
    if out is not None:
        prog = Progress(quiet=quiet)
        with prog.stage("write", f"writing the outputs to {out}"):
            multi.out = write_cases_outputs(multi, out, cache=None if explicit else store)
    if explicit:
        store.commit()
    return multi


def _shared_linearisations(cases: list, jobs: list, store, labels, shelf) -> dict | None:
    """One network per group of load cases (:func:`~fem2tmm.keys.network_group`) for the radiation-aware
    reduction: ``{group: {"T": (n_dof,) K or None, "aware": bool, "case": name, "cases": [names]}}`` for the groups
    of two cases or more, the emission of every case of a group linearised about the converged field of the
    group's first case (in file order, so the same on every scheduler), computed by a reduced run of that case
    without its reference (its clustering, traces and reduction are then reused by the cases through the stage
    cache).  ``aware``: whether that run used the radiation-aware reduction (with ``radiation_aware = "auto"``
    the first case chooses for its group; ``T`` None when it chose the thesis').  None for a single case or
    without such groups."""
    aware = [(n, c, j) for (n, c, _), j in zip(cases, jobs)
             if c.reduction.enabled and c.reduction.radiation_aware is not False]
    if len(cases) < 2 or not aware:
        return None
    members: dict = {}
    for n, c, j in aware:
        members.setdefault(network_group(c), []).append((n, c, j))
    groups: dict = {}
    for g, cs in members.items():
        if len(cs) < 2:  # a network of its own: its own outer iterations linearise it
            continue
        n, c, (_, prog, m) = cs[0]
        with reporting(prog.callback()), prog.stage("linearise", "the shared network's linearisation state"):
            first = _run(c, Progress(quiet=True), m, False, store, labels, shelf=shelf)
        # radiation_aware = "auto": the group's first case decides for the whole group (one network for the set)
        chosen = first.reduced is not None and first.reduced.method == "radiation_aware"
        groups[g] = {"T": first.reduced.T_recovered if chosen else None, "aware": chosen, "case": n,
                     "cases": [x[0] for x in cs]}
    return groups or None


class _Scenes:
    """The case's ray scenes, each built on first use (a stage whose result is cached needs none), taken from the
    run's :class:`SceneShelf` when another case of the run built one for the same geometry."""

    def __init__(self, surface, shelf: SceneShelf | None = None):
        self.surface = surface
        self.shelf = SceneShelf() if shelf is None else shelf
        self.fit = None  # (quadrics, quadric_of_face, report) when parts are traced against quadrics
        self._flat = self._main = None
        self._geometry = None

    def _key(self, *more) -> tuple:
        if self._geometry is None:
            self._geometry = digest("scene", self.surface.points, self.surface.faces)
        return (self._geometry, *more)

    def flat(self) -> TriangleScene:
        if self._flat is None:
            self._flat = self.shelf.get(self._key("flat"), lambda: TriangleScene(self.surface))
        return self._flat

    def main(self) -> TriangleScene:
        """Quadrics where the case asks for them, flat triangles elsewhere."""
        if self.fit is None:
            return self.flat()
        if self._main is None:
            self._main = self.shelf.get(self._key("quadric", scene_key(self.fit)),
                                        lambda: QuadricScene(self.surface, self.fit[1], self.fit[0]))
        return self._main


@dataclasses.dataclass
class _RunState:
    """What the stages of one :func:`_run` share: the case as the stages see it (the reduction's choice may replace
    it: ``case``; ``asked`` as given), the FE model, the stage cache and its status, the ray surface and scenes with
    their keys, and the result's parts being filled."""

    case: Case
    asked: Case
    prog: Progress
    store: object
    model: object
    result: Result
    do_ref: bool
    trace: bool  # exchange factors traced
    sun: bool
    orbit: object  # ``case.orbit`` when something radiates, else None
    surface: object
    scenes: _Scenes
    geometry: str | None
    ir: object
    solar: object
    dpart: Detailed
    opart: Orbit | None
    skey: str | None = None  # the scene's key (the quadric fit)
    # ``radiation_aware = "auto"`` kept the radiation-aware network by its design-state estimate: the thesis' reduction
    # (not delivered) and the inputs it ran with, checked over the same validity range after the reference
    alternative: tuple | None = None
    # the a-posteriori estimate's two half IR tallies (stages/choice.py), shared by the range's estimate
    tallies: dict = dataclasses.field(default_factory=dict)

    @property
    def status(self) -> dict:
        return self.result.cache

    def tracing(self) -> tuple:
        """``(surface, scene)`` of the estimators' IR tallies, ``(None, None)`` when no exchange is traced."""
        return (self.surface, self.scenes.main()) if self.trace else (None, None)

    def cached(self, stage: str, label: str, key, compute):
        return cached_stage(self.prog, self.store, self.status, stage, label, key, compute)

    def sun_key(self, stage: str, scene: str, role: str, *more) -> str:
        env = self.asked.environment
        return trace_key(stage, self.geometry, self.solar, scene, env.sun_direction, env.solar_flux,
                         env.solar_rays_per_face, tracer_settings(self.case, exchange=False, role=role), *more)

    def orbit_key(self, stage: str, *more) -> str:  # exactly what trace_orbit reads: both bands' optics, the orbit
        orbit = self.orbit
        return trace_key(stage, self.geometry, (self.solar, self.ir), self.skey, orbit.orbit, orbit.attitude,
                         orbit.kinds, orbit.rays_per_face, tracer_settings(self.case, exchange=False), *more)


@dataclasses.dataclass
class _Network:
    """The reduced network before a reduction method: conduction, radiation and this case's loads."""

    rm: object  # the network with the orbit-averaged loads
    rm_base: object  # ... without them
    sf: tuple | None  # super faces
    q_recover: np.ndarray  # (n_dof,) W loads recovered exactly
    q_recover_base: np.ndarray
    q_lumped: np.ndarray  # (n_SN,) W loads lumped per super node
    q_sn_orbit: np.ndarray | None  # (k, n_SN) W per orbit position
    inputs: ReductionInputs


def _run(case: Case, prog: Progress, mesh: Mesh | None, reference: bool | None, store=None,
         labels: np.ndarray | None = None, refine: Refinement | None = None,
         shelf: SceneShelf | None = None, linearised: dict | None = None) -> Result:
    mesh, run, problem = _prepare(case, prog, mesh, reference, store, labels, shelf)
    result = run.result
    clustering = reduced = reductor = ckey = None
    extra = {}  # what the run adds to the reduction method's output (result.reduced)
    if case.reduction.enabled:
        clustering, ckey = _cluster(run, labels, refine)
    _quadrics(run, clustering)
    q_solar = _detailed_solar(run)  # (n_dof,) W or None
    q_orbit = _detailed_orbit(run)  # (k, n_dof) W per position or None
    q_sn_orbit = None  # (k, n_SN) W per position
    if case.reduction.enabled:
        net = _reduced_network(run, clustering, ckey, q_solar, q_orbit, extra)
        q_sn_orbit = net.q_sn_orbit
        reduced, reductor, red = _reduce(run, net, clustering, linearised, extra)
        if run.trace:
            _emission_check(run, net, reduced, red, extra["radiation"])
        if run.case.reduction.target_rms is not None:  # error-driven refinement: split, then the next round
            refine = Refinement() if refine is None else refine
            nxt = _refinement_step(run, net, clustering, reduced, red, refine)
            if nxt is not None:
                return _run(case, prog, mesh, reference, store, labels=nxt, refine=refine, shelf=run.scenes.shelf,
                            linearised=linearised)
            reduced.refinement = refine
        _parametric(run, mesh, reduced)
        if q_sn_orbit is not None and run.orbit.steady == "positions":
            _orbit_positions_reduced(run, net, reduced, q_orbit)
    if run.do_ref or not run.case.reduction.enabled:  # the detailed reference model (with its own random streams)
        problem = _reference(run, problem, q_solar, q_orbit)
    result.detailed, result.orbit = run.dpart, run.opart
    if run.case.transient is not None:
        try:
            _transient(run, reduced, reductor, problem, q_orbit, q_sn_orbit)
        except NetworkRefusal as exc:
            asked = run.asked.reduction
            if (reduced is None or asked.radiation_aware != "auto" or asked.network != "exact"
                    or negative_loads(reduced.network)[1]):
                raise  # (the user chose the network, or a positive one keeps negative loads: the refusal says so)
            reduced, reductor = _positive_instead(run, net, clustering, extra, mesh, q_orbit, str(exc))
            _transient(run, reduced, reductor, problem, q_orbit, q_sn_orbit)
    if reduced is not None:
        deliver_and_verify(run, reduced, problem, net, q_orbit, _hand_over)
    result.summary = build_summary(result, prog.timings)
    return result


def _prepare(case: Case, prog: Progress, mesh: Mesh | None, reference: bool | None, store,
             labels: np.ndarray | None, shelf: SceneShelf | None):
    """Read and assemble, check the case against the model, and set up what the stages share: the mesh, the
    :class:`_RunState` and the detailed problem (without radiation and external loads)."""
    if case.clustering.method == "metis" and labels is None:
        from .cluster.metis import require

        require()  # the optional dependency, before any long computation
    if mesh is None:
        with prog.stage("read", "reading the mesh"):
            mesh = load_mesh(case)
    with prog.stage("assemble", "assembling the FE model"):
        model = build_model(mesh, case)
    check_transient(model, case)
    warn_implausible(model, case)  # unit mistakes, once, before the long computation
    do_ref = case.reference.detailed if reference is None else reference
    problem = detailed_problem(model)
    check_solvable(problem, describe=describe_nodes(model))
    radiating = bool(model.faces.active.any())
    trace = case.radiation.enabled and radiating
    sun = case.has_sun and radiating
    orbit = case.orbit if radiating else None
    surface = radiation_surface(model) if (trace or sun or orbit) else None
    if trace:  # the exchange-factor kernels (a Sun-only run compiles fewer and is not announced)
        seconds = compile_estimate()
        if seconds > 0:
            prog.note(f"compiling the ray tracer's kernels (first run after an install, ~{seconds:.0f} s)")
    return mesh, _RunState(
        case=case, asked=case, prog=prog, store=store, model=model,
        result=Result(case=case, mesh=mesh, model=model, cache={}), do_ref=do_ref, trace=trace, sun=sun,
        orbit=orbit, surface=surface,
        scenes=_Scenes(surface, shelf),  # the ray scenes, built when a stage traces (a cached stage needs none)
        geometry=geometry_key(model) if surface is not None else None,
        ir=surface.optics("ir") if surface is not None else None,
        solar=surface.optics("solar") if surface is not None else None,
        dpart=Detailed(),  # the detailed model's part of the result (its fields set by the stages that run)
        opart=Orbit() if orbit is not None else None), problem


def _cluster(run: _RunState, labels: np.ndarray | None, refine: Refinement | None):
    """Super nodes (following a coarse solar map when asked, weighted by Biot numbers when asked): the
    clustering and its cache key."""
    model, case, prog = run.model, run.case, run.prog
    flux = None
    if run.sun and case.solar_aware:
        flux = run.cached("solar_prepass", "tracing a coarse solar map for the clustering",
                          lambda: run.sun_key("solar_prepass", "flat", "prepass"),
                          lambda: solar_prepass(model, case, run.surface, scene=run.scenes.flat()))
    weights = weights_report = marks = None
    if case.clustering.allocation == "biot" and labels is None:
        check_super_node_counts(model, case)  # before the pre-solve
        with prog.stage("presolve_biot", "pre-solve for the Biot numbers (emission to space only)"):
            weights, weights_report = biot_weights(model, presolve_space(model, case))
        if case.reduction.radiation_aware is not True:  # (that one warns from its own pre-solve)
            warn_coarse_mesh(sum(r["elements_over_1"] for r in weights_report.values()),
                             max((r["max"] for r in weights_report.values()), default=None))
    if case.clustering.allocation == "loads" and labels is None:
        # (the default: where no load is concentrated on shells the weights are all NaN and the clusters keep equal
        # areas, as with "area"; summary.json reduced.clustering.allocation gives each load's share and reach)
        weights, weights_report, marks = load_weights(model, case)
    ckey = cluster_key(model, case, flux, labels, weights, marks)
    clustering = run.cached(
        "cluster", "clustering", lambda: ckey,
        lambda: cluster_model(model, case, progress=lambda i, n: report(i, n, "regions clustered"), flux=flux,
                              labels=labels, weights=weights, weights_report=weights_report, marks=marks))
    if refine is None and case.reduction.target_rms is not None:
        from .reduce.refine import check_budget

        check_budget(case.reduction.target_rms, case.reduction.max_super_nodes, len(clustering.cluster_part))
    return clustering, ckey


def _quadrics(run: _RunState, clustering) -> None:
    """Quadrics where the case asks for them (the scene itself is built when a stage traces); sets the scene key."""
    if run.surface is not None and any(p.quadric for p in run.case.parts):
        regions = quadric_regions(run.model, run.case, clustering)
        run.scenes.fit = run.cached("quadrics", "fitting quadrics", lambda: digest("quadrics", *regions),
                                    lambda: fit_quadrics(*regions))
        run.result.quadrics = run.scenes.fit[2]
    run.skey = scene_key(run.scenes.fit)


def _detailed_solar(run: _RunState) -> np.ndarray | None:
    """Solar nodal loads (n_dof,) W on the detailed mesh, when the reference or the reduction needs them."""
    case = run.case
    if not (run.sun and (run.do_ref or not case.reduction.enabled or case.environment.solar_on == "detailed")):
        return None
    q_solar, run.dpart.solar = run.cached(
        "solar_detailed", "tracing solar rays on the detailed mesh",
        lambda: run.sun_key("solar_detailed", run.skey, "reference"),
        lambda: detailed_solar(run.model, case, run.surface, scene=run.scenes.main()))
    run.result.absorbed_solar_faces, run.result.absorbed_solar_elements = absorbed_solar_maps(run.model,
                                                                                              run.dpart.solar)
    return q_solar


def _detailed_orbit(run: _RunState) -> np.ndarray | None:
    """Orbital loads (solar, albedo, planet IR) (k, n_dof) W at every position on the detailed mesh, when needed."""
    case, orbit = run.case, run.orbit
    if orbit is None or not (run.do_ref or not case.reduction.enabled or orbit.fluxes_on == "detailed"):
        return None
    q_orbit, run.opart.detailed = run.cached(
        "orbit_detailed", "tracing orbital fluxes on the detailed mesh", lambda: run.orbit_key("orbit_detailed"),
        lambda: detailed_orbit(run.model, case, run.surface, scene=run.scenes.main()))
    return q_orbit


def _reduced_network(run: _RunState, clustering, ckey: str, q_solar: np.ndarray | None,
                     q_orbit: np.ndarray | None, extra: dict) -> _Network:
    """Conduction reduced, super-face radiation, solar and orbital loads: the reduction method's inputs."""
    model, case, orbit, opart, surface, scenes = run.model, run.case, run.orbit, run.opart, run.surface, run.scenes
    rm = run.cached("reduce", "reducing conduction", lambda: reduce_key(model, case, ckey),
                    lambda: build_reduced(model, clustering, case))
    rm = refresh_reduced(rm, model)  # this case's loads, boundary temperatures, sink and optics
    sf = super_faces(model, rm) if surface is not None else None
    if run.trace:
        GR, g_space, extra["radiation"], extra["super_faces_count"] = run.cached(
            "radiation", "tracing super-face exchange factors",
            lambda: trace_key("radiation", run.geometry, run.ir, run.skey, sf, rm.n, tracer_settings(case)),
            lambda: reduced_radiation(model, rm, case, surface, scene=scenes.main(), sf=sf))
        rm = dataclasses.replace(rm, GR=GR, g_space=g_space)
    q_recover = model.Q
    q_lumped = np.zeros(rm.n)  # loads lumped per super node (super-face solar)
    if run.sun:
        if case.environment.solar_on == "detailed":
            # exact power distribution: q_SN = Y q; the non-uniform part stays in the recovery (X q)
            q_sn = rm.reduction.distribute(q_solar)
            q_recover = model.Q + q_solar
        else:
            q_sn, extra["solar"], _ = run.cached(
                "solar", "tracing solar rays on the super faces",
                lambda: run.sun_key("solar", run.skey, "reduced", sf, rm.n),
                lambda: super_face_solar(model, rm, case, surface, scene=scenes.main(), sf=sf))
            if run.result.absorbed_solar_elements is None:
                run.result.absorbed_solar_faces, run.result.absorbed_solar_elements = absorbed_solar_maps(
                    model, extra["solar"])
            q_lumped = q_sn
        rm = dataclasses.replace(rm, Q=rm.Q + q_sn)
        extra["solar_on"] = case.environment.solar_on
    q_sn_orbit = None
    if orbit is not None:
        if orbit.fluxes_on == "detailed":
            q_sn_orbit = rm.reduction.distribute(q_orbit.T).T  # exact distribution, per position
        else:
            q_sn_orbit, opart.super_faces = run.cached(
                "orbit", "tracing orbital fluxes on the super faces", lambda: run.orbit_key("orbit", sf, rm.n),
                lambda: super_face_orbit(model, rm, case, surface, scene=scenes.main(), sf=sf))
        opart.fluxes_on = orbit.fluxes_on
    rm_base, q_recover_base = rm, q_recover
    if q_sn_orbit is not None:  # the steady case: orbit-averaged loads
        q_sn_avg = orbit_average(opart.fluxes, q_sn_orbit)
        rm = dataclasses.replace(rm, Q=rm.Q + q_sn_avg)
        if orbit.fluxes_on == "detailed":
            q_recover = q_recover + orbit_average(opart.fluxes, q_orbit)
        else:
            q_lumped = q_lumped + q_sn_avg
    orbit_rec = None  # orbital loads traced on the FE faces travel with the recovery
    if q_orbit is not None and orbit.fluxes_on == "detailed":
        pos = opart.fluxes.positions
        orbit_rec = (q_orbit, pos.time, pos.period)
    fates = (side_fractions(sf[0], extra["radiation"].blocked, extra["radiation"].space) if run.trace
             else (None, None))
    inputs = ReductionInputs(model=model, case=case, clustering=clustering, network=rm,
                             q_recover=q_recover, q_lumped=q_lumped, orbit=orbit_rec,
                             unblocked=fates[0], to_space=fates[1],
                             # (a flat scene traces the facets: no scene is built for that answer)
                             traced_area=traced_area(scenes.main(), model) if run.trace and scenes.fit else None,
                             ir_on_asked=case.radiation.ir_on,
                             trace_ir=(lambda c: ir_absorption(model, rm, c, surface, scene=scenes.main(), sf=sf))
                             if run.trace else None)
    return _Network(rm=rm, rm_base=rm_base, sf=sf, q_recover=q_recover, q_recover_base=q_recover_base,
                    q_lumped=q_lumped, q_sn_orbit=q_sn_orbit, inputs=inputs)


def _reduce(run: _RunState, net: _Network, clustering, linearised: dict | None, extra: dict):
    """The thesis' reduction first (the network when nothing else is chosen, else the next method's start), the
    choice, the chosen method and its delivery.  Sets ``run.case`` to the case the chosen method ran and
    ``run.result.reduced``; returns ``(reduced, reductor, red)`` (``red`` the method's delivered output)."""
    model, case, prog, inputs = run.model, run.case, run.prog, net.inputs
    reductor = first_reductor(case)
    thesis_failed = None
    try:
        red = reductor.reduce(inputs, prog)
    except Fem2TmmError as exc:
        if (case.reduction.radiation_aware is False or case.reduction.network == "positive"
                or not np.any(model.space_coupling() > 0)):
            raise
        # the thesis' network has no physical solution (its negative conductances, a strong heater on a thin
        # panel): the radiation-aware reduction needs none, it starts from the detailed field radiating to
        # space (issue 42: a thin composite bracket at 30 super nodes, 40 W)
        thesis_failed = str(exc)
        with prog.stage("presolve_space", "the detailed field radiating to space (the thesis' network has no "
                                          "physical solution)"):
            T_start = presolve_space(model, case)
        red = Reduced(method=reductor.name, network=net.rm, solution=None, T_recovered=T_start,
                      q_recover=net.q_recover, case=case)
        case = dataclasses.replace(case, reduction=dataclasses.replace(case.reduction, radiation_aware=True))
    group = (linearised or {}).get(network_group(case)) if case.reduction.radiation_aware is not False else None
    if group is not None and case.reduction.radiation_aware == "auto":  # the set's choice, made by its first case
        case = dataclasses.replace(case, reduction=dataclasses.replace(case.reduction,
                                                                      radiation_aware=group["aware"]))
    case, choice = choose_reduction(model, case, red.network, red.T_recovered)
    if thesis_failed is not None:
        choice = {**choice, "chosen_by": "the thesis' network has no physical steady solution (its negative "
                                         "conductances): the radiation-aware reduction, started from the "
                                         "detailed field radiating to space",
                  "thesis_refused": thesis_failed}
    if group is not None and case.reduction.radiation_aware:
        extra["shared_network"] = {"linearised_at": group["case"], "cases": list(group["cases"])}
    inputs = net.inputs = dataclasses.replace(inputs, case=case, linearised_at=None if group is None else group["T"])
    if case.reduction.radiation_aware == "auto":  # the estimated errors decide
        red, choice, thesis = measured_choice(inputs, red, choice, prog, *run.tracing(), extra.get("radiation"),
                                               run.tallies)
        case, reductor = red.case, reductor_for(red.case)
        extra.update({} if thesis is None else {"thesis_T_recovered": thesis.T_recovered})
        run.alternative = None if thesis is None else (thesis, inputs)
    elif reductor_for(case).name != reductor.name:
        if thesis_failed is None:
            extra["thesis_T_recovered"] = red.T_recovered
        reductor = reductor_for(case)
        red = reduce_aware(inputs, prog, red, thesis_failed)  # (the only other method: radiation-aware)
        if red.network.radiative is not None and not red.network.radiative.shared:
            extra.pop("shared_network", None)  # left the set's network (no solution there): its own
        if red.notes:
            choice = {**choice, "ir_on": red.case.radiation.ir_on,
                      "chosen_by": "; ".join([choice["chosen_by"], *red.notes])}
        case = red.case
    run.case = case
    red = reductor.deliver(dataclasses.replace(inputs, case=case), red, prog)
    reduced = run.result.reduced = dataclasses.replace(red, clustering=clustering, choice=choice, **extra)
    return reduced, reductor, red


def _unblocked(net: _Network, red: Reduced) -> np.ndarray | None:
    """The emission every method shares: the unblocked fraction per side (εA (1 − blocked), issue 42)."""
    return red.ir.unblocked if red.ir is not None and red.ir.unblocked is not None else net.inputs.unblocked


def _emission_check(run: _RunState, net: _Network, reduced: Reduced, red: Reduced, res) -> None:
    """One emission for every method: the network's radiation to space against its field's (issue 42)."""
    ir_sides = red.ir is not None and red.ir.to_space is not None
    reduced.emission_check = emission_check(
        run.model.with_unblocked(None, net.inputs.traced_area), network_radiated_W(reduced.network, reduced.solution),
        reduced.T_recovered, red.ir.to_space if ir_sides else net.inputs.to_space, res.blocked, res.eps_area,
        net.rm.part[net.sf[1]], warn=reduced.method == "radiation_aware" and run.alternative is None)


def _refinement_step(run: _RunState, net: _Network, clustering, reduced: Reduced, red: Reduced,
                     refine: Refinement) -> np.ndarray | None:
    """The error-driven refinement's estimate: the next round's labels, or None when the target is met."""
    with run.prog.stage("refine", "estimating the recovery error (error-driven refinement)"):
        model = run.model.with_unblocked(_unblocked(net, red), net.inputs.traced_area)
        return refinement_step(model, clustering, run.case,
                               reduced.network, reduced.solution.T, reduced.T_recovered, net.q_recover,
                               net.q_lumped, reduced.ir, refine, *run.tracing())


def _parametric(run: _RunState, mesh: Mesh, reduced: Reduced) -> None:
    """The radiation-aware network's correction load at the parametric states, with this network's
    linearisation (same K̃, GR, C); a warning when the run's network is the thesis'."""
    asked, case = run.asked, run.case
    if asked.reduction.parametric and reduced.method == "radiation_aware":
        states = parametric_states(asked)
        with run.prog.stage("parametric", f"the network's correction at {len(states)} parametric states"):
            at = {"T": reduced.network.radiative.T_built, "aware": True, "case": "design", "cases": []}
            runs = []
            celsius = {b.name for b in asked.boundaries if b.kind == "temperature"} | {"sink"}
            for name, value, c in states:
                where = (f"{case.source}: [reduction] parametric {name} = "
                         f"{value - KELVIN if name in celsius else value:g}")
                try:
                    r = _run(c, Progress(quiet=True), mesh, False, run.store, shelf=run.scenes.shelf,
                             linearised={network_group(c): at})
                except Fem2TmmError as exc:
                    raise Fem2TmmError(f"{where}: that state has no solution on this network ({exc}); "
                                       "narrow the values") from None
                if r.reduced.method != reduced.method or r.reduced.choice["ir_on"] != reduced.choice["ir_on"]:
                    raise Fem2TmmError(
                        f"{where}: that state ran {r.reduced.method} with ir_on = {r.reduced.choice['ir_on']!r}, "
                        f"not the design's {reduced.method} with {reduced.choice['ir_on']!r}, so its correction "
                        "does not belong to this network; narrow the values or set [radiation] ir_on explicitly")
                runs.append((name, value, r.reduced))
            reduced.parametric = parametric_corrections(
                reduced, asked, [n for n, _ in asked.reduction.parametric], runs)
            if reduced.parametric["gl_change"] > 1e-9:  # the states must share this network's GL
                raise InternalError(f"the parametric states' networks differ from the design's by "
                                    f"{reduced.parametric['gl_change']:.3g} (relative GL)")
    elif asked.reduction.parametric:
        warnings.warn(f"{case.source}: [reduction] parametric is not used: the run's network is the thesis' "
                      f"({reduced.choice['chosen_by']}), which is state-independent: a named constant edited in "
                      "the deck already gives what fem2tmm gives", stacklevel=3)


def _orbit_positions_reduced(run: _RunState, net: _Network, reduced: Reduced, q_orbit: np.ndarray | None) -> None:
    """The reduced model solved at every orbit position (the steady case with ``steady = "positions"``)."""
    orbit, opart, q_sn_orbit = run.orbit, run.opart, net.q_sn_orbit
    with run.prog.stage("orbit_positions", "solving the reduced model at every orbit position"):
        if reduced.method == "radiation_aware":  # the network handed over: the average and each departure
            red = reduced.network
            if orbit.fluxes_on == "detailed":
                dq = q_orbit - orbit_average(opart.fluxes, q_orbit)
                pos_args = (reduced.q_recover, red.reduction.distribute(dq.T).T, dq)
            else:
                pos_args = (reduced.q_recover, q_sn_orbit - orbit_average(opart.fluxes, q_sn_orbit), None)
            opart.T_positions = orbit_positions_reduced(red, *pos_args, reduced.solution.T, run.case,
                                                        exported=reduced.recovery, T_ref=reduced.T_recovered)
        else:
            opart.T_positions = orbit_positions_reduced(
                net.rm_base, net.q_recover_base, q_sn_orbit, q_orbit if orbit.fluxes_on == "detailed" else None,
                reduced.solution.T, run.case)


def _reference(run: _RunState, problem, q_solar: np.ndarray | None, q_orbit: np.ndarray | None):
    """The detailed reference model (with its own random streams; two independent halves estimate its noise):
    its exchange factors and loads, its steady solution, its noise and its orbit positions.  Returns its problem
    (with the orbit-averaged loads)."""
    model, case, prog, dpart, opart, orbit = run.model, run.case, run.prog, run.dpart, run.opart, run.orbit
    noise = run.do_ref and case.reduction.enabled and case.reference.noise
    halves = []  # the problems of the two half references, when the reference is noisy
    if run.trace:
        ref = case.reference

        def detailed_refs(role: str = "reference", fraction: float = 1.0):
            return run.cached("radiation_detailed", "tracing FE-face exchange factors (detailed model)",
                              lambda: trace_key("radiation_detailed", run.geometry, run.ir, run.skey,
                                                tracer_settings(case, ref.rays_per_face, ref.ray_density, role=role,
                                                                fraction=fraction)),
                              lambda: detailed_radiation(model, case, run.surface, rays_per_face=ref.rays_per_face,
                                                         ray_density=ref.ray_density, scene=run.scenes.main(),
                                                         role=role, fraction=fraction))

        if noise:
            parts = [detailed_refs(role, 0.5) for role in ("reference", "reference_b")]
            halves = [dataclasses.replace(problem, faced=fr, g_space=gs) for fr, gs, _ in parts]
            faced, g_space = mean_faced([p[0] for p in parts]), 0.5 * (parts[0][1] + parts[1][1])
            dpart.radiation = parts[0][2]
            dpart.halves = 2
        else:
            faced, g_space, dpart.radiation = detailed_refs()
        problem = dataclasses.replace(problem, faced=faced, g_space=g_space)
    q_ref = q_solar
    if q_solar is not None and noise and case.reduction.enabled and case.environment.solar_on != "detailed":
        # the reference's own solar loads are noisy too: a second independent tracing
        q_b, _ = run.cached("solar_detailed_b", "tracing a second, independent detailed solar map (reference noise)",
                            lambda: run.sun_key("solar_detailed", run.skey, "reference_b"),
                            lambda: detailed_solar(model, case, run.surface, scene=run.scenes.main(),
                                                   role="reference_b"))
        halves = halves or [problem, problem]
        halves = [dataclasses.replace(h, Q=h.Q + q) for h, q in zip(halves, (q_solar, q_b))]
        q_ref = 0.5 * (q_solar + q_b)
    elif q_solar is not None:
        halves = [dataclasses.replace(h, Q=h.Q + q_solar) for h in halves]
    if q_ref is not None:
        problem = dataclasses.replace(problem, Q=problem.Q + q_ref)
    base = problem  # without the orbital loads
    if q_orbit is not None:  # the steady case: orbit-averaged loads
        q_avg = orbit_average(opart.fluxes, q_orbit)
        problem = dataclasses.replace(problem, Q=problem.Q + q_avg)
        halves = [dataclasses.replace(h, Q=h.Q + q_avg) for h in halves]
    tr = case.transient
    optional = tr is not None and tr.initial_temperature != "steady" and case.reduction.enabled
    if not optional or case.reference.steady:
        with prog.stage("solve_detailed", "solving the detailed model"):
            try:
                dpart.solution = solve_case(problem, case)
            except Fem2TmmError as exc:
                if not optional:
                    raise
                # asked for, but a transient from a given temperature does not need it
                warnings.warn(f"the detailed steady reference failed and is left out; the transient goes on: {exc}",
                              stacklevel=3)
                halves = []
    else:  # a transient from a given temperature: its detailed reference needs no steady solution
        halves = []
    if halves:
        with prog.stage("reference_noise", "solving the two half references (reference noise)"):
            Ta, Tb = (s.T for s in map_units(solve_unit, halves, shared=solver_settings(case), what="steady solves"))
        dpart.noise = reference_noise(model, Ta, Tb)
    if q_orbit is not None and orbit.steady == "positions" and dpart.solution is not None:
        with prog.stage("orbit_positions_detailed", "solving the detailed model at every orbit position"):
            T = orbit_positions_detailed(base, q_orbit, dpart.solution.T, case)
            if case.reduction.enabled:
                opart.T_positions_detailed = T
            else:
                opart.T_positions = T
    return problem


def _transient(run: _RunState, reduced: Reduced | None, reductor, problem, q_orbit: np.ndarray | None,
               q_sn_orbit: np.ndarray | None) -> None:
    """The reduced model in time (recovered at every output time) and the detailed reference."""
    case, orbit, opart, dpart = run.case, run.orbit, run.opart, run.dpart
    net = None if reduced is None else reduced.network
    # the exported recovery recovers the run's transient and per-position fields when it is the method's own
    exported = reduced.recovery if reduced is not None and reductor.field_from_export else None
    with run.prog.stage("transient", "integrating the transient"):
        rs, det = (None if reduced is None else reduced.solution), dpart.solution
        orbit_loads = None
        if q_orbit is not None or q_sn_orbit is not None:  # loads in time along the orbit
            pos = opart.fluxes.positions
            q_sn_t = q_sn_orbit
            if (q_orbit is not None and orbit.fluxes_on == "detailed" and net is not None
                    and net.radiative is not None):  # the radiation-aware network's own Y'
                q_sn_t = net.reduction.distribute(q_orbit.T).T
            orbit_loads = OrbitLoads(times=pos.time, period=pos.period, q_sn=q_sn_t, q_dof=q_orbit,
                                     recover_dof=orbit.fluxes_on == "detailed")
        with_ref = run.do_ref or not case.reduction.enabled
        run.result.transient = run_transient(case, run.model, net, None if rs is None else rs.T,
                                             None if reduced is None else reduced.q_recover,
                                             problem if with_ref else None, None if det is None else det.T,
                                             orbit=orbit_loads, exported=exported)


def _positive_instead(run: _RunState, net: _Network, clustering, extra: dict, mesh: Mesh, q_orbit: np.ndarray | None,
                      refusal: str) -> tuple[Reduced, object]:
    """The default's network when the chosen one's transient was refused for its negative conductances
    (:class:`~fem2tmm.errors.NetworkRefusal`): the thesis' reduction with a positive network (``network =
    "positive"``), whose maximum principle holds, reduced, checked and handed over in its place; the choice record
    says why.  A generated box with nothing emitting and a 164 W heater on 0.1 mm walls was refused before
    (tests/test_robustness.py)."""
    asked, first = run.asked, run.result.reduced
    run.case = dataclasses.replace(asked, reduction=dataclasses.replace(asked.reduction, network="positive"))
    net.inputs = dataclasses.replace(net.inputs, case=run.case)  # (the first method's resolved case: not this one's)
    run.alternative = None  # (the first choice's other candidate: not weighed against this network)
    if first.method == "thesis":  # its field stays the run's thesis' figure (summary accuracy.thesis_method)
        extra["thesis_T_recovered"] = first.T_recovered
    reduced, reductor, red = _reduce(run, net, clustering, None, extra)
    cause = refusal.removeprefix(f"{asked.source}: ").split("; use ")[0]
    what = "radiation-aware" if first.method == "radiation_aware" else "thesis'"
    reduced.choice = {**reduced.choice, "network_refused": {"method": first.method, "choice": first.choice,
                                                            "refusal": refusal},
                      "chosen_by": f"auto: the {what} network was refused in the transient ({cause}): the thesis' "
                                   "reduction with a positive network (network = \"positive\") replaces it"}
    fit = (reduced.method_report or {}).get("T_vs_exact_K") or {}
    warnings.warn(f"{asked.source}: {reduced.choice['chosen_by']}; at the design state it is "
                  f"{fit.get('max', 0.0):.3g} K from the exact condensation at most (summary.json "
                  "reduced.method_report); with more super nodes the exact network may integrate it", stacklevel=3)
    if run.trace:
        _emission_check(run, net, reduced, red, extra["radiation"])
    _parametric(run, mesh, reduced)
    if net.q_sn_orbit is not None and run.orbit.steady == "positions":
        _orbit_positions_reduced(run, net, reduced, q_orbit)
    return reduced, reductor


def _hand_over(run: _RunState, net: _Network, alt: Reduced, q_orbit: np.ndarray | None) -> None:
    """Hand over ``alt`` in place of the network verified first: read back and recovered again, its emission checked,
    the orbit positions of ``steady = "positions"`` solved on it."""
    from .handover import check_deliverable

    run.result.reduced = alt
    with run.prog.stage("deliverable", "reading back, solving and recovering the network handed over"):
        alt.delivered = check_deliverable(run.result, recover=run.dpart.solution is not None)
    if run.trace:
        _emission_check(run, net, alt, alt, alt.radiation)
    if net.q_sn_orbit is not None and run.orbit.steady == "positions":
        _orbit_positions_reduced(run, net, alt, q_orbit)
