"""Bad input found by trying fem2tmm as a new user (issue 15): empty and truncated mesh files, mirrored solids, a
load on fixed-temperature nodes.  One clear Fem2TmmError (CLI: exit 2, one line, no traceback)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import make_case, plate_case_toml

from fem2tmm import Fem2TmmError, meshes
from fem2tmm.cli import main
from fem2tmm.fem.model import build_model
from fem2tmm.io import read_mesh
from fem2tmm.mesh import ElementBlock, Mesh

MESHES = Path(__file__).resolve().parents[1] / "meshes"


def _bad_files(tmp_path):
    """Empty .msh and .bdf, and the committed fin mesh (Gmsh 4.1 and 2.2) cut in the header, in the nodes and in
    the elements."""
    (tmp_path / "empty.msh").write_bytes(b"")
    (tmp_path / "empty.bdf").write_bytes(b"")
    files = [tmp_path / "empty.msh", tmp_path / "empty.bdf"]
    for name in ("fin.msh", "fin_v22.msh"):
        data = (MESHES / name).read_bytes()
        for cut in (100, 2000, len(data) // 2, len(data) - 2000):
            p = tmp_path / f"cut{cut}_{name}"
            p.write_bytes(data[:cut])
            files.append(p)
    return files


def test_empty_and_truncated_mesh_files_raise_fem2tmm_error(tmp_path, capsys):
    for p in _bad_files(tmp_path):
        with pytest.raises(Fem2TmmError, match=str(p.name)):  # never SystemExit (meshio calls sys.exit)
            read_mesh(p)
        assert capsys.readouterr().err == ""  # meshio's own printing is kept out of the way


def test_cli_exits_2_with_one_line_on_bad_mesh_files(tmp_path, capsys):
    for p in _bad_files(tmp_path):
        case = tmp_path / f"{p.stem}.toml"
        case.write_text(plate_case_toml(mesh=p.name))
        code = main(["run", str(case), "--out", str(tmp_path / "out"), "--quiet"])
        cap = capsys.readouterr()
        assert code == 2, p
        assert cap.err.startswith("fem2tmm: error: ") and cap.err.count("\n") == 1 and "Traceback" not in cap.err
        assert p.name in cap.err and cap.out == ""
    # the real process: exit status 2, one line (meshio's sys.exit would give 1)
    r = subprocess.run([sys.executable, "-m", "fem2tmm.cli", "run", str(tmp_path / "empty.toml"), "--quiet"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "is empty" in r.stderr


def test_mirrored_solid_is_reoriented_with_a_warning_naming_it():
    # a hex whose node order is mirrored (negative Jacobian everywhere) is the same element: reoriented, so the
    # model equals the one of the correctly numbered mesh, and the warning names element 3
    m = meshes.box(1, 1, 1, 2, 2, 2, kind="solid")
    cells = m.blocks[0].cells.copy()
    cells[2] = cells[2][[4, 5, 6, 7, 0, 1, 2, 3]]  # top and bottom swapped: mirrored
    bad = Mesh(m.points, (ElementBlock("hex8", cells, m.blocks[0].ids),), m.groups)
    case = make_case([{"name": "b", "groups": ["box"], "material": "al"}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 0.0}])
    with pytest.warns(UserWarning, match=r"hex8 elements 3 have a negative Jacobian .*reoriented"):
        K_bad = build_model(bad, case).K
    K = build_model(m, case).K
    assert abs(K - K_bad).max() <= 1e-12 * abs(K).max()


def test_load_on_fixed_nodes():
    # a power on the very nodes held at a fixed temperature: it would heat nothing, exit 2 naming the nodes
    part = {"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black"}
    fix = {"kind": "temperature", "groups": ["xmin"], "value": 20.0}
    m = meshes.plate(1.0, 1.0, 4, 4)
    with pytest.raises(Fem2TmmError, match=r"whole load \(3 W\) falls on nodes of the fixed-temperature boundary"
                                           r".*nodes 1, 6, 11, 16, 21"):
        build_model(m, make_case([part], [fix, {"kind": "power", "groups": ["xmin"], "value": 3.0}]))
    # a flux over the whole plate: the fixed edge's nodal share (half a column of 4 x 4 quads: 1/8 of the 16 W
    # = 2 W) goes straight into the boundary: a warning with the watts
    with pytest.warns(UserWarning, match=r"2 W of its 16 W fall on nodes of the fixed-temperature boundary"):
        model = build_model(m, make_case([part], [fix, {"kind": "flux", "groups": ["plate"], "value": 16.0}]))
    assert model.Q.sum() == pytest.approx(16.0, rel=1e-12)
