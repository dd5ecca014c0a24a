"""The thermo-elastic chain, checked end to end with CalculiX (issue 30 item 3; Debian's ``calculix-ccx``, which
``.ci/run`` installs): fem2tmm's detailed thermal solution against CalculiX heat transfer on the same mesh, and the
displacements CalculiX computes from ``temperatures.inp`` (fem2tmm's ``*TEMPERATURE`` export) of the recovered field
against those of the detailed field and of one temperature per super node."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from benchmarks.thermoelastic import constant_per_super_node, frd_block, model_cards, run_ccx, static_displacements
from conftest import make_case
from fem2tmm import meshes
from fem2tmm.constants import KELVIN
from fem2tmm.pipeline import run

CCX = shutil.which("ccx")
pytestmark = pytest.mark.skipif(CCX is None, reason="CalculiX (ccx, Debian package calculix-ccx) is not installed")

L, W = 0.2, 0.04
N_SN = 5
TI = {"conductivity": 20.0, "density": 4500.0, "specific_heat": 520.0}  # a titanium-alloy-like bar


def bar():
    return meshes.box(L, W, W, 20, 4, 4, kind="solid")


def bar_case(n_sn, radiate=True, aware=False):
    return make_case([{"name": "bar", "groups": ["box"], "material": "ti", "front": "black" if radiate else "none",
                       "super_nodes": n_sn}],
                     [{"name": "root", "kind": "temperature", "groups": ["xmin"], "value": 20.0},
                      {"name": "heater", "kind": "power", "groups": ["xmax"], "value": 3.0}],
                     materials={"ti": TI}, environment={"sink_temperature": -100.0},
                     radiation={"enabled": False}, reference={"detailed": True},
                     reduction={"radiation_aware": aware, "outer_iterations": 10})


def test_detailed_thermal_solution_agrees_with_calculix_heat_transfer(tmp_path):
    # Pure conduction on the same hex mesh (fixed root, heat into the tip face, no radiation): two independent FE
    # codes with the same trilinear elements agree to solver round-off (the trial: 2.5e-5 K)
    mesh = bar()
    r = run(bar_case(4, radiate=False), mesh=mesh)
    T_ft = r.T_detailed_nodes - KELVIN
    tip = mesh.groups["xmax"].nodes
    q_tip = r.model.Q[r.model.node_dof[tip]]
    lines = ["*HEADING", "fem2tmm vs CalculiX heat transfer"] + model_cards(mesh)
    lines += ["*MATERIAL, NAME=TI", "*CONDUCTIVITY", f"{TI['conductivity']!r}", "*SOLID SECTION, ELSET=EALL, MATERIAL=TI",
              "*STEP", "*HEAT TRANSFER, STEADY STATE", "1.0, 1.0", "*BOUNDARY"]
    lines += [f"{int(mesh.node_ids[n])}, 11, 11, 20.0" for n in mesh.groups["xmin"].nodes]
    lines += ["*CFLUX"] + [f"{int(mesh.node_ids[n])}, 11, {q!r}" for n, q in zip(tip, q_tip.tolist()) if q != 0]
    lines += ["*NODE FILE", "NT", "*END STEP"]
    T_ccx = frd_block(run_ccx(tmp_path, "heat", "\n".join(lines) + "\n"), "NDTEMP")
    err = max(abs(T_ccx[int(i)][0] - T_ft[k]) for k, i in enumerate(mesh.node_ids))
    assert err < 1e-3, err  # .frd holds 5 significant digits (E12.5: ~1e-4 relative of ~100 °C); measured 5.0e-5 K


def test_recovered_temperatures_give_the_detailed_displacements(tmp_path):
    # Linear static, thermal strain only, 3-2-1 supports, the temperatures from fem2tmm's temperatures.inp writer:
    # the recovered field's displacements within 1 % of max |u| of the detailed field's, and >= 5x closer than one
    # temperature per super node (issue 30 acceptance).  The bar radiates from every face to a -100 °C sink
    # (Bi of a 4 cm super node ~ 1): the radiation-aware reduction, whose recovery is the exported emission mode;
    # the thesis' reduction at 5 super nodes recovers 0.25 K RMS of a 15.8 K range and gives 2.3 % against 2.9 %
    # for super-node-constant temperatures (measured 2026-12-04), the radiation-aware one 6e-6 K
    mesh = bar()
    r = run(bar_case(N_SN, aware=True), mesh=mesh)
    fields = {"detailed": r.T_detailed_nodes, "recovered": r.T_recovered_nodes, "constant": constant_per_super_node(r)}
    ids = mesh.node_ids
    p = mesh.points
    supports = tuple(int(ids[np.flatnonzero((p == corner).all(axis=1))[0]]) for corner in ([0, 0, 0], [L, 0, 0],
                                                                                           [0, W, 0]))
    u = {name: static_displacements(tmp_path / name, mesh, T - KELVIN, supports,
                                    material={"E": 110e9, "nu": 0.34, "alpha": 8.6e-6})
         for name, T in fields.items()}
    umax = np.abs(u["detailed"]).max()
    e_rec = np.abs(u["recovered"] - u["detailed"]).max() / umax
    e_const = np.abs(u["constant"] - u["detailed"]).max() / umax
    assert umax > 1e-6  # the check has something to measure (metres)
    assert e_rec < 0.01, (e_rec, e_const)
    assert e_rec * 5 <= e_const, (e_rec, e_const)  # measured 4.8e-6 against 0.025 of max |u| = 20.7 µm
