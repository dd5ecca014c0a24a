"""The output folder of a run, written atomically: every file goes to a temporary sibling folder that
replaces ``out`` only once everything was written.

Files: ``temperatures.vtu``, ``temperatures.bdf`` and ``temperatures.inp`` (every mesh node), ``reduced.npz``, ``model.esatan`` and
``model.sinda`` (the reduced network), ``report.html`` with its images, ``summary.json``, and the marker
``.fem2tmm`` (JSON: the version and every file written).

Folder policy: fem2tmm never deletes or overwrites anything it did not write.  ``out`` may be missing (it is
created), an empty folder, or a folder fem2tmm wrote (its marker lists every file in it; it is replaced as a
whole); anything else is refused with the way out.  :func:`check_output_place` checks this, and that the place
can be written, before any computation.
"""

from __future__ import annotations

import datetime
import json
import os
import re
import shutil
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

from .._version import __version__
from ..case import Case
from ..constants import KELVIN
from ..errors import Fem2TmmError
from ..fem.model import FEModel
from ..result import Result
from .transient import write_transient
from .abaqus_temp import write_inp
from .nastran_temp import write_temp
from .orbit import write_orbit_npz
from .report import write_report
from .vtu import write_vtu


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


#: the marker file of a folder fem2tmm wrote
MARKER = ".fem2tmm"
#: what fem2tmm versions before the marker wrote (a folder of only these, with a summary.json naming a version,
#: is replaced as if it had a marker)
_LEGACY = re.compile(r"summary\.json|report\.html|[\w-]+\.png|temperatures\.(vtu|bdf)|reduced\.npz|"
                     r"model\.(esatan|sinda)")
_WAY_OUT = "give --out a new folder (or one fem2tmm wrote, which it replaces)"


def _entries(folder: Path) -> list[str]:
    """Every file and folder below ``folder`` as sorted relative POSIX paths."""
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


def _written_by_fem2tmm(folder: Path) -> list[str]:
    """The entries of ``folder`` that fem2tmm did not write ([] when it wrote them all, or the folder is empty)."""
    entries = _entries(folder)
    marker = folder / MARKER
    if marker.is_file():
        try:
            files = set(json.loads(marker.read_text(encoding="utf-8"))["files"])
        except (OSError, ValueError, KeyError, TypeError):
            return entries
        return [e for e in entries if e != MARKER and e not in files]
    foreign = [e for e in entries if not _LEGACY.fullmatch(e)]
    if entries and not foreign:  # an output folder of a version before the marker
        try:
            json.loads((folder / "summary.json").read_text(encoding="utf-8"))["version"]
        except (OSError, ValueError, KeyError, TypeError):
            return entries
    return foreign


def check_output_place(out: str | Path) -> Path:
    """Check, before any computation, that a run may write its output folder at ``out``; returns it absolute.

    Allowed: a missing folder whose nearest existing parent is a writable folder, an empty folder, or a folder
    fem2tmm wrote (every entry listed by its ``.fem2tmm`` marker), in a writable parent.  Raises
    :class:`~fem2tmm.errors.Fem2TmmError` naming the place and the way out otherwise: an existing file, a folder
    holding anything fem2tmm did not write (a case folder, ``.``), a path below a file, an unwritable place.
    """
    out = Path(os.path.abspath(Path(out).expanduser()))
    if out.exists() or out.is_symlink():
        if not out.is_dir() or out.is_symlink():
            raise Fem2TmmError(f"output path {out} exists and is not a folder fem2tmm wrote; fem2tmm never "
                               f"overwrites what it did not write: {_WAY_OUT}")
        if Path.cwd() == out or out in Path.cwd().parents:
            raise Fem2TmmError(f"output folder {out} is the current folder (or holds it) and cannot be replaced: "
                               f"{_WAY_OUT}, e.g. --out results")
        foreign = _written_by_fem2tmm(out)
        if foreign:
            shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
            raise Fem2TmmError(f"output folder {out} already exists and holds what fem2tmm did not write ({shown}); "
                               f"fem2tmm never deletes or overwrites it: {_WAY_OUT}")
    anc = out.parent
    while not anc.exists():
        anc = anc.parent
    if not anc.is_dir():
        raise Fem2TmmError(f"cannot create output folder {out}: {anc} is a file, not a folder; {_WAY_OUT}")
    try:  # the one reliable test (os.access says yes to root on a read-only file system)
        os.rmdir(tempfile.mkdtemp(prefix=".fem2tmm-probe.", dir=anc))
    except OSError as exc:
        raise Fem2TmmError(f"cannot create output folder {out}: {anc} is not writable ({exc.strerror}); "
                           f"{_WAY_OUT}") from None
    return out


