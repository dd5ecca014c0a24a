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
    assert quiet(read_mesh, write(tmp_path, two_plates([card("RBE2", 900, 6, 123456, 101, "THRU", 104, 0.1)]),
                                  name="thru.bdf")).joints[0].pairs.shape == (4, 2)  # 101 THRU 104, ALPHA 0.1
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


# ------------------------------------------------------------------------------------------- quadratic elements
def quadratic_deck(tmp_path):
    """[0, 2] x [0, 1]: one CQUAD8 on [0, 1] x [0, 1], two CTRIA6 on [1, 2] x [0, 1]; mid-side GRIDs at the
    edge midpoints (straight edges)."""
    pts = {}
    for i in range(5):
        for j in range(3):
            pts[1 + i + 5 * j] = (0.5 * i, 0.5 * j)
    del pts[7]  # (0.5, 0.5): the CQUAD8 has no centre node
    g = lambda x, y: 1 + int(round(2 * x)) + 5 * int(round(2 * y))  # noqa: E731
    lines = [card("GRID", k, "", x, y, 0.0) for k, (x, y) in pts.items()]
    # CQUAD8: corners G1-G4, mid-sides G5 (1-2), G6 (2-3), G7 (3-4), G8 (4-1)
    lines.append(card("CQUAD8", 1, 1, g(0, 0), g(1, 0), g(1, 1), g(0, 1), g(.5, 0), g(1, .5), "+"))
    lines.append(card("+", g(.5, 1), g(0, .5)))
    # CTRIA6: corners G1-G3, mid-sides G4 (1-2), G5 (2-3), G6 (3-1)
    lines.append(card("CTRIA6", 2, 1, g(1, 0), g(2, 0), g(2, 1), g(1.5, 0), g(2, .5), g(1.5, .5)))
    lines.append(card("CTRIA6", 3, 1, g(1, 0), g(2, 1), g(1, 1), g(1.5, .5), g(1.5, 1), g(1, .5)))
    lines += [card("PSHELL", 1, 10, 0.002), card("MAT4", 10, 200.0, 900.0, 2700.0)]
    return write(tmp_path, lines), pts


def test_cquad8_ctria6_area_capacity_and_linear_patch(tmp_path):
    deck, pts = quadratic_deck(tmp_path)
    with pytest.warns(UserWarning, match=r"quadratic elements \(CTRIA6 2, CQUAD8 1\) are modelled by their corner"):
        mesh = read_mesh(deck)
    left = [k for k, (x, _) in pts.items() if x == 0.0]
    right = [k for k, (x, _) in pts.items() if x == 2.0]
    case = case_for(deck, [{"name": "p", "groups": ["PID 1"], "super_nodes": 2}],
                    [{"kind": "temperature", "nodes": left, "value": 0.0},
                     {"kind": "temperature", "nodes": right, "value": 100.0, "name": "hot"}])
    res = quiet(run, case, mesh=mesh)
    # area exact: 2 m² (straight-edged quadratic elements have the area of their corner polygon)
    assert np.nansum(mesh.element_areas()) == pytest.approx(2.0, rel=1e-14)
    # heat capacity exact: ρ c t A = 2700 · 900 · 0.002 · 2 J/K
    assert res.model.capacity.sum() == pytest.approx(2700.0 * 900.0 * 0.002 * 2.0, rel=1e-12)
    # linear patch T = 50 x °C, exact at every GRID (corner and mid-side): linear fields are in the FE space
    x = np.array([pts[int(k)][0] for k in mesh.node_ids])
    for T in (res.T_detailed_nodes, res.T_recovered_nodes):
        np.testing.assert_allclose(T - KELVIN, 50.0 * x, rtol=0, atol=1e-9)
    # heat through the plate: k t W ΔT / L = 200 · 0.002 · 1 · 100 / 2 = 20 W
    # heat_into_fixed_W is positive into the boundary (docs/case-file.md): the cold edge takes +20 W
    assert res.summary["detailed"]["heat_into_fixed_W"][case.boundaries[0].name] == pytest.approx(20.0, rel=1e-9)


