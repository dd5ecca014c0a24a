"""Shared helpers for the test suite."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from fem2tmm.case import Case
from fem2tmm.solve.steady import SIGMA

AL = {"conductivity": 170.0, "density": 2700.0, "specific_heat": 900.0}


def plate_case_toml(group: str = "plate", mesh: str = "plate.msh") -> str:
    """Case-file text of one aluminium shell part ``group`` of ``mesh`` (mm), black front side, no boundary;
    callers append keys of that part (``super_nodes = 2``) or further tables."""
    return f"""
[mesh]
file = "{mesh}"
unit = "mm"
[materials.al]
conductivity = 170.0
[optics.black]
emissivity = 1.0
[[parts]]
name = "plate"
groups = ["{group}"]
material = "al"
thickness = 1e-3
front = "black"
"""


def make_case(parts, boundary=(), optics=None, materials=None, **sections) -> Case:
    """A Case from plain dicts (aluminium and a black optics are predefined)."""
    data = {
        "materials": materials or {"al": AL},
        "optics": optics or {"black": {"emissivity": 1.0, "absorptivity": 1.0}},
        "parts": list(parts),
        "boundary": list(boundary),
    }
    data.update(sections)
    return Case.from_dict(data)


def composite_box_case(n_sn: int, k: float = 5.0, reduction: dict | None = None, detailed: bool = True) -> Case:
    """A composite-like box case (its mesh: ``meshes.box`` with groups xmin ... zmax): 1 mm panels of conductivity
    ``k`` W/(m K) with ``n_sn`` super nodes on a held deck (zmin, 20 °C, one super node), ε 0.85 both sides, 5 W
    spread on the top panel, space-only radiation (-270 °C)."""
    thick = 1e-3
    return make_case([{"name": "panels", "groups": ["xmin", "xmax", "ymin", "ymax", "zmax"], "material": "m",
                       "thickness": thick, "front": "paint", "back": "paint", "super_nodes": n_sn},
                      {"name": "deck", "groups": ["zmin"], "material": "m", "thickness": thick, "front": "paint",
                       "back": "paint", "super_nodes": 1}],
                     [{"kind": "temperature", "groups": ["zmin"], "value": 20.0},
                      {"kind": "power", "groups": ["zmax"], "value": 5.0}],
                     optics={"paint": {"emissivity": 0.85, "absorptivity": 0.2}},
                     materials={"m": {"conductivity": k, "density": 1600.0, "specific_heat": 900.0}},
                     environment={"sink_temperature": -270.0}, radiation={"enabled": False},
                     reduction=reduction or {}, reference={"detailed": detailed})


def box_set_raw(n_sn: int, heater: float, cases: list, reduction: dict, detailed: bool) -> dict:
    """The raw case table of :func:`composite_box_case` with named boundaries (``deck`` 20 °C, ``heater`` W) and a
    ``[[cases]]`` list: a load-case set on the composite-like box."""
    return {"materials": {"m": {"conductivity": 5.0, "density": 1600.0, "specific_heat": 900.0}},
            "optics": {"paint": {"emissivity": 0.85, "absorptivity": 0.2}},
            "parts": [{"name": "panels", "groups": ["xmin", "xmax", "ymin", "ymax", "zmax"], "material": "m",
                       "thickness": 1e-3, "front": "paint", "back": "paint", "super_nodes": n_sn},
                      {"name": "deck", "groups": ["zmin"], "material": "m", "thickness": 1e-3, "front": "paint",
                       "back": "paint", "super_nodes": 1}],
            "boundary": [{"kind": "temperature", "groups": ["zmin"], "value": 20.0, "name": "deck"},
                         {"kind": "power", "groups": ["zmax"], "value": heater, "name": "heater"}],
            "environment": {"sink_temperature": -270.0}, "radiation": {"enabled": False},
            "reduction": reduction, "reference": {"detailed": detailed}, "cases": cases}


def fin_reference(k=170.0, t=1e-3, eps=1.0, r_in=0.05, r_out=0.15, T_in=293.15, T_sink=173.15):
    """Circular radiating fin, thesis eq. 4.18, solved with scipy's solve_bvp (independent of the FE code).

    T'' + T'/r + 2 ε σ/(k t) (T_sink⁴ − T⁴) = 0,  T(r_in) = T_in,  T'(r_out) = 0.
    """

    def f(r, y):
        return np.vstack([y[1], -y[1] / r - 2 * eps * SIGMA / (k * t) * (T_sink**4 - y[0] ** 4)])

    def bc(a, b):
        return np.array([a[0] - T_in, b[1]])

    r = np.linspace(r_in, r_out, 401)
    sol = solve_bvp(f, bc, r, np.vstack([np.full_like(r, T_in), np.zeros_like(r)]), tol=1e-9, max_nodes=200000)
    assert sol.status == 0, sol.message
    return sol


def beam_reference(k=170.0, w=0.01, eps=1.0, L=1.0, q=1.0, T_root=293.15, T_sink=173.15):
    """Conductive-radiative beam, thesis eq. 4.16 (steady): T'' + 4εσ/(k w) (T_sink⁴ − T⁴) + q/(k w²) = 0,
    T(0) = T_root, T'(L) = 0.  Solved with solve_bvp."""

    def f(x, y):
        return np.vstack([y[1], -4 * eps * SIGMA / (k * w) * (T_sink**4 - y[0] ** 4) - q / (k * w * w)])

    def bc(a, b):
        return np.array([a[0] - T_root, b[1]])

    x = np.linspace(0, L, 401)
    sol = solve_bvp(f, bc, x, np.vstack([np.full_like(x, T_root), np.zeros_like(x)]), tol=1e-9, max_nodes=200000)
    assert sol.status == 0, sol.message
    return sol


@pytest.fixture
def tmp_case_dir(tmp_path):
    return tmp_path
