"""The radiation-aware reduction (:mod:`fem2tmm.reduce.radiative`): shape functions that carry the emission.

Where a cluster is wider than its panel's fin length √(k t / h_rad) (cluster Biot number ≥ 1: thin radiating
composites), the thesis' uniform-load shape functions no longer hold.  This method condenses K + diag(4σe T³)
about a reference field instead, adds the correction load that makes the network exact at that field, and iterates
(outer iterations) to the fixed point where the reference is the recovered field itself.  Its recovery is the
emission-mode constrained solve of :class:`~fem2tmm.reduce.exported.ExportedRecovery`, which needs no reference
state: temperatures of any load state recover with it.  With ``[radiation] ir_on = "faces"`` (the default with this
method) every active FE side emits at its own recovered temperature through its own REFs.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from ..case import Case
from ..cluster import Clustering
from ..constants import SIGMA
from ..errors import Fem2TmmError, InternalError
from ..fem.model import FEModel
from ..reduce.exported import ExportedRecovery
from ..reduce.network import ReducedModel, build_reduced
from ..reduce.radiative import conduction_indefinite
from ..solve.steady import SteadySolution, solve_steady
from ..keys import network_group
from ..radiation.ir_absorption import IRAbsorption
from ..reduce.biot import biot_numbers, warn_coarse_mesh
from ..solve.problems import detailed_problem, reduced_problem
from .base import Reduced, ReductionInputs, Reductor, exported_arrays

OUTER_TOLERANCE = 1e-3  # K: outer iterations stop early once the recovered field moves less than this, or once
# the changes still to come (contracting steps, a geometric estimate: step r/(1 - r), r the ratio of the last two)
# are below it: each iteration re-reduces every cluster (the truss: ~20 s each at 10 super nodes)
#: a shared linearisation (load-case sets) converges linearly: this many times ``outer_iterations`` at most
SHARED_OUTER_FACTOR = 4
#: the shared fixed point is under-relaxed (halved, down to SHARED_MIN_RELAXATION) whenever a step is not below this
#: fraction of the one before: measured on examples/composite at 100 super nodes, a set linearised about heater 7.5 W
#: left heater 52.5 W oscillating by 330 K after 80 plain iterations (9.1 K RMS), (see docs/design-notes.md)
SHARED_CONTRACTION = 0.95
SHARED_MIN_RELAXATION = 1.0 / 64
OUTER_WARN = 0.05  # K: a warning when the last outer iteration still moved the field by more than this
# Largest cluster Biot number below which the radiation-aware reduction warns that it is not needed: the EUI
# baffle (cluster Bi <= 0.0044) gains nothing resolvable from it; the composite box, which it wins, has Bi 2-60
LOW_BIOT = 0.1


class RadiationAwareReductor(Reductor):
    """The radiation-aware reduction, started from the thesis' reduction of the same inputs (its network's
    couplings GR and g_space are kept; its recovered field is the first reference).  ``method_report`` holds one dict per
    outer iteration (:func:`radiation_aware_network`), ``ir`` the traced IR absorption (``ir_on`` "faces" or
    "detailed")."""

    name = "radiation_aware"
    #: the run's own field is its exported recovery's (the fixed point, to 1e-10 K): what a user recovers from the
    #: network's temperatures with ``fem2tmm recover``
    field_from_export = True

    def reduce(self, inputs: ReductionInputs, prog, start: Reduced | None = None) -> Reduced:
        if start is None:
            raise InternalError("the radiation-aware reduction starts from the thesis' reduction of the same inputs")
        case, model = inputs.case, inputs.model
        ir = None
        if inputs.trace_ir is not None and case.radiation.ir_on in ("detailed", "faces"):
            with prog.stage("ir_detailed", "tracing the FE sides' IR exchange factors (ir_on = faces)"
                            if case.radiation.ir_on == "faces" else
                            "tracing where the super faces' IR is absorbed (FE sides)"):
                ir = inputs.trace_ir(case)
        # one emission for every method (issue 42): a side emits εA (1 − blocked), the share its traced REFs close on
        model = model.with_unblocked(inputs.unblocked if ir is None or ir.unblocked is None else ir.unblocked,
                                     inputs.traced_area)
        notes = []
        with prog.stage("radiation_aware", "radiation-aware reduction and outer iterations"):
            args = (model, inputs.clustering, case, start.network, inputs.q_recover, inputs.q_lumped,
                    start.T_recovered)
            lin, out, failed = inputs.linearised_at, None, None
            try:
                out = radiation_aware_network(*args, ir, linearised_at=lin, advise=inputs.advise)
            except Fem2TmmError as exc:
                failed = exc
            if out is None and lin is not None:
                # a case set's network, linearised about another case's field, can have no physical solution at
                # this case's loads (issue 42: a thin bracket linearised at 0 W, this case 40 W): its own network
                warnings.warn(f"the load-case set's shared radiation-aware network has no physical steady solution "
                              f"for this case ({failed}); this case gets a network of its own", stacklevel=2)
                notes.append("the set's shared network had no solution for this case: a network of its own")
                lin = None
                try:
                    out = radiation_aware_network(*args, ir, advise=inputs.advise)
                except Fem2TmmError as exc:
                    failed = exc
            if out is not None:
                rm, sol, T, history = out
            else:
                exc = failed
                if not (inputs.ir_on_asked == "auto" and case.radiation.ir_on == "faces"):
                    raise exc
                # ir_on chosen by "auto": the per-side IR correction, linearised far from the solution, can leave
                # the network without a physical solution (a 0.1 mm panel under 745 W on one super node,
                # tests/test_robustness.py); the super faces' IR (ir_on = "super_faces") is the robust form
                warnings.warn(f"the radiation-aware network with ir_on = \"faces\" has no physical steady solution "
                              f"here ({exc}); it runs with ir_on = \"super_faces\" (absorbed IR uniform per super "
                              "node)", stacklevel=2)
                case = dataclasses.replace(case, radiation=dataclasses.replace(case.radiation, ir_on="super_faces"))
                notes.append("ir_on = \"faces\" had no network solution: \"super_faces\"")
                ir = None
                rm, sol, T, history = radiation_aware_network(*args[:2], case, *args[3:], None, linearised_at=lin,
                                                             advise=inputs.advise)
        return Reduced(method=self.name, network=rm, solution=sol, T_recovered=T, q_recover=inputs.q_recover,
                       case=case, method_report=history, ir=ir, notes=notes)

    def export(self, inputs: ReductionInputs, reduction: Reduced) -> ExportedRecovery:
        """The emission-mode recovery (module docstring), with the traced IR absorption when there is one."""
        model, ir = inputs.model, reduction.ir
        kw = {"mode": "emission", "e": np.asarray(reduction.network.radiative.e, float)}
        if ir is not None:
            kw.update(ir_A=ir.A.tocsr(), ir_owner=np.asarray(ir.owner, np.int64), ir_eps_area=np.asarray(ir.eps_area),
                      ir_face=np.zeros(0, np.int64) if ir.face is None else np.asarray(ir.face, np.int64),
                      face_W=model.faces.W.tocsr())
        return ExportedRecovery(**exported_arrays(inputs, reduction.network), **kw)

    def reconstruct(self, reduction: Reduced, T_sn: np.ndarray, loads: dict | None = None,
                    T0: np.ndarray | None = None) -> np.ndarray:
        """The exported recovery's constrained nonlinear solve (it holds for any load state)."""
        return reduction.recovery.recover(T_sn, loads=loads, T0=T0)