def write_folder(out: str | Path, fill: Callable[[Path], None], cache=None) -> Path:
    """Write an output folder atomically: ``fill(tmp)`` writes every file into a temporary sibling folder, which
    gets the ``.fem2tmm`` marker and then replaces ``out`` (a folder fem2tmm wrote) or becomes it.

    ``out`` must pass :func:`check_output_place` (checked again just before anything is replaced); on any error the
    temporary folder is removed and ``out`` is untouched.  Returns ``out`` absolute.  ``cache``: a
    :class:`~fem2tmm.cache.StageCache` whose new entries go to the stage-cache folder of the previous outputs
    (``out/.cache``, :meth:`~fem2tmm.cache.StageCache.commit`), which moves into the new ones (the marker lists
    its files too)."""
    from ..cache import CACHE_DIR

    out = check_output_place(out)
    parent = out.parent
    parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    try:
        fill(tmp)
        check_output_place(out)  # nothing foreign appeared meanwhile
        old_cache = out / CACHE_DIR
        keep = old_cache.is_dir() and not old_cache.is_symlink()
        if cache is not None:
            cache.commit(old_cache if keep else tmp / CACHE_DIR)
        if keep:  # nothing but renames between this and the swap
            os.replace(old_cache, tmp / CACHE_DIR)
        (tmp / MARKER).write_text(json.dumps({"version": __version__, "files": _entries(tmp)}, indent=1),
                                  encoding="utf-8")
        if out.exists():
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


def write_outputs(result: Result, out: Path, timings: dict[str, float] | None = None, cache=None) -> Path:
    """Write every output into a temporary sibling folder, then move it to ``out`` atomically.

    ``out`` must pass :func:`check_output_place` (checked again here, just before anything is replaced).
    ``timings`` (stage -> s) receives ``"write"``: the time spent writing (the report and ``summary.json``
    show the same figure, measured just before they are composed).  ``cache``: a
    :class:`~fem2tmm.cache.StageCache` whose new entries go to ``out/.cache`` (kept across runs)."""
    t0 = time.perf_counter()
    out = write_folder(out, lambda tmp: write_case_folder(result, tmp, t0), cache)
    if timings is not None:
        timings["write"] = time.perf_counter() - t0
    return out


def write_cases_outputs(multi, out: Path, timings: dict[str, float] | None = None, cache=None) -> Path:
    """The outputs of a multi-case run (:class:`~fem2tmm.result.CasesResult`), atomically: ``out/<case>/`` with
    every case's outputs (:func:`write_case_folder`), the envelope over the cases
    (:mod:`fem2tmm.export.envelope`), ``summary.json`` and ``report.html`` comparing the cases."""
    from .envelope import envelope, write_envelope
    from .report import write_cases_report
    from .summary import same_mesh_envelope

    t0 = time.perf_counter()

    def fill(tmp: Path) -> None:
        for name, r in multi.results.items():  # loop over cases
            (tmp / name).mkdir()
            write_case_folder(r, tmp / name)
        T = same_mesh_envelope(multi)
        if T is not None:
            first = next(iter(multi.results.values()))
            elements = np.unique(np.concatenate([r.model.elements for r in multi.results.values()]))
            write_envelope(tmp, first.mesh, elements, envelope(T), len(T))
        write_cases_report(tmp, multi.summary, _case_text(multi.case))
        (tmp / "summary.json").write_text(json.dumps(_jsonable(multi.summary), indent=2), encoding="utf-8")

    out = write_folder(out, fill, cache)
    if timings is not None:
        timings["write"] = time.perf_counter() - t0
    return out


