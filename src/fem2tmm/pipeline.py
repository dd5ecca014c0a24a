"""``run(case) -> Result``: the stages in order, timed, with progress, and the output folder.

This module knows only the order of the stages; each stage is one call to a function of
:mod:`fem2tmm.stages` (or of a stage package) that takes the case and plain data and returns plain data.
Nothing is written to the output folder until the whole run has succeeded (:func:`~fem2tmm.export.output.
write_outputs` writes a temporary folder next to it and renames it at the end).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from .case import Case
from .errors import Fem2TmmError
from .cache import digest
from .compute import map_units
from .export.output import check_output_place, write_cases_outputs, write_outputs
from .export.summary import build_cases_summary, build_summary
from .fem.model import build_model
from .mesh import Mesh
from .progress import Progress, report, reporting
from .radiation.compiled import compile_estimate
from .radiation.quadric import QuadricScene
from .radiation.surfaces import TriangleScene
from .reduce.network import build_reduced, refresh_reduced, super_faces
from .result import CasesResult, Result
from .solve.steady import check_solvable, solve_steady
from .stages import (absorbed_solar_maps, cluster_key, cluster_model, describe_nodes, detailed_problem,
                     detailed_radiation, detailed_solar, fit_quadrics, geometry_key, positive_reduced, quadric_regions,
                     radiation_surface, reduce_key, reduced_problem, reduced_radiation, scene_key, solar_prepass,
                     super_face_solar, trace_key, tracer_settings)

__all__ = ["CasesResult", "Result", "detailed_problem", "load_mesh", "run"]


def load_mesh(case: Case) -> Mesh:
    """The mesh of ``[mesh] file`` in ``[mesh] unit``."""
    from .io import read_mesh

    if case.mesh.file is None:
        raise Fem2TmmError(f"{case.source}: [mesh] file is missing")
    return read_mesh(case.mesh.file, unit=case.mesh.unit, **case.mesh.reader_options())


def run(case: Case, out: str | Path | None = None, mesh: Mesh | None = None, quiet: bool = True,
        reference: bool | None = None, cache: str | Path | bool | None = None) -> Result | CasesResult:
    """Run ``case``; write the output folder ``out`` (if given) only once everything succeeded.

    ``mesh`` overrides ``[mesh] file`` (e.g. a mesh built with :mod:`fem2tmm.meshes`); ``reference``
    overrides ``[reference] detailed``.  A case file with ``[[cases]]`` or ``[sweep]``
    (:mod:`fem2tmm.loadcases`) runs every case and returns a :class:`~fem2tmm.result.CasesResult`
    (outputs: one folder per case in ``out`` and the envelope over the cases); otherwise a
    :class:`~fem2tmm.result.Result`.  Stage results are shared between cases and runs through the stage cache
    (:mod:`fem2tmm.cache`): ``cache`` a folder, default ``<out>/.cache`` (memory only without ``out``), False
    for none.  The work units run where ``[compute] scheduler`` says (:mod:`fem2tmm.compute`).
    """
    from .cache import CACHE_DIR, StageCache
    from .compute import executing
    from .loadcases import load_cases

    out = None if out is None else check_output_place(out)  # before any computation
    cases = load_cases(case)  # every case validated before any computation
    explicit = cache not in (None, True, False)
    store = None if cache is False else StageCache(Path(cache) if explicit else None)
    if store is not None and not explicit and out is not None:
        store.folder = Path(out) / CACHE_DIR  # read from the previous run's outputs, written with the new ones
    meshes = {}
    results = []
    t0 = time.perf_counter()
    with executing(case.compute.scheduler, case.compute.workers) as ex:
        workers = ex.workers
        for name, c, _ in cases:
            prog = Progress(quiet=quiet, label=name or None)
            key = (str(c.mesh.file), c.mesh.unit)
            if mesh is None and key not in meshes:
                with prog.stage("read", "reading the mesh"):
                    meshes[key] = load_mesh(c)
            with reporting(prog.callback()):
                results.append(_run(c, prog, mesh if mesh is not None else meshes[key], reference, store))
    if len(cases) == 1 and not cases[0][0]:
        result = results[0]
        if out is not None:
            with prog.stage("write", f"writing the outputs to {out}"):
                result.out = write_outputs(result, out, timings=prog.timings, cache=None if explicit else store)
        if explicit:
            store.commit()
        return result
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


def _cached(prog: Progress, store, status: dict, stage: str, label: str, key, compute):
    """Stage ``stage``, timed: its value from the stage cache ``store`` under ``key()`` or ``compute()``d (and
    cached); records "computed" or "reused" in ``status``."""
    with prog.stage(stage, label):
        if store is None:
            value, how = compute(), "computed"
        else:
            value, how = store.get_or_compute(stage, key(), compute)
    status[stage] = how
    return value


class _Scenes:
    """The case's ray scenes, each built on first use (a stage whose result is cached needs none)."""

    def __init__(self, surface):
        self.surface = surface
        self.fit = None  # (quadrics, quadric_of_face, report) when parts are traced against quadrics
        self._flat = self._main = None

    def flat(self) -> TriangleScene:
        if self._flat is None:
            self._flat = TriangleScene(self.surface)
        return self._flat

    def main(self) -> TriangleScene:
        """Quadrics where the case asks for them, flat triangles elsewhere."""
        if self.fit is None:
            return self.flat()
        if self._main is None:
            self._main = QuadricScene(self.surface, self.fit[1], self.fit[0])
        return self._main


