"""``run(case) -> Result``: the stages in order, timed, with progress, and the output folder.

This module knows only the order of the stages; each stage is one call to a function of
:mod:`fem2tmm.stages` (or of a stage package) that takes the case and plain data and returns plain data.
Nothing is written to the output folder until the whole run has succeeded (:func:`~fem2tmm.export.output.
write_outputs` writes a temporary folder next to it and renames it at the end).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from .case import Case
from .errors import Fem2TmmError
from .export.output import check_output_place, write_outputs
from .export.summary import build_summary
from .fem.model import build_model
from .mesh import Mesh
from .progress import Progress, report, reporting
from .radiation.compiled import compile_estimate
from .radiation.surfaces import TriangleScene
from .reduce.network import build_reduced, super_faces
from .result import Result
from .solve.steady import check_solvable, solve_steady
from .stages import (absorbed_solar_maps, cluster_model, describe_nodes, detailed_orbit, detailed_problem,
                     detailed_radiation, detailed_solar, orbit_average, orbit_positions_detailed,
                     orbit_positions_reduced, positive_reduced, quadric_scene, radiation_surface, reduced_problem,
                     reduced_radiation, solar_prepass, super_face_orbit, super_face_solar)

__all__ = ["Result", "detailed_problem", "load_mesh", "run"]


def load_mesh(case: Case) -> Mesh:
    """The mesh of ``[mesh] file`` in ``[mesh] unit``."""
    from .io import read_mesh

    if case.mesh.file is None:
        raise Fem2TmmError(f"{case.source}: [mesh] file is missing")
    return read_mesh(case.mesh.file, unit=case.mesh.unit, **case.mesh.reader_options())


def run(case: Case, out: str | Path | None = None, mesh: Mesh | None = None, quiet: bool = True,
        reference: bool | None = None) -> Result:
    """Run ``case``; write the output folder ``out`` (if given) only once everything succeeded.

    ``mesh`` overrides ``[mesh] file`` (e.g. a mesh built with :mod:`fem2tmm.meshes`); ``reference``
    overrides ``[reference] detailed``.
    """
    out = None if out is None else check_output_place(out)  # before any computation
    prog = Progress(quiet=quiet)
    with reporting(prog.callback()):
        result = _run(case, prog, mesh, reference)
    if out is not None:
        with prog.stage("write", f"writing the outputs to {out}"):
            result.out = write_outputs(result, out, timings=prog.timings)
    return result


def _run(case: Case, prog: Progress, mesh: Mesh | None, reference: bool | None) -> Result:
    with prog.stage("read", "reading the mesh"):
        mesh = load_mesh(case) if mesh is None else mesh.validate()
    with prog.stage("assemble", "assembling the FE model"):
        model = build_model(mesh, case)
    do_ref = case.reference.detailed if reference is None else reference
    problem = detailed_problem(model)
    check_solvable(problem, describe=describe_nodes(model))
    result = Result(case=case, mesh=mesh, model=model)
    radiating = bool(model.faces.active.any())
    trace = case.radiation.enabled and radiating
    sun = case.has_sun and radiating
    orbit = case.orbit if radiating else None
    surface = radiation_surface(model) if (trace or sun or orbit) else None
    if surface is not None:
        seconds = compile_estimate()
        if seconds > 0:
            prog.note(f"compiling the ray tracer's kernels (first run after an install, ~{seconds:.0f} s)")
    q_solar = None  # detailed solar nodal loads (n_dof,) W
    scene = None  # one ray scene (Embree BVH) shared by every tracing stage

    # clustering (following a coarse solar map when asked)
    if case.reduction.enabled:
        flux = None
        if sun and case.solar_aware:
            with prog.stage("scene", "building the ray scene"):
                scene = TriangleScene(surface)
            with prog.stage("solar_prepass", "tracing a coarse solar map for the clustering"):
                flux = solar_prepass(model, case, surface, scene=scene)
        with prog.stage("cluster", "clustering"):
            result.clustering = cluster_model(model, case, progress=lambda i, n: report(i, n, "regions clustered"),
                                              flux=flux)

    # the ray scene: quadrics where the case asks for them, flat triangles elsewhere
    if surface is not None and any(p.quadric for p in case.parts):
        with prog.stage("quadrics", "fitting quadrics"):
            scene, result.quadrics = quadric_scene(model, case, surface, result.clustering)
    elif surface is not None and scene is None:
        with prog.stage("scene", "building the ray scene"):
            scene = TriangleScene(surface)

    # solar loads on the detailed mesh
    if sun and (do_ref or not case.reduction.enabled or case.environment.solar_on == "detailed"):
        with prog.stage("solar_detailed", "tracing solar rays on the detailed mesh"):
            q_solar, result.solar_detailed = detailed_solar(model, case, surface, scene=scene)
            result.absorbed_solar_faces, result.absorbed_solar_elements = absorbed_solar_maps(model, result.solar_detailed)

    # orbital loads (solar, albedo, planet IR at every position) on the detailed mesh
    q_orbit = None  # (k, n_dof) W per position
    if orbit is not None and (do_ref or not case.reduction.enabled or orbit.fluxes_on == "detailed"):
        with prog.stage("orbit_detailed", "tracing orbital fluxes on the detailed mesh"):
            q_orbit, result.orbit_detailed = detailed_orbit(model, case, surface, scene=scene)

    # reduced model: conduction, radiation, solar loads, solve, recovery
    if case.reduction.enabled:
        with prog.stage("reduce", "reducing conduction"):
            rm = build_reduced(model, result.clustering, case)
        sf = super_faces(model, rm) if surface is not None else None
        if trace:
            with prog.stage("radiation", "tracing super-face exchange factors"):
                GR, g_space, result.radiation, result.super_faces_count = reduced_radiation(
                    model, rm, case, surface, scene=scene, sf=sf)
                rm = dataclasses.replace(rm, GR=GR, g_space=g_space)
        q_recover = model.Q
        if sun:
            if case.environment.solar_on == "detailed":
                # exact power distribution: q_SN = Y q; the non-uniform part stays in the recovery (X q)
                q_sn = rm.reduction.distribute(q_solar)
                q_recover = model.Q + q_solar
            else:
                with prog.stage("solar", "tracing solar rays on the super faces"):
                    q_sn, result.solar_super_faces, _ = super_face_solar(model, rm, case, surface, scene=scene, sf=sf)
                if result.absorbed_solar_elements is None:
                    result.absorbed_solar_faces, result.absorbed_solar_elements = absorbed_solar_maps(
                        model, result.solar_super_faces)
            rm = dataclasses.replace(rm, Q=rm.Q + q_sn)
            result.solar_on = case.environment.solar_on
        q_sn_orbit = None  # (k, n_SN) W per position
        if orbit is not None:
            if orbit.fluxes_on == "detailed":
                q_sn_orbit = rm.reduction.distribute(q_orbit.T).T  # exact distribution, per position
            else:
                with prog.stage("orbit", "tracing orbital fluxes on the super faces"):
                    q_sn_orbit, result.orbit_super_faces = super_face_orbit(model, rm, case, surface, scene=scene,
                                                                            sf=sf)
            result.orbit_on = orbit.fluxes_on
        rm_base, q_recover_base = rm, q_recover
        if q_sn_orbit is not None:  # the steady case: orbit-averaged loads
            rm = dataclasses.replace(rm, Q=rm.Q + orbit_average(result, q_sn_orbit))
            if q_orbit is not None and orbit.fluxes_on == "detailed":
                q_recover = q_recover + orbit_average(result, q_orbit)
        result.reduced = rm
        with prog.stage("solve_reduced", "solving the reduced model"):
            result.reduced_solution = solve_steady(reduced_problem(rm), tol=case.solver.tolerance,
                                                   max_iter=case.solver.max_iterations)
        if case.reduction.network == "positive":
            exact = result.reduced_solution
            with prog.stage("positive", "fitting a positive sparse network"):
                rm, result.reduced_solution, result.positive = positive_reduced(model, rm, exact, case)
            result.reduced = rm
            result.T_recovered_exact = rm.reduction.recover(exact.T, q_recover)
        with prog.stage("recover", "recovering detailed temperatures"):
            result.T_recovered = rm.reduction.recover(result.reduced_solution.T, q_recover)
        if q_sn_orbit is not None and orbit.steady == "positions":
            with prog.stage("orbit_positions", "solving the reduced model at every orbit position"):
                result.orbit_T_positions = orbit_positions_reduced(rm_base, q_recover_base, q_sn_orbit,
                                                                   q_orbit if orbit.fluxes_on == "detailed" else None,
                                                                   result.reduced_solution.T, case)

    # detailed reference model
    if do_ref or not case.reduction.enabled:
        if trace:
            with prog.stage("radiation_detailed", "tracing FE-face exchange factors (detailed model)"):
                faced, g_space, result.radiation_detailed = detailed_radiation(
                    model, case, surface, rays_per_face=case.reference.rays_per_face,
                    ray_density=case.reference.ray_density, scene=scene)
                problem = dataclasses.replace(problem, faced=faced, g_space=g_space)
        if q_solar is not None:
            problem = dataclasses.replace(problem, Q=problem.Q + q_solar)
        base = problem
        if q_orbit is not None:
            problem = dataclasses.replace(problem, Q=problem.Q + orbit_average(result, q_orbit))
        with prog.stage("solve_detailed", "solving the detailed model"):
            result.detailed = solve_steady(problem, tol=case.solver.tolerance, max_iter=case.solver.max_iterations)
        if q_orbit is not None and orbit.steady == "positions":
            with prog.stage("orbit_positions_detailed", "solving the detailed model at every orbit position"):
                T = orbit_positions_detailed(base, q_orbit, result.detailed.T, case)
                if case.reduction.enabled:
                    result.orbit_T_positions_detailed = T
                else:
                    result.orbit_T_positions = T

    result.summary = build_summary(result, prog.timings)
    return result
