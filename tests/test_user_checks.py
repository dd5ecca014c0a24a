"""A new user's first hour: unit mistakes warned before the long computation, ``inspect`` listing the groups a
``[[boundary]]`` needs, a run's outputs reduced again by ``fem2tmm network reduce``, and the small CLI items
(space-separated Nastran, ``value = "5 W"``, ``--quiet``, progress in logs, the negative-GL note)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _plate_bdf(path: Path, n: int = 4, size: float = 100.0, sep: str = ",") -> Path:
    """A flat square plate of ``size`` x ``size`` (file units, mm here) in n x n CQUAD4 (PID 1), free field with
    ``sep`` between the fields."""
    nid = lambda i, j: j * (n + 1) + i + 1  # noqa: E731
    lines = ["BEGIN BULK"]
    lines += [sep.join(["GRID", str(nid(i, j)), "", f"{i * size / n:.1f}", f"{j * size / n:.1f}", "0.0"])
              for j in range(n + 1) for i in range(n + 1)]
    lines += [sep.join(["CQUAD4", str(j * n + i + 1), "1", str(nid(i, j)), str(nid(i + 1, j)), str(nid(i + 1, j + 1)),
                        str(nid(i, j + 1))]) for j in range(n) for i in range(n)]
    path.write_text("\n".join(lines + ["ENDDATA"]) + "\n")
    return path


def _plate_case(tmp_path: Path, unit: str = "mm", thickness: float = 1.0e-3, boundary: str = "value = 5.0") -> Path:
    _plate_bdf(tmp_path / "plate.bdf")
    case = tmp_path / "case.toml"
    case.write_text(f"""
[mesh]
file = "plate.bdf"
unit = "{unit}"
[materials.al]
conductivity = 170.0
density = 2700.0
specific_heat = 900.0
[optics.black]
emissivity = 0.9
absorptivity = 0.3
[[parts]]
name = "plate"
groups = ["PID 1"]
material = "al"
thickness = {thickness!r}
front = "black"
back = "none"
super_nodes = 4
[[boundary]]
kind = "power"
groups = ["PID 1"]
{boundary}
[environment]
sink_temperature = -100.0
[reference]
detailed = false
""")
    return case


def _cli(*args: str):
    """``fem2tmm ARGS`` in a process of its own (stderr as a log file: not a terminal)."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT)]))
    return subprocess.run([sys.executable, "-m", "fem2tmm.cli", *args], capture_output=True, text=True, env=env,
                          timeout=600)


# ---------------------------------------------------------------------------------------------- item 4: sanity


class _HeavyStage(Exception):
    pass


def _warnings_before_clustering(monkeypatch, case_path: Path) -> list[str]:
    """The warnings ``run`` gives before its first heavy stage (the clustering, monkeypatched to stop the run)."""
    from fem2tmm import pipeline
    from fem2tmm.case import Case

    seen = {}

    def heavy(*a, **k):
        seen["warnings"] = [str(x.message) for x in rec]
        raise _HeavyStage

    monkeypatch.setattr(pipeline, "cluster_model", heavy)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        with pytest.raises(_HeavyStage):
            pipeline.run(Case.from_toml(case_path), cache=False)
    return seen["warnings"]


def test_millimetre_mesh_read_as_metres_warns_once_before_the_clustering(tmp_path, monkeypatch):
    # a 100 mm plate read with unit = "m" is 100 m across: above 50 m (plausibility.LARGE_EXTENT_M)
    got = _warnings_before_clustering(monkeypatch, _plate_case(tmp_path, unit="m"))
    hits = [w for w in got if "across" in w]
    assert len(hits) == 1, got
    assert "case.toml" in hits[0] and "100 m across" in hits[0] and '[mesh] unit = "mm"' in hits[0]
    assert len(got) == 1, got  # nothing else is implausible about this case


def test_two_metre_shell_warns_once_before_the_clustering(tmp_path, monkeypatch):
    # thickness = 2.0 "meaning mm" on a 0.1 m plate: 20 x the plate's size
    got = _warnings_before_clustering(monkeypatch, _plate_case(tmp_path, thickness=2.0))
    assert len(got) == 1, got
    assert "[[parts]] 'plate'.thickness = 2 m" in got[0] and "20 x the part's size (0.1 m)" in got[0]


