"""Networks (issue 20): the 10-node model of Fernández Rico §5.1 (detailed solve, automatic grouping, reduced
solve against Tables 5-1 / 5-2), TMRT exactness, deck readers and their errors, round trip with fem2tmm's writers."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import make_case
from fem2tmm import Fem2TmmError, meshes
from fem2tmm.lpm import LoadCase, Network, read_esatan, read_network, read_sinda, solve_network
from fem2tmm.lpm import grouping as G
from fem2tmm.lpm.network import symmetric_couplings
from fem2tmm.lpm.tmrt import conductive_exchange, recomputed_average, tmrt_reduce

KELVIN = 273.15

# ---------------------------------------------------------------------------------------------------------------
# Fernández Rico (2018), §5.1 "10-node test model": K (W/K), R (x 1e-3 m², radiative exchange σ R (T_i⁴ - T_j⁴)),
# C (J/K), Q (W) and the distance matrix D (m) exactly as printed (upper triangles, two decimals).  Nodes 9
# (platform, 35 °C) and 10 (environment, 50 °C) are boundary nodes.
K_UPPER = np.array([
    [0, 0.26, 0.06, 0, 0, 0.05, 0, 0.06, 0.20, 0],
    [0, 0, 0.06, 0.05, 0, 0, 0, 0.06, 0.20, 0],
    [0, 0, 0, 0.35, 0.05, 0.35, 0.35, 0, 0, 0],
    [0, 0, 0, 0, 0.05, 0, 0.13, 0.35, 0, 0],
    [0, 0, 0, 0, 0, 0.05, 0, 0.05, 0, 0],
    [0, 0, 0, 0, 0, 0, 0.13, 0.35, 0, 0],
    [0, 0, 0, 0, 0, 0, 0, 0.35, 0, 0],
    [0] * 10, [0] * 10, [0] * 10])
R_UPPER = 1e-3 * np.array([
    [0, 0.01, 0.64, 0.15, 0, 0.51, 0.25, 0.65, 0, 2.25],
    [0, 0, 0.64, 0.50, 0, 0.15, 0.25, 0.65, 0, 2.25],
    [0, 0, 0, 1.30, 0, 1.28, 1.29, 3.52, 0, 9.00],
    [0, 0, 0, 0, 0, 0.51, 0.66, 1.29, 0, 4.50],
    [0] * 10,
    [0, 0, 0, 0, 0, 0, 0.65, 1.29, 0, 4.50],
    [0, 0, 0, 0, 0, 0, 0, 1.30, 0, 4.50],
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 9.00], [0] * 10, [0] * 10])
D_UPPER = np.array([
    [0, 0.05, 0.06, 0, 0, 0.06, 0, 0.06, 0.04, 0],
    [0, 0, 0.06, 0.06, 0, 0, 0, 0.06, 0.04, 0],
    [0, 0, 0, 0.06, 0.02, 0.06, 0.06, 0, 0, 0],
    [0, 0, 0, 0, 0.05, 0, 0.07, 0.06, 0, 0],
    [0, 0, 0, 0, 0, 0.05, 0, 0.02, 0, 0],
    [0, 0, 0, 0, 0, 0, 0.07, 0.06, 0, 0],
    [0, 0, 0, 0, 0, 0, 0, 0.06, 0, 0],
    [0] * 10, [0] * 10, [0] * 10])
C10 = np.array([13.0, 13.0, 51.8, 25.9, 100.0, 25.9, 25.9, 51.8, 1000.0, 0.0])
# printed results: detailed T (°C) of nodes 1-8; H_cb (node 9) and H_rb (node 10) in W
T_PRINTED = np.array([49.73, 49.73, 65.64, 66.61, 116.13, 66.61, 65.27, 65.64])
H_PRINTED = {"cb": 5.89, "rb": 4.11}
# Table 5-1 (T̄^D and T̂^R of reduced nodes 1-3, °C), Table 5-2 (reduced H_cb, H_rb, W)
TBAR_PRINTED = np.array([49.7, 65.9, 116.1])
TRED_PRINTED = np.array([49.7, 65.9, 115.9])
HRED_PRINTED = {"cb": 5.88, "rb": 4.12}
# Tolerances: the printed matrices are rounded to two decimals (relative errors up to 10 % on the 0.05 W/K
# couplings), which moves the temperatures by up to 0.26 K here: 0.3 K and 0.1 W as the issue states.
TOL_T, TOL_H = 0.3, 0.1


def ten_node_network() -> Network:
    n = 10
    i, j = np.nonzero(K_UPPER)
    GL = symmetric_couplings(n, i, j, K_UPPER[i, j])
    i, j = np.nonzero(R_UPPER)
    GR = symmetric_couplings(n, i, j, R_UPPER[i, j])
    kind = np.array(["D"] * 8 + ["B", "B"])
    T = np.full(n, 20.0 + KELVIN)
    T[8], T[9] = 35.0 + KELVIN, 50.0 + KELVIN
    Q = np.zeros(n)
    Q[4] = 10.0
    z = np.zeros(n)
    return Network(numbers=np.arange(1, 11), labels=np.array([f"N{k}" for k in range(1, 11)]), kind=kind, T=T,
                   C=C10, A=z, alp=z, eps=z, QI=Q, GL=GL, GR=GR, source="fernandez-rico-5.1")


def test_ten_node_detailed_solution_matches_the_printed_one():
    net = ten_node_network()
    sol = solve_network(net)
    assert np.abs(sol.T[:8] - KELVIN - T_PRINTED).max() < TOL_T
    assert abs(sol.H_conductive[8] - H_PRINTED["cb"]) < TOL_H and abs(sol.H_conductive[9]) < 1e-12
    assert abs(sol.H_radiative[9] - H_PRINTED["rb"]) < TOL_H and abs(sol.H_radiative[8]) < 1e-12
    # energy balance: the 10 W of the equipment leave through the two boundaries (round-off)
    assert abs(sol.H.sum() - 10.0) < 1e-9


def test_ten_node_automatic_grouping_reproduces_section_5_1():
    net = ten_node_network()
    grouper = G.prepare(net, distances=sp.csr_matrix(D_UPPER))
    # K̃ (eq. 35) against the printed K̃ where the distance is printed with >= 2 significant digits and the
    # coupling is >= 0.2 W/K: rounding D (±0.005 m) and K (±0.005 W/K) and C (±0.05 J/K) bounds the relative error
    # by 2·0.005/D + 0.005/K + 0.05/G
    printed = {(0, 1): 3.01, (2, 3): 1.88, (2, 5): 1.88, (2, 6): 1.88, (3, 6): 1.50, (3, 7): 1.88, (5, 7): 1.88,
               (6, 7): 1.88}
    Kt = grouper.Kt.toarray()
    for (a, b), v in printed.items():
        g = C10[a] * C10[b] / (C10[a] + C10[b])
        rel = 2 * 0.005 / D_UPPER[a, b] + 0.005 / K_UPPER[a, b] + 0.05 / g
        assert abs(Kt[a, b] - v) <= rel * v + 0.005, (a + 1, b + 1)
    # internal boundary nodes: 1 and 2 (coupled to the platform)
    assert list(np.flatnonzero(grouper.internal) + 1) == [1, 2]
    res = G.group(grouper, pf=0.2, dtmax=10.0)
    assert res.groups(net.numbers) == [[1, 2], [3, 4, 6, 7, 8], [5], [9], [10]]
    assert round(res.ratio, 2) == 0.62  # r_r = 1 - (5 - 2)/(10 - 2) = 0.625, printed 0.62
    # compaction (eq. 41-42) against the printed K^R, R^R, C^R (same rounding: 6 summed couplings ±0.005 each)
    red = res.reduced
    assert abs(red.GL[0, 1] - 0.327) < 6 * 0.005 + 1e-12 and abs(red.GL[0, 3] - 0.4) < 1e-12
    assert abs(red.GL[1, 2] - 0.2) < 1e-12
    assert np.allclose([red.GR[0, 1], red.GR[0, 4], red.GR[1, 4]], [4.4e-3, 4.5e-3, 31.5e-3], atol=0.05e-3)
    # C^R: printed C and C^R are rounded to 0.1 J/K, so a sum of m nodes is within (m + 1)·0.05 J/K
    size = np.bincount(res.labels)
    assert (np.abs(red.C - [25.9, 181.4, 100.0, 1000.0, 0.0]) <= (size + 1) * 0.05 + 1e-9).all()
    chk = res.checks[0]
    assert np.abs(chk.T_target[:3] - KELVIN - TBAR_PRINTED).max() < TOL_T
    assert np.abs(chk.T_reduced[:3] - KELVIN - TRED_PRINTED).max() < TOL_T
    assert abs(chk.Hc_reduced[0] - HRED_PRINTED["cb"]) < TOL_H
    assert abs(chk.Hr_reduced[1] - HRED_PRINTED["rb"]) < TOL_H
    # the thesis' verdict: "very good" — all criteria met (δ < 3 K; flows within 10 %)
    assert res.passed and chk.delta.max() < 0.3


def test_ten_node_sweep_finds_a_passing_grouping_at_least_as_reduced():
    grouper = G.prepare(ten_node_network(), distances=sp.csr_matrix(D_UPPER))
    sw = G.sweep(grouper, [0.01, 0.2, 1.0, 5.0], [0.5, 10.0, 100.0])
    assert sw.best is not None
    i, j = sw.best
    assert sw.passed[i, j] and sw.ratio[i, j] >= 0.625 - 1e-12
    # no coupling passes p_f = 5 and ΔT = 0.5 K: nothing is grouped, ratio 0
    assert sw.ratio[3, 0] == 0.0 and sw.n_c[3, 0] == 10


def test_nodes_without_coordinates_are_never_condensed():
    net = ten_node_network()
    X = np.full((10, 3), np.nan)
    X[:8] = np.random.default_rng(0).uniform(0.0, 0.05, (8, 3))
    X[2] = 0.0  # ESATAN's "no position": the origin
    grouper = G.prepare(G.compact(net, np.arange(10)).with_coordinates(net.numbers, X))
    res = G.group(grouper, pf=0.0, dtmax=1e9)
    assert [3] in res.groups(net.numbers)


# ------------------------------------------------------------------------------------------------------ TMRT
def random_network(seed: int = 3, n: int = 60):
    rng = np.random.default_rng(seed)
    a = np.r_[np.arange(n - 1), rng.integers(0, n - 1, 80)]
    b = np.r_[np.arange(1, n), rng.integers(0, n - 1, 80)]
    GL = symmetric_couplings(n, a, b, rng.uniform(0.05, 2.0, len(a)))
    kind = np.array(["D"] * n)
    kind[[0, n - 1]] = "B"
    supp = np.arange(5, 40)  # conduction-only nodes
    rad = np.setdiff1d(np.arange(1, n - 1), supp)
    ra = rng.choice(rad, 30)
    GR = symmetric_couplings(n, np.r_[ra, rad[:-1]], np.r_[np.full(30, n - 1), rad[1:]],
                             rng.uniform(1e-3, 5e-2, 30 + len(rad) - 1))
    T = np.full(n, 290.0)
    T[-1] = 3.0
    z = np.zeros(n)
    net = Network(numbers=np.arange(1, n + 1) * 10, labels=np.array(["x"] * n), kind=kind, T=T,
                  C=rng.uniform(1.0, 10.0, n), A=z, alp=z, eps=z, QI=z.copy(), GL=GL, GR=GR)
    return net, supp, rad, rng


def test_tmrt_suppression_is_exact_in_steady_state():
    net, supp, rad, rng = random_network()
    red = tmrt_reduce(net, suppress=net.numbers[supp])
    assert red.reduced.n == net.n - len(supp)
    # power distribution factors and temperature recovery factors are partitions of unity
    assert np.allclose(red.PD.sum(axis=0), 1.0, atol=1e-12) and np.allclose(red.TRt.sum(axis=1), 1.0, atol=1e-12)
    assert abs(red.reduced.C.sum() - net.C.sum()) < 1e-9  # equivalent capacitance conserves the total
    assert (red.reduced.GL.data > 0).all()  # the Schur complement of a Laplacian is a Laplacian
    for k in range(3):  # any loads on kept nodes (radiation on them too): exact to round-off
        Q = np.zeros(net.n)
        Q[rad] = rng.uniform(-1.0, 3.0, len(rad))
        case = LoadCase(f"c{k}", Q, net.T)
        d = solve_network(net, case)
        r = solve_network(red.reduced, LoadCase("r", Q[red.remaining], net.T[red.remaining]))
        assert np.abs(red.recover(r.T, Q_suppressed=np.zeros(len(supp))) - d.T).max() < 1e-10
    # RA and CE post-processing from the recovered field agree with the detailed field
    assert abs(recomputed_average(net, red.recover(r.T, np.zeros(len(supp))), net.numbers[3:9])
               - recomputed_average(net, d.T, net.numbers[3:9])) < 1e-10
    ce = conductive_exchange(net, d.T, net.numbers[:5], net.numbers[5:10])
    i = np.arange(5)
    j = np.arange(5, 10)
    assert abs(ce - sum(net.GL[a, b] * (d.T[a] - d.T[b]) for a in i for b in j)) < 1e-12


def test_tmrt_groups_sum_couplings_and_refuses_radiative_suppression():
    net, supp, rad, _ = random_network()
    red = tmrt_reduce(net, suppress=net.numbers[supp], groups=[net.numbers[rad[:4]]], capacitance="summed",
                      filter_threshold=0.01)
    assert red.reduced.n == net.n - len(supp) - 3
    assert abs(red.reduced.C.sum() - net.C.sum()) < 1e-9
    g = red.labels[rad[0]]
    assert (red.labels[rad[:4]] == g).all()
    assert red.reduced.numbers[g] == net.numbers[rad[:4]].min()
    with pytest.raises(Fem2TmmError, match="radiative couplings"):
        tmrt_reduce(net, suppress=net.numbers[rad[:2]])
    with pytest.raises(Fem2TmmError, match="boundary"):
        tmrt_reduce(net, suppress=net.numbers[[0]])


# --------------------------------------------------------------------------------------------------- readers
ESATAN_DECK = """$MODEL TEST
# a hand-written deck exercising constants, ranges and comments
$NODES
D1 = 'plate 1', T = 20.0, C = RHOC * 1.0, A = 0.1, EPS = 0.8, QI = 2.0;
D2 = 'plate 2', T = 20.0, C = RHOC * 2.0D0, A = 0.1, EPS = 0.8;
D3 = 'plate; 3', T = 20.0,
     C = 0.0;                      # arithmetic node, statement on two lines