# ------------------------------------------------------------------------------------------- composites, MAT5
def test_pcomp_thickness_and_ply_average(tmp_path):
    # plies 0.2 / 0.3 / 0.5 mm (mm-t-s deck); the last ply's MID blank = the ply before's (PCOMP rule)
    lines = [*plate_cards(0.0, 1, 1, 1), card("PCOMP", 1, "", "", "", "", "", "", "", "+"),
             card("+", 10, 0.2, 0.0, "", 11, 0.3, 45.0, "", "+"), card("+", "", 0.5, 90.0),
             card("MAT4", 10, 100.0, 9e8, 2.7e-9), card("MAT4", 11, 10.0, 1e9, 1.6e-9)]
    mesh = quiet(read_nastran, write(tmp_path, lines), unit="mm")
    p = mesh.properties["PID 1"]
    assert p.thickness == pytest.approx(1.0e-3, rel=1e-14) and p.card == "PCOMP"
    # in-plane conduction of plies in parallel: (100·0.2 + 10·0.8) / 1.0 W/(m K)
    assert p.conductivity == pytest.approx((100 * 0.2 + 10 * 0.8) / 1.0, rel=1e-14)
    # density by thickness (kg/m³), specific heat by mass
    assert p.density == pytest.approx((2700 * 0.2 + 1600 * 0.8) / 1.0, rel=1e-12)
    assert p.specific_heat == pytest.approx((2700 * 0.2 * 900 + 1600 * 0.8 * 1000) / (2700 * 0.2 + 1600 * 0.8), rel=1e-12)


@pytest.mark.parametrize("axis", ["x", "y"])
def test_mat5_orthotropic_plate(tmp_path, axis):
    # a 1 m x 1 m plate (4 x 4 quads, t = 2 mm), MAT5 KXX = 100, KYY = 10 W/(m K): heat flow between two
    # opposite edges held 100 K apart is k t W ΔT / L (the linear field is exact in the FE space)
    lines = [*plate_cards(0.0, 1, 1, 1, n=4), card("PSHELL", 1, 10, 0.002), card("MAT5", 10, 100.0, "", "", 10.0)]
    deck = write(tmp_path, lines)
    mesh = quiet(read_mesh, deck)
    assert mesh.properties["PID 1"].conductivity_tensor == (100.0, 0.0, 0.0, 10.0, 0.0, 0.0)
    c = 0 if axis == "x" else 1
    lo = mesh.node_ids[mesh.points[:, c] == 0.0].tolist()
    hi = mesh.node_ids[mesh.points[:, c] == 1.0].tolist()
    case = case_for(deck, [{"name": "p", "groups": ["PID 1"], "super_nodes": 3}],
                    [{"kind": "temperature", "nodes": lo, "value": 0.0, "name": "lo"},
                     {"kind": "temperature", "nodes": hi, "value": 100.0, "name": "hi"}])
    res = quiet(run, case)
    k = 100.0 if axis == "x" else 10.0
    # heat_into_fixed_W is positive into the boundary (docs/case-file.md): the cold edge takes k t W ΔT / L
    assert res.summary["detailed"]["heat_into_fixed_W"]["lo"] == pytest.approx(k * 0.002 * 1.0 * 100.0, rel=1e-9)


# ------------------------------------------------------------------------------------------- syntax, includes
def test_nested_include_relative_to_the_top_deck(tmp_path):
    # deck.bdf includes sub/a.inc; a.inc includes 'sub/b.inc', which exists only relative to the top deck
    (tmp_path / "sub").mkdir()
    write(tmp_path, ["INCLUDE 'sub/b.inc'", *plate_cards(0.0, 1, 1, 1)[9:]], name="sub/a.inc")
    write(tmp_path, plate_cards(0.0, 1, 1, 1)[:9], name="sub/b.inc")
    mesh = quiet(read_nastran, write(tmp_path, ["BEGIN BULK", "INCLUDE 'sub/a.inc'", card("PSHELL", 1, 1, 0.1)]))
    assert mesh.n_nodes == 9 and mesh.n_elements == 4
    with pytest.raises(Fem2TmmError, match=r"INCLUDE file 'nope\.inc' not found; tried \S*sub/nope\.inc, \S*/nope\.inc"):
        quiet(read_nastran, write(tmp_path, ["INCLUDE 'nope.inc'"], name="sub/c.inc").parent.parent
              / write(tmp_path, ["INCLUDE 'sub/c.inc'"], name="top2.bdf"))


