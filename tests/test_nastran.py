"""Nastran bulk data reader: formats, coordinate systems, properties, units and every error.

The reference deck ``tests/data/nastran_full.bdf`` (with its INCLUDEs ``nastran_full_grids.inc`` and
``nastran_full_cords.inc``) uses every supported card and format; the coordinates expected below are
computed by hand in the comments.
"""

from __future__ import annotations

import math
import random
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from fem2tmm.errors import Fem2TmmError
from scenarios import write_plate_deck
from fem2tmm.io.nastran import read_nastran
from fem2tmm.io.nastran.deck import _parse_int, _parse_real

DATA = Path(__file__).parent / "data"
FULL = DATA / "nastran_full.bdf"


def read_quiet(path, unit="m"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_nastran(path, unit=unit)


def sf(name, *fields, cont=""):
    """One small-field line: name in columns 1-8, data right-justified in 8-column fields."""
    s = f"{name:<8}" + "".join(f"{str(f):>8}" for f in fields)
    return (s.ljust(72) + cont if cont else s).rstrip()


def cord(card, cid, rid, c=("1.",), ab=("0.", "0.", "0.", "0.", "0.", "1.")):
    """The two small-field lines of a CORD2x card: A, B on the first, C on the continuation."""
    return [sf(card, cid, rid, *ab), sf("", *c)]


def deck(tmp_path, *lines, name="deck.bdf"):
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


SQUARE = [  # the four GRIDs of a unit square, used by the small decks below
    sf("GRID", 1, 0, "0.", "0.", "0."),
    sf("GRID", 2, 0, "1.", "0.", "0."),
    sf("GRID", 3, 0, "1.", "1.", "0."),
    sf("GRID", 4, 0, "0.", "1.", "0."),
]


# --------------------------------------------------------------------------------------------- full deck


def test_full_deck_coordinates_by_hand():
    mesh = read_quiet(FULL)
    s3 = math.sqrt(3.0)
    expected = {
        # small field, CP = 0 given explicitly (the GRDSET default is not used)
        1: (0.0, 0.0, 0.0),
        # small field, left-justified fields
        2: (1.0, 0.0, 0.0),
        # blank CP -> GRDSET CP = 1.  CORD2R 1: A = (10,0,0), B = (10,0,1), C = (10,1,0)
        #   ez = B - A = (0,0,1); ex = C - A = (0,1,0); ey = ez x ex = (-1,0,0)
        #   (1,2,3) -> A + 1 ex + 2 ey + 3 ez = (10,0,0) + (0,1,0) + (-2,0,0) + (0,0,3) = (8,1,3)
        3: (8.0, 1.0, 3.0),
        # CORD2C 2 = basic axes (A = 0, B = (0,0,1), C = (1,0,0)); (r, theta, z) = (2, 60 deg, 5)
        #   -> (2 cos 60, 2 sin 60, 5) = (1, sqrt 3, 5)
        4: (1.0, s3, 5.0),
        # CORD2S 3: A = (1,2,3), B = (1,2,4), C = (2,2,3): ez = (0,0,1), ex = (1,0,0), ey = (0,1,0)
        #   (r, theta, phi) = (2, 90, 90) -> local (2 sin90 cos90, 2 sin90 sin90, 2 cos90) = (0,2,0)
        #   -> (1,2,3) + (0,2,0) = (1,4,3)
        5: (1.0, 4.0, 3.0),
        # CORD2R 4 is defined in the cylindrical system 2 (large field):
        #   A = (r 1, th 90, z 0) = (0,1,0); B = (1, 90, 1) = (0,1,1); C = (2, 90, 0) = (0,2,0)
        #   ez = (0,0,1); ex = C - A = (0,1,0); ey = ez x ex = (-1,0,0)
        #   (1,2,3) -> (0,1,0) + (0,1,0) + (-2,0,0) + (0,0,3) = (-2,2,3)
        6: (-2.0, 2.0, 3.0),
        # CORD2R 5 is defined in system 4 (chain 5 -> 4 -> 2 -> 0, written before 4 in the file):
        #   A = 0 in 4 -> (0,1,0); B = (1,0,0) in 4 -> (0,1,0) + ex4 = (0,2,0); C = (0,0,1) in 4 -> (0,1,1)
        #   ez = (0,1,0); ex = (C - A) - ((C - A).ez) ez = (0,0,1); ey = ez x ex = (1,0,0)
        #   (1,1,1) -> (0,1,0) + (0,0,1) + (1,0,0) + (0,1,0) = (1,2,1)
        7: (1.0, 2.0, 1.0),
        # large field: 1.5D0, -.5+1 (= -0.5e1), 2.5-1 (= 2.5e-1) on a '*' continuation
        8: (1.5, -5.0, 0.25),
        # free field with 1.0d-3
        9: (1.0e-3, 2.0, 3.0),
        # large free field, '*,' continuation
        10: (1.0, 2.0, 3.0),
        # tabs
        11: (4.0, 5.0, 6.0),
        # lower-case card name, after a blank line; unused by every element but kept
        12: (7.0, 8.0, 9.0),
    }
    np.testing.assert_array_equal(mesh.node_ids, np.arange(1, 13))  # file order, INCLUDEs inlined
    want = np.array([expected[i] for i in range(1, 13)])
    # tolerance: rounding of cos/sin of degrees and of the chained transforms (a few ulp of 10)
    np.testing.assert_allclose(mesh.points, want, rtol=0, atol=1e-13)


def test_full_deck_elements():
    mesh = read_quiet(FULL)
    got = {b.type: (b.ids.tolist(), mesh.node_ids[b.cells].tolist()) for b in mesh.blocks}
    assert [b.type for b in mesh.blocks] == ["tri3", "quad4", "tet4", "hex8", "wedge6", "line2"]
    assert got["line2"] == ([300, 301], [[1, 2], [2, 3]])  # CBAR: 1-D conduction elements (issue 16)
    # CTRIA3* with a blank-first-field large continuation; free-field CTRIA3 with '+T103'
    assert got["tri3"] == ([102, 103], [[1, 2, 6], [1, 2, 8]])
    # CQUAD4 with THETA, ZOFFS and the T1-T4 continuation; blank PID; tab-separated
    assert got["quad4"] == ([100, 101, 105], [[1, 2, 7, 9], [2, 3, 4, 5], [1, 6, 7, 8]])
    assert got["tet4"] == ([200], [[1, 2, 6, 7]])
    # CHEXA: implicit small continuation; large field '*H1'/'*H2'; small line + free-field continuation
    assert got["hex8"] == ([201, 202, 204], [list(range(1, 9)), list(range(1, 9)), [9, 10, 11, 12, 1, 2, 3, 4]])
    assert got["wedge6"] == ([203], [[1, 2, 3, 4, 5, 6]])


def test_full_deck_groups():
    mesh = read_quiet(FULL)
    assert sorted(mesh.groups) == ["PID 1", "PID 10", "PID 101", "PID 30", "PID 31"]
    want = {  # PID: (dim, element ids, GRID ids of those elements)
        "PID 10": (2, {100, 102, 103, 105}, {1, 2, 6, 7, 8, 9}),
        "PID 101": (2, {101}, {2, 3, 4, 5}),  # blank PID on CQUAD4 101 -> PID = EID
        "PID 30": (3, {200, 201}, set(range(1, 9))),
        "PID 31": (3, {202, 203, 204}, set(range(1, 13))),
    }
    for name, (dim, eids, gids) in want.items():
        g = mesh.groups[name]
        assert g.dim == dim
        assert set(mesh.element_ids[g.elements].tolist()) == eids
        assert set(mesh.node_ids[g.nodes].tolist()) == gids
        assert np.all(np.diff(g.elements) > 0) and np.all(np.diff(g.nodes) > 0)


def test_full_deck_properties_si():
    p = read_quiet(FULL).properties
    # PSHELL 10: T = 1.0-3; MAT4 20: K = 1.7D+2, CP = 900., RHO = 2.7+3 (MAT1 20 RHO = 1. loses to MAT4)
    assert p["PID 10"].thickness == pytest.approx(1e-3, rel=1e-15)
    assert (p["PID 10"].conductivity, p["PID 10"].specific_heat) == (170.0, 900.0)
    assert p["PID 10"].density == 2700.0 and p["PID 10"].material_id == 20
    # free-field PSHELL 101 with T = 2.5D-3
    assert p["PID 101"].thickness == pytest.approx(2.5e-3, rel=1e-15)
    # PSOLID 30 -> MID 21 has only a MAT1: density only
    assert (p["PID 30"].thickness, p["PID 30"].conductivity, p["PID 30"].density, p["PID 30"].specific_heat) == (
        None, None, 2700.0, None)
    # PSOLID* 31 -> MAT4* 22 (K = .2, CP = 1.0E3, RHO blank) + MAT1 22 (RHO = 1200.)
    assert (p["PID 31"].conductivity, p["PID 31"].density, p["PID 31"].specific_heat) == (0.2, 1200.0, 1000.0)


def test_unknown_cards_one_warning():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        read_nastran(FULL)
    msgs = [str(w.message) for w in rec]
    assert len(msgs) == 1, msgs
    # counts by hand from the deck: PARAM x1 (CBAR x2 are bars, RBE2 x1 a joint; the GRID after ENDDATA is not read)
    assert msgs[0].endswith("ignored non-structural cards (listed in summary.json mesh.ignored_cards): PARAM (1)")
    mesh = read_quiet(FULL)
    assert mesh.cards["ignored"] == {"PARAM": 1} and mesh.cards["refused"] == {}
    assert mesh.cards["modelled"]["CBAR"] == 2 and mesh.cards["modelled"]["RBE2"] == 1
    (j,) = mesh.joints
    assert j.card == "RBE2" and mesh.node_ids[j.pairs].tolist() == [[1, 2], [1, 3]]


def test_units_mm_tonne_second():
    m = read_quiet(FULL)
    mm = read_quiet(FULL, unit="mm")
    np.testing.assert_allclose(mm.points, m.points * 1e-3, rtol=1e-15, atol=0)
    p, q = m.properties["PID 10"], mm.properties["PID 10"]
    # mm-t-s: T mm -> x1e-3 m; K mW/(mm K) = W/(m K); RHO t/mm3 -> x1e12 kg/m3; CP mJ/(t K) -> x1e-6 J/(kg K)
    assert q.thickness == pytest.approx(p.thickness * 1e-3, rel=1e-15)
    assert q.conductivity == pytest.approx(p.conductivity, rel=1e-15)
    assert q.density == pytest.approx(p.density * 1e12, rel=1e-15)
    assert q.specific_heat == pytest.approx(p.specific_heat * 1e-6, rel=1e-15)


def test_units_inch_drops_materials_with_a_warning():
    with pytest.warns(UserWarning, match="cannot be interpreted without a unit system"):
        m = read_nastran(FULL, unit="in")
    q = m.properties["PID 10"]
    assert q.thickness == pytest.approx(1e-3 * 0.0254, rel=1e-15)  # 1 in = 0.0254 m exactly
    assert (q.conductivity, q.density, q.specific_heat) == (None, None, None)
    np.testing.assert_allclose(m.points[4], np.array([1.0, 4.0, 3.0]) * 0.0254, atol=1e-15)


# --------------------------------------------------------------------------------------------- fields


def _fields(strings, width):
    return np.frombuffer("".join(s.ljust(width) for s in strings).encode(), np.uint8).reshape(-1, width).copy()


def test_real_fields_against_python_float():
    # reference: Python float() of the canonical E form; Nastran spellings of the same number:
    # D exponent, lower case, implicit exponent (E removed), left/right justified, 8 and 16 columns
    rng = random.Random(1)
    strings, want = [], []
    for _ in range(3000):
        v = rng.uniform(1, 10) * 10.0 ** rng.randint(-30, 30) * rng.choice([-1, 1])
        canon = f"{v:.2E}"  # e.g. -1.23E-05
        mant, exp = canon.split("E")
        exp = f"{int(exp):+d}"
        for s in (canon, canon.replace("E", "D"), canon.lower(), mant + exp, mant + "D" + exp):
            strings.append(s.rjust(8) if rng.random() < 0.5 else s)
            want.append(float(canon))
    strings += ["1.-3", "-.5+2", "+.5-2", "7.", ".7", "  12  ", "-3", "1.0E+01", "1+3"]
    want += [1e-3, -50.0, 0.005, 7.0, 0.7, 12.0, -3.0, 10.0, 1000.0]
    for width in (8, 16):
        sel = [i for i, s in enumerate(strings) if len(s) <= width]
        val, blank, ok = _parse_real(_fields([strings[i] for i in sel], width))
        assert ok.all() and not blank.any()
        np.testing.assert_array_equal(val, [want[i] for i in sel])  # exact: same decimal string as float()


def test_real_fields_blank_and_malformed():
    val, blank, ok = _parse_real(_fields(["", "1.2.3", "1.5-", "--1", "nan", "inf", "1.5E", "1E999", "2."], 8))
    assert blank.tolist() == [True] + [False] * 8
    assert ok.tolist() == [True] + [False] * 7 + [True]
    assert val[-1] == 2.0 and val[0] == 0.0


def test_int_fields_against_python_int():
    rng = random.Random(2)
    nums = [rng.randint(-(10**7) + 1, 10**8 - 1) for _ in range(2000)]
    strings = [str(n).rjust(8) if rng.random() < 0.5 else str(n) for n in nums]
    val, blank, ok = _parse_int(_fields(strings + ["", "+12", "1 2", "1.", "12a", "-"], 8))
    assert val[:2000].tolist() == nums  # reference: the ints the strings were printed from
    assert ok.tolist() == [True] * 2002 + [False] * 4
    assert blank.tolist() == [False] * 2000 + [True] + [False] * 5
    assert val[2001] == 12


# --------------------------------------------------------------------------------------------- plate


def _plate(nx, ny, lx, ly):
    """The reference: a structured plate built directly (GRID k at (i lx/nx, j ly/ny), row by row)."""
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1))
    pts = np.stack([i.ravel() * (lx / nx), j.ravel() * (ly / ny), np.zeros(i.size)], axis=1)
    r, c = np.divmod(np.arange(nx * ny), nx)
    n0 = r * (nx + 1) + c
    cells = np.stack([n0, n0 + 1, n0 + nx + 2, n0 + nx + 1], axis=1)
    return pts, cells


