"""``fem2tmm recover OUT_DIR --temperatures FILE``: temperatures computed outside fem2tmm, back onto the structure.

A thermal engineer solves the network fem2tmm handed over (``model.esatan``, ``model.sinda``, ``reduced.npz``) in
their own tool, hot and cold, along an orbit, and maps the super-node temperatures back onto every FE node for the
thermo-elastic analysis with the recovery ``reduced.npz`` carries (:mod:`fem2tmm.reduce.exported`).

The temperature file is a CSV with a header row: first column the super-node name as in the deck (``reduced.npz``
``names``; case-insensitive) or its number there (``1001`` or ``D1001``, ``reduced.npz`` ``numbers``: what an
ESATAN or SINDA result lists), then one column per time or case (°C); its header names the columns.  Every super
node of the network must have a row.  Optional rows: a named load (``[[boundary]]`` name of a power or flux boundary,
in W or W/m²) and ``sink`` (°C) give that value per column; the design value otherwise; ``time`` (s, on the run's
time axis) gives each column's orbital loads to a network with orbital loads traced on the FE faces (the orbit
average otherwise, as in the steady design case), or ``position`` (the orbit position counted from 1: position 1
is the first row of ``orbit.npz``'s per-position arrays; ``[orbit] steady = "positions"``) that position's loads
exactly.  Outputs (written atomically,
never over anything fem2tmm did not write): ``temperatures.vtu`` (one column) or ``temperatures.pvd`` with one VTU
per column in ``temperatures/``, ``temperatures.bdf`` (one Nastran TEMP load set per column, SID 1, 2, ...) and
``temperatures.inp`` (one Abaqus/CalculiX ``*STEP`` with ``*TEMPERATURE`` per column).
"""

from __future__ import annotations

import csv
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from .constants import KELVIN
from .errors import Fem2TmmError


def _numbers(cells) -> bool:
    """Whether every cell of a row reads as a number."""
    try:
        [float(c) for c in cells]
    except ValueError:
        return False
    return True


