"""The validity range of the network handed over: chosen from the case, verified, stated (issue 41, item 2).

A reduced network is exact, or nearly, at the state it was built for; an engineer edits its constants (a heater's
power, a held interface's temperature, the sink) and solves it elsewhere.  With the detailed reference on, the run
checks the network over a range of each named constant:

- **The range** (:func:`verify_range`): each named power or flux ``[[boundary]]`` from 0 to
  :data:`POWER_FACTOR` x its design value; each named temperature boundary :data:`TEMPERATURE_SWING_K` either side
  of its design value; the sink from :data:`COLDEST_SINK_K` (−270 °C) to the warmest temperature of the design
  state.  ``[reduction] verify = {name = [low, high]}`` replaces the range of the names it lists.
- **The states** (:func:`verify_states`): each constant at either end of its range, the others at design (one at a
  time), then every constant at its low end and every constant at its high end: 2m + 2 states for m constants, not
  the 2^m corners.
- **At each state** (:func:`verify_network`): the ESATAN deck as written (``model.esatan``) with that constant edited
  as a user edits it (:func:`edit_deck`: the ``$CONSTANTS`` value, or the space node's temperature), read back with
  :func:`fem2tmm.lpm.readers.read_network` and solved with :func:`fem2tmm.lpm.solve.solve_network` (the read-back path
  of :func:`fem2tmm.handover.check_deliverable`), recovered with the recovery read from ``reduced.npz``
  (:class:`~fem2tmm.reduce.exported.ExportedRecovery`, what ``fem2tmm recover`` does), against the detailed model
  solved at that state (:func:`state_problem`: the same exchange factors and solar loads, its Newton warm-started
  from the design field).

The error is the recovered field's against the detailed one over the mesh nodes (as ``summary.json accuracy``),
beside the design state's through the same path and the reference's own noise (two half references, at the design
state only).  Where ``radiation_aware = "auto"`` kept the radiation-aware network by its design-state estimate,
the thesis' network is verified too, on the same detailed solutions, and :func:`range_choice` says which one is
handed over.  A state is flagged (:func:`worse_than_design`) when its RMS exceeds both :data:`WARN_FACTOR` x the
design's RMS and :data:`WARN_RMS_K`, or its maximum both :data:`WARN_FACTOR` x the design's maximum and
:data:`WARN_MAX_K`.
"""

from __future__ import annotations

import dataclasses
import functools
import re
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .constants import KELVIN
from .errors import Fem2TmmError, InternalError
from .fem.model import load_patterns

#: named powers and fluxes: verified from 0 to this many times their design value.  4x is the issue's "beyond the
#: tables" edit (a 10 W heater at 40 W) and covers a unit's duty cycle from off to a peak of several times its mean
POWER_FACTOR = 4.0
#: named temperature boundaries: verified this far either side of the design value (K).  A unit's interface moves
#: between its cold and hot operating limits (e.g. −20 to +50 °C) plus the qualification margins of ECSS-E-ST-31C
#: (±10 K): about ±45 K about the middle; 50 K is also the sink edit of the issue (−150 -> −100 °C)
TEMPERATURE_SWING_K = 50.0
#: the coldest sink verified: deep space, −270 °C
COLDEST_SINK_K = KELVIN - 270.0
#: a verified state is flagged when its error exceeds WARN_FACTOR x the design state's (the headline figure would
#: then mislead by more than the design error's own spread over the tool's examples) and the absolute floors below,
#: which are the issue's acceptance bounds for edited decks (RMS <= 1.0 K, max <= 3.0 K)
WARN_FACTOR = 3.0
WARN_RMS_K = 1.0
WARN_MAX_K = 3.0

_KINDS = ("power", "flux", "temperature")


@dataclass(frozen=True)
class Constant:
    """A named constant of the deck and the range it is verified over.

    Attributes
    ----------
    name : str
        The ``[[boundary]]`` name, or ``"sink"``.
    kind : str
        ``"power"`` (W), ``"flux"`` (W/m²), ``"temperature"`` (K) or ``"sink"`` (K).
    nominal, low, high : float
        The design value and the range's ends, SI (W, W/m², K).
    source : str
        ``"automatic"`` (:func:`verify_range`) or ``"case file"`` (``[reduction] verify``).
    """

    name: str
    kind: str
    nominal: float
    low: float
    high: float
    source: str = "automatic"

    @property
    def celsius(self) -> bool:
        return self.kind in ("temperature", "sink")

    @property
    def unit(self) -> str:
        """The case and deck unit: ``"W"``, ``"W/m2"`` or ``"degC"``."""
        return {"power": "W", "flux": "W/m2"}.get(self.kind, "degC")

    def to_case(self, value: float) -> float:
        """``value`` (SI) in case units (°C for temperatures)."""
        return float(value) - (KELVIN if self.celsius else 0.0)


@dataclass(frozen=True)
class State:
    """One verified state: ``label`` (e.g. ``"heater high"``, ``"all low"``) and ``values`` {constant name: SI
    value} of every constant of the range (the design values where it does not move them)."""

    label: str
    values: dict


