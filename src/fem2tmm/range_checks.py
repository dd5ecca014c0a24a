"""The network handed over, checked over its validity range, and the choices made there (issues 41 and 42).

After the reduction the run writes the network, reads it back, solves and recovers it (:func:`deliver_and_verify`).
Then its validity range (:mod:`fem2tmm.verify`): each named constant edited in the deck as a user edits it, the deck
solved, its field recovered, and

- **with the detailed reference**: the recovered field against the detailed model solved at that state
  (``reduced.verified``, status "verified");
- **without it** (``--no-reference``, ``[reference] detailed = false``): the range stays UNVERIFIED, but where the
  run has a choice to make, each candidate's error at those states is *estimated*: the a-posteriori estimate of
  ``radiation_aware = "auto"`` (:func:`fem2tmm.stages.choice.range_estimator`: Newton steps of the detailed
  problem at the state's loads, held temperatures and sink, from the recovered field, as at the design state; the
  same IR tallies as the design estimate).  ``reduced.verified.estimated`` keeps the record of the network handed over.

Two choices rest on that range, measured or estimated, on the same states:

- **Where a short super node's heat comes from** (:func:`_floor_choice`): the radiation-aware network whose short
  super nodes are fed along K̃'s links replaces the one fed from the held node when its worst RMS over the range is
  smaller by more than the noise and :data:`~fem2tmm.verify.FLOOR_RELATIVE_MARGIN` of the other's.
- **The thesis' network** (:func:`_range_choice`), where ``"auto"`` kept the radiation-aware one by its design-state
  estimate: it replaces it when its worst RMS over the range is smaller by more than the noise (with estimates, and
  by :data:`~fem2tmm.stages.choice.ESTIMATE_RELATIVE_MARGIN` of the kept one's: the estimator's own accuracy, as at
  the design state).

Without the reference the other candidate's states are checked in the order of the kept network's errors and stop
once it can no longer win (:func:`fem2tmm.verify.cannot_win`: the same choice, at a fraction of the cost where it
loses); with the reference every state of both is checked.

The orchestrator passes ``hand_over(run, net, alt, q_orbit)``, which delivers another network in place of the first.
"""

from __future__ import annotations

import dataclasses
import time

from .reductors import Reduced, reductor_for


def deliver_and_verify(run, reduced: Reduced, problem, net, q_orbit, hand_over) -> None:
    """What the user receives (the network written, read back, solved, recovered), then its validity range, verified
    against the detailed model or, without it and where a choice rests on it, estimated (module docstring).

    Parameters
    ----------
    run : the orchestrator's run state (``result``, ``case``, ``prog``, ``alternative``, ``tallies``, ``tracing()``)
    reduced : the network delivered first
    problem : the detailed steady problem at the design state
    net : the reduction's inputs and network (``net.inputs``)
    q_orbit : (k, n_dof) W orbital loads per position, or None
    hand_over : ``hand_over(run, net, alt, q_orbit)``: delivers ``alt`` in place of the first network
    """
    from .handover import check_deliverable
    from .stages.radiation import warn_emission
    from .verify import NO_REFERENCE, PROBE_STATE, verify_network, warn_off_range, why_unverified

    # the last candidate's recovery (its saddles and fields, adopted by the next candidate's), and what the deliverable
    # check wrote and read back of the first, which the range's check of that network takes as its own
    shared: dict = {"written": {}}
    with run.prog.stage("deliverable", "reading back, solving and recovering the network handed over"):
        reduced.delivered = check_deliverable(run.result, recover=run.dpart.solution is not None,
                                              keep=shared["written"])
    reduced.verified = why_unverified(run.result)  # the validity range: checked against the detailed model, or not
    floor = getattr(reduced.network.radiative, "floor_linked", None)
    other = run.alternative is not None
    unverified = None
    if reduced.verified is None:
        references = {}  # the detailed solutions at the verified states, shared with the other networks' checks

        def check(result, warn=False, against=None):
            return verify_network(result, problem, references, warn=warn, shared=shared, **(against or {}))

        stage = ("verify", "verifying the network over its validity range (edited decks vs detailed)")
    elif ((other or floor is not None) and reduced.verified.get("reason") == NO_REFERENCE
          and why_unverified(run.result, reference=False) is None):
        from .stages.choice import range_estimator, tally_budget

        unverified, surface_scene = reduced.verified, run.tracing()
        budget = tally_budget(net.inputs, reduced.radiation)
        estimators: list = []  # (network, its estimator): a second call on one network goes on with the same
        pool: list = []  # the estimates' factorisations, shared by the candidates (the same detailed K)

        def check(result, warn=False, against=None):
            est = next((e for r, e in estimators if r is result.reduced), None)
            if est is None:
                est = range_estimator(net.inputs, result.reduced, *surface_scene, run.tallies, budget, pool)
                estimators.append((result.reduced, est))
            return verify_network(result, problem, None, warn=False, estimator=est, shared=shared, **(against or {}))

        stage = ("estimate_range", "estimating the networks' error over the validity range (no detailed reference)")
    else:
        check = None
    if check is not None:
        with run.prog.stage(*stage):
            # estimated with the floor's second candidate to weigh: one state first (_floor_choice goes on)
            probe = _one_state(PROBE_STATE) if unverified and floor is not None else None
            reduced.verified = check(run.result, warn=unverified is None and not (other or floor), against=probe)
        if floor is not None:
            reduced = _floor_choice(run, net, reduced, check, q_orbit, hand_over)
        if other:
            _range_choice(run, net, reduced, check, q_orbit, hand_over)
        final = run.result.reduced
        if unverified is not None:  # the range stays unverified; the estimate of the network handed over beside it
            final.verified = {**unverified, "estimated": final.verified}
        elif other or floor is not None:
            warn_off_range(run.case.source, final.verified)  # for the network handed over
    if floor is not None:
        reduced.network.radiative.floor_linked = None  # the candidate not handed over
    if run.alternative is not None and run.result.reduced is reduced:  # its warning, held back until it was kept
        warn_emission(reduced.emission_check)
    run.alternative = None
    for r in (reduced, run.result.reduced):  # the saddles the design state, the positions and the range shared
        if hasattr(r.recovery, "release"):
            r.recovery.release()


