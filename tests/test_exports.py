"""Exports: the ESATAN deck round-trips and solves to the same temperatures; SINDA, Nastran TEMP and VTU
parse with independent simple parsers; the HTML report references only images that exist."""

from __future__ import annotations

import re

import meshio
import numpy as np
import pytest

from conftest import make_case
from fem2tmm.mesh import shapes
from fem2tmm.lpm import read_esatan, solve_network
from fem2tmm.pipeline import run


@pytest.fixture(scope="module")
def fin_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fin") / "out"
    mesh = shapes.annulus(0.05, 0.15, 10, 60)
    case = make_case(
        [{"name": "fin", "groups": ["annulus"], "material": "al", "thickness": 1e-3, "front": "black",
          "back": "black", "super_nodes": 12}],
        [{"kind": "temperature", "groups": ["inner"], "value": 20.0},
         {"kind": "flux", "groups": ["annulus"], "value": 30.0}],
        environment={"sink_temperature": -100.0},
        radiation={"rays_per_face": 200},
        reference={"detailed": True, "rays_per_face": 20},
    )
    return run(case, out=out, mesh=mesh)


def test_esatan_deck_round_trip_solves_to_the_same_temperatures(fin_run):
    # issue 8: written, read back (fem2tmm.lpm's ESATAN reader), and solved to the same temperatures (1e-9 K)
    net = read_esatan(fin_run.out / "model.esatan")
    rm, rs = fin_run.reduced.network, fin_run.reduced.solution
    n = rm.n  # the deck's last node is SPACE
    K = net.K().toarray()[:n, :n]
    K[np.diag_indices(n)] -= np.asarray(net.GL[:n, n:].sum(axis=1)).ravel()  # links to space are GR only
    assert np.abs(K - rm.K).max() <= 1e-12 * np.abs(rm.K).max()
    sol = solve_network(net)
    assert np.abs(sol.T[:n] - rs.T).max() < 1e-9
    assert list(net.labels[:n]) == list(rm.names)
    text = (fin_run.out / "model.esatan").read_text()
    n_neg = fin_run.summary["reduced"]["negative_links"]
    assert f"{n_neg} are negative" in text and text.count("# negative") == n_neg


def test_sinda_blocks_parse(fin_run):
    # independent parser: node lines "id, T, C", conductor lines "id, a, b, G"; negative ids = boundary nodes /
    # radiation conductors
    text = (fin_run.out / "model.sinda").read_text()
    blocks = re.split(r"^HEADER ", text, flags=re.M)
    nodes = [b for b in blocks if b.startswith("NODE DATA")][0].splitlines()[1:]
    conds = [b for b in blocks if b.startswith("CONDUCTOR DATA")][0].splitlines()[1:]
    # a named fixed temperature is a register (issue 41: SINDA gets the ESATAN deck's named constants)
    regs = [b for b in blocks if b.startswith("REGISTER DATA")]
    reg = {ln.split("=")[0].strip(): float(ln.split("=")[1].split("$")[0]) for b in regs for ln in b.splitlines()[1:]
           if "=" in ln}
    node = {int(ln.split(",")[0]): reg[ln.split(",")[1].strip()] if ln.split(",")[1].strip() in reg
            else float(ln.split(",")[1])
            for ln in nodes if ln.strip() and "$" in ln}
    rm, rs = fin_run.reduced.network, fin_run.reduced.solution
    assert len(node) == rm.n + 1  # + space
    assert sum(1 for k in node if k < 0) == int(rm.fixed.sum()) + 1  # boundary nodes and space are negative
    temps = sorted(v for k, v in node.items() if k > 0)
    assert np.allclose(temps, sorted(rs.T[~rm.fixed] - 273.15), atol=1e-9)
    lin = [ln for ln in conds if ln.strip() and not ln.strip().startswith("-") and "," in ln and not ln.startswith("END")]
    rad = [ln for ln in conds if ln.strip().startswith("-")]
    G = np.array([float(ln.split(",")[3]) for ln in lin])
    iu = np.triu_indices(rm.n, 1)
    assert np.isclose(G.sum(), -rm.K[iu].sum(), rtol=1e-12)
    GRsum = sum(float(ln.split(",")[3]) for ln in rad)
    assert np.isclose(GRsum, rm.GR[iu].sum() + rm.g_space.sum(), rtol=1e-12)


