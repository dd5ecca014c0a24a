"""Load cases through the pipeline: per-case results equal separate runs, bit-for-bit the same on every scheduler,
shared stages reused from the stage cache across cases and reruns, per-case folders and the envelope."""

from __future__ import annotations

import copy
import dataclasses
import json

import numpy as np
import pytest

from fem2tmm.case import Case
from fem2tmm.loadcases import deep_merge
from fem2tmm.mesh.shapes import baffle
from fem2tmm.pipeline import run

GROUPS = ["aperture_lip", "front_cone", "outer_skin", "main_cone", "middle_annulus", "back_annulus"]
# the baffle of the demo (a coarse parametric mesh, 1368 quads) with a heater and a cheap ray budget
BASE = {
    "materials": {"al": {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}},
    "optics": {"paint": {"emissivity": 0.05, "absorptivity": 0.2, "specular": 1.0}},
    "parts": [{"name": "baffle", "groups": GROUPS, "material": "al", "thickness": 1e-3, "front": "paint",
               "back": "paint", "super_nodes": 8}],
    "boundary": [{"name": "screws", "kind": "temperature", "groups": ["screw_rims"], "value": 20.0},
                 {"name": "heater", "kind": "power", "groups": ["middle_annulus"], "value": 2.0}],
    "environment": {"sink_temperature": -100.0, "sun_direction": [-1.0, 1.0, 1.41421356], "solar_flux": 17400.0,
                    "solar_rays_per_face": 4},
    "radiation": {"rays_per_face": 400},
    "reference": {"detailed": False},
    # the validity range is not what these tests are about: without it no case estimates its range (2026-12-07)
    "reduction": {"verify": False},
}
HOT_COLD = [
    {"name": "hot", "optics": {"paint": {"absorptivity": 0.3}}, "boundary": {"heater": {"value": 4.0}}},
    {"name": "cold", "optics": {"paint": {"absorptivity": 0.15, "emissivity": 0.08}},
     "boundary": {"heater": {"value": 0.5}}, "environment": {"sink_temperature": -120.0}},
]


@pytest.fixture(scope="module")
def mesh():
    return baffle(h=6e-3, n_theta=36)


def case_of(data: dict) -> Case:
    return Case.from_dict(copy.deepcopy(data), source="baffle.toml")


def test_two_cases_give_the_temperatures_of_two_separate_runs(mesh, tmp_path):
    multi = run(case_of({**BASE, "cases": HOT_COLD}), out=tmp_path / "out", mesh=mesh)
    assert list(multi.results) == ["hot", "cold"]
    T_cases = []
    for entry in HOT_COLD:
        alone = run(case_of(deep_merge(BASE, {k: v for k, v in entry.items() if k != "name"})), mesh=mesh,
                    cache=False)
        got = multi.results[entry["name"]]
        # the same arithmetic on the same inputs: equal to round-off (1e-12 K, the tolerance)
        assert np.nanmax(np.abs(got.T_nodes - alone.T_nodes)) <= 1e-12
        T_cases.append(alone.T_nodes)
    assert np.nanmax(T_cases[0] - T_cases[1]) > 1.0  # the cases differ (hotter optics, more power)
    # outputs: today's contract per case, the envelope over both, a summary row per case
    out = tmp_path / "out"
    for name in ("hot", "cold"):
        assert {"summary.json", "temperatures.vtu", "temperatures.bdf", "reduced.npz", "model.esatan",
                "report.html"} <= {p.name for p in (out / name).iterdir()}
    s = json.loads((out / "summary.json").read_text())
    assert [c["name"] for c in s["cases"]] == ["hot", "cold"]
    assert s["cases"][1]["cache"]["cluster"] == "reused" and s["cases"][1]["cache"]["radiation"] == "computed"
    assert set(s["cases"][0]["parts"]) == {"baffle"}
    import meshio

    env = meshio.read(out / "envelope.vtu").point_data
    T = np.stack(T_cases) - 273.15
    ok = np.isfinite(T[0])
    assert np.array_equal(env["temperature_max"][ok], T.max(axis=0)[ok])
    assert np.array_equal(env["temperature_min"][ok], T.min(axis=0)[ok])
    assert np.array_equal(env["case_of_max"][ok], np.argmax(T, axis=0)[ok].astype(float))
    assert (env["case_of_max"][~ok] == -1).all()
    hot_card = (out / "envelope_hot.bdf").read_text().splitlines()[4]  # first TEMP* card: SID 1, grid, T
    assert hot_card.startswith("TEMP*") and int(hot_card[8:24]) == 1
    assert float(hot_card[40:56]) == pytest.approx(T.max(axis=0)[ok][0], abs=1e-6)  # 10 significant digits
    assert "cold" in (out / "report.html").read_text(encoding="utf-8")


