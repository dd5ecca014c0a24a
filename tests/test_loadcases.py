"""Load cases and sweeps: [[cases]] deep-merged over the base file, [sweep] grids/zips/random samples, safe names."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from fem2tmm import Fem2TmmError
from fem2tmm.case import Case, load_cases
from fem2tmm.loadcases import deep_merge, expand

BASE = """
[mesh]
file = "plate.msh"

[materials.al]
conductivity = 170.0

[optics.paint]
emissivity = 0.8
absorptivity = 0.3

[[parts]]
name = "plate"
groups = ["plate"]
material = "al"
thickness = 1e-3
front = "paint"

[[boundary]]
name = "root"
kind = "temperature"
groups = ["root"]
value = 20.0

[[boundary]]
name = "heater"
kind = "power"
groups = ["plate"]
value = 5.0
"""


def cases_of(extra: str, tmp_path):
    p = tmp_path / "case.toml"
    p.write_text(BASE + extra, encoding="utf-8")
    return load_cases(Case.from_toml(p))


def test_without_cases_the_file_is_one_case_unchanged(tmp_path):
    p = tmp_path / "case.toml"
    p.write_text(BASE, encoding="utf-8")
    case = Case.from_toml(p)
    [(name, c, params)] = load_cases(case)
    assert name == "" and c is case and params == {}


def test_cases_merge_tables_and_named_entries(tmp_path):
    got = cases_of("""
[[cases]]
name = "hot"
[cases.optics.paint]
absorptivity = 0.6
[cases.boundary.heater]
value = 12.0

[[cases]]
name = "cold"
[cases.boundary.1]
value = 0.5
[cases.environment]
sink_temperature = -150.0
""", tmp_path)
    hot, cold = (c for _, c, _ in got)
    assert [n for n, _, _ in got] == ["hot", "cold"]
    # only the overridden keys change; the others keep the base values
    assert (hot.optics["paint"].absorptivity, hot.optics["paint"].emissivity) == (0.6, 0.8)
    assert [b.value for b in hot.boundaries] == [293.15, 12.0]
    assert [b.value for b in cold.boundaries] == [293.15, 0.5]
    assert cold.environment.sink_temperature == pytest.approx(123.15, abs=1e-12)
    assert cold.optics["paint"].absorptivity == 0.3
    assert hot.name == "hot" and hot.source == str(tmp_path / "case.toml")
    assert hot.mesh.file == tmp_path / "plate.msh"  # paths stay relative to the case file


def test_array_of_tables_in_a_case_replaces_the_whole_list():
    base = tomllib.loads(BASE)
    merged = deep_merge(base, tomllib.loads('[[boundary]]\nkind = "temperature"\ngroups = ["x"]\nvalue = 1.0'))
    assert merged["boundary"] == [{"kind": "temperature", "groups": ["x"], "value": 1.0}]
    assert len(base["boundary"]) == 2  # the base is not modified


def test_errors_name_the_case_and_the_key(tmp_path):
    with pytest.raises(Fem2TmmError, match=r"\[case 'hot'\]: \[optics.paint\].absorptivity: must be <= 1"):
        cases_of('[[cases]]\nname = "hot"\n[cases.optics.paint]\nabsorptivity = 1.4\n', tmp_path)
    with pytest.raises(Fem2TmmError, match=r"\[case 'hot'\].*unknown key\(s\) 'absorbtivity'"):
        cases_of('[[cases]]\nname = "hot"\n[cases.optics.paint]\nabsorbtivity = 0.4\n', tmp_path)
    with pytest.raises(Fem2TmmError, match=r"boundary.heatr: no \[\[boundary\]\] entry is named 'heatr'.*root, heater"):
        cases_of('[[cases]]\nname = "hot"\n[cases.boundary.heatr]\nvalue = 1.0\n', tmp_path)


@pytest.mark.parametrize("names, message", [
    (["hot", "HOT"], "unique"),
    (["../x"], "safe folder name"),
    (["a b"], "safe folder name"),
    (["nul"], "reserved device name"),
    ([".hidden"], "safe folder name"),
])
def test_case_names_are_unique_safe_folder_names(names, message):
    raw = {**tomllib.loads(BASE), "cases": [{"name": n} for n in names]}
    with pytest.raises(Fem2TmmError, match=message):
        expand(raw, "case.toml")


def test_grid_and_zip_sweeps(tmp_path):
    got = cases_of("""