def test_plate_deck_equals_direct_construction(tmp_path):
    nx, ny = 7, 5
    pts, cells = _plate(nx, ny, 0.3, 0.2)
    # free field with repr() floats: must round-trip exactly
    lines = ["BEGIN BULK", "PSHELL,1,1,1.5e-3", "MAT4,1,170.,900.,2700."]
    lines += [f"GRID,{k + 1},,{x!r},{y!r},{z!r}" for k, (x, y, z) in enumerate(pts.tolist())]
    lines += [f"CQUAD4,{e + 1},1,{','.join(str(n + 1) for n in c)}" for e, c in enumerate(cells)]
    mesh = read_nastran(deck(tmp_path, *lines, "ENDDATA"))
    np.testing.assert_array_equal(mesh.points, pts)
    (blk,) = mesh.blocks
    assert blk.type == "quad4"
    np.testing.assert_array_equal(blk.cells, cells)
    np.testing.assert_array_equal(blk.ids, np.arange(1, nx * ny + 1))
    np.testing.assert_array_equal(mesh.groups["PID 1"].elements, np.arange(nx * ny))
    assert mesh.properties["PID 1"].thickness == 1.5e-3
    # total area: 0.3 x 0.2 (the element areas of the read mesh sum to the plate's)
    assert mesh.element_areas().sum() == pytest.approx(0.06, rel=1e-14)
    # the benchmark's small-field writer: 8-column fields (%8.6f) round the coordinates to 5e-7
    mesh8 = read_nastran(write_plate_deck(tmp_path / "p8.bdf", nx, ny, size=1.0))
    pts1, _ = _plate(nx, ny, 1.0, 1.0)
    np.testing.assert_allclose(mesh8.points, pts1, rtol=0, atol=5e-7)
    np.testing.assert_array_equal(mesh8.blocks[0].cells, cells)