def radiation_aware_network(model: FEModel, clustering: Clustering, case: Case, rm: ReducedModel,
                            q_detailed: np.ndarray, q_lumped: np.ndarray, T_ref: np.ndarray,
                            ir: IRAbsorption | None = None, linearised_at: np.ndarray | None = None,
                            advise: bool = True) -> tuple[ReducedModel, SteadySolution, np.ndarray, list[dict]]:
    """The radiation-aware reduced network and its outer iterations (:mod:`fem2tmm.reduce.radiative`).

    Parameters
    ----------
    model, clustering, case : as for :func:`~fem2tmm.reduce.network.build_reduced`
    rm : the thesis' reduced model with its radiation (``GR``, ``g_space``), whose couplings are kept
    q_detailed : (n_dof,) W loads known on the detailed mesh (heaters, detailed solar): distributed by Y'
    q_lumped : (n,) W loads already lumped per super node (super-face solar)
    T_ref : (n_dof,) K the pre-solve's recovered field ; with face-to-face radiation the emission is first
        linearised about the detailed field radiating to space only (solved to 0.1 K) instead, then about each outer iteration's
        field: at most ``[reduction] outer_iterations`` reductions and network solves, fewer once the field moves, or is estimated to move from then on, less than :data:`OUTER_TOLERANCE`
    ir : where the absorbed IR lands (``ir_on = "detailed"``), or None (thesis: uniform per super node).  Given,
        the absorbed power of every FE face at the reference state, q_abs, goes through the exact power
        distribution like a known load: ``Y' q_abs − S q_abs`` (S: sum per super node) is added to the network's
        loads (it moves power within and between super nodes, the total is kept) and q_abs to the recovery
    linearised_at : (n_dof,) K or None.  Given (a load-case set's shared network, :func:`network_group`), the
        emission is linearised about this field once: K' = K + diag(4σe·linearised_at³) is reduced once, so K̃
        (the deck's GL), the super-node capacitance and GR are those of every other case of the set, and only
        the loads (Y'q and the correction, at this case's own fixed point) differ.  The outer iterations then
        keep h fixed and converge linearly (measured on examples/composite at 100 super nodes with the network
        of the 30 W case: 2 to 26 iterations to 1 mK for heater 0 / 60 W, sink −100 °C, deck 0 °C), to the same
        fixed point as re-linearising: the identity behind the correction holds for any h.  At most
        :data:`SHARED_OUTER_FACTOR` × ``[reduction] outer_iterations`` iterations
    advise : False skips the warning that the method is not needed below :data:`LOW_BIOT` (the method was chosen
        by ``"auto"``'s estimated errors, not asked for)

    Returns
    -------
    ``(rm', solution, T, history)``: the network (``K`` = K̃, ``Q`` = Y'q + q_lumped + Q_corr at the last
    reference), its solution, the recovered field (n_dof,) K and one dict per outer iteration
    (``max_dT_K``, ``rms_dT_K``: change of the recovered field; ``correction_W``: Σ|Q_corr|).
    """
    from ..linalg import blas_threads

    history: list[dict] = []
    f = model.faces
    shared = linearised_at is not None
    def space_only_field():  # the detailed field radiating to space only, with the run's known loads (K)
        return solve_steady(dataclasses.replace(detailed_problem(model), Q=np.asarray(q_detailed, float)),
                            tol=0.1, max_iter=case.solver.max_iterations).T

    if not shared and case.radiation.enabled and rm.GR is not None:
        # with face-to-face radiation, start from the detailed field radiating to space only, with the run's known loads (a sparse Newton on
        # the FE mesh): it has the fin shapes the thesis' pre-solve lacks.  From the thesis' field, 89 K off at 10
        # super nodes on examples/composite, the first linearisation could be so far off that the network had no
        # physical solution (heater 60 W: correction loads of thousands of W, the Newton driving a node to 0 K);
        # from this one 10 super nodes converge in 7 outer iterations at 30 and 60 W (10 before, and none at 60 W).
        # (Without exchange that field would be the detailed solution itself: the thesis' field stays the start.)
        T_ref = space_only_field()
        presolved = True
    else:
        presolved = shared
    restarted = False
    omega = 1.0  # relaxation of the shared fixed point (below)
    n_outer = max(int(case.reduction.outer_iterations), 1) * (SHARED_OUTER_FACTOR if shared else 1)
    if shared:  # one linearisation for the whole case set: reduce once, keep h fixed
        base = build_reduced(model, clustering, case, T_ref=np.asarray(linearised_at, float))
        base = dataclasses.replace(base, radiative=dataclasses.replace(base.radiative, T_sink=model.T_sink))
        T_ref = np.asarray(linearised_at, float).copy()
    for it in range(n_outer + (0 if presolved else 1)):  # (one restart may take an iteration)
        if len(history) >= n_outer:
            break
        # (re-)linearise about the latest field: Newton-like, the steps shrink quadratically (shared: h fixed,
        # the steps shrink linearly)
        ra_rm = base if shared else build_reduced(model, clustering, case, T_ref=T_ref)
        # the super nodes' full emitting εA (the untraced g_space of build_reduced): the network's GR lacks the
        # self-exchange of a concave super node, whose lumped absorption cancels it (module docstring)
        e_sn = ra_rm.g_space
        ra = ra_rm.radiative
        T_sn_ref = np.where(ra_rm.fixed, ra_rm.T_fixed, ra_rm.supernodes.A @ T_ref)
        # a super node of one DOF emits what its DOF does (it owns few or no super faces: that emission would be a
        # constant load of the correction)
        dg = one_node_emission(ra_rm, T_sn_ref, e_sn, rm.g_space)
        # clusters given their H_SN as their own emission (K̃ not positive definite: one_node_emission)
        emitting_h = [str(ra_rm.names[i])
                      for i in np.flatnonzero((dg != 0) & (dofs_per_super_node(ra_rm.supernodes.A) > 1))]
        ra_rm = dataclasses.replace(ra_rm, GR=rm.GR, g_space=rm.g_space + dg)
        corr = ra.correction(T_ref, T_sn_ref, e_sn + dg)
        q_rec = q_detailed
        if ir is not None:
            p_face = ir.face_power(T_sn_ref, model.T_sink, f.W @ T_ref**4)
            q_abs = np.asarray(f.W.T @ p_face).ravel()
            # replace the network's own lumped absorption at the reference by the tallied q_abs through Y': from the
            # other super nodes σ GR (T_SN⁴ − T_s⁴), and its own (concave super nodes: e_SN − g_space − GR 1, which
            # the correction's e_SN emission returns lumped).  Exact at the fixed point up to the tally's ray noise
            # (GR then only carries the linear response); subtracting the tally's own sum per super node instead
            # leaves the difference of two independent tracings (and, with FE-face emitters, the super faces'
            # lumping: measured in examples/composite/README.md)
            d4 = T_sn_ref**4 - model.T_sink**4
            own = self_exchange(e_sn, rm)
            absorbed = SIGMA * (np.asarray(rm.GR @ d4).ravel() + own * d4)
            corr = corr + ra.reduction.distribute(q_abs) - absorbed
            q_rec = q_detailed + q_abs
        ra_rm = dataclasses.replace(ra_rm, Q=ra.reduction.distribute(q_detailed) + q_lumped + corr)
        lin_T, lin_q = T_ref, q_rec - q_detailed  # the network's correction is this field's (transient recovery)
        try:
            with blas_threads(1):  # a dense Newton on ~100 nodes: threads only contend on a shared machine
                sol = solve_steady(reduced_problem(ra_rm), tol=case.solver.tolerance,
                                   max_iter=case.solver.max_iterations)
        except Fem2TmmError:
            if presolved:
                raise
            # linearised about the thesis' field, too far off (a strong heater on a thin strip: 2 000 K where the
            # thesis' field had hundreds), the network has no physical solution: start again from the detailed
            # field radiating to space only (without face-to-face exchange, the detailed solution itself)
            T_ref = space_only_field()
            presolved = restarted = True
            continue
        T = ra.recover(sol.T, q_rec, T_ref)
        d = T - T_ref
        history.append({"iteration": it + 1, "max_dT_K": float(np.abs(d).max(initial=0.0)),
                        "rms_dT_K": float(np.sqrt(np.mean(d**2))) if d.size else 0.0,
                        "correction_W": float(np.abs(corr).sum())})
        if emitting_h:
            history[-1]["clusters_emitting_H"] = emitting_h
        if restarted:
            history[-1]["restarted"] = ("the network linearised about the thesis' field had no physical solution: "
                                        "restarted from the detailed field radiating to space")
            restarted = False
        step = history[-1]["max_dT_K"]
        if shared and len(history) >= 2 and step > SHARED_CONTRACTION * history[-2]["max_dT_K"]:
            # h fixed far from this case's state (a hot case on a set linearised about a cold one): the plain fixed
            # point stops contracting and can oscillate by hundreds of kelvin; under-relax until it contracts
            omega = max(0.5 * omega, SHARED_MIN_RELAXATION)
        if omega < 1.0:
            history[-1]["relaxation"] = omega
        T_ref = T if omega == 1.0 else T_ref + omega * (T - T_ref)
        if step < OUTER_TOLERANCE:
            break
        if len(history) >= 2:  # contracting: the changes still to come, estimated as a geometric series
            r = step / max(history[-2]["max_dT_K"], 1e-300)
            if r < (0.9 if shared else 0.5) and step * r / (1.0 - r) < OUTER_TOLERANCE:
                history[-1]["stop"] = "estimated remaining change below the tolerance"
                break
    # Biot numbers at the last linearisation (the pre-solve's field can be far off with few super nodes: on
    # examples/composite at 10 super nodes it counted 132 elements over 1 where the converged field has none)


    biot = biot_numbers(model, ra_rm, ra.h)
    history[-1]["biot"] = biot
    if advise and biot["cluster_max"] is not None and biot["cluster_max"] < LOW_BIOT:
        warnings.warn(f"every cluster has a Biot number h_rad A/(k t) below {LOW_BIOT} (max "
                      f"{biot['cluster_max']:.3g}): the thesis' uniform-load assumption already holds, and "
                      "the radiation-aware reduction adds outer iterations for little gain here (and with "
                      "ir_on = \"super_faces\", absorbed IR lumped per super face, it can be less accurate: "
                      "docs/design-notes.md); consider [reduction] radiation_aware = false", stacklevel=2)
    warn_coarse_mesh(biot["elements_over_1"], biot["element_max"])
    last = history[-1]["max_dT_K"]
    if last > OUTER_WARN:
        warnings.warn(f"the radiation-aware reduction did not converge in [reduction] outer_iterations = "
                      f"{len(history)}: its last step still moved the recovered field by {last:.3g} K (steps "
                      f"{', '.join(format(h['max_dT_K'], '.3g') for h in history)} K); the temperatures are off "
                      "by about that much: raise outer_iterations (the steps shrink quadratically once they are "
                      "small; fewer super nodes need more)", stacklevel=2)
    if not shared and not case.reduction.parametric:
        held = held_reactions(model, ra_rm, T, q_detailed, None if ir is None else q_rec - q_detailed)
        # a concave super node's self-exchange: the share of its linearised emission H that never leaves it
        own = self_exchange(e_sn, rm)
        # the physical couplings to space: the super faces', and a one-DOF super node's own emission
        args = (ra.reduction.distribute(q_detailed) + q_lumped, case, held, rm.g_space + np.maximum(dg, 0.0))
        built, sol_built = ra_rm, sol
        ra_rm, sol = effective_network(built, sol_built, *args, self_exchange=own)
        linked = None
        if ra_rm.g_space_table is not None and case.reduction.verify and case.transient is None:
            # the other source of a short super node's heat, where it makes another network: the run keeps the one
            # that holds the validity range better (emission_floor_links; the range is checked, verified or
            # estimated, only with [reduction] verify on a steady deck); a candidate, so it does not warn
            linked = effective_network(built, sol_built, *args, self_exchange=own, floor="linked", warn=False)
            if linked[0].g_space_table is None or np.array_equal(np.asarray(linked[0].K), np.asarray(ra_rm.K)):
                linked = None
        if ra_rm.g_space_table is not None:  # the heat the loads radiate inside their super nodes: nodes of its own
            ra_rm, sol = with_hot_spots(model, case, ra_rm, sol, q_detailed, T)
        if linked is not None:
            ra.floor_linked = with_hot_spots(model, case, *linked, q_detailed, T)
    ra.history = history
    ra.shared = shared
    ra.T_lin, ra.q_tally = lin_T, lin_q
    ra.T_built = np.asarray(linearised_at, float) if shared else lin_T
    # what the network was given (W): the known loads before their distribution; the network's Q sums to less, the
    # difference being the heat its correction load and the distribution with K' radiate (summary radiated_W)
    ra.known_load_W = float(np.sum(q_detailed) + np.sum(q_lumped))
    return ra_rm, sol, T, history