def verify_range(case, T_warmest: float, radiating: bool = True) -> tuple[Constant, ...]:
    """The range each named constant of ``case`` is verified over.

    Parameters
    ----------
    case : Case
        The run's case: its named power / flux / temperature ``[[boundary]]`` entries without a time table, its sink
        and ``[reduction] verify_range`` ((name, low, high) SI, replacing the automatic range of those names).
    T_warmest : float
        K, the warmest temperature of the design state (the detailed field's hottest node, held nodes included):
        the top of the sink's range.
    radiating : bool
        Whether the model radiates to the sink; without radiation the sink is no constant of the network.

    Returns
    -------
    tuple of Constant
        The named boundaries in case order, then the sink.  A power or flux whose design value is 0 has no
        automatic range (0 x 4 = 0): it is left at 0 unless the case file gives one.
    """
    given = {n: (lo, hi) for n, lo, hi in case.reduction.verify_range}
    out = []
    for b in case.boundaries:
        if not b.name or b.kind not in _KINDS or b.table is not None:
            continue
        if b.kind == "temperature":
            lo, hi = max(b.value - TEMPERATURE_SWING_K, 1.0), b.value + TEMPERATURE_SWING_K
        else:
            lo, hi = sorted((0.0, POWER_FACTOR * b.value))
        src = "automatic"
        if b.name in given:
            (lo, hi), src = given[b.name], "case file"
        out.append(Constant(b.name, b.kind, float(b.value), float(lo), float(hi), src))
    env = case.environment
    if env.sink_table is None and radiating:
        sink = float(env.sink_temperature)
        lo, hi = min(COLDEST_SINK_K, sink), max(float(T_warmest), sink)
        src = "automatic"
        if "sink" in given:
            (lo, hi), src = given["sink"], "case file"
        out.append(Constant("sink", "sink", sink, float(lo), float(hi), src))
    return tuple(out)


def verify_states(constants: tuple[Constant, ...]) -> list[State]:
    """The states to check: each constant at its low end, then its high end, the others at design (an end equal
    to the design value is left out), then all at their low ends and all at their high ends (left out when that is
    a state already listed, as with a single constant).

    Returns
    -------
    list of State
        Each with the value of every constant (SI).
    """
    design = {c.name: c.nominal for c in constants}
    out: list[State] = []
    seen = [design]
    for c in constants:
        for end, v in (("low", c.low), ("high", c.high)):
            if v != c.nominal:
                vals = {**design, c.name: v}
                out.append(State(f"{c.name} {end}", vals))
                seen.append(vals)
    for end in ("low", "high"):
        vals = {c.name: getattr(c, end) for c in constants}
        if vals not in seen:
            out.append(State(f"all {end}", vals))
            seen.append(vals)
    return out


def worse_than_design(rms: float, mx: float, design_rms: float, design_max: float) -> bool:
    """Whether a verified state's error (RMS ``rms``, maximum ``mx``, K) is flagged against the design state's
    (module docstring: :data:`WARN_FACTOR`, :data:`WARN_RMS_K`, :data:`WARN_MAX_K`)."""
    return bool((rms > WARN_FACTOR * design_rms and rms > WARN_RMS_K)
                or (mx > WARN_FACTOR * design_max and mx > WARN_MAX_K))


# ------------------------------------------------------------------------------------------- the deck edited
_BLOCK = re.compile(r"^\s*\$([A-Z0-9]+)", re.M | re.I)
_SUBBLOCKS = {"REAL", "INTEGER", "CHARACTER", "CONTROL"}  # within $CONSTANTS, indented or not
_SPACE_T = re.compile(r"^(\s*B\d+\s*=\s*'SPACE'\s*,\s*T\s*=\s*)([^,;]+)", re.M | re.I)


def _span(text: str, name: str) -> tuple[int, int] | None:
    """Where the deck's ``$name`` block starts and ends in ``text`` (None when it has none)."""
    blocks = _blocks(text)
    return next(((a, blocks[k + 1][0]) for k, (a, b) in enumerate(blocks[:-1]) if b == name), None)


@functools.lru_cache(maxsize=1)
def _blocks(text: str) -> list[tuple[int, str]]:
    """The deck's block headers (start, NAME) and its end, kept for the next edit of the same text (every state of
    the range edits the deck as written: the satellite's 20 edits, 46 ms of scans; :func:`verify_network` lets the
    text go when it is done)."""
    return [(m.start(), m.group(1).upper()) for m in _BLOCK.finditer(text)
            if m.group(1).upper() not in _SUBBLOCKS] + [(len(text), "")]


def _block(text: str, name: str) -> str:
    """The text of the deck's ``$name`` block (empty when it has none)."""
    span = _span(text, name)
    return "" if span is None else text[span[0]:span[1]]