def parse_temp(path):
    """Independent large-field parser: "TEMP*" + 4 fields of 16, continuation "*" + up to 3 fields of 16.
    Returns ({grid id: T}, TEMPD default)."""
    lines = path.read_text().splitlines()
    temps, default = {}, None
    for i, ln in enumerate(lines):
        if ln.startswith("TEMPD*"):
            default = float(ln[24:40])
        if ln.startswith("TEMP*"):
            f = [ln[8 + 16 * k: 24 + 16 * k].strip() for k in range(4)]
            nxt = lines[i + 1] if i + 1 < len(lines) and lines[i + 1].startswith("*") else ""
            f += [nxt[8 + 16 * k: 24 + 16 * k].strip() for k in range(3)]
            vals = [x for x in f[1:] if x]
            for g, t in zip(vals[0::2], vals[1::2]):
                temps[int(g)] = float(t)
    return temps, default


def test_nastran_temp_cards_parse(fin_run):
    temps, default = parse_temp(fin_run.out / "temperatures.bdf")
    mesh = fin_run.mesh
    T = fin_run.T_nodes - 273.15
    assert len(temps) == mesh.n_nodes and default is not None
    got = np.array([temps[int(g)] for g in mesh.node_ids])
    assert np.abs(got - T).max() < 1e-8 * np.abs(T).max()  # 10 significant digits in a 16-character field


def test_vtu_fields(fin_run):
    m = meshio.read(fin_run.out / "temperatures.vtu")
    T = m.point_data["temperature"]
    assert np.allclose(T, fin_run.T_nodes - 273.15)
    assert np.allclose(m.point_data["error"], m.point_data["temperature"] - m.point_data["reference_temperature"])
    labels = np.concatenate(m.cell_data["cluster"])
    assert len(np.unique(labels)) == 12


def test_report_references_existing_images(fin_run):
    html = (fin_run.out / "report.html").read_text()
    imgs = re.findall(r'<img src="([^"]+)"', html)
    assert {"clusters.png", "temperature.png", "error.png", "lse.png"} <= set(imgs)
    for name in imgs:
        data = (fin_run.out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    assert "Heat flows" in html and "into fixed boundary" in html and "Temperatures per part" in html
    # the error is shown with the reference's own noise beside it (issue 21), the value of summary.json
    noise = fin_run.summary["accuracy"]["reference_noise_rms_K"]
    assert noise is not None and f"the reference&#x27;s own noise: RMS {noise:.2g} K" in html


def test_reduced_npz_contents(fin_run):
    d = np.load(fin_run.out / "reduced.npz")
    n = fin_run.reduced.network.n
    assert d["K"].shape == (n, n) and d["GR"].shape == (n + 1, n + 1) and d["C"].shape == (n,)
    assert np.allclose(d["GR"], d["GR"].T)
    # total capacitance of the reduced model = total capacitance of the detailed one (exact)
    assert d["C"].sum() == pytest.approx(fin_run.model.capacity.sum(), rel=1e-12)
    assert d["T"].shape == (n,) and set(d["names"]) == set(fin_run.reduced.network.names)


def test_nastran_deck_end_to_end(tmp_path):
    # a Nastran deck (PSHELL thickness and MAT4 from the deck, mm-t-s units) through the whole pipeline; the
    # boundary is given by original GRID ids and the TEMP cards come back with the same ids
    from pathlib import Path

    from fem2tmm.case import Case
    from fem2tmm.io import read_mesh

    deck = Path(__file__).parent / "data" / "plate_same.bdf"
    (tmp_path / "case.toml").write_text(f"""
[mesh]
file = "{deck}"
unit = "mm"
[optics.white]
emissivity = 0.85
absorptivity = 0.2
[[parts]]
name = "plate"
groups = ["PID 7"]
front = "white"
back = "white"
super_nodes = 3
[[boundary]]
kind = "temperature"
nodes = [1, 2]
value = 25.0
[[boundary]]
kind = "power"
groups = ["PID 7"]
value = 2.0
[environment]
sink_temperature = -50.0
""")
    res = run(Case.from_toml(tmp_path / "case.toml"), out=tmp_path / "out")
    s = res.summary
    assert s["reduced"]["super_nodes"] == 3 and s["reduced"]["boundary_nodes"] == 1
    assert s["energy_balance_W"]["reduced"]["relative"] < 1e-9
    mesh = read_mesh(deck, unit="mm")
    temps, _ = parse_temp(tmp_path / "out" / "temperatures.bdf")
    assert set(temps) == set(int(g) for g in mesh.node_ids)  # every GRID, by its original id
    # GRIDs 1 and 2 are held at 25 °C: their recovered temperatures are exactly 25 °C
    T = res.T_nodes - 273.15
    assert np.allclose(T[np.isin(mesh.node_ids, [1, 2])], 25.0, atol=1e-9)
