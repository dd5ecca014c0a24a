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

from benchmarks.offdesign import _err, deck_books, deck_state, detailed_books, run_bracket

N_QUADS, N_SN = 24, 60
STATES = [(10.0, -270.0), (0.0, -270.0), (40.0, -270.0),
          pytest.param(10.0, -100.0, marks=pytest.mark.xfail(strict=False, reason=(
              "issue 41 open: on this coarse network 4 super nodes close their design balance with a negative "
              "effective emitting area; at a -100 C sink they run warm (measured 17.2 K RMS / 142 K max against the "
              "thesis network's 8.3 / 58.9); 0.36 / 2.58 K at 300 super nodes on the full mesh (docs/design-notes.md)")))]


@pytest.fixture(scope="module")
def decks(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("offdesign")
    run_bracket(N_SN, n=N_QUADS, out=tmp / "default", detailed=False)
    run_bracket(N_SN, n=N_QUADS, out=tmp / "thesis", detailed=False, thesis=True)
    return tmp


@pytest.mark.parametrize("heater, sink", STATES)
def test_the_edited_deck_beats_the_thesis_network_and_its_books_add_up(decks, heater, sink):
    ref = run_bracket(N_SN, heater, sink, n=N_QUADS)[0]
    T_ref = ref.detailed.solution.T
    field, net, T, _ = deck_state(decks / "default", heater, sink)
    rms, mx = _err(ref.model, field, T_ref)
    t_field, *_ = deck_state(decks / "thesis", heater, sink)
    t_rms, t_mx = _err(ref.model, t_field, T_ref)
    # measured 2026-12-04, RMS / max K, this network vs the thesis network (reference noise 0.01-0.07 K RMS):
    # design 0.32/1.18 vs 9.8/41.2; heater 0 W 2.79/5.98 vs 10.5/37.6; 40 W 1.36/6.62 vs 30.1/276.  On main
    # 3955e37 the temperatures pass and the books below fail (held edge 19.9 W against 38.3 W)
    assert rms < t_rms and mx < t_mx, (rms, mx, t_rms, t_mx)
    books, detailed = deck_books(net, T), detailed_books(ref)
    design = (heater, sink) == (10.0, -270.0)
    # the heat the held edge gives the structure, from the deck's own terms (its GL and its GR to space)
    assert books["from_held"] == pytest.approx(detailed["from_held"], rel=0.01 if design else 0.02), (books, detailed)
    # Not asserted: "applied" (and so "to_space") - Y'q keeps the share of the heater that the hot spot radiates
    # above its super node's mean inside the network's emission: 15 % here, 1.3 % at 300 super nodes on the full
    # mesh (docs/design-notes.md, issue 41 item 3 open)