# --------------------------------------------------------------------------------------------- deck forms


def test_deck_without_begin_bulk_or_enddata(tmp_path):
    mesh = read_nastran(deck(tmp_path, *SQUARE, sf("CQUAD4", 1, 1, 1, 2, 3, 4)))
    assert mesh.n_elements == 1 and mesh.n_nodes == 4


def test_include_quoted_over_lines_and_in_subfolder(tmp_path):
    (tmp_path / "sub").mkdir()
    deck(tmp_path / "sub", *SQUARE[2:], "INCLUDE 'more.inc'", name="grids.inc")  # relative to sub/
    deck(tmp_path / "sub", sf("CQUAD4", 1, 1, 1, 2, 3, 4), name="more.inc")
    main = deck(tmp_path, *SQUARE[:2], "INCLUDE 'sub/", "  grids.inc'", sf("GRID", 5, 0, "2.", "0.", "0."))
    mesh = read_nastran(main)
    assert mesh.node_ids.tolist() == [1, 2, 3, 4, 5]
    assert mesh.n_elements == 1


def test_mixed_widths_in_one_card(tmp_path):
    # CHEXA* large first line (EID PID G1 G2), then small '+' line (G3..G8): 16- then 8-column fields
    lines = [sf("GRID", i + 1, 0, f"{x}.", f"{y}.", f"{z}.") for i, (x, y, z) in
             enumerate([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)])]
    lines += ["CHEXA*".ljust(8) + "".join(f"{v:>16}" for v in (9, 3, 1, 2)), sf("+", 3, 4, 5, 6, 7, 8)]
    lines += [sf("PSOLID", 3, 1)]
    mesh = read_nastran(deck(tmp_path, *lines))
    assert mesh.node_ids[mesh.blocks[0].cells].tolist() == [list(range(1, 9))]
    assert mesh.element_volumes() == pytest.approx([1.0], rel=1e-14)  # the unit cube


