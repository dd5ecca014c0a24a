"""The cost curve's arithmetic (benchmarks/scaling.py, ``fem2tmm bench scaling``): the fitted exponents and the
memory gate of the 3·10⁶-element point.  The timed runs themselves are the benchmark's, not the tests'."""

import numpy as np
import pytest

from benchmarks import scaling


def _rows(p_stage: float, p_pipe: float):
    e = np.array([1e4, 1e5, 1e6])
    return [{"elements": int(x), "pipeline_s": 2.0 * (x / 1e4) ** p_pipe,
             "stages_s": {"reduce": 0.5 * (x / 1e4) ** p_stage}, "baselines_s": {"pardiso": 0.1 * (x / 1e4)},
             "detailed_solve_s": 0.3 * (x / 1e4) ** 1.1} for x in e]


def test_the_fit_returns_the_power_law_the_times_follow():
    # exact power laws: the least-squares slope on log-log is the exponent to round-off (3 decimals reported)
    ex = scaling.fit(_rows(1.15, 1.08))["exponents"]
    assert ex["reduce"] == pytest.approx(1.15, abs=1e-3)
    assert ex["pipeline"] == pytest.approx(1.08, abs=1e-3)
    assert ex["baseline_pardiso"] == pytest.approx(1.0, abs=1e-3)
    assert ex["detailed_solve"] == pytest.approx(1.1, abs=1e-3)


def test_the_large_point_needs_memory_in_proportion_to_its_elements():
    ok, need, avail = scaling.fits(scaling.LARGE)
    _, need_1m, _ = scaling.fits(395)
    # 6.4 n² quads: the 3·10⁶ point needs (685/395)² = 3.0x the 10⁶ point's memory (to the 0.1 GB rounding)
    assert need == pytest.approx(need_1m * (685 / 395) ** 2, abs=0.2)
    assert ok == (avail >= need)