[sweep]
name = "hl"
[sweep.grid]
"optics.paint.absorptivity" = [0.2, 0.4]
[sweep.zip]
"boundary.heater.value" = [1.0, 2.0, 3.0]
"environment.sink_temperature" = [-100.0, -110.0, -120.0]
""", tmp_path)
    assert [n for n, _, _ in got] == [f"hl_{k}" for k in range(6)]
    alpha = [c.optics["paint"].absorptivity for _, c, _ in got]
    power = [c.boundaries[1].value for _, c, _ in got]
    assert alpha == [0.2, 0.2, 0.2, 0.4, 0.4, 0.4] and power == [1.0, 2.0, 3.0] * 2
    assert got[4][2] == {"optics.paint.absorptivity": 0.4, "boundary.heater.value": 2.0,
                         "environment.sink_temperature": -110.0}


def test_cases_times_sweep_points(tmp_path):
    got = cases_of("""
[[cases]]
name = "hot"
[[cases]]
name = "cold"
[sweep.grid]
"boundary.heater.value" = [1.0, 2.0]
""", tmp_path)
    assert [n for n, _, _ in got] == ["hot_sweep_0", "hot_sweep_1", "cold_sweep_0", "cold_sweep_1"]


def test_random_sweep_is_reproducible_and_sample_wise(tmp_path):
    spec = """
[sweep]
samples = {n}
seed = 7
[sweep.random]
"optics.paint.absorptivity" = {{ distribution = "uniform", low = 0.2, high = 0.4 }}
"boundary.heater.value" = {{ distribution = "normal", mean = 10.0, std = 1.0 }}
"""
    a = cases_of(spec.format(n=400), tmp_path)
    b = cases_of(spec.format(n=3), tmp_path)
    alpha = np.array([c.optics["paint"].absorptivity for _, c, _ in a])
    power = np.array([c.boundaries[1].value for _, c, _ in a])
    # a sample does not depend on how many are drawn
    assert [c.boundaries[1].value for _, c, _ in b] == list(power[:3])
    assert alpha.min() >= 0.2 and alpha.max() < 0.4
    # moments within 4 standard errors (n = 400): uniform mean 0.3, sd 0.2/sqrt(12); normal mean 10, sd 1
    assert abs(alpha.mean() - 0.3) < 4 * (0.2 / np.sqrt(12)) / np.sqrt(400)
    assert abs(power.mean() - 10.0) < 4 * 1.0 / np.sqrt(400)
    assert abs(power.std(ddof=1) - 1.0) < 4 * 1.0 / np.sqrt(2 * 399)
    # the two parameters come from independent streams (correlation within 4 / sqrt(n))
    assert abs(np.corrcoef(alpha, power)[0, 1]) < 4 / np.sqrt(400)


@pytest.mark.parametrize("sweep, message", [
    ('[sweep.grid]\n"optics.paint.absorptivity" = []', "non-empty list"),
    ('[sweep.zip]\n"a.b" = [1]\n"a.c" = [1, 2]', "same length"),
    ('[sweep.random]\n"a.b" = { distribution = "uniform", low = 0, high = 1 }', "needs 'samples'"),
    ('[sweep]\nsamples = 2\nseed = 1\n[sweep.random]\n"a.b" = { distribution = "beta" }', "distribution"),
    ('[sweep.grid]\n"cases.x" = [1]', "cannot change"),
])
def test_malformed_sweeps_are_refused_before_any_computation(tmp_path, sweep, message):
    p = tmp_path / "case.toml"
    p.write_text(BASE + sweep, encoding="utf-8")
    with pytest.raises(Fem2TmmError, match=message):
        Case.from_toml(p)  # checked when the file is read


def test_compute_table_and_scheduler_check(tmp_path):
    p = tmp_path / "case.toml"
    p.write_text(BASE + '[compute]\nscheduler = "tcp://10.0.0.1:8786"\n', encoding="utf-8")
    assert Case.from_toml(p).compute.scheduler == "tcp://10.0.0.1:8786"
    p.write_text(BASE + '[compute]\nscheduler = "cluster"\n', encoding="utf-8")
    with pytest.raises(Fem2TmmError, match=r"\[compute\].scheduler: expected 'serial', 'local'"):
        Case.from_toml(p)
