"""Steady solver: the Newton-Krylov path for factored face radiation equals the direct Newton path."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import make_case
from fem2tmm.mesh import shapes
from fem2tmm.fem.model import build_model
from fem2tmm.pipeline import detailed_problem
from fem2tmm.solve.steady import FacedRadiation, SteadyProblem, solve_steady


def faced_plate():
    """(model, problem): a held, heated black plate whose detailed problem has a random symmetric, non-negative
    face-to-face coupling (m², sparse)."""
    mesh = shapes.plate(0.3, 0.2, 12, 8)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-4,
                       "front": "black", "back": "black"}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                      {"kind": "power", "groups": ["plate"], "value": 5.0}])
    model = build_model(mesh, case)
    f = model.faces.W.shape[0]
    G = sp.random(f, f, density=0.05, random_state=1) * 1e-4
    return model, dataclasses.replace(detailed_problem(model),
                                      faced=FacedRadiation(W=model.faces.W, G=sp.csr_matrix(G + G.T)))


def test_faced_radiation_newton_krylov_equals_dense_newton():
    model, faced = faced_plate()
    # the same problem with a dense K takes the direct (assembled-Jacobian) Newton path
    node = dataclasses.replace(faced, K=model.K.toarray())
    s1 = solve_steady(faced)
    s2 = solve_steady(node)
    assert s1.stats["gmres_iterations"] > 0  # the Krylov path ran
    assert np.abs(s1.T - s2.T).max() < 1e-9
    assert s1.balance["relative"] < 1e-9 and s2.balance["relative"] < 1e-9
    # face-to-face exchange is internal: the same heat leaves through the fixed edge and the sink
    assert abs(s1.balance["imbalance_W"]) < 1e-9 * s1.balance["applied_W"]


def test_faced_radiation_is_the_laplacian_of_the_node_couplings():
    """The face-to-face term is σ[diag(C1) − C]T⁴ with C = Wᵀ G W (lumped emission, FacedRadiation): checked
    against the explicit dense Laplacian on a random network, to round-off (1e-12 relative: float64 sums)."""
    import scipy.sparse as sp

    from fem2tmm.constants import SIGMA
    from fem2tmm.solve.steady import FacedRadiation, SteadyProblem, residual

    rng = np.random.default_rng(7)
    n, f = 9, 6
    W = rng.random((f, n)) * (rng.random((f, n)) < 0.5)
    W[np.arange(f), rng.integers(0, n, f)] += 1.0
    W /= W.sum(axis=1, keepdims=True)
    G = rng.random((f, f))
    G = 0.5 * (G + G.T)
    np.fill_diagonal(G, 0.0)
    T = 250.0 + 100.0 * rng.random(n)
    p = SteadyProblem(K=sp.csr_matrix((n, n)), Q=np.zeros(n), fixed=np.zeros(n, bool), T_fixed=np.zeros(n),
                      g_space=np.zeros(n), T_sink=3.0, faced=FacedRadiation(W=sp.csr_matrix(W), G=sp.csr_matrix(G)))
    C = W.T @ G @ W
    expected = SIGMA * (np.diag(C.sum(axis=1)) - C) @ T**4
    r = residual(p, T)
    np.testing.assert_allclose(r, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
    assert abs(r.sum()) < 1e-12 * np.abs(r).sum()  # energy conserved between the faces
    # and not the face-averaged form σ Wᵀ diag(G1) W T⁴ − σ C T⁴ (different whenever a face's nodes differ in T)
    other = SIGMA * (W.T @ (G.sum(axis=1) * (W @ T**4)) - C @ T**4)
    assert np.abs(r - other).max() > 1e-6 * np.abs(r).max()


def test_a_stalled_krylov_step_falls_back_to_the_exact_jacobian(monkeypatch):
    """Issue 31: when GMRES stalls (here forced: it returns its start vector and a failure flag), the Newton step is
    solved by a direct factorisation of the exact Jacobian, and the solve converges to the same field as the
    Krylov path (1e-9 K: the Newton tolerance)."""
    import scipy.sparse.linalg as spla

    _, faced = faced_plate()
    good = solve_steady(faced)
    monkeypatch.setattr(spla, "gmres", lambda A, b, **kw: (np.zeros_like(b), 1))
    stalled = solve_steady(faced)
    assert stalled.stats["direct_fallbacks"] >= 1
    assert np.abs(stalled.T - good.T).max() < 1e-9
    assert stalled.balance["relative"] < 1e-9


def _lone_network(sparse: bool):
    """4 nodes, each conducting to every other (0.1 W/K), node 0 held at 300 K, node 3 heated 2 W, each emitting to a
    3 K sink; and node 4, a radiator coupled only to the sink (g = 0.02 m²) and by GR = 0.01 m² to node 5, a fixed node at
    250 K, loaded with 0.5 W (a deck's hot-spot node beside its space node)."""
    n = 6
    K = np.zeros((n, n))
    for a in range(4):
        for b in range(a + 1, 4):
            K[a, a] += 0.1
            K[b, b] += 0.1
            K[a, b] = K[b, a] = -0.1
    GR = np.zeros((n, n))
    GR[4, 5] = GR[5, 4] = 0.01
    fixed = np.zeros(n, bool)
    fixed[[0, 5]] = True
    return SteadyProblem(K=sp.csr_matrix(K) if sparse else K, Q=np.array([0, 0, 0, 2.0, 0.5, 0]),
                         fixed=fixed, T_fixed=np.array([300.0, 0, 0, 0, 0, 250.0]),
                         g_space=np.array([0, 0.01, 0.01, 0.01, 0.02, 0]), T_sink=3.0,
                         GR=sp.csr_matrix(GR) if sparse else GR)


def test_a_radiator_coupled_only_to_the_sink_and_fixed_nodes_is_solved_in_closed_form():
    # Node 4's balance: σ (g + GR) T⁴ = Q + σ (g T_s⁴ + GR T_5⁴), solved before Newton starts; from 1 000 K, Newton on
    # T⁴ would take a quarter of the temperature a step at most before its quadratic end
    from fem2tmm.constants import SIGMA

    problem = _lone_network(sparse=True)
    exact = ((0.5 / SIGMA + 0.02 * 3.0**4 + 0.01 * 250.0**4) / 0.03) ** 0.25
    T0 = np.full(6, 1000.0)
    sol = solve_steady(problem, T0=T0, tol=1e-12)
    assert sol.T[4] == pytest.approx(exact, rel=1e-14)  # the closed form, untouched by the Newton steps
    # the same network with node 4 also conducting to node 3 is an ordinary node: Newton from 1 000 K takes more steps
    K = problem.K.toarray()
    K[3, 3] += 1e-6
    K[4, 4] += 1e-6
    K[3, 4] = K[4, 3] = -1e-6
    coupled = solve_steady(dataclasses.replace(problem, K=sp.csr_matrix(K)), T0=T0, tol=1e-12)
    assert coupled.T[4] == pytest.approx(exact, rel=1e-4)  # a conductor of 1e-6 W/K moves it by little
    assert sol.iterations < coupled.iterations
    assert sol.balance["relative"] < 1e-12


def test_a_dense_network_read_as_sparse_is_solved_dense_to_the_same_temperatures():
    # DENSE_NETWORK / DENSE_FILL: a small network whose K is mostly non-zero is solved with dense Jacobians; the
    # temperatures are the sparse path's to round-off (1e-10 K: Newton's tolerance 1e-12 K, LU round-off)
    from fem2tmm.solve import steady

    sparse_problem = _lone_network(sparse=True)
    dense_problem = _lone_network(sparse=False)
    assert steady._Operators(sparse_problem).dense  # 6 nodes, 16 of 36 entries non-zero: above DENSE_FILL
    a = solve_steady(sparse_problem, tol=1e-12)
    b = solve_steady(dense_problem, tol=1e-12)
    assert np.abs(a.T - b.T).max() < 1e-10


def test_a_lone_radiator_beside_a_sparse_network_is_solved_in_closed_form():
    # The same closed form on the sparse path (a 200-node conducting chain, 1.5 % of K non-zero, stays sparse): the
    # radiator's row and column of K hold no stored entry, its GR reaches only the held node
    from fem2tmm.constants import SIGMA
    from fem2tmm.solve import steady

    n = 202  # 0..199 the chain (0 held at 300 K, 199 heated 2 W), 200 the radiator, 201 held at 250 K
    main = np.zeros(n)
    main[:200] = 0.2
    main[[0, 199]] = 0.1
    off = np.zeros(n - 1)
    off[:199] = -0.1
    K = sp.diags([main, off, off], [0, 1, -1]).tocsr()
    K.eliminate_zeros()
    GR = sp.csr_matrix(([0.01, 0.01], ([200, 201], [201, 200])), shape=(n, n))
    fixed = np.zeros(n, bool)
    fixed[[0, 201]] = True
    T_fixed = np.zeros(n)
    T_fixed[[0, 201]] = [300.0, 250.0]
    Q = np.zeros(n)
    Q[[199, 200]] = [2.0, 0.5]
    g = np.full(n, 1e-3)
    g[[0, 201]] = 0.0
    g[200] = 0.02
    problem = SteadyProblem(K=K, Q=Q, fixed=fixed, T_fixed=T_fixed, g_space=g, T_sink=3.0, GR=GR)
    ops = steady._Operators(problem)
    assert not ops.dense
    start = np.where(fixed, T_fixed, 1000.0)
    found, T_found = ops.lone(np.flatnonzero(~fixed), start)
    assert found.tolist() == [200]  # the radiator alone: the chain's nodes conduct, the held nodes are not free
    sol = solve_steady(problem, T0=np.full(n, 1000.0), tol=1e-12)
    assert T_found[0] == sol.T[200]
    exact = ((0.5 / SIGMA + 0.02 * 3.0**4 + 0.01 * 250.0**4) / 0.03) ** 0.25
    assert sol.T[200] == pytest.approx(exact, rel=1e-14) and sol.balance["relative"] < 1e-12