def write_case_folder(result: Result, folder: Path, t0: float | None = None) -> None:
    """Every output of one case into the existing folder ``folder`` (DESIGN §4.3); ``t0`` the start of the
    writing (``perf_counter``) for the ``write`` timing."""
    t0 = time.perf_counter() if t0 is None else t0
    model, mesh = result.model, result.mesh
    T = result.T_nodes
    point_data = {"temperature": T - KELVIN}
    if result.reduced is not None and result.detailed.solution is not None:
        Td = result.T_detailed_nodes
        point_data["reference_temperature"] = Td - KELVIN
        point_data["error"] = T - Td
    cell_data = {"part": _element_full(model, mesh.n_elements, model.element_part)}
    if result.reduced is not None:
        cell_data["cluster"] = result.reduced.clustering.labels
        cell_data["region"] = result.reduced.clustering.regions
    if result.absorbed_solar_elements is not None:
        cell_data["absorbed_solar"] = result.absorbed_solar_elements
    write_vtu(folder / "temperatures.vtu", mesh, point_data, cell_data, elements=model.elements)
    write_temp(folder / "temperatures.bdf", mesh.node_ids, T - KELVIN)
    if result.transient is not None and result.transient.T_result is not None:  # one *STEP per output time
        run = result.transient
        write_inp(folder / "temperatures.inp", mesh.node_ids,
                  np.array([model.node_temperatures(Tk) for Tk in run.T_result]).T - KELVIN,
                  labels=[f"t = {t:.9g} s" for t in run.times])
    else:
        write_inp(folder / "temperatures.inp", mesh.node_ids, T - KELVIN, labels=["steady"])
    if result.reduced is not None:
        _write_reduced(folder, result)
    write_orbit_npz(folder, result)
    if result.transient is not None:
        write_transient(folder, result)

    def written() -> None:  # the write time so far, into the report's and summary.json's timing tables
        result.summary.setdefault("timings_s", {})["write"] = time.perf_counter() - t0

    write_report(folder, result, _case_text(result.case), before_html=written)
    written()
    (folder / "summary.json").write_text(json.dumps(_jsonable(result.summary), indent=2), encoding="utf-8")


def _element_full(model: FEModel, n_elements: int, values: np.ndarray) -> np.ndarray:
    v = np.full(n_elements, -1, np.int64)
    v[model.elements] = values
    return v


def _case_text(case: Case) -> str:
    """The case as the user wrote it: the TOML file, or (a case built in Python) its data written as TOML."""
    p = Path(case.source)
    if p.suffix == ".toml" and p.exists():
        return p.read_text(encoding="utf-8")
    return to_toml(_jsonable(dict(case.raw)))


def _toml_key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else json.dumps(k)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a JSON string is a valid TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (datetime.datetime, datetime.date, datetime.time)):  # TOML's own date-times (RFC 3339)
        return v.isoformat()
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def to_toml(data: dict, prefix: str = "") -> str:
    """``data`` (JSON-like: str keys; str, int, float, bool, dates and times, lists, dicts) as TOML text: scalars first, then
    ``[tables]`` and ``[[arrays of tables]]``, so that ``tomllib.loads(to_toml(d)) == d``."""
    lines, later = [], []
    for k, v in data.items():
        key = f"{prefix}.{_toml_key(k)}" if prefix else _toml_key(k)
        if isinstance(v, dict) and v:
            sub = to_toml(v, key)
            later.append(sub if sub.startswith("\n[") else f"\n[{key}]\n" + sub)  # no header for sub-tables only
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            later.extend(f"\n[[{key}]]\n" + to_toml(x, key) for x in v)
        else:
            lines.append(f"{_toml_key(k)} = {_toml_value(v)}")
    text = "\n".join(lines) + ("\n" if lines else "") + "".join(later)
    return text if prefix else text.lstrip("\n")


def _write_reduced(folder: Path, result: Result) -> None:
    """``reduced.npz``, ``model.esatan`` and ``model.sinda`` of the reduced network (:mod:`fem2tmm.export.deliverable`)."""
    from .deliverable import write_network

    write_network(folder, result)