def _run(case: Case, prog: Progress, mesh: Mesh | None, reference: bool | None, store=None) -> Result:
    if mesh is None:
        with prog.stage("read", "reading the mesh"):
            mesh = load_mesh(case)
    mesh = mesh.validate()
    with prog.stage("assemble", "assembling the FE model"):
        model = build_model(mesh, case)
    do_ref = case.reference.detailed if reference is None else reference
    problem = detailed_problem(model)
    check_solvable(problem, describe=describe_nodes(model))
    result = Result(case=case, mesh=mesh, model=model, cache={})
    status = result.cache
    radiating = bool(model.faces.active.any())
    trace = case.radiation.enabled and radiating
    sun = case.has_sun and radiating
    surface = radiation_surface(model) if (trace or sun) else None
    if surface is not None:
        seconds = compile_estimate()
        if seconds > 0:
            prog.note(f"compiling the ray tracer's kernels (first run after an install, ~{seconds:.0f} s)")
    scenes = _Scenes(surface)
    geometry = geometry_key(model) if surface is not None else None
    ir = surface.optics("ir") if surface is not None else None
    solar = surface.optics("solar") if surface is not None else None
    env = case.environment
    sun_settings = (env.sun_direction, env.solar_flux, env.solar_rays_per_face, tracer_settings(case, exchange=False))
    q_solar = None  # detailed solar nodal loads (n_dof,) W

    # clustering (following a coarse solar map when asked)
    if case.reduction.enabled:
        flux = None
        if sun and case.solar_aware:
            flux = _cached(prog, store, status, "solar_prepass", "tracing a coarse solar map for the clustering",
                           lambda: trace_key("solar_prepass", geometry, solar, "flat", *sun_settings),
                           lambda: solar_prepass(model, case, surface, scene=scenes.flat()))
        cluster_progress = lambda i, n: report(i, n, "regions clustered")  # noqa: E731
        ckey = cluster_key(model, case, flux)
        result.clustering = _cached(prog, store, status, "cluster", "clustering", lambda: ckey,
                                    lambda: cluster_model(model, case, progress=cluster_progress, flux=flux))

    # quadrics where the case asks for them (the scene itself is built when a stage traces)
    if surface is not None and any(p.quadric for p in case.parts):
        regions = quadric_regions(model, case, result.clustering)
        scenes.fit = _cached(prog, store, status, "quadrics", "fitting quadrics",
                             lambda: digest("quadrics", *regions), lambda: fit_quadrics(*regions))
        result.quadrics = scenes.fit[2]
    skey = scene_key(scenes.fit)

    # solar loads on the detailed mesh
    if sun and (do_ref or not case.reduction.enabled or case.environment.solar_on == "detailed"):
        q_solar, result.solar_detailed = _cached(
            prog, store, status, "solar_detailed", "tracing solar rays on the detailed mesh",
            lambda: trace_key("solar_detailed", geometry, solar, skey, *sun_settings),
            lambda: detailed_solar(model, case, surface, scene=scenes.main()))
        result.absorbed_solar_faces, result.absorbed_solar_elements = absorbed_solar_maps(model, result.solar_detailed)

    # reduced model: conduction, radiation, solar loads, solve, recovery
    if case.reduction.enabled:
        rm = _cached(prog, store, status, "reduce", "reducing conduction", lambda: reduce_key(model, case, ckey),
                     lambda: build_reduced(model, result.clustering, case))
        rm = refresh_reduced(rm, model)  # this case's loads, boundary temperatures, sink and optics
        sf = super_faces(model, rm) if surface is not None else None
        if trace:
            GR, g_space, result.radiation, result.super_faces_count = _cached(
                prog, store, status, "radiation", "tracing super-face exchange factors",
                lambda: trace_key("radiation", geometry, ir, skey, sf, rm.n, tracer_settings(case)),
                lambda: reduced_radiation(model, rm, case, surface, scene=scenes.main(), sf=sf))
            rm = dataclasses.replace(rm, GR=GR, g_space=g_space)
        q_recover = model.Q
        if sun:
            if case.environment.solar_on == "detailed":
                # exact power distribution: q_SN = Y q; the non-uniform part stays in the recovery (X q)
                q_sn = rm.reduction.distribute(q_solar)
                q_recover = model.Q + q_solar
            else:
                q_sn, result.solar_super_faces, _ = _cached(
                    prog, store, status, "solar", "tracing solar rays on the super faces",
                    lambda: trace_key("solar", geometry, solar, skey, sf, rm.n, *sun_settings),
                    lambda: super_face_solar(model, rm, case, surface, scene=scenes.main(), sf=sf))
                if result.absorbed_solar_elements is None:
                    result.absorbed_solar_faces, result.absorbed_solar_elements = absorbed_solar_maps(
                        model, result.solar_super_faces)
            rm = dataclasses.replace(rm, Q=rm.Q + q_sn)
            result.solar_on = case.environment.solar_on
        result.reduced = rm
        with prog.stage("solve_reduced", "solving the reduced model"):
            result.reduced_solution = _solve(reduced_problem(rm), case)
        if case.reduction.network == "positive":
            exact = result.reduced_solution
            with prog.stage("positive", "fitting a positive sparse network"):
                rm, result.reduced_solution, result.positive = positive_reduced(model, rm, exact, case)
            result.reduced = rm
            result.T_recovered_exact = rm.reduction.recover(exact.T, q_recover)
        with prog.stage("recover", "recovering detailed temperatures"):
            result.T_recovered = rm.reduction.recover(result.reduced_solution.T, q_recover)

    # detailed reference model
    if do_ref or not case.reduction.enabled:
        if trace:
            ref = case.reference
            faced, g_space, result.radiation_detailed = _cached(
                prog, store, status, "radiation_detailed", "tracing FE-face exchange factors (detailed model)",
                lambda: trace_key("radiation_detailed", geometry, ir, skey,
                                  tracer_settings(case, ref.rays_per_face, ref.ray_density)),
                lambda: detailed_radiation(model, case, surface, rays_per_face=ref.rays_per_face,
                                           ray_density=ref.ray_density, scene=scenes.main()))
            problem = dataclasses.replace(problem, faced=faced, g_space=g_space)
        if q_solar is not None:
            problem = dataclasses.replace(problem, Q=problem.Q + q_solar)
        with prog.stage("solve_detailed", "solving the detailed model"):
            result.detailed = _solve(problem, case)

    result.summary = build_summary(result, prog.timings)
    return result


def _solve(problem, case: Case):
    """The steady solution of ``problem``: one work unit (:func:`fem2tmm.compute.map_units`)."""
    [solution] = map_units(_solve_unit, [problem], shared={"tol": case.solver.tolerance,
                                                          "max_iter": case.solver.max_iterations},
                           what="steady solves")
    return solution


def _solve_unit(problem, tol: float, max_iter: int):
    return solve_steady(problem, tol=tol, max_iter=max_iter)