def dofs_per_super_node(A) -> np.ndarray:
    """(n,) int: the DOFs each super node's mean is taken over (the non-zeros of its row of ``A`` (n, n_dof), sparse
    or dense); 1 for a joint's end, a kept node or a unit an isothermal RBE2 ties into one node."""
    return np.diff(A.tocsr().indptr) if hasattr(A, "tocsr") else np.count_nonzero(np.asarray(A), axis=1)


def one_node_emission(rm: ReducedModel, T_sn: np.ndarray, e_sn: np.ndarray, g_space: np.ndarray) -> np.ndarray:
    """(n,) m²: the change of the coupling to space of each free super node that stands for one DOF (a joint's end, a
    kept node, a part an isothermal RBE2 ties into one node) that makes the network's emission there follow the
    DOF's own: ``H_SN / (4σ T_SN³) − e_SN``, held so that ``g_space + change`` stays ≥ 0; where the network's
    conduction K̃ is not positive definite on its free nodes, the same for every free cluster whose own emission
    slope 4σ e_SN T_SN³ falls short of its H_SN; zero elsewhere.

    The network's radiation R_SN emits through the super faces a super node owns (``e_SN``: its coupling to space,
    its exchange GR, its self-absorbed share); what it does not emit there reaches the network only through the
    correction load, a constant at the reference state.  A super node of one DOF carries all of that DOF's emission
    in H_SN = Y'h, yet owns none of its faces (a joint's end: they belong to the cluster beside it, or, on a fully
    determined element, to one of its nodes) or only some (a unit whose RBE2 spider also ties the panel quads round
    it into its node: 0.0036 m² of its own against 0.014-0.020 m² of emission).  The constant is then a sink that
    does not fall as the node cools: an MLI blanket's stitched corner (1 to 19 W, fed by a 5 mW/K CBUSH) or such a
    unit (15 to 53 W) had no steady state in the network (its Newton drove it to 0 K).  With the coupling changed,
    the node's emission follows its own temperature, the correction at the reference is unchanged (its ``e_SN``
    counts the change) and so is the fixed point.  Clusters of many DOFs keep their super faces' couplings: given
    H_SN instead, the bars of examples/satellite (no face of their own, H_SN from the panel nodes they share) slowed
    its outer iterations to a 0.83 contraction (0.058 K RMS after 20, against 0.031 K in 10).

    Unless K̃ = K'_SN − diag(H_SN) is not positive definite on the free nodes
    (:func:`fem2tmm.reduce.radiative.conduction_indefinite`; the satellite's is, 0.0026 W/K its least eigenvalue):
    taking a cluster's positive H_SN off the diagonal without an emission of its own to carry it then leaves the
    network's Jacobian positive definite only while other nodes' emission makes up for it, and the cluster's share
    of that emission a constant sink.  A 2 × 2 radiator of ε = 0 beside an MLI-covered panel (41.8 W, 3 super nodes;
    tests/test_robustness.py "mli_emissionless_radiator_negative_share") got, through shape-function weights ±4 at
    the shared edge, H_SN = +0.107 W/K at one radiator cluster (a 28 W constant sink, no face of its own) and
    −0.107 W/K at another: K̃'s least eigenvalue on the free nodes −0.0027 W/K, and the network had no steady
    solution (Newton steps of 1e6 K).  With the cluster's share its own T⁴ emission, its emission slope at the
    reference is H_SN again, as in the exact reduced operator K'_SN = K̃ + diag(H_SN), the sink falls as the
    cluster cools, and the outer iterations converge (15, to 19.1 K RMS against the thesis' 418 K, reference
    noise 8.4 K).

    ``rm`` the radiation-aware reduced model (``radiative.H`` W/K, ``supernodes.A``), ``T_sn`` (n,) K its super
    nodes at the reference, ``e_sn`` (n,) m² the εA of the super faces each owns, ``g_space`` (n,) m² the network's
    couplings to space.
    """
    T = np.asarray(T_sn, float)
    e_sn = np.asarray(e_sn, float)
    dofs = dofs_per_super_node(rm.supernodes.A)
    free = ~np.asarray(rm.fixed, bool) & (T > 0)
    slope = np.zeros(rm.n)
    slope[free] = rm.radiative.H[free] / (4.0 * SIGMA * T[free] ** 3)
    sel = free & (dofs == 1)
    if conduction_indefinite(rm.K, rm.fixed):  # clusters short of their H_SN too (see the docstring)
        sel |= free & (slope > e_sn)
    out = np.zeros(rm.n)
    out[sel] = np.maximum(slope[sel] - e_sn[sel], -np.asarray(g_space, float)[sel])
    return out


