"""Steady solver: the Newton-Krylov path for factored face radiation equals the direct Newton path."""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from conftest import make_case
from fem2tmm.mesh import shapes
from fem2tmm.fem.model import build_model
from fem2tmm.pipeline import detailed_problem
from fem2tmm.solve.steady import FacedRadiation, solve_steady


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
