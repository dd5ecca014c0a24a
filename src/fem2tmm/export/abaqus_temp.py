"""Temperatures for thermo-elastic solvers outside Nastran: Abaqus / CalculiX ``*TEMPERATURE`` (``temperatures.inp``).

One ``*STEP`` per state (steady result, output time or CSV column), each a ``*STATIC`` step whose ``*TEMPERATURE``
block gives every node of the thermal model its temperature in °C by original node id, and a ``*NODE FILE`` output
request for the displacements.  Include it after the model data (``*INCLUDE, INPUT=temperatures.inp``); the
supports are the model's (``*BOUNDARY`` in the model data applies to every step), and the stress-free temperature is
the model's ``*INITIAL CONDITIONS, TYPE=TEMPERATURE``.  Checked with CalculiX 2.20 (``tests/test_calculix.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def temperature_steps(node_ids: np.ndarray, T_celsius: np.ndarray, labels: list[str] | None = None,
                      title: str = "fem2tmm temperatures") -> str:
    """The text of ``temperatures.inp``.

    Parameters
    ----------
    node_ids : (n,) int
        Original node ids.
    T_celsius : (n,) or (n, k) float
        °C; NaN: node outside the thermal model, not written.
    labels : list of k str, optional
        What each column is (a time, a case), written as a comment before its step.
    title : str
        First comment line.
    """
    T = np.asarray(T_celsius, float)
    T = T[:, None] if T.ndim == 1 else T
    ids = np.asarray(node_ids, np.int64)
    lines = [f"** {title}", f"** {T.shape[1]} step(s), temperatures in degC by original node id; include after the "
             "model data (*INCLUDE, INPUT=temperatures.inp)"]
    for j in range(T.shape[1]):
        ok = np.isfinite(T[:, j])
        if labels is not None:
            lines.append(f"** step {j + 1}: {labels[j]}")
        lines += ["*STEP", "*STATIC", "*TEMPERATURE"]
        lines += [f"{i:d}, {v!r}" for i, v in zip(ids[ok].tolist(), T[ok, j].tolist())]
        lines += ["*NODE FILE", "U", "*END STEP"]
    return "\n".join(lines) + "\n"


def write_inp(path: str | Path, node_ids: np.ndarray, T_celsius: np.ndarray, labels: list[str] | None = None,
              title: str = "fem2tmm temperatures") -> None:
    """Write :func:`temperature_steps` to ``path``."""
    Path(path).write_text(temperature_steps(node_ids, T_celsius, labels, title), encoding="ascii")


__all__ = ["temperature_steps", "write_inp"]