def self_exchange(e_sn: np.ndarray, rm: ReducedModel) -> np.ndarray:
    """(n,) m²: each super node's coupling to itself, the emission of a concave super node that returns to it:
    its super faces' full εA ``e_sn`` (n,) m² less its traced couplings to space (``rm.g_space``) and to the other
    super nodes (``rm.GR`` row sums), at least 0; zeros without exchange factors (``rm.GR`` None)."""
    if rm.GR is None:
        return np.zeros(rm.n)
    return np.maximum(np.asarray(e_sn, float) - rm.g_space - np.asarray(rm.GR.sum(axis=1)).ravel(), 0.0)


def effective_network(rm: ReducedModel, sol: SteadySolution, Q_applied: np.ndarray, case: Case,
                      held_W: np.ndarray | None = None, g_space: np.ndarray | None = None,
                      self_exchange: np.ndarray | None = None, floor: str = "held",
                      warn: bool = True) -> tuple[ReducedModel, SteadySolution]:
    """The radiation-aware network without a correction load (issue 41): the applied loads ``Q_applied`` (n,) W as
    the exact reduction distributes them (Y'q), K̃ and GR as they are, and each super node's coupling to space a
    function of its own temperature (:func:`fem2tmm.reduce.radiative.effective_emission`) that holds the design
    state ``sol``; a super node whose balance there asks for a negative emitting area gets the heat it lacks by
    conduction from a warmer held node first (:func:`fem2tmm.reduce.radiative.emission_floor_links`).
    ``held_W`` (n,) W or None: the heat each fixed node gives the structure in the detailed model at
    that state; what its conductors and its radiative couplings to the other super nodes do not carry (the emission
    of the fin next to it, steeper than its neighbours' mean temperatures show; a held part's own emission to space)
    becomes its own coupling to space, at its own temperature, so that the network's heat
    books match the detailed ones (it moves no temperature: the node is fixed).  ``g_space`` (n,) m² or None: each
    node's physical coupling to space (default ``rm.g_space``; the network handed in may carry another, the outer
    iterations' :func:`one_node_emission`).  ``self_exchange`` (n,) m² or None: each super node's coupling to
    itself (a concave cluster's emission that it re-absorbs); the emission's slope at T* matches H less its
    linearisation 4σ GR_self T*³, which neither GR (no diagonal) nor K̃ carries: the heat a super node loses as it
    warms.  Matching the gross H made a concave super node's effective emission rise faster than T⁴, and the deck
    drifted off its design state (examples/baffle, the screws held 50 K warmer: 0.50 K RMS against 0.007 K;
    examples/smallsat, all constants high: 1.11 against 0.44 K; docs/design-notes.md).  ``floor``: where a short super
    node's heat comes from, ``"held"`` or ``"linked"`` (:func:`fem2tmm.reduce.radiative.emission_floor_links`);
    ``warn`` False: a candidate network, which says nothing when it has no solution.  Returns the network and its
    solution (the design state again, to the solver's tolerance); where the network without correction has no
    solution, ``rm`` and ``sol`` as given."""
    from ..linalg import blas_threads
    from ..reduce.radiative import effective_emission, emission_floor_links

    T = sol.T
    given = rm
    g_space = rm.g_space if g_space is None else np.asarray(g_space, float)
    # super nodes short of heat at T* (a negative emitting area): conduction from the held edge or along K̃'s links
    rm = dataclasses.replace(rm, K=np.asarray(rm.K, float) + emission_floor_links(
        rm.K, Q_applied, rm.GR, rm.fixed, T, rm.T_sink, g_space, source=floor))
    g_fixed = np.where(rm.fixed, g_space, 0.0)
    if held_W is not None:
        d4 = T**4 - rm.T_sink**4
        G = None if rm.GR is None else np.asarray(rm.GR, float)
        for i in np.flatnonzero(rm.fixed):
            row = -np.array(rm.K[i], float)
            row[i] = 0.0
            # W neither its conductors nor its radiative couplings to the other super nodes carry (a held part that
            # radiates into the structure, examples/composite's deck: 88 W to the panels, booked to space as well
            # until 2026-12-07, 32 % too much radiated in all), with the share of the loads the distribution puts on
            # the node itself (its Q, which its reaction includes; :func:`with_hot_spots` takes it off again where
            # the hot spots apply it)
            exchange = 0.0 if G is None else SIGMA * float(G[i] @ (T[i] ** 4 - T**4))
            left = float(held_W[i] - row @ (T[i] - T) - exchange + Q_applied[i])
            if np.isfinite(left) and abs(d4[i]) > 1e-12 * T[i] ** 4:
                g_fixed[i] = left / (SIGMA * d4[i])
    # the emission slope to match: H less what a concave super node re-absorbs of its own emission (4σ GR_self T³),
    # which neither GR (no diagonal) nor K̃ carries
    H = np.asarray(rm.radiative.H, float)
    if self_exchange is not None:
        H = np.maximum(H - 4.0 * SIGMA * np.asarray(self_exchange, float) * T**3, 0.0)
    e, table = effective_emission(rm.K, Q_applied, rm.GR, rm.fixed, T, rm.T_sink, H, g_fixed, g_space)
    net = dataclasses.replace(rm, Q=np.asarray(Q_applied, float), g_space=e, g_space_table=table)
    try:
        with blas_threads(1):
            new = solve_steady(reduced_problem(net), T0=T, tol=case.solver.tolerance,
                               max_iter=case.solver.max_iterations)
    except Fem2TmmError as exc:  # a network without a solution at its own design state is not handed over
        if warn:
            warnings.warn(f"the radiation-aware network without a correction load has no steady solution at its own "
                          f"design state ({exc}); the network with the correction load is written instead",
                          stacklevel=2)
        return given, sol
    return net, new


