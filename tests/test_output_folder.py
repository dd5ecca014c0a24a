"""Output folder policy (issue 15): fem2tmm never deletes or overwrites anything it did not write, and checks the
output place before any computation."""

from __future__ import annotations

import hashlib
import json
import textwrap
import time

import pytest
from test_errors import write_plate_msh

from conftest import plate_case_toml
from fem2tmm.cli import main
from fem2tmm.export.output import MARKER

CASE = plate_case_toml() + textwrap.dedent("""\
    super_nodes = 2
    [[boundary]]
    kind = "temperature"
    nodes = [1]
    value = 20.0
    [radiation]
    enabled = false
    [reference]
    detailed = false
    """)


@pytest.fixture
def case_dir(tmp_path):
    d = tmp_path / "study"
    d.mkdir()
    write_plate_msh(d / "plate.msh")
    (d / "case.toml").write_text(CASE)
    return d


def snapshot(folder):
    """{relative path: sha256 (files) or 'dir'} of everything below ``folder``, the folder's siblings included."""
    out = {}
    for p in sorted(folder.parent.rglob("*")):
        out[p.relative_to(folder.parent).as_posix()] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def run_cli(case_dir, out, capsys):
    t = time.perf_counter()
    code = main(["run", str(case_dir / "case.toml"), "--out", str(out), "--quiet"])
    dt = time.perf_counter() - t
    return code, capsys.readouterr().err, dt


def assert_refused(code, err, name):
    assert code == 2
    assert err.startswith("fem2tmm: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert str(name) in err and "--out" in err


def test_foreign_folder_is_left_byte_identical(case_dir, capsys):
    out = case_dir.parent / "results"
    out.mkdir()
    (out / "notes.txt").write_text("my own notes")
    before = snapshot(case_dir)
    code, err, _ = run_cli(case_dir, out, capsys)
    assert_refused(code, err, out)
    assert "notes.txt" in err
    assert snapshot(case_dir) == before  # every file byte-identical, nothing added (no temporary folder left)


def test_the_case_folder_itself_is_refused(case_dir, capsys):
    before = snapshot(case_dir)
    code, err, _ = run_cli(case_dir, case_dir, capsys)
    assert_refused(code, err, case_dir)
    assert "case.toml" in err and snapshot(case_dir) == before


def test_out_dot_leaves_no_stray_folder(case_dir, capsys, monkeypatch):
    monkeypatch.chdir(case_dir)
    before = snapshot(case_dir)
    code, err, _ = run_cli(case_dir, ".", capsys)
    assert_refused(code, err, case_dir)
    assert snapshot(case_dir) == before
    # also when the current folder is empty: it cannot be replaced, nothing is left beside it
    empty = case_dir.parent / "empty"
    empty.mkdir()
    monkeypatch.chdir(empty)
    before = snapshot(empty)
    code, err, _ = run_cli(case_dir, ".", capsys)
    assert code == 2 and snapshot(empty) == before


def test_a_previous_run_is_replaced_and_missing_folders_are_created(case_dir, capsys):
    out = case_dir.parent / "a" / "b" / "results"
    assert run_cli(case_dir, out, capsys)[0] == 0  # missing (with its parents): created
    marker = json.loads((out / MARKER).read_text())
    assert {"summary.json", "report.html", "temperatures.vtu", "model.esatan"} <= set(marker["files"])
    (out / "summary.json").write_text("stale")  # a file fem2tmm wrote (listed by the marker)
    assert run_cli(case_dir, out, capsys)[0] == 0  # replaced as a whole
    assert json.loads((out / "summary.json").read_text())["version"] == marker["version"]
    assert sorted(p.name for p in out.parent.iterdir()) == ["results"]  # no temporary folder left beside it
    # a file added by the user makes it foreign: refused, untouched
    (out / "mine.txt").write_text("keep me")
    before = snapshot(out)
    code, err, _ = run_cli(case_dir, out, capsys)
    assert_refused(code, err, out)
    assert "mine.txt" in err and snapshot(out) == before


def test_empty_and_legacy_folders(case_dir, capsys):
    empty = case_dir.parent / "empty"
    empty.mkdir()
    assert run_cli(case_dir, empty, capsys)[0] == 0 and (empty / MARKER).is_file()
    # a folder written before the marker existed: only fem2tmm's file names, and a summary.json with a version
    legacy = case_dir.parent / "legacy"
    legacy.mkdir()
    (legacy / "summary.json").write_text(json.dumps({"version": "0.1"}))
    (legacy / "report.html").write_text("<html></html>")
    (legacy / "temperature.png").write_bytes(b"png")
    assert run_cli(case_dir, legacy, capsys)[0] == 0 and (legacy / MARKER).is_file()
    assert not (legacy / "temperature.png").exists() or (legacy / "temperature.png").read_bytes() != b"png"


def test_existing_file_and_unwritable_places_fail_within_a_second(case_dir, capsys):
    afile = case_dir.parent / "afile"
    afile.write_text("x")
    before = snapshot(case_dir)
    # tests run as root: a path below a regular file, and a folder in /proc, fail for root too
    for out in (afile, afile / "sub", "/proc/fem2tmm-no-such-place/out"):
        code, err, dt = run_cli(case_dir, out, capsys)
        assert_refused(code, err, out)
        assert dt < 1.0, (out, dt)  # before any computation (the run itself takes seconds)
    assert snapshot(case_dir) == before and afile.read_text() == "x"
