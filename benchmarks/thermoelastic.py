"""``fem2tmm bench thermoelastic``: the thermo-elastic chain on examples/truss with CalculiX (issue 30 item 3).

fem2tmm runs the truss (121 693 tetrahedra, aluminium, one pad held at 20 °C, 10 W on the other, radiating to a
−100 °C sink) at 10 and 100 super nodes; CalculiX (``ccx``, Debian's ``calculix-ccx``) then solves the linear
static thermal-strain problem on the same tetrahedra (C3D4), 3-2-1 supports on the held pad, three times per
count: with the detailed temperatures, with the recovered temperatures read from fem2tmm's ``temperatures.inp``
writer, and with one temperature per super node (each node taking its dominant super node's).  Reported: the
temperature error of the two reduced fields against the detailed one, and the displacement error (RMS and max
over the nodes, per cent of the detailed field's max |u|).

The CalculiX helpers here (mesh cards, running ccx, reading .frd result blocks) are also used by
``tests/test_calculix.py``.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
_CCX_TYPE = {"hex8": "C3D8", "tet4": "C3D4", "wedge6": "C3D6"}
ALUMINIUM = {"E": 70.0e9, "nu": 0.33, "alpha": 23.0e-6}


def ccx() -> str | None:
    """The CalculiX executable, or None."""
    return shutil.which("ccx")


def model_cards(mesh) -> list[str]:
    """``*NODE`` and ``*ELEMENT`` cards of a solid mesh (hex8, tet4, wedge6) with its own node and element ids."""
    ids = mesh.node_ids
    lines = ["*NODE, NSET=NALL"] + [f"{i:d}, {x!r}, {y!r}, {z!r}"
                                    for i, (x, y, z) in zip(ids.tolist(), mesh.points.tolist())]
    for t, cells, gidx in mesh.iter_blocks():
        if t not in _CCX_TYPE:
            continue
        lines.append(f"*ELEMENT, TYPE={_CCX_TYPE[t]}, ELSET=EALL")
        lines += [f"{int(mesh.element_ids[g])}, " + ", ".join(str(int(ids[c])) for c in row)
                  for row, g in zip(cells, gidx)]
    return lines


def run_ccx(folder: Path, name: str, text: str, timeout: float = 1800.0) -> str:
    """Write ``name``.inp in ``folder``, run ccx on it, return the .frd text (raises on a failed run)."""
    (folder / f"{name}.inp").write_text(text)
    p = subprocess.run([ccx(), "-i", name], cwd=folder, capture_output=True, text=True, timeout=timeout)
    if p.returncode != 0 or "Job finished" not in p.stdout:
        raise RuntimeError(f"ccx failed on {folder / name}.inp:\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")
    return (folder / f"{name}.frd").read_text()


def frd_block(frd: str, block: str) -> dict[int, np.ndarray]:
    """{node id: values} of the last result block named ``block`` (DISP, NDTEMP) of a CalculiX .frd text."""
    out, cur = {}, None
    for line in frd.splitlines():
        if line.startswith(" -4") and line.split()[1] == block:
            cur = {}
        elif cur is not None and line.startswith(" -1"):
            rest = line[13:]
            cur[int(line[3:13])] = np.array([float(rest[12 * k: 12 * k + 12]) for k in range(len(rest) // 12)])
        elif cur is not None and line.startswith(" -3"):
            out, cur = cur, None
    return out


def static_displacements(folder: Path, mesh, T_nodes_C: np.ndarray, supports: tuple[int, int, int],
                         material: dict = ALUMINIUM, T_free_C: float = 20.0) -> np.ndarray:
    """(n, 3) m: CalculiX linear static displacements of ``mesh`` under the thermal strain of ``T_nodes_C`` (°C per
    mesh node, written by fem2tmm's ``temperatures.inp`` writer), strain-free at ``T_free_C``, held by a 3-2-1
    support on the node ids ``supports`` (a: x, y, z; b: y, z; c: z)."""
    from fem2tmm.export.abaqus_temp import write_inp

    folder.mkdir(parents=True, exist_ok=True)
    a, b, c = supports
    lines = ["*HEADING", "fem2tmm thermo-elastic chain"] + model_cards(mesh)
    lines += ["*MATERIAL, NAME=M", "*ELASTIC", f"{material['E']!r}, {material['nu']!r}", "*EXPANSION",
              f"{material['alpha']!r}", "*SOLID SECTION, ELSET=EALL, MATERIAL=M",
              "*INITIAL CONDITIONS, TYPE=TEMPERATURE", f"NALL, {T_free_C!r}",
              "*BOUNDARY", f"{a}, 1, 3", f"{b}, 2, 3", f"{c}, 3, 3", "*INCLUDE, INPUT=temperatures.inp"]
    write_inp(folder / "temperatures.inp", mesh.node_ids, np.asarray(T_nodes_C, float))
    disp = frd_block(run_ccx(folder, "static", "\n".join(lines) + "\n"), "DISP")
    return np.array([disp[int(i)][:3] for i in mesh.node_ids])


def constant_per_super_node(result) -> np.ndarray:
    """(n_nodes,) K: each FE node at the temperature of the super node weighing most on it (what a network gives
    without a recovery)."""
    rm = result.reduced.network
    dof_sn = np.asarray(rm.supernodes.A.argmax(axis=0)).ravel()
    return result.model.node_temperatures(result.reduced.solution.T[dof_sn])


def _supports(mesh) -> tuple[int, int, int]:
    """Three nodes of the held pad for a 3-2-1 support: the corner nearest the origin, the farthest along x from it,
    the farthest along y."""
    nodes = mesh.groups["pad_fixed"].nodes
    p = mesh.points[nodes]
    a = nodes[np.argmin(np.linalg.norm(p - p.min(0), axis=1))]
    b = nodes[np.argmax(p[:, 0] - mesh.points[a, 0] - np.abs(p[:, 1] - mesh.points[a, 1]))]
    c = nodes[np.argmax(p[:, 1] - mesh.points[a, 1] - np.abs(p[:, 0] - mesh.points[a, 0]))]
    return tuple(int(mesh.node_ids[i]) for i in (a, b, c))


def bench_thermoelastic(n_sn=(10, 100)) -> list[dict]:
    from fem2tmm.case import Case
    from fem2tmm.constants import KELVIN
    from fem2tmm.pipeline import run

    if ccx() is None:
        return [{"bench": "thermoelastic", "skipped": "ccx (Debian calculix-ccx) is not installed"}]
    folder = REPO / "examples" / "truss"
    rows, u_det = [], None
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for n in n_sn:
            import tomllib

            raw = tomllib.loads((folder / "case.toml").read_text())
            raw["parts"][0]["super_nodes"] = n
            case = Case.from_dict(raw, base_dir=folder)
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = run(case)
            t_run = time.perf_counter() - t0
            mesh = res.mesh
            sup = _supports(mesh)
            T = {"recovered": res.T_recovered_nodes, "constant": constant_per_super_node(res)}
            t0 = time.perf_counter()
            if u_det is None:
                u_det = static_displacements(tmp / "detailed", mesh, res.T_detailed_nodes - KELVIN, sup)
            umax = float(np.linalg.norm(u_det, axis=1).max())
            for name, field in T.items():
                u = static_displacements(tmp / f"{name}_{n}", mesh, field - KELVIN, sup)
                dT = (field - res.T_detailed_nodes)[res.model.node_dof >= 0]
                du = np.linalg.norm(u - u_det, axis=1)
                rows.append({"bench": "thermoelastic", "study": "truss", "super_nodes": n, "field": name,
                             "T_rms_K": float(np.sqrt(np.mean(dT**2))), "T_max_K": float(np.abs(dT).max()),
                             "u_max_detailed_um": umax * 1e6,
                             "u_rms_pct": 100 * float(np.sqrt(np.mean(du**2))) / umax,
                             "u_max_pct": 100 * float(du.max()) / umax,
                             "fem2tmm_run_s": round(t_run, 1)})
                print(rows[-1], flush=True)
            rows[-1]["ccx_s"] = round(time.perf_counter() - t0, 1)
    return rows
