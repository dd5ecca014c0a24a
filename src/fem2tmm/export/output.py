"""The output folder of a run, written atomically: every file goes to a temporary sibling folder that
replaces ``out`` only once everything was written.

Files: ``temperatures.vtu`` and ``temperatures.bdf`` (every mesh node), ``reduced.npz``, ``model.esatan`` and
``model.sinda`` (the reduced network), ``report.html`` with its images, and ``summary.json``.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..case import Case
from ..constants import KELVIN
from ..errors import Fem2TmmError
from ..fem.model import FEModel
from .esatan import Deck, node_numbers, write_esatan
from .nastran_temp import write_temp
from .orbit import write_orbit_npz
from .report import write_report
from .sinda import write_sinda
from .vtu import write_vtu

if TYPE_CHECKING:
    from ..result import Result


def _jsonable(x):
    """``x`` with numpy scalars/arrays and paths turned into JSON types (recursively)."""
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
        if result.absorbed_solar_elements is not None:
            cell_data["absorbed_solar"] = result.absorbed_solar_elements
        write_vtu(tmp / "temperatures.vtu", mesh, point_data, cell_data, elements=model.elements)
        write_temp(tmp / "temperatures.bdf", mesh.node_ids, T - KELVIN)
        if result.reduced is not None:
            _write_reduced(tmp, result)
        write_orbit_npz(tmp, result)
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
    write_sinda(folder / "model.sinda", deck, submodel=Path(result.case.source).stem)
