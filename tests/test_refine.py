"""Error-driven refinement (issue 21 item 5, fem2tmm.reduce.refine): the estimator against exact answers, the
splitter's contiguity, and a small refinement loop that meets its target against the detailed FE solve."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from conftest import composite_box_case, make_case
from fem2tmm import meshes
from fem2tmm.errors import Fem2TmmError
from fem2tmm.export.summary import summary_table
from fem2tmm.fem.model import build_model
from fem2tmm.pipeline import run
from fem2tmm.reduce.refine import (cluster_errors, emission_residual, global_estimate, interior_dofs, local_error, mark,
                                   owner_dofs, split_clusters)
from fem2tmm.solve.steady import solve_steady
from fem2tmm.solve.problems import detailed_problem
from fem2tmm.stages.cluster import cluster_model
from fem2tmm.stages.refine import _element_links

K_LOW, T_THICK = 5.0, 1e-3  # W/(m K), m: composite-like panel
MAT = {"m": {"conductivity": K_LOW, "density": 1600.0, "specific_heat": 900.0}}


def plate_case(n_sn, radiating=True, **reduction):
    """A 0.2 x 0.1 m plate of 1 mm, k = 5, held at 20 °C along xmin, 1 W spread over it, black, space only."""
    side = "black" if radiating else "none"
    return make_case([{"name": "p", "groups": ["plate"], "material": "m", "thickness": T_THICK, "front": side,
                       "back": side, "super_nodes": n_sn}],
                     [{"kind": "temperature", "groups": ["xmin"], "value": 20.0},
                      {"kind": "power", "groups": ["plate"], "value": 1.0}],
                     materials=MAT, environment={"sink_temperature": -270.0}, radiation={"enabled": False},
                     reduction=reduction)


def _plate_model(n_sn):
    mesh = meshes.plate(0.2, 0.1, 20, 10)
    case = plate_case(n_sn)
    model = build_model(mesh, case)
    clustering = cluster_model(model, case)
    return mesh, case, model, clustering


def _emission(model):
    from fem2tmm.reduce.radiative import emission_weights

    return emission_weights(model.faces.W, model.faces.eps_area)


@pytest.mark.filterwarnings("ignore:.*flow straight into it")
def test_estimators_vanish_at_the_detailed_solution():
    # The residual of the detailed solution under its own loads is zero (Newton's tolerance), so both estimates of
    # the error of a "recovered" field equal to it are zero.
    mesh, case, model, clustering = _plate_model(6)
    T = solve_steady(detailed_problem(model), tol=1e-12, max_iter=50).T
    r, h = emission_residual(model.K, T, model.Q, _emission(model), model.T_sink)
    assert np.abs(r[~model.fixed_mask]).max() < 1e-9 * np.abs(model.Q).sum()  # W: the solver's tolerance (the
    # fixed DOF's residual is the heat flowing into it)
    el = clustering.labels[model.elements]
    k = len(clustering.cluster_part)
    dc = interior_dofs(model.element_dofs, el, model.n_dof, model.fixed_mask)
    assert np.abs(local_error(model.K, h, r, dc)).max() < 1e-9
    dT, share = global_estimate(model.K, h, r, ~model.fixed_mask, np.ones(model.n_dof),
                                owner_dofs(model.element_dofs, el, model.n_dof, model.fixed_mask), k)
    assert np.abs(dT).max() < 1e-9 and np.abs(share).max() < 1e-12


@pytest.mark.filterwarnings("ignore:.*flow straight into it")
def test_estimators_are_exact_for_a_linear_problem():
    # Conduction only (K T = q, one edge held): a field wrong by p on the interior DOFs of the clusters has residual
    # -K p, and the local solve with the interfaces held returns exactly -p (K_II p_I = (K p)_I when p = 0 off I);
    # the global solve returns -p for a perturbation anywhere, and its cluster shares sum to Σ w δT².
    mesh = meshes.plate(0.2, 0.1, 20, 10)
    case = plate_case(6, radiating=False)
    model = build_model(mesh, case)
    clustering = cluster_model(model, case)
    T = solve_steady(detailed_problem(model)).T
    rng = np.random.default_rng(0)
    el = clustering.labels[model.elements]
    k = len(clustering.cluster_part)
    dc = interior_dofs(model.element_dofs, el, model.n_dof, model.fixed_mask)
    assert (dc >= 0).sum() > 0.5 * model.n_dof  # most DOFs are inside a cluster
    p = np.where(dc >= 0, rng.normal(size=model.n_dof), 0.0)
    h = np.zeros(model.n_dof)
    r = model.Q - model.K @ (T + p)
    dT = local_error(model.K, h, r, dc)
    assert np.abs(dT + p).max() < 1e-8  # K: round-off of one sparse LU
    e2, rms = cluster_errors(dT, dc, k)
    assert rms == pytest.approx(np.sqrt(np.mean(p**2)), rel=1e-10)
    assert e2.sum() == pytest.approx((p**2).sum(), rel=1e-10)
    free = ~model.fixed_mask
    p = np.where(free, rng.normal(size=model.n_dof), 0.0)
    r = model.Q - model.K @ (T + p)
    w = rng.uniform(0.5, 2.0, model.n_dof)
    own = owner_dofs(model.element_dofs, el, model.n_dof, model.fixed_mask)
    dT, share = global_estimate(model.K, h, r, free, w, own, k)
    assert np.abs(dT + p).max() < 1e-8
    assert share.sum() == pytest.approx((w * p**2).sum(), rel=1e-8)  # the adjoint identity z'r = Σ w δT²
    # with emission h and a re-absorption feedback G = B' diag(g) E (each source one emitting DOF giving back at
    # most half of its linearised emission g = h, as faces re-absorb less than they emit) and a misplaced source
    # B' dp: (K' - G) δT = r + B' dp and the adjoint shares still sum to Σ w δT² (fixed point to 1e-6 relative)
    h = np.where(free, rng.uniform(0.5, 1.0, model.n_dof) * 1e-3, 0.0)  # W/K
    src = rng.choice(np.flatnonzero(free), 30, replace=False)
    E = sp.csr_matrix((np.ones(len(src)), (np.arange(len(src)), src)), shape=(len(src), model.n_dof))
    B = sp.random(len(src), model.n_dof, density=0.1, random_state=2, format="csr")
    B = sp.diags(0.5 / np.maximum(np.asarray(B.sum(axis=1)).ravel(), 1e-300)) @ B  # rows sum to 0.5
    dp = rng.normal(size=len(src))
    owner_g = rng.integers(0, k, len(src))
    dT, share = global_estimate(model.K, h, r, free, w, own, k, (B, dp, owner_g), (B, h[src], E))
    lhs = (model.K + sp.diags(h) - B.T @ sp.diags(h[src]) @ E) @ dT
    rhs = r + B.T @ dp
    assert np.abs((lhs - rhs)[free]).max() < 1e-5 * np.abs(rhs[free]).max()
    assert share.sum() == pytest.approx((w * dT**2).sum(), rel=1e-5)


@pytest.mark.filterwarnings("ignore:.*flow straight into it")
def test_interior_dofs_are_those_of_one_cluster_only():
    mesh, case, model, clustering = _plate_model(6)
    el = clustering.labels[model.elements]
    dc = interior_dofs(model.element_dofs, el, model.n_dof, model.fixed_mask)
    for d in range(model.n_dof):
        cl = np.unique(el[(model.element_dofs == d).any(axis=1)])
        expected = cl[0] if (len(cl) == 1 and not model.fixed_mask[d]) else -1
        assert dc[d] == expected


def test_mark_takes_the_fewest_worst_clusters_for_half_the_error():
    e2 = np.array([1.0, 10.0, 3.0, 6.0, 0.0])
    n_el = np.array([10, 10, 10, 10, 10])
    assert mark(e2, n_el, budget=10).tolist() == [1]  # 10 >= 0.5 * 20
    assert mark(e2, n_el, budget=10, bulk=0.7).tolist() == [1, 3]  # 16 >= 14
    assert mark(e2, n_el, budget=1, bulk=0.9).tolist() == [1]  # the budget caps the count
    # too small to split: skipped, the others still carry half of the total (6 + 3 + 1 >= 10)
    assert mark(e2, np.array([10, 2, 10, 10, 10]), budget=10).tolist() == [0, 2, 3]
    assert mark(e2, n_el, budget=0).size == 0


def test_split_keeps_clusters_contiguous_and_within_parts_and_regions():
    # Two parts (an L of two plates at 90 degrees: two regions of one part, and a separate plate as a second part).
    a = meshes.plate(0.2, 0.2, 10, 10)
    b = meshes.transform(meshes.plate(0.2, 0.2, 10, 10), rotation=meshes.rotation("y", -90.0), translation=(0.2, 0, 0))
    c = meshes.transform(meshes.plate(0.2, 0.2, 10, 10, name="lid"), translation=(0, 0, 0.3))
    mesh = meshes.merge(meshes.merge(a, b), c)
    case = make_case([{"name": "p", "groups": ["plate"], "material": "m", "thickness": T_THICK, "front": "black",
                       "super_nodes": 4},
                      {"name": "q", "groups": ["lid"], "material": "m", "thickness": T_THICK, "front": "black",
                       "super_nodes": 3}],
                     materials=MAT, radiation={"enabled": False})
    model = build_model(mesh, case)
    cl = cluster_model(model, case)
    k = len(cl.cluster_part)
    la, lb = _element_links(model, cl)
    assert (cl.regions[la] == cl.regions[lb]).all()
    cent = mesh.points[mesh.padded_cells[:, :4]].mean(axis=1)
    split = np.array([0, 2, k - 1])
    new = split_clusters(cl.labels, split, cent, np.ones(mesh.n_elements), la, lb, cl.cluster_part)
    assert new.max() + 1 == k + len(split)
    inside = cl.labels >= 0
    assert ((new >= 0) == inside).all()
    pairs = np.unique(np.stack([cl.labels[inside], new[inside]], 1), axis=0)
    assert len(np.unique(pairs[:, 1])) == len(pairs)  # every new cluster lies in one old cluster
    assert (np.bincount(pairs[:, 0]) == np.where(np.isin(np.arange(k), split), 2, 1)).all()
    # each new cluster contiguous through links inside one region; clusters of each part numbered consecutively
    same = new[la] == new[lb]
    n = mesh.n_elements
    g = sp.csr_matrix((np.ones(int(same.sum())), (la[same], lb[same])), shape=(n, n))
    _, comp = connected_components(g, directed=False)
    for c in range(new.max() + 1):
        assert len(np.unique(comp[new == c])) == 1, c
    part_of = np.array([cl.cluster_part[cl.labels[new == c][0]] for c in range(new.max() + 1)])
    assert (np.diff(part_of) >= 0).all()
    # run accepts the split partition as it is
    run(case, mesh=mesh, labels=new)


def small_box(n_sn, **reduction):
    """The composite box of tests/test_radiation_aware.py, coarser (3 cm quads): the thesis' reduction, space only."""
    box = meshes.box(0.3, 0.3, 0.24, 10, 10, 8)
    return composite_box_case(n_sn, K_LOW, {"radiation_aware": False, **reduction}), box


