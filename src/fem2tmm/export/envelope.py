"""The envelope over load cases: per mesh node the coldest and hottest temperature and the case that gives it.

Files (in the output folder of a multi-case run): ``envelope.vtu`` (point data ``temperature_min``,
``temperature_max`` °C, ``case_of_min``, ``case_of_max``: 0-based index into ``summary.json`` ``cases``, -1 for
nodes outside the thermal model), ``envelope_hot.bdf`` (Nastran ``TEMP``, SID 1: every node at its hottest) and
``envelope_cold.bdf`` (SID 2: every node at its coldest).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import KELVIN
from ..mesh import Mesh
from .nastran_temp import write_temp
from .vtu import write_vtu

#: Nastran load-set ids of the envelope's hot and cold temperature sets
HOT_SID, COLD_SID = 1, 2


@dataclass(frozen=True)
class Envelope:
    """``T_min``, ``T_max`` (n_nodes,) K (NaN outside every case's model); ``case_of_min``, ``case_of_max``
    (n_nodes,) index of the case giving it (the first such case in file order on ties; -1 where NaN)."""

    T_min: np.ndarray
    T_max: np.ndarray
    case_of_min: np.ndarray
    case_of_max: np.ndarray


def envelope(T_cases: np.ndarray) -> Envelope:
    """The envelope of node temperatures ``T_cases`` (k cases, n_nodes) K, NaN where a node is outside a case's
    model."""
    T = np.asarray(T_cases, float)
    missing = np.isnan(T)
    none = missing.all(axis=0)
    lo = np.argmin(np.where(missing, np.inf, T), axis=0)
    hi = np.argmax(np.where(missing, -np.inf, T), axis=0)
    cols = np.arange(T.shape[1])
    T_min, T_max = T[lo, cols], T[hi, cols]
    return Envelope(T_min=np.where(none, np.nan, T_min), T_max=np.where(none, np.nan, T_max),
                    case_of_min=np.where(none, -1, lo), case_of_max=np.where(none, -1, hi))


def write_envelope(folder: Path, mesh: Mesh, elements: np.ndarray, env: Envelope, n_cases: int) -> None:
    """Write ``envelope.vtu``, ``envelope_hot.bdf`` and ``envelope_cold.bdf`` of ``env`` (over ``n_cases``
    cases) into ``folder``; ``elements`` the mesh elements drawn in the VTU."""
    point_data = {"temperature_min": env.T_min - KELVIN, "temperature_max": env.T_max - KELVIN,
                  "case_of_min": env.case_of_min.astype(float), "case_of_max": env.case_of_max.astype(float)}
    write_vtu(folder / "envelope.vtu", mesh, point_data, elements=elements)
    write_temp(folder / "envelope_hot.bdf", mesh.node_ids, env.T_max - KELVIN, sid=HOT_SID,
               title=f"fem2tmm envelope: hottest of {n_cases} cases")
    write_temp(folder / "envelope_cold.bdf", mesh.node_ids, env.T_min - KELVIN, sid=COLD_SID,
               title=f"fem2tmm envelope: coldest of {n_cases} cases")


def envelope_summary(env: Envelope, names: list[str]) -> dict:
    """The summary's ``envelope`` entry: range (°C), and per case the number of nodes it makes coldest / hottest."""
    ok = np.isfinite(env.T_min)
    return {
        "T_min_C": float(np.min(env.T_min[ok]) - KELVIN) if ok.any() else None,
        "T_max_C": float(np.max(env.T_max[ok]) - KELVIN) if ok.any() else None,
        "coldest_nodes": {n: int(np.count_nonzero(env.case_of_min == k)) for k, n in enumerate(names)},
        "hottest_nodes": {n: int(np.count_nonzero(env.case_of_max == k)) for k, n in enumerate(names)},
        "files": {"vtu": "envelope.vtu", "hot": "envelope_hot.bdf", "cold": "envelope_cold.bdf"},
        "sids": {"hot": HOT_SID, "cold": COLD_SID},
    }