def test_free_field_replication_of_grids(tmp_path):
    # GRID 1 at x = 0; '=,*1,=,*0.5,==' makes GRID 2 at x = 0.5 (y, z copied); '=3' three more: 3, 4, 5
    lines = ["GRID,1,,0.,0.,0.", "=,*1,=,*0.5,==", "=3",
             "GRID,11,,0.,1.,0.", "=,*1,=,*(0.5),==", "=(3)",
             "CQUAD4,1,1,1,2,12,11", "=,*1,=,*1,*1,*1,*1", "=2", "PSHELL,1,1,.1"]
    mesh = quiet(read_nastran, write(tmp_path, lines))
    assert mesh.node_ids.tolist() == [1, 2, 3, 4, 5, 11, 12, 13, 14, 15]
    np.testing.assert_allclose(mesh.points[:5, 0], [0.0, 0.5, 1.0, 1.5, 2.0], rtol=0, atol=1e-15)
    assert mesh.element_ids.tolist() == [1, 2, 3, 4]
    assert np.nansum(mesh.element_areas()) == pytest.approx(2.0, rel=1e-14)


def test_legacy_reals_and_lenient_unused_cards(tmp_path):
    # '.2523 -3' (embedded blank, implicit exponent) is 2.523e-4; a malformed MAT1 nobody uses is a warning
    lines = [*plate_cards(0.0, 1, 1, 1), "PSHELL".ljust(8) + "1".ljust(8) + "10".ljust(8) + ".2523 -3", card("MAT4", 10, 1.0),
             card("MAT1", 99, "", "", "", "x.y")]
    with pytest.warns(UserWarning, match=r"malformed fields in 1 MAT1 card\(s\) the model does not use.*deck\.bdf:\d+"):
        mesh = read_nastran(write(tmp_path, lines))
    assert mesh.properties["PID 1"].thickness == pytest.approx(2.523e-4, rel=1e-15)
    lines[-2] = card("MAT4", 10, "1.x")  # the same fault in a used card is an error naming file:line
    with pytest.raises(Fem2TmmError, match=r"deck\.bdf:\d+: MAT4 field 3 \(K\) '1\.x' is malformed"):
        quiet(read_nastran, write(tmp_path, lines))


def test_mesh_format_by_content(tmp_path):
    lines = [*plate_cards(0.0, 1, 1, 1), card("PSHELL", 1, 1, 0.1)]
    for suffix in (".inp", ".nas", ".dat", ".blk", ".txt"):
        assert quiet(read_mesh, write(tmp_path, lines, name="m" + suffix)).n_elements == 4
    with pytest.raises(Fem2TmmError, match="Abaqus input file"):
        read_mesh(write(tmp_path, ["*HEADING", "*NODE", "1, 0., 0., 0."], name="a.inp"))


def test_line_sections(tmp_path):
    # PBARL TUBE (r_out 10, r_in 8 mm), PBEAML I, PROD, PTUBE, CONROD in mm: areas (m²) from the MSC QRG forms
    lines = [card("GRID", i, "", float(i), 0.0, 0.0) for i in range(1, 7)]
    lines += [card("CBAR", 1, 1, 1, 2, 0.0, 1.0, 0.0), card("PBARL", 1, 10, "", "TUBE", "", "", "", "", "+"),
              card("+", 10.0, 8.0),
              card("CBEAM", 2, 2, 2, 3, 0.0, 1.0, 0.0), card("PBEAML", 2, 10, "", "I", "", "", "", "", "+"),
              card("+", 100.0, 50.0, 40.0, 5.0, 8.0, 6.0),
              card("CROD", 3, 3, 3, 4), card("PROD", 3, 10, 12.5),
              card("CTUBE", 4, 4, 4, 5), card("PTUBE", 4, 10, 20.0, 2.0),
              card("CONROD", 5, 5, 6, 10, 7.0), card("MAT4", 10, 150.0)]
    mesh = quiet(read_nastran, write(tmp_path, lines), unit="mm")
    want = [np.pi * (10**2 - 8**2), 50 * 8 + 40 * 6 + (100 - 8 - 6) * 5, 12.5, np.pi * (20**2 - 16**2) / 4, 7.0]
    np.testing.assert_allclose(mesh.section_area, np.array(want) * 1e-6, rtol=1e-14)
    assert mesh.properties["CONROD MID 10"].conductivity == 150.0
    with pytest.raises(Fem2TmmError, match=r"PBARL 1: section type 'HAT' is not supported"):
        lines[7] = card("PBARL", 1, 10, "", "HAT", "", "", "", "", "+")
        quiet(read_nastran, write(tmp_path, lines))


