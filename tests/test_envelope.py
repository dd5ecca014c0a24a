"""The interpolation behind ``fem2tmm bench envelope_parametric`` (benchmarks/envelope.py): Lagrange on the nearest
points, checked on polynomials it must reproduce exactly (closed forms, to round-off)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from benchmarks.envelope import _interpolated  # noqa: E402


def test_quadratic_on_the_three_nearest_points_linear_with_two_constant_with_one():
    xs = np.array([60.0, 0.0, 30.0, 15.0, 45.0])  # unsorted, as the training states come
    rows = np.stack([2.0 + 0.5 * xs - 0.01 * xs**2, -xs**2])  # two "nodes", quadratics in x
    for x in (7.5, 22.0, 52.5, 60.0, 75.0, -10.0):  # inside, at a point, and extrapolated at both ends
        expect = np.array([2.0 + 0.5 * x - 0.01 * x**2, -x**2])
        assert np.allclose(_interpolated(xs, rows.T, x), expect, rtol=0, atol=1e-9)
    two = np.array([0.0, 20.0])
    assert np.allclose(_interpolated(two, np.array([[1.0], [3.0]]), 5.0), [1.5], atol=1e-12)  # linear
    assert np.allclose(_interpolated(np.array([4.0]), np.array([[7.0]]), 9.0), [7.0])  # constant
    # on a cubic the nearest three points decide: through 0/15/30 the quadratic is x³ − x(x − 15)(x − 30) (the
    # interpolation error of x³ is the node polynomial), −843.75 at 7.5; through 15/30/45 it would be 6750
    cubic = xs**3
    assert abs(_interpolated(xs, cubic[:, None], 7.5)[0] - (7.5**3 - 7.5 * (7.5 - 15) * (7.5 - 30))) < 1e-6
