"""Outputs of a transient run: ``transient.npz``, the ParaView time series (``temperatures.pvd`` + one VTU per
output time in ``transient/``), Nastran ``TEMP`` with one load set per output time, and the ``summary.json``
section.

Temperatures are °C in the files, times in s.  Columns of the (n_times, n_nodes) arrays follow ``node_id``: the
original ids of the mesh nodes that belong to the thermal model, in mesh order.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING
from xml.sax.saxutils import quoteattr

import numpy as np

from ..constants import KELVIN
from .esatan import DeckTransient
from .nastran_temp import write_temp_series
from .orbit import save_plot
from .vtu import write_vtu

if TYPE_CHECKING:
    from ..result import Result

#: folder (inside the output folder) of the per-time VTU files
SERIES_FOLDER = "transient"


def model_nodes(result: Result) -> tuple[np.ndarray, np.ndarray]:
    """(mesh node indices (k,), their DOFs (k,)) of the mesh nodes in the thermal model, in mesh order."""
    nodes = np.flatnonzero(result.model.node_dof >= 0)
    return nodes, result.model.node_dof[nodes]


def write_transient_npz(path: Path, result: Result) -> None:
    """``times`` (n_t,) s, ``temperature`` (n_t, n_nodes) °C (recovered when reduced), ``node_id`` (n_nodes,),
    ``sn_temperature`` (n_t, n_SN) °C and ``sn_names``, ``reference_temperature`` (n_t, n_nodes) °C when the detailed
    model ran, and the per-step energy books of each model (``energy_<model>_<quantity>``, J)."""
    run = result.transient
    nodes, dofs = model_nodes(result)
    data = {"times": run.times, "temperature": run.T_result[:, dofs] - KELVIN,
            "node_id": result.mesh.node_ids[nodes].astype(np.int64)}
    if run.reduced is not None:
        data["sn_temperature"] = run.reduced.T - KELVIN
        data["sn_names"] = result.reduced.network.names.astype(str)
    if run.detailed is not None and run.T_recovered is not None:
        data["reference_temperature"] = run.detailed.T[:, dofs] - KELVIN
    for name, sol in (("reduced", run.reduced), ("detailed", run.detailed)):
        if sol is not None:
            for k, v in sol.steps.items():
                data[f"energy_{name}_{k}"] = v
    np.savez(path, **data)


def write_time_series(folder: Path, result: Result) -> list[str]:
    """``temperatures.pvd`` and one VTU per output time (point data ``temperature`` °C, and ``reference_temperature``
    and ``error`` K when the detailed model ran); returns the VTU paths relative to ``folder``."""
    run, mesh, model = result.transient, result.mesh, result.model
    (folder / SERIES_FOLDER).mkdir(exist_ok=True)
    width = max(4, len(str(len(run.times) - 1)))
    files = []
    part = np.full(mesh.n_elements, -1, np.int64)
    part[model.elements] = model.element_part
    for k, t in enumerate(run.times):
        T = model.node_temperatures(run.T_result[k])
        pdata = {"temperature": T - KELVIN}
        if run.detailed is not None and run.T_recovered is not None:
            Td = model.node_temperatures(run.detailed.T[k])
            pdata["reference_temperature"] = Td - KELVIN
            pdata["error"] = T - Td
        name = f"{SERIES_FOLDER}/temperatures_{k:0{width}d}.vtu"
        write_vtu(folder / name, mesh, pdata, {"part": part}, elements=model.elements)
        files.append(name)
    rows = "\n".join(f'    <DataSet timestep="{t!r}" group="" part="0" file={quoteattr(f)}/>'
                     for t, f in zip(map(float, run.times), files))
    (folder / "temperatures.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n", encoding="utf-8")
    return files


def write_transient_temp(path: Path, result: Result) -> dict[int, float]:
    """Nastran TEMP, one SID per output time (SID 1 = the first output time); returns SID -> time (s)."""
    run = result.transient
    nodes, dofs = model_nodes(result)
    return write_temp_series(path, result.mesh.node_ids[nodes], run.T_result[:, dofs] - KELVIN, run.times)


def extreme_super_nodes(result: Result) -> tuple[int, int]:
    """Rows of the hottest and coldest cluster super nodes (largest maximum / smallest minimum over time)."""
    T = result.transient.reduced.T
    rows = np.flatnonzero(result.reduced.network.kind == "cluster")
    return int(rows[np.argmax(T[:, rows].max(axis=0))]), int(rows[np.argmin(T[:, rows].min(axis=0))])


def transient_summary(result: Result) -> dict:
    """The ``summary.json`` ``transient`` section."""
    run = result.transient
    st = run.settings
    s = {"method": st.method, "start_s": st.start, "end_s": st.end, "step_s": st.step, "tolerance_K": st.tolerance,
         "output_every_s": st.output_every, "capacitance": result.case.transient.capacitance,
         "initial_temperature": result.case.transient.initial_temperature if isinstance(
             result.case.transient.initial_temperature, str) else result.case.transient.initial_temperature - KELVIN,
         "periodic": st.periodic, "times_s": run.times.tolist(),
         "nastran_sid_time_s": {str(k + 1): float(t) for k, t in enumerate(run.times)},
         "energy_balance": {}, "solver": {}, "timings_s": dict(run.timings), "accuracy": None}
    for name, sol in (("reduced", run.reduced), ("detailed", run.detailed)):
        if sol is None:
            continue
        s["energy_balance"][name] = dict(sol.energy)
        s["solver"][name] = dict(sol.stats)
    main = run.reduced if run.reduced is not None else run.detailed
    if st.periodic and main is not None:  # the reported model's periods (each model has its own in "solver")
        s["periods"], s["period_changes_K"] = main.stats["periods"], main.stats["period_changes_K"]
    acc = run.accuracy()
    if acc is not None:
        dof = acc.pop("dof_of_max")
        node = int(np.flatnonzero(result.model.node_dof == dof)[0])
        acc["node_of_max"] = int(result.mesh.node_ids[node])
        acc["max_per_time_K"] = acc["max_per_time_K"].tolist()
        s["accuracy"] = acc
    if run.reduced is not None and (result.reduced.network.kind == "cluster").any():
        hot, cold = extreme_super_nodes(result)
        T = run.reduced.T[:, result.reduced.network.kind == "cluster"] - KELVIN
        s["super_nodes_C"] = {"min": float(T.min()), "max": float(T.max()),
                              "hottest": str(result.reduced.network.names[hot]),
                              "coldest": str(result.reduced.network.names[cold])}
    return s


def transient_plots(folder: Path, result: Result) -> list[tuple[str, str]]:
    """Report images: T(t) of the hottest, coldest and per-part super nodes (reduced, solid; the detailed field's
    super-node averages A·T, dashed), and the error of the recovered field over time.  Returns (file, caption)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run, rm = result.transient, None if result.reduced is None else result.reduced.network
    t = run.times
    unit, scale = ("h", 3600.0) if t[-1] - t[0] > 3 * 3600 else (("min", 60.0) if t[-1] - t[0] > 180 else ("s", 1.0))
    x = t / scale
    images = []
    if run.reduced is not None and (rm.kind == "cluster").any():
        Td = None if run.detailed is None else (rm.supernodes.A @ run.detailed.T.T).T  # (n_t, n_SN) K
        hot, cold = extreme_super_nodes(result)
        fig, ax = plt.subplots(figsize=(7.5, 4.2), dpi=110)
        for row, colour in ((hot, "#cc0000"), (cold, "#3465a4")):
            ax.plot(x, run.reduced.T[:, row] - KELVIN, color=colour, label=f"{rm.names[row]} reduced")
            if Td is not None:
                ax.plot(x, Td[:, row] - KELVIN, "--", color=colour, label=f"{rm.names[row]} detailed (A·T)")
        parts = sorted({int(p) for p in rm.part[rm.kind == "cluster"]})
        for k, p in enumerate(parts):
            rows = np.flatnonzero((rm.part == p) & (rm.kind == "cluster"))
            ax.plot(x, run.reduced.T[:, rows].mean(axis=1) - KELVIN, ":", color=f"C{(k + 2) % 10}",
                    label=f"part {result.model.parts[p].name}: mean of {len(rows)} super nodes")
        save_plot(fig, ax, folder / "transient_temperatures.png", f"time [{unit}]", "T [°C]",
                  "Super-node temperatures")
        images.append(("transient_temperatures.png", "Hottest and coldest super nodes and each part's mean over time: "
                       "reduced (solid) against the detailed model's super-node averages (dashed)"))
    acc = run.accuracy()
    if acc is not None:
        err = np.abs(run.T_recovered - run.detailed.T)
        fig, ax = plt.subplots(figsize=(7.5, 3.6), dpi=110)
        ax.plot(x, err.max(axis=1), color="#cc0000", label="max over the nodes")
        ax.plot(x, np.sqrt(np.mean(err**2, axis=1)), color="#3465a4", label="RMS over the nodes")
        save_plot(fig, ax, folder / "transient_error.png", f"time [{unit}]", "|recovered − detailed| [K]",
                  f"Error over time (max {acc['max_K']:.3g} K at {acc['time_of_max_s'] / scale:.4g} {unit})",
                  legend_fontsize=8)
        images.append(("transient_error.png", "Error of the recovered temperatures against the detailed model over time"))
    return images


