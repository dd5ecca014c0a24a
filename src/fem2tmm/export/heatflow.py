"""Heat-flow books a thermal engineer reads: every input named, every output named, and what they leave open.

:func:`heat_flow_summary` (summary.json ``heat_flows``) gives, for the reduced network and the detailed model, the steady books (W; an orbit
case's steady solve takes the orbit-averaged loads) and the transient books (J over the interval the solver's
energy books cover: the whole run, or the last period of a periodic one):

* in: each applied load by its ``[[boundary]]`` name, absorbed solar (a steady Sun), and per orbital kind the
  absorbed solar, albedo and planet IR (orbit average, or its time integral in a transient);
* out: radiated to space (for a radiation-aware network also the part its correction load carries), into each
  held (fixed-temperature) boundary by name, and in a transient the heat stored;
* the imbalance, in - out (- stored), and its size relative to the larger of the inputs and the outputs.

The sum of the named inputs is checked against the load the solver applied (the sum of the network's or the
mesh's Q): a difference larger than round-off is shown as its own row (``INPUT_NOT_NAMED``), never spread over the
named ones; in a transient, the named inputs are exact time integrals of their tables and the solver's applied
energy is its own quadrature of them, so their difference is shown as ``QUADRATURE`` (Crank-Nicolson is exact for
loads linear over each step; its first backward-Euler steps are not).

:func:`part_books` balances each part of the reduced network: the heat put into its super nodes (Q), radiated to
space, and exchanged with the other parts and with the held nodes through the network's GL and GR, from the
solved temperatures.  Part-to-part flows come from the same matrices (:func:`part_exchange`); what each part
absorbs on its FE faces from :func:`part_absorbed`.  Per time: :func:`position_inputs` (each orbit position's
absorbed power per kind) and :func:`step_powers` (a transient's mean powers over each step).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..constants import SIGMA
from ..fem.model import boundary_load

#: the row of a difference between the solver's applied load and the named inputs
INPUT_NOT_NAMED = "input not named (the solver's load minus the named inputs)"
#: the row of the transient's quadrature of the inputs against their exact time integrals
QUADRATURE = "time integration (the solver's quadrature of the inputs minus their exact integrals)"
#: labels of the orbital kinds
KIND_LABEL = {"solar": "absorbed solar", "albedo": "albedo", "ir": "planet IR"}


def _book(inputs: list, outputs: list, applied: float | None, extra_row: str, unit: str) -> dict:
    """A book {"in": [[label, value]], "out": [[label, value]], "imbalance", "relative", "unit"}; ``applied`` the
    solver's total input, against which the named inputs are checked."""
    named = sum(v for _, v in inputs)
    inputs = [list(r) for r in inputs]
    if applied is not None:
        gap = applied - named
        if abs(gap) > 1e-9 * max(abs(applied), abs(named), 1e-300):
            inputs.append([extra_row, gap])
    total_in = sum(v for _, v in inputs)
    total_out = sum(v for _, v in outputs)
    imbalance = total_in - total_out
    scale = max(sum(abs(v) for _, v in inputs), sum(abs(v) for _, v in outputs), 1e-300)
    return {"unit": unit, "in": inputs, "out": [list(r) for r in outputs], "in_total": total_in,
            "out_total": total_out, "imbalance": imbalance, "relative": abs(imbalance) / scale}


def _orbit_fluxes(result, model: str):
    """The orbital fluxes a model took: the reduced network those of ``fluxes_on``, the detailed model the FE faces'."""
    o = result.orbit
    if o is None:
        return None
    if model == "reduced" and o.fluxes_on == "super_faces" and o.super_faces is not None:
        return o.super_faces
    return o.detailed if o.detailed is not None else o.super_faces


def _named_loads(result) -> list[tuple[str, float]]:
    return [(f"applied '{name}'", float(w)) for name, w in result.model.loads.items()]


def _steady_inputs(result, model: str) -> tuple[list, str]:
    """The named steady inputs (W) of ``model`` ("reduced" | "detailed") and what they are (steady or orbit average)."""
    rows = _named_loads(result)
    basis = "steady"
    sol = result.reduced.solar if model == "reduced" and result.reduced is not None else None
    sol = sol if sol is not None else result.detailed.solar
    if sol is not None:
        rows.append(("absorbed solar", float(sol.absorbed)))
    fl = _orbit_fluxes(result, model)
    if fl is not None:  # an orbit's steady solve takes the orbit-averaged loads (steady = "positions" too)
        from ..radiation.orbital import period_average

        basis = "orbit average"
        pos = fl.positions
        for kind in fl.kinds:
            mean = float(period_average(pos.time, fl.absorbed[kind].sum(axis=1), pos.period))
            rows.append((f"{KIND_LABEL.get(kind, kind)} (orbit average)", mean))
    return rows, basis


