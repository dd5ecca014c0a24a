"""``fem2tmm bench choice``: what ``[reduction] radiation_aware = "auto"`` (the default, issue 29) chooses on every
committed study, and what each reduction gives there.

Each study's case runs three ways, with the detailed reference and its own noise:

- ``default``: the case file as committed (the examples that used to set ``radiation_aware``/``ir_on`` now leave
  them at their defaults; ``case_eui.toml`` keeps its ``ir_on = "detailed"``, which auto answers with the
  radiation-aware reduction);
- ``thesis``: ``radiation_aware = false``, IR uniform per super node;
- ``radiation_aware``: ``radiation_aware = true`` with IR per FE face (``ir_on = "faces"``, or the case's own).

Per row: the choice (``reduced.choice``: method, ``chosen_by``, the largest cluster Biot number at the thesis'
field, and for ``default`` the a-posteriori estimate of each candidate with its ray noise, its cost and its share of
the reduction stages' time: fem2tmm.stages.choice), the exported network's FE-level RMS / max error (``accuracy``),
the reference noise, the whole run's wall time, and ``verified``: the validity range's states (each named constant
at either end, all low, all high; :mod:`fem2tmm.verify`), each state's RMS / max K against its own detailed
reference, and ``verified_range``: where the estimate kept the radiation-aware network, that network's and the
thesis' worst RMS over the same verified states, and whether the thesis' replaced it (``reduced.choice.verified_range``,
:func:`fem2tmm.verify.range_choice`), and ``floor``: where super nodes of the radiation-aware network were short of
heat, whether the network handed over feeds them from the held node or along K̃'s links, with both worsts
(``reduced.choice.floor``).  The claim the table shows (issue 42): on every study the default's error is
never above the thesis' by more than the reference noise, at the design state and over the verified states.  One
JSON line per (study, method).

A fourth run, ``blind``, is the default without the detailed reference (``--no-reference``): its choices rest on the
estimated range (:mod:`fem2tmm.range_checks`).  Its row gives what it handed over (method, the floor's source), the
estimated worst of each candidate, the range check's seconds, and ``same_as_default``: whether it handed over the
network the default chose with the reference.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from .envelope import timed_run

REPO = Path(__file__).resolve().parents[1]
STUDIES = ("fin/case.toml", "cylinders/case.toml", "baffle/case.toml", "baffle/case_100.toml", "baffle/case_eui.toml",
           "truss/case.toml", "smallsat/case.toml", "satellite/case.toml", "composite/case.toml")


def _case(file: str, method: str):
    from fem2tmm.case import Case

    path = REPO / "examples" / file
    raw = tomllib.loads(path.read_text())
    red, rad = raw.setdefault("reduction", {}), raw.setdefault("radiation", {})
    if method == "thesis":
        red["radiation_aware"] = False
        rad.pop("ir_on", None)
    elif method == "radiation_aware":
        red["radiation_aware"] = True
        if rad.get("enabled", True):
            rad.setdefault("ir_on", "faces")
    return Case.from_dict(raw, base_dir=path.parent)


def _verified(v: dict | None) -> dict | None:
    """The validity range's check (``reduced.verified``) in brief: each state's RMS / max K of the exported network
    against that state's detailed reference, the design state's through the same path, and the worst state."""
    if not v or not v.get("states"):
        return None
    return {"design": [v["design"]["rms_K"], v["design"]["max_K"]],
            "states": {r["label"]: [r["rms_K"], r["max_K"]] for r in v["states"]},
            "worst": None if v["worst"] is None else [v["worst"]["label"], v["worst"]["rms_K"], v["worst"]["max_K"]]}


def _range(rc: dict | None) -> dict | None:
    """The choice over the validity range (``reduced.choice.verified_range``) in brief: whether the thesis' network
    replaced the radiation-aware one, each network's worst RMS and state, the tolerance and the check's seconds."""
    if not rc:
        return None
    return {"thesis": rc["thesis"], "worst_K": rc["worst_K"], "worst_state": rc["worst_state"],
            "tolerance_K": rc["tolerance_K"], "seconds": rc.get("seconds"), "by": rc.get("by"),
            "checked": rc.get("checked", True)}


def _blind(file: str, default: dict) -> dict:
    """The default without the detailed reference: what it hands over, on the estimated range."""
    res, seconds = timed_run(_case(file, "default"), reference=False)
    red = res.summary["reduced"]
    ch, est = red["choice"] or {}, (red.get("verified") or {}).get("estimated")
    floor = (ch.get("floor") or {}).get("source")
    return {"study": file, "method": "blind", "radiation_aware": ch.get("radiation_aware"), "floor_source": floor,
            "chosen_by": ch.get("chosen_by"), "estimated": _verified(est),
            "verified_range": _range(ch.get("verified_range")),
            "floor": None if not ch.get("floor") else {k: ch["floor"][k] for k in ("source", "worst_K", "worst_state")},
            "range_seconds": None if est is None else est.get("seconds"), "seconds": round(seconds, 1),
            "same_as_default": (ch.get("radiation_aware") == default["radiation_aware"]
                                and floor == (default["floor"] or {}).get("source"))}


def bench_choice() -> list[dict]:
    rows = []
    for file in STUDIES:
        for method in ("default", "thesis", "radiation_aware", "blind"):
            if method == "blind":
                rows.append(_blind(file, next(r for r in rows if r["study"] == file and r["method"] == "default")))
                print(rows[-1], flush=True)
                continue
            res, seconds = timed_run(_case(file, method))
            s = res.summary
            acc, red = s["accuracy"], s["reduced"]
            ch = red["choice"] or {}
            rows.append({"study": file, "method": method, "super_nodes": red["super_nodes"],
                         "radiation_aware": ch.get("radiation_aware"), "ir_on": ch.get("ir_on"),
                         "chosen_by": ch.get("chosen_by"), "biot_cluster_max": ch.get("biot_cluster_max"),
                         "estimated_rms_K": ch.get("estimated_rms_K"), "estimate_noise_K": ch.get("estimate_noise_K"),
                         "estimate_seconds": ch.get("estimate_seconds"),
                         "estimate_cost_fraction": ch.get("estimate_cost_fraction"),
                         "rms_K": acc["rms_K"], "max_K": acc["max_K"],
                         "reference_noise_rms_K": acc.get("reference_noise_rms_K"), "seconds": round(seconds, 1),
                         "verified": _verified(red.get("verified")),
                         "verified_range": _range(ch.get("verified_range")),
                         "floor": None if not ch.get("floor") else {
                             k: ch["floor"][k]
                             for k in ("source", "worst_K", "worst_state", "tolerance_K", "seconds")}})
            print(rows[-1], flush=True)
    return rows