def deck_transient(run) -> DeckTransient | None:
    """The time-dependent inputs and control of a :class:`~fem2tmm.solve.transient.TransientRun`'s reduced model
    for the ESATAN / SINDA decks."""
    p = run.reduced_problem
    if p is None:
        return None
    st = run.settings
    loads = tuple((pat, tb.t, tb.v) for pat, tb in zip(p.Q.patterns, p.Q.tables))
    temps = tuple((int(np.argmax(pat)), tb.t, tb.v) for pat, tb in zip(p.T_fixed.patterns, p.T_fixed.tables))
    sink = None if p.T_sink.is_constant else (p.T_sink.t, p.T_sink.v)
    # the solvers' time step (ESATAN's SLCRNC needs DTIMEI): the fixed step, else the adaptive run's largest step,
    # else the output interval
    step = st.step if st.step is not None else st.output_every
    return DeckTransient(loads=loads, base=np.asarray(p.Q.base, float), temperatures=temps, sink=sink,
                         start=st.start, end=st.end,
                         step=step if step is not None else (st.end - st.start) / 100.0, output=st.output_every,
                         periodic=st.periodic, method=st.method)


def write_transient(folder: Path, result: Result) -> None:
    """Every transient output into ``folder`` (see module docstring)."""
    write_transient_npz(folder / "transient.npz", result)
    write_time_series(folder, result)
    write_transient_temp(folder / "temperatures_transient.bdf", result)


__all__ = ["write_transient", "transient_plots", "deck_transient", "write_transient_npz", "write_time_series", "write_transient_temp",
           "transient_summary", "model_nodes"]