def by_correction(rm) -> float | None:
    """Heat (W) a radiation-aware network ``rm`` radiates outside its couplings to space: its known loads minus the
    sum of its nodes' Q and its loads' hot-spot nodes' (the correction load and the distribution with
    K' = K + diag(h) take it out); None for other networks, and for a network whose hot-spot nodes leave nothing."""
    known = getattr(rm.radiative, "known_load_W", None) if rm.radiative is not None else None
    if known is None:
        return None
    # (a fixed node's Q moves nothing, but its reaction, the book into that boundary, counts it: an input of the
    # network's books)
    left = float(known - np.sum(np.asarray(rm.Q)) - rm.hot_spot_W)
    # the network's hot-spot nodes apply and radiate what its distribution leaves: nothing left but round-off
    return None if rm.hot_spots is not None and abs(left) <= 1e-9 * max(abs(known), 1e-300) else left


def network_radiated_W(rm, sol) -> float:
    """W the network ``rm`` radiates in all at its solution ``sol``: through its couplings to space, its loads'
    hot-spot nodes and (a radiation-aware network with a correction load) outside its couplings."""
    return float(np.sum(sol.to_space)) + rm.hot_spot_W + (by_correction(rm) or 0.0)


def correction_label(rm) -> str:
    """The book row of :func:`by_correction`: a network with a correction load radiates that share through it; one
    whose couplings to space follow its temperatures (``g_space_table``, no correction load) loses it in the
    distribution of its loads (Y'q: the share a load's hot spot radiates inside its own super node)."""
    if getattr(rm, "g_space_table", None) is not None:
        return "radiated inside the loaded super nodes (load distribution Y'q)"
    return "radiated through the radiation-aware correction load"


def _by_correction(result) -> float | None:
    return by_correction(result.reduced.network)


def steady_books(result) -> dict:
    """{"reduced": book, "detailed": book} (W) of the steady solutions that ran (see the module's notes)."""
    out = {}
    det = result.detailed.solution
    if det is not None:
        rows, basis = _steady_inputs(result, "detailed")
        outs = [("radiated to space", float(det.to_space.sum()))]
        outs += [(f"into fixed boundary '{g.name}'", -float(det.heat_fixed[g.dof].sum())) for g in result.model.fixed]
        out["detailed"] = dict(_book(rows, outs, float(det.balance["applied_W"]), INPUT_NOT_NAMED, "W"), basis=basis)
    red = result.reduced
    if red is not None:
        rm, rs = red.network, red.solution
        rows, basis = _steady_inputs(result, "reduced")
        outs = [("radiated to space", float(rs.to_space.sum()) + rm.hot_spot_W)]
        applied = float(rs.balance["applied_W"])
        by_correction = _by_correction(result)
        if by_correction is not None:  # the radiation-aware network radiates part of its heat outside its couplings
            outs.append((correction_label(rm), by_correction))
            applied += by_correction
        outs += [(f"into fixed boundary '{rm.names[i]}'", -float(rs.heat_fixed[i])) for i in np.flatnonzero(rm.fixed)]
        out["reduced"] = dict(_book(rows, outs, applied, INPUT_NOT_NAMED, "W"), basis=basis)
    return out


def hot_spot_energy(rm, tabled: dict, duration: float) -> float:
    """J the loads' hot-spot nodes of ``rm`` (:class:`fem2tmm.reduce.radiative.HotSpots`) apply and radiate over
    ``duration`` s: each its share of its load's energy, ``tabled`` {name: (W per unit value, J of the load)} for the
    loads that follow a time table, its design power times the duration for the others."""
    hs = rm.hot_spots
    if hs is None:
        return 0.0
    out = 0.0
    for name, unit, Q in zip(hs.load, hs.unit, hs.Q):
        if str(name) in tabled and tabled[str(name)][0]:
            per_unit, energy = tabled[str(name)]
            out += float(unit) / per_unit * energy
        else:
            out += float(Q) * duration
    return out


def _integral(f, a: float, b: float, breaks: np.ndarray) -> float:
    """∫_a^b f dt of a piecewise-linear f with its breakpoints ``breaks``: exact trapezoid over them."""
    t = np.unique(np.concatenate([[a, b], breaks[(breaks > a) & (breaks < b)]]))
    return float(np.trapezoid(np.asarray(f(t), float), t))