_CHECKED = ("verified", "partly verified", "estimated")


def _range_choice(run, net, reduced: Reduced, check, q_orbit, hand_over) -> None:
    """The measured choice over the validity range (issue 42): the thesis' network, delivered and checked on the
    same states (``check``: the same detailed solutions, or the estimate), replaces the radiation-aware one the
    design-state estimate kept when its worst RMS is smaller by more than the noise
    (:func:`fem2tmm.verify.range_choice`; estimated: and by ``ESTIMATE_RELATIVE_MARGIN`` of the kept one's).
    Recorded in ``reduced.choice.verified_range`` either way (``by``: "reference" or "estimate"; ``unchecked``: the
    thesis' states left out once it could not win, :func:`fem2tmm.verify.cannot_win`); the orbit positions of
    ``steady = "positions"`` are solved again on the network handed over.  Not where the deck carries what the thesis'
    network cannot (the parametric correction, a load-case set's shared network)."""
    from .stages.choice import ESTIMATE_RELATIVE_MARGIN
    from .verify import RANGE_FLOOR_K, range_choice

    thesis, inputs = run.alternative
    if (reduced.verified.get("status") not in _CHECKED or reduced.parametric is not None
            or reduced.shared_network is not None):
        return
    estimated = reduced.verified["status"] == "estimated"
    if estimated and _thesis_cannot_win(reduced):
        return
    t0 = time.perf_counter()
    with run.prog.stage("verify_thesis", "checking the thesis' network over the same range"):
        alt = reductor_for(thesis.case).deliver(dataclasses.replace(inputs, case=thesis.case), thesis, run.prog)
        alt = dataclasses.replace(alt, clustering=reduced.clustering, radiation=reduced.radiation,
                                  super_faces_count=reduced.super_faces_count, solar=reduced.solar,
                                  solar_on=reduced.solar_on, refinement=reduced.refinement)
        relative = ESTIMATE_RELATIVE_MARGIN if estimated else 0.0
        alt.verified = check(dataclasses.replace(run.result, reduced=alt), against=_against(reduced, relative))
    rc = range_choice(reduced.verified, alt.verified, relative=relative)
    rc["seconds"] = time.perf_counter() - t0
    rc["by"] = "estimate" if estimated else "reference"
    rc["unchecked"] = list(alt.verified.get("unchecked", []))  # the thesis' states it no longer needed
    wk, wt = rc["worst_K"]["kept"], rc["worst_K"]["thesis"]
    failed = "".join(f"; the {who} network has no solution at {', '.join(rc['failed'][k])}"
                     for k, who in (("kept", "radiation-aware"), ("thesis", "thesis'")) if rc["failed"][k])
    what = ("estimated (no detailed reference) over the validity range" if estimated else "over the verified range")
    tolerance = (f"the margin {rc['tolerance_K']:.2g} K (the estimates' noise, at least {RANGE_FLOOR_K:g} K and "
                 f"{ESTIMATE_RELATIVE_MARGIN:.0%} of the radiation-aware network's worst)" if estimated else
                 f"the tolerance {rc['tolerance_K']:.2g} K (the reference noise, at least {RANGE_FLOOR_K:g} K)")
    least = (f"at least {wt:.3g} K ({rc['worst_state']['thesis']}; {len(rc['unchecked'])} of its states not checked "
             "once it could not be better)" if rc["unchecked"] else f"{wt:.3g} K ({rc['worst_state']['thesis']})")
    figures = (f"{what} the radiation-aware network's worst RMS is {wk:.3g} K "
               f"({rc['worst_state']['kept']}), the thesis' {least}, {tolerance}{failed}")
    # the validity range's cost in the run is both checks' (summary: verified.seconds, cost_fraction)
    both = reduced.verified["seconds"] + rc["seconds"]
    if not rc["thesis"]:
        reduced.choice = {**reduced.choice, "verified_range": rc,
                          "chosen_by": f"{reduced.choice['chosen_by']}; {figures}: kept"}
        reduced.verified = {**reduced.verified, "seconds": both}
        return
    rc["replaced"] = {"method": reduced.method, "verified": reduced.verified}
    alt.verified = {**alt.verified, "seconds": both}
    alt.choice = {**reduced.choice, "radiation_aware": False, "ir_on": thesis.case.radiation.ir_on,
                  "verified_range": rc,
                  "chosen_by": (f"{reduced.choice['chosen_by']}; {figures}: the thesis' network holds the range "
                                "better and is handed over")}
    run.case = thesis.case
    hand_over(run, net, alt, q_orbit)