def test_refinement_meets_its_target_against_the_detailed_solve(tmp_path):
    # Thin k = 5 panels held along the deck, 5 W on the top, emitting to space: the thesis' reduction at 10 super
    # nodes is tens of kelvin off (its uniform-load recovery, Bi >> 1).  Refinement to target_rms = 8 K must end
    # with an estimate <= 8 K and a measured RMS against the detailed FE solve <= 8 K, with fewer super nodes than
    # the uniform clustering needs for the same error.
    target = 8.0
    case, box = small_box(10, target_rms=target, refine_rounds=10, max_super_nodes=200)
    r = run(case, mesh=box, out=tmp_path / "out")
    ref = r.summary["reduced"]["refinement"]
    written = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert written["reduced"]["refinement"]["rounds"] == ref["rounds"]
    assert "estimated RMS per round" in (tmp_path / "out" / "report.html").read_text()
    assert "estimated RMS per round" in summary_table(r.summary)
    rounds = ref["rounds"]
    assert ref["stop"] == "target met" and rounds[-1]["estimated_rms_K"] <= target
    assert len(rounds) > 2 and rounds[0]["estimated_rms_K"] > 2 * target  # the loop had to work
    assert [h["n_super_nodes"] for h in rounds] == sorted(h["n_super_nodes"] for h in rounds)
    measured = r.summary["accuracy"]["rms_K"]
    assert measured <= target, rounds
    # the estimate tracks the measured error within a factor 2 (space-only radiation: one Newton step of the
    # detailed problem from the recovered field).  Measured: 10 -> 14 -> 18 -> 22 -> 27 -> 34 super nodes, estimate
    # 19.8 -> 7.09 K, measured 6.64 K; uniform clusters at 34: 8.19 K
    assert 0.5 * measured <= rounds[-1]["estimated_rms_K"] <= 2 * measured
    n_final = rounds[-1]["n_super_nodes"]
    uniform = run(small_box(n_final)[0], mesh=box).summary["accuracy"]["rms_K"]
    assert measured < uniform, (measured, uniform)


