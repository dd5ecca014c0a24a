"""The validity range of the network handed over: chosen, verified against the detailed model, stated (issue 41,
item 2; :mod:`fem2tmm.verify`).

Every figure here is of what the user receives: the deck written by the run, its constants edited as an engineer
edits them, read back by :mod:`fem2tmm.lpm`, solved, recovered with the recovery of ``reduced.npz``, against the
detailed model solved at that state.
"""

from __future__ import annotations

import dataclasses
import re
import warnings

import numpy as np
import pytest
from conftest import composite_box_case, make_case

import fem2tmm
from fem2tmm import meshes
from fem2tmm.case import Case
from fem2tmm.constants import KELVIN
from fem2tmm.errors import Fem2TmmError
from fem2tmm.export.summary import summary_table
from fem2tmm.lpm import read_esatan
from fem2tmm.lpm.solve import solve_network
from fem2tmm.pipeline import run
from fem2tmm.verify import COLDEST_SINK_K, POWER_FACTOR, TEMPERATURE_SWING_K, verify_range, verify_states


def _two_heaters(verify=None, sink=-150.0) -> Case:
    """A plate with two named heaters (2 W and 6 W) and a sink (no run: the range and states only)."""
    red = {} if verify is None else {"verify": verify}
    return make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                       "super_nodes": 4}],
                     [{"name": "heater_a", "kind": "power", "groups": ["plate"], "value": 2.0},
                      {"name": "heater_b", "kind": "power", "nodes": [1], "value": 6.0}],
                     environment={"sink_temperature": sink}, reduction=red)


def test_the_states_of_two_named_powers_and_a_sink():
    case = _two_heaters()
    T_warm = KELVIN + 60.0
    c = verify_range(case, T_warm)
    assert [(x.name, x.kind) for x in c] == [("heater_a", "power"), ("heater_b", "power"), ("sink", "sink")]
    # each power from 0 to 4x its design value; the sink from -270 °C to the warmest design temperature
    assert (c[0].low, c[0].high) == (0.0, POWER_FACTOR * 2.0) == (0.0, 8.0)
    assert (c[1].low, c[1].high) == (0.0, 24.0)
    assert c[2].low == pytest.approx(KELVIN - 270.0) and c[2].high == T_warm
    states = verify_states(c)
    # one at a time at either end (6), then all low and all high: 2m + 2 states, not the 2^m corners
    assert [s.label for s in states] == ["heater_a low", "heater_a high", "heater_b low", "heater_b high",
                                         "sink low", "sink high", "all low", "all high"]
    design = {"heater_a": 2.0, "heater_b": 6.0, "sink": KELVIN - 150.0}
    for s in states[:6]:  # exactly one constant away from its design value
        moved = [k for k in design if s.values[k] != pytest.approx(design[k])]
        assert moved == [s.label.split()[0]]
    assert states[6].values == {"heater_a": 0.0, "heater_b": 0.0, "sink": COLDEST_SINK_K}
    assert states[7].values == {"heater_a": 8.0, "heater_b": 24.0, "sink": T_warm}
    # a sink already at -270 °C: its low end is the design value and is not a state of its own
    cold = verify_range(_two_heaters(sink=-270.0), T_warm)
    assert "sink low" not in [s.label for s in verify_states(cold)]
    # the user's range replaces the automatic one for the names it lists (any case), case units in, SI out
    user = verify_range(_two_heaters(verify={"HEATER_A": [1.0, 3.0], "sink": [-200.0, 0.0]}), T_warm)
    assert (user[0].low, user[0].high, user[0].source) == (1.0, 3.0, "case file")
    assert (user[1].low, user[1].high, user[1].source) == (0.0, 24.0, "automatic")
    assert (user[2].low, user[2].high) == pytest.approx((KELVIN - 200.0, KELVIN))
    # a held temperature moves TEMPERATURE_SWING_K either side
    held = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black"}],
                     [{"name": "edge", "kind": "temperature", "groups": ["xmin"], "value": 20.0}])
    e = verify_range(held, T_warm)[0]
    assert (e.low, e.high) == pytest.approx((KELVIN + 20.0 - TEMPERATURE_SWING_K, KELVIN + 20.0 + TEMPERATURE_SWING_K))
    # no radiation: the sink is no constant of the network
    assert [x.name for x in verify_range(case, T_warm, radiating=False)] == ["heater_a", "heater_b"]