def read_temperature_table(path: str | Path, names: np.ndarray, load_names: np.ndarray,
                           numbers: np.ndarray | None = None
                           ) -> tuple[np.ndarray, dict, np.ndarray | None, list[str], np.ndarray | None,
                                      np.ndarray | None]:
    """Parse a temperature CSV (module docstring).  ``numbers`` (n_sn,) int or None: each super node's number in the
    decks (``D1001``, SINDA's ``1001``), in the order of ``names``; a row may then name its node by either (an
    ESATAN or SINDA result lists the numbers).

    Returns ``(T_sn (n_sn, k) K, loads {name: (k,)}, sinks (k,) K or None, column labels, times (k,) s or None,
    positions (k,) int (counted from 0) or None)``; raises
    :class:`Fem2TmmError` naming the row and column of a missing or unknown node or a non-numeric value.
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [r for r in csv.reader(fh) if any(c.strip() for c in r)]
    except OSError as exc:
        raise Fem2TmmError(f"{path}: cannot read the temperature file ({exc.strerror or exc})") from None
    if len(rows) < 2 or len(rows[0]) < 2:
        raise Fem2TmmError(f"{path}: needs a header row (node, column names ...) and one row per super node with at "
                           "least one temperature column (°C)")
    labels = [c.strip() or f"column {j}" for j, c in enumerate(rows[0][1:], start=2)]
    k = len(labels)
    index = {str(n).upper(): i for i, n in enumerate(names)}
    if numbers is not None:  # the deck's numbers, where no label reads the same
        for i, num in enumerate(np.asarray(numbers).ravel()):
            for alias in (str(int(num)), f"D{int(num)}"):
                index.setdefault(alias, i)
    loads_index = {str(n).upper(): str(n) for n in load_names}
    T = np.full((len(names), k), np.nan)
    loads: dict[str, np.ndarray] = {}
    sinks = times = positions = None
    seen: dict[int, int] = {}
    for lineno, row in enumerate(rows[1:], start=2):
        key = row[0].strip()
        if len(row) - 1 != k:
            raise Fem2TmmError(f"{path}: row {lineno} ({key!r}) has {len(row) - 1} values for {k} columns")
        vals = np.empty(k)
        for j, cell in enumerate(row[1:]):
            try:
                vals[j] = float(cell)
            except ValueError:
                raise Fem2TmmError(f"{path}: row {lineno} ({key!r}), column {j + 2} ({labels[j]!r}): {cell!r} is not "
                                   "a number") from None
            if not np.isfinite(vals[j]):
                raise Fem2TmmError(f"{path}: row {lineno} ({key!r}), column {j + 2} ({labels[j]!r}): {cell!r} is not "
                                   "a finite number")
        up = key.upper()
        if up in index:
            i = index[up]
            if i in seen:
                raise Fem2TmmError(f"{path}: row {lineno}: super node {key!r} appears twice (also row {seen[i]})")
            seen[i] = lineno
            T[i] = vals + KELVIN
        elif up in loads_index:
            loads[loads_index[up]] = vals
        elif up == "SINK":
            sinks = vals + KELVIN
        elif up == "TIME":
            times = vals
        elif up == "POSITION":
            if np.any(vals != np.round(vals)) or np.any(vals < 1):
                raise Fem2TmmError(f"{path}: row {lineno} ('position'): orbit positions are counted from 1 (the rows "
                                   f"of orbit.npz): {', '.join(format(v, 'g') for v in vals[:5])}")
            positions = vals.astype(np.int64) - 1
        else:
            raise Fem2TmmError(f"{path}: row {lineno}: {key!r} is no super node of this network (nor a named load: "
                               f"{', '.join(map(str, load_names)) or 'none'}, nor 'sink', 'time' or 'position'); its "
                               "super nodes are "
                               f"{', '.join(map(str, names[:8]))}{' ...' if len(names) > 8 else ''}"
                               + ("" if numbers is None else " (or their deck numbers "
                                  f"{', '.join(str(int(v)) for v in np.asarray(numbers).ravel()[:4])} ...)"))
    missing = [str(names[i]) for i in range(len(names)) if i not in seen]
    first = rows[0][0].strip().upper()
    if missing and first in index and index[first] not in seen and _numbers(rows[0][1:]):
        raise Fem2TmmError(f"{path}: the first row is read as the header (node, column names ...) but it is super "
                           f"node {rows[0][0].strip()!r} with its temperatures: put a header row such as "
                           f"'node,T' above it")
    if missing:
        raise Fem2TmmError(f"{path}: no row for super node(s) {', '.join(missing[:10])}"
                           f"{f' and {len(missing) - 10} more' if len(missing) > 10 else ''}: every super node of the "
                           "network needs its temperature")
    if np.any(T <= 0.0) or (sinks is not None and np.any(sinks <= 0.0)):
        raise Fem2TmmError(f"{path}: temperatures must be above absolute zero (the file is in °C)")
    if times is not None and positions is not None:
        raise Fem2TmmError(f"{path}: give a 'time' row or a 'position' row, not both (a position's loads are exact, "
                           "a time's interpolated between positions)")
    return T, loads, sinks, labels, times, positions


def recover(out_dir: str | Path, temperatures, out: str | Path | None = None, in_time: bool = False,
            step: float | None = None, scheme: str = "crank-nicolson") -> dict:
    """Recover FE-node temperatures from super-node temperatures computed anywhere.

    Parameters
    ----------
    out_dir : str or Path
        A ``fem2tmm run`` output folder (its ``reduced.npz`` and ``temperatures.vtu``).
    temperatures : str, Path or mapping
        A temperature CSV (module docstring), or ``{super-node name: °C or (k,) °C}`` plus optional named loads,
        ``"sink"`` (°C), ``"time"`` (s) or ``"position"`` (counted from 1).
    out : str or Path, optional
        Folder to write ``temperatures.vtu`` / ``.pvd``, ``temperatures.bdf`` and ``temperatures.inp`` into
        (atomically; fem2tmm's output-folder policy).  None writes nothing.
    in_time : bool
        The columns are one transient at increasing ``time`` values (the first its start):
        :meth:`~fem2tmm.reduce.exported.ExportedRecovery.recover_transient` integrates the heat each super node
        stores between them, with named loads and sink linear between columns.  Needs a ``time`` row and a
        ``reduced.npz`` with the capacitance.
    step : float, optional
        With ``in_time``: the largest sub-step (s).
    scheme : str
        With ``in_time``: ``"crank-nicolson"``, ``"backward-euler"`` or ``"bdf2"``.

    Returns
    -------
    dict
        ``node_id`` (n_nodes,), ``temperature`` (n_nodes, k) °C (NaN outside the model), ``labels`` (k,),
        ``out`` the folder written or None.
    """
    from .reduce.exported import load

    out_dir = Path(out_dir)
    npz = out_dir / "reduced.npz"
    if not npz.is_file():
        raise Fem2TmmError(f"{out_dir}: no reduced.npz: give the output folder of a fem2tmm run with a reduction")
    if out is not None:
        from .export.output import check_output_place

        out = check_output_place(out)  # before any computation
    rec = load(npz)
    numbers = _deck_numbers(npz, rec.names)
    where = str(temperatures) if isinstance(temperatures, (str, Path)) else "the temperatures"
    if isinstance(temperatures, (str, Path)):
        T_sn, loads, sinks, labels, times, positions = read_temperature_table(temperatures, rec.names, rec.load_names,
                                                                              numbers)
    else:
        T_sn, loads, sinks, labels, times, positions = _from_mapping(temperatures, rec.names, rec.load_names, numbers)
    if positions is not None:
        k = 0 if rec.orbit_q is None else rec.orbit_q.shape[0]
        if not k:
            raise Fem2TmmError(f"{where}: a 'position' row, but {npz} carries no orbital loads (they travel with the "
                               "recovery when [orbit] fluxes_on = \"detailed\")")
        if positions.max() >= k:
            raise Fem2TmmError(f"{where}: orbit position {int(positions.max()) + 1} of a network with {k} positions")
    if in_time:
        if times is None:
            raise Fem2TmmError(f"{where}: recovering in time needs a 'time' row (s) giving each column's time")
        if positions is not None:
            raise Fem2TmmError(f"{where}: recovering in time takes a 'time' row, not 'position'")
        if rec.C is None:
            raise Fem2TmmError(f"{npz} carries no capacitance (its case gives no density and specific heat): "
                               "recover without --in-time, or give them and run the case again")
        orbital = rec.orbit_q is not None
        T_dof = rec.recover_transient(T_sn.reshape(rec.n_sn, -1), np.asarray(times, float), loads=loads or None,
                                      T_sink=sinks, step=step, scheme=scheme, orbital=orbital)
    else:
        T_dof = rec.recover(T_sn, loads=loads, T_sink=sinks, times=times, positions=positions).reshape(rec.n_dof, -1)
    T_nodes = rec.node_temperatures(T_dof) - KELVIN
    result = {"node_id": rec.node_ids, "temperature": T_nodes, "labels": labels, "out": None}
    if out is not None:
        vtu = out_dir / "temperatures.vtu"
        if not vtu.is_file():
            raise Fem2TmmError(f"{out_dir}: no temperatures.vtu (the mesh the recovered temperatures are written on)")
        from .export.output import write_folder

        result["out"] = write_folder(out, lambda tmp: _write(tmp, vtu, rec.node_ids, T_nodes, labels))
    return result


def _deck_numbers(npz: Path, names: np.ndarray) -> np.ndarray | None:
    """(n_sn,) the deck number of each of the recovery's super nodes ``names``, from ``reduced.npz`` ``numbers``
    (None for a file written before it carried them, or a name it lacks)."""
    with np.load(npz, allow_pickle=False) as z:
        if "numbers" not in z.files:
            return None
        of = dict(zip(z["names"].astype(str), np.asarray(z["numbers"]).astype(np.int64)))
    got = [of.get(str(n)) for n in names]
    return None if any(v is None for v in got) else np.array(got, np.int64)


def _from_mapping(temps, names, load_names, numbers=None):
    lower = {str(k).upper(): v for k, v in dict(temps).items()}
    k = max((np.atleast_1d(np.asarray(v, float)).size for v in lower.values()), default=1)
    rows = [["node"] + [f"column {j + 1}" for j in range(k)]]
    for key, v in dict(temps).items():
        rows.append([str(key)] + [repr(float(x)) for x in np.broadcast_to(np.atleast_1d(np.asarray(v, float)), (k,))])
    import io
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "temperatures.csv"
        buf = io.StringIO()
        csv.writer(buf).writerows(rows)
        p.write_text(buf.getvalue(), encoding="utf-8")
        return read_temperature_table(p, names, load_names, numbers)


def _write(folder: Path, vtu: Path, node_ids: np.ndarray, T: np.ndarray, labels: list[str]) -> None:
    import meshio

    from .export.abaqus_temp import write_inp
    from .export.nastran_temp import temp_cards, write_temp

    base = meshio.read(str(vtu))
    if len(base.points) != len(T):
        raise Fem2TmmError(f"{vtu}: {len(base.points)} points, the recovery has {len(T)} nodes: not the same run")

    def vtu_with(path, col):
        m = meshio.Mesh(base.points, base.cells, point_data={"temperature": T[:, col], "node_id": node_ids},
                        cell_data={k: v for k, v in base.cell_data.items() if k in ("part", "cluster", "element_id")})
        meshio.write(str(path), m, file_format="vtu")

    k = T.shape[1]
    if k == 1:
        vtu_with(folder / "temperatures.vtu", 0)
        write_temp(folder / "temperatures.bdf", node_ids, T[:, 0], title=f"fem2tmm recovered temperatures: {labels[0]}")
    else:
        (folder / "temperatures").mkdir()
        width = max(4, len(str(k - 1)))
        files = [f"temperatures/temperatures_{j:0{width}d}.vtu" for j in range(k)]
        for j, f in enumerate(files):
            vtu_with(folder / f, j)
        rows = "\n".join(f'    <DataSet timestep="{j}" group="" part="0" name={quoteattr(lab)} file={quoteattr(f)}/>'
                         for j, (lab, f) in enumerate(zip(labels, files)))
        (folder / "temperatures.pvd").write_text(
            '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
            f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n", encoding="utf-8")
        lines = ["$ fem2tmm recovered temperatures", f"$ {k} load sets, temperatures in degC; SID -> column:"]
        lines += [f"$   SID {j + 1:d} = {lab}" for j, lab in enumerate(labels)]
        for j in range(k):
            lines += temp_cards(node_ids, T[:, j], j + 1)
        (folder / "temperatures.bdf").write_text("\n".join(lines) + "\n", encoding="ascii")
    write_inp(folder / "temperatures.inp", node_ids, T, labels=labels, title="fem2tmm recovered temperatures")


__all__ = ["read_temperature_table", "recover"]