def edit_deck(text: str, constants: dict[str, float], sink_C: float | None = None) -> str:
    """An ESATAN deck's text with constants edited as an engineer edits them.

    Parameters
    ----------
    text : str
        The deck (``model.esatan``).
    constants : dict
        {constant name: value in deck units (W, W/m², °C)}: the statement ``NAME = ...;`` of the ``$CONSTANTS``
        block gets that value.
    sink_C : float, optional
        °C: the sink: the constant ``SINK`` when the deck has one, else the space node's ``T``.

    Returns
    -------
    str
        The edited text.

    Raises
    ------
    InternalError
        A constant is not defined once in ``$CONSTANTS`` (the deck fem2tmm wrote names every constant it edits).
    """
    span = _span(text, "CONSTANTS")
    edits = dict(constants)
    has_sink = span is not None and re.search(r"^\s*SINK\s*=", text[span[0]:span[1]], re.M | re.I) is not None
    if sink_C is not None and has_sink:
        edits["SINK"] = sink_C
    if edits:
        if span is None:
            raise InternalError("the deck has no $CONSTANTS block to edit")
        body = text[span[0]:span[1]]
        for name, v in edits.items():
            body, k = re.subn(rf"^(\s*){re.escape(name)}(\s*=\s*)[^;]*;", rf"\g<1>{name}\g<2>{float(v)!r};", body,
                              flags=re.M | re.I)
            if k != 1:
                raise InternalError(f"the deck defines the constant {name} {k} times in $CONSTANTS, not once")
        text = text[:span[0]] + body + text[span[1]:]
    if sink_C is not None and not has_sink:
        text, k = _SPACE_T.subn(rf"\g<1>{float(sink_C)!r}", text, count=1)
        if k != 1:
            raise InternalError("the deck has no space node (B... = 'SPACE', T = ...) to edit")
    return text


# -------------------------------------------------------------------------------------- the detailed state
def state_problem(problem, model, case, values: dict, patterns: dict | None = None):
    """The detailed steady problem at another value of the named constants.

    Parameters
    ----------
    problem : SteadyProblem
        The run's detailed problem at the design state (its exchange factors, solar and orbit-average loads).
    model : FEModel
        The FE model (its named loads' patterns, :func:`fem2tmm.fem.model.boundary_load`, and held groups).
    case : Case
        The run's case (its ``[[boundary]]`` entries at their design values).
    values : dict
        {constant name: SI value} (:class:`State` ``values``); "sink" the sink temperature (K).
    patterns : dict, optional
        {named load: (n_dof,) W per unit value}, computed once for several states (:func:`load_patterns`).

    Returns
    -------
    SteadyProblem
        Loads (n_dof,) W, held temperatures (n_dof,) K and sink (K) of that state; the rest shared with ``problem``.
    """
    Q = np.array(problem.Q, float)
    T_fixed = np.array(problem.T_fixed, float)
    named = {b.name: b for b in case.boundaries if b.name}
    for name, v in values.items():
        if name == "sink":
            continue
        b = named[name]
        if v == b.value:
            continue
        if b.kind == "temperature":
            for g in model.fixed:
                if g.name == name:
                    T_fixed[g.dof] = v
        else:
            Q += (v - b.value) * (load_patterns(model, case, [name]) if patterns is None else patterns)[name]
    return dataclasses.replace(problem, Q=Q, T_fixed=T_fixed, T_sink=float(values.get("sink", problem.T_sink)))


# ---------------------------------------------------------------------------------------------- the check
def unverified(reason: str) -> dict:
    """The ``reduced.verified`` of a run that did not verify its range: ``{"status": "UNVERIFIED", "reason"}``."""
    return {"status": "UNVERIFIED", "reason": reason}


def superseded(verified: dict | None) -> dict | None:
    """``reduced.verified`` of a case whose deck got the parametric tables of its load-case set after its check
    (:func:`fem2tmm.reductors.radiation_aware.set_parametric`): the deck handed over is not the one verified, so it is
    UNVERIFIED, with the figures of the deck before the tables in the reason."""
    if verified is None or verified["status"] == "UNVERIFIED":
        return verified
    w = verified["worst"]
    before = "" if w is None else f"; before them its worst state '{w['label']}' had RMS {w['rms_K']:.3g} K"
    return unverified("the deck follows its load-case set's parametric tables, added after the check" + before
                      + "; run the case alone to verify it")


#: ``reduced.verified.reason`` of a run without a detailed reference
NO_REFERENCE = "no detailed reference was solved: [reference] detailed = false or --no-reference"


def why_unverified(result, reference: bool = True) -> dict | None:
    """``reduced.verified`` of a run whose range is not verified (:func:`unverified` with the reason), or None
    when :func:`verify_network` applies: ``[reduction] verify`` on, a detailed steady reference solved, the network
    read back (``reduced.delivered``) and a steady deck.  ``reference`` False: the same without the reference (when
    the range can be *estimated*: :func:`verify_network` with an ``estimator``)."""
    red = result.reduced
    if not result.case.reduction.verify:
        return unverified("[reduction] verify = false")
    if reference and result.detailed.solution is None:
        return unverified(NO_REFERENCE)
    if result.transient is not None:
        return unverified("a transient deck: the range is verified on steady decks")
    if red.recovery is None:
        return unverified("the network carries no recovery to verify with")
    if red.delivered is not None and red.delivered.get("error"):
        return unverified(f"the network handed over could not be read back and solved: {red.delivered['error']}")
    return None


