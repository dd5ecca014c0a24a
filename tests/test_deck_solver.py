"""The independent deck reader and solver of the tests (tests/deck_solver.py) against closed forms.

deck_solver shares no code with fem2tmm; these checks make it a reference nobody here chose: the steady two-node
radiator (T2⁴ = Q/(σ GR) + Ts⁴, T1 = T2 + Q/GL), the RC decay (the theta scheme's exact discrete solution
((1 − (1−θ)a)/(1 + θa))ⁿ, a = G h / C, and e^(−G t / C) within the scheme's O(h²) error), a conductance that follows
a node temperature through INTRP1 (a quadratic's root), time tables, named constants and continuation lines.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from deck_solver import DeckError, solve_esatan_steady, solve_esatan_transient

SIGMA = 5.670374419e-8


def write(tmp_path, text: str, name: str = "m.esatan"):
    p = tmp_path / name
    p.write_text(text)
    return p


RADIATOR = """$MODEL RAD
$NODES
    D1 = 'heater', T = 20.0, C = 10.0;
    D2 = 'radiator', T = 0.0, C = 10.0;
    B99 = 'SPACE', T = SINK;
$CONDUCTORS
    GL(1, 2) = GLINK;
    GR(2, 99) = 0.85 *
        0.5;  # eps A, continued over a line
$CONSTANTS
  $REAL
    Q = 10.0;
    GLINK = 2.0 * HALF;
    HALF = 0.25;  # defined after its use
    SINK = -270.0;
  $CONTROL
    STEFAN = 5.670374419e-08;
$INITIAL
$EXECUTION
    CALL SOLVFM;
$VARIABLES1
    QI1 = Q;
$ENDMODEL RAD
"""


@pytest.mark.parametrize("Q,sink", [(10.0, -270.0), (0.0, -100.0), (40.0, -150.0)])
def test_two_node_radiator_matches_the_closed_form(tmp_path, Q, sink):
    T = solve_esatan_steady(write(tmp_path, RADIATOR), edits={"Q": Q, "SINK": sink})
    Ts = sink + 273.15
    T2 = (Q / (SIGMA * 0.425) + Ts**4) ** 0.25
    T1 = T2 + Q / 0.5
    # tolerance: Newton stops at a 1e-9 K correction; round-off of T⁴ ~ 1e-12 relative
    assert T[2] + 273.15 == pytest.approx(T2, abs=1e-8)
    assert T[1] + 273.15 == pytest.approx(T1, abs=1e-8)
    assert T[99] == pytest.approx(sink, abs=1e-12)


def test_an_edit_of_an_undefined_constant_is_refused(tmp_path):
    with pytest.raises(DeckError, match="no constant 'HEATER'"):
        solve_esatan_steady(write(tmp_path, RADIATOR), edits={"HEATER": 0.0})


RC = """$MODEL RC
$NODES
    D1 = 'mass', T = 100.0, C = CAP;
    B2 = 'sink', T = 0.0;
$CONDUCTORS
    GL(1, 2) = 0.5;
$CONSTANTS
    CAP = 50.0;
  $CONTROL
    TIMEO = 0.0;
    TIMEND = 400.0;
    DTIMEI = 10.0;
    OUTINT = 100.0;
$EXECUTION
    CALL {routine};
$ENDMODEL RC
"""


@pytest.mark.parametrize("routine,theta", [("SLCRNC", 0.5), ("SLFWBK", 0.5)])
def test_rc_decay_is_the_theta_scheme_s_discrete_solution(tmp_path, routine, theta):
    times, T = solve_esatan_transient(write(tmp_path, RC.format(routine=routine)), initial="deck")
    a = 0.5 * 10.0 / 50.0
    n = times / 10.0
    discrete = 100.0 * ((1 - (1 - theta) * a) / (1 + theta * a)) ** n
    np.testing.assert_allclose(T[1], discrete, rtol=0, atol=1e-8)  # Newton's 1e-9 K per step, 40 steps
    exact = 100.0 * np.exp(-0.5 * times / 50.0)
    # Crank-Nicolson's global error ~ t h² λ³ / 12 · T: at most 0.08 K here (λ = 0.01 /s, h = 10 s)
    assert np.abs(T[1] - exact).max() < 0.1
    be = solve_esatan_transient(write(tmp_path, RC.format(routine=routine)), initial="deck",
                                scheme="backward-euler")[1][1]
    np.testing.assert_allclose(be, 100.0 * (1 / (1 + a)) ** n, rtol=0, atol=1e-8)


TDEP = """$MODEL TDEP
$NODES
    D1 = 'node', T = 20.0, C = 1.0;
    B2 = 'held', T = 0.0;
$CONDUCTORS
    GL(1, 2) = 1.0;
$CONSTANTS
    POWER = 30.0;
$ARRAYS
  $REAL
    KOFT(4) = -100.0, 0.0,
              100.0, 2.0;  # continued
$VARIABLES1
    GL(1, 2) = INTRP1(T1, KOFT) + 1.0;
    QI1 = POWER * INTRP1(TIMEM,
        QTAB);
$ARRAYS
    QTAB(4) = 0.0, 1.0, 100.0, 1.0;
$EXECUTION
    CALL SOLVFM;
$ENDMODEL TDEP
"""


def test_a_conductance_following_a_node_temperature(tmp_path):
    # G(T) = 2 + 0.01 T (T in degC, within the table), Q = G T: 0.01 T² + 2 T − Q = 0
    T = solve_esatan_steady(write(tmp_path, TDEP))
    root = (-2 + math.sqrt(4 + 4 * 0.01 * 30.0)) / 0.02
    assert T[1] == pytest.approx(root, abs=1e-8)
    T = solve_esatan_steady(write(tmp_path, TDEP), edits={"POWER": 0.0})
    assert abs(T[1]) < 1e-9
