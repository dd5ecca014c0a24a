"""The run's result as typed parts, one per stage output (issue 29 item 5), and a run without a reduced model.

``Result.detailed`` (always there), ``Result.reduced`` (the reduction method's output), ``Result.orbit`` and
``Result.transient`` (None when their stage did not run).  ``[reduction] enabled = false`` runs the detailed model
alone and must still write every output that makes sense without a network.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import make_case

from fem2tmm import meshes
from fem2tmm.pipeline import run
from fem2tmm.reductors import REDUCTORS
from fem2tmm.result import Detailed, Reduced

PLATE = dict(
    parts=[{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "super_nodes": 3,
            "front": "black"}],
    boundary=[{"kind": "temperature", "groups": ["xmin"], "value": 20.0, "name": "edge"},
              {"kind": "power", "groups": ["plate"], "value": 5.0, "name": "heater"}],
    radiation={"enabled": False}, environment={"sink_temperature": -270.0},
)


def test_a_run_is_made_of_one_typed_part_per_stage():
    res = run(make_case(**PLATE), mesh=meshes.plate(1.0, 1.0, 8, 8))
    assert isinstance(res.detailed, Detailed) and isinstance(res.reduced, Reduced)
    assert res.orbit is None and res.transient is None
    red = res.reduced
    assert red.method in REDUCTORS and red.method == ("radiation_aware" if red.choice["radiation_aware"] else "thesis")
    assert red.recovery is not None and red.clustering is not None and red.delivered is not None
    # the part's own parts agree with each other: the field is the network's solution recovered (the recovery
    # that travels with it, fed the same super-node temperatures, gives it back to its Newton tolerance, 1e-10 K)
    assert np.abs(red.recovery.recover(red.solution.T, T0=red.T_recovered) - red.T_recovered).max() < 1e-8
    assert res.summary["reduced"]["super_nodes"] == int(np.count_nonzero(red.network.kind == "cluster"))
    assert res.summary["reduced"]["reductor"] == red.method


def test_the_detailed_model_alone_writes_its_outputs(tmp_path):
    # [reduction] enabled = false: no network, no recovery; the temperatures are the detailed model's.  Energy:
    # the heater's 5 W leave through the held edge and the emission to space (balance to the solver's 1e-9 W scale)
    case = make_case(**PLATE, reduction={"enabled": False})
    res = run(case, mesh=meshes.plate(1.0, 1.0, 8, 8), out=tmp_path / "out")
    assert res.reduced is None and res.detailed.solution is not None
    assert np.array_equal(res.T_nodes, res.T_detailed_nodes)
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["temperatures_C"]["source"] == "detailed model" and s["temperatures_C"]["super_nodes"] is None
    assert s.get("reduced") is None and s["accuracy"]["rms_K"] is None
    into_edge = sum(s["detailed"]["heat_into_fixed_W"].values())
    assert into_edge + float(res.detailed.solution.to_space.sum()) == pytest.approx(5.0, abs=1e-6)
    written = {p.name for p in (tmp_path / "out").iterdir()}
    assert {"summary.json", "report.html", "temperatures.vtu"} <= written
    assert not {"reduced.npz", "model.esatan"} & written
