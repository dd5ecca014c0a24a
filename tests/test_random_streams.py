"""The reference and the reduced model draw independent random numbers (issue 21, "honest error bars").

If the detailed reference traced its rays with the reduced model's random numbers, the two ray-noise errors
would be correlated and the reduced-vs-detailed metric would not see them.  Every tracing role of a run has its
own seed (``stages.radiation.SEED_ROLES``, all derived from ``[radiation] seed``).  These tests check it through
``fem2tmm.run`` itself, in two ways that fail if a stage takes another role's stream:

* every ray tracing of a run gets its own generator: no two calls share a (seed, spawn key) pair, and the
  reference stages never get a seed a reduced-model stage got;
* changing the seed of one role alone (the reduced model's, or the reference's) leaves every result of the
  other model identical bit for bit, and does change the results of the role changed.

``tests/test_radiation_aware.py::test_reference_and_reduced_model_draw_independent_random_numbers`` checks the
other face of it: the sampled REFs differ and their errors are uncorrelated.
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from conftest import make_case
from fem2tmm import meshes
from fem2tmm.stages import radiation as radiation_stages, refine as refine_stages, solar as solar_stages
from fem2tmm.pipeline import run

#: stage functions that trace rays, and whose model they serve
REDUCED = {"reduced_radiation", "super_face_solar", "super_face_orbit", "ir_absorption"}
REFERENCE = {"detailed_radiation", "detailed_solar", "detailed_orbit"}
OTHER = {"solar_prepass", "side_tally"}  # the clustering's coarse solar map; the error estimate's side tally
#: the root of the generator's spawn key inside each tracer (radiation/tracer.py, solar.py, planet.py): exchange
#: rays (stream 0), solar rays (7), per-side absorption (7, an exchange tracer on stream 7), orbit (its own
#: per-position seeds: seed + [position])
SPAWN_ROOT = {"trace_exchange": 0, "trace_solar": 7, "trace_absorption": 7, "trace_orbit": "orbit"}


def _entropy(seed) -> tuple:
    return tuple(int(x) for x in np.atleast_1d(seed))


@pytest.fixture
def spy(monkeypatch):
    """Record (stage, tracer, seed) of every ray tracing a run makes (the calls go through unchanged)."""
    import fem2tmm.radiation.orbital as orbital

    calls = []

    def wrap(module, name):
        real = getattr(module, name)

        def traced(*args, **kw):
            stage = next(f.function for f in inspect.stack() if f.function in REDUCED | REFERENCE | OTHER)
            calls.append((stage, name, _entropy(kw["seed"])))
            return real(*args, **kw)

        monkeypatch.setattr(module, name, traced)

    for module in (radiation_stages, solar_stages, refine_stages):
        for name in ("trace_exchange", "trace_solar", "trace_absorption"):
            if hasattr(module, name):
                wrap(module, name)
    wrap(orbital, "trace_orbit")
    return calls


def facing_plates_case(reduction=None, **radiation):
    """Two facing 4 x 4 plates, half reflecting, lit at 30° so one shades part of the other; super-face solar loads
    (the reduced model traces its own Sun) with the solar-aware clustering; 1 W on the plates, 3 K sink."""
    a = meshes.plate(1.0, 1.0, 4, 4)
    b = meshes.transform(meshes.plate(1.0, 1.0, 4, 4), rotation=meshes.rotation("x", 180.0),
                         translation=(0, 1.0, 0.5))
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "grey",
                       "back": "grey", "super_nodes": 4}], [{"kind": "power", "groups": ["plate"], "value": 1.0}],
                     optics={"grey": {"emissivity": 0.5, "absorptivity": 0.5, "specular": 0.5}},
                     environment={"sink_temperature": -270.0, "sun_direction": [0.0, 0.5, 0.866],
                                  "solar_flux": 1000.0, "solar_on": "super_faces", "solar_rays_per_face": 40},
                     radiation={"rays_per_face": 300, **radiation},
                     reference={"detailed": True, "rays_per_face": 60}, reduction=reduction or {})
    return case, meshes.merge(a, b)


def _assert_streams_distinct(calls):
    stages_seen = {c[0] for c in calls}
    ids = [(SPAWN_ROOT[tracer], seed) for _, tracer, seed in calls]
    assert len(set(ids)) == len(ids), calls  # no two tracings share a generator
    red = {seed for stage, _, seed in calls if stage in REDUCED}
    ref = {seed for stage, _, seed in calls if stage in REFERENCE}
    assert red and ref and not red & ref, calls
    return stages_seen


def test_every_tracing_of_a_run_has_its_own_stream(spy):
    case, mesh = facing_plates_case()
    run(case, mesh=mesh, cache=False)
    seen = _assert_streams_distinct(spy)
    # the reduced REFs and Sun, two half-budget reference REFs and two reference solar maps, the solar pre-pass,
    # and (the default radiation_aware = "auto" takes the radiation-aware reduction on these thin black plates,
    # with ir_on = "faces") the FE sides' IR exchange factors, and (issue 42: "auto" chooses by both candidates'
    # estimated error, reduced.choice.estimated_rms_K) the estimator's side-to-side tally, two halves on their own
    # streams "estimate_a" and "estimate_b"
    assert seen == {"reduced_radiation", "super_face_solar", "detailed_radiation", "detailed_solar", "solar_prepass",
                    "ir_absorption", "side_tally"}
    assert sum(c[0] == "side_tally" for c in spy) == 2
    assert sum(c[0] == "detailed_radiation" for c in spy) == 2 and sum(c[0] == "detailed_solar" for c in spy) == 2


def test_ir_on_the_fe_faces_has_its_own_stream(spy):
    # radiation-aware with the super faces' IR tallied per FE side: one more tracing, its own stream
    case, mesh = facing_plates_case({"radiation_aware": True}, ir_on="detailed", ir_rays_per_face=20)
    run(case, mesh=mesh, cache=False)
    seen = _assert_streams_distinct(spy)
    assert "ir_absorption" in seen


def _runs_with_role_seed(monkeypatch, case, mesh, role):
    """A baseline run and a run where only ``role``'s seed moved (to an entropy no role of the run uses)."""
    base = run(case, mesh=mesh, cache=False)
    with monkeypatch.context() as m:
        m.setitem(radiation_stages.SEED_ROLES, role, 99)
        moved = run(case, mesh=mesh, cache=False)
    return base, moved