def transient_books(result) -> dict:
    """{"reduced": book, "detailed": book} (J) over the interval of each model's energy books, with ``start_s`` and
    ``end_s`` of that interval and the heat stored as an output."""
    run = result.transient
    if run is None:
        return {}
    case = result.case
    start = run.settings.start
    period = run.settings.end - run.settings.start
    out = {}
    for model, sol in (("reduced", run.reduced), ("detailed", run.detailed)):
        if sol is None or not len(sol.steps.get("t", ())):
            continue
        a = float(sol.steps["t"][0] - sol.steps["h"][0])
        b = float(sol.steps["t"][-1])
        rows, per_unit_of = [], {}
        tabled = {bd.name: bd for bd in case.boundaries if bd.kind != "temperature" and bd.table is not None}
        for name, w in result.model.loads.items():  # every named load (deck loads too): constant, or its table
            bd = tabled.get(name)
            if bd is None:
                rows.append((f"applied '{name}'", float(w) * (b - a)))
                continue
            per_unit = float(boundary_load(result.model, case, dataclasses.replace(bd, value=1.0)).sum())
            tab = bd.table.periodic(start, period) if run.settings.periodic else bd.table
            rows.append((f"applied '{name}'", per_unit * _integral(tab, a, b, np.asarray(tab.breakpoints(a, b), float))))
            per_unit_of[name] = (per_unit, rows[-1][1])
        sol_sun = result.reduced.solar if model == "reduced" and result.reduced is not None else None
        sol_sun = sol_sun if sol_sun is not None else result.detailed.solar
        if sol_sun is not None:
            rows.append(("absorbed solar", float(sol_sun.absorbed) * (b - a)))
        fl = _orbit_fluxes(result, model)
        if fl is not None:
            from ..radiation.orbital import period_integral

            pos = fl.positions
            for kind in fl.kinds:  # orbit time 0 at the transient's start, piecewise linear between positions
                energy = period_integral(pos.time, fl.absorbed[kind].sum(axis=1), pos.period, a - start, b - start)
                rows.append((f"{KIND_LABEL.get(kind, kind)}", energy))
        e = sol.energy
        applied = float(e["applied_J"])
        hot = hot_spot_energy(result.reduced.network, per_unit_of, b - a) if model == "reduced" else 0.0
        applied += hot  # the loads' hot-spot nodes: applied and radiated as their loads (no capacitance)
        outs = [("radiated to space", float(e["to_space_J"]) + hot)]
        by_correction = _by_correction(result) if model == "reduced" else None
        if by_correction is not None:  # the correction load, constant in time, carries part of the radiation
            outs.append((correction_label(result.reduced.network), by_correction * (b - a)))
            applied += by_correction * (b - a)
        outs += [("into fixed boundaries", float(e["into_fixed_J"]))]
        outs += [("stored (heat capacity)", float(e["stored_J"]))]
        out[model] = dict(_book(rows, outs, applied, QUADRATURE, "J"), start_s=a, end_s=b)
    return out


def position_inputs(result, model: str = "reduced") -> tuple[list[str], np.ndarray]:
    """The absorbed power (W) of each orbital kind at each orbit position (the fluxes ``model`` took): columns
    ``true_anomaly_deg``, ``time_s``, one per kind, ``total``; (columns, (positions, columns) array)."""
    fl = _orbit_fluxes(result, model)
    if fl is None:
        return [], np.zeros((0, 0))
    cols = ["true_anomaly_deg", "time_s"] + [f"{KIND_LABEL.get(k, k)}_W" for k in fl.kinds] + ["total_W"]
    per = [fl.absorbed[k].sum(axis=1) for k in fl.kinds]
    data = np.column_stack([fl.true_anomaly, fl.time, *per, np.sum(per, axis=0)])
    return cols, data


def step_powers(result, model: str = "reduced") -> tuple[list[str], np.ndarray]:
    """Mean powers (W) over each step of a transient's energy books: columns ``t_end_s``, each orbital kind absorbed
    (the exact integral of its table over the step, over the step), every input together (the solver's), radiated to
    space, into fixed boundaries, stored, imbalance.  Returns (column names, (steps, columns) array)."""
    run = result.transient
    sol = None if run is None else getattr(run, model)
    if sol is None or not len(sol.steps.get("t", ())):
        return [], np.zeros((0, 0))
    st = sol.steps
    t1, h = np.asarray(st["t"], float), np.asarray(st["h"], float)
    cols, data = ["t_end_s"], [t1]
    fl = _orbit_fluxes(result, model)
    if fl is not None:
        from ..radiation.orbital import period_integral

        pos = fl.positions
        start = run.settings.start
        for kind in fl.kinds:
            p = fl.absorbed[kind].sum(axis=1)
            e = [period_integral(pos.time, p, pos.period, b - hh - start, b - start) for b, hh in zip(t1, h)]
            cols.append(f"{KIND_LABEL.get(kind, kind)}_W")
            data.append(np.array(e) / h)
    for k, name in (("applied", "all inputs_W"), ("to_space", "radiated to space_W"), ("into_fixed", "into fixed_W"),
                    ("stored", "stored_W"), ("imbalance", "imbalance_W")):
        cols.append(name)
        data.append(np.asarray(st[k], float) / h)
    return cols, np.stack(data, axis=1)