def test_a_plausible_case_gets_no_warning_and_the_cli_warns_before_the_clustering(tmp_path, monkeypatch):
    assert _warnings_before_clustering(monkeypatch, _plate_case(tmp_path)) == []
    # the CLI (a process of its own, as a user runs it): the warning is printed once, after the assembly and
    # before the clustering's progress line
    case = _plate_case(tmp_path, unit="m")
    p = _cli("run", str(case), "--out", str(tmp_path / "out"))
    assert p.returncode == 0, p.stderr
    err = p.stderr
    assert err.count("m across") == 1, err
    assert err.index("m across") < err.index("[fem2tmm] clustering"), err


def test_a_case_set_warns_once(tmp_path):
    from fem2tmm.case import Case
    from fem2tmm.pipeline import run

    case = _plate_case(tmp_path, unit="m")
    text = case.read_text().replace('kind = "power"', 'name = "heater"\nkind = "power"')
    case.write_text(text + '[[cases]]\nname = "cold"\n[cases.boundary.heater]\nvalue = 1.0\n'
                           '[[cases]]\nname = "hot"\n[cases.boundary.heater]\nvalue = 10.0\n')
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")  # every warning call shows: the once is the run's own
        multi = run(Case.from_toml(case), cache=False)
    assert len(multi.results) == 2
    assert sum("m across" in str(w.message) for w in rec) == 1, [str(w.message) for w in rec]


@pytest.mark.parametrize("key,text,expect", [
    # aluminium's 170 W/(m K) written in mW/(m K): above diamond's ~2200 (CONDUCTIVITY_RANGE, CRC Handbook)
    ("conductivity", "conductivity = 1.7e5", "[materials.al] conductivity = 170000 W/(m K) is outside"),
    ("boundary", "value = 5.0e4", "value = 50000 W over 0.01 m2 is a heat flux of 5e+06 W/m2"),
    # the solar constant written in mW/m2
    ("sun", "sun_direction = [0, 0, 1]\nsolar_flux = 1.361e6", "[environment] solar_flux = 1.361e+06 W/m2 is above"),
])
def test_conductivity_and_flux_out_of_physical_range_warn(tmp_path, key, text, expect):
    from fem2tmm.case import Case
    from fem2tmm.fem.model import build_model
    from fem2tmm.fem.plausibility import implausible
    from fem2tmm.pipeline import load_mesh

    path = _plate_case(tmp_path, boundary=text if key == "boundary" else "value = 5.0")
    if key == "conductivity":
        path.write_text(path.read_text().replace("conductivity = 170.0", text))
    if key == "sun":
        path.write_text(path.read_text().replace("[environment]\n", f"[environment]\n{text}\n"))
    case = Case.from_toml(path)
    notes = implausible(build_model(load_mesh(case), case), case)
    assert len(notes) == 1 and expect in notes[0], notes


def test_extent_note_is_shared_and_never_advises_the_unit_in_force():
    from fem2tmm.fem.plausibility import extent_note

    assert extent_note(0.3, "m", "--unit") is None
    assert "then give --unit mm" in extent_note(300.0, "m", "--unit")
    assert "mm" not in extent_note(300.0, "mm", "[mesh] unit").split("check")[1]  # unit = "mm" already
    assert 'then give [mesh] unit = "m"' in extent_note(1.0e-3, "mm", "[mesh] unit")


def test_inspect_lists_line_and_node_groups_with_their_counts(capsys):
    from fem2tmm.cli import main

    assert main(["inspect", str(ROOT / "meshes" / "fin.msh"), "--unit", "mm"]) == 0
    out = capsys.readouterr().out
    section = out.split("line and node groups")[1]
    # meshes/make_fin.py: 120 nodes on each circular edge (N_CIRC = 120)
    assert "inner_edge" in section and "outer_edge" in section
    rows = {ln.split()[0]: ln.split() for ln in section.splitlines()[2:4]}
    assert rows["inner_edge"][1:] == ["line", "120"] and rows["outer_edge"][1:] == ["line", "120"]


# ------------------------------------------------------------------------------ item 5: outputs are inputs


