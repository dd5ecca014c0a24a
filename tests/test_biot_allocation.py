"""Biot-aware allocation (issue 21 item 3): ``[clustering] allocation = "biot"`` weights shell elements by their
Biot number h_rad A/(k t) from an emission-to-space pre-solve, and the per-element Bi > 1 warning; and
``allocation = "loads"``: smaller super nodes around the named loads."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import scipy.sparse as sp
import pytest

from conftest import make_case
from fem2tmm import meshes
from fem2tmm.errors import Fem2TmmError
from fem2tmm.fem.model import build_model
from fem2tmm.mesh.core import PropertyData
from fem2tmm.pipeline import run
from fem2tmm.reduce.biot import BIOT_EXPONENT, biot_weights
from fem2tmm.stages.cluster import cluster_model, presolve_space
from fem2tmm.solve.steady import SIGMA

T_THICK = 1e-3


def two_plates(k_a, k_b, n=20):
    """Two coplanar 0.2 x 0.2 m plates side by side (x in [0, 0.2] and [0.2, 0.4]), one part whose conductivity
    comes from the mesh (group a: k_a, group b: k_b), so that it splits into two regions."""
    a = meshes.plate(0.2, 0.2, n, n, name="a")
    b = meshes.plate(0.2, 0.2, n, n, name="b", origin=(0.2, 0.0, 0.0))
    mesh = meshes.merge(a, b)
    props = {"a": PropertyData(conductivity=k_a), "b": PropertyData(conductivity=k_b)}
    return dataclasses.replace(mesh, properties=props)


def two_plates_case(n_sn, allocation):
    # no fixed temperature, 8 W spread by area, black both sides: the exact steady field is uniform whatever k
    # (load per area = emission per area everywhere), so Bi_a / Bi_b = k_b / k_a exactly
    return make_case([{"name": "p", "groups": ["a", "b"], "thickness": T_THICK, "front": "black", "back": "black",
                       "super_nodes": n_sn}],
                     [{"kind": "power", "groups": ["a", "b"], "value": 8.0}],
                     environment={"sink_temperature": -270.0}, radiation={"enabled": False},
                     clustering={"allocation": allocation}, reference={"detailed": False})


def counts(model, clustering):
    """Super nodes on plate a (x < 0.2) and on plate b."""
    cen = model.mesh.points[model.element_cells[:, :4]].mean(axis=1)[:, 0]
    lab = clustering.labels[model.elements]
    return len(np.unique(lab[cen < 0.2])), len(np.unique(lab[cen > 0.2]))


def test_case_key_is_validated():
    assert two_plates_case(4, "area").clustering.allocation == "area"
    default = make_case([{"name": "p", "groups": ["a"], "material": "al", "thickness": T_THICK}])
    # the default since 2026-12-07: smaller super nodes around concentrated loads, equal areas elsewhere
    assert default.clustering.allocation == "loads"
    with pytest.raises(Fem2TmmError, match="allocation"):
        two_plates_case(4, "volume")


def test_uniform_biot_gives_the_area_allocation():
    # same k on both plates: uniform field, uniform Bi -> every weight is the area (times 1), the same clusters
    mesh = two_plates(5.0, 5.0)
    case_area, case_biot = two_plates_case(10, "area"), two_plates_case(10, "biot")
    model = build_model(mesh, case_area)
    T = presolve_space(model, case_area)
    # closed form: 8 W = 2 σ T⁴ · 0.08 m² (both sides of 0.08 m²) -> T = 249.9 K; Newton stopped at 0.1 K
    assert T == pytest.approx((8.0 / (2 * SIGMA * 0.08)) ** 0.25, abs=0.1)
    w, rep = biot_weights(model, T)
    area = model.mesh.element_areas(model.elements)
    assert (w == area).all()  # densities rounded to 9 digits: exactly 1 here
    # element Bi = 2·4σT³ A / (k t) = 8σT³ · 1e-4 / 5e-3 (1 cm quads): 0.14 at 250 K
    assert rep["p"]["max"] == pytest.approx(8 * SIGMA * T.mean() ** 3 * 1e-4 / (5.0 * T_THICK), rel=1e-6)
    ca = cluster_model(model, case_area)
    cb = cluster_model(model, case_biot, weights=w, weights_report=rep)
    assert counts(model, ca) == counts(model, cb)  # one region here (same k): clusters may straddle x = 0.2
    assert (ca.labels == cb.labels).all()
    assert cb.report["allocation"]["method"] == "biot"


def test_low_conductivity_plate_gets_more_super_nodes():
    # k = 5 against 170: Bi ratio 34 -> super nodes per area in ratio 34^(2/3) = 10.5 (BIOT_EXPONENT), 22 super
    # nodes: quotas 22·10.5/11.5 = 20.1 and 1.9 -> 20 / 2; area allocation 11 / 11
    mesh = two_plates(5.0, 170.0)
    res = {a: run(two_plates_case(22, a), mesh=mesh) for a in ("area", "biot")}
    model = res["area"].model
    assert counts(model, res["area"].reduced.clustering) == (11, 11)
    n_a, n_b = counts(model, res["biot"].reduced.clustering)
    ratio = (170.0 / 5.0) ** BIOT_EXPONENT
    assert n_a + n_b == 22 and abs(n_a - 22 * ratio / (1 + ratio)) < 1, (n_a, n_b)
    rep = res["biot"].summary["reduced"]["clustering"]["allocation"]
    assert rep["method"] == "biot" and rep["p"]["max"] / rep["p"]["mean"] == pytest.approx(2 * 34 / 35, rel=1e-6)
    assert "presolve_biot" in res["biot"].summary["timings_s"]


@pytest.mark.parametrize("n, fires", [(10, True), (30, False)])
def test_element_biot_over_one_warns_on_a_coarse_mesh_only(n, fires):
    # 0.3 x 0.09 m strip of k = 5, 1 mm, black both sides, held at 20 °C at x = 0: element Bi = 8σT³ A / (k t)
    # = 11.1 W/(m² K) · A / 5e-3 at 293 K: 2.0 for 3 cm quads (n = 10), 0.22 for 1 cm ones (n = 30)
    mesh = meshes.plate(0.3, 0.09, n, n * 3 // 10)
    for allocation, aware in (("area", True), ("biot", False)):
        case = make_case([{"name": "p", "groups": ["plate"], "material": "m", "thickness": T_THICK,
                           "front": "black", "back": "black", "super_nodes": 3}],
                         [{"kind": "temperature", "groups": ["xmin"], "value": 20.0}],
                         materials={"m": {"conductivity": 5.0}}, environment={"sink_temperature": -270.0},
                         radiation={"enabled": False}, clustering={"allocation": allocation},
                         reduction={"radiation_aware": aware, "outer_iterations": 1}, reference={"detailed": False})
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            run(case, mesh=mesh)
        hits = [x for x in w if "Biot number h_rad A/(k t) > 1" in str(x.message)]
        assert len(hits) == (1 if fires else 0), [str(x.message) for x in w]


def test_ir_on_faces_emits_from_the_fe_faces_and_agrees_with_super_faces_at_uniform_temperature():
    # Two facing black 0.2 m plates 5 cm apart.  ir_on = "faces" traces every FE side as its own emitter (the
    # same rays per FE face as ir_on = "detailed"); at a uniform temperature emitting per FE face or per super
    # face is the same physics, so the absorbed power per FE face agrees within the ray noise, and the run closes
    # its reduced energy balance.
    from fem2tmm.reduce.network import build_reduced
    from fem2tmm.stages.radiation import ir_absorption, radiation_surface

    a = meshes.plate(0.2, 0.2, 8, 8)
    b = meshes.transform(meshes.plate(0.2, 0.2, 8, 8), rotation=meshes.rotation("x", 180.0), translation=(0, 0.2, 0.05))
    mesh = meshes.merge(a, b)

    def case(ir_on):
        return make_case([{"name": "p", "groups": ["plate"], "material": "m", "thickness": T_THICK,
                           "front": "black", "back": "black", "super_nodes": 8}],
                         [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                          {"kind": "power", "groups": ["plate"], "value": 2.0}],
                         materials={"m": {"conductivity": 5.0}}, environment={"sink_temperature": -270.0},
                         radiation={"rays_per_face": 400, "ir_on": ir_on, "ir_rays_per_face": 200},
                         reduction={"radiation_aware": True}, reference={"detailed": True, "rays_per_face": 100})

    model = build_model(mesh, case("faces"))
    rm = build_reduced(model, cluster_model(model, case("faces")), case("faces"))
    surface = radiation_surface(model)
    T = np.full(rm.n, 300.0)
    T4 = np.full(model.faces.n, 300.0**4)
    p = {m: ir_absorption(model, rm, case(m), surface).face_power(T, model.T_sink, T4) for m in ("detailed", "faces")}
    # total absorbed: each plate's front sees the other's front with F ≈ 0.6 (0.2 m squares 5 cm apart): order
    # 0.6 · 2 · σT⁴ · 0.04 m² ≈ 22 W; the two tallies agree to 2 % in total (3σ); per face, each tally lands ~128 · 200 ·
    # 0.6 / 64 ≈ 240 rays on a front face (binomial sd 6.5 %), so their difference has ~9 % RMS (measured 10 %)
    assert 15 < p["faces"].sum() < 30
    assert p["faces"].sum() == pytest.approx(p["detailed"].sum(), rel=0.02)  # 3σ: 25 600 rays each, sd 0.5 %
    lit = p["detailed"] > 0.1 * p["detailed"].max()
    rel = (p["faces"][lit] - p["detailed"][lit]) / p["detailed"][lit]
    assert np.sqrt(np.mean(rel**2)) < 0.15, np.sqrt(np.mean(rel**2))
    # the per-side REFs of "faces" come with the detailed reference's estimator: reciprocity (εA_i F_ij = εA_j F_ji,
    # to round-off) and closure (each row plus its share to space is 1; here the outer sides see only space)
    from fem2tmm.reduce.network import super_faces

    ia = ir_absorption(model, rm, case("faces"), surface)
    side = np.flatnonzero(super_faces(model, rm)[0] >= 0)
    G = (sp.diags(ia.eps_area) @ ia.A[:, side]).toarray()
    assert np.abs(G - G.T).max() <= 1e-12 * G.max()
    assert np.asarray(ia.A.sum(axis=1)).max() <= 1.0 + 1e-12
    res = run(case("faces"), mesh=mesh)
    s = res.summary
    assert s["energy_balance_W"]["reduced"]["relative"] < 1e-9
    assert s["accuracy"]["rms_K"] < s["accuracy"]["thesis_method"]["rms_K"]


def test_impossible_super_node_counts_are_refused_up_front(monkeypatch):
    # a part that splits into two regions (k = 5 and 170) asked for 1 super node merges them (issue 33: the count
    # asked is the count given); a 2 x 2 triangle plate (8 elements, 9 nodes, 3 of them held) cannot have 7
    # independent super nodes (6 unknown temperatures)
    one = run(two_plates_case(1, "biot"), mesh=two_plates(5.0, 170.0))
    assert one.reduced.clustering.report["parts"][0]["regions_merged"]["merges"] == 1
    assert one.summary["energy_balance_W"]["reduced"]["relative"] < 1e-9
    case = make_case([{"name": "p", "groups": ["plate"], "material": "m", "thickness": T_THICK, "front": "black",
                       "back": "black", "super_nodes": 7}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 20.0}],
                     materials={"m": {"conductivity": 5.0}}, radiation={"enabled": False},
                     clustering={"allocation": "biot"}, reference={"detailed": False})
    import fem2tmm.pipeline as pipeline

    called = []
    real = pipeline.presolve_space
    monkeypatch.setattr(pipeline, "presolve_space", lambda *a: called.append(1) or real(*a))
    with pytest.raises(Fem2TmmError, match=r"asks for 7 super nodes, but its elements have only 6 nodes"):
        run(case, mesh=meshes.plate(0.1, 0.1, 2, 2, element="tri3"))
    assert not called  # refused before the Biot pre-solve


def test_ir_on_faces_fixed_point_does_not_depend_on_the_clustering():
    # With every FE side emitting at the recovered field and the tally replacing the network's lumped absorption,
    # the outer iterations converge to the detailed model solved with the tally's face-to-face exchange: the
    # same field for 4 and 12 super nodes (the emitters and their rays do not depend on the clusters), up to the
    # outer tolerance (1 mK per step).  With super-face emission (ir_on = "detailed") the clusters emit at their
    # mean temperature and the fields differ (measured 6.2 K here against 1.1e-4 K).
    a = meshes.plate(0.2, 0.2, 8, 8)
    b = meshes.transform(meshes.plate(0.2, 0.2, 8, 8), rotation=meshes.rotation("x", 180.0), translation=(0, 0.2, 0.05))
    mesh = meshes.merge(a, b)

    def field(ir_on, n_sn):
        case = make_case([{"name": "p", "groups": ["plate"], "material": "m", "thickness": T_THICK,
                           "front": "black", "back": "black", "super_nodes": n_sn}],
                         [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                          {"kind": "power", "groups": ["plate"], "value": 2.0}],
                         materials={"m": {"conductivity": 5.0}}, environment={"sink_temperature": -270.0},
                         radiation={"rays_per_face": 200, "ir_on": ir_on, "ir_rays_per_face": 50},
                         reduction={"radiation_aware": True, "outer_iterations": 12}, reference={"detailed": False})
        return run(case, mesh=mesh).reduced.T_recovered

    d_faces = np.abs(field("faces", 4) - field("faces", 12)).max()
    d_detailed = np.abs(field("detailed", 4) - field("detailed", 12)).max()
    assert d_faces < 1e-2 and d_detailed > 10 * d_faces, (d_faces, d_detailed)


def test_an_element_collapsed_by_an_isothermal_joint_has_no_biot_number(tmp_path):
    # issue 42 item 5: a quad whose four corners an isothermal RBE2 ties into one node conducts nothing of its own
    # (its k t is round-off); main 3955e37 warned "Bi > 1 (max 6.9e11)" for it.  1 m plate of 8 x 8 quads, k 200,
    # 2 mm, black both sides, held at 20 °C on x = 0: the other elements' Bi = 8σT³ A / (k t) <= 0.48 at 300 K.
    from fem2tmm.reduce.biot import element_biot

    n = 8
    lines = []
    for j in range(n + 1):
        for i in range(n + 1):
            lines.append(f"GRID,{1 + i + (n + 1) * j},,{i / n},{j / n},0.0")
    for j in range(n):
        for i in range(n):
            g = 1 + i + (n + 1) * j
            lines.append(f"CQUAD4,{1 + i + n * j},1,{g},{g + 1},{g + n + 2},{g + n + 1}")
    corners = (1 + 4 + (n + 1) * 4, 1 + 5 + (n + 1) * 4, 1 + 5 + (n + 1) * 5, 1 + 4 + (n + 1) * 5)  # element 37
    lines += ["PSHELL,1,10,0.002", "MAT4,10,200.0,900.0,2700.0", f"RBE2,900,{corners[0]},123456,"
              + ",".join(map(str, corners[1:]))]
    deck = tmp_path / "plate.bdf"
    deck.write_text("\n".join(lines) + "\n")
    mesh_nodes = ",".join(str(1 + (n + 1) * j) for j in range(n + 1))
    case = make_case([{"name": "p", "groups": ["PID 1"], "front": "black", "back": "black", "super_nodes": 4}],
                     [{"kind": "temperature", "nodes": [int(x) for x in mesh_nodes.split(",")], "value": 20.0}],
                     mesh={"file": str(deck)}, joints=[{"cards": ["RBE2"], "treatment": "isothermal"}],
                     environment={"sink_temperature": -270.0}, radiation={"enabled": False},
                     reduction={"radiation_aware": True, "outer_iterations": 2}, reference={"detailed": False})
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = run(case)
    assert not [x for x in w if "Biot number h_rad A/(k t) > 1" in str(x.message)], [str(x.message) for x in w]
    model = res.model
    h = 4.0 * SIGMA * model.space_coupling() * 300.0**3
    h_el, kt, shell = element_biot(model, h)
    ed = model.element_dofs[:, :4]
    collapsed = np.flatnonzero((ed == ed[:, :1]).all(axis=1))
    assert len(collapsed) == 1  # element 37
    row = int(collapsed[0])
    assert h_el[row] == 0.0  # no conduction of its own: no Biot number
    far = np.flatnonzero(shell)
    held = model.fixed[0].dof
    far = far[np.all((model.element_dofs[far, :4] != model.element_dofs[row, 0])
                     & (model.element_dofs[far, :4] != held), axis=1)]  # touching neither the joint nor the held edge
    bi = h_el[far] / kt[far]
    # closed form for the elements that do not touch the joint: 4σT³ · 2 sides · A / (k t), A = 1/64 m², k t = 0.4
    assert bi.max() == pytest.approx(4 * SIGMA * 300.0**3 * 2 / 64 / 0.4, rel=1e-6)


def test_loads_allocation_puts_smaller_super_nodes_around_the_heater():
    # `allocation = "loads"`: the L-bracket's 0.2 m heater patch (16 of 24 x 24 quads a panel, 5 cm quads) and the
    # elements within its reach √(0.04/π) = 0.113 m weigh 3x their area and are a region of their own; 60 super
    # nodes then crowd around it
    from fem2tmm.mesh import shapes
    from fem2tmm.stages.cluster import LOAD_DENSITY, load_weights

    mesh = shapes.bracket(n=24)

    def case(allocation):
        return make_case([{"name": "bracket", "groups": ["floor", "wall", "heater"], "material": "al",
                           "thickness": 1.5e-3, "front": "black", "back": "black", "super_nodes": 60}],
                         [{"kind": "temperature", "groups": ["edge"], "value": 20.0},
                          {"name": "heater", "kind": "power", "groups": ["heater"], "value": 10.0}],
                         clustering={"allocation": allocation}, reference={"detailed": False})

    model = build_model(mesh, case("loads"))
    w, rep, marks = load_weights(model, case("loads"))
    area = model.mesh.element_areas(model.elements)
    heater = np.isin(model.elements, mesh.groups["heater"].elements)
    assert heater.sum() == 16 and rep["heater"]["area_m2"] == pytest.approx(0.04, rel=1e-9)
    assert rep["heater"]["reach_m"] == pytest.approx(np.sqrt(0.04 / np.pi), rel=1e-12)
    assert np.allclose(w[heater], LOAD_DENSITY * area[heater])
    cen = model.mesh.points[model.element_cells[:, :4]].mean(axis=1)
    gap = np.linalg.norm(cen[:, None] - cen[heater][None], axis=2).min(axis=1)
    ring = ~heater & (gap <= rep["heater"]["reach_m"])
    assert rep["heater"]["elements"] == int((heater | ring).sum()) and np.allclose(w[ring], LOAD_DENSITY * area[ring])
    assert np.allclose(w[~(heater | ring)], area[~(heater | ring)])  # everything else: its area
    assert (marks == (heater | ring)).all()  # the near elements are a region of their own
    sizes = {}
    for allocation in ("area", "loads"):
        loads = allocation == "loads"
        c = cluster_model(model, case(allocation), weights=w if loads else None, weights_report=rep,
                          marks=marks if loads else None)
        lab = c.labels[model.elements]
        hot = np.unique(lab[heater])
        sizes[allocation] = np.mean([(lab == k).sum() for k in hot])  # elements per super node on the patch
        assert len(np.unique(lab[lab >= 0])) == 60  # the part's count is kept
        if loads:  # no super node straddles the near region's edge
            assert not np.intersect1d(lab[marks == 1], lab[marks == 0]).size
    # the near region (the 16 patch quads and 44 around them) holds 60 x 3 of 1 092 + 180 weight: 9 of the 60 super
    # nodes for 60 elements, about 7 elements each against 19 with equal areas
    assert sizes["loads"] < 0.5 * sizes["area"], sizes


def test_loads_allocation_leaves_a_load_spread_over_its_part_alone():
    # a heater on the whole wall (576 of the bracket's 1 152 quads, half its area) is not concentrated
    # (LOAD_CONCENTRATED = 0.1): no weight changes, no region of its own, and the report says why; the patch of the
    # test above covers 16 / 1 152 = 1.4 % and is
    from fem2tmm.mesh import shapes
    from fem2tmm.stages.cluster import LOAD_CONCENTRATED, load_weights

    mesh = shapes.bracket(n=24)
    case = make_case([{"name": "bracket", "groups": ["floor", "wall", "heater"], "material": "al",
                       "thickness": 1.5e-3, "front": "black", "back": "black", "super_nodes": 60}],
                     [{"kind": "temperature", "groups": ["edge"], "value": 20.0},
                      {"name": "wall_heater", "kind": "power", "groups": ["wall", "heater"], "value": 10.0},
                      {"name": "patch", "kind": "power", "groups": ["heater"], "value": 10.0}],
                     clustering={"allocation": "loads"}, reference={"detailed": False})
    model = build_model(mesh, case)
    w, rep, marks = load_weights(model, case)
    assert rep["wall_heater"]["share"] == pytest.approx(0.5, rel=1e-9) and rep["wall_heater"]["spread"]
    assert rep["wall_heater"]["elements"] == 0
    assert rep["patch"]["share"] == pytest.approx(16 / 1152, rel=1e-9) and rep["patch"]["share"] < LOAD_CONCENTRATED
    assert "spread" not in rep["patch"]
    heater = np.isin(model.elements, mesh.groups["heater"].elements)
    assert marks.sum() == rep["patch"]["elements"] and marks[heater].all()  # the patch's reach only
    # with the spread load alone, nothing is weighted: the clusters keep equal areas
    alone = make_case([{"name": "bracket", "groups": ["floor", "wall", "heater"], "material": "al",
                        "thickness": 1.5e-3, "front": "black", "back": "black", "super_nodes": 60}],
                      [{"kind": "temperature", "groups": ["edge"], "value": 20.0},
                       {"name": "wall_heater", "kind": "power", "groups": ["wall", "heater"], "value": 10.0}],
                      clustering={"allocation": "loads"}, reference={"detailed": False})
    w, rep, marks = load_weights(build_model(mesh, alone), alone)
    assert np.isnan(w).all() and not marks.any() and rep["wall_heater"]["spread"]