def part_exchange(result) -> tuple[list[str], np.ndarray]:
    """Heat (W) from part to part through the reduced network's GL and GR at its solved temperatures.

    Returns ``names`` (p + 2,): the parts, then "held nodes" and "space"; ``F`` (p + 2, p + 2) W, F[a, b] the net
    heat flowing from a to b (antisymmetric; flows inside a part are not counted).  The radiation-aware network's
    correction load is an input, not an exchange.
    """
    rm, rs = result.reduced.network, result.reduced.solution
    parts = [p.name for p in result.model.parts]
    n_p = len(parts)
    grp = np.where(rm.fixed, n_p, np.where(rm.part >= 0, rm.part, n_p))  # held and part-less nodes: "held nodes"
    T = rs.T
    K = np.asarray(rm.K)
    flow = -K * (T[:, None] - T[None, :])  # i -> j through GL_ij = -K_ij
    if rm.GR is not None:
        flow = flow + SIGMA * np.asarray(rm.GR) * (T[:, None] ** 4 - T[None, :] ** 4)
    np.fill_diagonal(flow, 0.0)
    G = np.zeros((len(T), n_p + 2))
    G[np.arange(len(T)), grp] = 1.0
    F = G.T @ flow @ G
    F[:, n_p + 1] = G.T @ (SIGMA * rm.g_space * (T**4 - rm.T_sink**4))
    hs = rm.hot_spots
    if hs is not None:  # the loads' hot-spot nodes radiate their share to space from their part
        F[:, n_p + 1] += np.bincount(np.where(hs.part >= 0, hs.part, n_p), weights=hs.Q, minlength=n_p + 2)
    F[n_p + 1, :] = -F[:, n_p + 1]
    np.fill_diagonal(F, 0.0)
    return parts + ["held nodes", "space"], F


def part_books(result) -> list[dict]:
    """Per part of the reduced network (steady): ``part``, ``in_W`` (the load Q put into its super nodes),
    ``to_space_W``, ``to_held_W``, ``to_other_parts_W`` (net, through GL and GR) and ``imbalance_W``."""
    if result.reduced is None:
        return []
    rm = result.reduced.network
    names, F = part_exchange(result)
    n_p = len(names) - 2
    Q = np.bincount(np.where(rm.part >= 0, rm.part, n_p)[~rm.fixed], weights=rm.Q[~rm.fixed], minlength=n_p + 1)
    if rm.hot_spots is not None:  # the share of the loads their hot-spot nodes take (applied as applied)
        hs = rm.hot_spots
        Q = Q + np.bincount(np.where(hs.part >= 0, hs.part, n_p), weights=hs.Q, minlength=n_p + 1)
    rows = []
    for p in range(n_p):
        others = float(F[p, :n_p].sum())
        row = {"part": names[p], "in_W": float(Q[p]), "to_space_W": float(F[p, n_p + 1]),
               "to_held_W": float(F[p, n_p]), "to_other_parts_W": others}
        row["imbalance_W"] = row["in_W"] - row["to_space_W"] - row["to_held_W"] - others
        rows.append(row)
    return rows


def part_absorbed(result) -> dict | None:
    """Absorbed power (W) per part on the detailed model's FE faces (each face belongs to one part): a steady Sun's,
    and each orbital kind's orbit average.  ``{"parts": [...], "columns": [...], "W": (parts, columns)}`` or None
    when nothing was traced on the FE faces."""
    f = result.model.faces
    n_p = len(result.model.parts)
    cols, data = [], []
    sun = result.detailed.solar
    if sun is not None and getattr(sun, "absorbed_face", None) is not None and len(sun.absorbed_face) == f.n:
        cols.append("absorbed solar")
        data.append(np.bincount(f.part, weights=sun.absorbed_face, minlength=n_p))
    fl = None if result.orbit is None else result.orbit.detailed
    if fl is not None and all(fl.absorbed[k].shape[1] == f.n for k in fl.kinds):
        from ..radiation.orbital import period_average

        pos = fl.positions
        for kind in fl.kinds:
            mean = period_average(pos.time, fl.absorbed[kind], pos.period)  # (n_faces,)
            cols.append(f"{KIND_LABEL.get(kind, kind)} (orbit average)")
            data.append(np.bincount(f.part, weights=mean, minlength=n_p))
    if not cols:
        return None
    return {"parts": [p.name for p in result.model.parts], "columns": cols,
            "W": np.stack(data, axis=1).tolist()}