# ------------------------------------------------------------------------------------------- NASTRAN-95 washer
N95 = Path(__file__).parent / "data" / "nastran95"


def published_temperatures() -> dict[int, float]:
    """GRID -> temperature from the 'T E M P E R A T U R E   V E C T O R' table of d01121a.out."""
    lines = (N95 / "d01121a.out").read_text().splitlines()
    start = next(i for i, s in enumerate(lines) if "T E M P E R A T U R E   V E C T O R" in s)
    out = {}
    for s in lines[start + 3:]:
        m = re.match(r"\s+(\d+)\s+S\s+(.*)$", s)
        if not m:
            break
        for k, v in enumerate(m.group(2).split()):
            out[int(m.group(1)) + k] = float(v)
    return out


def test_nastran95_washer_d01_12_1a(tmp_path):
    # the deck as published: CHEXA1/CHEXA2/CWEDGE with a material id in field 2, CTETRA, no PSOLID; its own
    # QBDY1 on a CHBDY AREA4 (flux 288.5 at r = 1) and SPC (T = 0 at r = 2), read through nastran_loads
    case = Case.from_dict({"mesh": {"file": "d01121a.inp", "nastran_loads": True, "temperature_unit": "C"},
                           "parts": [{"name": "washer", "groups": ["PID 200"], "super_nodes": 3}]},
                          base_dir=N95, source=str(N95 / "case.toml"))
    res = quiet(run, case)
    mesh = res.mesh
    assert mesh.cards["modelled"] == {"CHEXA1": 1, "CHEXA2": 1, "CTETRA": 5, "CWEDGE": 14}
    assert set(mesh.cards["ignored"]) == {"PARAM", "SEQGP"}
    pub = published_temperatures()
    assert len(pub) == 44 and pub[11] == 0.0 and pub[1] == 199.4187
    ids = mesh.node_ids
    r = np.hypot(mesh.points[:, 0], mesh.points[:, 1])
    exact = 288.5 * np.log(2.0 / r)  # analytic: q r = 288.5 (k = 1), T(2) = 0
    nastran = np.array([pub[int(g)] for g in ids])
    err_n95 = np.abs(nastran - exact).max()
    assert err_n95 == pytest.approx(3.44, abs=0.01)  # the published solution's largest error (GRID 12/112)
    for T in (res.T_detailed_nodes, res.T_recovered_nodes):
        ours = T - KELVIN
        # fem2tmm is no farther from the analytic solution than NASTRAN-95 at its worst GRID
        assert np.abs(ours - exact).max() <= err_n95
        # on the wedge zone (CWEDGE elements, r >= 1.3) both codes use the same linear prism; one element away
        # from the interface with the HEXA1/HEXA2/TETRA zone (whose elements differ: NASTRAN-95's HEXA1/2 are
        # sub-tetrahedra, ours the trilinear hexahedron) they agree within 0.01 K
        wedge = r >= 1.5 - 1e-12
        assert np.abs(ours - nastran)[wedge].max() < 0.01
    # the flux input: 288.5 W/m² x the inner face (r = 1, 4 degrees, 0.1 deep) = 2.0141 W (published OLOAD 4 x 0.5034)
    assert res.summary["detailed"]["loads_W"]["deck flux (QBDY/QHBDY)"] == pytest.approx(4 * 5.034252e-01, rel=1e-6)


