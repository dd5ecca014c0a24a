"""One radiation model for every method (issue 42): rays stopped by inactive sides (optics "none").

A ray a side emits that an inactive side stops counts as never emitted: the traced REFs close on εA (1 − blocked)
(fem2tmm.radiation.tracer.side_fractions), and so does every method's emission (the radiation-aware reduction's
linearisation, correction load, exported recovery).  The small reproduction of the issue: a 1 x 1 m, 1 mm
aluminium radiator held on one edge with a 20 W heater, under an identical plate of optics "none" 5 cm above it.
On main 3955e37 the default (radiation-aware) reduction missed the blocked share: 14.9 K RMS against the detailed
reference, the network radiating 134.7 W to space where its field's traced emission is 76.5 W.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from conftest import make_case
from fem2tmm.mesh import shapes
from fem2tmm.pipeline import run
from fem2tmm.radiation.reference import parallel_rectangles_view_factor


def radiator_under_blocker(n: int = 16, gap: float = 0.05):
    """Two n x n quad plates 1 x 1 m: the radiator at z = 0 and the blocker at z = ``gap`` (groups ``radiator``,
    ``blocker``; ``xmin`` the nodes of both x = 0 edges)."""
    return shapes.merge(shapes.plate(1.0, 1.0, n, n, name="radiator"),
                        shapes.plate(1.0, 1.0, n, n, origin=(0.0, 0.0, gap), name="blocker"))


def radiator_case(seed: int = 0, n_sn: int = 16):
    parts = [{"name": "radiator", "groups": ["radiator"], "material": "al", "thickness": 1e-3, "front": "paint",
              "back": "paint", "super_nodes": n_sn},
             {"name": "blocker", "groups": ["blocker"], "material": "al", "thickness": 1e-3, "front": "none",
              "back": "none", "super_nodes": 4}]
    return make_case(parts, [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                             {"kind": "power", "groups": ["radiator"], "value": 20.0}],
                     optics={"paint": {"emissivity": 0.85, "absorptivity": 0.2}},
                     environment={"sink_temperature": -270.0}, radiation={"seed": seed},
                     reference={"detailed": True})


def test_blocked_rays_are_never_emitted_by_every_method():
    mesh = radiator_under_blocker()
    runs, fields = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # 0.5 W of the heater on the held edge
        for seed in (0, 1):  # two independent tracings of the reduced model: its own ray noise
            r = run(radiator_case(seed), mesh=mesh)
            runs.append(r)
            fields.append(r.model.node_temperatures(r.reduced.T_recovered))
    d = (fields[0] - fields[1])[np.isfinite(fields[0])]
    own_noise = float(np.sqrt(np.mean(d**2)) / np.sqrt(2.0))  # one run's: the difference of two has twice its variance
    for r in runs:
        s = r.summary
        acc, check = s["accuracy"], s["reduced"]["emission_check"]
        assert r.reduced.method == "radiation_aware"  # the default's choice here (cluster Biot number > 1)
        # the blocked share of the radiator's emission (both sides alike, εA-weighted) is half the view factor of
        # its top side to the blocker: two parallel 1 m squares 5 cm apart, closed form (Howell C-11) 0.908;
        # tolerance ~4 sigma of 16 000 rays (sqrt(0.1 x 0.9 / 16000) = 0.0024)
        F = parallel_rectangles_view_factor(1.0, 1.0, 0.05)
        assert check["blocked_by_part"]["radiator"] == pytest.approx(0.5 * F, abs=0.01)  # measured 0.4536
        assert "blocker" not in check["blocked_by_part"]  # it emits nothing
        # issue 42: at the network's solution its radiation to space and its field's traced emission agree to 1 %
        assert check["relative"] < 0.01  # measured 0.005 and 0.0005 (main: 0.76)
        # error at the noise level: 3 sigma of the reference's noise and the reduced model's own ray noise
        # (measured 0.081 and 0.029 K RMS; noise 0.004 / 0.010 K reference, 0.047 K own; main: 14.9 K)
        sigma = np.hypot(acc["reference_noise_rms_K"], own_noise)
        assert acc["rms_K"] <= 3.0 * sigma, (acc, own_noise)
        # the thesis' network counts blocked rays as never emitted too: it has its uniform-load error only
        assert acc["thesis_method"]["rms_K"] > 10 * acc["rms_K"]  # measured 1.73 K
        # "auto" reports the a-posteriori estimate of both candidates (fem2tmm.stages.refine.error_estimate, no
        # reference): measured 1.77 K for the thesis (1.73 K measured) and 0.093 K for the radiation-aware network;
        # bound as in test_the_refinement_estimate_emits_what_the_reference_emits
        est = s["reduced"]["choice"]["estimated_rms_K"]
        assert 0.6 < est["thesis"] / acc["thesis_method"]["rms_K"] < 1.4, est
        assert est["radiation_aware"] < 0.1 * est["thesis"], est


def test_the_summary_reports_no_blocking_without_an_inactive_blocker():
    mesh = radiator_under_blocker(8)
    case = radiator_case(n_sn=4)
    case = dataclasses.replace(case, parts=case.parts[:1])  # the blocker plate is no part: not in the scene
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = run(case, mesh=mesh)
    check = r.summary["reduced"]["emission_check"]
    assert check["blocked_by_part"] == {"radiator": 0.0}
    assert check["relative"] < 0.01
    assert r.summary["accuracy"]["rms_K"] < 1e-6  # nothing exchanged: the network is exact (measured 0.0 K)


@pytest.mark.parametrize("aware", [False, True])
def test_the_refinement_estimate_emits_what_the_reference_emits(aware):
    # [reduction] target_rms's global estimate (fem2tmm.reduce.refine) on the radiator under its blocker, 12 super
    # nodes, no split allowed (max_super_nodes = the start): with the full εA it estimated 10.8 K (thesis, measured
    # 2.73 K) and 12.6 K (radiation-aware, measured 0.109 K); with εA (1 − blocked) 2.52 and 0.120 K.  Bound: the
    # estimator's measured accuracy on examples/composite, 0.66-0.99 of the measured RMS (docs/case-file.md,
    # refine_estimator), widened to [0.6, 1.4] for the ray noise of the 20-ray side tally
    case = radiator_case(n_sn=8)
    case = dataclasses.replace(case, reduction=dataclasses.replace(case.reduction, radiation_aware=aware,
                                                                   target_rms=1e-6, max_super_nodes=12))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = run(case, mesh=radiator_under_blocker())
    s = r.summary
    estimate = s["reduced"]["refinement"]["rounds"][-1]["estimated_rms_K"]
    assert 0.6 < estimate / s["accuracy"]["rms_K"] < 1.4, (estimate, s["accuracy"]["rms_K"])