def test_begin_bulk_inside_include_discards_the_control_section(tmp_path):
    deck(tmp_path, "BEGIN BULK", *SQUARE, sf("CTRIA3", 1, 1, 1, 2, 3), name="bulk.inc")
    mesh = read_quiet(deck(tmp_path, "SOL 101", "CEND", "INCLUDE 'bulk.inc'"))
    assert mesh.n_elements == 1
    assert mesh.node_ids.tolist() == [1, 2, 3, 4]


def test_undefined_material_warns(tmp_path):
    p = deck(tmp_path, *SQUARE, sf("CQUAD4", 1, 1, 1, 2, 3, 4), sf("PSHELL", 1, 7, ".002"))
    with pytest.warns(UserWarning, match=r"no MAT4/MAT5/MAT1 card: MID 7 \(PID 1\)"):
        m = read_nastran(p)
    assert m.properties["PID 1"].thickness == 0.002 and m.properties["PID 1"].conductivity is None


# --------------------------------------------------------------------------------------------- errors

Q = sf("CQUAD4", 1, 1, 1, 2, 3, 4)
ERRORS = {
    "missing_grid": (
        [*SQUARE, Q, sf("CQUAD4", 2, 1, 1, 2, 99, 98), sf("CTRIA3", 3, 1, 1, 97, 2)],
        [r"elements 2, 3 reference GRIDs 97, 98, 99 that are not defined", r"deck\.bdf:6"],
    ),
    "duplicate_grid": ([*SQUARE, sf("GRID", 2, 0, "5.", "0.", "0."), Q], [r"GRID 2 is defined twice: \S*deck\.bdf:2 and \S*deck\.bdf:5"]),
    "duplicate_element": ([*SQUARE, Q, sf("CTRIA3", 1, 1, 1, 2, 3)], [r"element id 1 is defined twice: \S*:5 and \S*:6"]),
    "tet10": (
        [*SQUARE, sf("CTETRA", 8, 1, 1, 2, 3, 4, 1, 2), sf("", 3, 4, 1, 2)],
        [r"GRIDs 1, 2, 3, 4 are mid-side nodes of quadratic elements and also corner nodes"],
    ),
    "hex20": (
        [*SQUARE, sf("CHEXA", 9, 1, 1, 2, 3, 4, 1, 2), sf("", 3, 4, 1, 2, 3, 4, 1, 2), sf("", 3, 4, 1, 2, 3, 4)],
        [r"GRIDs 1, 2, 3, 4 are mid-side nodes of quadratic elements and also corner"],
    ),
    "penta15": (
        [*SQUARE, sf("CPENTA", 10, 1, 1, 2, 3, 4, 1, 2), sf("", 3)],
        [r"GRIDs 3 are mid-side nodes of quadratic elements and also corner"],
    ),
    "undefined_cp": ([*SQUARE, sf("GRID", 5, 9, "1.", "0.", "0."), Q], [r"deck\.bdf:5: GRIDs 5 are given in coordinate system 9, which is not defined"]),
    "undefined_rid": (
        [*SQUARE, Q, *cord("CORD2R", 2, 7)],
        [r"deck\.bdf:6: coordinate system 2 is defined in system 7, which is not defined"],
    ),
    "rid_cycle": (
        [*SQUARE, Q, *cord("CORD2R", 2, 3), *cord("CORD2C", 3, 2)],
        [r"cycle: (2 -> 3 -> 2|3 -> 2 -> 3)"],
    ),
    "degenerate_cord": (
        [*SQUARE, Q, *cord("CORD2R", 2, 0, c=("0.", "0.", "2."))],
        [r"deck\.bdf:6: coordinate system 2: point C lies on the z axis"],
    ),
    "duplicate_cord": (
        [*SQUARE, Q, *cord("CORD2R", 2, 0), *cord("CORD2S", 2, 0)],
        [r"coordinate system 2 is defined twice: \S*:6 and \S*:8"],
    ),
    "malformed_real": ([*SQUARE, sf("GRID", 5, 0, "1.2.3", "0.", "0."), Q], [r"deck\.bdf:5: GRID field 4 \(X1\) '1\.2\.3' is not a real number"]),
    "malformed_int": ([*SQUARE, sf("CQUAD4", 1, 1, 1, 2, "3.", 4)], [r"deck\.bdf:5: CQUAD4 field 6 \(G3\) '3\.' is not an integer"]),
    "blank_required": ([*SQUARE, sf("CQUAD4", 1, 1, 1, 2, 3)], [r"deck\.bdf:5: CQUAD4 field 'G4' is blank; it is required"]),
    "stray_continuation": ([sf("+C", 1, 2), *SQUARE, Q], [r"deck\.bdf:1: continuation line with no card before it"]),
    "free_field_too_long": ([*SQUARE, "CHEXA,1,1,1,2,3,4,1,2,3,4"], [r"deck\.bdf:5: free-field line has 10 data fields; at most 8"]),
    "pshell_on_solid": ([*SQUARE, sf("CTETRA", 1, 1, 1, 2, 3, 4), sf("PSHELL", 1, 1, ".1")], [r"deck\.bdf:6: PSHELL 1 is used by solid elements"]),
    "pid_shell_and_solid": ([*SQUARE, Q, sf("CTETRA", 2, 1, 1, 2, 3, 4)], [r"property ids 1 are used by elements of different kinds \(bars, shells, solids\)"]),
    "two_grdsets": ([sf("GRDSET", "", 0), sf("GRDSET", "", 0), *SQUARE, Q], [r"more than one GRDSET card: \S*:1 and \S*:2"]),
    "duplicate_pid": ([*SQUARE, Q, sf("PSHELL", 1, 1, ".1"), sf("PSOLID", 1, 1)], [r"property id 1 is defined twice: \S*:6 and \S*:7"]),
    "duplicate_mat4": ([*SQUARE, Q, sf("MAT4", 1, "1."), sf("MAT4", 1, "2.")], [r"MAT4 1 is defined twice"]),
    "grid_id_zero": ([*SQUARE, sf("GRID", 0, 0, "1.", "0.", "0."), Q], [r"deck\.bdf:5: GRID ids must be positive integers: 0"]),
    "no_elements": ([*SQUARE, sf("PARAM", "POST", -1)], [r"no supported elements"]),
}