@pytest.mark.parametrize("verify, message", [
    ({"nozzle": [0.0, 1.0]}, "[reduction].verify.nozzle: no [[boundary]] named 'nozzle' (named boundaries: "
                             "heater_a, heater_b; or sink)"),
    ({"heater_a": [5.0, 1.0]}, "[reduction].verify.heater_a: low 5 is above high 1 W: give [low, high]"),
    ({"heater_a": [1.0]}, "[reduction].verify.heater_a: expected [low, high], two numbers in W"),
    ({"heater_a": ["a", 2]}, "expected [low, high]"),
    ({"sink": [-300.0, 0.0]}, "[reduction].verify.sink: low -300 °C is at or below absolute zero"),
    ({"heater_a": [0, 1], "HEATER_A": [0, 2]}, "'heater_a' is given twice"),
    ("yes", "[reduction].verify: expected true, false or a table"),
    ({}, "[reduction].verify: expected true, false or a table"),
])
def test_verify_is_validated_with_the_file_and_key(verify, message):
    data = {"materials": {"al": {"conductivity": 170.0}}, "optics": {"black": {"emissivity": 1.0}},
            "parts": [{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black"}],
            "boundary": [{"name": "heater_a", "kind": "power", "groups": ["plate"], "value": 2.0},
                         {"name": "heater_b", "kind": "power", "nodes": [1], "value": 6.0}],
            "reduction": {"verify": verify}}
    with pytest.raises(Fem2TmmError) as exc:
        Case.from_dict(data, source="my_case.toml")
    assert str(exc.value).startswith("my_case.toml: ") and message in str(exc.value)


def test_verify_refuses_a_boundary_that_follows_a_table():
    data = {"materials": {"al": {"conductivity": 170.0}}, "optics": {"black": {"emissivity": 1.0}},
            "parts": [{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black"}],
            "boundary": [{"name": "heater", "kind": "power", "groups": ["plate"], "value": [[0.0, 1.0], [10.0, 3.0]]}],
            "transient": {"end": 10.0, "step": 1.0}, "reduction": {"verify": {"heater": [0, 4]}}}
    with pytest.raises(Fem2TmmError, match=r"verify\.heater: \[\[boundary\]\] 'heater' follows a table in time"):
        Case.from_dict(data, source="my_case.toml")
    data["reduction"] = {"verify": False}
    assert Case.from_dict(data).reduction.verify is False


def test_a_linear_network_is_verified_exact_at_every_state(tmp_path):
    # a conducting plate held at one edge with two named heaters and no radiation: the detailed problem is linear and
    # the thesis' exact condensation with its recovery (T = X q + Y'T_SN) reproduces it for any value of the named
    # loads and held temperature (DESIGN §3.2).  Expected error: round-off (no ray noise: the reference noise is 0);
    # bound 1e-6 K, three decades above the solvers' 1e-9 K tolerance
    plate = meshes.plate(0.4, 0.2, 24, 12)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 2e-3, "front": "none",
                       "super_nodes": 6}],
                     [{"name": "edge", "kind": "temperature", "groups": ["xmin"], "value": 20.0},
                      {"name": "heater_a", "kind": "power", "groups": ["plate"], "value": 3.0},
                      {"name": "heater_b", "kind": "power", "groups": ["xmax"], "value": 1.5}],
                     optics={"black": {"emissivity": 1.0}}, radiation={"enabled": False},
                     reduction={"radiation_aware": False})
    r = run(case, mesh=plate, out=tmp_path / "out")
    v = r.reduced.verified
    assert v["status"] == "verified"
    assert [c["name"] for c in v["range"]] == ["edge", "heater_a", "heater_b"]  # no sink: nothing radiates
    assert len(v["states"]) == 8
    for st in v["states"]:
        assert st["error"] is None and st["max_K"] < 1e-6, st
    assert v["design"]["max_K"] < 1e-6 and not v["flagged"]
    # the states span a real range of temperatures (the check is not trivially at the design field)
    assert v["node_T_C"][0] == pytest.approx(-30.0) and v["node_T_C"][1] > 75.0
    # stated in both decks and reduced.npz
    esatan = (tmp_path / "out" / "model.esatan").read_text()
    assert "# VALIDITY RANGE: verified" in esatan and "UNVERIFIED" in esatan  # ("outside these ranges ...")
    assert re.search(r"#\s+HEATER_A\s+0 \.\. 12 W \(design 3; automatic\)", esatan)
    assert "C VALIDITY RANGE: verified" in (tmp_path / "out" / "model.sinda").read_text()
    with np.load(tmp_path / "out" / "reduced.npz") as z:
        assert str(z["verified_status"]) == "verified"
        assert list(z["verified_names"]) == ["edge", "heater_a", "heater_b"]
        np.testing.assert_allclose(z["verified_low"], [-30.0, 0.0, 0.0])
        np.testing.assert_allclose(z["verified_high"], [70.0, 12.0, 6.0])
        assert len(z["verified_rms_K"]) == 8 and np.all(z["verified_max_K"] < 1e-6)
    # the comment lines fit ESATAN's and SINDA's 132 columns
    assert max(len(line) for line in esatan.splitlines() if line.startswith("#")) <= 132
    assert r.summary["reduced"]["verified"]["status"] == "verified"


def test_without_a_reference_the_deck_says_unverified(tmp_path):
    box = meshes.box(0.3, 0.3, 0.3, 6, 6, 6)
    r = run(composite_box_case(8, 5.0, {"radiation_aware": False}, detailed=False), mesh=box, out=tmp_path / "out")
    assert r.reduced.verified["status"] == "UNVERIFIED"
    assert "no detailed reference" in r.reduced.verified["reason"]
    esatan = (tmp_path / "out" / "model.esatan").read_text()
    assert "# VALIDITY RANGE: UNVERIFIED" in esatan and "VALIDITY RANGE: verified" not in esatan
    assert "C VALIDITY RANGE: UNVERIFIED" in (tmp_path / "out" / "model.sinda").read_text()
    with np.load(tmp_path / "out" / "reduced.npz") as z:
        assert str(z["verified_status"]) == "UNVERIFIED" and "no detailed reference" in str(z["verified_reason"])
        assert "verified_low" not in z
    assert r.summary["reduced"]["verified"]["status"] == "UNVERIFIED"
    # verify = false: not verified either, and said so
    r = run(composite_box_case(8, 5.0, {"radiation_aware": False, "verify": False}, detailed=True), mesh=box)
    assert r.reduced.verified == {"status": "UNVERIFIED", "reason": "[reduction] verify = false"}


def test_the_verified_figure_is_what_an_independent_solve_of_the_edited_deck_gives(tmp_path):
    # the composite-like box (1 mm k = 5 W/(m K) panels, emission to space only: no ray noise), radiation-aware
    # network, 16 super nodes.  Off its design state it drifts (issue 41): the check must report that drift, and the
    # number must be the one a user gets by editing the deck, solving it and recovering it with fem2tmm recover
    box = meshes.box(0.3, 0.3, 0.3, 10, 10, 10)
    case = composite_box_case(16, 5.0, {"radiation_aware": True})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = run(case, mesh=box, out=tmp_path / "out")
    v = r.reduced.verified
    assert v["status"] == "verified" and not v["failed"]
    st = next(s for s in v["states"] if s["label"] == "power_1 high")
    assert st["values"] == {"temperature_0": 20.0, "power_1": 20.0, "sink": -270.0}
    # independently: the deck's POWER_1 edited in the text, read by fem2tmm.lpm, solved, recovered by fem2tmm.recover
    text = (tmp_path / "out" / "model.esatan").read_text()
    text, n = re.subn(r"(?m)^(\s*POWER_1 = )[^;]+;", r"\g<1>20.0;", text)
    assert n == 1
    (tmp_path / "edited.esatan").write_text(text)
    net = read_esatan(tmp_path / "edited.esatan")
    T = solve_network(net).T
    temps = {str(lab): float(t - KELVIN) for lab, t in zip(net.labels, T) if lab != "SPACE"}
    rec = fem2tmm.recover(tmp_path / "out", {**temps, "power_1": 20.0})
    # the detailed model of that state, built and solved from scratch (no reduction)
    state = dataclasses.replace(case, boundaries=tuple(dataclasses.replace(b, value=20.0) if b.kind == "power" else b
                                                       for b in case.boundaries),
                                reduction=dataclasses.replace(case.reduction, enabled=False))
    ref = run(state, mesh=box)
    ok = r.model.node_dof >= 0
    e = rec["temperature"][:, 0][ok] - (ref.T_detailed_nodes[ok] - KELVIN)
    # the same figure up to the solvers' tolerance (1e-9 K steps; the detailed solve here starts cold, the check's
    # from the design field)
    assert st["rms_K"] == pytest.approx(float(np.sqrt(np.mean(e**2))), abs=1e-6)
    assert st["max_K"] == pytest.approx(float(np.abs(e).max()), abs=1e-6)
    # this network drifts off its design state (issue 41): the check says so, beside the design error
    assert v["worst"]["rms_K"] > 3 * v["design"]["rms_K"] and v["flagged"]
    assert any("off the detailed model beyond its design state" in str(w.message) for w in caught)
    table = summary_table(r.summary)
    assert "validity range" in table and f"worst '{v['worst']['label']}'" in table


def test_a_set_deck_that_gets_the_sets_tables_after_its_check_says_unverified(tmp_path):
    # two cases sharing one radiation-aware network that differ in the heater alone: each deck gets the set's
    # parametric tables after its own run (set_parametric), so the deck handed over is not the deck verified
    from conftest import box_set_raw

    raw = box_set_raw(8, 5.0, [{"name": "cold", "boundary": {"heater": {"value": 2.0}}},
                               {"name": "hot", "boundary": {"heater": {"value": 10.0}}}],
                      {"radiation_aware": True}, True)
    box = meshes.box(0.3, 0.3, 0.3, 6, 6, 6)
    multi = run(Case.from_dict(raw), mesh=box, out=tmp_path / "out")
    for name, r in multi.results.items():
        assert r.reduced.parametric is not None and r.reduced.parametric.get("from") == "the case set"
        v = r.reduced.verified
        assert v["status"] == "UNVERIFIED" and "parametric tables, added after the check" in v["reason"]
        assert r.summary["reduced"]["verified"] == v
        assert "# VALIDITY RANGE: UNVERIFIED" in (tmp_path / "out" / name / "model.esatan").read_text()


def test_the_deck_is_edited_where_an_engineer_edits_it():
    # $CONSTANTS with its sub-blocks at column 0 (as ESATAN-TMS writes them) or indented (as fem2tmm does); the
    # sink is the space node's T unless the deck has a constant SINK; nothing else changes
    from fem2tmm.verify import edit_deck

    deck = ("$MODEL X\n$NODES\n    D1 = 'a', T = EDGE, C = 1;\n    B9000 = 'SPACE', T = -270.0;\n$CONDUCTORS\n"
            "    GL(1, 9000) = 1.0;\n$CONSTANTS\n$REAL\n    HEATER = 30.0;  # W\n    EDGE = 20.0;\n$CONTROL\n"
            "    STEFAN = 5.67e-8;\n$VARIABLES1\n    QI1 = 0.5 * HEATER;\n$ENDMODEL X\n")
    e = edit_deck(deck, {"HEATER": 120.0, "EDGE": -30.0}, sink_C=10.0)
    assert e == (deck.replace("HEATER = 30.0;", "HEATER = 120.0;").replace("EDGE = 20.0;", "EDGE = -30.0;")
                 .replace("'SPACE', T = -270.0;", "'SPACE', T = 10.0;"))
    parametric = deck.replace("T = -270.0;", "T = SINK;").replace("  $REAL", "").replace(
        "    EDGE = 20.0;\n", "    EDGE = 20.0;\n    SINK = -270.0;\n")
    e = edit_deck(parametric, {}, sink_C=-100.0)
    assert "SINK = -100.0;" in e and "T = SINK;" in e
    with pytest.raises(Exception, match="NOZZLE 0 times"):
        edit_deck(deck, {"NOZZLE": 1.0})


def test_the_small_satellite_default_deck_beats_the_thesis_network_at_every_verified_state():
    """Issue 41's acceptance on ``examples/smallsat`` at its committed count (31 super nodes): every state its
    ``[reduction] verify`` checks (each named power 0 and 4x, the sink at the warmest design temperature, all low, all
    high) is closer to that state's detailed reference with the default (radiation-aware) deck than with the thesis'
    deck, to within the reference's own ray noise (0.063 K RMS at the design state: the closest state, sink high, is
    0.36 against 0.41 K).  Measured 2026-12-06 18:30 UTC: default 0.086-0.44 K RMS, thesis 0.41-0.60 K.  Before the
    effective emission's slope left out a concave super node's self-exchange (radiation_aware.effective_network), the
    sink-high and all-high states were 0.89 and 1.11 K, above the thesis' 0.41 and 0.60 K (docs/design-notes.md)."""
    from benchmarks.choice import _case

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = run(_case("smallsat/case.toml", "default"))
    v = r.summary["reduced"]["verified"]
    assert v["status"] == "verified", v
    noise = v["reference_noise"]["rms_K"]
    # the run's own check of the thesis' network over the same range and detailed solutions (the record's thesis
    # figures equal an independent thesis run's: the two-plate test below): the radiation-aware network kept
    rc = r.summary["reduced"]["choice"]["verified_range"]
    assert r.reduced.method == "radiation_aware" and not rc["thesis"], rc
    out = {"default": {k: a for k, (a, _) in rc["states_K"].items() if k != "design"},
           "thesis": {k: t for k, (_, t) in rc["states_K"].items() if k != "design"}}
    assert out["default"] == {s["label"]: s["rms_K"] for s in v["states"]}
    assert len(out["default"]) == 7, out
    worse = {k: (out["default"][k], out["thesis"][k]) for k in out["default"]
             if out["default"][k] >= out["thesis"][k] + noise}
    assert not worse, (worse, noise)
    # and better by more than that noise at most states (measured: 6 of 7)
    assert sum(out["default"][k] + noise < out["thesis"][k] for k in out["default"]) >= 5, out


def _record(design, states, noise=0.01):
    """A ``reduced.verified`` record in brief: design RMS, {label: RMS or None (no solution)}."""
    return {"design": {"rms_K": design, "max_K": 3 * design}, "reference_noise": {"rms_K": noise, "max_K": 0.0},
            "states": [{"label": k, "rms_K": v, "max_K": None if v is None else 3 * v} for k, v in states.items()]}


def _cut(record: dict, order: list, enough) -> dict:
    """``record`` cut as verify_network visits its states (``order`` first, then the others) at the first ``enough``
    (called with the design state's RMS, then each solved state's): the rows after it unchecked."""
    labels = [r["label"] for r in record["states"]]
    visit = list(order) + [k for k in labels if k not in order]
    done = enough(record["design"]["rms_K"])
    for row in sorted(record["states"], key=lambda r: visit.index(r["label"])):
        if done:
            row.update(rms_K=None, max_K=None, checked=False)
        elif row["rms_K"] is not None:
            done = enough(row["rms_K"])
    return record


def test_a_candidate_stops_where_it_can_no_longer_win_and_the_choice_is_the_same():
    """:func:`fem2tmm.verify.cannot_win`: another candidate's states are checked in the order of the kept network's
    errors and stop once one is off by the kept worst less the least margin :func:`range_choice` applies.  Over
    random records (states with and without solutions, noises, margins), every record cut where ``enough`` says so
    gets the choice the full record gets, and its unchecked states are not named as states without a solution."""
    from fem2tmm.verify import cannot_win, range_choice

    rng = np.random.default_rng(7)
    stopped = 0
    for _ in range(3000):
        labels = [f"s{i}" for i in range(int(rng.integers(1, 8)))]
        kept_rms = {k: (None if rng.random() < 0.1 else float(rng.lognormal(0.0, 1.0))) for k in labels}
        alt_rms = {k: (None if rng.random() < 0.1 else float(rng.lognormal(0.0, 1.0))) for k in labels}
        noise, relative = float(rng.choice([0.0, 0.01, 0.3])), float(rng.choice([0.0, 0.2]))
        kept = _record(float(rng.lognormal(-2.0, 1.0)), kept_rms, noise)
        full = _record(float(rng.lognormal(-1.0, 1.0)), alt_rms, noise)
        order, enough = cannot_win(kept, relative)
        assert order == sorted((k for k in labels if kept_rms[k] is not None), key=lambda k: -kept_rms[k])
        cut = _cut(_record(full["design"]["rms_K"], alt_rms, noise), order, enough)
        a, b = range_choice(kept, full, relative), range_choice(kept, cut, relative)
        assert a["thesis"] == b["thesis"], (kept, full, cut)
        assert set(b["failed"]["thesis"]) <= set(a["failed"]["thesis"])
        stopped += any(r.get("checked") is False for r in cut["states"])
    assert stopped > 500  # the cut happens often (measured 1 389 of 3 000)


def test_a_kept_network_stops_where_it_must_lose_and_the_choice_is_the_same():
    """:func:`fem2tmm.verify.must_lose`, the counterpart of ``cannot_win`` for a candidate checked in full first: the
    kept network's states stop once one is off by more than the other's worst plus the largest margin
    :func:`range_choice` can apply there.  Over random estimated records (states with and without solutions, each
    state's noise of the kept network within NOISE_BOUND of the other's largest, margins), every kept record cut where
    ``enough`` says so gets the choice its full record gets."""
    from fem2tmm.verify import NOISE_BOUND, must_lose, range_choice

    def record(design, states, noise):
        return {"design": {"rms_K": design, "max_K": 3 * design}, "estimate_noise": {"rms_K": noise},
                "states": [{"label": k, "rms_K": v, "max_K": None if v is None else 3 * v} for k, v in states.items()]}

    rng = np.random.default_rng(11)
    stopped = 0
    for _ in range(3000):
        labels = [f"s{i}" for i in range(int(rng.integers(1, 8)))]
        kept_rms = {k: (None if rng.random() < 0.1 else float(rng.lognormal(0.5, 1.0))) for k in labels}
        alt_rms = {k: (None if rng.random() < 0.1 else float(rng.lognormal(-0.5, 1.0))) for k in labels}
        noise = float(rng.choice([0.0, 0.01, 0.3]))
        kept_noise = noise * NOISE_BOUND * float(rng.random())  # (the bound must_lose assumes)
        relative = float(rng.choice([0.0, 0.2]))
        other = record(float(rng.lognormal(-2.0, 1.0)), alt_rms, noise)
        full = record(float(rng.lognormal(-2.0, 1.0)), kept_rms, kept_noise)
        order, enough = must_lose(other, relative)
        cut = _cut(record(full["design"]["rms_K"], kept_rms, kept_noise), order, enough)
        assert range_choice(full, other, relative)["thesis"] == range_choice(cut, other, relative)["thesis"]
        stopped += any(r.get("checked") is False for r in cut["states"])
    assert stopped > 500  # the cut happens often


def test_the_range_choice_compares_each_networks_worst_state_beyond_the_reference_noise():
    """:func:`fem2tmm.verify.range_choice`: the thesis' network replaces the other when its worst RMS over the design
    state and the verified states both solve is smaller by more than the reference noise (at least
    ``RANGE_FLOOR_K``); a difference within it keeps the network chosen; a state without a solution is named, not
    counted (a solver that fails is loud, a network far off everywhere is not)."""
    from fem2tmm.verify import RANGE_FLOOR_K, range_choice

    aware = _record(0.03, {"sink high": 12.8, "adapter low": 8.8})
    thesis = _record(3.5, {"sink high": 3.4, "adapter low": 3.5})
    rc = range_choice(aware, thesis)
    assert rc["thesis"] and rc["worst_K"] == {"kept": 12.8, "thesis": 3.5}
    assert rc["worst_state"] == {"kept": "sink high", "thesis": "design"}
    assert rc["states_K"]["design"] == [0.03, 3.5] and rc["states_K"]["adapter low"] == [8.8, 3.5]
    # worse at one state, but its worst within the noise of the thesis' worst: kept
    assert not range_choice(_record(0.03, {"a": 0.505}, noise=0.01), _record(0.5, {"a": 0.2}))["thesis"]
    assert range_choice(_record(0.03, {"a": 0.515}, noise=0.01), _record(0.5, {"a": 0.2}))["thesis"]
    # without ray noise, round-off apart is a tie: at least RANGE_FLOOR_K
    tie = range_choice(_record(1e-12, {"a": 3e-10}, noise=0.0), _record(1e-12, {"a": 1e-12}, noise=0.0))
    assert not tie["thesis"] and tie["tolerance_K"] == RANGE_FLOOR_K
    # a state without a solution: named, left out of both worsts
    rc = range_choice(_record(0.03, {"a": None, "b": 0.1}), _record(583.0, {"a": 600.0, "b": 590.0}))
    assert not rc["thesis"] and rc["worst_K"] == {"kept": 0.1, "thesis": 590.0}, rc
    assert rc["failed"] == {"kept": ["a"], "thesis": []} and rc["states_K"]["a"] == [None, 600.0]
    rc = range_choice(_record(0.03, {"a": 5.0, "b": 0.1}), _record(0.5, {"a": None, "b": 0.6}))
    assert rc["worst_K"] == {"kept": 0.1, "thesis": 0.6} and not rc["thesis"]


def _two_plates():
    """A model of the robustness campaign (2026-12-06, seed 31) where the verified range hands over the thesis'
    network: two 10 cm plates of 3 x 3 quads touching at one corner, k 1.78 W/(m K), 0.15 mm, ε 1/3 on both sides
    (specular), one edge held at −1.5 °C, sink 17 °C, 6 super nodes.  Both networks are 4.6 K off at the design
    state; with the sink at −270 °C the radiation-aware one is 35.8 K off and the thesis' 26.1 K."""
    from fem2tmm.mesh.shapes import merge, plate, transform

    data = {"materials": {"m": {"conductivity": 1.78225058965384, "density": 2000.0, "specific_heat": 900.0}},
            "optics": {"paint": {"emissivity": 1 / 3, "absorptivity": 0.004082782894796245, "specular": 1.0}},
            "parts": [{"name": "p", "groups": ["plate"], "material": "m", "front": "paint", "back": "paint",
                       "super_nodes": 6, "thickness": 0.00015188602363243594}],
            "boundary": [{"name": "held", "kind": "temperature", "groups": ["xmin"], "value": -1.5102529342459547},
                         {"name": "heater", "kind": "power", "groups": ["plate"], "value": 3.554869846347404e-107}],
            "environment": {"sink_temperature": 17.003585921904516},
            "radiation": {"rays_per_face": 50}, "reference": {"rays_per_face": 10}}
    mesh = merge(plate(0.1, 0.1, 3, 3), transform(plate(0.1, 0.1, 3, 3), translation=(0.1, 0.1, 0.0)))
    return data, mesh


def test_the_default_hands_over_the_thesis_network_where_it_holds_the_verified_range_better(tmp_path):
    """Issue 42, the choice over the verified range: the design-state estimate keeps the radiation-aware network
    (estimated 1.6e-9 against 4.5 K), but over the verified range its worst state (sink −270 °C) is 35.8 K RMS where
    the thesis' network is 26.1 K (``_two_plates``).  The default hands over the thesis' network: the same deck, the
    same verified figures (to round-off) as the run asked for the thesis' method, its choice record keeping both
    networks' range.  (Until 2026-12-07 examples/cylinders changed hands this way; with the emission drawn from the
    quadric areas the rays are traced on, its radiation-aware network holds the range better: the next test.)"""
    data, mesh = _two_plates()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = tmp_path / "out"
        default = run(Case.from_dict(data), mesh=mesh, out=out)
        thesis = run(Case.from_dict({**data, "reduction": {"radiation_aware": False}}), mesh=mesh)
    ch = default.summary["reduced"]["choice"]
    rc = ch["verified_range"]
    assert default.reduced.method == "thesis" and ch["radiation_aware"] is False, ch["chosen_by"]
    assert ch["estimated_rms_K"]["radiation_aware"] < ch["estimated_rms_K"]["thesis"]  # the estimate's own pick
    assert rc["thesis"] and rc["worst_K"]["kept"] > rc["worst_K"]["thesis"] + rc["tolerance_K"], rc
    assert rc["replaced"]["method"] == "radiation_aware" and rc["by"] == "reference"
    assert rc["replaced"]["verified"]["worst"]["rms_K"] == pytest.approx(rc["worst_K"]["kept"], rel=1e-12)
    assert "holds the range better" in ch["chosen_by"]
    deck = (out / "model.esatan").read_text()  # the deck says which network the range chose, and both worsts
    assert f"chosen over the range: the thesis' network (worst RMS {rc['worst_K']['thesis']:.3g} K)" in deck
    shown = summary_table(default.summary)  # the figures the choice rests on, for the engineer: both networks
    assert "range, both networks" in shown and f"sink low {rc['states_K']['sink low'][0]:.3g} / " in shown, shown
    vd, vt = default.summary["reduced"]["verified"], thesis.summary["reduced"]["verified"]
    assert default.summary["accuracy"]["rms_K"] == pytest.approx(thesis.summary["accuracy"]["rms_K"], rel=1e-9)
    assert [s["label"] for s in vd["states"]] == [s["label"] for s in vt["states"]]
    for a, b in zip(vd["states"], vt["states"]):
        assert a["rms_K"] == pytest.approx(b["rms_K"], rel=1e-6, abs=1e-9), (a["label"], a["rms_K"], b["rms_K"])
    # the record's figures for the thesis' network are that independent run's
    for s in vt["states"]:
        assert rc["states_K"][s["label"]][1] == pytest.approx(s["rms_K"], rel=1e-6, abs=1e-9)
    # and what the run hands over holds the range no worse than either network beyond the noise
    worst = max([vd["design"]["rms_K"]] + [s["rms_K"] for s in vd["states"]])
    assert worst <= rc["worst_K"]["thesis"] + 1e-9
    # without the reference the estimate makes the same choice: its Newton steps continue while a step moves a node
    # by more than 2 % (one step estimated 25.2 / 35.5 K and kept the radiation-aware network)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        blind = run(Case.from_dict(data), mesh=mesh, reference=False)
    bc = blind.summary["reduced"]["choice"]["verified_range"]
    assert blind.reduced.method == "thesis" and bc["by"] == "estimate" and bc["thesis"], bc
    for who in ("kept", "thesis"):  # no traced IR here: the converged steps are the detailed solve (measured 1e-3)
        assert bc["worst_K"][who] == pytest.approx(rc["worst_K"][who], rel=0.02), (bc["worst_K"], rc["worst_K"])


def test_the_cylinders_radiation_aware_network_emits_from_the_traced_quadric_areas_and_holds_the_range():
    """examples/cylinders (32 super nodes, fitted quadrics, specular): the rays are traced from the cylinders'
    quadric patches, 0.31416 m², where the facets are 0.31058 m² (12 around each tube, 1.15 % less).  Every method
    now emits from the traced area (``ReductionInputs.traced_area``): the radiation-aware network is 0.026 K RMS at
    the design state and 0.059 K at its worst verified state (from the facets: 0.073 and 0.51 K, and the range
    handed the thesis' network over, 0.095 / 0.134 K; measured 2026-12-07, reference noise 0.0047 K).  So the default
    keeps it and is better than the thesis' network at every verified state; the network radiates what its field
    does (the emission check, from the facets 1.07 %); the thesis' a-posteriori estimate is its measured error within
    a factor 2.5 (from the facets 11x); and without the reference the estimated range keeps it too."""
    from benchmarks.choice import _case

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        default = run(_case("cylinders/case.toml", "default"))
        blind = run(_case("cylinders/case.toml", "default"), reference=False)
    s, ch = default.summary, default.summary["reduced"]["choice"]
    rc = ch["verified_range"]
    assert default.reduced.method == "radiation_aware" and not rc["thesis"], ch["chosen_by"]
    noise = s["accuracy"]["reference_noise_rms_K"]
    assert s["accuracy"]["rms_K"] < 0.05  # measured 0.026 K
    for label, (aware, thesis) in rc["states_K"].items():  # better than the thesis' network at every state
        assert aware < thesis - noise, (label, aware, thesis)
    assert rc["worst_K"]["kept"] < 0.1  # measured 0.059 K (all high)
    assert s["reduced"]["emission_check"]["relative"] < 0.003  # measured 1.3e-6
    # the thesis' estimate against its error in the same run: 0.19 against 0.095 K (from the facets 1.04 K, 11x); the
    # radiation-aware one's 1e-4 K is its own model's (it does not see the network's ray noise, as on every study)
    est = ch["estimated_rms_K"]
    assert 0.5 < est["thesis"] / s["accuracy"]["thesis_method"]["rms_K"] < 2.5, (est, s["accuracy"]["thesis_method"])
    assert est["radiation_aware"] < 0.1 * est["thesis"]
    cb = blind.summary["reduced"]["choice"]
    assert blind.reduced.method == "radiation_aware" and cb["verified_range"]["by"] == "estimate", cb["chosen_by"]
    assert blind.summary["reduced"]["verified"]["status"] == "UNVERIFIED"


def _satellite_quick():
    """examples/satellite/case.toml with a coarser orbit (4 positions, 30 rays per face and position, the orbit
    average only): the same structure, super nodes and verified range, a quarter of the run time."""
    import tomllib
    from pathlib import Path

    f = Path(__file__).resolve().parents[1] / "examples" / "satellite" / "case.toml"
    raw = tomllib.loads(f.read_text())
    raw["orbit"].update(positions=4, rays_per_face=30, steady="average")
    return Case.from_dict(raw, base_dir=f.parent)


def test_the_satellites_short_bars_are_fed_along_their_links_where_that_holds_the_range_better():
    """Issue 41/42 on examples/satellite (orbit coarsened): 24 bar and fitting super nodes emit nothing and are short
    of heat at the design state (condensed panel emission, down to −40 W).  Fed from the held adapter, 0.2 K warmer,
    they follow it: 4.46 K RMS with the sink at its warmest design temperature (12.8 K with the full orbit).  Fed
    along the links the reduction gave them, 1.79 K at worst (measured 2026-12-06).  The run verifies both and hands
    over the second, which also beats the thesis' network over the range (3.95 K), so the default stays the
    radiation-aware network, exact at the design state; fed from the adapter it would have lost the range to the
    thesis' network (a second run forcing the held node measured that: the thesis' network handed over, its
    recorded worst the same 4.46 K to 1e-6)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = run(_satellite_quick())
    ch = r.summary["reduced"]["choice"]
    fl, v, vr = ch["floor"], r.summary["reduced"]["verified"], ch["verified_range"]
    assert fl["source"] == "linked", ch["chosen_by"]
    assert fl["worst_K"]["held"] > fl["worst_K"]["linked"] + fl["tolerance_K"], fl
    assert fl["tolerance_K"] >= 0.2 * fl["worst_K"]["held"]  # the margin of a choice between two rules
    assert not fl["failed"]["linked"]
    # what the run hands over is the linked network: its own verified worst is the record's
    worst = max([v["design"]["rms_K"]] + [s["rms_K"] for s in v["states"]])
    assert worst == pytest.approx(fl["worst_K"]["linked"], rel=1e-12)
    assert "comes from the super nodes linked to them" in ch["chosen_by"]
    # it is the radiation-aware network, exact at the design state (reference noise 0.027 K RMS; measured 0.031 K),
    # and it holds the verified range better than the thesis' network, which the held node's would not have
    assert r.reduced.method == "radiation_aware" and r.summary["accuracy"]["rms_K"] < 0.1
    assert not vr["thesis"] and worst < vr["worst_K"]["thesis"] < fl["worst_K"]["held"], (vr, fl)
    # Without the detailed reference the same choice is made on the range's *estimated* errors (one Newton step of
    # the detailed problem at each state, from the edited deck's recovered field): the links again, and the thesis'
    # network does not replace it.  The range stays unverified; the estimate of the network handed over is beside it.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e = run(_satellite_quick(), reference=False)
    ce = e.summary["reduced"]["choice"]
    fe, ve = ce["floor"], e.summary["reduced"]["verified"]
    assert fe["by"] == "estimate" and fe["source"] == "linked", ce["chosen_by"]
    # both probed at the state farthest from the design one, the linked network lower there and checked in full, the
    # held one only until it must lose (verify.must_lose): its worst "at least"
    assert not fe["unchecked"]["linked"] and fe["unchecked"]["held"], fe
    assert "at least" in ce["chosen_by"].split("from the held node")[0].rsplit("(", 1)[-1], ce["chosen_by"]
    assert ve["status"] == "UNVERIFIED" and ve["estimated"]["status"] == "estimated"
    assert ce["verified_range"]["by"] == "estimate" and not ce["verified_range"]["thesis"]
    assert e.reduced.method == "radiation_aware"
    # the measured choice's whole cost: the design-state estimate and the range's estimated checks (both stages)
    t = e.summary["timings_s"]
    assert ce["range_estimate_seconds"] == pytest.approx(t["estimate_range"] + t["verify_floor"], rel=1e-12)
    assert ce["estimate_total_cost_fraction"] == pytest.approx(
        (ce["estimate_seconds"] + ce["range_estimate_seconds"]) / ce["reduction_seconds"], rel=1e-12)
    assert ce["estimate_total_cost_fraction"] > ce["estimate_cost_fraction"] > 0
    # the estimate at each state against the error measured there (the same network, states and decks): the
    # estimator's accuracy off the design state as on it (at the design state over the robustness campaign, its
    # ratio's quartiles 0.92 and 1.23; here 0.6-0.95, measured 2026-12-07), bounded by a factor of 2
    measured = {s["label"]: s["rms_K"] for s in v["states"]}
    for s in ve["estimated"]["states"]:
        assert 0.5 < s["rms_K"] / measured[s["label"]] < 2.0, (s["label"], s["rms_K"], measured[s["label"]])
    for key in ("held", "linked"):
        assert 0.5 < fe["worst_K"][key] / fl["worst_K"][key] < 2.0, (fe, fl)
    # what the engineer reads: the deck's header, the terminal and the report say UNVERIFIED and give the estimate
    from fem2tmm.export.report import _verified_section
    from fem2tmm.export.validity import validity_lines

    deck = " ".join(validity_lines(ve, ce))
    assert "UNVERIFIED" in deck and "ESTIMATED" in deck and "estimated worst state 'all high'" in deck, deck
    assert "range, estimated" in summary_table(e.summary)
    page = _verified_section(ve)
    assert "ESTIMATED" in page and page.count("<tr>") == len(ve["estimated"]["states"]) + 2, page  # head, design