X4 = 'inactive', T = 0.0;
B99 = 'SPACE', T = -269.0;
B98 = 'IF', T = TIF;
$CONDUCTORS
GL(1, 2) = G12;
GL(2:3, 98) = 0.5 * G12;
GL(1, 4) = 7.0;
GR(1:2, 99) = 0.1 * 0.8;
$CONSTANTS
$REAL
G12 = 1.5;
RHOC = 900.0 * 2.7;
TIF = 10.0 + 5.0;
$VARIABLES1
QI2 = 3.0;
$EXECUTION
SOLVFM;
$ENDMODEL
"""


def test_esatan_reader_constants_ranges_and_kinds(tmp_path):
    p = tmp_path / "m.esatan"
    p.write_text(ESATAN_DECK)
    net = read_esatan(p)
    assert list(net.numbers) == [1, 2, 3, 4, 99, 98] and list(net.kind) == ["D", "D", "D", "X", "B", "B"]
    assert net.labels[2] == "plate; 3" and net.C[1] == pytest.approx(2 * 2430.0) and net.C[2] == 0.0
    assert net.T[5] == pytest.approx(15.0 + KELVIN) and list(net.QI[:2]) == [2.0, 3.0]
    GL = net.GL.toarray()
    assert GL[0, 1] == 1.5 and GL[1, 5] == 0.75 and GL[2, 5] == 0.75 and GL[0, 3] == 7.0
    assert net.GR[0, 4] == pytest.approx(0.08) and net.GR[1, 4] == pytest.approx(0.08)
    act = net.active()
    assert act.n == 5 and any("inactive" in s for s in act.notes)
    # steady state by hand: node 3 is arithmetic between 2 and the interface
    sol = solve_network(act)
    assert abs(sol.H.sum() - 5.0) < 1e-9


@pytest.mark.parametrize("line, bad, match", [
    (5, "D2 = 'plate 2', T = 20.0, C = NOPE;", "unknown constant"),
    (12, "GL(1, 77) = G12;", "undefined node"),
    (12, "GF(1, 2) = 1.0;", "GL and GR"),
    (5, "D2 = 'plate 2', T = 20.0, COLOUR = 3;", "unknown attribute"),
])
def test_esatan_reader_errors_name_file_and_line(tmp_path, line, bad, match):
    lines = ESATAN_DECK.splitlines()
    lines[line - 1] = bad
    p = tmp_path / "bad.esatan"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(Fem2TmmError, match=rf"bad\.esatan:{line}: .*{match}"):
        read_esatan(p)


PLAIN_DECK = """$MODEL PLAIN
$NODES
D1 = 'a', T = 20.0, C = 1.0, A = 0.1, EPS = 0.8;
D2 = 'b', T = 20.0, C = 1.0, A = 0.1, EPS = 0.8;
D3 = 'c', T = 20.0, C = 1.0, A = 0.1, EPS = 0.8;
B99 = 'SPACE', T = -269.0;
B98 = 'held', T = 20.0;
$CONDUCTORS
# plain conductors, as fem2tmm writes them
GL(1, 2) = 1.5;
GL(2, 3) = -0.25;
GL(3, 98) = 2.0;
GR(1, 99) = 0.08;
GR(2, 99) = 0.07;
$CONSTANTS
$REAL
HEATER = 10.0;
$VARIABLES1
QI1 = 0.25 * HEATER;
QI3 = 0.75 * HEATER;
$ENDMODEL
"""


def test_a_deck_read_again_with_its_constants_edited_reads_as_a_fresh_read(tmp_path):
    # the validity range reads the same deck at every state, its constants edited: the second read reuses the parse of
    # the last plain $CONDUCTORS block read (lpm.esatan._LAST_CONDUCTORS), and must read what a fresh read reads
    from fem2tmm.lpm import esatan

    def fresh(path):
        esatan._LAST_CONDUCTORS[0] = None
        return read_esatan(path)

    def same(a, b):
        for k in ("numbers", "T", "C", "A", "eps", "QI"):
            assert np.array_equal(getattr(a, k), getattr(b, k)), k
        assert (a.GL != b.GL).nnz == 0 and (a.GR != b.GR).nnz == 0

    p = tmp_path / "m.esatan"
    p.write_text(PLAIN_DECK)
    first = fresh(p)
    assert esatan._LAST_CONDUCTORS[0] is not None  # kept: every conductor plain
    edited = tmp_path / "e.esatan"
    edited.write_text(PLAIN_DECK.replace("HEATER = 10.0;", "HEATER = 40.0;").replace("T = -269.0", "T = -100.0"))
    again = read_esatan(edited)
    assert again.QI[0] == 10.0 and again.QI[2] == 30.0 and first.QI[0] == 2.5
    same(again, fresh(edited))
    # a conductor edited, or the block moved by a line: parsed again
    read_esatan(p)
    moved = tmp_path / "moved.esatan"
    moved.write_text(PLAIN_DECK.replace("GL(2, 3) = -0.25;", "GL(2, 3) = -0.5;"))
    assert read_esatan(moved).GL[1, 2] == -0.5
    for lines, at in ((1, 12), (2, 13)):  # node 98 gone, the same block at line 12 (reused) or moved to line 13
        read_esatan(p)
        gone = tmp_path / f"gone{lines}.esatan"
        gone.write_text(PLAIN_DECK.replace("B98 = 'held', T = 20.0;", "\n".join(["# no held node"] * lines)))
        with pytest.raises(Fem2TmmError, match=rf"gone{lines}\.esatan:{at}: conductor to undefined node\(s\) 98"):
            read_esatan(gone)
    # a block with a general conductor is not kept
    general = tmp_path / "g.esatan"
    general.write_text(PLAIN_DECK.replace("GL(1, 2) = 1.5;", "GL(1, 2) = HEATER / 10;"))
    esatan._LAST_CONDUCTORS[0] = None
    assert read_esatan(general).GL[0, 1] == 1.0 and esatan._LAST_CONDUCTORS[0] is None


@pytest.mark.parametrize("edit", [
    None,  # as fem2tmm writes it: read at once (lpm.esatan._plain_block)
    ("GL(1, 2) = 1.5;\nGL(2, 3) = -0.25;", "GL(1, 2) = 1.5; GL(2, 3) = -0.25;"),  # two on a line
    ("GL(2, 3) = -0.25;", "GL(2, 3) = -0.25"),  # not terminated
    ("GL(2, 3) = -0.25;", "GL(2, 3) = nan;"),  # not a number
    ("GL(2, 3) = -0.25;", "GL (2, 3) = -0.25;"),
    ("GL(2, 3) = -0.25;", "gl(2, 3) = -.25e0;  # lower case"),
    ("GL(2, 3) = -0.25;", "GL(2,\n 3) = -0.25;"),  # over two lines
    ("# plain conductors, as fem2tmm writes them", "# GL(7, 8) = 1; a conductor in a comment"),
    ("GL(2, 3) = -0.25;", "GL(2, 3) = -0.25; # 5; 6"),
    ("GL(2, 3) = -0.25;", "GL(2, 3) = 0.25 * 2;"),
    ("GL(2, 3) = -0.25;", "GL(2:3, 98) = 1.0;"),
    ("GL(2, 3) = -0.25;", "GL(2, 97) = 1.0;"),  # an undefined node: the same message and line
    ("GL(2, 3) = -0.25;", "GL(2.0, 3) = -0.25;"),  # a node number that is not an integer
    ("GL(2, 3) = -0.25;", "GL(2, 3) = -0.25;\n$REAL"),
])
def test_a_plain_conductor_block_read_at_once_reads_as_statement_by_statement(tmp_path, monkeypatch, edit):
    """The $CONDUCTORS block of plain conductors is read at once by NumPy (5·10⁵ conductors 1.88 -> 0.61 s); any
    block that is not exactly that goes statement by statement.  Either way the network, or the error with its file
    and line, is the one the statement-by-statement reader gives."""
    from fem2tmm.lpm import esatan

    text = PLAIN_DECK if edit is None else PLAIN_DECK.replace(*edit)
    path = tmp_path / "m.esatan"
    path.write_text(text)

    def read(at_once):
        esatan._LAST_CONDUCTORS[0] = None
        if not at_once:
            monkeypatch.setattr(esatan, "_plain_block", lambda block: None)
        try:
            return read_esatan(path)
        except Fem2TmmError as exc:
            return str(exc)
        finally:
            monkeypatch.undo()

    a, b = read(True), read(False)
    if isinstance(b, str):
        assert a == b
        return
    for k in ("numbers", "T", "C", "A", "eps", "QI"):
        assert np.array_equal(getattr(a, k), getattr(b, k)), k
    assert (a.GL != b.GL).nnz == 0 and (a.GR != b.GR).nnz == 0
    block = text.split("$CONDUCTORS\n")[1].split("$CONSTANTS")[0]
    assert (esatan._plain_block(block) is not None) == (edit is None or edit[1].startswith("gl(")), edit


SINDA_DECK = """C hand-written SINDA/FLUINT deck
HEADER CONTROL DATA, GLOBAL
      SIGMA  = 5.670374419e-8
      ABSZRO = -273.15
      UID    = SI