# ------------------------------------------------------------------------------------------- inspect, outputs
def test_inspect_counts_regions(tmp_path, capsys):
    from fem2tmm.cli import main

    # PID 1: a U channel folded at 90 degrees twice (3 regions at the 30 degree default); PID 2: a flat plate
    lines = []
    xs, zs = [0.0, 0.0, 1.0, 1.0], [1.0, 0.0, 0.0, 1.0]  # the U profile in the xz plane, extruded along y
    for j, y in enumerate((0.0, 0.5, 1.0)):
        for i, (x, z) in enumerate(zip(xs, zs)):
            lines.append(card("GRID", 1 + i + 4 * j, "", x, y, z))
    for j in range(2):
        for i in range(3):
            g = 1 + i + 4 * j
            lines.append(card("CQUAD4", 1 + i + 3 * j, 1, g, g + 1, g + 5, g + 4))
    lines += plate_cards(5.0, 101, 101, 2)
    lines += [card("PSHELL", 1, 10, 0.001), card("PSHELL", 2, 10, 0.002), card("MAT4", 10, 1.0),
              card("SPC1", 1, 1, 101, "THRU", 103), card("CBUSH", 500, 9, 8, 101), card("PARAM", "POST", -1),
              card("RBAR", 501, 5, 6, 123456)]
    deck = write(tmp_path, lines)
    assert main(["inspect", str(deck)]) == 0
    text = capsys.readouterr().out
    # 3 regions that merge down to 1 (issue 33: the U is one connected piece), area 3 m²
    assert re.search(r"PID 1\s+shell\s+6\s+3\s+1\s+3 m2", text), text
    assert re.search(r"PID 2\s+shell\s+4\s+1\s+1\s+1 m2\s+0.002 m \(PSHELL\)", text), text
    # the merges a count below the regions implies, smallest first: a 1 m² face of the channel across its 1 m fold
    assert re.search(r"PID 1\s+3 regions -> 1: 1 m2 across 1 m of shared edge; ", text), text
    assert "consistent" in text and "cards refused" in text and "RBAR (1)" in text and "PARAM (1)" in text
    # one piece: the CBUSH joins the channel to the plate; it touches the joint and the SPC1
    assert "connected pieces (elements and joints): 1" in text and "joint: yes, SPC: yes" in text


def test_line_part_clusters_and_vtu(tmp_path):
    # a chain of 12 CRODs between the two plates, clustered into 3 contiguous super nodes; outputs hold line cells
    lines = two_plates([])
    for i in range(11):
        lines.append(card("GRID", 1000 + i, "", 1.0 + (i + 1) / 12, 0.5, 0.0))
    chain = [6, *range(1000, 1011), 104]
    lines += [card("CROD", 900 + i, 3, a, b) for i, (a, b) in enumerate(zip(chain[:-1], chain[1:]))]
    lines += [card("PROD", 3, 30, 1e-4), card("MAT4", 30, 100.0, 900.0, 2700.0)]
    deck = write(tmp_path, lines)
    case = case_for(deck, [*PLATES, {"name": "rod", "groups": ["PID 3"], "super_nodes": 3}], HEAT_FIX)
    res = quiet(run, case, out=tmp_path / "out")
    rep = next(p for p in res.summary["reduced"]["clustering"]["parts"] if p["name"] == "rod")
    assert rep["kind"] == "line" and rep["clusters"] == 3 and rep["contiguous"]
    i6, i104 = res.mesh.node_index([6, 104], where="test")
    T = res.T_recovered_nodes
    # closed form: 5 W through a rod of L = 1 m, A = 1e-4 m², k = 100: ΔT = 5 / (100 · 1e-4) = 500 K
    assert T[i6] - T[i104] == pytest.approx(500.0, rel=1e-9)
    import meshio

    vtu = meshio.read(tmp_path / "out" / "temperatures.vtu")
    assert sum(len(c.data) for c in vtu.cells if c.type == "line") == 12


def test_case_overrides_deck_loads(tmp_path):
    # the washer with only its QBDY1 taken from the deck and the outer face held at 10 °C by the case instead of
    # the deck's SPC at 0: the problem is linear, so every temperature moves by exactly +10 K
    base = {"file": "d01121a.inp", "temperature_unit": "C"}
    parts = [{"name": "washer", "groups": ["PID 200"], "super_nodes": 3}]
    a = quiet(run, Case.from_dict({"mesh": {**base, "nastran_loads": True}, "parts": parts},
                                  base_dir=N95, source=str(N95 / "case.toml")), reference=True)
    b = quiet(run, Case.from_dict({"mesh": {**base, "nastran_loads": ["QBDY1"]}, "parts": parts,
                                   "boundary": [{"kind": "temperature", "nodes": [11, 22, 111, 122], "value": 10.0}]},
                                  base_dir=N95, source=str(N95 / "case.toml")), reference=True)
    np.testing.assert_allclose(b.T_detailed_nodes - a.T_detailed_nodes, 10.0, rtol=0, atol=1e-9)
    assert [g.name for g in a.model.fixed] == ["SPC 0 C"] and len(b.model.fixed) == 1
    # all deck loads on, and the case's boundary on the same GRIDs: the case wins over the deck's SPC
    c = quiet(run, Case.from_dict({"mesh": {**base, "nastran_loads": True}, "parts": parts,
                                   "boundary": [{"kind": "temperature", "nodes": [11, 22, 111, 122], "value": 10.0}]},
                                  base_dir=N95, source=str(N95 / "case.toml")), reference=True)
    np.testing.assert_allclose(c.T_detailed_nodes, b.T_detailed_nodes, rtol=0, atol=1e-9)
    assert len(c.model.fixed) == 1


