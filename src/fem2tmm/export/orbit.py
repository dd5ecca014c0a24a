"""Orbit outputs of a run with ``[orbit]``: the summary entry, ``orbit.npz`` (the position table, the fluxes per
position and FE face or super face, per-position temperatures) and the report's plots of the fluxes and
temperatures against the true anomaly."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..constants import KELVIN

if TYPE_CHECKING:
    from ..result import Result


def orbit_summary(result: Result) -> dict | None:
    """The ``orbit`` entry of ``summary.json``: the orbit, where the fluxes were traced, and per kind the
    orbit-averaged and largest absorbed power (W, whole model), the rays traced and the largest relative energy
    imbalance of a position (Σ incident - Σ absorbed - lost)."""
    fl = None if result.orbit is None else result.orbit.fluxes
    if fl is None:
        return None
    o = result.case.orbit
    pos = fl.positions
    from ..radiation.orbital import period_average

    kinds = {}
    for kind in fl.kinds:
        a = fl.absorbed[kind].sum(axis=1)
        inc = fl.incident[kind].sum(axis=1)
        bal = np.abs(inc - a - fl.lost[kind]) / np.maximum(np.abs(inc), 1e-300)
        kinds[kind] = {"absorbed_mean_W": float(period_average(pos.time, a, pos.period)),
                       "absorbed_max_W": float(a.max()), "incident_max_W": float(inc.max()),
                       "rays": int(fl.rays[kind].sum()), "max_relative_imbalance": float(bal.max())}
    ecl = pos.eclipse
    dark = float(period_average(pos.time, (pos.lit < 1.0).astype(float), pos.period)) if ecl.any() else 0.0
    return {"altitude_km": float((o.orbit.semi_major_axis * (1 - o.orbit.eccentricity) - o.orbit.planet.radius) / 1e3),
            "period_s": float(pos.period), "beta_deg": float(o.orbit.beta), "positions": int(len(pos)),
            "eclipse": o.orbit.eclipse, "eclipse_fraction": dark, "attitude": o.attitude.kind,
            "fluxes_on": result.orbit.fluxes_on or "detailed", "steady": o.steady,
            "detailed_mesh": result.orbit.detailed is not None, "super_faces": result.orbit.super_faces is not None,
            "kinds": kinds, "segments": int(fl.segments)}


def write_orbit_npz(folder: Path, result: Result) -> None:
    """``orbit.npz``: ``true_anomaly_deg``, ``time_s``, ``lit``, ``eclipse``, ``event`` (k,), ``sun_mesh``,
    ``nadir_mesh`` (k, 3), ``position_mesh_m`` (k, 3), ``period_s``; ``detailed_absorbed_<kind>_W`` /
    ``detailed_incident_<kind>_W`` (k, n_faces) per FE face, ``super_faces_absorbed_<kind>_W`` /
    ``super_faces_incident_<kind>_W`` (k, 2 n_faces) per side; with per-position solves ``temperature_C`` (k,
    n_nodes) (recovered or detailed) and ``reference_temperature_C``; ``node_id`` (n_nodes,)."""
    fl = None if result.orbit is None else result.orbit.fluxes
    if fl is None:
        return
    pos = fl.positions
    data = {"true_anomaly_deg": pos.true_anomaly, "time_s": pos.time, "lit": pos.lit, "eclipse": pos.eclipse,
            "event": pos.event.astype(str), "sun_mesh": fl.sun, "nadir_mesh": fl.nadir,
            "position_mesh_m": fl.position, "period_s": np.float64(pos.period)}
    for name, f in (("detailed", result.orbit.detailed), ("super_faces", result.orbit.super_faces)):
        if f is None:
            continue
        for kind in f.kinds:  # per FE face (detailed) or per side (super faces), W
            data[f"{name}_absorbed_{kind}_W"] = f.absorbed[kind]
            data[f"{name}_incident_{kind}_W"] = f.incident[kind]
    model = result.model
    if result.orbit.T_positions is not None:
        data["temperature_C"] = np.array([model.node_temperatures(T) for T in result.orbit.T_positions]) - KELVIN
    if result.orbit.T_positions_detailed is not None:
        data["reference_temperature_C"] = (np.array([model.node_temperatures(T)
                                                     for T in result.orbit.T_positions_detailed]) - KELVIN)
    data["node_id"] = result.mesh.node_ids
    np.savez(folder / "orbit.npz", **data)


def orbit_plots(folder: Path, result: Result) -> list[tuple[str, str]]:
    """The report's plots ``orbit_fluxes.png`` (absorbed power per kind against the true anomaly) and, with
    per-position solves, ``orbit_temperatures.png``; returns (image, caption) pairs."""
    fl = None if result.orbit is None else result.orbit.fluxes
    if fl is None:
        return []
    pos = fl.positions
    model = result.model

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    images = []
    nu = np.asarray(pos.true_anomaly, float)  # in time order from perigee
    fig, ax = plt.subplots(figsize=(7.0, 3.8), dpi=110)
    for f, style, label in ((result.orbit.detailed, "-", "FE faces"), (result.orbit.super_faces, "--", "super faces")):
        if f is None:
            continue
        for kind, colour in zip(f.kinds, ("#e69f00", "#0072b2", "#d55e00")):
            ax.plot(nu, f.absorbed[kind].sum(axis=1), style, color=colour, label=f"{kind} ({label})")
    _eclipse_band(ax, pos)
    save_plot(fig, ax, folder / "orbit_fluxes.png", "true anomaly [deg]", "absorbed power [W]",
              "Orbital heat loads, whole model")
    images.append(("orbit_fluxes.png", "Absorbed solar, albedo and planet-IR power along the orbit (grey: eclipse)"))
    if result.orbit.T_positions is not None:
        fig, ax = plt.subplots(figsize=(7.0, 3.8), dpi=110)
        parts = model.parts
        for p, info in enumerate(parts):
            dofs = np.unique(model.element_dofs[model.element_part == p])
            dofs = dofs[dofs >= 0]
            T = result.orbit.T_positions[:, dofs].mean(axis=1) - KELVIN
            line, = ax.plot(nu, T, "-", label=f"{info.name}")
            if result.orbit.T_positions_detailed is not None:
                ax.plot(nu, result.orbit.T_positions_detailed[:, dofs].mean(axis=1) - KELVIN, ":",
                        color=line.get_color())
        _eclipse_band(ax, pos)
        save_plot(fig, ax, folder / "orbit_temperatures.png", "true anomaly [deg]", "mean temperature [°C]",
                  "Steady temperature at each position (dotted: detailed)")
        images.append(("orbit_temperatures.png", "Mean temperature per part of a steady solve at each position"))
    return images


def save_plot(fig, ax, path: Path, xlabel: str, ylabel: str, title: str, legend_fontsize: float = 7) -> None:
    """Label ``ax`` (axis labels, title, legend), lay ``fig`` out tightly, write it to ``path`` and close it.

    Parameters
    ----------
    fig, ax : a matplotlib figure and its axes (the caller has selected the Agg backend)
    path : PNG file written
    xlabel, ylabel, title : texts of the axis labels and the title
    legend_fontsize : font size (points) of the legend
    """
    import matplotlib.pyplot as plt

    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=legend_fontsize)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _eclipse_band(ax, pos) -> None:
    """Grey spans over the eclipsed parts of the orbit."""
    nu = np.asarray(pos.true_anomaly, float)
    dark = pos.lit < 1.0
    k = 0
    while k < len(nu):
        if dark[k]:
            j = k
            while j + 1 < len(nu) and dark[j + 1]:
                j += 1
            ax.axvspan(nu[k], nu[j], color="0.85", zorder=0)
            k = j + 1
        else:
            k += 1
