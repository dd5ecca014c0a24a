"""``run(case) -> Result``: the stages in order, timed, with progress, and the output folder.

This module knows only the order of the stages; each stage is one call to a function of
:mod:`fem2tmm.stages` (or of a stage package) that takes the case and plain data and returns plain data.
Nothing is written to the output folder until the whole run has succeeded (:func:`~fem2tmm.export.output.
write_outputs` writes a temporary folder next to it and renames it at the end).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

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
from .stages import (absorbed_solar_maps, check_transient, cluster_model, describe_nodes, detailed_problem,
                     detailed_radiation, detailed_solar, ir_absorption, mean_faced, positive_reduced, quadric_scene,
                     radiation_aware_network, radiation_surface, reduced_problem, reduced_radiation, reference_noise,
                     run_transient, solar_prepass, super_face_solar)

__all__ = ["Result", "detailed_problem", "load_mesh", "run"]


def load_mesh(case: Case) -> Mesh:
    """The mesh of ``[mesh] file`` in ``[mesh] unit``."""
    from .io import read_mesh

    if case.mesh.file is None:
        raise Fem2TmmError(f"{case.source}: [mesh] file is missing")
    return read_mesh(case.mesh.file, unit=case.mesh.unit, **case.mesh.reader_options())


def run(case: Case, out: str | Path | None = None, mesh: Mesh | None = None, quiet: bool = True,
        reference: bool | None = None, labels: np.ndarray | None = None) -> Result:
    """Run ``case``; write the output folder ``out`` (if given) only once everything succeeded.

    ``mesh`` overrides ``[mesh] file`` (e.g. a mesh built with :mod:`fem2tmm.mesh.shapes`); ``reference``
    overrides ``[reference] detailed``.  ``labels`` (n_elements,) int: your own partition into super nodes
    (e.g. from METIS or another tool), one cluster per mesh element (-1 outside the parts), numbered 0 … K−1
    with every number used and each cluster within one part; it replaces the clustering (and the parts'
    ``super_nodes``).  Non-contiguous clusters are accepted with a warning.
    """
    out = None if out is None else check_output_place(out)  # before any computation
    prog = Progress(quiet=quiet)
    with reporting(prog.callback()):
        result = _run(case, prog, mesh, reference, labels)
    if out is not None:
        with prog.stage("write", f"writing the outputs to {out}"):
            result.out = write_outputs(result, out, timings=prog.timings)
    return result


def _run(case: Case, prog: Progress, mesh: Mesh | None, reference: bool | None,
         labels: np.ndarray | None = None) -> Result:
    if case.clustering.method == "metis" and labels is None:
        from .cluster.metis import require

        require()  # the optional dependency, before any long computation
    with prog.stage("read", "reading the mesh"):
        mesh = load_mesh(case) if mesh is None else mesh
    with prog.stage("assemble", "assembling the FE model"):
        model = build_model(mesh, case)
    check_transient(model, case)
    do_ref = case.reference.detailed if reference is None else reference
    problem = detailed_problem(model)
    check_solvable(problem, describe=describe_nodes(model))
    result = Result(case=case, mesh=mesh, model=model)
    radiating = bool(model.faces.active.any())
    trace = case.radiation.enabled and radiating
    sun = case.has_sun and radiating
    surface = radiation_surface(model) if (trace or sun) else None
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
                                              flux=flux, labels=labels)

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
        result.q_recover = q_recover
        q_lumped = np.zeros(rm.n)  # loads lumped per super node (super-face solar)
        if sun:
            if case.environment.solar_on == "detailed":
                # exact power distribution: q_SN = Y q; the non-uniform part stays in the recovery (X q)
                q_sn = rm.reduction.distribute(q_solar)
                q_recover = model.Q + q_solar
                result.q_recover = q_recover
            else:
                with prog.stage("solar", "tracing solar rays on the super faces"):
                    q_sn, result.solar_super_faces, _ = super_face_solar(model, rm, case, surface, scene=scene, sf=sf)
                if result.absorbed_solar_elements is None:
                    result.absorbed_solar_faces, result.absorbed_solar_elements = absorbed_solar_maps(
                        model, result.solar_super_faces)
                q_lumped = q_sn
            rm = dataclasses.replace(rm, Q=rm.Q + q_sn)
            result.solar_on = case.environment.solar_on
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
        if case.reduction.radiation_aware:
            ir = None
            if trace and case.radiation.ir_on == "detailed":
                with prog.stage("ir_detailed", "tracing where the super faces' IR is absorbed (FE sides)"):
                    ir = ir_absorption(model, rm, case, surface, scene=scene, sf=sf)
            with prog.stage("radiation_aware", "radiation-aware reduction and outer iterations"):
                result.thesis_T_recovered = result.T_recovered
                result.reduced, result.reduced_solution, result.T_recovered, result.radiation_aware = (
                    radiation_aware_network(model, result.clustering, case, rm, q_recover, q_lumped,
                                            result.T_recovered, ir))

    # detailed reference model (with its own random streams; two independent halves estimate its noise)
    if do_ref or not case.reduction.enabled:
        noise = do_ref and case.reduction.enabled and case.reference.noise
        halves = []  # the problems of the two half references, when the reference is noisy
        if trace:
            with prog.stage("radiation_detailed", "tracing FE-face exchange factors (detailed model)"):
                ref = case.reference
                if noise:
                    parts = [detailed_radiation(model, case, surface, rays_per_face=ref.rays_per_face,
                                                ray_density=ref.ray_density, scene=scene, role=role, fraction=0.5)
                             for role in ("reference", "reference_b")]
                    halves = [dataclasses.replace(problem, faced=fr, g_space=gs) for fr, gs, _ in parts]
                    faced, g_space = mean_faced([p[0] for p in parts]), 0.5 * (parts[0][1] + parts[1][1])
                    result.radiation_detailed = parts[0][2]
                    result.reference_halves = 2
                else:
                    faced, g_space, result.radiation_detailed = detailed_radiation(
                        model, case, surface, rays_per_face=ref.rays_per_face, ray_density=ref.ray_density,
                        scene=scene)
                problem = dataclasses.replace(problem, faced=faced, g_space=g_space)
        q_ref = q_solar
        if q_solar is not None and noise and case.reduction.enabled and case.environment.solar_on != "detailed":
            # the reference's own solar loads are noisy too: a second independent tracing
            with prog.stage("solar_detailed_b", "tracing a second, independent detailed solar map (reference noise)"):
                q_b, _ = detailed_solar(model, case, surface, scene=scene, role="reference_b")
            halves = halves or [problem, problem]
            halves = [dataclasses.replace(h, Q=h.Q + q) for h, q in zip(halves, (q_solar, q_b))]
            q_ref = 0.5 * (q_solar + q_b)
        elif q_solar is not None:
            halves = [dataclasses.replace(h, Q=h.Q + q_solar) for h in halves]
        if q_ref is not None:
            problem = dataclasses.replace(problem, Q=problem.Q + q_ref)
        with prog.stage("solve_detailed", "solving the detailed model"):
            result.detailed = solve_steady(problem, tol=case.solver.tolerance, max_iter=case.solver.max_iterations)
        if halves:
            with prog.stage("reference_noise", "solving the two half references (reference noise)"):
                Ta, Tb = (solve_steady(h, tol=case.solver.tolerance, max_iter=case.solver.max_iterations).T
                          for h in halves)
            result.reference_noise = reference_noise(model, Ta, Tb)

    # transient: the reduced model in time (recovered at every output time) and the detailed reference
    if case.transient is not None:
        with prog.stage("transient", "integrating the transient"):
            rs, det = result.reduced_solution, result.detailed
            result.transient = run_transient(case, model, result.reduced, None if rs is None else rs.T,
                                             result.q_recover, problem if det is not None else None,
                                             None if det is None else det.T)

    result.summary = build_summary(result, prog.timings)
    return result
