"""Issue 33: a satellite structure as a structural team hands it over reduces end to end.

Panels with stiffeners on their edges (bars on panel nodes only), struts with a four-bar junction, fittings that
touch the panels by nodes only (single hexes among them), an electronics unit on RBE2 and a battery on CBUSH
(``meshes/make_satellite.py``).  One part per kind, the usual split, and one part holding every kind.  What is
checked is what nobody here chose: energy conservation of both models, the super-node counts asked for, and that
a stiffener is reduced with the panel it stiffens.
"""

from __future__ import annotations

import importlib.util
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from fem2tmm.case import Case
from fem2tmm.cluster.contact import join_dependent
from fem2tmm.pipeline import run

ROOT = Path(__file__).resolve().parents[1]
PANELS = ["PID 1", "PID 2", "PID 3", "PID 4"]
BARS = ["PID 11", "PID 12", "PID 13", "PID 14"]
FITTINGS = ["PID 21", "PID 22", "PID 23"]


def satellite_deck(tmp: Path, n: int = 12) -> Path:
    spec = importlib.util.spec_from_file_location("make_satellite", ROOT / "meshes" / "make_satellite.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    path = tmp / "satellite.bdf"
    path.write_text(mod.deck(n))
    return path


def satellite_case(deck: Path, parts: list[dict]) -> Case:
    data = {
        "mesh": {"file": deck.name},
        "optics": {"white": {"emissivity": 0.85, "absorptivity": 0.25}, "black": {"emissivity": 0.88}},
        "parts": [*parts, {"name": "interface", "groups": ["PID 5"]}],
        "joints": [{"cards": ["RBE2"], "treatment": "isothermal"},
                   {"cards": ["CBUSH"], "treatment": "conductance", "conductance": 0.5}],
        "boundary": [{"name": "adapter", "kind": "temperature", "groups": ["PID 5"], "value": 20.0},
                     {"name": "heater", "kind": "power", "groups": ["PID 22"], "value": 30.0}],
        "environment": {"sink_temperature": -270.0},
    }
    return Case.from_dict(data, base_dir=deck.parent, source=str(deck.parent / "case.toml"))


def quiet_run(case):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the deck's PBUSH is ignored by name (a structural stiffness)
        return run(case)


def per_kind(n_panels: int, n_bars: int, n_fittings: int) -> list[dict]:
    return [{"name": "panels", "groups": PANELS, "front": "white", "back": "black", "super_nodes": n_panels},
            {"name": "bars", "groups": BARS, "super_nodes": n_bars},
            {"name": "fittings", "groups": FITTINGS, "front": "black", "super_nodes": n_fittings}]


def check_balances(res) -> None:
    # energy conservation (first law) of the detailed and the reduced model: loads in = heat into the held
    # interface + radiation out, to round-off of the solves (1e-9 of the gross flows)
    for key in ("detailed", "reduced"):
        bal = res.summary["energy_balance_W"][key]
        assert abs(bal["relative"]) < 1e-9, (key, bal)


@pytest.fixture(scope="module")
def deck(tmp_path_factory):
    return satellite_deck(tmp_path_factory.mktemp("satellite"))


@pytest.mark.parametrize("count", [1, 5, 50])
def test_one_part_per_kind_reduces_at_every_count(deck, count):
    res = quiet_run(satellite_case(deck, per_kind(count, count, count)))
    check_balances(res)
    acc = res.summary["accuracy"]
    assert np.isfinite(acc["rms_K"]) and acc["reference_noise_rms_K"] > 0
    report = res.reduced.clustering.report
    got = {p: int(np.count_nonzero(res.reduced.network.part[res.reduced.network.kind == "cluster"] == i))
           for i, p in enumerate(m.name for m in res.model.parts)}
    # the count asked for is the count given: panels and fittings always; the bars have 32 free elements (the
    # tripod, its post and the mast), so 50 gives them one super node per free bar
    assert got["panels"] == count and got["fittings"] == count
    assert got["bars"] == min(count, 32)
    # every stiffener (bars on panel nodes only) is reduced with the panel it stiffens
    mesh, model = res.mesh, res.model
    stiff = np.concatenate([mesh.groups[g].elements for g in ("PID 11", "PID 12")])
    lab = res.reduced.clustering.labels[stiff]
    panels = [i for i, p in enumerate(model.parts) if p.name == "panels"][0]
    assert (res.reduced.clustering.cluster_part[lab[lab >= 0]] == panels).all()
    assert report["joined"]["parts"]["bars"]["embedded"] == int(np.count_nonzero(lab >= 0))


def test_the_usual_split_at_the_issue_counts(deck):
    # issue 33's acceptance: 60 super nodes on the shells, 30 on the bars, 4 on the solids
    res = quiet_run(satellite_case(deck, per_kind(60, 30, 4)))
    check_balances(res)
    acc = res.summary["accuracy"]
    assert res.summary["reduced"]["super_nodes"] == 94
    # the recovered error is reported beside the reference's noise; bound: issue 33's 2 K (for 100 super nodes on
    # its study); this coarse deck with the thesis' reduction measured 0.94 K RMS, noise 0.010 K (2026-12-04)
    assert acc["rms_K"] < 2.0 and acc["reference_noise_rms_K"] < 0.1


@pytest.mark.parametrize("count", [1, 50])
def test_one_part_of_every_kind(deck, count):
    part = [{"name": "structure", "groups": PANELS + BARS + FITTINGS, "front": "white", "back": "black",
             "super_nodes": count}]
    res = quiet_run(satellite_case(deck, part))
    check_balances(res)
    assert res.summary["reduced"]["super_nodes"] == count
    assert res.model.parts[0].kind == "mixed"


def test_dependent_super_nodes_are_merged():
    # two bars over the same two nodes (two parts' rods on the same GRIDs) have identical mean-temperature rows;
    # the third bar has a node of its own
    dofs = np.full((3, 8), -1)
    dofs[:, :2] = [[0, 1], [0, 1], [1, 2]]
    shares = np.where(dofs >= 0, 1.0, 0.0)
    labels, kept, merges = join_dependent(np.array([0, 1, 2]), np.array([0, 1, 1]), dofs, shares,
                                          np.zeros(3, bool))
    assert merges == [(0, 1)] and kept.tolist() == [1, 2] and labels.tolist() == [0, 0, 1]
    # independent rows are left alone
    labels, kept, merges = join_dependent(np.array([0, 1]), np.array([0, 0]), dofs[[0, 2]], shares[[0, 2]],
                                          np.zeros(3, bool))
    assert merges == [] and labels.tolist() == [0, 1]


def test_a_shell_on_a_solid_face_covers_it(tmp_path):
    # a 1 m hex (its own part) with a quad (another part) on its bottom face, its normal pointing away (-z): the two
    # are in contact; the hex radiates through its five other faces, the quad through its front side only
    lines = ["BEGIN BULK"]
    gid = {}
    for k, z in enumerate((0.0, 1.0)):
        for j, y in enumerate((0.0, 1.0)):
            for i, x in enumerate((0.0, 1.0)):
                gid[i, j, k] = len(gid) + 1
                lines.append(f"GRID,{gid[i, j, k]},,{x},{y},{z}")
    lines += [f"CHEXA,1,1,{gid[0, 0, 0]},{gid[1, 0, 0]},{gid[1, 1, 0]},{gid[0, 1, 0]},{gid[0, 0, 1]},{gid[1, 0, 1]}",
              f",{gid[1, 1, 1]},{gid[0, 1, 1]}",
              f"CQUAD4,2,2,{gid[0, 0, 0]},{gid[0, 1, 0]},{gid[1, 1, 0]},{gid[1, 0, 0]}",
              "PSOLID,1,1", "PSHELL,2,1,0.001", "MAT4,1,100.0,900.0,2700.0", "ENDDATA"]
    deck = tmp_path / "cube.bdf"
    deck.write_text("\n".join(lines) + "\n")
    case = Case.from_dict({"mesh": {"file": deck.name}, "optics": {"black": {"emissivity": 1.0}},
                           "parts": [{"name": "block", "groups": ["PID 1"], "front": "black"},
                                     {"name": "skin", "groups": ["PID 2"], "front": "black", "back": "black"}],
                           "boundary": [{"kind": "power", "groups": ["PID 1"], "value": 10.0}]},
                          base_dir=tmp_path, source=str(tmp_path / "case.toml"))
    from fem2tmm.fem.model import build_model
    from fem2tmm.io import read_mesh

    model = build_model(read_mesh(deck), case)
    f = model.faces
    assert int((f.kind == 1).sum()) == 5 and int((f.kind == 0).sum()) == 1
    quad = int(np.flatnonzero(f.kind == 0)[0])
    assert f.active[2 * quad] and not f.active[2 * quad + 1]  # the back side faces into the hex
    # emitting area: 5 m² of hex faces (front only) + the quad's front = 6 m² at ε = 1
    assert float((f.eps_area).sum()) == pytest.approx(6.0, rel=1e-12)
    # the same quad the other way round (its front into the hex): the front is the covered side
    flipped = deck.read_text().replace(f"CQUAD4,2,2,{gid[0, 0, 0]},{gid[0, 1, 0]},{gid[1, 1, 0]},{gid[1, 0, 0]}",
                                       f"CQUAD4,2,2,{gid[0, 0, 0]},{gid[1, 0, 0]},{gid[1, 1, 0]},{gid[0, 1, 0]}")
    deck.write_text(flipped)
    f = build_model(read_mesh(deck), case).faces
    quad = int(np.flatnonzero(f.kind == 0)[0])
    assert not f.active[2 * quad] and f.active[2 * quad + 1]
    # a second hex on top of the first and the quad between them (at z = 1): solid on both sides, nothing radiates
    lines = [ln for ln in flipped.splitlines() if ln != "ENDDATA"]
    top = {}
    for j, y in enumerate((0.0, 1.0)):
        for i, x in enumerate((0.0, 1.0)):
            top[i, j] = 100 + len(top)
            lines.append(f"GRID,{top[i, j]},,{x},{y},2.0")
    lines += [f"CHEXA,3,1,{gid[0, 0, 1]},{gid[1, 0, 1]},{gid[1, 1, 1]},{gid[0, 1, 1]},{top[0, 0]},{top[1, 0]}",
              f",{top[1, 1]},{top[0, 1]}",
              f"CQUAD4,4,2,{gid[0, 0, 1]},{gid[1, 0, 1]},{gid[1, 1, 1]},{gid[0, 1, 1]}", "ENDDATA"]
    deck.write_text("\n".join(lines) + "\n")
    f = build_model(read_mesh(deck), case).faces
    shells = np.flatnonzero(f.kind == 0)
    assert len(shells) == 2 and int((f.kind == 1).sum()) == 9  # 2 x 6 hex faces - the shared one - the bottom
    middle = [q for q in shells if not f.active[2 * q] and not f.active[2 * q + 1]]
    assert len(middle) == 1



def test_inspect_a_case_says_what_each_parts_count_does(deck, capsys):
    # issue 33 item 4: per part, the fewest count without merging (regions), the fewest at all, and what the asked
    # count implies
    from fem2tmm.cli import main

    case = deck.parent / "inspect_case.toml"
    case.write_text(f'[mesh]\nfile = "{deck.name}"\n\n'
                    '[[parts]]\nname = "panels"\ngroups = ["PID 1", "PID 2", "PID 3", "PID 4"]\nsuper_nodes = 2\n\n'
                    '[[parts]]\nname = "bars"\ngroups = ["PID 11", "PID 12", "PID 13", "PID 14"]\nsuper_nodes = 30\n\n'
                    '[[parts]]\nname = "fittings"\ngroups = ["PID 21", "PID 22", "PID 23"]\nsuper_nodes = 4\n')
    assert main(["inspect", str(case)]) == 0
    text = capsys.readouterr().out
    rows = {line.split()[0]: line for line in text[text.index("parts of the case"):].splitlines()[2:5]}
    # the fittings: nine pieces (three feet, four mounts, the unit, the battery), five of which join what they touch
    assert "5 of its 9 pieces join the clusters they touch" in rows["fittings"], text
    # the panels: 11 regions (split at the box edges, the deck's T-junctions and the property changes) in 3 pieces
    # (the deck meets the walls at junction edges only): at 2, one piece joins and 8 regions merge
    assert re.search(r"panels\s+shell\s+\d+\s+11\s+1\s+2\s+1 of its 3 pieces joins the cluster it touches; "
                     r"8 region merge\(s\), smallest first", rows["panels"]), text
    # the bars: the stiffeners lie on panel nodes
    assert "bars on shell/solid nodes join those clusters" in rows["bars"], text