def verify_network(result, problem, references: dict | None = None, warn: bool = True,
                   estimator=None, order=None, enough=None, shared: dict | None = None) -> dict:
    """Verify the network a run hands over over its validity range (module docstring), or estimate its error there.

    Parameters
    ----------
    result : Result
        The run (its reduced network, recovery, detailed design solution and noise, case and model).
    problem : SteadyProblem
        The detailed problem at the design state (the one ``result.detailed.solution`` solves).
    references : dict, optional
        The detailed steady solutions at the verified states, {sorted state values: SteadySolution}, filled here
        and reused by another call on the same run (another candidate network over the same range:
        :func:`range_choice`).
    warn : bool
        Warn when states are flagged or have no solution (:func:`warn_off_range`); False where the caller may hand
        over another network and warns for the one it keeps.
    estimator : callable, optional
        Without a detailed reference: ``estimator(values, T_sn, T_rec) -> {"beyond_noise_K", "max_K", "noise_K"}``,
        the a-posteriori estimate of the recovered field's error at a state ({constant name: SI value}, {} the
        design state; the deck's super-node temperatures (n,) K; the recovered field (n_dof,) K), in place of the
        detailed solve (:func:`fem2tmm.stages.choice.range_estimator`).  The record's ``status`` is then
        "estimated", each row's ``rms_K`` the estimate beyond its ray noise and ``noise_K`` that noise, and the
        sink's range tops at the recovered field's warmest temperature.
    order : sequence of str, optional
        State labels to check first, in this order (the others after them, in :func:`verify_states`' order).
    enough : callable, optional
        ``enough(rms_K) -> bool``, called with the design state's RMS and then each checked state's: True leaves
        the states not yet checked unchecked (rows with ``checked`` False, listed in ``unchecked``).  For a
        candidate that cannot win a choice any more (:func:`cannot_win`).
    shared : dict, optional
        Kept between the calls on the candidates of one run (as ``references``): the last candidate's recovery, whose
        saddles and recovered fields the next one adopts where its detailed operator is the same
        (:meth:`~fem2tmm.reduce.exported.ExportedRecovery.adopt_about`); and ``written``, what the deliverable check
        wrote and read back of a network (:func:`fem2tmm.handover.check_deliverable` ``keep``), whose deck text and
        recovery serve for that network instead of writing it again; and ``sessions``, each estimated network's
        deck, recovery, design state and rows (with an ``estimator``): a second call on the same ``result.reduced``
        goes on from the first, its states left unchecked there (``enough``) checked now, those checked kept (the
        floor's choice without the reference probes both candidates at one state before either is checked in full,
        :func:`fem2tmm.range_checks._floor_choice`).

    Returns
    -------
    dict
        ``reduced.verified`` of ``summary.json``: ``status`` ("verified", or "UNVERIFIED" with ``reason``),
        ``range`` [{name, deck, kind, unit, nominal, low, high, source}] in case units, ``states`` [{label,
        values (case units), rms_K, max_K, node_T_C [min, max] of the deck's nodes, seconds, network_s,
        detailed_s, detailed_iterations, flagged, error}], ``design`` {rms_K, max_K} through the same path,
        ``reference_noise`` {rms_K, max_K} (design state) or None, ``estimate_noise`` {rms_K} (the largest over the
        states; with an ``estimator``) or None, ``worst`` (the state of largest RMS),
        ``node_T_C`` [min, max] over the design and every verified state, ``flagged`` [labels], ``unchecked``
        [labels] (``enough``), ``seconds``.
    """
    from .export.deliverable import write_deck, write_network
    from .export.esatan import constant_name
    from .handover import _by_label
    from .linalg import blas_threads
    from .lpm.readers import read_network
    from .lpm.solve import solve_network
    from .reduce.exported import (ESTIMATED_RANGE_TOLERANCE, ESTIMATED_RECOVERY_TOLERANCE, RANGE_RECOVERY_TOLERANCE,
                                  load)
    from .solve.steady import solve_steady

    t_start = time.perf_counter()
    case, model, red = result.case, result.model, result.reduced
    det = result.detailed.solution
    T_warmest = float(np.max(red.T_recovered if estimator is not None else det.T))
    radiating = bool(np.any(np.asarray(problem.g_space) > 0) or problem.faced is not None or problem.GR is not None)
    constants = verify_range(case, T_warmest, radiating)
    deck_name = {c.name: constant_name(c.name) for c in constants if c.kind != "sink"}
    names = red.network.names
    ok = model.node_dof >= 0
    T_ref_design = None if estimator is not None else model.node_temperatures(det.T)[ok]
    noises = []  # the estimate's ray noise at each state (estimator only)

    def error(T_dof, T_ref_nodes, values=None, T_sn=None):
        if estimator is not None:
            est = estimator(values, T_sn, T_dof)
            noises.append(float(est["noise_K"]))
            return float(est["beyond_noise_K"]), float(est["max_K"])
        e = model.node_temperatures(T_dof)[ok] - T_ref_nodes
        return float(np.sqrt(np.mean(e**2))), float(np.abs(e).max(initial=0.0))

    # estimated, on one BLAS thread: each state's work is then many small dense operations (the network's Newton, the
    # recovery's Schur complement and chord steps), which a second thread only slows on a shared machine.  The
    # L-bracket at 100 super nodes beside another process's single-threaded run (load 1.5): deck solves 0.52 -> 0.07 s,
    # recoveries 1.49 -> 0.49 s (2026-12-07).  With the reference each state's detailed factorisation keeps the threads
    threads = 1 if estimator is not None else None
    # this network estimated before: go on from there (estimates only: with the reference every state is checked at
    # once, and a network's deck and recovery are not kept beyond its check)
    sessions = None if shared is None or estimator is None else shared.setdefault("sessions", [])
    session = next((s for r, s in sessions or () if r is red), None)
    with tempfile.TemporaryDirectory(prefix="fem2tmm-verify-") as tmp, blas_threads(threads):
        folder = Path(tmp)
        written = (shared or {}).get("written") or {}
        if session is not None:
            text, recovery, constants, deck_name = (session[k] for k in ("text", "recovery", "constants", "deck_name"))
            noises[:] = session["noises"]
        elif written.get("reduced") is red and written.get("recovery") is not None:  # read back by the deliverable
            text, recovery = written["text"], written["recovery"]
        elif written.get("recovery") is not None and written["reduced"].recovery is red.recovery:
            # another network of the same recovery (the floor's candidate fed along the links): its deck alone is
            # written, the recovery read back from the first's reduced.npz serves (its recovery arrays are that
            # object's: examples/smallsat 32 -> 12 ms, the satellite 112 -> 48 ms, median of 7, 2026-12-07)
            write_deck(folder, result)
            text = (folder / "model.esatan").read_text(encoding="utf-8")
            recovery = written["recovery"]
        else:
            write_network(folder, result, sinda=False)
            text = (folder / "model.esatan").read_text(encoding="utf-8")
            recovery = load(folder / "reduced.npz")
        # the last candidate's saddles and fields (none to adopt where its recovery is this one), else, on a first
        # call, the saddle of the run's own recovery of the design state
        last = (shared or {}).get("recovery")
        if last is not recovery and not recovery.adopt_about(last) and session is None:
            recovery.adopt_about(red.recovery)
        if session is None:
            # the sink: the constant SINK of a parametric deck, else the space node's temperature
            deck_name["sink"] = "SINK" if re.search(r"^\s*SINK\s*=", text, re.M | re.I) else "SPACE node T"
            # only what the deck holds as a constant (and the recovery as a named load) is a constant a user edits
            load_names = set(map(str, recovery.load_names))
            defined = set(re.findall(r"^\s*([A-Za-z_]\w*)\s*=", _block(text, "CONSTANTS"), re.M))
            constants = tuple(c for c in constants if c.kind == "sink" or (
                deck_name[c.name] in defined and (c.kind == "temperature" or c.name in load_names)))
        if shared is not None:
            shared["recovery"] = recovery
        load_names = set(map(str, recovery.load_names))
        states = verify_states(constants)
        # the named loads' patterns, for the detailed problem at each state (an estimator forms its own loads)
        patterns = (None if estimator is not None else
                    load_patterns(model, case, [c.name for c in constants if c.kind in ("power", "flux")]))

        def deck_state(values: dict | None):
            """The deck edited to ``values`` (None: as written), read back and solved: (T_sn (n,) K in the order
            of the network's names, the deck's whole solution (n + 1,) K, {named load: value}, sink K or None)."""
            edits, sink_C = {}, None
            loads, T_sink = {}, None
            for c in constants:
                v = (values or {}).get(c.name, c.nominal)
                if v == c.nominal:
                    continue
                if c.kind == "sink":
                    sink_C, T_sink = c.to_case(v), v
                else:
                    edits[deck_name[c.name]] = c.to_case(v)
                    if c.name in load_names:
                        loads[c.name] = v
            path = folder / "state.esatan"
            path.write_text(edit_deck(text, edits, sink_C) if values is not None else text, encoding="utf-8")
            net = read_network(path)
            sol = solve_network(net, T0=design_deck, tol=deck_tol)
            T_sn = _by_label(net, sol.T, names)
            if T_sn is None:
                raise InternalError("the deck read back lacks some of the network's node labels")
            return T_sn, sol.T, loads, T_sink

        # an estimate's states need neither the deck's nor the recovery's last digits (ESTIMATED_RANGE_TOLERANCE)
        deck_tol, recovery_tol = ((1e-10, RANGE_RECOVERY_TOLERANCE) if estimator is None else
                                  (ESTIMATED_RANGE_TOLERANCE, ESTIMATED_RECOVERY_TOLERANCE))
        if session is None:
            design_deck = None
            T_sn0, design_deck, _, _ = deck_state(None)
            # the design state through the same path: the chord from the run's recovered field with the saddle
            # factorised there, which every state below then shares (recover(T0=) would factorise it once more)
            T_des = recovery.recover_about(red.T_recovered, T_sn0)
            d_rms, d_max = error(T_des, T_ref_design, {}, T_sn0)
            node_lo, node_hi = float(T_sn0.min()), float(T_sn0.max())
            rows = [{"label": st.label, "values": {c.name: c.to_case(st.values[c.name]) for c in constants},
                     "rms_K": None, "max_K": None, "node_T_C": None, "flagged": False, "error": None, "seconds": 0.0,
                     "network_s": 0.0} for st in states]
        else:  # its rows copied (the first call's record stays as it was), the unchecked ones to check now
            design_deck, d_rms, d_max, node_lo, node_hi = (session[k] for k in ("design_deck", "d_rms", "d_max",
                                                                                 "node_lo", "node_hi"))
            rows = [{k: v for k, v in r.items() if k != "checked"} for r in session["rows"]]
        rank = {label: i for i, label in enumerate(order or ())}
        stopped = enough is not None and any(enough(r) for r in [d_rms] + [r["rms_K"] for r in rows
                                                                           if r["rms_K"] is not None])
        # each state's deck edited, read back and solved, its field recovered from the run's design field through
        # the saddle factorised there (the chord iteration of ExportedRecovery.recover_about; its first step the
        # linearised one): examples/composite's 7 states 1.2 -> 0.26 s of saddle factorisations (the design state's,
        # and their own for the 3 states where its chord does not contract; 2026-12-07); a saddle such a state needed
        # is kept for the next, each state starts from the nearest field recovered so far, and stops at
        # RANGE_RECOVERY_TOLERANCE: recoveries 0.86 -> 0.60 s.  In the order asked (``order``), until ``enough``
        for i in sorted(range(len(states)), key=lambda i: (rank.get(states[i].label, len(rank)), i)):
            st, row = states[i], rows[i]
            if row["rms_K"] is not None or row["error"] is not None:  # (checked by the first call)
                continue
            if stopped:
                row["checked"] = False
                continue
            t0 = time.perf_counter()
            try:
                T_sn, _, loads, T_sink = deck_state(st.values)
            except Fem2TmmError as exc:  # a state without a solution (say so in the summary and the deck)
                row["error"] = str(exc)
                row["seconds"] = row["network_s"] = time.perf_counter() - t0
                continue
            try:
                T_rec = recovery.recover_about(red.T_recovered, T_sn, loads=loads, T_sink=T_sink,
                                               tol=recovery_tol)
                t1 = time.perf_counter()
                # the detailed model at that state, its Newton from the recovered field (it converges to the
                # solver's tolerance from any start: the start only saves iterations, 7 -> 4 on examples/composite)
                key = tuple(sorted(st.values.items()))
                if estimator is not None:
                    ref = None
                elif references is not None and key in references:
                    ref = references[key]
                else:
                    p_state = state_problem(problem, model, case, st.values, patterns)
                    settings = {"tol": case.solver.tolerance, "max_iter": case.solver.max_iterations}
                    try:
                        ref = solve_steady(p_state, T0=T_rec, **settings)
                    except Fem2TmmError:
                        ref = solve_steady(p_state, T0=det.T, **settings)
                    if references is not None:
                        references[key] = ref
            except Fem2TmmError as exc:
                row["error"] = str(exc)
                row["seconds"] = row["network_s"] = time.perf_counter() - t0
                continue
            if ref is None:
                rms, mx = error(T_rec, None, st.values, T_sn)
                row["noise_K"] = noises[-1]
            else:
                rms, mx = error(T_rec, model.node_temperatures(ref.T)[ok])
            t2 = time.perf_counter()
            node_lo, node_hi = min(node_lo, float(T_sn.min())), max(node_hi, float(T_sn.max()))
            row.update(rms_K=rms, max_K=mx, node_T_C=[float(T_sn.min() - KELVIN), float(T_sn.max() - KELVIN)],
                       network_s=t1 - t0, detailed_s=t2 - t1,
                       detailed_iterations=None if ref is None else ref.iterations,
                       flagged=worse_than_design(rms, mx, d_rms, d_max))
            row["seconds"] = row["network_s"] + row["detailed_s"]
            stopped = enough is not None and enough(rms)
    done = [r for r in rows if r["rms_K"] is not None]
    worst = max(done, key=lambda r: (r["rms_K"], r["max_K"]), default=None)
    noise = result.detailed.noise
    out = {
        "status": ("estimated" if estimator is not None else
                   "verified" if len(done) == len(rows) else "partly verified"),
        "range": [{"name": c.name, "deck": deck_name[c.name], "kind": c.kind, "unit": c.unit,
                   "nominal": c.to_case(c.nominal), "low": c.to_case(c.low), "high": c.to_case(c.high),
                   "source": c.source} for c in constants],
        "states": rows,
        "design": {"rms_K": d_rms, "max_K": d_max},
        "reference_noise": (None if noise is None or estimator is not None else
                            {"rms_K": noise["rms_K"], "max_K": noise["max_K"]}),
        "estimate_noise": {"rms_K": max(noises)} if noises else None,
        "worst": worst,
        "failed": [r["label"] for r in rows if r["error"] is not None],
        "unchecked": [r["label"] for r in rows if r.get("checked") is False],
        "flagged": [r["label"] for r in rows if r["flagged"]],
        "node_T_C": [node_lo - KELVIN, node_hi - KELVIN],
        "threshold": {"factor": WARN_FACTOR, "rms_K": WARN_RMS_K, "max_K": WARN_MAX_K},
        "seconds": time.perf_counter() - t_start + (0.0 if session is None else session["seconds"]),
    }
    if sessions is not None:  # for a second call on this network
        keep = {"text": text, "recovery": recovery, "constants": constants, "deck_name": deck_name,
                "noises": list(noises), "design_deck": design_deck, "d_rms": d_rms, "d_max": d_max,
                "node_lo": node_lo, "node_hi": node_hi, "rows": rows, "seconds": out["seconds"]}
        if session is None:
            sessions.append((red, keep))
        else:
            session.update(keep)
    _blocks.cache_clear()  # (the deck's text)
    if warn:
        warn_off_range(case.source, out)
    return out