def test_moving_the_reduced_models_stream_leaves_the_reference_unchanged(monkeypatch):
    case, mesh = facing_plates_case()
    a, b = _runs_with_role_seed(monkeypatch, case, mesh, "reduced")
    # the reference: identical, bit for bit (REFs of its first half, its solar map, its solution and noise)
    np.testing.assert_array_equal(a.detailed.radiation.F_raw.toarray(), b.detailed.radiation.F_raw.toarray())
    np.testing.assert_array_equal(a.detailed.solar.absorbed_face, b.detailed.solar.absorbed_face)
    np.testing.assert_array_equal(a.detailed.solution.T, b.detailed.solution.T)
    assert a.detailed.noise == b.detailed.noise
    # the reduced model did draw other numbers (else this test could not fail)
    assert not np.array_equal(a.reduced.radiation.F_raw.toarray(), b.reduced.radiation.F_raw.toarray())
    assert not np.array_equal(a.reduced.solar.absorbed_side, b.reduced.solar.absorbed_side)
    assert not np.array_equal(a.reduced.solution.T, b.reduced.solution.T)


@pytest.mark.parametrize("role", ["reference", "reference_b"])
def test_moving_a_reference_stream_leaves_the_reduced_model_unchanged(monkeypatch, role):
    case, mesh = facing_plates_case()
    a, b = _runs_with_role_seed(monkeypatch, case, mesh, role)
    np.testing.assert_array_equal(a.reduced.radiation.F_raw.toarray(), b.reduced.radiation.F_raw.toarray())
    np.testing.assert_array_equal(a.reduced.solar.absorbed_side, b.reduced.solar.absorbed_side)
    np.testing.assert_array_equal(a.reduced.solution.T, b.reduced.solution.T)
    np.testing.assert_array_equal(a.reduced.T_recovered, b.reduced.T_recovered)
    # the reference moved: both halves enter its solution, each half its own stream
    assert not np.array_equal(a.detailed.solution.T, b.detailed.solution.T)
    first_half_moved = not np.array_equal(a.detailed.radiation.F_raw.toarray(), b.detailed.radiation.F_raw.toarray())
    assert first_half_moved == (role == "reference")


def orbit_case():
    o = {"altitude": 700e3, "inclination": 98.0, "beta": 20.0, "positions": 4, "rays_per_face": 30,
         "fluxes_on": "super_faces", "attitude": {"kind": "nadir", "primary": "-z", "secondary": "+x"}}
    return make_case([{"name": "plate", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                       "back": "black", "super_nodes": 1}], environment={"sink_temperature": -270.15}, orbit=o,
                     radiation={"enabled": False})


def test_orbital_fluxes_of_the_reference_have_their_own_stream(spy, monkeypatch):
    # fluxes_on = "super_faces": the reduced model traces the orbit on its super faces, the reference on the FE
    # faces; the reference must not take the reduced model's per-position seeds
    mesh = meshes.plate(0.5, 0.5, 4, 4)
    run(orbit_case(), mesh=mesh, cache=False)
    orbit_calls = [c for c in spy if c[1] == "trace_orbit"]
    assert {c[0] for c in orbit_calls} == {"detailed_orbit", "super_face_orbit"}
    _assert_streams_distinct(orbit_calls)
    a, b = _runs_with_role_seed(monkeypatch, orbit_case(), mesh, "reduced")
    np.testing.assert_array_equal(a.orbit.detailed.total("absorbed"), b.orbit.detailed.total("absorbed"))
    assert not np.array_equal(a.orbit.super_faces.total("absorbed"), b.orbit.super_faces.total("absorbed"))