# ------------------------------------------------------------------------------------------- units, solids
def test_inch_lbf_second_fahrenheit_materials(tmp_path):
    # MAT4 K = 1 lbf/(s °F) = 0.1129848 W / (0.0254 m · 5/9 K) = 8.006803 W/(m K) (1 in·lbf = 0.1129848 J);
    # RHO = 1 lbf s²/in⁴ = 4.4482216 N s² / 0.0254⁴ m⁴... = 1.0686895e7 kg/m³; CP = 1 in²/(s² °F) = 0.0254²/(5/9)
    lines = [*plate_cards(0.0, 1, 1, 1), card("PSHELL", 1, 10, 0.1), card("MAT4", 10, 1.0, 1.0, 1.0)]
    deck = write(tmp_path, lines)
    p = quiet(read_nastran, deck, unit_system="in-lbf-s", temperature_unit="F").properties["PID 1"]
    assert p.conductivity == pytest.approx(0.1129848290276167 / (0.0254 * 5 / 9), rel=1e-12)
    assert p.density == pytest.approx(1.0686895e7, rel=1e-7)
    assert p.specific_heat == pytest.approx(0.0254**2 / (5 / 9), rel=1e-12)
    assert p.thickness == pytest.approx(0.1 * 0.0254, rel=1e-15)
    with pytest.raises(Fem2TmmError, match=r"unit system 'in-lbf-s' is ambiguous about temperature.*temperature_unit"):
        quiet(read_nastran, deck, unit_system="in-lbf-s")
    with pytest.raises(Fem2TmmError, match=r"\[mesh\]: unit = 'mm' contradicts unit_system = 'in-lbf-s'"):
        Case.from_dict({"mesh": {"file": "x.bdf", "unit": "mm", "unit_system": "inch-lbf-s"},
                        "parts": [{"name": "p", "groups": ["PID 1"]}]})


def test_ignore_cards_lets_the_run_proceed(tmp_path):
    deck = write(tmp_path, two_plates([card("RBAR", 900, 6, 104, 123456), card("CBUSH", 901, 7, 6, 104)]))
    # the RBAR is dropped explicitly; the CBUSH (PID 7) conducts 2 W/K: drop = P / G = 5 / 2 K
    case = case_for(deck, PLATES, HEAT_FIX, mesh={"ignore_cards": ["RBAR"]},
                    joints=[{"pids": [7], "treatment": "conductance", "conductance": 2.0}])
    res = quiet(run, case)
    assert res.mesh.cards["ignored"] == {"RBAR": 1} and res.summary["mesh"]["joints"] == {"CBUSH": {"conductance": 1}}
    assert res.summary["mesh"]["ignored_cards"] == {"RBAR": 1}
    i6, i104 = res.mesh.node_index([6, 104], where="test")
    assert res.T_recovered_nodes[i6] - res.T_recovered_nodes[i104] == pytest.approx(2.5, rel=1e-9)