def warn_off_range(source, verified: dict) -> None:
    """Warn when a verified record (:func:`verify_network`) has states flagged against its design state or without a
    solution: the network handed over does not hold them."""
    rows = verified["states"]
    flagged = [r for r in rows if r["flagged"]]
    if not (rows and (flagged or verified["failed"])):
        return
    import warnings

    d_rms, d_max = verified["design"]["rms_K"], verified["design"]["max_K"]
    bad = ", ".join(f"{r['label']} (RMS {r['rms_K']:.3g} K, max {r['max_K']:.3g} K)" for r in flagged)
    failed = ", ".join(verified["failed"])
    warnings.warn(f"{source}: the network handed over is off the detailed model beyond its design state (RMS "
                  f"{d_rms:.3g} K, max {d_max:.3g} K there): " + "; ".join(
                      x for x in (bad and f"worse than {WARN_FACTOR:g} x that at {bad}",
                                  failed and f"no solution at {failed}") if x)
                  + ". The decks and summary.json reduced.verified give the range checked; an edited constant "
                  "beyond a state flagged here is outside what the network holds", stacklevel=3)


#: the least difference between two networks' worst verified RMS that :func:`range_choice` acts on (K), where the
#: reference has no ray noise (nothing traced) or less: below it the two differ by round-off (the robustness
#: campaign's models whose networks are both exact to 1e-10 K), as the campaign's own margin (benchmarks/robustness.py)
RANGE_FLOOR_K = 1e-3


