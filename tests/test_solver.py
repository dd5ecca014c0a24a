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


def test_faced_radiation_newton_krylov_equals_dense_newton():
    mesh = shapes.plate(0.3, 0.2, 12, 8)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "al", "thickness": 1e-4,
                       "front": "black", "back": "black"}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                      {"kind": "power", "groups": ["plate"], "value": 5.0}])
    model = build_model(mesh, case)
    base = detailed_problem(model)
    W = model.faces.W
    f = W.shape[0]
    # a random symmetric, non-negative face-to-face coupling (m²), sparse
    G = sp.random(f, f, density=0.05, random_state=1) * 1e-4
    G = sp.csr_matrix(G + G.T)
    faced = dataclasses.replace(base, faced=FacedRadiation(W=W, G=G))
    # the same problem with a dense K takes the direct (assembled-Jacobian) Newton path
    node = dataclasses.replace(faced, K=model.K.toarray())
    s1 = solve_steady(faced)
    s2 = solve_steady(node)
    assert s1.stats["gmres_iterations"] > 0  # the Krylov path ran
    assert np.abs(s1.T - s2.T).max() < 1e-9
    assert s1.balance["relative"] < 1e-9 and s2.balance["relative"] < 1e-9
    # face-to-face exchange is internal: the same heat leaves through the fixed edge and the sink
    assert abs(s1.balance["imbalance_W"]) < 1e-9 * s1.balance["applied_W"]