@pytest.fixture(scope="module")
def plate_run(tmp_path_factory):
    """A 0.2 m aluminium plate, 10 x 10 quads in 16 super nodes, held at 20 °C along x = 0, 5 W spread over it,
    radiating to a -100 °C sink: its output folder and result."""
    from fem2tmm.case import Case
    from fem2tmm.mesh import shapes
    from fem2tmm.pipeline import run

    mesh = shapes.plate(0.2, 0.2, 10, 10)
    case = Case.from_dict({
        "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
        "optics": {"black": {"emissivity": 0.9, "absorptivity": 0.3}},
        "parts": [{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1.0e-3, "front": "black",
                   "back": "none", "super_nodes": 16}],
        "boundary": [{"kind": "temperature", "groups": ["xmin"], "value": 20.0, "name": "root"},
                     {"kind": "power", "groups": ["plate"], "value": 5.0}],
        "environment": {"sink_temperature": -100.0},
        "radiation": {"rays_per_face": 50},
        "reference": {"detailed": False}}, source="plate")
    out = tmp_path_factory.mktemp("plate") / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run(case, out=out, mesh=mesh, cache=False)
    return out, result


def test_a_run_exports_its_super_nodes_positions(plate_run):
    from fem2tmm.lpm.readers import read_network

    out, result = plate_run
    z = np.load(out / "reduced.npz")
    rm, model = result.reduced.network, result.model
    X = z["positions"]
    assert X.shape == (rm.n, 3)
    # independent of the weights A: on equal squares of one material and thickness a cluster's capacitance-weighted
    # centroid is the mean of its elements' centroids (each quad4 gives a quarter of its capacitance to each node)
    centroids = model.mesh.points[model.element_cells[:, :4]].mean(axis=1)
    for k in range(int(rm.element_cluster.max()) + 1):
        expect = centroids[rm.element_cluster == k].mean(axis=0)
        assert np.abs(X[k] - expect).max() < 1e-12, (k, X[k], expect)  # round-off of sums of 0.02 m coordinates
    # the boundary node: the centroid of its nodes, the edge x = 0 (y from 0 to 0.2 m)
    b = int(np.flatnonzero(rm.fixed)[0])
    assert np.abs(X[b] - [0.0, 0.1, 0.0]).max() < 1e-12
    # nodes.csv: the same positions under the decks' node numbers
    rows = np.loadtxt(out / "nodes.csv", delimiter=",", skiprows=1)
    deck = read_network(out / "model.esatan")
    number = {int(n): i for i, n in enumerate(deck.numbers)}
    assert (out / "nodes.csv").read_text().splitlines()[0] == "node,x,y,z" and len(rows) == rm.n
    assert all(deck.labels[number[int(r[0])]] == rm.names[i] for i, r in enumerate(rows))
    assert np.array_equal(rows[:, 1:], X)


def test_network_reduce_reduces_a_runs_own_output(plate_run, tmp_path):
    import json

    from fem2tmm.cli import main

    out, result = plate_run
    n = result.reduced.network.n + 1  # + the space node
    for i, args in enumerate((["reduced.npz"], ["model.esatan", "--coordinates", str(out / "nodes.csv")])):
        dest = tmp_path / f"net{i}"
        assert main(["network", "reduce", str(out / args[0]), *args[1:], "--out", str(dest), "--quiet"]) == 0
        s = json.loads((dest / "summary.json").read_text())
        assert s["nodes"]["detailed"] == n and s["nodes"]["reduced"] < n, s["nodes"]
        assert s["criteria"]["met"] is True


