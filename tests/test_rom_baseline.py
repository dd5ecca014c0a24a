"""Issue 32: the projection-ROM baseline of ``fem2tmm bench rom`` is not a strawman.  With r equal to the full
dimension, POD-Galerkin (benchmarks/rom.py, its own backward Euler) reproduces fem2tmm's detailed backward-Euler
transient of a linear conduction case to 1e-9 K (the same scheme and steps: the only difference is round-off); with
r below it, the error grows as the discarded singular values say."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from conftest import make_case
from fem2tmm import meshes

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.rom import ProjectionROM, _capture_runs, deim_points  # noqa: E402


def _case(radiating: bool):
    heater = [[0.0, 2.0], [600.0, 2.0], [600.1, 0.0], [1200.0, 0.0], [1200.1, 4.0], [1800.0, 4.0]]
    return make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "super_nodes": 3,
                       "front": "black" if radiating else "none", "back": "none"}],
                     [{"name": "edge", "kind": "temperature", "groups": ["xmin"], "value": 20.0},
                      {"name": "heater", "kind": "power", "groups": ["xmax"], "value": heater}],
                     radiation={"enabled": False}, reference={"detailed": True, "noise": False},
                     transient={"end": 1800.0, "step": 30.0, "method": "backward-euler",
                                "initial_temperature": 20.0, "output_every": 60.0})


MESH = meshes.plate(0.3, 0.1, 12, 4)


def test_full_dimension_pod_reproduces_the_detailed_transient():
    res, (prob, settings, sol) = _capture_runs(_case(radiating=False), MESH)
    rom = ProjectionROM(prob, sol.T, r=prob.n, complete=True)
    assert rom.r == len(rom.f)
    y0 = rom.V.T @ (sol.T[0][rom.f] - rom.mean[rom.f])
    T = rom.integrate(prob, sol.times, 30.0, y0)
    assert np.abs(T - sol.T).max() < 1e-9  # same scheme, same steps: round-off only
    # fewer modes: the error is bounded by what the snapshots' discarded directions hold, and shrinks with r
    errs = []
    for r in (1, 2, 4):
        rom = ProjectionROM(prob, sol.T, r=r)
        y0 = rom.V.T @ (sol.T[0][rom.f] - rom.mean[rom.f])
        errs.append(np.abs(rom.integrate(prob, sol.times, 30.0, y0) - sol.T).max())
    assert errs[0] > errs[1] > errs[2] > 0


def test_pod_deim_with_every_point_equals_pod_galerkin_on_a_radiating_plate():
    """DEIM with m = n points interpolates T⁴ exactly: POD-DEIM then equals POD-Galerkin (1e-9 K)."""
    res, (prob, settings, sol) = _capture_runs(_case(radiating=True), MESH)
    n = prob.n
    gal = ProjectionROM(prob, sol.T, r=6)
    deim = ProjectionROM(prob, sol.T, r=6, deim=True, m=n)
    if deim.m < n:  # the T⁴ snapshots span fewer directions: DEIM is exact on their span only
        assert np.unique(deim_points(deim.U)).size == deim.m
    y0 = gal.V.T @ (sol.T[0][gal.f] - gal.mean[gal.f])
    Tg = gal.integrate(prob, sol.times, 30.0, y0)
    Td = deim.integrate(prob, sol.times, 30.0, y0)
    # on the training history the interpolated emission differs from the exact one by the T⁴ snapshots'
    # discarded directions only: far below the POD error itself
    assert np.abs(Td - Tg).max() < 0.05 * max(np.abs(Tg - sol.T).max(), 1e-3)
