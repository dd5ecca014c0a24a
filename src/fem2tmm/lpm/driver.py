"""``fem2tmm network reduce``: read a deck, reduce it (automatic grouping or TMRT), check it per load case, write
the reduced decks, ``summary.json`` and ``report.html``.

Output folder (checked before any computation, :func:`fem2tmm.export.output.check_output_place`): new, empty, or
one fem2tmm wrote (its ``.fem2tmm`` marker) — nothing fem2tmm did not write is ever overwritten; everything is
written into a temporary sibling folder that replaces it at the end.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._version import __version__
from ..constants import KELVIN
from ..errors import Fem2TmmError
from . import grouping as G
from .network import LoadCase, Network
from .readers import read_coordinates, read_network
from .settings import NetworkSettings
from .solve import solve_network
from .tmrt import conductive_exchange, recomputed_average, tmrt_reduce


@dataclass
class NetworkReduction:
    """Everything ``network reduce`` computed.  ``labels`` (n_d,) reduced node of every detailed node (-1:
    suppressed); ``checks`` / ``reduced_solutions`` / ``detailed_solutions`` one per load case."""

    detailed: Network
    reduced: Network
    labels: np.ndarray
    cases: list
    detailed_solutions: list
    reduced_solutions: list
    checks: list
    ratio: float
    method: str
    settings: NetworkSettings
    pf: float | None = None
    dtmax: float | None = None
    sweep: G.Sweep | None = None
    suppressed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    timings: dict = field(default_factory=dict)
    tmrt: object = None  # the TmrtReduction (method "tmrt")

    def recovered(self, k: int = 0) -> np.ndarray:
        """Detailed temperatures (n_d,) K recovered from the reduced solution of load case ``k``: a grouped node
        takes its group's temperature; a TMRT-suppressed node its recovery ``TRt T_red + K_SS⁻¹ Q_S``."""
        T_red = self.reduced_solutions[k].T
        if self.tmrt is not None:
            return self.tmrt.recover(T_red, self.cases[k].Q[self.tmrt.suppressed])
        return T_red[self.labels]

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def groups(self) -> list[list[int]]:
        """Detailed node numbers of every reduced node (in reduced order; suppressed nodes in none)."""
        keep = self.labels >= 0
        g = G.Grouping(labels=self.labels[keep], reduced=self.reduced, checks=self.checks,
                       solutions=self.reduced_solutions, ratio=self.ratio)
        return g.groups(self.detailed.numbers[keep])


def load_cases(net: Network, specs) -> list[LoadCase]:
    """Load cases of ``net`` from :class:`~fem2tmm.lpm.settings.LoadCaseSpec` (overrides of QI W and boundary °C);
    none: the deck's own case."""
    if not specs:
        return [net.default_case()]
    out = []
    for spec in specs:
        Q = net.QI.astype(float).copy()
        T = net.T.astype(float).copy()
        if spec.power:
            Q[net.index(list(spec.power), where=f"load case {spec.name!r} power")] = list(spec.power.values())
        if spec.boundary:
            idx = net.index(list(spec.boundary), where=f"load case {spec.name!r} boundary")
            notb = ~net.boundary[idx]
            if notb.any():
                raise Fem2TmmError(f"load case {spec.name!r}: {net.describe(idx[notb])} are not boundary nodes")
            T[idx] = np.asarray(list(spec.boundary.values()), float) + KELVIN
        out.append(LoadCase(name=spec.name, Q=Q, T_boundary=T))
    return out


