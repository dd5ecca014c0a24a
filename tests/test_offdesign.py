"""Issue 41: the single-case deck holds where the engineer takes it (a fast version of ``fem2tmm bench offdesign``).

The L-bracket of issue 41 on a coarser mesh (24 x 24 quads per panel, 60 super nodes): its ``model.esatan``, written
by a default single-case run, is edited as a user would (HEATER 0 and 40 W, the sink -100 °C), read back from the
deck alone (fem2tmm.lpm), solved, recovered with ``reduced.npz``'s recovery and compared with each state's own
detailed reference (a fresh run of that state).  The yardstick nobody here chose is the thesis network at the same
count, edited and recovered likewise (issue 41's acceptance: "better than the thesis network at the same count"),
and the detailed model's heat books (issue 41: within 1 % at the design state, 2 % at the edited states).
"""

from __future__ import annotations

import pytest

import numpy as np

from benchmarks.offdesign import _err, deck_books, deck_state, detailed_books, edit_deck, run_bracket

N_QUADS, N_SN = 24, 60
STATES = [(10.0, -270.0), (0.0, -270.0), (40.0, -270.0), (10.0, -100.0)]


@pytest.fixture(scope="module")
def decks(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("offdesign")
    run_bracket(N_SN, n=N_QUADS, out=tmp / "default", detailed=False)
    run_bracket(N_SN, n=N_QUADS, out=tmp / "thesis", detailed=False, thesis=True)
    return tmp


@pytest.mark.parametrize("heater, sink", STATES)
def test_the_edited_deck_beats_the_thesis_network_and_its_books_add_up(decks, heater, sink):
    ref = run_bracket(N_SN, heater, sink, n=N_QUADS, verify=False)[0]  # its detailed reference
    T_ref = ref.detailed.solution.T
    field, net, T, _ = deck_state(decks / "default", heater, sink)
    rms, mx = _err(ref.model, field, T_ref)
    t_field, *_ = deck_state(decks / "thesis", heater, sink)
    t_rms, t_mx = _err(ref.model, t_field, T_ref)
    # measured 2026-12-04 with equal areas (the default since 2026-12-07 puts smaller super nodes at the heater and
    # passes the same bounds), RMS / max K, this network vs the thesis network (reference noise 0.01-0.07 K RMS):
    # design 0.32/1.18 vs 9.8/41.2; heater 0 W 2.79/5.98 vs 10.5/37.6; 40 W 1.36/6.62 vs 30.1/276.  On main
    # 3955e37 the temperatures pass and the books below fail (held edge 19.9 W against 38.3 W).  Sink -100 C
    # (2026-12-06): 1.24/5.42 vs 8.29/58.9; before emission_floor_links 4 super nodes had a negative effective
    # emitting area and the deck ran to 17.2/142 (the deck at 100 super nodes on the full mesh had no solution).
    # Its held-edge book below is 31.28 W against 31.92 W: -2.0 %, at the bound's edge (issue 41: 2 %); it is the
    # network's conduction from the held edge (the neighbouring super nodes' temperatures), not its loads
    assert rms < t_rms and mx < t_mx, (rms, mx, t_rms, t_mx)
    books, detailed = deck_books(net, T), detailed_books(ref)
    design = (heater, sink) == (10.0, -270.0)
    # the heat the held edge gives the structure, from the deck's own terms (its GL and its GR to space)
    assert books["from_held"] == pytest.approx(detailed["from_held"], rel=0.01 if design else 0.02), (books, detailed)
    # the same books from the deck read and solved by the tests' own reader (tests/deck_solver.py, no fem2tmm
    # import): every category within issue 41's bound of the detailed model's (1 % at the design state, 2 % at the
    # edited states).  Measured 2026-12-06: applied 10 / 0 / 40 / 10 W exact (the hot-spot node takes the heater's
    # in-cluster share, 15.5 % here; before it the deck applied 8.45 W of 10), held edge -0.007 % / +0.1 % / -0.2 % /
    # -2.0 %, to space equal to applied + held (steady)
    ind = independent_books(decks / "default", heater, sink)
    for k in ("applied", "from_held", "to_space"):
        assert ind[k] == pytest.approx(detailed[k], rel=0.01 if design else 0.02, abs=1e-9), (k, ind, detailed)
    assert ind["from_held"] == pytest.approx(books["from_held"], rel=1e-6)  # the two readers agree
    if sink == -270.0:  # the SINDA deck's books, its HEATER register edited, equal the ESATAN deck's
        sinda = independent_books(decks / "default", heater, sink, sinda=True)
        for k in ("applied", "from_held", "to_space"):
            assert sinda[k] == pytest.approx(ind[k], rel=1e-6, abs=1e-9), (k, sinda, ind)


def independent_books(folder, heater: float, sink: float, sinda: bool = False) -> dict:
    """Heat books (W) of the design deck of ``folder`` edited to (heater W, sink °C), read and solved by
    tests/deck_solver.py: applied (Σ QI of the diffusion nodes), from the held nodes (their net outflow through
    every GL and GR of the deck, to space included) and to space (every GR to the boundary node labelled SPACE).
    ``sinda``: the SINDA deck, its HEATER register edited (the sink as written)."""
    from deck_solver import Network, _steady, read_esatan, read_sinda

    if sinda:
        net = Network(read_sinda(folder / "model.sinda"), {"HEATER": heater})
    else:
        path = folder / "edited_independent.esatan"
        path.write_text(edit_deck((folder / "model.esatan").read_text(), heater, sink))
        net = Network(read_esatan(path))
    t0 = net.c.get("TIMEO", 0.0)
    T = _steady(net, t0, net.T_start)
    Q, _, GL, GR = net.evaluate(t0, T)
    space = np.array([str(lab).strip("'").upper() == "SPACE" for lab in net.m.labels])
    held = net.m.boundary & ~space
    sigma = net.stefan
    GL, GR = GL.toarray(), GR.toarray()
    out_of = GL * (T[:, None] - T[None, :]) + sigma * GR * (T[:, None] ** 4 - T[None, :] ** 4)  # i -> j, W
    return {"applied": float(Q[~net.m.boundary].sum()), "from_held": float(out_of[held][:, ~held].sum()),
            "to_space": float(out_of[~space][:, space].sum())}


def test_a_network_that_emits_nothing_gets_no_coupling_to_space_from_round_off():
    """effective_emission where nothing emits (ε = 0: H = 0, no applied load, every node at the held temperature):
    each node's balance Q − K̃ T is the round-off of K̃ T (zero row sums only to the last bit), and a coupling to
    space made of it (1e-14 m²) gave a transient's books spurious watts (7.7e-9 relative, tests/test_robustness.py
    ``radiation_aware_transient_round_off``).  The coupling must be exactly 0."""
    import numpy as np

    from fem2tmm.reduce.radiative import effective_emission

    rng = np.random.default_rng(3)
    W = rng.uniform(0.01, 1.0, (6, 6))
    K = -(W + W.T)
    K[np.diag_indices(6)] = 0.0
    K[np.diag_indices(6)] = -K.sum(axis=1)
    T = np.full(6, 273.15 + 1e-3 * 7)  # uniform: K̃ T is 0 up to round-off
    assert np.any(K @ T != 0.0)  # the round-off the rule is for
    fixed = np.zeros(6, bool)
    fixed[0] = True
    e, (x, y) = effective_emission(K, np.zeros(6), None, fixed, T, 356.95, np.zeros(6), np.zeros(6), np.zeros(6))
    assert np.all(e == 0.0) and np.all(y == 0.0)


def test_a_super_node_short_of_heat_is_fed_from_the_held_edge_and_the_design_state_stays_exact():
    """emission_floor_links on a 4-node chain: held node 0 (293 K), node 3 pulled below its own emission by a
    negative K̃ link (what the dense reduction gives a cold cluster far from the heater, issue 41)."""
    import numpy as np

    from fem2tmm.constants import SIGMA
    from fem2tmm.reduce.radiative import EMISSION_MIN_FRACTION, effective_emission, emission_floor_links

    T = np.array([293.0, 200.0, 120.0, 80.0])
    K = np.array([[0.05, -0.05, 0.0, 0.0], [-0.05, 0.07, -0.03, 0.01], [0.0, -0.03, 0.04, -0.01],
                  [0.0, 0.01, -0.01, 0.0]])
    K[np.diag_indices(4)] -= K.sum(axis=1)  # zero row sums, as K̃
    Q, fixed, g = np.array([0.0, 2.0, 0.2, 0.0]), np.array([True, False, False, False]), np.full(4, 0.05)
    H = np.full(4, 0.01)
    e0, _ = effective_emission(K, Q, None, fixed, T, 3.0, H, np.zeros(4), g)
    assert e0[3] < 0  # the case the links are for
    dK = emission_floor_links(K, Q, None, fixed, T, 3.0, g)
    assert np.allclose(dK.sum(axis=1), 0.0) and np.allclose(dK, dK.T)
    e, _ = effective_emission(K + dK, Q, None, fixed, T, 3.0, H, np.zeros(4), g)
    assert e[3] == pytest.approx(EMISSION_MIN_FRACTION * g[3], rel=1e-9)  # fed up to the floor, not beyond
    assert np.allclose(e[1:3], e0[1:3])  # the others untouched (their heat came from the held node)
    # the design state still closes every free node's balance, by an independent sum of the flows
    flow = Q - (K + dK) @ T - SIGMA * e * (T**4 - 3.0**4)
    assert np.abs(flow[~fixed]).max() < 1e-12


def test_a_super_node_short_of_heat_is_fed_along_its_own_links_when_asked_and_the_design_state_stays_exact():
    """emission_floor_links, ``source = "linked"``, on the chain above: node 3's only conducting link from a warmer
    node is node 2's (0.01 W/K, 40 K warmer: 0.4 W); that link alone grows, by 1 + need / 0.4 W, and the held node
    gives nothing (the rule the satellite's short bars keep, docs/design-notes.md)."""
    import numpy as np

    from fem2tmm.constants import SIGMA
    from fem2tmm.reduce.radiative import EMISSION_MIN_FRACTION, effective_emission, emission_floor_links

    T = np.array([293.0, 200.0, 120.0, 80.0])
    K = np.array([[0.05, -0.05, 0.0, 0.0], [-0.05, 0.07, -0.03, 0.01], [0.0, -0.03, 0.04, -0.01],
                  [0.0, 0.01, -0.01, 0.0]])
    K[np.diag_indices(4)] -= K.sum(axis=1)
    Q, fixed, g = np.array([0.0, 2.0, 0.2, 0.0]), np.array([True, False, False, False]), np.full(4, 0.05)
    r3 = Q[3] - K[3] @ T  # node 3's balance: what it must lose to space (negative: short of heat)
    need = SIGMA * EMISSION_MIN_FRACTION * g[3] * (T[3] ** 4 - 3.0**4) - r3
    assert r3 < 0 and need > 0
    dK = emission_floor_links(K, Q, None, fixed, T, 3.0, g, source="linked")
    assert np.allclose(dK.sum(axis=1), 0.0) and np.allclose(dK, dK.T)
    off = dK - np.diag(np.diag(dK))
    assert np.count_nonzero(off) == 2  # the 2-3 link only: not the held node, not the negative 1-3 link
    assert -dK[3, 2] == pytest.approx(0.01 * need / (0.01 * (T[2] - T[3])), rel=1e-12)
    assert -dK[3, 2] * (T[2] - T[3]) == pytest.approx(need, rel=1e-12)  # the flow it adds is what node 3 lacked
    e, _ = effective_emission(K + dK, Q, None, fixed, T, 3.0, np.full(4, 0.01), np.zeros(4), g)
    assert e[3] == pytest.approx(EMISSION_MIN_FRACTION * g[3], rel=1e-9)
    flow = Q - (K + dK) @ T - SIGMA * e * (T**4 - 3.0**4)
    assert np.abs(flow[~fixed]).max() < 1e-12


def test_the_deck_edited_to_a_sink_at_the_held_edges_temperature_is_solved_and_verified(tmp_path):
    """The coarse bracket at 30 super nodes: its deck, edited to a sink at 20 °C (the held edge's temperature: a
    thermal-vacuum test at ambient), stalls a Newton started from the deck's design temperatures (down to ~60 K);
    fem2tmm's deck solver starts again from a uniform field, and its solution is the independent reader's
    (tests/deck_solver.py, its own Newton from the deck's start).  Before 2026-12-06 22:40 UTC the validity range
    recorded that state as without a solution; now it is verified (0.66 K RMS, measured)."""
    from deck_solver import Network, _steady, read_esatan as independent_read

    from fem2tmm.errors import Fem2TmmError
    from fem2tmm.lpm import read_esatan
    from fem2tmm.lpm.solve import solve_network, steady_problem
    from fem2tmm.solve.steady import solve_steady

    # equal areas: the clusters of the deck whose Newton stalls (with the default's smaller super nodes at the heater,
    # allocation = "loads", the same edited deck converges from its design temperatures)
    res = run_bracket(30, n=N_QUADS, out=tmp_path / "deck", allocation="area")[0]
    v = res.summary["reduced"]["verified"]
    st = next(s for s in v["states"] if s["label"] == "sink high")
    assert st["values"]["sink"] == pytest.approx(20.0) and st["rms_K"] is not None and not v["failed"], st
    path = tmp_path / "edited.esatan"
    path.write_text(edit_deck((tmp_path / "deck" / "model.esatan").read_text(), 10.0, 20.0))
    net = read_esatan(path)
    with pytest.raises(Fem2TmmError):  # the start the fallback is for
        solve_steady(steady_problem(net, net.default_case()), T0=np.where(net.T > 1.0, net.T, 293.15), tol=1e-10)
    T = solve_network(net).T
    ind = Network(independent_read(path))
    T_ind = _steady(ind, ind.c.get("TIMEO", 0.0), np.full(len(ind.T_start), 293.15))
    labels = [str(x).strip("'").upper() for x in ind.m.labels]
    by = {str(x).upper(): t for x, t in zip(net.labels, T)}
    assert np.allclose([by[x] for x in labels], T_ind, atol=1e-6)
    # physically no node is colder than the sink and the held edge (both 20 °C); the 30-super-node network's exact
    # condensation (negative GL) puts one 2.51 K below them (measured 2026-12-06): that departure is in its verified
    # RMS above, and it must not grow
    assert T_ind.min() > 293.15 - 3.0


def test_a_sink_at_absolute_zero_is_read_back_solved_and_verified(tmp_path):
    """A sink of −273.15 °C (the case file accepts it; deep space is often idealised so): the deck's space node sits
    at 0 K.  Before 2026-12-06 23:10 UTC fem2tmm's own deck reader refused a boundary at 0 K, so the deliverable
    check failed and the run's range was UNVERIFIED (the campaign's 3 × 3 plate at a 0 K sink).  Now the deck reads
    back and solves, and its solution is the independent reader's (tests/deck_solver.py)."""
    from deck_solver import Network, _steady, read_esatan as independent_read

    from fem2tmm.lpm import read_esatan
    from fem2tmm.lpm.solve import solve_network

    res = run_bracket(30, sink_C=-273.15, n=N_QUADS, out=tmp_path / "deck")[0]
    red = res.summary["reduced"]
    assert not (red.get("delivered") or {}).get("error"), red.get("delivered")
    assert red["verified"]["status"] == "verified", red["verified"]
    path = tmp_path / "deck" / "model.esatan"
    net = read_esatan(path)
    space = [i for i, x in enumerate(net.labels) if str(x).upper() == "SPACE"]
    assert len(space) == 1 and net.T[space[0]] == pytest.approx(0.0, abs=1e-9)
    T = solve_network(net).T
    ind = Network(independent_read(path))
    T_ind = _steady(ind, ind.c.get("TIMEO", 0.0), ind.T_start)
    by = {str(x).upper(): t for x, t in zip(net.labels, T)}
    assert np.allclose([by[str(x).strip("'").upper()] for x in ind.m.labels], T_ind, atol=1e-6)
    # the exported network against the detailed model at that state: 0.32 K RMS measured 2026-12-06; the bound is
    # issue 42's 1 K at 300 super nodes, held here at 30
    assert res.summary["accuracy"]["rms_K"] < 1.0


def test_the_report_says_where_the_default_put_smaller_super_nodes(decks):
    # the default's allocation ("loads", since 2026-12-07): the coarse bracket's 0.2 m heater patch (16 of 1 152
    # quads, 1.4 % of the part) draws smaller super nodes; the report names it, its footprint and its reach
    import json

    al = json.loads((decks / "default" / "summary.json").read_text())["reduced"]["clustering"]["allocation"]
    assert al["method"] == "loads" and al["heater"]["share"] == pytest.approx(16 / 1152, rel=1e-9)
    page = (decks / "default" / "report.html").read_text()
    assert "smaller super nodes around the concentrated loads" in page
    assert "heater&#x27; (0.04 m², 1.4% of its parts)" in page or "heater' (0.04 m², 1.4% of its parts)" in page
    assert f"{al['heater']['elements']} elements within 11.3 cm" in page  # reach √(0.04/π) = 0.1128 m
