"""Nastran ``TEMP``/``TEMPD`` bulk data with the original GRID ids (large field, °C)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _f16(v) -> str:
    if isinstance(v, (int, np.integer)):
        s = str(int(v))
    else:
        s = f"{float(v):.9E}"
    if len(s) > 16:
        raise ValueError(f"value {v!r} does not fit a 16-character field")
    return s.ljust(16)


def temp_cards(node_ids: np.ndarray, T_celsius: np.ndarray, sid: int = 1, default: float | None = None) -> list[str]:
    """TEMPD + TEMP cards (three grids per card, large field) of one load set ``sid`` for the nodes with finite
    temperatures; ``default`` (°C; default: the mean) goes to every other grid."""
    node_ids = np.asarray(node_ids, np.int64)
    T = np.asarray(T_celsius, float)
    ok = np.isfinite(T)
    ids, vals = node_ids[ok], T[ok]
    if default is None:
        default = float(vals.mean()) if len(vals) else 20.0
    lines = [("TEMPD*  " + _f16(sid) + _f16(default)).rstrip()]
    for k in range(0, len(ids), 3):
        g = ids[k : k + 3]
        t = vals[k : k + 3]
        fields = [sid]
        for gi, ti in zip(g, t):
            fields += [gi, float(ti)]
        first = "TEMP*   " + "".join(_f16(x) for x in fields[:4])
        lines.append(first.rstrip())
        if len(fields) > 4:
            lines.append(("*       " + "".join(_f16(x) for x in fields[4:])).rstrip())
    return lines


def write_temp(path: str | Path, node_ids: np.ndarray, T_celsius: np.ndarray, sid: int = 1,
               default: float | None = None, title: str = "fem2tmm temperatures") -> int:
    """Write TEMP cards (three grids per card, large field) for the nodes with finite temperatures.

    ``node_ids`` (n,) original GRID ids, ``T_celsius`` (n,) °C (NaN = not written); a TEMPD card gives
    ``default`` (°C; default: the mean temperature) to every other grid.  Returns the number of grids written.
    """
    n = int(np.isfinite(np.asarray(T_celsius, float)).sum())
    lines = [f"$ {title}", f"$ {n} grids, temperatures in degC, load set SID = {sid}",
             "$ TEMPD gives the default temperature of grids outside the thermal model"]
    lines += temp_cards(node_ids, T_celsius, sid, default)
    Path(path).write_text("\n".join(lines) + "\n", encoding="ascii")
    return n


def write_temp_series(path: str | Path, node_ids: np.ndarray, T_celsius: np.ndarray, times: np.ndarray,
                      first_sid: int = 1, title: str = "fem2tmm transient temperatures") -> dict[int, float]:
    """One TEMP load set per output time: SID ``first_sid + k`` holds the temperatures at ``times[k]``.

    ``T_celsius`` (n_t, n) °C, ``times`` (n_t,) s; the SID -> time map is written as comments at the top (for the
    thermo-elastic load cases: one SUBCASE per SID with ``TEMP(LOAD) = SID``) and returned.
    """
    T = np.asarray(T_celsius, float)
    sids = {first_sid + k: float(t) for k, t in enumerate(np.asarray(times, float))}
    n = int(np.isfinite(T[0]).sum()) if len(T) else 0
    lines = [f"$ {title}", f"$ {n} grids, temperatures in degC, {len(sids)} load sets (one per output time)",
             "$ SID -> time (s):"] + [f"$   SID {sid:d} = {t:.9g} s" for sid, t in sids.items()]
    lines.append("$ TEMPD gives the default temperature of grids outside the thermal model")
    for k, sid in enumerate(sids):
        lines += temp_cards(node_ids, T[k], sid)
    Path(path).write_text("\n".join(lines) + "\n", encoding="ascii")
    return sids