def test_refinement_keys_are_validated():
    for bad, key in (({"target_rms": -1.0}, "target_rms"), ({"target_rms": 1.0, "max_super_nodes": 0},
                                                             "max_super_nodes"),
                     ({"target_rms": 1.0, "refine_estimator": "x"}, "refine_estimator"),
                     ({"refine_rounds": -1}, "refine_rounds"), ({"refine_rays_per_face": 0}, "refine_rays_per_face")):
        with pytest.raises(Fem2TmmError, match=key):
            plate_case(4, **bad)
    case, box = small_box(10, target_rms=1.0, max_super_nodes=5)
    with pytest.raises(Fem2TmmError, match="max_super_nodes"):
        run(case, mesh=box)


@pytest.mark.slow
def test_composite_refinement_meets_its_target():
    # issue 21 item 5 acceptance: examples/composite (k = 5 panels, IR on the FE faces, radiation-aware) from 10
    # super nodes (measured 2.12 K) to target_rms = 1.0 K, 7x the reference's own noise (0.14 K RMS); the final
    # measured RMS (recovered vs the detailed reference) must meet the target.  Measured 2026-12-02: 5 rounds,
    # 10 -> 29 super nodes, estimate 0.90 K, measured 0.92 K (the uniform clustering: 1.20 K at 25, 0.76 K at 50).
    from pathlib import Path

    from fem2tmm.case import Case

    root = Path(__file__).resolve().parents[1]
    case = Case.from_toml(root / "examples" / "composite" / "case.toml")
    parts = tuple(dataclasses.replace(p, super_nodes=10) if p.super_nodes > 1 else p for p in case.parts)
    # super-face emission (the refinement's regime; with the example's per-FE-face emission the error is ray noise)
    case = dataclasses.replace(case, parts=parts, radiation=dataclasses.replace(case.radiation, ir_on="detailed"),
                               reduction=dataclasses.replace(case.reduction, target_rms=1.0, refine_rounds=8,
                                                             outer_iterations=5))
    r = run(case)
    ref = r.summary["reduced"]["refinement"]
    assert ref["stop"] == "target met" and len(ref["rounds"]) > 1, ref
    assert r.summary["accuracy"]["rms_K"] <= 1.0, (r.summary["accuracy"], ref["rounds"])