def heat_flow_summary(result) -> dict:
    """The ``heat_flows`` entry of summary.json: steady and transient books, and the per-part balance."""
    out = {"steady": steady_books(result), "transient": transient_books(result), "parts": part_books(result),
           "part_absorbed": part_absorbed(result), "part_to_part": None}
    if result.reduced is not None:
        names, F = part_exchange(result)
        rm = result.reduced.network
        out["part_to_part"] = {"names": names, "W": F.tolist(), "held": [str(n) for n in rm.names[rm.fixed]],
                               "note": "net heat from the row's part to the column's through the reduced network's GL "
                                       "and GR at its steady temperatures (antisymmetric); 'held nodes' are the fixed-"
                                       "temperature boundary nodes (named in 'held'), 'space' the sink"}
    return out


__all__ = ["INPUT_NOT_NAMED", "QUADRATURE", "by_correction", "heat_flow_summary", "part_books", "part_exchange", "steady_books",
           "transient_books"]


def flow_text(v: float, unit: str) -> str:
    """A flow or an energy for a table: thousands separated from 10 000 on (J over an orbit), 6 significant digits
    below, e.g. ``1,382,299 J``, ``233.245 W``."""
    v = float(v) + 0.0  # no "-0"
    return f"{v:,.0f} {unit}" if abs(v) >= 1e4 else f"{v:.6g} {unit}"


def _side_by_side(books: dict) -> tuple[list[str], list[tuple[str, str, dict]]]:
    """The models of ``books`` (reduced first) and the union of their rows in order: (section, label, {model: value})."""
    models = [m for m in ("reduced", "detailed") if m in books]
    rows: list[tuple[str, str, dict]] = []
    for section in ("in", "out"):
        seen: dict[str, dict] = {}
        for m in models:
            for label, v in books[m][section]:
                seen.setdefault(label, {})[m] = v
        rows += [(section, label, vals) for label, vals in seen.items()]
    return models, rows


def book_rows(books: dict, fmt) -> tuple[list[str], list[tuple]]:
    """Table rows of steady or transient ``books``: header models and rows (what, value per model, ...) with
    the totals and the imbalance; ``fmt(value)`` formats a number."""
    models, rows = _side_by_side(books)
    out = []
    for section, label, vals in rows:
        out.append((("in: " if section == "in" else "out: ") + label, *(fmt(vals[m]) if m in vals else "—"
                                                                          for m in models)))
    out.append(("total in", *(fmt(books[m]["in_total"]) for m in models)))
    out.append(("total out", *(fmt(books[m]["out_total"]) for m in models)))
    out.append(("imbalance (in − out)", *(f"{fmt(books[m]['imbalance'])} ({books[m]['relative']:.1e} relative)"
                                          for m in models)))
    return models, out


def heat_flow_rows(s: dict, key: str = "steady") -> list[tuple[str, str]]:
    """(label, text) rows of summary.json's ``heat_flows[key]`` ("steady" | "transient") for the terminal: per
    model, every named input and output as one sum each, and the imbalance."""
    books = (s.get("heat_flows") or {}).get(key) or {}
    unit = "W" if key == "steady" else "J"
    out = []
    for m in ("reduced", "detailed"):
        b = books.get(m)
        if not b:
            continue
        when = b.get("basis", "steady") if key == "steady" else f"{b['start_s']:g} to {b['end_s']:g} s"
        word = "heat" if key == "steady" else "energy"

        def terms(rows):
            return " + ".join(f"{flow_text(v, unit)} {label}" for label, v in rows) or "none"

        out.append((f"{word} in ({m}, {when})", f"{terms(b['in'])} = {flow_text(b['in_total'], unit)}"))
        out.append((f"{word} out ({m})", f"{terms(b['out'])} = {flow_text(b['out_total'], unit)}; imbalance "
                    f"{b['imbalance']:.3g} {unit} ({b['relative']:.1e} relative)"))
    return out


__all__ += ["part_absorbed", "book_rows", "flow_text", "heat_flow_rows", "position_inputs", "step_powers"]