def test_network_refuses_a_reduction_without_positions(plate_run, tmp_path, capsys):
    from fem2tmm.cli import main

    out, _ = plate_run
    # the deck alone: exit 2, pointing at the positions written beside it; nothing written
    assert main(["network", "reduce", str(out / "model.esatan"), "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert "no node has a position" in err and f"--coordinates {out / 'nodes.csv'}" in err
    assert "Traceback" not in err and not (tmp_path / "a").exists()
    # a reduced.npz without positions (as written before they were exported)
    z = dict(np.load(out / "reduced.npz"))
    z.pop("positions")
    np.savez(tmp_path / "old.npz", **z)
    assert main(["network", "reduce", str(tmp_path / "old.npz"), "--out", str(tmp_path / "b")]) == 2
    assert "no node has a position" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------ item 6: small items


def test_space_separated_bdf_is_one_clear_error(tmp_path, capsys):
    from fem2tmm.cli import main

    # free field is comma-separated (MSC Nastran QRG, "Bulk Data Entry format"): blanks between the fields are
    # refused at the first such card with one message, instead of a list of unknown 'cards' 'GRID 1' ...
    path = _plate_bdf(tmp_path / "plate.bdf", sep=" ")
    assert main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and len(err) < 400, err
    assert f"{path}:2:" in err and "separated by blanks" in err and "'GRID,1,0.0,0.0,0.0'" in err
    # the same plate with commas reads: 16 quads
    from fem2tmm.io import read_mesh

    assert read_mesh(_plate_bdf(tmp_path / "ok.bdf"), unit="mm").n_elements == 16


def test_a_value_with_its_unit_says_what_was_expected(tmp_path, capsys):
    from fem2tmm.cli import main

    case = _plate_case(tmp_path, boundary='value = "5 W"')
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{case}: [[boundary]][0].value: cannot read '5 W': not a number" in err, err
    assert "expected a number in W, a time table [[t, v], ...] or a CSV file name" in err
    assert "write value = 5 (no quotes, no unit)" in err


def test_quiet_hides_the_progress_not_the_result(tmp_path):
    p = _cli("run", str(_plate_case(tmp_path)), "--out", str(tmp_path / "out"), "--quiet")
    assert p.returncode == 0, p.stderr
    assert "[fem2tmm]" not in p.stderr  # no progress
    assert "reduced model" in p.stdout and "T min/mean/max 'plate'" in p.stdout  # the result table
    assert p.stdout.rstrip().endswith(f"outputs in {tmp_path / 'out'}")
    # the negative-GL note: short, inside the reduced model's row (the full note is in report.html)
    row = next(ln for ln in p.stdout.splitlines() if "reduced model" in ln)
    assert len(row) < 140 and "negative GL are" not in p.stdout, row
    assert "negative GL are positive off-diagonal terms" in (tmp_path / "out" / "report.html").read_text()


def test_periodic_transient_progress_is_labelled_and_has_no_carriage_return_in_a_log():
    import io

    from conftest import make_case
    from fem2tmm.fem.model import build_model
    from fem2tmm.mesh import shapes
    from fem2tmm.progress import Progress, reporting
    from fem2tmm.solve.transient import TransientSettings, solve_transient
    from fem2tmm.timefunc import Series, Table
    from test_transient import problem_of

    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 5e-3, "front": "black",
                       "back": "black"}], [{"kind": "flux", "groups": ["plate"], "value": 1.0}],
                     environment={"sink_temperature": -270.0})
    model = build_model(shapes.plate(0.2, 0.2, 2, 2), case)
    P = 6000.0
    t = np.linspace(0, P, 13)
    problem = problem_of(model, model.capacity, Series(0 * model.Q, (model.Q,),
                                                       (Table(t, 500 * (1 + np.sin(2 * np.pi * t / P))),)))
    log = io.StringIO()  # a log file: not a terminal
    prog = Progress(stream=log)
    with reporting(prog.callback()), prog.stage("transient", "integrating"):
        sol = solve_transient(problem, TransientSettings(end=P, step=300.0, output_every=600.0, periodic=True), 293.15)
    text = log.getvalue()
    periods = sol.stats["periods"]
    assert periods >= 2 and "\r" not in text
    for k in range(1, periods + 1):  # one line per period, each labelled: 10 output intervals of 600 s
        assert text.count(f"[fem2tmm]   transient intervals, period {k}: 10/10\n") == 1, text


def test_a_number_given_with_its_unit_names_the_file_key_and_what_was_expected(tmp_path, capsys):
    from fem2tmm.cli import main

    case = _plate_case(tmp_path)
    case.write_text(case.read_text().replace("thickness = 0.001", 'thickness = "2 mm"'))
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{case}: [[parts]][0] ('plate').thickness: expected a number, got '2 mm'" in err
    assert "write the number alone, no quotes, in SI units (m," in err


def test_inspect_of_a_case_advises_its_unit_key_and_a_closed_pipe_is_no_traceback(tmp_path, capsys):
    import os
    import subprocess
    import sys

    from fem2tmm.cli import main

    case = _plate_case(tmp_path, unit="m")
    assert main(["inspect", str(case)]) == 0
    size = capsys.readouterr().out.splitlines()[1]
    assert 'with [mesh] unit = "m"' in size and 'then give [mesh] unit = "mm"' in size, size
    # `fem2tmm inspect case.toml | head -0`: the reader is gone before the report is printed
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT)]))
    p = subprocess.Popen([sys.executable, "-m", "fem2tmm.cli", "inspect", str(case)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, env=env)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 0 and err == "", err