def _without_fixed_load(rm: ReducedModel, T_sn: np.ndarray) -> dict:
    """``{"g_space", "g_space_table"}`` of ``rm`` with each fixed node's coupling to space less what radiates its
    own load ``rm.Q`` at the super-node temperatures ``T_sn`` (n,) K (:func:`effective_network` counts the load in
    it; the node's reaction then stays the same once its Q is zero)."""
    fixed = np.flatnonzero(np.asarray(rm.fixed, bool))
    d4 = np.asarray(T_sn, float)[fixed] ** 4 - rm.T_sink**4
    ok = np.abs(d4) > 1e-12 * np.asarray(T_sn, float)[fixed] ** 4
    dg = np.zeros(rm.n)
    dg[fixed[ok]] = np.asarray(rm.Q, float)[fixed[ok]] / (SIGMA * d4[ok])
    table = rm.g_space_table
    if table is not None:  # (a fixed node's table is constant)
        table = (table[0], np.asarray(table[1], float) - dg[:, None])
    return {"g_space": np.asarray(rm.g_space, float) - dg, "g_space_table": table}


def with_hot_spots(model: FEModel, case: Case, rm: ReducedModel, sol: SteadySolution, q_detailed: np.ndarray,
                   T: np.ndarray) -> tuple[ReducedModel, SteadySolution]:
    """The network ``rm`` with the radiator nodes of :func:`fem2tmm.reduce.radiative.hot_spots` (one per power or
    flux ``[[boundary]]``, and one for the rest of ``q_detailed`` (n_dof,) W) at the design field ``T`` (n_dof,) K,
    and its solution's energy balance with their load applied and radiated to space (no temperature moves)."""
    from ..fem.model import boundary_load
    from ..reduce.radiative import hot_spots

    names, pats, vals = [], [], []
    rest = np.array(q_detailed, float)
    for b in case.boundaries:
        if b.kind in ("power", "flux"):
            pat = boundary_load(model, case, dataclasses.replace(b, value=1.0))
            names.append(b.name)
            pats.append(pat)
            vals.append(float(b.value))
            rest = rest - b.value * pat
    if np.abs(rest).sum() > 1e-9 * max(np.abs(q_detailed).sum(), 1e-300):
        names.append("")
        pats.append(rest)
        vals.append(1.0)
    if not pats:
        return rm, sol
    hs = hot_spots(rm.reduction.distribute, ~np.asarray(rm.fixed, bool), rm.part, np.array(pats), np.array(vals),
                   names, T, rm.radiative.e, rm.T_sink)
    if hs is None:
        return rm, sol
    # the loads' share on a fixed node moves nothing: the hot spots apply it (their share is the load less what
    # the free nodes get), so it leaves the fixed nodes' Q and their books hold only their conductors' flows (and
    # their own coupling to space, which effective_network set to radiate that share too: taken off here)
    rm = dataclasses.replace(rm, hot_spots=hs, Q=np.where(rm.fixed, 0.0, rm.Q),
                             **_without_fixed_load(rm, sol.T))
    from ..linalg import blas_threads

    with blas_threads(1):
        sol = solve_steady(reduced_problem(rm), T0=sol.T, tol=case.solver.tolerance, max_iter=case.solver.max_iterations)
    b = dict(sol.balance)
    b["applied_W"] = b.get("applied_W", 0.0) + rm.hot_spot_W
    b["space_W"] = b.get("space_W", 0.0) + rm.hot_spot_W
    return rm, dataclasses.replace(sol, balance=b)