def _against(reduced: Reduced, relative: float) -> dict:
    """:func:`fem2tmm.verify.verify_network`'s ``order`` and ``enough`` for a candidate weighed against ``reduced``
    (:func:`fem2tmm.verify.cannot_win`): without the detailed reference its estimated states stop once it cannot
    replace ``reduced`` (examples/smallsat's floor candidate: 0.24 -> 0.08 s).  With the reference every state is
    checked: the record then gives both networks at every verified state, what the docs' "better than the thesis'
    network at every edited state" rests on, and costs recoveries only (the detailed solutions are shared)."""
    from .verify import cannot_win

    if reduced.verified.get("status") != "estimated":
        return {}
    order, enough = cannot_win(reduced.verified, relative)
    return {"order": order, "enough": enough}


def _one_state(label: str) -> dict:
    """:func:`fem2tmm.verify.verify_network`'s ``order`` and ``enough`` that check the state ``label`` alone (the first
    in the order where there is no such state): ``enough`` is called with the design state's RMS first."""
    calls = iter((False,))
    return {"order": [label], "enough": lambda rms: next(calls, True)}


def _at(verified: dict, label: str) -> dict:
    """A record reduced to one of its states (its design state's RMS left out: both candidates are exact there)."""
    return {**verified, "design": {**verified["design"], "rms_K": 0.0},
            "states": [r for r in verified["states"] if r["label"] == label]}


def _floor_decision(held: Reduced, linked: Reduced) -> dict:
    """:func:`fem2tmm.verify.range_choice` of the floor's two candidates (their ``verified`` records), and never a
    network without a solution at a state the other solves (both are the same method's)."""
    from .verify import FLOOR_RELATIVE_MARGIN, range_choice

    rc = range_choice(held.verified, linked.verified, relative=FLOOR_RELATIVE_MARGIN)
    rc["thesis"] = rc["thesis"] and set(rc["failed"]["thesis"]) <= set(rc["failed"]["kept"])
    return rc


def _thesis_cannot_win(reduced: Reduced) -> bool:
    """Estimated ranges only: where the kept network's estimated worst over the range is at most the thesis' estimate
    at the design state alone (beyond its noise, ``reduced.choice``), the thesis' worst over the range, which counts
    the design state, cannot be smaller: its decks are not checked (on examples/composite that saves 3 s, its 7
    recoveries).  Records the shortcut in ``reduced.choice.verified_range`` (``checked`` False) and returns True."""
    import numpy as np

    from .verify import range_worst

    ch = reduced.choice or {}
    rms, noise = (ch.get(k, {}).get("thesis") for k in ("estimated_rms_K", "estimate_noise_K"))
    if rms is None:
        return False
    et = float(np.sqrt(max(rms**2 - (noise or 0.0) ** 2, 0.0)))
    wk, lk = range_worst(reduced.verified)
    if et < wk:
        return False
    rc = {"by": "estimate", "checked": False, "thesis": False, "worst_K": {"kept": wk, "thesis": None},
          "worst_state": {"kept": lk, "thesis": None}, "thesis_design_estimate_K": et, "tolerance_K": None,
          "states_K": {}, "failed": {"kept": list(reduced.verified["failed"]), "thesis": []}, "seconds": 0.0}
    reduced.choice = {**ch, "verified_range": rc, "chosen_by": (
        f"{ch['chosen_by']}; estimated (no detailed reference) over the validity range the radiation-aware network's "
        f"worst RMS is {wk:.3g} K ({lk}), not above the thesis' estimate at the design state alone ({et:.3g} K): "
        "the thesis' network cannot hold the range better (its decks not checked): kept")}
    return True