@pytest.mark.parametrize("case", sorted(ERRORS))
def test_errors(tmp_path, case):
    lines, patterns = ERRORS[case]
    p = deck(tmp_path, *lines)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(Fem2TmmError) as exc:
            read_nastran(p)
    for pat in patterns:
        assert re.search(pat, str(exc.value)), str(exc.value)


def test_include_errors(tmp_path):
    deck(tmp_path, "INCLUDE 'b.inc'", name="a.inc")
    deck(tmp_path, "INCLUDE 'a.inc'", name="b.inc")
    with pytest.raises(Fem2TmmError, match=r"INCLUDE cycle: \S*deck\.bdf -> \S*a\.inc -> \S*b\.inc -> \S*a\.inc"):
        read_nastran(deck(tmp_path, *SQUARE, "INCLUDE 'a.inc'"))
    with pytest.raises(Fem2TmmError, match=r"deck\.bdf:5: INCLUDE file 'nope\.inc' not found; tried \S*nope\.inc, "):
        read_nastran(deck(tmp_path, *SQUARE, "INCLUDE 'nope.inc'", Q))


def test_file_and_unit_errors(tmp_path):
    with pytest.raises(Fem2TmmError, match="cannot read Nastran file"):
        read_nastran(tmp_path / "missing.bdf")
    with pytest.raises(Fem2TmmError, match="unknown length unit 'furlong'"):
        read_nastran(FULL, unit="furlong")


