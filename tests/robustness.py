"""Generated small models for the robustness campaign (issue 31; a plate under an inactive lid, issue 42): shared by
tests/test_robustness.py (a budget that fits in the default run) and ``fem2tmm bench robustness`` (a longer
profile).

Every generated model must either solve, with both energy balances closed and every temperature within the bounds
of its sources of heat and cold, or stop with a :class:`~fem2tmm.Fem2TmmError` that names the cause.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import scipy.sparse as sp
from hypothesis import strategies as st

from fem2tmm import meshes
from fem2tmm.case import MIN_EMISSIVITY, Case
from fem2tmm.constants import KELVIN
from fem2tmm.errors import Fem2TmmError
from fem2tmm.pipeline import run
from fem2tmm.solve.steady import COLD_FIELD

#: kelvin: how far outside its sources' bounds a solution may lie (see check)
BOUND_TOLERANCE = 1e-3


def make_mesh(call: str):
    """The mesh of a generator call such as ``"plate(0.1, 0.1, 3, 3)"`` (functions of :mod:`fem2tmm.meshes`)."""
    return eval(call, {name: getattr(meshes, name) for name in ("plate", "box", "merge", "transform")})


@st.composite
def models(draw):
    """(case data, mesh, what): a random small shell or solid model; the case is parsed by :func:`check`, whose
    refusals count as outcomes."""
    kind = draw(st.sampled_from(["plate", "sliver", "box", "solid", "two_plates_at_a_node", "blocked"]))
    if kind == "plate":
        call = (f"plate({draw(st.floats(0.05, 0.5))!r}, {draw(st.floats(0.05, 0.5))!r}, {draw(st.integers(1, 12))}, "
                f"{draw(st.integers(1, 12))})")
        part_groups, held = ["plate"], "xmin"
    elif kind == "sliver":  # a thin sliver, one element across
        call = f"plate({draw(st.floats(0.2, 1.0))!r}, {draw(st.floats(1e-3, 5e-3))!r}, {draw(st.integers(4, 30))}, 1)"
        part_groups, held = ["plate"], "xmin"
    elif kind == "box":
        call = f"box(0.2, 0.15, 0.1, {draw(st.integers(1, 5))}, {draw(st.integers(1, 5))}, {draw(st.integers(1, 4))})"
        part_groups, held = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"], "zmin"
    elif kind == "solid":
        call = (f"box(0.2, 0.05, 0.05, {draw(st.integers(1, 8))}, {draw(st.integers(1, 3))}, "
                f"{draw(st.integers(1, 3))}, kind='solid', "
                f"element={draw(st.sampled_from(['hex8', 'tet4', 'wedge6']))!r})")
        part_groups, held = ["box"], "xmin"
    elif kind == "blocked":  # a plate under an inactive lid (optics "none": it shades and conducts, issue 42)
        n = draw(st.integers(1, 8))
        call = (f"merge(plate(0.2, 0.2, {n}, {n}), plate(0.2, 0.2, {n}, {n}, "
                f"origin=(0.0, 0.0, {draw(st.floats(0.01, 0.2))!r}), name='lid'))")
        part_groups, held = ["plate"], "xmin"  # xmin: both plates' edges (the lid is held with the plate)
    else:  # two plates touching at one corner node only
        call = "merge(plate(0.1, 0.1, 3, 3), transform(plate(0.1, 0.1, 3, 3), translation=(0.1, 0.1, 0.0)))"
        part_groups, held = ["plate"], "xmin"
    mesh = make_mesh(call)
    n_el = int(mesh.n_elements)
    eps = draw(st.one_of(st.just(0.0), st.floats(MIN_EMISSIVITY, 1.0)))  # below: refused (test_case)
    optics = {"paint": {"emissivity": eps, "absorptivity": draw(st.floats(0.0, 1.0)),
                        "specular": draw(st.sampled_from([0.0, 1.0, 0.5]))}}
    solid = kind == "solid"
    part = {"name": "p", "groups": part_groups, "material": "m", "front": "paint",
            "super_nodes": draw(st.integers(1, max(1, min(50, n_el))))}
    if not solid:
        part["thickness"] = draw(st.floats(1e-4, 5e-3))
        part["back"] = draw(st.sampled_from(["paint", "none"]))
    boundary = []
    hold = draw(st.booleans()) or kind == "blocked"  # the lid has no load of its own: held, else undetermined
    if hold:
        boundary.append({"name": "held", "kind": "temperature", "groups": [held],
                         "value": draw(st.floats(-150.0, 120.0))})
    heater = draw(st.floats(0.0, 1000.0))
    if heater > 0 or not hold:
        boundary.append({"name": "heater", "kind": "power", "groups": part_groups[:1] if kind != "box" else ["zmax"],
                         "value": heater})
    sink = draw(st.floats(0.0, 400.0)) - KELVIN
    if not hold and eps == 0.0:
        eps = 0.5  # a model with neither a held node nor emission has no steady solution: covered by the refusal test
        optics["paint"]["emissivity"] = eps
    data = {"materials": {"m": {"conductivity": 10 ** draw(st.floats(0.0, 3.0)), "density": 2000.0,
                                "specific_heat": 900.0}},
            "optics": optics, "parts": [part] + ([{"name": "lid", "groups": ["lid"], "material": "m",
                                                    "thickness": part.get("thickness", 1e-3), "front": "none",
                                                    "back": "none", "super_nodes": 1}] if kind == "blocked" else []),
            "boundary": boundary,
            "environment": {"sink_temperature": sink},
            "radiation": {"enabled": draw(st.booleans()), "rays_per_face": 50},
            "reduction": {"radiation_aware": draw(st.booleans()), "outer_iterations": 20},
            "reference": {"detailed": True, "rays_per_face": 10, "noise": False}}
    if draw(st.booleans()) and eps > 0:
        data["environment"].update(sun_direction=[0.3, 0.2, 1.0], solar_flux=1361.0)
    transient = draw(st.booleans())
    if transient:
        data["transient"] = {"end": 600.0, "step": 60.0, "initial_temperature": draw(st.floats(-100.0, 100.0))}
    return data, mesh, f"{call}: {n_el} elements, transient={transient}"


def check(data: dict, mesh) -> str:
    """Parse and run one generated model; return "solved" or "refused: <cause>", or raise AssertionError."""
    try:
        case = Case.from_dict(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = run(case, mesh=mesh)
    except Fem2TmmError as exc:
        msg = str(exc)
        assert "did not converge" not in msg and "singular" not in msg, f"solver failure on a well-posed model: {msg}"
        # the cause without the case's name and numbers, so that refusals group by kind
        cause = re.sub(r"[-+]?\d[\d.]*(e[-+]?\d+)?", "#", msg.removeprefix("<case>: ").split(";")[0])
        cause = re.sub(r"#(?:, #)*(?:, … \(# in all\))?", "#", cause)
        return "refused: " + cause[:120]
    s = r.summary
    for which in ("reduced", "detailed"):
        bal = s["energy_balance_W"].get(which)
        if bal:
            assert bal["relative"] < 1e-9, (which, bal)
    steady_lo = [case.environment.sink_temperature] + [b.value for b in case.boundaries if b.kind == "temperature"]
    det = r.detailed.solution
    fields = [("reduced", r.reduced.solution.T, steady_lo), ("detailed", None if det is None else det.T, steady_lo)]
    if case.transient is not None:
        for which, bal in s["transient"]["energy_balance"].items():
            if bal:
                assert bal["relative"] < 1e-9, ("transient", which, bal)
        start = steady_lo + [case.transient.initial_temperature]
        fields += [("reduced", r.transient.reduced.T, start),
                   ("detailed", None if r.transient.detailed is None else r.transient.detailed.T, start)]
    # bounds: between the coldest and the hottest source of heat or cold (sink, held temperatures, the start), and
    # above the hot bound only where heat is put in (heaters, Sun).  A network with negative conductances (the
    # thesis' exact condensation may have some) does not obey the maximum principle: its own solution is not held
    # to the bounds, the outcome says so
    heated = any(b.kind == "power" and b.value > 0 for b in case.boundaries) or case.environment.solar_flux > 0
    K = r.reduced.network.K.toarray() if sp.issparse(r.reduced.network.K) else np.asarray(r.reduced.network.K, float)
    off = K - np.diag(np.diag(K))
    monotone = not np.any(off > 1e-9 * np.abs(K).max())
    outside = []
    for which, T, lo in fields:
        if T is None:
            continue
        assert np.all(np.isfinite(T)) and np.all(T > 0), which
        # BOUND_TOLERANCE: the floating-point floor of the worst-conditioned generated models (a solid whose
        # conduction is 1e12 times its emission conductance near a 2.5 K sink: temperatures determined to 7e-4 K)
        ok = T.min() >= min(lo) - BOUND_TOLERANCE
        if not heated:
            # a field settling at 0 K stops on the residual floor, within COLD_FIELD of 0 K (solve.steady)
            ok = ok and T.max() <= max(lo) + BOUND_TOLERANCE + (COLD_FIELD if max(lo) < COLD_FIELD else 0.0)
        if not ok:
            assert which == "reduced" and not monotone, (which, float(T.min()), float(T.max()), lo)
            outside.append(which)
    return "solved, the network's negative conductances take it outside the bounds" if outside else "solved"