def held_reactions(model: FEModel, rm: ReducedModel, T: np.ndarray, q: np.ndarray, q_abs: np.ndarray | None
                   ) -> np.ndarray:
    """(n,) W: the heat each fixed super node gives the structure in the detailed model at the field ``T`` (n_dof,) K:
    ``K T + σ e (T⁴ − T_s⁴) − q − q_abs`` at its DOF (its conduction and its own faces' net emission), NaN elsewhere."""
    e = np.asarray(rm.radiative.e, float)
    r = np.asarray(model.K @ T).ravel() + SIGMA * e * (T**4 - model.T_sink**4) - q
    if q_abs is not None:
        r = r - q_abs
    out = np.full(rm.n, np.nan)
    dof = np.asarray(rm.supernodes.dof)
    out[rm.fixed] = r[dof[rm.fixed]]
    return out


# ------------------------------------------------------------------------------------------ parametric correction
def parametric_states(case: Case) -> list[tuple[str, float, Case]]:
    """The one-at-a-time states of ``[reduction] parametric``: ``(name, value (SI), case)`` with that named boundary's
    value (or the sink temperature) changed and nothing else: no transient, no detailed reference, no parametric
    states of its own; per-position orbit solves become the orbit average (the network's steady state)."""
    base = dataclasses.replace(case, reduction=dataclasses.replace(case.reduction, parametric=()), transient=None,
                               reference=dataclasses.replace(case.reference, detailed=False))
    if base.orbit is not None and base.orbit.steady != "average":
        base = dataclasses.replace(base, orbit=dataclasses.replace(base.orbit, steady="average"))
    out = []
    for name, values in case.reduction.parametric:
        for v in values:
            if name == "sink":
                c = dataclasses.replace(base, environment=dataclasses.replace(base.environment, sink_temperature=v))
            else:
                c = dataclasses.replace(base, boundaries=tuple(dataclasses.replace(b, value=v) if b.name == name
                                                               else b for b in base.boundaries))
            out.append((name, float(v), c))
    return out