def range_worst(verified: dict, labels=None) -> tuple[float, str]:
    """``(RMS K, label)``: the largest RMS of a verified record over the design state and its verified states with a
    solution (only those in ``labels`` when given)."""
    rows = [("design", verified["design"]["rms_K"])] + [
        (r["label"], r["rms_K"]) for r in verified["states"]
        if r["rms_K"] is not None and (labels is None or r["label"] in labels)]
    label, rms = max(rows, key=lambda x: x[1])
    return float(rms), label


#: the share of the kept network's worst verified RMS by which the network whose short super nodes are fed along
#: K̃'s links must beat the one fed from the held node to replace it (``range_choice(..., relative=)``): the worst
#: state is one number, and a near tie there can hide a larger loss elsewhere (issue 41's L-bracket at 100 super
#: nodes: 2.98 against 3.02 K at heater 40 W, beyond the 0.028 K noise, but 2.75 against 1.56 K at heater 0 W); on
#: examples/satellite the links win by 12.8 against 1.76 K (docs/design-notes.md, "Where a short node's heat comes
#: from")
FLOOR_RELATIVE_MARGIN = 0.2


def range_choice(kept: dict, thesis: dict, relative: float = 0.0) -> dict:
    """Whether the thesis' network replaces the one a run chose by its design-state estimate, measured over the
    validity range both were verified on (:func:`verify_network` of each, the same states and detailed solutions).

    The network an engineer edits must hold over the range it states; one exact at the design state and far off
    beyond it is worse for them than one a little off everywhere.  So the comparison is each network's worst RMS
    over the design state and the verified states where both have a solution: the thesis' network replaces the other
    when that worst is smaller by more than the detailed reference's own noise (its RMS at the design state; for two
    estimated records, the two estimates' ray noise added in quadrature), or
    :data:`RANGE_FLOOR_K` if that is more: the bound the default is held to against the thesis method.  A state
    where a deck has no solution is not counted against it: its solver says so where the user edits it, and the
    record and the run's warning name it, where a network far off everywhere is silently wrong.

    Parameters
    ----------
    kept, thesis : dict
        ``reduced.verified`` of the network chosen and of the thesis' network (status "verified" or "partly verified"),
        or of any other candidate verified on the same states.
    relative : float
        The other network must also be better by this share of the kept one's worst RMS (0: the noise alone).

    Returns
    -------
    dict
        ``{"thesis": bool, "worst_K": {"kept", "thesis"}, "worst_state": {"kept", "thesis"}, "tolerance_K",
        "states_K": {label: [kept RMS, thesis RMS]}, "failed": {"kept", "thesis"}}`` (``states_K`` includes "design",
        None for a state without a solution; ``failed`` the states each has no solution at).
    """
    solved = lambda v: {r["label"] for r in v["states"] if r["rms_K"] is not None}  # noqa: E731
    # (a state the other left unchecked, :func:`cannot_win`, is not one it has no solution at)
    both = solved(kept) - {r["label"] for r in thesis["states"] if r["rms_K"] is None and r.get("checked", True)}
    wk, lk = range_worst(kept, both)
    wt, lt = range_worst(thesis, both)
    noise = kept.get("reference_noise")
    if noise is None and kept.get("estimate_noise") is not None:  # estimated records: both estimates' noise
        noise = {"rms_K": float(np.hypot(kept["estimate_noise"]["rms_K"],
                                         (thesis.get("estimate_noise") or {"rms_K": 0.0})["rms_K"]))}
    tol = max(0.0 if noise is None else float(noise["rms_K"]), RANGE_FLOOR_K, relative * wk)
    by = {r["label"]: r["rms_K"] for r in thesis["states"]}
    states = {"design": [kept["design"]["rms_K"], thesis["design"]["rms_K"]]}
    states.update({r["label"]: [r["rms_K"], by.get(r["label"])] for r in kept["states"]})
    failed = {k: [r["label"] for r in v["states"] if r["rms_K"] is None and r.get("checked", True)]
              for k, v in (("kept", kept), ("thesis", thesis))}
    return {"thesis": bool(wk > wt + tol), "worst_K": {"kept": wk, "thesis": wt},
            "worst_state": {"kept": lk, "thesis": lt}, "tolerance_K": tol, "states_K": states, "failed": failed}