def test_chexa20_linear_patch_and_mat5_solid(tmp_path):
    # a 2 x 1 x 1 m block of two CHEXA20 (mid-side GRIDs at edge midpoints), MAT5 KXX = 5, KYY = 7, KZZ = 11:
    # volume exact, the linear field T = 30 x exact at every GRID, heat = KXX A ΔT / L = 5 · 1 · 60 / 2 = 150 W
    X = {}

    def gid(x, y, z):
        key = (round(2 * x), round(2 * y), round(2 * z))
        return X.setdefault(key, len(X) + 1)

    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    edges = [(0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 5), (2, 6), (3, 7), (4, 5), (5, 6), (6, 7), (7, 4)]
    lines = []
    for e, x0 in enumerate((0.0, 1.0)):
        c = [(x + x0, y, z) for x, y, z in corners]
        m = [tuple((np.array(c[a]) + np.array(c[b])) / 2) for a, b in edges]
        g = [gid(*p) for p in c + m]
        lines += [card("CHEXA", 1 + e, 1, *g[:6], "+"), card("+", *g[6:14], "+"), card("+", *g[14:])]
    lines = [card("GRID", i, "", k[0] / 2, k[1] / 2, k[2] / 2) for k, i in X.items()] + lines
    lines += [card("PSOLID", 1, 10), card("MAT5", 10, 5.0, "", "", 7.0, "", 11.0)]
    deck = write(tmp_path, lines)
    mesh = quiet(read_mesh, deck)
    assert len(mesh.midside) == 20 and np.nansum(mesh.element_volumes()) == pytest.approx(2.0, rel=1e-14)
    lo = mesh.node_ids[mesh.points[:, 0] == 0.0].tolist()
    hi = mesh.node_ids[mesh.points[:, 0] == 2.0].tolist()
    case = case_for(deck, [{"name": "b", "groups": ["PID 1"], "super_nodes": 1}],
                    [{"kind": "temperature", "nodes": lo, "value": 0.0, "name": "lo"},
                     {"kind": "temperature", "nodes": hi, "value": 60.0, "name": "hi"}])
    res = quiet(run, case, mesh=mesh)
    for T in (res.T_detailed_nodes, res.T_recovered_nodes):
        np.testing.assert_allclose(T - KELVIN, 30.0 * mesh.points[:, 0], rtol=0, atol=1e-9)
    assert res.summary["detailed"]["heat_into_fixed_W"]["lo"] == pytest.approx(150.0, rel=1e-9)


def test_pcompg_plies(tmp_path):
    # PCOMPG: one ply per continuation line (GPLYID MID T THETA SOUT); plies 0.2 / 0.3 / 0.5 mm
    lines = [*plate_cards(0.0, 1, 1, 1), card("PCOMPG", 1, "", "", "", "", "", "", "", "+"),
             card("+", 1, 10, 0.2, 0.0, "", "", "", "", "+"), card("+", 2, 10, 0.3, 45.0, "", "", "", "", "+"),
             card("+", 3, 10, 0.5, 90.0), card("MAT4", 10, 100.0)]
    p = quiet(read_nastran, write(tmp_path, lines), unit="mm").properties["PID 1"]
    assert p.thickness == pytest.approx(1.0e-3, rel=1e-14) and p.conductivity == pytest.approx(100.0, rel=1e-14)


def test_joint_on_mid_side_nodes(tmp_path):
    # a CBUSH from a free GRID 900 to the mid-side GRID 5 of a CQUAD8 edge 1-2: T_5 = (T_1 + T_2) / 2 (the
    # corner-node model of the quadratic element); 5 W into GRID 900 flow through G = 0.5 W/K and across the plate
    # to its edge x = 0 held at 20 °C: the joint drops P / G = 10 K exactly, and 5 W reach the edge
    lines = [card("GRID", i + 1, "", x, y, 0.0) for i, (x, y) in enumerate(
        [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0), (1, 0.5), (0.5, 1), (0, 0.5)])]
    lines += [card("CQUAD8", 1, 1, 1, 2, 3, 4, 5, 6, "+"), card("+", 7, 8), card("PSHELL", 1, 10, 0.002),
              card("MAT4", 10, 200.0), card("GRID", 900, "", 0.5, -1.0, 0.0), card("CBUSH", 50, 7, 900, 5)]
    deck = write(tmp_path, lines)
    case = case_for(deck, [{"name": "p", "groups": ["PID 1"]}],
                    [{"kind": "temperature", "nodes": [1, 4, 8], "value": 20.0, "name": "edge"},
                     {"kind": "power", "nodes": [900], "value": 5.0}],
                    joints=[{"cards": ["CBUSH"], "treatment": "conductance", "conductance": 0.5}])
    res = quiet(run, case)
    i900, i1, i2, i5 = res.mesh.node_index([900, 1, 2, 5], where="test")
    for T in (res.T_detailed_nodes, res.T_recovered_nodes):
        assert T[i5] == pytest.approx((T[i1] + T[i2]) / 2, rel=1e-14) and T[i2] > T[i1] + 1.0
        assert T[i900] - T[i5] == pytest.approx(10.0, rel=1e-9)
    assert res.summary["detailed"]["heat_into_fixed_W"]["edge"] == pytest.approx(5.0, rel=1e-9)