def parametric_corrections(design: Reduced, case: Case, names: list[str],
                           states: list[tuple[str, float, Reduced]]) -> dict:
    """The radiation-aware network's correction load at the parametric states, as departures from the design's.

    ``design`` the run's reduction, ``case`` its case, ``names`` the constants (named boundaries or "sink") in the
    order of the deck's tables; ``states`` ``(name, value (SI), reduction)`` of each state (:func:`parametric_states`,
    or the cases of a set), each reduced with the design's linearisation (the same K̃, GR, C).  The correction is
    what the network's loads hold beyond the known loads, ``Q − Y'q − q_lumped`` (q_lumped, the same in every state,
    cancels in the departures).  Returns ``{"names": (k,) str, "values": [(m_k,) SI, the design's value first],
    "dQ": [(m_k, n) W, zeros first], "gl_change": max |ΔK̃| / max |K̃| over the states}`` for
    :func:`fem2tmm.export.deliverable.network_deck` (the deck's correction follows each named constant, quadratic
    between the values: :func:`fem2tmm.reduce.radiative.parametric_weights`).
    """
    net = design.network

    def corr(red: Reduced) -> np.ndarray:
        return np.asarray(red.network.Q, float) - red.network.radiative.reduction.distribute(red.q_recover)

    c0 = corr(design)
    scale = max(float(np.abs(net.K).max()), 1e-300)
    vals, dqs = [], []
    for name in names:
        rows = [(v, r) for n, v, r in states if n == name]
        vals.append(np.array([_value(case, name)] + [v for v, _ in rows], float))
        dqs.append(np.vstack([np.zeros(net.n)] + [corr(r) - c0 for _, r in rows]))
    change = max((float(np.abs(r.network.K - net.K).max()) / scale for _, _, r in states), default=0.0)
    return {"names": tuple(names), "values": vals, "dQ": dqs, "gl_change": change}


