"""Transient analysis (issue 17): the time steppers against closed forms, the thesis' transient beam
(§4.4.2, Fig. 4.12), periodic states, the steady limit and exact energy books."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import make_case
from fem2tmm import meshes
from fem2tmm.constants import KELVIN, SIGMA
from fem2tmm.fem.model import build_model, consistent_capacity
from fem2tmm.reduce.network import build_reduced
from fem2tmm.solve.steady import solve_steady
from fem2tmm.solve.transient import TransientProblem, TransientSettings, recover_series, solve_transient
from fem2tmm.solve.problems import reduced_problem
from fem2tmm.stages.cluster import cluster_model
from fem2tmm.timefunc import Series, Table
from test_detailed import square_tube_beam

#: every transient run balances its discrete energy books to this (issue 17)
ENERGY_RTOL = 1e-9


def problem_of(net, C, Q=None) -> TransientProblem:
    """A transient problem of an FE model or a reduced model with constant inputs (``Q`` overrides the loads)."""
    if hasattr(net, "fixed_mask"):  # FEModel
        fixed, T_fixed, g, K = net.fixed_mask, net.fixed_values, net.space_coupling(), net.K
    else:  # ReducedModel
        fixed, T_fixed, g, K = net.fixed, net.T_fixed, net.g_space, net.K
    return TransientProblem(K=K, C=C, Q=Series(net.Q) if Q is None else Q, fixed=fixed, T_fixed=Series(T_fixed),
                            g_space=g, T_sink=Table.constant(net.T_sink), GR=getattr(net, "GR", None))


def balanced(sol):
    e = sol.energy
    assert e["relative"] < ENERGY_RTOL and e["max_step_relative"] < ENERGY_RTOL, e
    assert e["stored_J"] == pytest.approx(e["applied_J"] - e["to_space_J"] - e["into_fixed_J"],
                                          abs=ENERGY_RTOL * (abs(e["applied_J"]) + abs(e["to_space_J"])
                                                             + abs(e["into_fixed_J"]) + abs(e["stored_J"])))
    return sol


# ------------------------------------------------------------------------------------------ thesis beam
def beam_case(n_sn: int, radiating: bool = False):
    w = 0.01
    side = "black" if radiating else "none"
    return make_case(
        [{"name": "beam", "groups": ["beam"], "material": "al", "thickness": w / 4, "front": side, "back": "none",
          "super_nodes": n_sn}],
        [{"kind": "temperature", "groups": ["root"], "value": 20.0},
         {"kind": "power", "groups": ["beam"], "value": 1.0}],
        environment={"sink_temperature": -100.0},
        clustering={"feature_angle": 91.0},  # the tube as one region (see test_reduced_pipeline)
        reference={"detailed": False},
    )


def beam_fourier(x, t, k=170.0, rho=2700.0, c=900.0, A=1e-4, q=1.0, L=1.0, T0=293.15, terms=500):
    """Heated beam, root fixed at T0, tip insulated, uniform q (W/m), start at T0 (separation of variables):
    T = T0 + q/(kA) (L x − x²/2) − Σ bₙ sin(λₙ x) exp(−α λₙ² t), λₙ = (2n−1)π/(2L), bₙ = 2q/(kA L λₙ³)."""
    n = np.arange(1, terms + 1)
    lam = (2 * n - 1) * np.pi / (2 * L)
    b = q / (k * A) * 2 / (L * lam**3)
    return T0 + q / (k * A) * (L * x - x**2 / 2) - (np.sin(np.outer(x, lam)) * np.exp(-k / (rho * c) * lam**2 * t)) @ b


@pytest.fixture(scope="module")
def beam_runs():
    """Detailed FE and reduced (1 and 2 super nodes) transients of the thesis beam, CN with 30 s steps."""
    mesh = square_tube_beam(1000, 1.0, 0.01)
    settings = TransientSettings(end=600 * 60.0, step=30.0, output_every=60.0, method="crank-nicolson")
    model = build_model(mesh, beam_case(1))
    detailed = balanced(solve_transient(problem_of(model, model.capacity), settings, 293.15))
    Td = np.array([model.node_temperatures(T) for T in detailed.T])
    out = {"mesh": mesh, "detailed": detailed, "Td": Td}
    for n in (1, 2):
        case = beam_case(n)
        model = build_model(mesh, case)
        rm = build_reduced(model, cluster_model(model, case), case)
        red = balanced(solve_transient(problem_of(rm, rm.C), settings, 293.15))
        Tr = recover_series(rm.reduction.recover, red.T, Series(model.Q), red.times)
        out[n] = np.array([model.node_temperatures(T) for T in Tr])
    return out


def test_transient_beam_detailed_matches_the_fourier_series(beam_runs):
    # snapshots of thesis Fig. 4.12 (20, 60, 120, 600 min): the 1000-element FE model against the exact series;
    # 5 mK covers the space (h² = 1e-6 m²) and time (CN, 30 s) discretisation (measured 0.7 mK at 20 min)
    x = beam_runs["mesh"].points[:, 0]
    times = beam_runs["detailed"].times
    for minutes in (20, 60, 120, 600):
        i = int(np.flatnonzero(np.isclose(times, minutes * 60.0))[0])
        exact = beam_fourier(x, minutes * 60.0)
        assert np.abs(beam_runs["Td"][i] - exact).max() < 5e-3, minutes


def test_transient_beam_reduced_error_matches_the_thesis(beam_runs):
    # thesis §4.4.2 / Fig. 4.12: the recovered reduced solution's largest error against the detailed FE solution
    # over space and time is 2.6 K with 1 super node and 0.6 K with 2 (root node its own boundary node);
    # issue 17: within 0.15 K.  The error is largest during the warm-up and vanishes towards steady state.
    times = beam_runs["detailed"].times
    Td = beam_runs["Td"]
    for n_sn, thesis in ((1, 2.6), (2, 0.6)):
        err = np.abs(beam_runs[n_sn] - Td)
        assert err.max() == pytest.approx(thesis, abs=0.15), (n_sn, err.max())
        per_time = err.max(axis=1)
        t_max = times[per_time.argmax()]
        assert 20 * 60 <= t_max <= 120 * 60, t_max  # Fig. 4.12: the worst snapshots are 60 and 120 min
        i600 = int(np.flatnonzero(np.isclose(times, 36000.0))[0])
        assert per_time[i600] < 0.1 * err.max()  # close to steady state the reduction is exact again
    assert np.abs(beam_runs[2] - Td).max() < 0.3 * np.abs(beam_runs[1] - Td).max()


# ----------------------------------------------------------------------------------- radiative cooling
def test_radiative_cooling_orders_of_convergence():
    # one lumped node radiating to a 0 K sink: C dT/dt = −εσA T⁴, T(t) = (T0⁻³ + 3εσA t / C)^(−1/3).
    # Measured order in the step (least-squares slope over h, h/2, h/4, h/8): 1 for backward Euler, 2 for
    # Crank-Nicolson and BDF2, within 0.1 (issue 17).
    C, epsA, T0, end = 1000.0, 0.01, 600.0, 20000.0
    prob = TransientProblem(K=sp.csr_matrix((1, 1)), C=np.array([C]), Q=Series(np.zeros(1)), fixed=np.zeros(1, bool),
                            T_fixed=Series(np.zeros(1)), g_space=np.array([epsA]), T_sink=Table.constant(0.0))
    exact = (T0**-3 + 3 * epsA * SIGMA * end / C) ** (-1 / 3)
    ns = np.array([100, 200, 400, 800])
    for method, order in (("backward-euler", 1), ("crank-nicolson", 2), ("bdf2", 2)):
        errs = []
        for n in ns:
            sol = balanced(solve_transient(prob, TransientSettings(end=end, step=end / n, method=method), T0))
            errs.append(abs(sol.T[-1, 0] - exact))
        slope = np.polyfit(np.log(end / ns), np.log(errs), 1)[0]
        assert slope == pytest.approx(order, abs=0.1), (method, slope, errs)


# ------------------------------------------------------------------------------------------------ slab
@pytest.mark.parametrize("method,capacitance", [("crank-nicolson", "lumped"), ("crank-nicolson", "consistent"),
                                                ("bdf2", "lumped")])
def test_slab_step_in_surface_temperature_matches_the_fourier_series(method, capacitance):
    # a 0.1 m aluminium slab (200 hex8 in a row) at 20 °C whose face x = 0 is held at 120 °C from t = 0, the
    # other faces insulated: T = T1 + (T0 − T1) Σ 4/((2n−1)π) sin(λₙx) exp(−αλₙ²t), λₙ = (2n−1)π/(2L).
    # Issue 17: within 0.01 K at 0.05, 0.2 and 1 diffusion time L²/α, with adaptive steps (2e-4 K local error).
    L = 0.1
    mesh = meshes.box(L, 0.01, 0.01, 200, 1, 1, kind="solid")
    case = make_case([{"name": "slab", "groups": ["box"], "material": "al", "front": "none"}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 120.0}])
    model = build_model(mesh, case)
    C = model.capacity if capacitance == "lumped" else consistent_capacity(model)
    alpha = 170.0 / (2700.0 * 900.0)
    tau = L * L / alpha
    sol = balanced(solve_transient(problem_of(model, C), TransientSettings(
        end=tau, tolerance=2e-4, output_every=0.05 * tau, method=method), 20.0 + KELVIN))
    x = mesh.points[:, 0]
    n = np.arange(1, 401)
    lam = (2 * n - 1) * np.pi / (2 * L)
    for f in (0.05, 0.2, 1.0):
        i = int(np.argmin(np.abs(sol.times - f * tau)))
        assert sol.times[i] == pytest.approx(f * tau, rel=1e-12)
        exact = 393.15 - 100.0 * (np.sin(np.outer(x, lam)) * np.exp(-alpha * lam**2 * f * tau)) @ (4 / ((2 * n - 1) * np.pi))
        assert np.abs(model.node_temperatures(sol.T[i]) - exact).max() < 0.01, f
    assert sol.energy["into_fixed_J"] < 0  # heat flows out of the hot boundary into the slab


def test_consistent_capacitance_rows_sum_to_the_lumped_one():
    mesh = meshes.merge(meshes.plate(0.2, 0.1, 6, 3, name="a"), meshes.plate(0.2, 0.1, 4, 2, element="tri3",
                                                                              origin=(0, 0, 0.1), name="b"))
    case = make_case([{"name": "a", "groups": ["a"], "material": "al", "thickness": 1e-3},
                      {"name": "b", "groups": ["b"], "material": "al", "thickness": 2e-3}])
    model = build_model(mesh, case)
    C = consistent_capacity(model)
    assert abs(C - C.T).max() == 0.0
    np.testing.assert_allclose(np.asarray(C.sum(axis=1)).ravel(), model.capacity, rtol=1e-13)
    # ρ c t A in total: 2700·900·(1e-3·0.02 + 2e-3·0.02) J/K
    assert C.sum() == pytest.approx(2700 * 900 * (1e-3 * 0.02 + 2e-3 * 0.02), rel=1e-12)


# -------------------------------------------------------------------------------------------- periodic
def test_periodic_state_equals_twenty_periods_from_a_far_start():
    # a 5 mm black plate radiating to ~3 K under a sinusoidal flux 500 (1 + sin 2πt/P) W/m² (P = 6000 s): the
    # periodic iteration (repeat the period until two successive periods differ by < 1e-3 K) equals the last
    # period of a plain run over 20 periods started 140 K below the orbit, within periodic_tolerance.
    mesh = meshes.plate(0.2, 0.2, 8, 8)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 5e-3, "front": "black",
                       "back": "black"}], [{"kind": "flux", "groups": ["plate"], "value": 1.0}],
                     environment={"sink_temperature": -270.0})
    model = build_model(mesh, case)
    P, tol = 6000.0, 1e-3
    t = np.linspace(0, P, 121)
    per = balanced(solve_transient(problem_of(model, model.capacity, Series(0 * model.Q, (model.Q,),
                                                                            (Table(t, 500 * (1 + np.sin(2 * np.pi * t / P))),))),
                                   TransientSettings(end=P, step=60.0, output_every=600.0, periodic=True,
                                                     periodic_tolerance=tol), 293.15))
    assert per.stats["periods"] >= 3 and per.stats["period_changes_K"][-1] < tol
    # over one period of the periodic state the stored energy returns (to the last period's change)
    assert abs(per.energy["stored_J"]) < 1e-3 * per.energy["applied_J"]
    assert per.energy["applied_J"] == pytest.approx(500 * 0.04 * P, rel=1e-12)
    t20 = np.concatenate([t[:-1] + k * P for k in range(20)] + [[20 * P]])
    far = balanced(solve_transient(problem_of(model, model.capacity, Series(0 * model.Q, (model.Q,),
                                                                            (Table(t20, 500 * (1 + np.sin(2 * np.pi * t20 / P))),))),
                                   TransientSettings(end=20 * P, step=60.0, output_every=600.0), 150.0))
    last = far.T[-len(per.times):]
    assert np.abs(last - per.T).max() < tol


# ---------------------------------------------------------------------------------------- steady limit
def test_long_time_reduced_transient_equals_the_steady_reduced_solution():
    # the radiating thesis beam reduced to 2 super nodes: integrated (BDF2, adaptive) for 3·10⁵ s ≈ 50 time
    # constants from 20 °C, it must land on the steady reduced solution within 1e-6 K (issue 17)
    mesh = square_tube_beam(200, 1.0, 0.01)
    case = beam_case(2, radiating=True)
    model = build_model(mesh, case)
    rm = build_reduced(model, cluster_model(model, case), case)
    steady = solve_steady(reduced_problem(rm), tol=1e-12)
    sol = balanced(solve_transient(problem_of(rm, rm.C), TransientSettings(end=3e5, tolerance=1e-3,
                                                                            method="bdf2"), 293.15))
    assert np.abs(sol.T[-1] - steady.T).max() < 1e-6
    assert sol.energy["to_space_J"] > 0
    # and "steady" as the initial state stays there
    again = balanced(solve_transient(problem_of(rm, rm.C), TransientSettings(end=1e4, step=1e3), "steady"))
    assert np.abs(again.T - steady.T).max() < 1e-6


# -------------------------------------------------------------------------------------------- case file
def test_case_file_time_tables_and_transient_section(tmp_path):
    (tmp_path / "sink.csv").write_text("time_s, sink_C\n0, -100\n# eclipse\n3000, -200\n6000, -100\n")
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": [[0, 20.0], [600, 40.0]]},
                      {"kind": "power", "groups": ["plate"], "value": [[0, 0.0], [1000, 5.0]]}],
                     environment={"sink_temperature": str(tmp_path / "sink.csv")},
                     transient={"start": 300.0, "end": 6000.0, "step": 60.0})
    b0, b1 = case.boundaries
    assert b0.table(300.0) == pytest.approx(303.15) and b0.value == pytest.approx(303.15)  # value at start, K
    assert b0.table(-5.0) == pytest.approx(293.15) and b0.table(1e6) == pytest.approx(313.15)  # constant outside
    assert b1.value == pytest.approx(1.5) and b1.table(500.0) == pytest.approx(2.5)
    env = case.environment
    assert env.sink_table(1500.0) == pytest.approx(-150.0 + KELVIN) and env.sink_temperature == pytest.approx(-110 + KELVIN)
    tr = case.transient
    assert (tr.method, tr.capacitance, tr.initial_temperature, tr.periodic) == ("crank-nicolson", "lumped", "steady", False)
    from fem2tmm.errors import Fem2TmmError

    bad = [({"kind": "power", "groups": ["plate"], "value": [[0, 1.0], [0, 2.0]]}, {}, "strictly increasing"),
           ({"kind": "power", "groups": ["plate"], "value": [[0, 1.0, 3.0]]}, {}, "[time (s), value] pairs"),
           ({"kind": "power", "groups": ["plate"], "value": "missing.csv"}, {}, "cannot read"),
           ({"kind": "power", "groups": ["plate"], "value": 1.0}, {"end": 10.0}, "'step'"),
           ({"kind": "power", "groups": ["plate"], "value": 1.0}, {"end": 10.0, "step": 1.0, "method": "rk4"}, "method")]
    for b, tr, words in bad:
        with pytest.raises(Fem2TmmError, match=None) as exc:
            make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3}], [b],
                      **({"transient": tr} if tr else {}))
        assert words in str(exc.value) and ("[boundary]" in str(exc.value) or "[transient]" in str(exc.value)), exc.value


def test_factored_face_radiation_reaches_the_steady_solution():
    # the detailed model's face-to-face radiation in factored form Wᵀ G W (GMRES on the exact Newton matrix,
    # preconditioned by the lumped-face factorisation): the long-time transient equals the steady solver's
    # answer (independent Newton-Krylov) within 1e-6 K
    from fem2tmm.solve.steady import FacedRadiation

    mesh = meshes.plate(0.2, 0.2, 6, 6)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                       "back": "black"}], [{"kind": "temperature", "nodes": [1], "value": 20.0},
                                           {"kind": "flux", "groups": ["plate"], "value": 200.0}],
                     environment={"sink_temperature": -150.0})
    model = build_model(mesh, case)
    f = model.faces.n
    G = sp.random(f, f, density=0.3, random_state=1)
    G = ((G + G.T) * 1e-3).tocsr()
    G.setdiag(0)
    prob = TransientProblem(K=model.K, C=model.capacity, Q=Series(model.Q), fixed=model.fixed_mask,
                            T_fixed=Series(model.fixed_values), g_space=model.space_coupling(),
                            T_sink=Table.constant(model.T_sink), faced=FacedRadiation(W=model.faces.W, G=G.tocsr()))
    sol = balanced(solve_transient(prob, TransientSettings(end=2e5, tolerance=1e-3, method="bdf2"), 250.0))
    steady = solve_steady(prob.steady_problem(0.0), tol=1e-12)
    assert np.abs(sol.T[-1] - steady.T).max() < 1e-6


# ------------------------------------------------------------------------------------------- pipeline
def test_pipeline_transient_beam_reproduces_the_thesis_error():
    # the same thesis beam through `run` with [transient]: the summary's accuracy over space and time is the
    # 2.6 K of thesis Fig. 4.12 (1 super node, within 0.15 K), both models' books balance
    from fem2tmm.pipeline import run

    case = beam_case(1)
    case = make_case([p for p in case.raw["parts"]], case.raw["boundary"], environment={"sink_temperature": -100.0},
                     clustering={"feature_angle": 91.0}, reference={"detailed": True},
                     transient={"end": 36000.0, "step": 30.0, "output_every": 600.0, "initial_temperature": 20.0})
    res = run(case, mesh=square_tube_beam(1000, 1.0, 0.01))
    tr = res.summary["transient"]
    assert tr["accuracy"]["max_K"] == pytest.approx(2.6, abs=0.15)
    assert 20 * 60 <= tr["accuracy"]["time_of_max_s"] <= 120 * 60
    for k in ("reduced", "detailed"):
        assert tr["energy_balance"][k]["relative"] < ENERGY_RTOL
    # 1 W for 10 h: applied energy 36 kJ exactly, in both models
    assert tr["energy_balance"]["reduced"]["applied_J"] == pytest.approx(36000.0, rel=1e-12)
    assert tr["energy_balance"]["detailed"]["applied_J"] == pytest.approx(36000.0, rel=1e-12)


def test_pipeline_transient_tables_and_outputs(tmp_path):
    # a plate whose edge temperature ramps 20 -> 40 °C and whose flux follows a triangle 100 -> 400 -> 100 W/m²
    # (time tables); the outputs: transient.npz, the ParaView series, Nastran TEMP with one SID per output time,
    # decks with the interpolation arrays; the applied energy is the scheme's integral of the table (the kinks lie
    # on step boundaries, where the trapezoidal rule of Crank-Nicolson is exact)
    import json

    from fem2tmm.pipeline import run

    mesh = meshes.plate(0.2, 0.1, 20, 10)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                       "back": "black", "super_nodes": 4}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": [[0, 20.0], [3000, 40.0]], "name": "edge"},
                      {"kind": "flux", "groups": ["plate"], "value": [[0, 100.0], [1500, 400.0], [3000, 100.0]]}],
                     environment={"sink_temperature": -100.0}, radiation={"enabled": False},
                     transient={"end": 3000.0, "step": 60.0, "output_every": 300.0})
    with pytest.warns(UserWarning):  # part of the flux falls on the fixed edge
        res = run(case, mesh=mesh, out=tmp_path / "out")
    out = tmp_path / "out"
    tr = json.loads((out / "summary.json").read_text())["transient"]
    times = np.arange(0.0, 3001.0, 300.0)
    np.testing.assert_allclose(tr["times_s"], times)
    assert tr["nastran_sid_time_s"] == {str(k + 1): t for k, t in enumerate(times)}
    for k in ("reduced", "detailed"):
        e = tr["energy_balance"][k]
        assert e["relative"] < ENERGY_RTOL
        # ∫ q A dt = 0.02 m² · (100 + 400)/2 W/m² · 3000 s (the part on the fixed edge included), plus what the
        # scheme adds: Crank-Nicolson starts with two backward-Euler steps that take the end value of the rising
        # load, (h/2)·ΔQ each with ΔQ = 0.02 m² · 0.2 W/(m² s) · 60 s
        assert e["applied_J"] == pytest.approx(0.02 * 250.0 * 3000.0 + 2 * 30.0 * 0.02 * 0.2 * 60.0, rel=1e-12)
    assert tr["accuracy"]["max_K"] > 0 and tr["accuracy"]["rms_K"] <= tr["accuracy"]["max_K"]
    data = np.load(out / "transient.npz")
    ok = res.model.node_dof >= 0
    np.testing.assert_array_equal(data["node_id"], mesh.node_ids[ok])
    assert data["temperature"].shape == (len(times), ok.sum()) == data["reference_temperature"].shape
    assert data["sn_temperature"].shape == (len(times), res.reduced.network.n)
    edge = np.isin(data["node_id"], mesh.node_ids[mesh.groups["xmin"].nodes])
    ramp = (20.0 + 20.0 * times / 3000.0)[:, None]
    assert np.abs(data["temperature"][:, edge] - ramp).max() < 1e-9
    assert np.abs(data["reference_temperature"][:, edge] - ramp).max() < 1e-9
    pvd = (out / "temperatures.pvd").read_text()
    assert pvd.count("<DataSet") == len(times) and (out / "transient" / "temperatures_0010.vtu").is_file()
    bdf = (out / "temperatures_transient.bdf").read_text()
    assert "$   SID 11 = 3000 s" in bdf and bdf.count("TEMPD*") == len(times)
    esatan, sinda = (out / "model.esatan").read_text(), (out / "model.sinda").read_text()
    # the flux table as multiples of its named constant (issue 41: the load counted once, FLUX_1 = 0 turns it off)
    assert "QTAB1(6) = 0.0, 1.0, 1500.0, 4.0, 3000.0, 1.0;" in esatan and "SLCRNC;" in esatan
    assert "FLUX_1 = 100.0;" in esatan and "* FLUX_1 * INTRP1(TIMEM, QTAB1);" in esatan
    assert "TTAB1(4) = 0.0, 20.0, 3000.0, 40.0;" in esatan and "DTIMEI = 60.0;" in esatan
    assert "CALL FWDBCK" in sinda and "D1DEG1(TIMEM, A1)" in sinda  # FWDBCK: SINDA/FLUINT's Crank-Nicolson
    assert (out / "transient_temperatures.png").is_file() and (out / "transient_error.png").is_file()


def test_transient_without_capacitance_is_refused_before_computing():
    from fem2tmm.errors import Fem2TmmError
    from fem2tmm.pipeline import run

    case = make_case([{"name": "p", "groups": ["plate"], "material": "k", "thickness": 1e-3}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 20.0}],
                     materials={"k": {"conductivity": 100.0}}, transient={"end": 10.0, "step": 1.0})
    with pytest.raises(Fem2TmmError, match=r"\[transient\] needs the capacitance.*'p'"):
        run(case, mesh=meshes.plate(0.1, 0.1, 2, 2))


def test_pipeline_periodic_transient():
    # [transient] periodic through `run`: a radiating plate under a sinusoidal flux (table) reaches its periodic
    # state in both models; over the last period the stored energy returns to within the last period change
    from fem2tmm.pipeline import run

    P = 6000.0
    t = np.linspace(0.0, P, 61)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 2e-3, "front": "black",
                       "back": "black", "super_nodes": 2}],
                     [{"kind": "flux", "groups": ["plate"],
                       "value": [[float(a), float(300 * (1 + np.sin(2 * np.pi * a / P)))] for a in t]}],
                     environment={"sink_temperature": -270.0}, radiation={"enabled": False},
                     transient={"end": P, "step": 100.0, "output_every": 600.0, "periodic": True,
                                "periodic_tolerance": 1e-3, "initial_temperature": 0.0})
    res = run(case, mesh=meshes.plate(0.2, 0.1, 10, 5))
    tr = res.summary["transient"]
    assert tr["periods"] >= 3 and tr["period_changes_K"][-1] < 1e-3
    for k in ("reduced", "detailed"):
        e = tr["energy_balance"][k]
        assert e["relative"] < ENERGY_RTOL and e["applied_J"] == pytest.approx(0.02 * 300 * P, rel=1e-12)
        assert tr["solver"][k]["period_changes_K"][-1] < 1e-3
        # C·ΔT over one period is bounded by the last period change (1e-3 K) times the capacitance (97 J/K)
        assert abs(e["stored_J"]) < 2700 * 900 * 2e-3 * 0.02 * 1e-3


def test_consistent_capacitance_of_a_bar(tmp_path):
    # a CBAR (A = 3e-4 m², L = 1 m, ρc = 2700·900) between two Nastran plates: its consistent block is
    # ρ c A L / 6 [[2, 1], [1, 2]] (exact ∫NᵢNⱼ of linear shape functions) and every row sums to the lumped value
    from fem2tmm.io import read_mesh
    from test_nastran_structural import HEAT_FIX, PLATES, card, case_for, quiet, two_plates, write

    deck = write(tmp_path, two_plates([card("CBAR", 900, 3, 6, 104, 0.0, 0.0, 1.0), card("PBAR", 3, 30, 3e-4),
                                       card("MAT4", 30, 150.0, 900.0, 2700.0)]))
    mesh = quiet(read_mesh, deck)
    model = build_model(mesh, case_for(deck, [*PLATES, {"name": "bar", "groups": ["PID 3"], "super_nodes": 1}],
                                       HEAT_FIX))
    C = consistent_capacity(model)
    np.testing.assert_allclose(np.asarray(C.sum(axis=1)).ravel(), model.capacity, rtol=1e-13)
    i6, i104 = model.node_dof[mesh.node_index([6, 104], where="test")]
    # GRIDs 6 and 104 share only the bar (the plates do not touch), so their coupling is the bar's alone
    assert C[i6, i104] == pytest.approx(2700.0 * 900.0 * 3e-4 * 1.0 / 6.0, rel=1e-12)


def test_cool_down_to_a_0_K_sink_with_the_detailed_reference_matches_the_closed_form():
    # Issue 31: a black 0.1 m aluminium plate, 1 mm, at 300 °C, no heater, sink at -273.15 °C, [transient] end
    # 600 s step 1 s, [reference] detailed = true, failed with "the radiative Newton step did not converge" in the
    # steady detailed solve (solution T = 0 K) that preceded every transient.  A transient from a given temperature
    # needs no steady solve.  Closed form of a lumped plate radiating from both sides (Bi = h L / k ~ 1e-5):
    # C dT/dt = -σ ε 2A T⁴  =>  T(t) = (T0⁻³ + 3 σ ε 2A t / C)^(-1/3); issue 31: within 0.2 K at every output time.
    from fem2tmm.pipeline import run

    plate = meshes.plate(0.1, 0.1, 6, 6)
    rho, c, t = 2700.0, 900.0, 1e-3
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": t, "front": "black",
                       "back": "black", "super_nodes": 2}],
                     environment={"sink_temperature": -273.15}, radiation={"enabled": False},
                     transient={"end": 600.0, "step": 1.0, "initial_temperature": 300.0, "output_every": 60.0},
                     reference={"detailed": True})
    r = run(case, mesh=plate)
    run_ = r.transient
    C = rho * c * t * 0.01
    T0 = 300.0 + KELVIN
    exact = (T0**-3 + 3 * SIGMA * 2 * 0.01 * run_.times / C) ** (-1.0 / 3.0)
    for T in (run_.T_recovered, run_.detailed.T):
        err = np.abs(T - exact[:, None]).max()
        assert err < 0.2, err  # measured 0.042 K (Crank-Nicolson, 1 s steps), reduced and detailed alike
    assert r.detailed.solution is None  # no steady reference was needed nor solved


def test_a_step_longer_than_the_transient_is_refused():
    from fem2tmm.errors import Fem2TmmError

    with pytest.raises(Fem2TmmError, match=r"step \(700.0 s\) is longer than the transient itself.*600"):
        make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-3, "front": "black",
                    "super_nodes": 2}], transient={"end": 600.0, "step": 700.0, "initial_temperature": 20.0})
