"""Right signs and results always shown (issue 15): heat_into_fixed_W positive into the boundary; temperatures
per part and per super node in summary.json, the terminal table and the report, with or without a reference."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import make_case

from fem2tmm import meshes
from fem2tmm.export.summary import summary_table
from fem2tmm.pipeline import run

HEATED_PLATE = dict(
    parts=[{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "super_nodes": 3}],
    boundary=[{"kind": "temperature", "groups": ["xmin"], "value": 20.0, "name": "edge"},
              {"kind": "power", "groups": ["plate"], "value": 1.0, "name": "heater"}],
)


def test_heat_into_the_fixed_boundary_is_positive():
    # 1 W heater on a conducting plate held at one edge, no radiation (both sides inactive): in steady state the
    # whole watt flows into the boundary, +1.0 W, in the reduced and the detailed model (energy conservation;
    # the solves are direct, so 1e-9)
    res = run(make_case(**HEATED_PLATE), mesh=meshes.plate(1.0, 1.0, 8, 8))
    s = res.summary
    assert sum(s["detailed"]["heat_into_fixed_W"].values()) == pytest.approx(1.0, abs=1e-9)
    assert sum(s["reduced"]["heat_into_fixed_W"].values()) == pytest.approx(1.0, abs=1e-9)
    assert s["loads_W"]["boundaries"] == {"heater": pytest.approx(1.0, abs=1e-12)}
    table = summary_table(s)
    assert "into fixed 'edge' (reduced)" in table and "+1 W" in table
    # linear conduction with a known load: the recovery is exact, so both columns agree (thesis §4.3; 1e-9 K)
    tc = s["temperatures_C"]
    for k in ("min", "mean", "max"):
        assert tc["parts"]["plate"][k] == pytest.approx(tc["reference"]["parts"]["plate"][k], abs=1e-9)
    assert tc["parts"]["plate"]["min"] == pytest.approx(20.0, abs=1e-9)  # the fixed edge
    assert "recovered" in table and "|  detailed" in table


def test_temperatures_are_shown_without_a_reference(tmp_path):
    case = make_case(**HEATED_PLATE, reference={"detailed": False})
    res = run(case, mesh=meshes.plate(1.0, 1.0, 8, 8), out=tmp_path / "out")
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["detailed"] is None
    plate = s["temperatures_C"]["parts"]["plate"]
    T = res.T_recovered_nodes[np.isfinite(res.T_recovered_nodes)] - 273.15
    assert (plate["min"], plate["mean"], plate["max"]) == pytest.approx((T.min(), T.mean(), T.max()), abs=1e-12)
    assert plate["max"] > plate["mean"] > plate["min"] == pytest.approx(20.0, abs=1e-9)
    assert s["temperatures_C"]["reference"] is None
    sn = s["temperatures_C"]["super_nodes"]
    assert len(sn) == 4  # 3 super nodes + the fixed edge
    table = summary_table(s)
    assert "T min/mean/max 'plate'" in table and "T super nodes" in table
    report = (tmp_path / "out" / "report.html").read_text()
    assert "Temperatures per part" in report and f"{plate['max']:.2f}" in report


def test_case_written_as_toml_reads_back_the_same():
    # a case built in Python (the demo) is shown in the report as TOML, not JSON: it must read back identically
    import tomllib

    from fem2tmm.demo import DEMO_CASE
    from fem2tmm.export.output import to_toml

    import datetime

    # (an [orbit] date as tomllib reads it from a case file: a Python case dict of examples/smallsat carries one)
    data = {**DEMO_CASE, "odd keys": {"a.b": [1, 2.5, "x"], "t": {"u": True, "v": {"w": -1e-300}}},
            "orbit": {"date": datetime.datetime(2026, 6, 21, 12, 0), "day": datetime.date(2026, 6, 21),
                      "utc": datetime.datetime(2026, 6, 21, 12, 0, 30, 5000, tzinfo=datetime.timezone.utc),
                      "at": datetime.time(7, 32)}}
    text = to_toml(data)
    assert tomllib.loads(text) == data
    assert "[[parts]]" in text and "[environment]" in text and not text.startswith("{")


def test_too_many_super_nodes_fail_before_clustering():
    # 4 x 4 quads (25 nodes), the 5 nodes of the fixed edge merged into one boundary node: 20 nodes are unknown,
    # so 21 super nodes over this part cannot be independent (21 rows of A in a 20 + 1-dimensional space with
    # the boundary row); refused at once, naming the part and the largest possible count
    import time

    from fem2tmm import Fem2TmmError

    part = {**HEATED_PLATE["parts"][0], "super_nodes": 21}
    case = make_case([part], HEATED_PLATE["boundary"][:1], radiation={"enabled": False})
    t = time.perf_counter()
    with pytest.raises(Fem2TmmError, match=r"'plate' asks for 21 super nodes.*only 20 nodes with an unknown "
                                           r"temperature \(21 nodes, a held group's nodes counted as one, 1 of them "
                                           r"fixed or kept\).*at most 20"):
        run(case, mesh=meshes.plate(1.0, 1.0, 4, 4))
    assert time.perf_counter() - t < 1.0  # before any clustering or reduction
    # 16 (one per element) is allowed by the count; the run says how many GL are negative and what they are
    part["super_nodes"] = 16
    s = run(make_case([part], HEATED_PLATE["boundary"][:1], radiation={"enabled": False}),
            mesh=meshes.plate(1.0, 1.0, 4, 4)).summary
    assert s["reduced"]["negative_links"] > 0 and "exact reduction" in summary_table(s)