def set_parametric(results: list) -> int:
    """The parametric tables of a load-case set, from its own cases: no run beyond the set's.

    ``results`` the set's :class:`~fem2tmm.result.Result` objects.  Cases that share one radiation-aware network
    (``reduced.shared_network``; the same GL, GR and C) and differ from a case in the value of one named boundary
    (power, flux, temperature; no table) or in the sink temperature alone (the same environment, orbit and other
    boundaries) are that case's one-at-a-time states: its ``reduced.parametric`` (unless ``[reduction]
    parametric`` set one) gets their corrections (:func:`parametric_corrections`), so that its deck follows the named
    constants between the set's values.  Returns the number of cases that got tables.
    """
    groups: dict = {}
    for r in results:
        red = r.reduced
        if red is not None and red.method == "radiation_aware" and red.shared_network is not None:
            groups.setdefault((network_group(r.case), red.shared_network["linearised_at"]), []).append(r)
    done = 0
    for members in (m for m in groups.values() if len(m) > 1):
        for r in (r for r in members if r.reduced.parametric is None):
            states = [(name, _value(o.case, name), o.reduced) for name in _named_constants(r.case)
                      for o in members if o is not r and _differs_only_in(r.case, o.case, name)]
            if states:
                names = list(dict.fromkeys(n for n, _, _ in states))
                r.reduced.parametric = {**parametric_corrections(r.reduced, r.case, names, states),
                                        "from": "the case set"}
                done += 1
    return done


def _named_constants(case: Case) -> list[str]:
    return [b.name for b in case.boundaries if b.name and b.table is None
            and b.kind in ("power", "flux", "temperature")] + ["sink"]


def _value(case: Case, name: str) -> float:
    if name == "sink":
        return float(case.environment.sink_temperature)
    return float(next(b.value for b in case.boundaries if b.name == name))


def _differs_only_in(a: Case, b: Case, name: str) -> bool:
    """Whether case ``b`` is case ``a`` with another value of the constant ``name`` and nothing else changed that
    sets the steady state (boundaries, environment, orbit)."""
    if _value(a, name) == _value(b, name) or a.orbit != b.orbit:
        return False
    if name == "sink":
        env = dataclasses.replace(b.environment, sink_temperature=a.environment.sink_temperature)
        return env == a.environment and a.environment.sink_table is None and a.boundaries == b.boundaries
    bounds = tuple(dataclasses.replace(x, value=y.value) if x.name == name else x
                   for x, y in zip(b.boundaries, a.boundaries))
    return a.environment == b.environment and len(a.boundaries) == len(b.boundaries) and bounds == a.boundaries