HEADER REGISTER DATA
      GC = 0.5
HEADER NODE DATA, SUB
      GEN 1, 3, 1, 20.0, 100.0    $ plate
      -99, -269.0, 0.0            $ SPACE
      -98, 15.0, 0.0              $ IF
HEADER CONDUCTOR DATA, SUB
      GEN 1, 2, 1, 1, 1, 2, 1, 2*GC
      3, 3, 98, GC
      -4, 1, SUB.99, 0.08
      -5, 3, 99, 0.08
HEADER SOURCE DATA, SUB
      1, 2.0, 2, 3.0
END OF DATA
"""


def test_sinda_reader_gen_radiation_and_sources(tmp_path):
    p = tmp_path / "m.sinda"
    p.write_text(SINDA_DECK)
    net = read_network(p)
    assert list(net.numbers) == [1, 2, 3, 98, 99] and list(net.kind) == ["D", "D", "D", "B", "B"]
    GL = net.GL.toarray()
    assert GL[0, 1] == 1.0 and GL[1, 2] == 1.0 and GL[2, 3] == 0.5
    assert net.GR[0, 4] == pytest.approx(0.08) and net.GR[2, 4] == pytest.approx(0.08)
    assert list(net.QI) == [2.0, 3.0, 0.0, 0.0, 0.0] and net.T[3] == pytest.approx(15.0 + KELVIN)
    assert abs(solve_network(net).H.sum() - 5.0) < 1e-9
    bad = SINDA_DECK.replace("      -5, 3, 99, 0.08", "      -5, 3, 99")
    q = tmp_path / "bad.sinda"
    q.write_text(bad)
    with pytest.raises(Fem2TmmError, match=r"bad\.sinda:16: conductor data needs"):
        read_sinda(q)


# ----------------------------------------------------------------------------------------------- round trip
@pytest.fixture(scope="module")
def fin_out(tmp_path_factory):
    from fem2tmm.pipeline import run

    out = tmp_path_factory.mktemp("lpm_fin") / "out"
    mesh = meshes.annulus(0.05, 0.15, 6, 36)
    case = make_case(
        [{"name": "fin", "groups": ["annulus"], "material": "al", "thickness": 1e-3, "front": "black",
          "back": "black", "super_nodes": 8}],
        [{"kind": "temperature", "groups": ["inner"], "value": 20.0},
         {"kind": "flux", "groups": ["annulus"], "value": 30.0}],
        environment={"sink_temperature": -100.0}, radiation={"rays_per_face": 200}, reference={"detailed": False})
    return run(case, out=out, mesh=mesh, quiet=True)


def test_round_trip_of_fem2tmm_decks_gives_the_same_reduced_solution(fin_out):
    T_ref = fin_out.reduced.solution.T
    sols = {}
    for name in ("reduced.npz", "model.esatan", "model.sinda"):
        net = read_network(fin_out.out / name)
        sol = solve_network(net.active())
        sols[name] = sol.T[:-1]  # the last node is space (boundary)
        assert np.abs(sols[name] - T_ref).max() < 1e-9, name
    # the decks carry the exact reduction's negative GL (kept, not filtered)
    net = read_network(fin_out.out / "model.esatan")
    assert (net.GL.data < 0).sum() == 2 * fin_out.summary["reduced"]["negative_links"]


# ------------------------------------------------------------------------------------------------------ CLI
def ten_node_coordinates():
    """Node positions (m) of nodes 1-8 whose distances are the printed D (the printed D is realisable in 3-D:
    least squares from a fixed start reaches it to 1e-9 m)."""
    from scipy.optimize import least_squares

    i, j = np.nonzero(D_UPPER[:8, :8])

    def f(x):
        X = x.reshape(8, 3)
        return np.linalg.norm(X[i] - X[j], axis=1) - D_UPPER[i, j]

    sol = least_squares(f, np.random.default_rng(0).uniform(0.0, 0.1, 24), xtol=1e-15, ftol=1e-15)
    assert np.abs(sol.fun).max() < 1e-6
    return sol.x.reshape(8, 3) + 0.1  # away from the origin (ESATAN's "no position")


@pytest.fixture(scope="module")
def ten_deck(tmp_path_factory):
    from fem2tmm.export.esatan import write_esatan
    from fem2tmm.lpm.driver import to_deck

    d = tmp_path_factory.mktemp("ten")
    net = ten_node_network()
    write_esatan(d / "ten.esatan", to_deck(net, net.T), title="ten")
    X = ten_node_coordinates()
    (d / "nodes.csv").write_text("node,x,y,z\n" + "".join(f"{k + 1},{x},{y},{z}\n" for k, (x, y, z) in enumerate(X)))
    return d


def test_cli_network_reduce_writes_decks_summary_and_report(ten_deck, tmp_path, capsys):
    import json

    from fem2tmm.cli import main

    out = tmp_path / "out"
    case = tmp_path / "net.toml"
    case.write_text('[criteria]\ndelta_max = 3.0\n[[load_cases]]\nname = "nominal"\n'
                    '[[load_cases]]\nname = "hot"\npower = { 5 = 12.0 }\nboundary = { 9 = 40.0 }\n')
    rc = main(["network", "reduce", str(ten_deck / "ten.esatan"), "--case", str(case), "--coordinates",
               str(ten_deck / "nodes.csv"), "--pf", "0.2", "--dtmax", "10", "--out", str(out), "--quiet"])
    assert rc == 0
    s = json.loads((out / "summary.json").read_text())
    # the writer adds an uncoupled SPACE node (11): it stays a boundary node of its own
    assert s["groups"] == [[1, 2], [3, 4, 6, 7, 8], [5], [9], [10], [11]]
    assert s["ratio"] == pytest.approx(0.625) and set(s["criteria"]["cases"]) == {"nominal", "hot"}
    red_T = s["reduced"]["temperatures_C"]
    assert set(red_T) == {"1", "3", "5", "9", "10", "11"}
    assert abs(red_T["5"] - TRED_PRINTED[2]) < TOL_T
    assert abs(s["reduced"]["heat_flows_W"]["9"]["conductive"] - HRED_PRINTED["cb"]) < TOL_H
    assert abs(s["cases"]["hot"]["reduced"]["temperatures_C"]["9"] - 40.0) < 1e-9
    # the hot case: 12 W instead of 10 W leave through the boundaries
    hot = s["cases"]["hot"]["detailed"]["heat_flows_W"]
    assert abs(sum(v["total"] for v in hot.values()) - 12.0) < 1e-9
    assert (out / "sweep.png").is_file() and "sweep.png" in (out / "report.html").read_text()
    # the reduced decks read back and solve to the reduced temperatures of the first case
    for name in ("model.esatan", "model.sinda"):
        net = read_network(out / name)
        sol = solve_network(net.active())
        got = dict(zip(net.numbers.tolist(), sol.T - KELVIN))
        assert all(abs(got[int(k)] - v) < 1e-6 for k, v in red_T.items()), name
    # a folder fem2tmm wrote (its .fem2tmm marker) is replaced; one holding a file of the user's is refused
    assert (out / ".fem2tmm").is_file()
    # without --coordinates nothing is sized, so nothing would be reduced: refused (exit 2), naming the nodes.csv
    # beside the deck, before anything is written
    before = (out / "summary.json").read_text()
    assert main(["network", "reduce", str(ten_deck / "ten.esatan"), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "no node has a position" in err and f"--coordinates {ten_deck / 'nodes.csv'}" in err, err
    assert (out / "summary.json").read_text() == before
    assert main(["network", "reduce", str(ten_deck / "ten.esatan"), "--coordinates", str(ten_deck / "nodes.csv"),
                 "--out", str(out), "--quiet"]) == 0
    (out / "mine.txt").write_text("user file")
    assert main(["network", "reduce", str(ten_deck / "ten.esatan"), "--out", str(out), "--quiet"]) == 2
    assert (out / "mine.txt").read_text() == "user file"


def test_cli_bad_deck_exits_2_naming_file_and_line(tmp_path, capsys):
    from fem2tmm.cli import main

    p = tmp_path / "bad.esatan"
    p.write_text(ESATAN_DECK.replace("GL(1, 4) = 7.0;", "GL(1, 4) = 7.0 +;"))
    assert main(["network", "reduce", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert f"{p}:14:" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_cli_tmrt_case_with_ra_and_ce_post_processing(tmp_path):
    import json

    from fem2tmm.export.esatan import write_esatan
    from fem2tmm.cli import main
    from fem2tmm.lpm.driver import to_deck

    net, supp, rad, _ = random_network()
    deck = tmp_path / "rnd.esatan"
    write_esatan(deck, to_deck(net, net.T), title="rnd")
    case = tmp_path / "net.toml"
    nums = net.numbers
    case.write_text(
        '[reduction]\nmethod = "tmrt"\n'
        f"[tmrt]\nsuppress = {nums[supp].tolist()}\n"
        f'[[post.ra]]\nname = "inner"\nnodes = {nums[supp[:6]].tolist()}\n'
        f'[[post.ce]]\nname = "a_to_b"\nfrom = {nums[supp[:5]].tolist()}\nto = {nums[supp[5:12]].tolist()}\n')
    out = tmp_path / "out"
    assert main(["network", "reduce", str(deck), "--case", str(case), "--out", str(out), "--quiet"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["method"] == "tmrt" and s["nodes"]["suppressed"] == len(supp)
    # suppression is exact: RA and CE of suppressed nodes recovered = detailed (round-off of the solves)
    ra, ce = s["post_processing"]["RA_C"]["inner"], s["post_processing"]["CE_W"]["a_to_b"]
    assert abs(ra["recovered"] - ra["detailed"]) < 1e-8 and abs(ce["recovered"] - ce["detailed"]) < 1e-8
    assert s["criteria"]["met"] and s["cases"]["deck"]["criteria"]["max_delta_K"] < 1e-8
    f = np.load(out / "tmrt_factors.npz")
    assert f["PD"].shape == (s["nodes"]["reduced"], len(supp)) and np.allclose(f["TRt"].sum(axis=1), 1.0)
    bad = tmp_path / "bad.toml"
    bad.write_text('[[post.ra]]\nname = "x"\nnodes = [123456]\n')
    assert main(["network", "reduce", str(deck), "--case", str(bad), "--out", str(tmp_path / "o2")]) == 2


def test_esatan_reader_takes_a_transient_deck_at_its_start_time(tmp_path):
    # the shape fem2tmm's transient decks have: doublet arrays read by INTRP1(TIMEM, A) in $VARIABLES1
    p = tmp_path / "tr.esatan"
    p.write_text(ESATAN_DECK.replace("$VARIABLES1\nQI2 = 3.0;\n", """$ARRAYS
    Q1(6) = 0.0, 1.0, 100.0, 5.0, 200.0, 9.0;  # doublets (time, value)
    TTAB1(4) = 0.0, 10.0, 200.0, 30.0;
