"""The measured choice of ``[reduction] radiation_aware = "auto"``: the method with the smaller
estimated error on this model, without a detailed reference.

The estimate is the ``target_rms`` global estimator (:func:`fem2tmm.stages.refine.error_field`: a Newton step of
the detailed problem from the recovered field, under the true loads and the FE sides' traced IR; further steps while
the last moved a node by more than :data:`ESTIMATE_LINEAR` of its temperature), applied to each candidate's recovered
field.  Its own ray noise is measured, as the reference's is: the side-to-side IR tally is
traced as two independent halves (``[reduction] refine_rays_per_face`` / 2 rays per emitting FE side each, random
streams ``estimate_a`` / ``estimate_b``); the estimate is the RMS of the mean of the two error fields, its noise
``N = RMS(δT_a − δT_b) / 2`` (the noise of that mean).  Noise adds in quadrature to the error it rides on, so the
error the estimate sees beyond its noise is ``E = √max(RMS² − N², 0)``.

Its cost is bounded (:func:`tally_budget`): the two halves together trace at most :data:`ESTIMATE_RAY_SHARE` of the
run's own REF rays (or :data:`ESTIMATE_RAYS_FLOOR` per half), a stratified random share of the FE sides emitting
(every super face its share, Horvitz-Thompson weights), so the tally costs a bounded share of the radiation stage
at any mesh size; a smaller share shows as a larger measured noise, and a thesis' estimate within it keeps the
thesis' network.  The re-absorption solve is GMRES at :data:`ESTIMATE_TOL` on the one factorisation of
``K + diag(h)`` both halves share; with a sampled share it is left out (``K'⁻¹ r``, linear in the tally: the
sampled sides' re-absorption, weighted by their stratum, made a spiky operator whose inverse is biased; at 266 832
quads, radiation seed 2, the thesis' 0.32 K at a noise of 0.22 K then built the radiation-aware network and its
``ir_on = "faces"`` tracing, a 461 s run; without it 0.28 K at 0.20 K, the thesis kept, 19 % of the reduction).

The rule (:func:`measured_choice`), in the order it costs:

1. estimate the thesis' network (solved anyway).  If ``E_thesis ≤ N_thesis`` its error cannot be told from the
   estimate's noise, and if the largest cluster Biot number is below :data:`~fem2tmm.reductors.AUTO_BIOT` (or
   there is none: no shells) nothing else speaks against it either: keep it (no outer iterations, a
   state-independent network).  No radiation-aware network is built;
2. otherwise build the radiation-aware network
   (:class:`~fem2tmm.reductors.radiation_aware.RadiationAwareReductor`) and estimate it; it is kept when
   ``E_thesis − E_aware > max(√(N_thesis² + N_aware²), r E_thesis)``: smaller by more than the noise of the
   comparison and by more than :data:`ESTIMATE_RELATIVE_MARGIN` (r = 20 %) of the thesis' estimate, the estimator's
   own accuracy.  Where the estimates cannot tell them apart (a tie within that margin), the Biot number decides as
   it does above
   :data:`~fem2tmm.reductors.ESTIMATE_MAX_UNKNOWNS`: clusters wider than their fin length (Bi ≥ AUTO_BIOT) take the
   radiation-aware network, others the thesis'.  A small generated MLI model whose thesis' estimate (498 K) was
   within its noise (2 271 K, a 120-ray tally) kept a thesis network 418 K off where the radiation-aware one is
   19 K off (tests/test_robustness.py ``mli_emissionless_radiator_negative_share``).  A radiation-aware network
   without a physical steady solution loses: the thesis' is handed over, with a warning and
   ``reduced.choice.aware_refused``.  Only where the thesis' network was refused too does the run stop
   (:func:`reduce_aware`: one message for both, advising neither setting).

Step 1's shortcut never changes the outcome of step 2 (``E_aware ≥ 0``).  Without a traced tally (space-only
radiation, or ``ir_on = "faces"`` where the network's absorbed IR already follows the FE sides) an estimate has no
ray noise of its own and ``N = 0``.

The estimate covers the design state.  Over the off-design range of ``[reduction] verify`` the choice is made
after the network is written (:mod:`fem2tmm.range_checks`): when step 2 keeps the radiation-aware network, the thesis'
network is checked too, on the same states, and handed over when its worst RMS over the design and checked states is
smaller by more than the noise.  With the detailed reference the states' errors are measured (the same detailed
solutions for both: a generated model of the robustness campaign, two plates touching at a corner, both networks
4.6 K off at the design state, the radiation-aware one 35.8 K at a −270 °C sink and the thesis' 26.1 K;
tests/test_verify.py).  Without it they are
*estimated* (:func:`range_estimator`: this estimate at each state, from the edited deck's recovered field, with the
state's own linearisation and the design estimate's tallies), and the thesis' network must also be better by
:data:`ESTIMATE_RELATIVE_MARGIN` of the other's worst.  On examples/satellite (orbit coarsened) the estimated worsts
are 0.6-0.95 of the measured ones at every state, and both choices come out as with the reference (2026-12-07).  The
range's decks cost what the verification's do (0.11 s per state there); the estimates themselves 0.02 s per state.
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import numpy as np

from ..case import Case
from ..errors import Fem2TmmError
from ..reduce.network import negative_loads
from ..reductors import AUTO_BIOT, REDUCTORS, Reduced, ReductionInputs
from .refine import Refinement, error_field, side_tally, uses_side_tally

#: what the estimate covers (summary.json ``reduced.choice.estimate_covers``)
COVERS = ("the design state; the [reduction] verify range is then checked for both networks after the network is "
          "written (reduced.choice.verified_range): measured with the detailed reference, estimated without it, and "
          "the thesis' network replaces the radiation-aware one where it holds that range better")


def resolved(case: Case, aware: bool) -> Case:
    """``case`` with ``radiation_aware`` set to ``aware`` and ``ir_on = "auto"`` resolved as
    :func:`fem2tmm.reductors.choose_reduction` does ("faces" with the radiation-aware reduction, else
    "super_faces")."""
    rad = case.radiation
    ir_on = rad.ir_on if rad.ir_on != "auto" else ("faces" if aware and rad.enabled else "super_faces")
    return dataclasses.replace(case, reduction=dataclasses.replace(case.reduction, radiation_aware=aware),
                               radiation=dataclasses.replace(rad, ir_on=ir_on))


#: the two half tallies of the estimate together trace at most this share of the run's own exchange rays (the super
#: faces' REFs, ``[radiation]`` budget), or :data:`ESTIMATE_RAYS_FLOOR` per half if that is more: the estimate's
#: tracing then costs about that share of the radiation stage, whatever the mesh (at 266 832 quads, 10 + 10 rays
#: per FE side were 1.07e7 rays against the run's 1e7, most of the estimate's 76 % of the reduction stages)
ESTIMATE_RAY_SHARE = 0.05
#: rays per half tally always allowed (up to the full tally): a small model's estimate keeps a few 10⁴ rays per half
#: whatever its REF budget.  At 2·10⁵ the baffle's case_100 (100 super nodes, specular, thesis kept) spent 2.85 s of
#: its 2.96 s estimate in the two half tallies, 40-65 % of its 7.5 s of reduction stages; at 5·10⁴ 15 % under load
#: 2-3 (6.5 s of reduction stages) but 19-25 % on a quiet machine (4.0-5.0 s, 2026-12-06 20:27 UTC); at 3·10⁴ 16-17 %
#: there, its noise 0.0094 -> 0.0113 K (docs/studies.md, "Which reduction runs by default", measures every study)
ESTIMATE_RAYS_FLOOR = 30_000
#: the radiation-aware network replaces the thesis' only when its estimate is smaller by more than this share of the
#: thesis' estimate (or by more than their ray noise, if that is more): the estimator's own accuracy.  Over the
#: robustness campaign (2000 models, 2026-12-06 17:40-17:53 UTC) the thesis' estimate over its measured error had
#: quartiles 0.92 and 1.23; with the noise alone as the margin, 3 of 289 radiation-aware choices were worse than the
#: thesis' network by more than the reference noise (a plate under a 1 cm lid: estimates 0.620 / 0.613 K, measured
#: thesis 0.133 K, radiation-aware 0.541 K); with 20 % none, and no choice that was better beyond the noise lost
ESTIMATE_RELATIVE_MARGIN = 0.2
#: the estimate takes another Newton step of the detailed problem where the last one moved a node by more than this
#: share of its temperature (the T⁴ linearisation's error is ~1.5x that share of the step), at most
#: ESTIMATE_MAX_STEPS.  One step misranked a generated two-plate model at a −270 °C sink (estimated 25.2 / 35.5 K,
#: measured 35.8 / 26.1 K: radiation-aware / thesis); five give the measured figures (2026-12-07, tests/test_verify.py)
ESTIMATE_LINEAR = 0.02
ESTIMATE_MAX_STEPS = 5
#: relative tolerance of the estimate's re-absorption solve (GMRES): its error in the estimate is of that order,
#: far below the estimate's own accuracy (0.66-0.99 of the measured RMS on examples/composite) and its ray noise
ESTIMATE_TOL = 1e-3


def tally_budget(inputs: ReductionInputs, exchange=None) -> tuple[int, float]:
    """``(rays per emitting FE side, share of the active sides that emit)`` of each of the two half tallies.

    ``[reduction] refine_rays_per_face`` / 2 rays per side each, capped so that both halves together trace at most
    :data:`ESTIMATE_RAY_SHARE` of ``exchange.rays`` (the run's own REF rays; None: no cap), or
    :data:`ESTIMATE_RAYS_FLOOR` per half, by letting only a random
    share of the sides emit, each its full rays (:func:`~fem2tmm.stages.refine.side_tally`, unbiased), not by fewer
    rays per side: the tally's self-normalised rows are biased at a few rays per side, a bias the two halves share
    and so cannot measure (a 30 cm box at 2000 W/(m K) whose thesis' network is 1.3e-4 K off: estimated 0.0036 K
    beyond a noise of 0.0038 K at 2 rays per side and half, 0.001 K beyond 0.0016 K at 10, none at 50 and 200).
    The estimate's noise, measured from the two halves, grows as the share shrinks; a thesis' estimate within that
    noise keeps the thesis' network (module docstring)."""
    n = int(np.count_nonzero(inputs.model.faces.active))
    per = max(1, int(np.ceil(inputs.case.reduction.refine_rays_per_face / 2)))
    if exchange is None or not n:
        return per, 1.0
    cap = max(ESTIMATE_RAY_SHARE * float(np.sum(exchange.rays)) / 2.0, ESTIMATE_RAYS_FLOOR)
    return per, min(1.0, max(cap / per, 1.0) / n)


def super_face_of_sides(model, clustering) -> np.ndarray:
    """(2f,) int: each FE side's super face, as the cluster of its element and which side (2 c + 0 front, + 1
    back); -1 for faces of no cluster.  The strata of the estimate's sampled tally."""
    f = model.faces
    lab = np.asarray(clustering.labels, np.int64)[f.element]
    return np.where(np.repeat(lab, 2) >= 0, 2 * np.repeat(lab, 2) + np.tile([0, 1], f.n), -1)


def estimate(inputs: ReductionInputs, red: Reduced, surface=None, scene=None,
             tallies: dict | None = None, budget: tuple[int, float] | None = None, pre: list | None = None) -> dict:
    """The a-posteriori estimate of one candidate's recovered-field error, with its own ray noise.

    Parameters
    ----------
    inputs : the reduction's inputs (model, clustering, case, loads ``q_recover`` (n_dof,) W, ``q_lumped`` (n,) W)
    red : the candidate (its network, ``solution.T`` (n,) K, ``T_recovered`` (n_dof,) K, ``ir``)
    surface, scene : the radiation surface and ray scene, or None (no radiation traced)
    tallies : ``{"a", "b"}`` the two half tallies, traced on first use and shared by the candidates
    budget : ``(rays per side, share of the sides)`` of each half tally (:func:`tally_budget`; None: its uncapped
        value)
    pre : factorisations of ``K + diag(h)`` at earlier fields, shared by the calls on one candidate
        (:func:`~fem2tmm.reduce.refine.global_estimate`: one near enough stands for the field's own), or None

    Returns
    -------
    ``{"rms_K", "noise_K", "beyond_noise_K", "max_K"}``: the RMS of the estimated error field over the mesh nodes
    (K), its ray noise N (K, 0 without a tally), √max(rms² − N², 0) (K) and the field's largest magnitude (K).
    """
    case = red.case
    model = inputs.model.with_unblocked(red.ir.unblocked if red.ir is not None and red.ir.unblocked is not None
                                        else inputs.unblocked, inputs.traced_area)
    side = uses_side_tally(model, case, red.ir, surface)
    if side:
        tallies = {} if tallies is None else tallies
        per, share = tally_budget(inputs) if budget is None else budget
        for h in ("a", "b"):
            if h not in tallies:
                tallies[h] = side_tally(model, case, surface, scene, rays_per_face=per, role=f"estimate_{h}",
                                        share=share, strata=super_face_of_sides(model, inputs.clustering))
    # Newton steps of the detailed problem from the recovered field while the last one moved a node by more than
    # ESTIMATE_LINEAR of its temperature (the T⁴ linearisation's error, ~1.5 x of the step, x its relative size); both
    # halves step from their mean field, through one factorisation of K + diag(h) there; a step not below half the
    # one before (Newton not contracting: a tally of a few rays per side) is left out and ends the steps.  Each half's
    # estimate is the mean field reached plus its own last step (its residual carries its whole tally at every step:
    # summing the halves' steps would count their difference once per step)
    T_rec = np.asarray(red.T_recovered, float)
    T, kept, last = T_rec, None, 0.0
    for _ in range(ESTIMATE_MAX_STEPS):
        args = (model, inputs.clustering, case, red.network, red.solution.T, T, inputs.q_recover, inputs.q_lumped,
                red.ir)
        if side:
            lu: dict = {}
            out = [error_field(*args, Refinement(side_absorption=tallies[h]), surface, scene, cache=lu,
                               tol=ESTIMATE_TOL, reabsorb=share >= 1.0, pre=pre) for h in ("a", "b")]
        else:
            out = [error_field(*args, Refinement(), None, None, tol=None if pre is None else ESTIMATE_TOL, pre=pre)]
        steps, w = [o[0] for o in out], out[0][1]  # (the RMS weights: mesh nodes per DOF)
        step = sum(steps) / len(steps)
        size = float(np.abs(step).max(initial=0.0))
        if kept is not None and size >= 0.5 * last:  # Newton does not contract (a noisy tally): the steps so far
            break
        kept = [T - T_rec + s for s in steps]
        if np.all(np.abs(step) <= ESTIMATE_LINEAR * T):
            break
        T, last = np.maximum(T + step, 1.0), size
    dT = sum(kept) / len(kept)
    noise = float(np.sqrt((w * (kept[0] - kept[1]) ** 2).sum() / w.sum()) / 2.0) if side else 0.0
    rms = float(np.sqrt((w * dT**2).sum() / w.sum()))
    return {"rms_K": rms, "noise_K": noise, "beyond_noise_K": float(np.sqrt(max(rms**2 - noise**2, 0.0))),
            "max_K": float(np.abs(dT[w > 0]).max(initial=0.0))}


def range_estimator(inputs: ReductionInputs, red: Reduced, surface=None, scene=None, tallies: dict | None = None,
                    budget: tuple[int, float] | None = None, pre: list | None = None):
    """The estimate of :func:`estimate` at the other states of the validity range, for
    :func:`fem2tmm.verify.verify_network` ``(estimator=)`` in a run without a detailed reference.

    At a state the same Newton step of the detailed problem is taken from the recovered field of the edited deck,
    under that state's loads (the named power and flux loads' patterns scaled to their edited values,
    :func:`fem2tmm.fem.model.load_patterns`), its held temperatures (the deck's fixed super nodes) and sink; the side
    tallies are geometry and are shared with the design estimate (``tallies``).  The linearisation is the state's
    own, so the estimate is as good off the design state as on it (solved on a factorisation of ``K + diag(h)`` at
    an earlier state where h has not moved far: :func:`fem2tmm.reduce.refine.global_estimate` ``pre``).

    Parameters
    ----------
    inputs : the reduction's inputs (the design state's loads ``q_recover`` (n_dof,) W)
    red : the candidate network (its ``network``, ``solution``, ``case`` and ``ir``)
    surface, scene, tallies, budget : as for :func:`estimate`
    pre : list, optional
        The factorisations kept so far, shared by the candidates of one run (the same detailed K; h from each
        candidate's recovered field at a state, a few K apart); a new list by default.

    Returns
    -------
    ``estimator(values, T_sn, T_rec) -> dict``: :func:`estimate`'s record at the state ``values`` ({constant name:
    SI value}, "sink" K; {} the design state), the deck's super-node temperatures ``T_sn`` (n,) K in the network's
    order and the recovered field ``T_rec`` (n_dof,) K.
    """
    from ..fem.model import load_patterns

    model, case = inputs.model, inputs.case
    named = {b.name: b for b in case.boundaries if b.name}
    patterns: dict = {}
    tallies = {} if tallies is None else tallies
    pre = [] if pre is None else pre  # factorisations of K + diag(h) at the states estimated so far

    def at(values: dict, T_sn: np.ndarray, T_rec: np.ndarray) -> dict:
        q = np.array(inputs.q_recover, float)
        for name, v in values.items():
            b = named.get(name)
            if b is None or b.kind == "temperature" or v == b.value:
                continue
            if name not in patterns:
                patterns.update(load_patterns(model, case, [name]))
            q += (v - b.value) * patterns[name]
        net = red.network
        net = dataclasses.replace(net, T_fixed=np.where(net.fixed, T_sn, net.T_fixed))
        cand = dataclasses.replace(red, network=net, solution=dataclasses.replace(red.solution, T=T_sn),
                                   T_recovered=T_rec)
        m = dataclasses.replace(model, T_sink=float(values.get("sink", model.T_sink)))
        return estimate(dataclasses.replace(inputs, model=m, q_recover=q), cand, surface, scene, tallies, budget, pre)

    return at


def measured_choice(inputs: ReductionInputs, thesis: Reduced, choice: dict, prog, surface=None,
                    scene=None, exchange=None, tallies: dict | None = None) -> tuple[Reduced, dict, Reduced | None]:
    """Resolve ``radiation_aware = "auto"`` by the estimated errors (the module's rule).

    Parameters
    ----------
    inputs : the reduction's inputs, ``inputs.case`` with ``radiation_aware = "auto"``
    thesis : the thesis' reduction of those inputs (solved, recovered)
    choice : :func:`fem2tmm.reductors.choose_reduction`'s record (its Biot number is kept as information)
    prog : :class:`~fem2tmm.progress.Progress` (stages "estimate", and the radiation-aware reduction's own)
    surface, scene : the radiation surface and ray scene, or None (no radiation traced)
    exchange : the run's super-face :class:`~fem2tmm.radiation.ExchangeResult` (its rays cap the estimate's,
        :func:`tally_budget`), or None
    tallies : dict, filled with the two half tallies traced here (shared with :func:`range_estimator`), or None

    Returns
    -------
    ``(red, choice, thesis_or_None)``: the kept reduction (its ``case`` resolved), the record for summary.json
    ``reduced.choice`` (``estimated_rms_K``, ``estimate_noise_K`` per candidate, None for one not built,
    ``chosen_by``, ``estimate_seconds``, ``estimate_covers``, ``estimate_rays`` the rays of each half tally traced,
    [] without one), and the thesis' reduction when the other was kept.
    """
    tallies = {} if tallies is None else tallies
    seconds, refused = 0.0, None

    def timed(red: Reduced) -> dict:
        nonlocal seconds
        with prog.stage("estimate", f"estimating the {red.method.replace('_', '-')} reduction's error "
                                    "(a-posteriori)"):
            t0 = time.perf_counter()
            out = estimate(inputs, red, surface, scene, tallies, budget)
            seconds += time.perf_counter() - t0
        return out

    budget = tally_budget(inputs, exchange)
    thesis = dataclasses.replace(thesis, case=resolved(inputs.case, False))
    est = {"thesis": timed(thesis), "radiation_aware": None}
    et = est["thesis"]
    kept, why = thesis, None
    bi = choice.get("biot_cluster_max")
    wide = bi is not None and bi >= AUTO_BIOT  # clusters wider than their fin length: the tie-break (module rule)
    if et["beyond_noise_K"] <= et["noise_K"] and not wide:
        biot = ("there is no shell Biot number" if bi is None else
                f"the largest cluster Biot number {bi:.3g} is below {AUTO_BIOT:g}")
        why = (f"auto: the thesis' estimated error {et['rms_K']:.3g} K is at its estimate's noise "
               f"{et['noise_K']:.2g} K and {biot}: the thesis' network (the radiation-aware one not built)")
    else:
        aware_inputs = dataclasses.replace(inputs, case=resolved(inputs.case, True), advise=False)
        try:
            aware = REDUCTORS["radiation_aware"]().reduce(aware_inputs, prog, start=thesis)
        except Fem2TmmError as exc:  # a candidate without a physical steady solution loses: the thesis' has one
            refused = str(exc)
            why = ("auto: the radiation-aware network has no physical steady solution: the thesis' network "
                   f"(estimated error {et['rms_K']:.3g} K, noise {et['noise_K']:.2g} K)")
            warnings.warn(f"{inputs.case.source}: [reduction] radiation_aware = \"auto\": the radiation-aware network "
                          f"has no physical steady solution here ({refused}); the run hands over the thesis' network "
                          f"(its estimated error {et['rms_K']:.3g} K, summary.json reduced.choice)", stacklevel=2)
        else:
            ea = est["radiation_aware"] = timed(aware)
            noise = float(np.hypot(et["noise_K"], ea["noise_K"]))
            margin = max(noise, ESTIMATE_RELATIVE_MARGIN * et["beyond_noise_K"])
            gain = et["beyond_noise_K"] - ea["beyond_noise_K"]
            pair = (f"estimated error thesis {et['rms_K']:.3g} K, radiation-aware {ea['rms_K']:.3g} K "
                    f"(their noise {noise:.2g} K, the margin {margin:.2g} K: that noise or "
                    f"{ESTIMATE_RELATIVE_MARGIN:.0%} of the thesis' estimate)")
            if gain > margin:
                kept, why = aware, f"auto: {pair}: the radiation-aware network, smaller by more than the margin"
            elif gain >= -margin and wide:
                kept, why = aware, (f"auto: {pair}: a tie within the margin, and the largest cluster Biot number "
                                    f"{bi:.3g} >= {AUTO_BIOT:g}: the radiation-aware network")
            elif gain >= -margin:
                why = f"auto: {pair}: a tie within the margin, the thesis' network"
            else:
                why = f"auto: {pair}: the thesis' network, smaller by more than the margin"
            if kept is aware and aware.notes:
                why = "; ".join([why, *aware.notes])
    choice = {**choice, "radiation_aware": kept is not thesis, "ir_on": kept.case.radiation.ir_on, "chosen_by": why,
              "estimated_rms_K": {k: None if v is None else v["rms_K"] for k, v in est.items()},
              "estimate_noise_K": {k: None if v is None else v["noise_K"] for k, v in est.items()},
              "estimate_seconds": seconds, "estimate_covers": COVERS, "aware_refused": refused,
              "estimate_rays": [int(budget[0] * (t[2] > 0).sum()) for t in (tallies.get("a"), tallies.get("b"))
                                if t is not None], "estimate_sides_share": budget[1]}
    return kept, choice, None if kept is thesis else thesis


def reduce_aware(inputs: ReductionInputs, prog, start: Reduced, thesis_refused: str | None) -> Reduced:
    """The radiation-aware reduction the case resolved to (``radiation_aware = true``, or ``"auto"`` where the
    thesis' network has no physical solution: ``thesis_refused`` its refusal), started from ``start``.

    Where the thesis' network was refused and the radiation-aware one has no physical steady solution either, no
    method here has one: one :class:`Fem2TmmError` says so for both, and advises neither ``radiation_aware`` setting
    (both were tried).  Otherwise the radiation-aware reduction's own error stands."""
    try:
        return REDUCTORS["radiation_aware"]().reduce(inputs, prog, start=start)
    except Fem2TmmError as exc:
        if thesis_refused is None:
            raise
        src = f"{inputs.case.source}: "
        cause = lambda msg: msg.removeprefix(src).split("; use ")[0]  # noqa: E731  (their advice: tried here)
        # (the positive network keeps the loads: not where their exact distribution has a negative share)
        advice = ("" if inputs.case.reduction.network == "positive" or negative_loads(inputs.network)[1] else
                  "[reduction] network = \"positive\" (the thesis' reduction with positive conductances) or ")
        raise Fem2TmmError(
            f"{inputs.case.source}: neither reduction method has a physical steady solution for this model at these "
            f"super-node counts: the thesis' network: {cause(thesis_refused)}; the radiation-aware network: "
            f"{cause(str(exc))}; use {advice}more super nodes (in the parts where the load or the held temperatures "
            "are)") from None
