"""``[reduction] radiation_aware = "auto"`` (the default, issue 29): the radiation-aware reduction where some
cluster is wider than its panel's fin length √(k t / h_rad) (cluster Biot number ≥ 1, reductors.AUTO_BIOT), the thesis'
reduction elsewhere; what ran and why in summary.json ``reduced.choice``."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import composite_box_case, make_case
from fem2tmm import meshes
from fem2tmm.case import Case
from fem2tmm.errors import Fem2TmmError
from fem2tmm.pipeline import run
from fem2tmm.reductors import AUTO_BIOT

def box():
    """The 0.3 x 0.3 x 0.25 m box of 1.5 cm quads (tests/test_radiation_aware.py)."""
    return meshes.box(0.3, 0.3, 0.25, 20, 20, 17)


def test_auto_follows_the_cluster_biot_number_and_gives_the_explicit_methods_network():
    mesh = box()
    # 1 mm panels, 0.39 m² in 40 clusters of A ≈ 0.0098 m².  Fin length L² = k t / h_rad, h_rad = 2·4σεT³ ≈ 7 W/(m² K)
    # at 270 K: k = 5 -> L = 2.7 cm, Bi = A / L² ≈ 14 > 1; k = 170 -> L = 16 cm, Bi ≈ 0.4 < 1 (measured 8.4 and
    # 0.51: the panels are colder and warmer than 270 K)
    for k, expect in ((5.0, True), (170.0, False)):
        auto = run(composite_box_case(40, k, {"outer_iterations": 20}, detailed=True), mesh=mesh)
        choice = auto.summary["reduced"]["choice"]
        assert choice["radiation_aware"] is expect, choice
        assert choice["chosen_by"].startswith("auto: largest cluster Biot number")
        assert (choice["biot_cluster_max"] >= AUTO_BIOT) is expect
        assert (0.2 < choice["biot_cluster_max"] < 0.8) if not expect else (3 < choice["biot_cluster_max"] < 30)
        assert choice["ir_on"] == "super_faces"  # space-only radiation: no face-to-face IR to place
        explicit = run(composite_box_case(40, k, {"radiation_aware": expect, "outer_iterations": 20}, detailed=False),
                       mesh=mesh)
        # the same network as asking for that method: bit-identical GL, C and loads
        assert np.array_equal(auto.reduced.network.K, explicit.reduced.network.K) and np.array_equal(auto.reduced.network.Q, explicit.reduced.network.Q)
        acc = auto.summary["accuracy"]
        if expect:  # where auto chooses it, the radiation-aware network beats the thesis' (measured 5.6e-5 vs 6.0 K)
            assert acc["rms_K"] * 100 < acc["thesis_method"]["rms_K"], acc
        else:  # below Bi 1 the thesis' uniform-load shape functions hold: measured 0.68 K RMS at Bi 0.51, the
            # largest error of the cases below 1 (docs/design-notes.md, "Which reduction by default")
            assert acc["rms_K"] < 1.5, acc


def test_auto_with_ir_on_the_faces_or_a_positive_network():
    # ir_on = "faces" / "detailed" asks for the radiation-aware reduction: auto takes it, false refuses the case
    mesh = meshes.plate(0.2, 0.2, 6, 6)
    parts = [{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
              "back": "black", "super_nodes": 4}]
    bnd = [{"kind": "temperature", "groups": ["xmin"], "value": 20.0}]
    r = run(make_case(parts, bnd, radiation={"ir_on": "detailed", "ir_rays_per_face": 10}, reference={"detailed": False}),
            mesh=mesh)
    choice = r.summary["reduced"]["choice"]
    assert (choice["radiation_aware"], choice["ir_on"]) == (True, "detailed")
    assert choice["chosen_by"] == 'auto: [radiation] ir_on = "detailed" needs it' and choice["biot_cluster_max"] > 0
    with pytest.raises(Fem2TmmError, match="ir_on"):
        make_case(parts, bnd, radiation={"ir_on": "faces"}, reduction={"radiation_aware": False})
    with pytest.raises(Fem2TmmError, match="radiation_aware"):
        make_case(parts, bnd, reduction={"radiation_aware": "yes"})
    # the positive network is the thesis' reduction's own fit: auto keeps the thesis there
    r = run(make_case(parts, bnd, reduction={"network": "positive"}, reference={"detailed": False}), mesh=mesh)
    assert r.summary["reduced"]["choice"]["radiation_aware"] is False
    assert r.reduced.network.radiative is None


def test_a_case_set_takes_its_first_cases_choice_for_every_case():
    # One network for the set (issue 29 item 2): auto decides once, on the group's first case, and every case then
    # shares its GL and C, even a case that alone would sit on the other side of the threshold (a cold sink lowers
    # h_rad, so the Biot numbers differ from case to case)
    base = composite_box_case(40, 5.0, {"outer_iterations": 20}, detailed=False)
    raw = dict(base.raw)
    raw["boundary"] = [dict(b, name=n) for b, n in zip(raw["boundary"], ("deck", "heater"))]
    raw["cases"] = [{"name": "nominal"}, {"name": "cold", "boundary": {"heater": {"value": 0.0}}}]
    multi = run(Case.from_dict(raw), mesh=box())
    res = multi.results
    for name, r in res.items():
        assert r.summary["reduced"]["choice"]["radiation_aware"] is True, name
        assert r.reduced.shared_network == {"linearised_at": "nominal", "cases": ["nominal", "cold"]}
        assert np.array_equal(r.reduced.network.K, res["nominal"].reduced.network.K)