@pytest.mark.filterwarnings("ignore:.*flow straight into it")
def test_a_factorisation_at_another_field_stands_for_the_fields_own(monkeypatch):
    # global_estimate(pre=): the range's estimate at a state whose linearised emission h is within PRECONDITION_KAPPA
    # of a field already factorised takes GMRES on that factorisation (to ``tol``) instead of its own; further away
    # it factorises its own and keeps it.  The answer is the direct one to the GMRES tolerance, with and without the
    # re-absorption feedback.
    from fem2tmm.reduce import refine

    mesh, case, model, clustering = _plate_model(6)
    T = solve_steady(detailed_problem(model), tol=1e-12, max_iter=50).T
    free = ~model.fixed_mask
    rng = np.random.default_rng(3)
    r = np.where(free, rng.normal(size=model.n_dof) * 1e-3, 0.0)  # W
    w = np.ones(model.n_dof)
    own = np.full(model.n_dof, -1)
    h = 4 * 5.67e-8 * _emission(model) * T**3  # W/K
    src = rng.choice(np.flatnonzero(free), 30, replace=False)
    E = sp.csr_matrix((np.ones(len(src)), (np.arange(len(src)), src)), shape=(len(src), model.n_dof))
    B = sp.random(len(src), model.n_dof, density=0.1, random_state=2, format="csr")
    B = sp.diags(0.5 / np.maximum(np.asarray(B.sum(axis=1)).ravel(), 1e-300)) @ B
    for feedback in (None, (B, h[src], E)):
        pre: list = []
        h_design = h * (0.8**3)  # the design field 20 % colder everywhere: κ = 1.95
        refine.global_estimate(model.K, h_design, r, free, w, own, 0, feedback=feedback, shares=False, pre=pre)
        assert len(pre) == 1  # the design state's factorisation, kept
        direct, _ = refine.global_estimate(model.K, h, r, free, w, own, 0, feedback=feedback, shares=False)
        cache: dict = {}
        near, _ = refine.global_estimate(model.K, h, r, free, w, own, 0, feedback=feedback, shares=False,
                                         cache=cache, tol=1e-8, pre=pre)
        assert cache["shift"] is not None and len(pre) == 1  # the design factorisation stood for its own
        assert np.abs(near - direct).max() < 1e-6 * np.abs(direct).max()  # GMRES at 1e-8 relative
        far_h = h * 20.0  # κ = 20 / 0.512 > PRECONDITION_KAPPA: its own factorisation, kept beside the first
        far_direct, _ = refine.global_estimate(model.K, far_h, r, free, w, own, 0, feedback=feedback, shares=False)
        cache = {}
        far, _ = refine.global_estimate(model.K, far_h, r, free, w, own, 0, feedback=feedback, shares=False,
                                        cache=cache, tol=1e-8, pre=pre)
        assert cache["shift"] is None and len(pre) == refine.PRECONDITIONERS
        assert np.abs(far - far_direct).max() < 1e-6 * np.abs(far_direct).max()
    # where GMRES on the kept factorisation does not reach the tolerance within PRECONDITIONED_MAX_ITER, the field's own
    # factorisation answers (and is kept as the latest)
    pre = []
    refine.global_estimate(model.K, h * 0.8**3, r, free, w, own, 0, shares=False, pre=pre)
    first = pre[0][1]
    cache = {}
    monkeypatch.setattr(refine, "PRECONDITIONED_MAX_ITER", 1)
    own_lu, _ = refine.global_estimate(model.K, h, r, free, w, own, 0, shares=False, cache=cache, tol=1e-8, pre=pre)
    direct, _ = refine.global_estimate(model.K, h, r, free, w, own, 0, shares=False)
    assert cache["shift"] is None and len(pre) == 2 and pre[0][1] is first and pre[1][1] is cache["lu"]
    assert np.abs(own_lu - direct).max() <= 1e-12 * np.abs(direct).max()
