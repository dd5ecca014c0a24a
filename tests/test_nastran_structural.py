"""Issue 16: real structural decks — bars, joints, quadratic and NASTRAN-95 elements, composites, MAT5,
units, INCLUDE search, replication, deck boundary conditions, refusal of unmodelled cards.

Every deck is written by the test; every number is checked against a closed form whose source is given
beside the assertion.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from fem2tmm.case import Case
from fem2tmm.errors import Fem2TmmError
from fem2tmm.io import read_mesh
from fem2tmm.io.nastran import read_nastran
from fem2tmm.pipeline import run

KELVIN = 273.15


def card(*fields) -> str:
    """One free-field card."""
    return ",".join(str(f) for f in fields)


def write(tmp_path: Path, lines, name="deck.bdf") -> Path:
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def plate_cards(x0: float, gid0: int, eid0: int, pid: int, n: int = 2, size: float = 1.0):
    """An n x n CQUAD4 plate in z = 0 over [x0, x0 + size] x [0, size]; GRIDs gid0 + i + (n + 1) j."""
    lines = []
    for j in range(n + 1):
        for i in range(n + 1):
            lines.append(card("GRID", gid0 + i + (n + 1) * j, "", x0 + size * i / n, size * j / n, 0.0))
    for j in range(n):
        for i in range(n):
            g = gid0 + i + (n + 1) * j
            lines.append(card("CQUAD4", eid0 + i + n * j, pid, g, g + 1, g + n + 2, g + n + 1))
    return lines


def two_plates(extra):
    """Plate A (PID 1, x in [0, 1]) and plate B (PID 2, x in [2, 3]), 2 x 2 quads each, mm-free SI deck."""
    return [*plate_cards(0.0, 1, 1, 1), *plate_cards(2.0, 101, 101, 2),
            card("PSHELL", 1, 10, 0.002), card("PSHELL", 2, 10, 0.002), card("MAT4", 10, 200.0, 900.0, 2700.0),
            *extra]


def quiet(fn, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **k)


def case_for(path: Path, parts, boundary, **top) -> Case:
    return Case.from_dict({"mesh": {"file": path.name, **top.pop("mesh", {})}, "parts": parts, "boundary": boundary,
                           **top}, base_dir=path.parent, source=str(path.parent / "case.toml"))


PLATES = [{"name": "A", "groups": ["PID 1"], "super_nodes": 2}, {"name": "B", "groups": ["PID 2"], "super_nodes": 2}]
HEAT_FIX = [{"kind": "power", "groups": ["PID 1"], "value": 5.0}, {"kind": "temperature", "groups": ["PID 2"], "value": 20.0}]


def test_plates_joined_by_a_cbar(tmp_path):
    # GRID 6 = (1, 0.5, 0) on plate A's edge, GRID 104 = (2, 0.5, 0) on plate B's edge: a bar of L = 1 m,
    # PBAR A = 3e-4 m², MAT4 K = 150 W/(m K): all 5 W go through it (the plates touch nothing else)
    deck = write(tmp_path, two_plates([card("CBAR", 900, 3, 6, 104, 0.0, 0.0, 1.0), card("PBAR", 3, 30, 3e-4),
                                       card("MAT4", 30, 150.0, 900.0, 2700.0)]))
    mesh = quiet(read_mesh, deck)
    assert mesh.section_area[mesh.groups["PID 3"].elements].tolist() == [3e-4]
    case = case_for(deck, [*PLATES, {"name": "bar", "groups": ["PID 3"], "super_nodes": 1}], HEAT_FIX)
    res = quiet(run, case, mesh=mesh)
    i6, i104 = mesh.node_index([6, 104], where="test")
    for T in (res.T_detailed_nodes, res.T_recovered_nodes):  # detailed, and recovered from the reduced model
        drop = T[i6] - T[i104]
        # closed form: q = k A ΔT / L with q = 5 W, so ΔT = q L / (k A) = 5 / (150 · 3e-4) = 111.11 K
        assert drop == pytest.approx(5.0 * 1.0 / (150.0 * 3e-4), rel=1e-9)
        assert 150.0 * 3e-4 * drop / 1.0 == pytest.approx(5.0, rel=1e-9)  # heat through the bar
    # capacity of the bar: ρ c A L (two nodal halves), J/K
    bar = np.flatnonzero(res.model.element_types == 5)
    assert res.model.capacity_shares[bar, :2].sum() == pytest.approx(2700.0 * 900.0 * 3e-4 * 1.0, rel=1e-12)


@pytest.mark.parametrize("treatment", ["conductance", "isothermal"])
def test_plates_joined_by_an_rbe2(tmp_path, treatment):
    # RBE2 from GRID 6 (plate A) to GRIDs 104 and 101 (plate B): two connections
    deck = write(tmp_path, two_plates([card("RBE2", 900, 6, 123456, 104, 101)]))
    joint = {"cards": ["RBE2"], "treatment": treatment}
    if treatment == "conductance":
        joint["conductance"] = 0.5
    case = case_for(deck, PLATES, HEAT_FIX, joints=[joint])
    res = quiet(run, case)
    mesh = res.mesh
    i6, i101, i104 = mesh.node_index([6, 101, 104], where="test")
    for T in (res.T_detailed_nodes, res.T_recovered_nodes):
        if treatment == "conductance":
            # closed form: P flows through two conductances G = 0.5 W/K in parallel to the fixed plate:
            # T6 - T_B = P / (2 G) = 5 K
            assert T[i6] - T[i104] == pytest.approx(5.0 / (2 * 0.5), rel=1e-9)
            assert T[i6] - T[i101] == pytest.approx(5.0 / (2 * 0.5), rel=1e-9)
        else:  # merged nodes: equal temperatures (to round-off of the solve)
            assert T[i6] == pytest.approx(T[i104], abs=1e-9) and T[i6] == pytest.approx(T[i101], abs=1e-9)
    if treatment == "conductance":  # the joint stays its own link between one-node super nodes
        assert res.summary["reduced"]["kept_nodes"] >= 1


def test_unmodelled_structural_card_exit_2(tmp_path, capsys):
    from fem2tmm.cli import main

    deck = write(tmp_path, two_plates([card("RBAR", 900, 6, 104, 123456), card("PARAM", "POST", -1)]))
    (tmp_path / "case.toml").write_text(f'[mesh]\nfile = "{deck.name}"\n[[parts]]\nname = "A"\ngroups = ["PID 1"]\n'
                                        '[[boundary]]\nkind = "temperature"\ngroups = ["PID 1"]\nvalue = 0.0\n')
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert "RBAR (1)" in err and '[mesh] ignore_cards = ["RBAR"]' in err and "Traceback" not in err
    assert "PARAM" not in err  # non-structural cards are not mixed in


def test_joint_without_treatment_names_the_key(tmp_path):
    deck = write(tmp_path, two_plates([card("CBUSH", 900, 7, 6, 104)]))
    with pytest.raises(Fem2TmmError, match=r'CBUSH \(1\).*\[\[joints\]\] cards = \["CBUSH"\] treatment'):
        quiet(run, case_for(deck, PLATES, HEAT_FIX))
