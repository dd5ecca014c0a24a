"""The validity range a deck and ``reduced.npz`` state: over what range of each named constant, and of node
temperatures, the network was verified against the detailed model (:mod:`fem2tmm.verify`), or that it was not.

:func:`validity_lines` is the comment block of ``model.esatan`` (``#``) and ``model.sinda`` (``C``), each line at
most :data:`WIDTH` characters so that a commented line stays within the 132 columns of both tools' input;
:func:`validity_arrays` the ``verified_*`` arrays of ``reduced.npz``.
"""

from __future__ import annotations

import textwrap

import numpy as np

#: longest line of the statement (characters, without the comment mark): within 132 with "# " or "C "
WIDTH = 120


def _status(verified: dict | None) -> dict:
    return verified or {"status": "UNVERIFIED", "reason": "the run did not verify it"}


def validity_lines(verified: dict | None, choice: dict | None = None) -> list[str]:
    """The deck's validity statement from ``reduced.verified`` (:func:`fem2tmm.verify.verify_network`, or
    ``{"status": "UNVERIFIED", "reason"}``; None: unverified), and from ``reduced.choice`` (or None) which network
    the range chose where both were verified (``verified_range``, :func:`fem2tmm.verify.range_choice`).

    Returns
    -------
    list of str
        Comment text without the comment mark, each line at most :data:`WIDTH` characters.
    """
    v = _status(verified)
    if v["status"] == "UNVERIFIED":
        text = (f"VALIDITY RANGE: UNVERIFIED. This network was not checked against the detailed model away from its "
                f"design state ({v['reason']}); edited constants (loads, held temperatures, sink) give results of "
                "unknown accuracy.")
        out = textwrap.wrap(text, WIDTH)
        est = v.get("estimated")
        if est and est.get("worst") is not None:  # estimated where a choice rested on the range (fem2tmm.range_checks)
            w = est["worst"]
            out += textwrap.wrap(
                f"Its error was ESTIMATED instead (a-posteriori, without the detailed model: not a verification) at "
                f"{len(est['states'])} states (each constant at either end of its range, the others at design; then "
                "all low, all high):", WIDTH)
            out += _range_lines(est)
            out.append(f"  estimated worst state '{w['label']}': RMS {w['rms_K']:.3g} K, max {w['max_K']:.3g} K "
                       f"(design state RMS {est['design']['rms_K']:.3g} K)")
            out += _chosen_lines(choice)
        return [line[:WIDTH] for line in out]
    out = [f"VALIDITY RANGE: {v['status']} against the detailed FE model at {len(v['states'])} states",
           "(each constant at either end of its range, the others at design; then all low, all high):"]
    out += _range_lines(v)
    d, w = v["design"], v["worst"]
    out.append(f"  recovered field against the detailed model: design state RMS {d['rms_K']:.3g} K, max {d['max_K']:.3g} K")
    if w is not None:
        out.append(f"  worst verified state '{w['label']}': RMS {w['rms_K']:.3g} K, max {w['max_K']:.3g} K")
    if v.get("reference_noise"):
        out.append(f"  reference noise (design state): RMS {v['reference_noise']['rms_K']:.3g} K, "
                   f"max {v['reference_noise']['max_K']:.3g} K")
    if v["failed"]:
        out += textwrap.wrap(f"NOT verified (no solution): {', '.join(v['failed'])}", WIDTH, initial_indent="  ",
                             subsequent_indent="    ")
    if v["flagged"]:
        out += textwrap.wrap(f"WARNING: error above {v['threshold']['factor']:g} x the design state's: "
                             f"{', '.join(v['flagged'])}", WIDTH, initial_indent="  ", subsequent_indent="    ")
    out += _chosen_lines(choice)
    out.append("Outside these ranges the network is UNVERIFIED.")
    return [line[:WIDTH] for line in out]


def _range_lines(v: dict) -> list[str]:
    """Each constant's range and the node temperatures the checked decks reached."""
    out = [f"  {r['deck']:<24} {r['low']:.5g} .. {r['high']:.5g} {r['unit']} (design {r['nominal']:.5g}; "
           f"{r['source']})" for r in v["range"]]
    lo, hi = v["node_T_C"]
    return out + [f"  node temperatures seen: {lo:.5g} .. {hi:.5g} degC"]


def _chosen_lines(choice: dict | None) -> list[str]:
    """Which network the range chose (``reduced.choice.verified_range``), or nothing."""
    rc = (choice or {}).get("verified_range")
    if not (rc and rc["worst_K"]["kept"] is not None):
        return []
    wk, wt = rc["worst_K"]["kept"], rc["worst_K"]["thesis"]
    worst = "estimated worst RMS" if rc.get("by") == "estimate" else "worst RMS"
    other = (f"{wt:.3g} K" if wt is not None else
             f"estimated {rc['thesis_design_estimate_K']:.3g} K at the design state alone")
    which = (f"the thesis' network ({worst} {wt:.3g} K) rather than the radiation-aware one ({wk:.3g} K)"
             if rc["thesis"] else f"the radiation-aware network ({worst} {wk:.3g} K) rather than the thesis' "
             f"({other})")
    return textwrap.wrap(f"This network was chosen over the range: {which}.", WIDTH, initial_indent="  ",
                         subsequent_indent="    ")


def validity_arrays(verified: dict | None) -> dict[str, np.ndarray]:
    """The ``verified_*`` arrays of ``reduced.npz``.

    Returns
    -------
    dict
        ``verified_status`` str ("verified", "partly verified" or "UNVERIFIED"), ``verified_reason`` str (why
        unverified, else empty); when verified: ``verified_names`` (m,) str (``[[boundary]]`` names, ``sink``),
        ``verified_units`` (m,) str, ``verified_nominal``, ``verified_low``, ``verified_high`` (m,) in case units
        (W, W/m², °C), ``verified_states`` (s,) str, ``verified_rms_K``, ``verified_max_K`` (s,) K (NaN: no
        solution), ``verified_design_K`` (2,) RMS and max at the design state, ``verified_node_T_C`` (2,) the
        node-temperature range seen.
    """
    v = _status(verified)
    out = {"verified_status": np.array(v["status"]), "verified_reason": np.array(v.get("reason", ""))}
    if v["status"] == "UNVERIFIED":
        return out
    rng, st = v["range"], v["states"]
    nan = float("nan")
    out.update(
        verified_names=np.array([r["name"] for r in rng], dtype=str),
        verified_units=np.array([r["unit"] for r in rng], dtype=str),
        verified_nominal=np.array([r["nominal"] for r in rng], float),
        verified_low=np.array([r["low"] for r in rng], float),
        verified_high=np.array([r["high"] for r in rng], float),
        verified_states=np.array([s["label"] for s in st], dtype=str),
        verified_rms_K=np.array([nan if s["rms_K"] is None else s["rms_K"] for s in st], float),
        verified_max_K=np.array([nan if s["max_K"] is None else s["max_K"] for s in st], float),
        verified_design_K=np.array([v["design"]["rms_K"], v["design"]["max_K"]], float),
        verified_node_T_C=np.array(v["node_T_C"], float))
    return out


__all__ = ["WIDTH", "validity_arrays", "validity_lines"]