def _three_cases(scheduler: str, workers: int | None = None) -> dict:
    cases = [{"name": "a"}, {"name": "b", "optics": {"paint": {"emissivity": 0.1}}},
             {"name": "c", "optics": {"paint": {"absorptivity": 0.35}}, "boundary": {"heater": {"value": 1.0}}}]
    return {**BASE, "cases": cases, "compute": {"scheduler": scheduler, **({"workers": workers} if workers else {})}}


def test_serial_and_local_clusters_are_bit_identical(mesh, capsys):
    pytest.importorskip("distributed")
    from fem2tmm.radiation.tracer import BATCH
    from fem2tmm.reduce.conduction import BATCHES_PER_WORKER

    runs = {}
    for scheduler, workers in (("serial", None), ("local", 1), ("local", 2)):
        capsys.readouterr()
        # a fresh in-memory cache per run; on Dask the cases run concurrently (client threads)
        multi = run(case_of(_three_cases(scheduler, workers)), mesh=mesh, quiet=scheduler == "serial")
        assert multi.summary["compute"]["workers"] == (workers or 1)
        runs[(scheduler, workers)] = multi
        if scheduler == "local":  # one bar over all work units, with the worker count, and its total at the end
            err = capsys.readouterr().err
            # the ray batches of the traces each case computed (solar, REFs; not the reused ones; the two half
            # tallies of "auto"'s error estimate and, where it chose the radiation-aware reduction (every case here:
            # thesis estimated 0.055-0.105 K, its noise 0.002-0.005 K), its FE sides' IR REFs, ir_rays_per_face per
            # emitting side), the batches of clusters of each local reduction a case computed and one steady solve
            # per case
            # (the radiation-aware reduction reduces once per outer iteration, on the same clusters, in every case)
            reductions = lambda r: len((r.summary["reduced"].get("radiation_aware") or {}).get(  # noqa: E731
                "outer_iterations") or [])
            ir = lambda r: (r.reduced.ir is not None and r.reduced.ir.face is not None) * -(  # noqa: E731
                -r.case.radiation.ir_rays_per_face * len(r.reduced.ir.eps_area) // BATCH)
            units = sum((r.cache["solar_detailed"] == "computed") * -(-r.detailed.solar.rays // BATCH)
                        + (r.cache["radiation"] == "computed") * -(-int(np.sum(r.reduced.radiation.rays)) // BATCH)
                        + r.reduced.network.reduction.diagnostics["tasks"] * ((r.cache["reduce"] == "computed")
                                                                               + reductions(r)) + 1
                        + sum(-(-n // BATCH) for n in r.reduced.choice["estimate_rays"]) + ir(r)
                        for r in multi.results.values())
            s = "s" if workers > 1 else ""
            assert f"[fem2tmm] {units} work units on {workers} worker{s}\n" in err
            assert "ray batches on" not in err and "steady solves on" not in err  # no bar per map_units call
            tasks = [r.reduced.network.reduction.diagnostics["tasks"] for r in multi.results.values()
                     if r.cache["reduce"] == "computed"]
            assert tasks and 0 < tasks[0] <= BATCHES_PER_WORKER * workers  # batches of the 8 clusters
    ref = runs[("serial", None)]
    for multi in runs.values():
        for name, r in multi.results.items():
            e = ref.results[name]
            assert r.cache == e.cache  # computed by the first case that needs it, reused by the others
            assert np.array_equal(r.reduced.T_recovered, e.reduced.T_recovered)
            # the reduction (its clusters condensed on the workers) and the recovery that travels with the network
            net, net_e = r.reduced.network, e.reduced.network
            assert np.array_equal(net.K, net_e.K) and np.array_equal(net.C, net_e.C)
            T_sn = np.linspace(250.0, 300.0, net.n)
            assert np.array_equal(net.reduction.recover(T_sn), net_e.reduction.recover(T_sn))
            rec, rec_e = r.reduced.recovery.arrays(), e.reduced.recovery.arrays()
            assert rec.keys() == rec_e.keys()
            for k in rec:
                assert np.array_equal(rec[k], rec_e[k]), k
            assert np.array_equal(r.reduced.network.GR, e.reduced.network.GR) and np.array_equal(r.reduced.network.Q, e.reduced.network.Q)
            assert np.array_equal(r.detailed.solar.absorbed_side, e.detailed.solar.absorbed_side)
            assert np.array_equal(r.reduced.solution.T, e.reduced.solution.T)


def test_cases_share_one_ray_scene_per_geometry(mesh, monkeypatch):
    """The load cases of one run build each ray scene once (the scene depends on the geometry and the quadric fit,
    not on the optics, which come with each trace), and still give the temperatures of separate runs (1e-12 K)."""
    import fem2tmm.pipeline as pipeline

    built = []
    real = pipeline.QuadricScene

    class Counting(real):
        def __init__(self, *args, **kw):
            built.append(1)
            super().__init__(*args, **kw)

    monkeypatch.setattr(pipeline, "QuadricScene", Counting)
    base = copy.deepcopy(BASE)
    base["parts"] = [{**BASE["parts"][0], "quadric": ["front_cone", "main_cone"]}]
    multi = run(case_of({**base, "cases": HOT_COLD}), mesh=mesh, cache=False)
    assert len(built) == 1  # two cases whose optics differ: one scene
    for entry in HOT_COLD:
        alone = run(case_of(deep_merge(base, {k: v for k, v in entry.items() if k != "name"})), mesh=mesh,
                    cache=False)
        assert np.nanmax(np.abs(multi.results[entry["name"]].T_nodes - alone.T_nodes)) <= 1e-12
    assert len(built) == 3  # each separate run builds its own


def test_a_scene_refuses_a_surface_of_another_geometry(mesh):
    from fem2tmm.errors import Fem2TmmError
    from fem2tmm.fem.model import build_model
    from fem2tmm.radiation.surfaces import TriangleScene
    from fem2tmm.stages.radiation import radiation_surface

    a = radiation_surface(build_model(mesh, case_of(BASE)))
    hot = radiation_surface(build_model(mesh, case_of(deep_merge(BASE, {"optics": HOT_COLD[1]["optics"]}))))
    assert not np.array_equal(hot.emissivity, a.emissivity)
    scene = TriangleScene(a, "numpy")
    assert TriangleScene.of(hot, scene, "test") is scene  # other optics, same geometry: shared
    moved = dataclasses.replace(a, points=a.points + 1e-3)
    with pytest.raises(Fem2TmmError, match="another surface"):
        TriangleScene.of(moved, scene, "test")


def test_rerun_reuses_what_did_not_change(mesh, tmp_path):
    out = tmp_path / "out"
    first = run(case_of(BASE), out=out, mesh=mesh)
    assert set(first.summary["cache"].values()) == {"computed"}
    hotter = deep_merge(BASE, {"boundary": {"heater": {"value": 3.0}}})
    second = run(case_of(hotter), out=out, mesh=mesh)
    # only the solves ran again: clustering, reduction, REFs (and the quadric-free solar trace) came from out/.cache
    assert second.summary["cache"] == {"cluster": "reused", "solar_detailed": "reused", "reduce": "reused",
                                       "radiation": "reused"}
    assert np.nanmax(second.T_nodes - first.T_nodes) > 0.1  # 1 W more heats the baffle
    fresh = run(case_of(hotter), mesh=mesh, cache=False)  # the reused entries give exactly a fresh run's numbers
    assert np.array_equal(second.reduced.T_recovered, fresh.reduced.T_recovered)
    third = run(case_of(deep_merge(hotter, {"optics": {"paint": {"emissivity": 0.07}}})), out=out, mesh=mesh)
    assert third.summary["cache"] == {"cluster": "reused", "solar_detailed": "reused", "reduce": "reused",
                                      "radiation": "computed"}
    assert len(list((out / ".cache").iterdir())) == 5  # cluster, solar, reduce, radiation x 2


def test_a_failing_case_on_dask_stops_the_others_and_raises_its_error(mesh, monkeypatch):
    """A case that fails in its client thread: the run raises that case's Fem2TmmError (unchanged), not a
    cancellation of the others; an interrupt raised in a case thread (Ctrl-C) propagates the same way."""
    pytest.importorskip("distributed")
    import fem2tmm.pipeline as pipeline
    from fem2tmm.errors import Fem2TmmError

    check = pipeline.check_transient

    def failing(exc):
        def f(model, case):
            if case.name == "b":
                raise exc
            return check(model, case)
        return f

    from fem2tmm.compute import DaskExecutor

    cancels = []
    cancel = DaskExecutor.cancel
    monkeypatch.setattr(DaskExecutor, "cancel", lambda self: cancels.append(1) or cancel(self))
    monkeypatch.setattr(pipeline, "check_transient", failing(Fem2TmmError("case b: boom")))
    with pytest.raises(Fem2TmmError, match="^case b: boom$"):
        run(case_of(_three_cases("local", 2)), mesh=mesh)
    assert cancels == [1]  # the other cases' units were cancelled once
    monkeypatch.setattr(pipeline, "check_transient", failing(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        run(case_of(_three_cases("local", 2)), mesh=mesh)