def reduce_network(deck: str | Path, settings: NetworkSettings | None = None, pf: float | None = None,
                   dtmax: float | None = None, coordinates: str | Path | None = None) -> NetworkReduction:
    """Read ``deck`` and reduce it as ``settings`` says (``pf`` / ``dtmax`` override the case's thresholds)."""
    t0 = time.perf_counter()
    settings = settings or NetworkSettings()
    for name, v in (("--pf", pf), ("--dtmax", dtmax)):
        if v is not None and not (np.isfinite(v) and v >= 0):
            raise Fem2TmmError(f"{name} {v}: expected a number >= 0")
    net = read_network(deck)
    if coordinates is not None:
        nums, xyz = read_coordinates(coordinates)
        net = net.with_coordinates(nums, xyz, where=str(coordinates))
    net = net.active()
    cases = load_cases(net, settings.load_cases)
    _validate(net, settings)
    if settings.method != "tmrt":
        _check_positions(net, deck, coordinates)
    timings = {"read": time.perf_counter() - t0}
    t1 = time.perf_counter()
    detailed = [solve_network(net, c) for c in cases]
    timings["detailed_solve"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    if settings.method == "tmrt":
        res = _tmrt(net, cases, detailed, settings)
    else:
        res = _auto(net, cases, detailed, settings, settings.pf if pf is None else pf,
                    settings.dtmax if dtmax is None else dtmax)
    timings["reduce"] = time.perf_counter() - t1
    res.timings = timings
    if settings.method != "tmrt" and res.reduced.n >= net.n:
        unknown = ~G.known_positions(net.coordinates, net.n) & ~net.boundary
        if unknown.any():
            raise Fem2TmmError(f"{net.source}: nothing was reduced and {int(unknown.sum())} of the "
                               f"{int((~net.boundary).sum())} non-boundary nodes have no position (never condensed): "
                               f"{net.describe(np.flatnonzero(unknown)[:10])}; {_POSITIONS_HOW}")
    return res


#: where a network's node positions come from (Fernandez Rico 4.2.1: a coupling is sized by the nodes' distance)
_POSITIONS_HOW = ("positions come from FX/FY/FZ of the ESATAN nodes, 'positions' of a reduced.npz or --coordinates "
                  "nodes.csv (columns node,x,y,z in m; a fem2tmm run writes one beside its decks)")


def _check_positions(net: Network, deck, coordinates) -> None:
    """Refuse, before the reduction, a network none of whose non-boundary nodes has a position: no coupling
    can be sized, so nothing would be condensed (Fernandez Rico 4.2.1)."""
    known = G.known_positions(net.coordinates, net.n)
    if known[~net.boundary].any():
        return
    beside = Path(deck).with_name("nodes.csv")
    if coordinates is not None:
        how = f"the nodes of {coordinates} are none of its non-boundary nodes: check its node numbers"
    elif beside.is_file():
        how = f"give --coordinates {beside} (the positions written beside the deck)"
    else:
        how = _POSITIONS_HOW
    raise Fem2TmmError(f"{net.source}: no node has a position, so no coupling can be sized and nothing would be "
                       f"reduced; {how}")


def _validate(net: Network, settings: NetworkSettings) -> None:
    """Every node number the case names exists (before any long computation)."""
    where = settings.source
    if settings.suppress:
        net.index(settings.suppress, where=f"{where}: [tmrt] suppress")
    for k, g in enumerate(settings.groups):
        net.index(g, where=f"{where}: [tmrt] groups[{k}]")
    for name, nodes in settings.ra:
        net.index(nodes, where=f"{where}: [[post.ra]] {name}")
    for name, a, b in settings.ce:
        net.index(list(a) + list(b), where=f"{where}: [[post.ce]] {name}")
        if set(a) & set(b):
            raise Fem2TmmError(f"{where}: [[post.ce]] {name}: from and to share nodes {sorted(set(a) & set(b))}")


def _auto(net, cases, detailed, settings, pf, dtmax) -> NetworkReduction:
    grouper = G.prepare(net, cases, crit=settings.criteria, mu=settings.mu,
                        internal_boundary=settings.internal_boundary, detailed=detailed)
    sw = G.sweep(grouper, settings.pf_values, settings.dtmax_values)
    if pf is None or dtmax is None:
        sub = G.sweep(grouper, settings.pf_values if pf is None else [pf],
                      settings.dtmax_values if dtmax is None else [dtmax])
        if sub.best is not None:
            i, j = sub.best
        else:  # nothing passes: the most accurate pair (smallest worst δ), reported as failing
            i, j = np.unravel_index(np.argmin(sub.max_delta), sub.max_delta.shape)
        pf, dtmax = float(sub.pf[i]), float(sub.dtmax[j])
    g = G.group(grouper, pf, dtmax)
    return NetworkReduction(detailed=net, reduced=g.reduced, labels=g.labels, cases=cases,
                            detailed_solutions=detailed, reduced_solutions=g.solutions, checks=g.checks,
                            ratio=g.ratio, method="auto", settings=settings, pf=pf, dtmax=dtmax, sweep=sw)


def _tmrt(net, cases, detailed, settings) -> NetworkReduction:
    red = tmrt_reduce(net, suppress=settings.suppress, groups=settings.groups, capacitance=settings.capacitance,
                      filter_threshold=settings.filter)
    P = G.restriction(red.labels, red.reduced.n)
    checks, sols = [], []
    s = red.suppressed
    for case, det in zip(cases, detailed):
        Q = np.asarray(P.T @ case.Q).ravel() + (red.PD @ case.Q[s] if len(s) else 0.0)
        rcase = LoadCase(case.name, Q, G.weighted_mean(case.T_boundary, net.C, red.labels, red.reduced.n))
        chk, sol = G.check_case(net, red.labels, red.reduced, case, det, settings.criteria, rcase=rcase)
        checks.append(chk)
        sols.append(sol)
    n_b = int(net.boundary.sum())
    return NetworkReduction(detailed=net, reduced=red.reduced, labels=red.labels, cases=cases,
                            detailed_solutions=detailed, reduced_solutions=sols, checks=checks,
                            ratio=G.reduction_ratio(net.n, red.reduced.n, n_b), method="tmrt", settings=settings,
                            suppressed=net.numbers[s], tmrt=red)


# ------------------------------------------------------------------------------------------------------ outputs
def _temps(numbers, T) -> dict:
    return {str(int(k)): round(float(t) - KELVIN, 6) for k, t in zip(numbers, T)}


def _flows(numbers, Hc, Hr) -> dict:
    return {str(int(k)): {"conductive": float(c), "radiative": float(r), "total": float(c + r)}
            for k, c, r in zip(numbers, Hc, Hr)}


def build_summary(res: NetworkReduction, deck: str) -> dict:
    """The ``summary.json`` dict (first load case at the top level, every case under ``cases``)."""
    net, red = res.detailed, res.reduced
    bd = np.flatnonzero(net.boundary)
    crit = res.settings.criteria
    cases = {}
    for case, det, sol, chk in zip(res.cases, res.detailed_solutions, res.reduced_solutions, res.checks):
        cases[case.name] = {
            "detailed": {"temperatures_C": _temps(net.numbers, det.T),
                         "heat_flows_W": _flows(net.numbers[bd], det.H_conductive[bd], det.H_radiative[bd])},
            "reduced": {"temperatures_C": _temps(red.numbers, sol.T),
                        "target_temperatures_C": _temps(red.numbers, chk.T_target),
                        "heat_flows_W": _flows(red.numbers[chk.boundary], chk.Hc_reduced, chk.Hr_reduced)},
            "criteria": chk.summary(),
        }
    for k, (case, det) in enumerate(zip(res.cases, res.detailed_solutions)):
        rec = res.recovered(k) if (res.settings.ra or res.settings.ce) else None
        post = {"RA_C": {}, "CE_W": {}}
        for name, nodes in res.settings.ra:
            post["RA_C"][name] = {"detailed": recomputed_average(net, det.T, nodes) - KELVIN,
                                  "recovered": recomputed_average(net, rec, nodes) - KELVIN}
        for name, a, b in res.settings.ce:
            post["CE_W"][name] = {"detailed": conductive_exchange(net, det.T, a, b),
                                  "recovered": conductive_exchange(net, rec, a, b)}
        if rec is not None:
            cases[case.name]["post_processing"] = post
    first = cases[res.cases[0].name]
    s = {
        "version": __version__,
        "deck": str(deck),
        "method": res.method,
        "nodes": {"detailed": int(net.n), "boundary": int(net.boundary.sum()), "reduced": int(red.n),
                  "suppressed": int(len(res.suppressed))},
        "ratio": float(res.ratio),
        "thresholds": {"pf": res.pf, "dtmax_K": res.dtmax, "mu_m2_per_s": res.settings.mu},
        "groups": res.groups(),
        "suppressed": [int(v) for v in res.suppressed],
        "detailed": first["detailed"],
        "reduced": first["reduced"] | {"conductive_links": int(red.GL.nnz // 2),
                                       "radiative_links": int(red.GR.nnz // 2)},
        "post_processing": first.get("post_processing"),
        "criteria": {"delta_max_K": crit.delta_max, "q_max_W": crit.q_max, "q_lim_W": crit.q_lim,
                     "q_rel_max": crit.q_rel_max, "met": bool(res.passed),
                     "cases": {k: v["criteria"] for k, v in cases.items()}},
        "cases": cases,
        "notes": list(net.notes),
        "timings_s": {k: round(v, 4) for k, v in res.timings.items()},
    }
    if res.sweep is not None:
        sw = res.sweep
        s["sweep"] = {"pf": sw.pf.tolist(), "dtmax_K": sw.dtmax.tolist(), "ratio": sw.ratio.tolist(),
                      "passed": sw.passed.tolist(), "max_delta_K": sw.max_delta.tolist(),
                      "best": None if sw.best is None else {"pf": float(sw.pf[sw.best[0]]),
                                                             "dtmax_K": float(sw.dtmax[sw.best[1]]),
                                                             "ratio": float(sw.ratio[sw.best])}}
    return s


def to_deck(net: Network, T: np.ndarray):
    """An :class:`~fem2tmm.export.esatan.Deck` of ``net`` with temperatures ``T`` (n,) K: a boundary node labelled
    SPACE becomes the deck's space node; without one, an uncoupled SPACE node is numbered after the largest."""
    from ..export.esatan import Deck

    space = np.flatnonzero(net.boundary & (np.char.upper(net.labels.astype(str)) == "SPACE"))
    keep = np.ones(net.n, bool)
    GRd = net.GR.toarray()
    if len(space):
        sp_i = int(space[0])
        keep[sp_i] = False
        number, T_space, gr_space = int(net.numbers[sp_i]), float(T[sp_i]), GRd[sp_i][keep]
    else:
        number, T_space, gr_space = int(net.numbers.max(initial=0)) + 1, 3.0, np.zeros(net.n)
    k = np.flatnonzero(keep)
    return Deck(numbers=net.numbers[k], labels=net.labels[k], boundary=net.boundary[k], T=np.asarray(T)[k],
                C=net.C[k], A=net.A[k], alp=net.alp[k], eps=net.eps[k], GL=net.GL[k][:, k].toarray(),
                GR=GRd[np.ix_(k, k)], GR_space=gr_space, Q=net.QI[k], space=number, T_space=T_space)


def write_outputs(res: NetworkReduction, deck: str | Path, out: str | Path) -> Path:
    """``model.esatan``, ``model.sinda``, ``summary.json``, ``report.html`` (+ PNGs) into ``out``, atomically and
    never over anything fem2tmm did not write (:func:`fem2tmm.export.output.write_folder`)."""
    from ..export.esatan import write_esatan
    from ..export.output import write_folder
    from ..export.sinda import write_sinda
    from .report import write_report

    def fill(tmp: Path) -> None:
        d = to_deck(res.reduced, res.reduced_solutions[0].T)
        write_esatan(tmp / "model.esatan", d, title=f"{Path(deck).stem}_reduced")
        write_sinda(tmp / "model.sinda", d, submodel=Path(deck).stem)
        summary = build_summary(res, str(deck))
        write_report(tmp, res, summary)
        if res.tmrt is not None:  # TMRT's power distribution and temperature recovery factors
            t = res.tmrt
            np.savez(tmp / "tmrt_factors.npz", suppressed=t.detailed.numbers[t.suppressed],
                     reduced=t.reduced.numbers, PD=t.PD, TRt=t.TRt)
        (tmp / "summary.json").write_text(json.dumps(summary, indent=1), encoding="utf-8")

    return write_folder(out, fill)


def network_reduce(deck, case=None, pf=None, dtmax=None, coordinates=None, out=None) -> NetworkReduction:
    """The ``fem2tmm network reduce`` command: validate, reduce, write; returns the :class:`NetworkReduction`."""
    from ..export.output import check_output_place

    if out is None:
        raise Fem2TmmError("network reduce: --out DIR is required")
    check_output_place(out)
    settings = NetworkSettings.from_toml(case) if case else NetworkSettings()
    res = reduce_network(deck, settings, pf=pf, dtmax=dtmax, coordinates=coordinates)
    write_outputs(res, deck, out)
    return res


__all__ = ["NetworkReduction", "build_summary", "load_cases", "network_reduce", "reduce_network",
           "to_deck", "write_outputs"]