$VARIABLES1
QI2 = 3.0 + 2.0 * (INTRP1(TIMEM, Q1) - 1.0);
T98 = INTRP1(TIMEM, TTAB1);
""").replace("TIF = 10.0 + 5.0;", "TIF = 10.0 + 5.0;\nTIMEO = 50.0;"))
    net = read_esatan(p)
    # at TIMEO = 50 s: Q1 = 1 + (5 - 1)·50/100 = 3 -> QI2 = 3 + 2·2 = 7 W; TTAB1 = 10 + 20·50/200 = 15 °C
    assert net.QI[1] == pytest.approx(7.0) and net.T[5] == pytest.approx(15.0 + KELVIN)


@pytest.mark.parametrize("what", ["split_top", "_segments"])
def test_cuts_by_str_methods_equal_the_character_scans(what):
    # split_top cuts a text with no parentheses and closed single quotes (a node's attributes, an array's numbers),
    # esatan._segments a deck line with closed single quotes and no double quotes (a node's line), by str methods
    # (expressions.split_quoted); the character scans decide the others.  On 20 000 random texts over the characters
    # that matter, both give the same pieces.
    from fem2tmm.lpm import esatan, expressions

    fast, scan, chars = {"split_top": (expressions.split_top, expressions._split_scan, "ab1 ,,,''\"();="),
                         "_segments": (esatan._segments, esatan._segments_scan, "ab1 ;;''\"#,=")}[what]
    rng = np.random.default_rng(5)
    alphabet = np.array(list(chars))
    for _ in range(20000):
        text = "".join(rng.choice(alphabet, rng.integers(0, 16)))
        assert fast(text) == scan(text), text
    assert expressions.split_top("D1 = 'a, b', T = 2") == ["D1 = 'a, b'", " T = 2"]
    assert esatan._segments("D1 = 'a;b#', T = 2; # c; d") == ["D1 = 'a;b#', T = 2", " "]
