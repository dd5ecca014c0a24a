"""Bad input: one clear Fem2TmmError naming the culprit; the CLI exits 2 with no traceback and no output."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import meshio
import numpy as np
import pytest

from conftest import make_case, plate_case_toml
from fem2tmm import Fem2TmmError
from fem2tmm.mesh import shapes
from fem2tmm.case import Case
from fem2tmm.cli import main
from fem2tmm.fem.model import build_model
from fem2tmm.io import read_mesh
from fem2tmm.mesh import ElementBlock, Mesh
from fem2tmm.pipeline import run

PLATE_PART = {"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black"}
EDGE_T = {"kind": "temperature", "groups": ["xmin"], "value": 20.0}


def write_plate_msh(path, quad=True, extra=None):
    m = shapes.plate(1.0, 1.0, 2, 2)
    cells = [("quad", m.blocks[0].cells)]
    phys = [np.full(len(m.blocks[0].cells), 1)]
    if extra is not None:
        cells.append(extra)
        phys.append(np.full(len(extra[1]), 1))
    mm = meshio.Mesh(m.points * 1000, cells, cell_data={"gmsh:physical": phys, "gmsh:geometrical": phys},
                     field_data={"plate": np.array([1, 2])})
    meshio.write(str(path), mm, file_format="gmsh22", binary=False)




def test_part_without_material():
    with pytest.raises(Fem2TmmError, match=r"'plate' has no material"):
        build_model(shapes.plate(), make_case([{**PLATE_PART, "material": None} if False else
                                               {k: v for k, v in PLATE_PART.items() if k != "material"}], [EDGE_T]))


def test_shell_part_without_thickness():
    with pytest.raises(Fem2TmmError, match=r"shell part without thickness"):
        build_model(shapes.plate(), make_case([{k: v for k, v in PLATE_PART.items() if k != "thickness"}], [EDGE_T]))


def test_group_missing_from_mesh():
    with pytest.raises(Fem2TmmError, match=r"group 'plat' is not in mesh .*available groups: .*'plate'"):
        build_model(shapes.plate(), make_case([{**PLATE_PART, "groups": ["plat"]}], [EDGE_T]))


def test_boundary_group_missing_from_mesh():
    with pytest.raises(Fem2TmmError, match=r"\[\[boundary\]\] 'temperature_0'.*group 'edge'"):
        build_model(shapes.plate(), make_case([PLATE_PART], [{**EDGE_T, "groups": ["edge"]}]))


def test_zero_area_element_names_ids():
    m = shapes.plate(1.0, 1.0, 2, 2)
    # a fifth quad on four collinear new nodes: zero area
    line = np.column_stack([np.linspace(2, 3, 4), np.zeros(4), np.zeros(4)])
    pts = np.concatenate([m.points, line])
    cells = np.concatenate([m.blocks[0].cells, [np.arange(m.n_nodes, m.n_nodes + 4)]])
    from fem2tmm.mesh import make_group

    blocks = (ElementBlock("quad4", cells, np.arange(1, 6)),)
    groups = dict(m.groups)
    groups["plate"] = make_group("plate", 2, np.arange(5), mesh_cells=np.pad(cells, ((0, 0), (0, 4)), constant_values=-1))
    with pytest.raises(Fem2TmmError, match=r"quad4 elements 5 have zero area"):
        build_model(Mesh(pts, blocks, groups), make_case([PLATE_PART], [EDGE_T]))


def test_bowtie_quad_names_ids():
    m = shapes.plate(1.0, 1.0, 2, 2)
    c = m.blocks[0].cells.copy()
    c[1] = c[1][[0, 2, 1, 3]]  # crossed (bow-tie) node order
    bad = Mesh(m.points, (ElementBlock("quad4", c, m.blocks[0].ids),), m.groups)
    with pytest.raises(Fem2TmmError, match=r"quad4 elements 2 .*bow-tie"):
        build_model(bad, make_case([PLATE_PART], [EDGE_T]))


def test_inverted_hex_names_ids():
    m = shapes.box(1, 1, 1, 2, 2, 2, kind="solid")
    pts = m.points.copy()
    cells = m.blocks[0].cells
    # push node 6 of element 1 through the opposite face: the Jacobian changes sign inside the element
    pts[cells[0, 6]] = pts[cells[0, 0]] - 0.2
    bad = Mesh(pts, m.blocks, m.groups)
    case = make_case([{"name": "b", "groups": ["box"], "material": "al"}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 0.0}])
    with pytest.raises(Fem2TmmError, match=r"hex8 elements 1\b.*inverted Jacobian"):
        build_model(bad, case)


def test_nan_coordinate_names_node():
    m = shapes.plate(1.0, 1.0, 2, 2)
    pts = m.points.copy()
    pts[4, 1] = np.nan
    with pytest.raises(Fem2TmmError, match=r"non-finite .* node ids 5"):
        Mesh(pts, m.blocks, m.groups).validate()


def test_empty_mesh(tmp_path):
    meshio.write(str(tmp_path / "e.msh"), meshio.Mesh(np.zeros((1, 3)), [("vertex", np.array([[0]]))]),
                 file_format="gmsh22", binary=False)
    with pytest.raises(Fem2TmmError, match=r"no supported elements"):
        read_mesh(tmp_path / "e.msh")


def test_unknown_unit(tmp_path):
    write_plate_msh(tmp_path / "plate.msh")
    with pytest.raises(Fem2TmmError, match=r"unknown length unit 'furlong'"):
        read_mesh(tmp_path / "plate.msh", unit="furlong")
    (tmp_path / "c.toml").write_text(plate_case_toml("plate").replace('"mm"', '"furlong"'))
    with pytest.raises(Fem2TmmError, match=r"c.toml: \[mesh\].unit: unknown length unit"):
        Case.from_toml(tmp_path / "c.toml")


@pytest.mark.parametrize("eps", [-0.1, 1.2])
def test_emissivity_outside_unit_interval(eps):
    with pytest.raises(Fem2TmmError, match=r"\[optics.black\].emissivity: must be"):
        make_case([PLATE_PART], [EDGE_T], optics={"black": {"emissivity": eps}})


def test_unsupported_element_type_lists_supported(tmp_path):
    tri6 = ("triangle6", np.array([[0, 1, 2, 3, 4, 5]]))
    write_plate_msh(tmp_path / "p.msh", extra=tri6)
    with pytest.raises(Fem2TmmError, match=r"unsupported element type\(s\) triangle6; supported: tri3, quad4, tet4, hex8, wedge6"):
        read_mesh(tmp_path / "p.msh")


def test_element_referencing_missing_node():
    m = shapes.plate(1.0, 1.0, 1, 1)
    c = m.blocks[0].cells.copy()
    c[0, 2] = 99
    with pytest.raises(Fem2TmmError, match=r"quad4 elements 1 reference nodes that do not exist"):
        Mesh(m.points, (ElementBlock("quad4", c, m.blocks[0].ids),)).validate()


def test_floating_part_without_boundary_or_radiation():
    # a conductive plate with no fixed temperature and no active side: its temperature is undetermined
    case = make_case([{**PLATE_PART, "front": "none"}], [{"kind": "power", "groups": ["plate"], "value": 1.0}])
    with pytest.raises(Fem2TmmError, match=r"neither a fixed temperature nor radiation.*'plate'"):
        run(case, mesh=shapes.plate())


def test_unknown_case_key_and_missing_material():
    with pytest.raises(Fem2TmmError, match=r"unknown key\(s\) 'super_node'"):
        make_case([{**PLATE_PART, "super_node": 3}], [EDGE_T])
    with pytest.raises(Fem2TmmError, match=r"'steel' is not a defined material; defined: al"):
        make_case([{**PLATE_PART, "material": "steel"}], [EDGE_T])


def test_overlapping_temperature_boundaries():
    case = make_case([PLATE_PART], [EDGE_T, {"kind": "temperature", "groups": ["ymin"], "value": 30.0}])
    with pytest.raises(Fem2TmmError, match=r"are in two temperature boundaries"):
        build_model(shapes.plate(), case)


# ----------------------------------------------------------------------------------------------- CLI
def test_cli_user_error_exits_2_without_traceback_or_output(tmp_path, capsys):
    write_plate_msh(tmp_path / "plate.msh")
    (tmp_path / "case.toml").write_text(plate_case_toml("nope"))
    out = tmp_path / "out"
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("fem2tmm: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert "group 'nope' is not in mesh" in err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "plate.msh"]  # no temp folder left


def test_cli_failure_late_in_the_run_leaves_no_output(tmp_path, capsys):
    # the error happens after the mesh was read and the model assembled (undetermined temperature)
    write_plate_msh(tmp_path / "plate.msh")
    toml = plate_case_toml("plate").replace('front = "black"', 'front = "none"')
    toml += '[[boundary]]\nkind = "power"\ngroups = ["plate"]\nvalue = 1.0\n'
    (tmp_path / "case.toml").write_text(toml)
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 2
    assert not (tmp_path / "out").exists()
    assert "Traceback" not in capsys.readouterr().err


def test_console_script_exit_code(tmp_path):
    # the installed entry point: a missing case file is a user error (2), one line on stderr
    p = subprocess.run([sys.executable, "-m", "fem2tmm.cli", "run", str(tmp_path / "missing.toml")],
                       capture_output=True, text=True)
    assert p.returncode == 2
    assert p.stderr.strip() == f"fem2tmm: error: case file {tmp_path / 'missing.toml'} does not exist"


def test_cli_success_writes_outputs(tmp_path):
    write_plate_msh(tmp_path / "plate.msh")
    toml = plate_case_toml("plate") + textwrap.dedent("""
        [[boundary]]
        kind = "temperature"
        groups = ["plate"]
        value = 15.0
        """)
    (tmp_path / "case.toml").write_text(toml)
    assert main(["run", str(tmp_path / "case.toml"), "--quiet"]) == 0
    out = tmp_path / "case-out"
    assert {p.name for p in out.iterdir()} >= {"summary.json", "temperatures.vtu", "temperatures.bdf"}


def test_a_missing_mesh_names_the_case_file_and_its_key(tmp_path, capsys):
    # `fem2tmm run` and `fem2tmm inspect` of a case whose [mesh] file is misspelled: one line naming the case file,
    # the key and the path looked for, before anything runs; nothing written
    write_plate_msh(tmp_path / "plate.msh")
    case = tmp_path / "case.toml"
    case.write_text(plate_case_toml("plate").replace("plate.msh", "plate2.msh"))
    for argv in (["run", str(case), "--out", str(tmp_path / "out")], ["inspect", str(case)]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"{case}: [mesh] file: {tmp_path / 'plate2.msh'} does not exist" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()