#: without the reference, the floor's two candidates are first estimated at this state, and the one lower there is
#: checked in full first (:func:`fem2tmm.range_checks._floor_choice`): the state farthest from the design state (the
#: first state where it is not one, a single constant's range)
PROBE_STATE = "all high"
#: :func:`must_lose` bounds the kept network's estimate noise at the states it leaves unchecked by this many times the
#: other's largest: both estimates at a state take the same tallies on fields a few K apart (the same state, the same
#: detailed operator).  Where the choice on the states checked does not hold, every state is checked (the caller)
NOISE_BOUND = 2.0


def must_lose(other: dict, relative: float = 0.0):
    """``(order, enough)`` for :func:`verify_network` of the kept network when another candidate, checked in full
    first (``other``, its record), is weighed against it by :func:`range_choice` (``relative`` as there): the kept
    network's states in the order of ``other``'s errors, largest first, and ``enough(rms_K)``, True once one of its
    states is off by more than the other's worst plus the largest margin :func:`range_choice` can apply there (the
    other's estimate noise and the kept one's, bounded by :data:`NOISE_BOUND` times the other's; :data:`RANGE_FLOOR_K`;
    ``relative`` of that state's RMS): the kept network's worst is then at least that state's, and the other
    replaces it.  The counterpart of :func:`cannot_win`, for a candidate that wins: its states all checked, the kept
    network's a few.  Estimated records only (with the reference every state of both is checked)."""
    wo, _ = range_worst(other)
    n = float((other.get("estimate_noise") or other.get("reference_noise") or {"rms_K": 0.0})["rms_K"])
    margin = max(float(np.hypot(n, NOISE_BOUND * n)), RANGE_FLOOR_K)
    rows = sorted((r for r in other["states"] if r["rms_K"] is not None), key=lambda r: -r["rms_K"])
    return [r["label"] for r in rows], lambda rms: bool(rms > wo + margin and (1.0 - relative) * rms > wo)


