"""``run(case) -> Result``: the stages in order, timed, with progress, and the output folder.

Nothing is written to the output folder until the whole run has succeeded: outputs go to a temporary
folder next to it that is renamed at the end.
"""

from __future__ import annotations

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
from .solve.steady import SteadyProblem, SteadySolution, check_solvable, solve_steady


class Progress:
    """Stage timer and tqdm progress (silent when ``quiet``)."""

    def __init__(self, quiet: bool = False, stream=None):
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.timings: dict[str, float] = {}

    @contextmanager
    def stage(self, name: str, label: str | None = None):
        if not self.quiet:
            print(f"[fem2tmm] {label or name} …", file=self.stream, flush=True)
        t0 = time.perf_counter()
        yield
        dt = time.perf_counter() - t0
        self.timings[name] = self.timings.get(name, 0.0) + dt
        if not self.quiet:
            print(f"[fem2tmm] {label or name}: {dt:.2f} s", file=self.stream, flush=True)

    def bar(self, total: int, desc: str):
        """A tqdm bar (or a no-op object) with ``update(n)`` and ``close()``."""
        from tqdm.auto import tqdm

        return tqdm(total=total, desc=desc, disable=self.quiet or total <= 1, file=self.stream, leave=False)


@dataclass
class Result:
    """What a run produced.  ``summary`` is the dict written to ``summary.json``."""

    case: Case
    mesh: Mesh
    model: FEModel
    summary: dict
    detailed: SteadySolution | None = None
    out: Path | None = None
    extras: dict = field(default_factory=dict)

    @property
    def T_detailed_nodes(self) -> np.ndarray | None:
        """(n_nodes,) detailed temperatures in K (NaN outside the model), or None."""
        return None if self.detailed is None else self.model.node_temperatures(self.detailed.T)


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
    prog = Progress(quiet=quiet)
    with prog.stage("read", "reading the mesh"):
        mesh = load_mesh(case) if mesh is None else mesh.validate()
    with prog.stage("assemble", "assembling the FE model"):
        model = build_model(mesh, case)
    do_ref = case.reference.detailed if reference is None else reference
    detailed = None
    problem = detailed_problem(model)
    check_solvable(problem, describe=_describe_nodes(model))
    with prog.stage("solve_detailed", "solving the detailed model"):
        detailed = solve_steady(problem, tol=case.solver.tolerance, max_iter=case.solver.max_iterations)
    summary = _summary(case, mesh, model, detailed, prog.timings, do_ref)
    result = Result(case=case, mesh=mesh, model=model, summary=summary, detailed=detailed)
    if out is not None:
        t0 = time.perf_counter()
        summary["timings_s"]["write"] = 0.0
        result.out = write_outputs(result, Path(out))
        prog.timings["write"] = time.perf_counter() - t0
    return result


def _summary(case, mesh, model: FEModel, detailed: SteadySolution | None, timings, reference: bool) -> dict:
    T = None if detailed is None else model.node_temperatures(detailed.T)
    fixed_heat = {}
    if detailed is not None:
        for g in model.fixed:
            fixed_heat[g.name] = float(detailed.heat_fixed[g.dof])
    return {
        "version": __version__,
        "case": case.source,
        "mesh": {"file": str(case.mesh.file) if case.mesh.file else mesh.source, "nodes": int(mesh.n_nodes),
                 "elements": int(mesh.n_elements), "model_nodes": int(np.sum(model.node_dof >= 0)),
                 "dofs": int(model.n_dof), "thermal_elements": int(len(model.elements)),
                 "radiating_faces": int(model.faces.n)},
        "reduced": None,
        "radiation": {"model": "space only: every active side radiates to the sink (face-to-face REFs not traced)",
                      "rays": 0, "lse_rms": None},
        "accuracy": {"rms_K": None, "max_K": None},
        "detailed": None if detailed is None else {
            "iterations": detailed.iterations,
            "T_min_C": float(np.nanmin(T) - KELVIN), "T_max_C": float(np.nanmax(T) - KELVIN),
            "heat_into_fixed_W": fixed_heat, "loads_W": dict(model.loads),
            "to_space_W": float(detailed.to_space.sum()),
        },
        "energy_balance_W": {"reduced": None, "detailed": None if detailed is None else detailed.balance},
        "timings_s": dict(timings),
    }


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
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    try:
        model, mesh = result.model, result.mesh
        T = result.T_detailed_nodes
        point_data = {"temperature": T - KELVIN}
        cell_data = {"part": _element_part_full(model, mesh.n_elements)}
        write_vtu(tmp / "temperatures.vtu", mesh, point_data, cell_data, elements=model.elements)
        write_temp(tmp / "temperatures.bdf", mesh.node_ids, T - KELVIN)
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


def _element_part_full(model: FEModel, n_elements: int) -> np.ndarray:
    v = np.full(n_elements, -1, np.int64)
    v[model.elements] = model.element_part
    return v