def _floor_choice(run, net, reduced: Reduced, check, q_orbit, hand_over) -> Reduced:
    """Where a short super node's heat comes from (:func:`fem2tmm.reduce.radiative.emission_floor_links`): the
    radiation-aware network with it fed along K̃'s links, checked on the same states (``check``: the same detailed
    solutions, or the estimate), replaces the one fed from the held node when its worst RMS over the range is smaller
    beyond the noise and :data:`~fem2tmm.verify.FLOOR_RELATIVE_MARGIN` of the held one's
    (:func:`fem2tmm.verify.range_choice`).  Both are exact at the design state.  ``reduced.choice.floor`` keeps both
    worsts (``by``: "reference" or "estimate").  Returns the network handed over."""
    from .verify import FLOOR_RELATIVE_MARGIN, must_lose, range_choice

    if reduced.verified.get("status") not in _CHECKED:
        return reduced
    t0 = time.perf_counter()
    first = reduced.verified["seconds"]
    with run.prog.stage("verify_floor", "checking the network with its short super nodes fed along its links"):
        linked, sol = reduced.network.radiative.floor_linked
        alt = dataclasses.replace(reduced, network=linked, solution=sol)
        result = dataclasses.replace(run.result, reduced=alt)
        probed = [r for r in reduced.verified["states"] if r["rms_K"] is not None]
        if reduced.verified["unchecked"] and not probed:  # (the probe state without a solution: all its states)
            reduced.verified = check(run.result)
        if reduced.verified["status"] == "estimated" and reduced.verified["unchecked"]:
            # estimated, the held network checked at one state (deliver_and_verify): the linked one there; where it
            # is lower there by the margin it needs to win (range_choice's), it is checked in full first and the held
            # one until it must lose, else the held one first and the linked one until it cannot win (the winner's
            # states all needed, the loser's a few: examples/satellite, the links 1.72 K against 6.52 K there,
            # 20 -> 12 deck round trips; on a near tie the held one first, as the L-bracket's 3.06 K against 3.02 K)
            label = probed[0]["label"]
            alt.verified = check(result, against=_one_state(label))
            at = {r["label"]: r["rms_K"] for r in alt.verified["states"]}.get(label)
            if at is not None and range_choice(_at(reduced.verified, label), _at(alt.verified, label),
                                               relative=FLOOR_RELATIVE_MARGIN)["thesis"]:
                alt.verified = check(result)
                reduced.verified = check(run.result, against=dict(zip(("order", "enough"), must_lose(
                    alt.verified, FLOOR_RELATIVE_MARGIN))))
                if reduced.verified["unchecked"] and not _floor_decision(reduced, alt)["thesis"]:
                    # the held network kept after all (its noise beyond must_lose's bound, or the linked one without
                    # a solution where it was not checked): handed over, so all its states
                    reduced.verified = check(run.result)
            else:
                reduced.verified = check(run.result)
                alt.verified = check(result, against=_against(reduced, FLOOR_RELATIVE_MARGIN))
        else:
            alt.verified = check(result, against=_against(reduced, FLOOR_RELATIVE_MARGIN))
    rc = _floor_decision(reduced, alt)
    by = "estimate" if reduced.verified["status"] == "estimated" else "reference"
    rec = {"source": "linked" if rc["thesis"] else "held", "tolerance_K": rc["tolerance_K"],
           "seconds": time.perf_counter() - t0, "by": by,
           "unchecked": {k: list(v.verified.get("unchecked", [])) for k, v in (("held", reduced), ("linked", alt))},
           "failed": {"held": rc["failed"]["kept"], "linked": rc["failed"]["thesis"]},
           **{k: {"held": rc[k]["kept"], "linked": rc[k]["thesis"]} for k in ("worst_K", "worst_state")}}
    keep = alt if rc["thesis"] else reduced
    keep.verified = {**keep.verified, "seconds": first + rec["seconds"]}
    worst = "estimated worst RMS" if by == "estimate" else "worst verified RMS"
    keep.choice = {**(reduced.choice or {}), "floor": rec, "chosen_by": (
        f"{(reduced.choice or {}).get('chosen_by', '')}; the heat its short super nodes lack comes from "
        f"{'the super nodes linked to them' if rc['thesis'] else 'the held node'} ({worst} "
        f"{'at least ' if rec['unchecked']['held'] else ''}{rec['worst_K']['held']:.3g} K from the held node, "
        f"{'at least ' if rec['unchecked']['linked'] else ''}"
        f"{rec['worst_K']['linked']:.3g} K along the links)")}
    if keep is alt:
        hand_over(run, net, alt, q_orbit)
    return keep
