"""The case file: the DESIGN §4.2 example parses into validated dataclasses."""

from __future__ import annotations

import pytest

from fem2tmm import Fem2TmmError
from fem2tmm.case import Case

DESIGN_EXAMPLE = """
[mesh]
file = "baffle.msh"
unit = "mm"

[materials.aluminium]
conductivity = 170.0
density = 2700.0
specific_heat = 900.0

[optics.polished_al]
emissivity = 0.05
absorptivity = 0.2
specular = 1.0
transmissivity = 0.0

[[parts]]
name = "cone"
groups = ["cone"]
material = "aluminium"
thickness = 1.0e-3
front = "polished_al"
back = "polished_al"
super_nodes = 60
quadric = false

[[boundary]]
kind = "temperature"
groups = ["screws"]
value = 20.0

[[boundary]]
kind = "power"
nodes = [101, 102]
value = 3.0

[environment]
sink_temperature = -100.0
sun_direction = [-1.0, 1.0, 0.0]
solar_flux = 17400.0

[radiation]
rays_per_face = 1000
seed = 0

[reduction]
method = "local"

[reference]
detailed = true
"""


def test_design_example_parses(tmp_path):
    p = tmp_path / "case.toml"
    p.write_text(DESIGN_EXAMPLE)
    c = Case.from_toml(p)
    assert c.mesh.file == tmp_path / "baffle.msh" and c.mesh.unit == "mm"
    assert c.materials["aluminium"].conductivity == 170.0
    assert c.optics["polished_al"].specular == 1.0
    (part,) = c.parts
    assert part.super_nodes == 60 and part.front == "polished_al" and part.thickness == 1e-3
    t, pw = c.boundaries
    assert t.value == pytest.approx(293.15) and t.groups == ("screws",)
    assert pw.nodes == (101, 102) and pw.value == 3.0
    assert c.environment.sink_temperature == pytest.approx(173.15)
    s = 2**-0.5
    assert c.environment.sun_direction == pytest.approx((-s, s, 0.0))
    assert c.radiation.rays_per_face == 1000 and c.reduction.method == "local" and c.reference.detailed


@pytest.mark.parametrize("patch, message", [
    (("rays_per_face = 1000", "rays_per_face = 1000\nray_density = 5.0"), r"either rays_per_face or ray_density"),
    (('kind = "power"', 'kind = "heat"'), r"\[\[boundary\]\]\[1\].kind: must be one of"),
    (("value = 20.0", "value = -300.0"), r"\[\[boundary\]\]\[0\].value: must be > -273.15"),
    (("super_nodes = 60", "super_nodes = 0"), r"super_nodes: must be >= 1"),
    (("super_nodes = 60", "super_nodes = 2.5"), r"super_nodes: expected an integer"),
    (('method = "local"', 'method = "fast"'), r"\[reduction\].method: must be one of 'local', 'global'"),
    (("transmissivity = 0.0", "transmissivity = 0.99"), r"emissivity \+ transmissivity = 1.04 exceeds 1"),
    (("sun_direction = [-1.0, 1.0, 0.0]", "sun_direction = [0, 0, 0]"), r"must not be the zero vector"),
    (('front = "polished_al"', 'front = "gold"'), r"'gold' is not a defined optics"),
])
def test_errors_name_file_and_key(tmp_path, patch, message):
    p = tmp_path / "bad.toml"
    p.write_text(DESIGN_EXAMPLE.replace(*patch))
    with pytest.raises(Fem2TmmError, match=message) as e:
        Case.from_toml(p)
    assert str(p) in str(e.value)


def test_invalid_toml(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[mesh\nfile = 1")
    with pytest.raises(Fem2TmmError, match=r"not valid TOML"):
        Case.from_toml(p)
