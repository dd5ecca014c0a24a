"""``run(case) -> Result``: the stages in order, timed, with progress, and the output folder.

Nothing is written to the output folder until the whole run has succeeded: outputs go to a temporary
folder next to it that is renamed at the end.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__
from .case import KELVIN, Case
from .errors import Fem2TmmError
from .fem.model import FEModel, build_model
from .mesh import Mesh
from .progress import report, reporting
from .solve.steady import SteadyProblem, SteadySolution, check_solvable, solve_steady


class Progress:
    """Stage timer and tqdm progress (silent when ``quiet``)."""

    def __init__(self, quiet: bool = False, stream=None):
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.timings: dict[str, float] = {}
        self._bars: dict[str, object] = {}

    @contextmanager
    def stage(self, name: str, label: str | None = None):
        if not self.quiet:
            print(f"[fem2tmm] {label or name} …", file=self.stream, flush=True)
        t0 = time.perf_counter()
        try:
            yield
        finally:
            self.close_bars()
        dt = time.perf_counter() - t0
        self.timings[name] = self.timings.get(name, 0.0) + dt
        if not self.quiet:
            print(f"[fem2tmm] {label or name}: {dt:.2f} s", file=self.stream, flush=True)

    def bar(self, total: int, desc: str):
        """A tqdm bar (or a no-op object) with ``update(n)`` and ``close()``."""
        from tqdm.auto import tqdm

        return tqdm(total=total, desc=desc, disable=self.quiet or total <= 1, file=self.stream, leave=False)

    def callback(self):
        """A :func:`fem2tmm.progress.report` callback driving one tqdm bar per kind of work (None if quiet).

        Bars still open when a stage ends are closed by :meth:`stage`."""
        if self.quiet:
            return None

        def cb(done: int, total: int, what: str) -> None:
            b = self._bars.get(what)
            if b is None or b.total != total or done < b.n:
                if b is not None:
                    b.close()
                b = self._bars[what] = self.bar(total, what)
            b.update(done - b.n)  # tqdm limits the redraw rate
            if done >= total:
                b.close()
                self._bars.pop(what, None)

        return cb

    def close_bars(self) -> None:
        for b in self._bars.values():
            b.close()
        self._bars.clear()


@dataclass
class Result:
    """What a run produced.  ``summary`` is the dict written to ``summary.json``."""

    case: Case
    mesh: Mesh
    model: FEModel
    summary: dict
    detailed: SteadySolution | None = None
    out: Path | None = None
    clustering: object | None = None
    reduced: object | None = None  # fem2tmm.network.ReducedModel
    reduced_solution: SteadySolution | None = None
    T_recovered: np.ndarray | None = None  # (n_dof,) K
    radiation: object | None = None  # ExchangeResult between super faces
    radiation_detailed: object | None = None  # ExchangeResult between FE face sides
    solar_detailed: object | None = None  # SolarResult traced on the FE face sides
    solar_super_faces: object | None = None  # SolarResult traced on the super faces
    extras: dict = field(default_factory=dict)

    @property
    def T_detailed_nodes(self) -> np.ndarray | None:
        """(n_nodes,) detailed temperatures in K (NaN outside the model), or None."""
        return None if self.detailed is None else self.model.node_temperatures(self.detailed.T)

    @property
    def T_recovered_nodes(self) -> np.ndarray | None:
        """(n_nodes,) temperatures recovered from the reduced model in K (NaN outside the model), or None."""
        return None if self.T_recovered is None else self.model.node_temperatures(self.T_recovered)

    @property
    def T_nodes(self) -> np.ndarray:
        """The result temperatures (K) of every mesh node: recovered when reduced, detailed otherwise."""
        return self.T_recovered_nodes if self.T_recovered is not None else self.T_detailed_nodes


def load_mesh(case: Case) -> Mesh:
    from .io import read_mesh

    if case.mesh.file is None:
        raise Fem2TmmError(f"{case.source}: [mesh] file is missing")
    return read_mesh(case.mesh.file, unit=case.mesh.unit)


def detailed_problem(model: FEModel) -> SteadyProblem:
    """The detailed steady problem (radiation: every active side sees only space)."""
    return SteadyProblem(K=model.K, Q=model.Q, fixed=model.fixed_mask, T_fixed=model.fixed_values,
                         g_space=model.space_coupling(), T_sink=model.T_sink)


def _describe_nodes(model: FEModel):
    def describe(dofs: np.ndarray) -> str:
        mask = np.isin(model.element_dofs, dofs).any(axis=1)
        names = sorted({model.parts[p].name for p in np.unique(model.element_part[mask])})
        return "parts " + ", ".join(repr(n) for n in names)

    return describe


def run(case: Case, out: str | Path | None = None, mesh: Mesh | None = None, quiet: bool = True,
        reference: bool | None = None) -> Result:
    """Run ``case``; write the output folder ``out`` (if given) only once everything succeeded.

    ``mesh`` overrides ``[mesh] file`` (e.g. a mesh built with :mod:`fem2tmm.meshes`); ``reference``
    overrides ``[reference] detailed``.
    """
    from .compute import executing
    from .loadcases import has_cases

    if has_cases(case.raw):
        raise Fem2TmmError(f"{case.source}: this version runs [[cases]]/[sweep] files case by case only through "
                           "fem2tmm.loadcases.load_cases; run each case separately")
    prog = Progress(quiet=quiet)
    with executing(case.compute.scheduler, case.compute.workers), reporting(prog.callback()):
        result = _run(case, prog, mesh, reference)
    if out is not None:
        result.out = write_outputs(result, Path(out))
    return result


def _run(case: Case, prog: Progress, mesh: Mesh | None, reference: bool | None) -> "Result":
    from .network import (build_reduced, cluster_model, detailed_radiation, detailed_solar, face_flux_per_element,
                          has_sun, quadric_scene, radiation_surface, reduced_radiation, solar_aware, solar_prepass,
                          super_face_solar, super_faces)
    from .radiation.surfaces import TriangleScene

    with prog.stage("read", "reading the mesh"):
        mesh = load_mesh(case) if mesh is None else mesh.validate()
    with prog.stage("assemble", "assembling the FE model"):
        model = build_model(mesh, case)
    do_ref = case.reference.detailed if reference is None else reference
    problem = detailed_problem(model)
    check_solvable(problem, describe=_describe_nodes(model))
    result = Result(case=case, mesh=mesh, model=model, summary={})
    trace = case.radiation.enabled and bool(model.faces.active.any())
    sun = has_sun(case) and bool(model.faces.active.any())
    surface = radiation_surface(model) if (trace or sun) else None
    q_solar = None  # detailed solar nodal loads (n_dof,) W
    scene = None  # one ray scene (Embree BVH) shared by every tracing stage
    if case.reduction.enabled:
        flux = None
        if sun and solar_aware(case):
            with prog.stage("scene", "building the ray scene"):
                scene = TriangleScene(surface)
            with prog.stage("solar_prepass", "tracing a coarse solar map for the clustering"):
                flux = solar_prepass(model, case, surface, scene=scene)
        with prog.stage("cluster", "clustering"):
            result.clustering = cluster_model(model, case, progress=lambda i, n: report(i, n, "regions clustered"),
                                              flux=flux)
    if surface is not None and any(p.quadric for p in case.parts):
        with prog.stage("quadrics", "fitting quadrics"):
            scene, result.extras["quadrics"] = quadric_scene(model, case, surface, result.clustering)
    elif surface is not None and scene is None:
        with prog.stage("scene", "building the ray scene"):
            scene = TriangleScene(surface)
    need_detailed_sun = sun and (do_ref or not case.reduction.enabled or case.environment.solar_on == "detailed")
    if need_detailed_sun:
        with prog.stage("solar_detailed", "tracing solar rays on the detailed mesh"):
            q_solar, sres = detailed_solar(model, case, surface, scene=scene)
            result.solar_detailed = sres
            result.extras["absorbed_solar_faces"] = sres.absorbed_face / model.faces.area
            result.extras["absorbed_solar_elements"] = face_flux_per_element(model, sres.absorbed_face)
    if case.reduction.enabled:
        with prog.stage("reduce", "reducing conduction"):
            result.reduced = build_reduced(model, result.clustering, case)
        sf = super_faces(model, result.reduced) if surface is not None else None
        if trace:
            with prog.stage("radiation", "tracing super-face exchange factors"):
                GR, g_space, res, n_sf = reduced_radiation(model, result.reduced, case, surface, scene=scene, sf=sf)
                result.reduced = dataclasses.replace(result.reduced, GR=GR, g_space=g_space)
                result.radiation = res
                result.extras["super_faces"] = n_sf
        q_recover = model.Q
        if sun:
            rm = result.reduced
            if case.environment.solar_on == "detailed":
                # exact power distribution: q_SN = Y q; the non-uniform part stays in the recovery (X q)
                q_sn = rm.reduction.distribute(q_solar)
                q_recover = model.Q + q_solar
            else:
                with prog.stage("solar", "tracing solar rays on the super faces"):
                    q_sn, sres_sf, _ = super_face_solar(model, rm, case, surface, scene=scene, sf=sf)
                result.solar_super_faces = sres_sf
                if "absorbed_solar_elements" not in result.extras:
                    result.extras["absorbed_solar_elements"] = face_flux_per_element(model, sres_sf.absorbed_face)
                    result.extras["absorbed_solar_faces"] = sres_sf.absorbed_face / model.faces.area
            result.reduced = dataclasses.replace(rm, Q=rm.Q + q_sn)
            result.extras["solar_on"] = case.environment.solar_on
        with prog.stage("solve_reduced", "solving the reduced model"):
            result.reduced_solution = solve_steady(result.reduced.problem(), tol=case.solver.tolerance,
                                                   max_iter=case.solver.max_iterations)
        with prog.stage("recover", "recovering detailed temperatures"):
            result.T_recovered = result.reduced.reduction.recover(result.reduced_solution.T, q_recover)
    if do_ref or not case.reduction.enabled:
        if trace:
            with prog.stage("radiation_detailed", "tracing FE-face exchange factors (detailed model)"):
                ref = case.reference
                rpf, dens = ref.rays_per_face, ref.ray_density
                faced, g_space, res = detailed_radiation(model, case, surface, rays_per_face=rpf, ray_density=dens,
                                                         scene=scene)
                problem = dataclasses.replace(problem, faced=faced, g_space=g_space)
                result.radiation_detailed = res
        if q_solar is not None:
            problem = dataclasses.replace(problem, Q=problem.Q + q_solar)
        with prog.stage("solve_detailed", "solving the detailed model"):
            result.detailed = solve_steady(problem, tol=case.solver.tolerance, max_iter=case.solver.max_iterations)
    result.summary = _summary(result, prog.timings)
    return result


def _summary(result: "Result", timings) -> dict:
    from .network import conductive_links

    case, mesh, model = result.case, result.mesh, result.model
    detailed = result.detailed
    T = result.T_detailed_nodes
    fixed_heat = {}
    if detailed is not None:
        for g in model.fixed:
            fixed_heat[g.name] = float(detailed.heat_fixed[g.dof])
    s = {
        "version": __version__,
        "case": case.source,
        "mesh": {"file": str(case.mesh.file) if case.mesh.file else mesh.source, "nodes": int(mesh.n_nodes),
                 "elements": int(mesh.n_elements), "model_nodes": int(np.sum(model.node_dof >= 0)),
                 "dofs": int(model.n_dof), "thermal_elements": int(len(model.elements)),
                 "radiating_faces": int(model.faces.n)},
        "reduced": None,
        "radiation": _radiation_summary(result),
        "accuracy": {"rms_K": None, "max_K": None},
        "detailed": None if detailed is None else {
            "iterations": detailed.iterations,
            "T_min_C": float(np.nanmin(T) - KELVIN), "T_max_C": float(np.nanmax(T) - KELVIN),
            "heat_into_fixed_W": fixed_heat, "loads_W": dict(model.loads),
            "to_space_W": float(detailed.to_space.sum()),
        },
        "energy_balance_W": {"reduced": None, "detailed": None if detailed is None else detailed.balance},
        "solar": _solar_summary(result),
        "quadrics": result.extras.get("quadrics"),
        "timings_s": dict(timings),
    }
    rm, rs = result.reduced, result.reduced_solution
    if rm is not None:
        n_links_space = int(np.count_nonzero(rm.g_space > 0))
        s["reduced"] = {
            "super_nodes": int(np.count_nonzero(rm.kind == "cluster")),
            "boundary_nodes": int(np.count_nonzero(rm.kind == "boundary")),
            "kept_nodes": int(np.count_nonzero(rm.kind == "kept")),
            "super_faces": int(result.extras.get("super_faces", np.count_nonzero(rm.area > 0))),
            "conductive_links": conductive_links(rm.K),
            "radiative_links": n_links_space + (0 if rm.GR is None else conductive_links(rm.GR)),
            "negative_links": rm.report.get("negative_links", 0),
            "method": rm.report.get("method"),
            "filter": rm.report.get("filter"),
            "clustering": result.clustering.report if result.clustering is not None else None,
            "iterations": rs.iterations,
            "heat_into_fixed_W": {str(rm.names[i]): float(rs.heat_fixed[i]) for i in np.flatnonzero(rm.fixed)},
            "to_space_W": float(rs.to_space.sum()),
        }
        s["energy_balance_W"]["reduced"] = rs.balance
        if detailed is not None:
            ok = model.node_dof >= 0
            err = (model.node_temperatures(result.T_recovered) - T)[ok]
            s["accuracy"] = {"rms_K": float(np.sqrt(np.mean(err**2))), "max_K": float(np.abs(err).max()),
                             "nodes": int(ok.sum())}
    return s


def _radiation_summary(result: "Result") -> dict:
    def one(res):
        return {"rays": int(np.sum(res.rays)), "lse_rms": float(res.lse_rms), "kappa": res.kappa,
                "groups": int(res.n_groups), "links": int(res.GR.nnz), "segments": int(res.segments),
                "capped_energy_fraction": float(res.capped_energy_fraction),
                "blocked_fraction": float(res.blocked_fraction), "engine": res.engine, "sampling": res.sampling}

    r, d = result.radiation, result.radiation_detailed
    if r is None and d is None:
        return {"model": "space only: every active side radiates to the sink (face-to-face REFs not traced)",
                "rays": 0, "lse_rms": None, "kappa": None}
    out = {"model": "face-to-face radiative exchange factors (quasi-Monte Carlo ray tracing)"}
    if r is not None:
        out.update(one(r))
    else:
        out.update({"rays": 0, "lse_rms": None, "kappa": None})
    if d is not None:
        out["detailed"] = one(d)
    return out


def _solar_summary(result: "Result") -> dict | None:
    def one(r):
        return {"absorbed_W": float(r.absorbed), "incident_W": float(r.incident), "shadowed_W": float(r.shadowed),
                "escaped_W": float(r.escaped), "blocked_W": float(r.blocked), "capped_W": float(r.capped),
                "rays": int(r.rays)}

    d, sf = result.solar_detailed, result.solar_super_faces
    if d is None and sf is None:
        return None
    out = {"solar_on": result.extras.get("solar_on", "detailed")}
    if d is not None:
        out["detailed_mesh"] = one(d)
    if sf is not None:
        out["super_faces"] = one(sf)
    return out


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    return x


def write_outputs(result: Result, out: Path) -> Path:
    """Write every output into a temporary sibling folder, then move it to ``out`` atomically."""
    from .export.nastran_temp import write_temp
    from .export.vtu import write_vtu

    out = Path(out)
    parent = out.resolve().parent
    parent.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    try:
        model, mesh = result.model, result.mesh
        T = result.T_nodes
        point_data = {"temperature": T - KELVIN}
        if result.T_recovered is not None and result.detailed is not None:
            Td = result.T_detailed_nodes
            point_data["reference_temperature"] = Td - KELVIN
            point_data["error"] = T - Td
        cell_data = {"part": _element_full(model, mesh.n_elements, model.element_part)}
        if result.clustering is not None:
            cell_data["cluster"] = result.clustering.labels
            cell_data["region"] = result.clustering.regions
        if "absorbed_solar_elements" in result.extras:
            cell_data["absorbed_solar"] = result.extras["absorbed_solar_elements"]
        write_vtu(tmp / "temperatures.vtu", mesh, point_data, cell_data, elements=model.elements)
        write_temp(tmp / "temperatures.bdf", mesh.node_ids, T - KELVIN)
        if result.reduced is not None:
            _write_reduced(tmp, result)
        from .export.report import write_report

        result.summary.setdefault("timings_s", {})["write"] = 0.0  # listed in the report's timing table
        write_report(tmp, result, _case_text(result.case))
        result.summary["timings_s"]["write"] = time.perf_counter() - t0  # everything but summary.json itself
        (tmp / "summary.json").write_text(json.dumps(_jsonable(result.summary), indent=2), encoding="utf-8")
        if out.exists():
            if not out.is_dir():
                raise Fem2TmmError(f"output path {out} exists and is not a folder")
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=parent))
            os.replace(out, old / "x")
            os.replace(tmp, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def _element_full(model: FEModel, n_elements: int, values: np.ndarray) -> np.ndarray:
    v = np.full(n_elements, -1, np.int64)
    v[model.elements] = values
    return v


def _case_text(case: Case) -> str:
    p = Path(case.source)
    if p.suffix == ".toml" and p.exists():
        return p.read_text(encoding="utf-8")
    return json.dumps(_jsonable(dict(case.raw)), indent=2)


def _write_reduced(folder: Path, result: Result) -> None:
    """``reduced.npz`` and ``model.esatan`` of the reduced network."""
    from .export.esatan import Deck, node_numbers, write_esatan

    rm, rs = result.reduced, result.reduced_solution
    n = rm.n
    GR = np.zeros((n + 1, n + 1))
    if rm.GR is not None:
        GR[:n, :n] = rm.GR
    GR[:n, n] = GR[n, :n] = rm.g_space
    C = rm.C if rm.C is not None else np.full(n, np.nan)
    np.savez(folder / "reduced.npz", names=rm.names.astype(str), is_boundary=rm.fixed, C=C, K=rm.K, GR=GR,
             Q=rm.Q, T=rs.T - KELVIN, kind=rm.kind.astype(str), part=rm.part,
             T_sink=np.float64(rm.T_sink - KELVIN))
    numbers, space = node_numbers(rm.part, len(result.model.parts))
    GL = -rm.K.copy()
    np.fill_diagonal(GL, 0.0)
    area = rm.area if rm.area is not None else np.zeros(n)
    eps = np.divide(rm.g_space, area, out=np.zeros(n), where=area > 0)
    deck = Deck(numbers=numbers, labels=rm.names, boundary=rm.fixed, T=rs.T, C=np.nan_to_num(C), A=area,
                alp=np.zeros(n), eps=eps, GL=GL, GR=np.zeros((n, n)) if rm.GR is None else rm.GR,
                GR_space=rm.g_space, Q=rm.Q, space=space, T_space=rm.T_sink)
    write_esatan(folder / "model.esatan", deck, title=Path(result.case.source).stem)
    from .export.sinda import write_sinda

    write_sinda(folder / "model.sinda", deck, submodel=Path(result.case.source).stem)