def cannot_win(kept: dict, relative: float = 0.0):
    """``(order, enough)`` for :func:`verify_network` of another candidate that :func:`range_choice` will weigh against
    ``kept`` (its record, fully checked): its states in the order of ``kept``'s errors, largest first, and
    ``enough(rms_K)``, True once one of its states is off by at least the kept network's worst less the least margin
    :func:`range_choice` can apply (the kept record's own noise, :data:`RANGE_FLOOR_K`, ``relative`` × that worst).
    The other's worst is then at least that state's and the kept one's worst over the states both solve at most its
    worst: the other cannot replace it, whatever its states left unchecked give, so they are not checked (the choice
    is the same; the other's worst in the record is that of the states checked).  The states where the kept network has
    no solution are not in the order, so they come last: a stop at one of them leaves only such states unchecked,
    which :func:`range_choice` does not weigh either.  Used without the detailed reference
    (:func:`fem2tmm.range_checks._against`): examples/smallsat's candidate fed along its links stops after its first
    state, 0.24 -> 0.08 s."""
    wk, _ = range_worst(kept)
    noise = kept.get("reference_noise") or kept.get("estimate_noise") or {"rms_K": 0.0}
    margin = max(float(noise["rms_K"]), RANGE_FLOOR_K, relative * wk)
    rows = sorted((r for r in kept["states"] if r["rms_K"] is not None), key=lambda r: -r["rms_K"])
    return [r["label"] for r in rows], lambda rms: bool(wk <= rms + margin)


__all__ = ["NO_REFERENCE", "PROBE_STATE", "Constant", "State", "cannot_win", "edit_deck", "must_lose", "range_choice",
           "range_worst", "state_problem", "superseded", "unverified", "verify_network", "verify_range",
           "verify_states", "warn_off_range", "why_unverified", "worse_than_design", "COLDEST_SINK_K",
           "FLOOR_RELATIVE_MARGIN", "POWER_FACTOR", "RANGE_FLOOR_K", "TEMPERATURE_SWING_K"]