# --------------------------------------------------------------------------------------------- scale


@pytest.mark.slow
def test_benchmark_million_quads(request):
    if "slow" not in (request.config.getoption("markexpr") or ""):
        pytest.skip("long measurement (about a minute): run with -m slow")
    from benchmarks.io import bench_nastran

    (res,) = bench_nastran(n_side=1000, repeats=1)
    assert res["elements"] == 1_000_000 and res["nodes"] == 1001**2
    assert res["median_s"] < 30.0  # brief: tens of seconds at most on the 2-core machine


def test_same_plate_as_msh_and_bdf_gives_the_same_K():
    # issue 2: one warped, irregular plate written as Gmsh 2.2 and as Nastran bulk data (PSHELL T = 1 mm,
    # MAT4 K = 170 in mm-t-s units); assembled K agree to 1e-12 relative
    from pathlib import Path

    from fem2tmm.case import Case
    from fem2tmm.fem.model import build_model
    from fem2tmm.io import read_mesh

    data = Path(__file__).parent / "data"
    case_msh = Case.from_dict({"materials": {"al": {"conductivity": 170.0}},
                               "parts": [{"name": "p", "groups": ["PID 7"], "material": "al", "thickness": 1e-3}],
                               "boundary": [{"kind": "temperature", "nodes": [1], "value": 0.0}]})
    # the Nastran deck carries its own thickness and conductivity (PSHELL/MAT4)
    case_bdf = Case.from_dict({"parts": [{"name": "p", "groups": ["PID 7"]}],
                               "boundary": [{"kind": "temperature", "nodes": [1], "value": 0.0}]})
    K1 = build_model(read_mesh(data / "plate_same.msh", unit="mm"), case_msh).K
    K2 = build_model(read_mesh(data / "plate_same.bdf", unit="mm"), case_bdf).K
    assert K1.shape == K2.shape
    assert abs(K1 - K2).max() <= 1e-12 * abs(K1).max()
    assert abs(K1).max() > 0.01  # a real conduction matrix (W/K)