def test_isothermal_joint_over_a_quadratic_edge(tmp_path):
    # an RBE2 spider over the whole edge 1-5-2 of a CQUAD8 (corners and mid-side): merging is exact, GRID 900
    # and the edge share one temperature; a spider to the mid-side GRID alone merges the edge (warning)
    lines = [card("GRID", i + 1, "", x, y, 0.0) for i, (x, y) in enumerate(
        [(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0), (1, 0.5), (0.5, 1), (0, 0.5)])]
    lines += [card("CQUAD8", 1, 1, 1, 2, 3, 4, 5, 6, "+"), card("+", 7, 8), card("PSHELL", 1, 10, 0.002),
              card("MAT4", 10, 200.0), card("GRID", 900, "", 0.5, -1.0, 0.0)]
    bc = [{"kind": "temperature", "nodes": [3, 4, 7], "value": 20.0}, {"kind": "power", "nodes": [900], "value": 5.0}]
    joints = [{"cards": ["RBE2"], "treatment": "isothermal"}]
    deck = write(tmp_path, [*lines, card("RBE2", 50, 900, 1, 1, 5, 2)])
    res = quiet(run, case_for(deck, [{"name": "p", "groups": ["PID 1"]}], bc, joints=joints))
    T = res.T_detailed_nodes
    i900, i1, i2, i5 = res.mesh.node_index([900, 1, 2, 5], where="test")
    assert T[i900] == T[i1] == T[i2] == T[i5]
    deck = write(tmp_path, [*lines, card("RBE2", 50, 900, 1, 5)], name="d2.bdf")
    with pytest.warns(UserWarning, match=r"isothermal joints reach mid-side GRIDs 5 whose edge ends"):
        run(case_for(deck, [{"name": "p", "groups": ["PID 1"]}], bc, joints=joints))


def test_nastran95_shell_aliases(tmp_path):
    # NASTRAN-95 shells and CSHEAR with their property cards (PID, MID, T like PSHELL)
    lines = [card("GRID", i + 1, "", float(i % 3), float(i // 3), 0.0) for i in range(9)]
    pairs = [("CQUAD1", "PQUAD1"), ("CQUAD2", "PQUAD2"), ("CQDMEM", "PQDMEM"), ("CQDMEM1", "PQDMEM1"),
             ("CQDMEM2", "PQDMEM2"), ("CSHEAR", "PSHEAR")]
    for k, (c, p) in enumerate(pairs):
        lines += [card(c, 10 + k, 10 + k, 1, 2, 5, 4), card(p, 10 + k, 1, 0.001 * (k + 1))]
    for k, (c, p) in enumerate([("CTRIA1", "PTRIA1"), ("CTRIA2", "PTRIA2"), ("CTRMEM", "PTRMEM")]):
        lines += [card(c, 20 + k, 20 + k, 2, 3, 6), card(p, 20 + k, 1, 0.01 * (k + 1))]
    lines.append(card("MAT4", 1, 5.0))
    mesh = quiet(read_nastran, write(tmp_path, lines))
    for k, (c, p) in enumerate(pairs):
        prop = mesh.properties[f"PID {10 + k}"]
        assert (prop.card, prop.thickness, prop.conductivity) == (p, 0.001 * (k + 1), 5.0)
    assert [b.type for b in mesh.blocks] == ["tri3", "quad4"] and mesh.properties["PID 22"].thickness == 0.03


def test_inspect_gives_the_size_and_flags_millimetres_read_as_metres():
    # meshes/baffle.msh is in mm (its case files say unit = "mm"): about 80 x 80 x 90 mm.  Read as metres it is
    # 80 m across, which the text must flag; with --unit mm it is 0.08 m and nothing is flagged.
    from pathlib import Path

    from fem2tmm.inspection import inspect_mesh, inspection_text

    path = Path(__file__).resolve().parents[1] / "meshes" / "baffle.msh"
    as_m, as_mm = (inspection_text(inspect_mesh(path, unit=u)) for u in ("m", "mm"))
    assert "is the file in millimetres? then give --unit mm" in as_m
    assert "millimetres" not in as_mm
    size = re.search(r"size ([\d.]+) x ([\d.]+) x ([\d.]+) m", as_mm)
    assert size and all(0.05 < float(x) < 0.2 for x in size.groups()), as_mm
