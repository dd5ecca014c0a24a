"""``fem2tmm bench offdesign``: the single-case deck edited as a user would (issue 41).

The thin composite L-bracket of issue 41 (:func:`fem2tmm.mesh.shapes.bracket`: two 1.2 m x 1.2 m panels at a right
angle, 60 x 60 quads each, k 5 W/(m K), 1.5 mm, ε 0.85 both sides; a 0.2 m x 0.2 m heater patch centred 0.6 m
along the joint and 1.0 m up the wall, 10 W; the floor's free edge held at 20 °C; deep space), default settings,
one case, no ``[[cases]]``, no parametric tables.  Its ``model.esatan`` is edited as a user would (HEATER 0, 5 and
40 W; the sink −100 °C), read back, solved outside the run, recovered with the recovery of its ``reduced.npz`` (what
``fem2tmm recover`` does) and compared with each state's own detailed reference (a fresh run of that state).
Beside it: the thesis network at the same count, edited and recovered likewise, and the heat books from the deck's
own conductors and loads (applied, into the held edge, to space) against the detailed model's.

One JSON line per (super nodes, method, state): ``rms_K``, ``max_K``, ``books`` (deck / detailed, W).
"""

from __future__ import annotations

import re
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

#: the user's edits of the design deck: (state name, HEATER W, sink °C); the first is the design state itself
STATES = [("design 10 W", 10.0, -270.0), ("heater 0 W", 0.0, -270.0), ("heater 5 W", 5.0, -270.0),
          ("heater 40 W", 40.0, -270.0), ("sink -100 C", 10.0, -100.0)]
N_SN = (100, 300)
CURVE = (30, 100, 300, 1000)
#: the super-node counts of ``fem2tmm bench offdesign_books``
BOOKS = (30, 100, 300)


def bracket_raw(n_sn: int, heater: float = 10.0, sink_C: float = -270.0, n: int = 60, thesis: bool = False,
                detailed: bool = True, verify: bool = True, allocation: str | None = None) -> dict:
    """The bracket's case table (default settings; ``thesis`` switches to the thesis' reduction, ``allocation`` sets
    ``[clustering] allocation``, None: its default)."""
    raw = {"materials": {"composite": {"conductivity": 5.0, "density": 1600.0, "specific_heat": 900.0}},
           "optics": {"paint": {"emissivity": 0.85, "absorptivity": 0.2}},
           "parts": [{"name": "bracket", "groups": ["floor", "wall", "heater"], "material": "composite",
                      "thickness": 1.5e-3, "front": "paint", "back": "paint", "super_nodes": n_sn}],
           "boundary": [{"name": "edge", "kind": "temperature", "groups": ["edge"], "value": 20.0},
                        {"name": "heater", "kind": "power", "groups": ["heater"], "value": heater}],
           "environment": {"sink_temperature": sink_C}, "reference": {"detailed": detailed}}
    if thesis:
        raw["reduction"] = {"radiation_aware": False}
    if not verify:  # a run kept for its detailed reference only: no validity range to check
        raw.setdefault("reduction", {})["verify"] = False
    if allocation is not None:
        raw["clustering"] = {"allocation": allocation}
    return raw


def bracket_case(n_sn: int, heater: float = 10.0, sink_C: float = -270.0, n: int = 60, thesis: bool = False,
                 detailed: bool = True, verify: bool = True, allocation: str | None = None):
    from fem2tmm.case import Case

    return Case.from_dict(bracket_raw(n_sn, heater, sink_C, n, thesis, detailed, verify, allocation),
                          base_dir=Path.cwd())


def run_bracket(n_sn: int, heater: float = 10.0, sink_C: float = -270.0, n: int = 60, thesis: bool = False,
                detailed: bool = True, out=None, verify: bool = True, allocation: str | None = None):
    """``(result, wall seconds)`` of the bracket run (warnings silenced); ``verify`` False: no validity-range check
    (a run kept for its detailed reference)."""
    from fem2tmm.mesh import shapes
    from fem2tmm.pipeline import run

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run(bracket_case(n_sn, heater, sink_C, n, thesis, detailed, verify, allocation),
                  mesh=shapes.bracket(n=n), out=out)
    return res, time.perf_counter() - t0


def edit_deck(text: str, heater: float, sink_C: float) -> str:
    """The deck text with HEATER and the sink (the SINK constant, else the space node's T) edited."""
    text, k = re.subn(r"(?m)^(\s*HEATER\s*=\s*)[^;]+;", rf"\g<1>{heater!r};", text)
    assert k == 1, "HEATER"
    text, k = re.subn(r"(?m)^(\s*SINK\s*=\s*)[^;]+;", rf"\g<1>{sink_C!r};", text)
    if k == 0:
        text, k = re.subn(r"(?m)^(\s*B\d+\s*=\s*'SPACE',\s*T\s*=\s*)[^;,]+", rf"\g<1>{sink_C!r}", text)
        assert k == 1, "space node"
    return text


def deck_state(folder: Path, heater: float, sink_C: float, T0=None):
    """The design deck of ``folder`` edited to (heater W, sink °C), read back, solved (fem2tmm.lpm: reads only the
    deck) and recovered with the folder's reduced.npz.  Returns ``(T_dof K, network, T_net K, recovery)``."""
    from fem2tmm.lpm import read_esatan
    from fem2tmm.lpm.solve import solve_network
    from fem2tmm.reduce.exported import load

    path = folder / "edited.esatan"
    path.write_text(edit_deck((folder / "model.esatan").read_text(), heater, sink_C))
    net = read_esatan(path)
    T = solve_network(net, T0=None).T
    rec = load(folder / "reduced.npz")
    labels = [str(x).upper() for x in net.labels]
    T_sn = np.array([T[labels.index(str(x).upper())] for x in rec.names])
    field = rec.recover(T_sn, loads={"heater": heater}, T_sink=sink_C + 273.15, T0=T0)
    return field, net, T, rec


def deck_books(net, T: np.ndarray) -> dict:
    """Heat books of a solved deck from its own terms (W): applied (Σ QI of the diffusion nodes), from the held
    nodes into the structure through GL, to space through GR to the space node (the boundary node labelled SPACE)."""
    from fem2tmm.constants import SIGMA

    space = np.flatnonzero(np.char.upper(np.asarray(net.labels).astype(str)) == "SPACE")
    held = np.asarray(net.boundary, bool).copy()
    held[space] = False
    free = ~np.asarray(net.boundary, bool)
    GL = net.GL.tocsr()
    GLh = GL[np.flatnonzero(held)][:, np.flatnonzero(free)]
    from_held = float((GLh.multiply(T[held][:, None] - T[free][None, :])).sum())
    GRs = np.asarray(net.GR.tocsr()[:, space].todense()).ravel() if len(space) else np.zeros(net.n)
    T_space = float(T[space[0]]) if len(space) else 0.0
    for i, j, k, x, y in getattr(net, "gr_tables", ()):  # couplings following a node's own temperature
        if len(space) and j == space[0]:
            GRs[i] = float(np.interp(T[k], x, y))
    to_space = float(SIGMA * np.sum(GRs * (T**4 - T_space**4)))
    # the held nodes' own GR to space (the emission of the fin next to them that the conductors do not carry)
    held_gr = float(SIGMA * np.sum(GRs[held] * (T[held] ** 4 - T_space**4)))
    to_space += 0.0
    return {"applied": float(np.sum(np.asarray(net.QI, float)[free])), "from_held": from_held + held_gr,
            "to_space": to_space, "from_held_through_GL": from_held}


def detailed_books(res) -> dict:
    b = res.detailed.solution.balance
    return {"applied": b["applied_W"], "from_held": b["fixed_W"], "to_space": b["space_W"]}


def _err(model, T, T_ref):
    ok = model.node_dof >= 0
    e = (model.node_temperatures(T) - model.node_temperatures(T_ref))[ok]
    return float(np.sqrt(np.mean(e**2))), float(np.abs(e).max())


def references(states=STATES, n: int = 60, cache: Path | None = None) -> dict:
    """``{(heater, sink): (model, T_detailed (n_dof,) K, detailed books)}``: each state's detailed reference (a run at
    30 super nodes with the detailed reference on; the reference does not depend on the super nodes).  ``cache``: a
    folder to keep them in between calls (the mesh and the settings must be the same)."""
    out = {}
    for _, heater, sink in states:
        key = (heater, sink)
        if key in out:
            continue
        f = None if cache is None else Path(cache) / f"ref_n{n}_{heater}_{sink}.npz"
        if f is not None and f.exists():
            z = np.load(f)
            model = run_bracket(30, heater, sink, n=n, detailed=False)[0].model if "model" not in out else out["model"]
            out["model"] = model
            out[key] = (model, z["T"], {k: float(z[k]) for k in ("applied", "from_held", "to_space")})
            continue
        res = run_bracket(30, heater, sink, n=n, verify=False)[0]
        out["model"] = res.model
        books = detailed_books(res)
        out[key] = (res.model, res.detailed.solution.T, books)
        if f is not None:
            f.parent.mkdir(parents=True, exist_ok=True)
            np.savez(f, T=res.detailed.solution.T, **books)
    return out


def offdesign_rows(counts=N_SN, n: int = 60, states=STATES, thesis: bool = True, tag: str = "offdesign",
                   cache: Path | None = None, allocation: str | None = None) -> list[dict]:
    """The study (module docstring) at each super-node count of ``counts`` on the bracket of ``n`` x ``n`` quads
    (``allocation``: the networks' ``[clustering] allocation``; the references do not depend on it)."""
    from fem2tmm.errors import Fem2TmmError

    t0 = time.perf_counter()
    refs = references(states, n, cache)
    ref_s = time.perf_counter() - t0
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for N in counts:
            methods = [("default", False)] + ([("thesis", True)] if thesis else [])
            for method, th in methods:
                folder = tmp / f"{method}{N}"
                design, wall = run_bracket(N, n=n, thesis=th, out=folder, detailed=False, allocation=allocation)
                for name, heater, sink in states:
                    model, T_ref, rb = refs[(heater, sink)]
                    try:
                        field, net, T, _ = deck_state(folder, heater, sink, T0=None)
                    except Fem2TmmError as exc:  # the edited deck has no steady solution: say so
                        rows.append({"bench": tag, "super_nodes": N, "method": method, "state": name,
                                     "error": str(exc)[:200]})
                        print(rows[-1], flush=True)
                        continue
                    rms, mx = _err(model, field, T_ref)
                    db = deck_books(net, T)
                    rows.append({"bench": tag, "super_nodes": N, "method": method, "state": name,
                                 "rms_K": round(rms, 3), "max_K": round(mx, 3),
                                 "books_deck_W": {k: round(v, 3) for k, v in db.items()},
                                 "books_detailed_W": {k: round(v, 3) for k, v in rb.items()},
                                 "books_max_rel": round(max(abs(db[k] - rb[k]) / max(abs(rb[k]), 1e-9)
                                                            for k in rb if abs(rb[k]) > 1e-6), 4),
                                 # deck / detailed - 1 of each category (applied 0 W: the difference, W)
                                 "books_rel": {k: round((db[k] - rb[k]) / rb[k], 5) if abs(rb[k]) > 1e-6
                                               else round(db[k] - rb[k], 6) for k in rb},
                                 "design_run_s": round(wall, 1), "references_s": round(ref_s, 1)})
                    print(rows[-1], flush=True)
    return rows


def bench_offdesign() -> list[dict]:
    """``fem2tmm bench offdesign``: the bracket at 100 and 300 super nodes, the default network and the thesis'."""
    return offdesign_rows(cache=_cache())


def _cache():
    import os

    c = os.environ.get("FEM2TMM_BENCH_CACHE")
    return Path(c) if c else None


def bench_offdesign_curve() -> list[dict]:
    """``fem2tmm bench offdesign_curve``: the default network from 30 to 1000 super nodes, every edited state."""
    return offdesign_rows(CURVE, thesis=False, tag="offdesign_curve", cache=_cache())


def allocation_rows(allocation: str) -> list[dict]:
    """The edited decks (:func:`offdesign_rows`) and the stepped transient
    (:func:`benchmarks.offdesign_transient.transient_rows`) at 100 and 300 super nodes, the default network with
    ``[clustering] allocation = allocation`` (rows tagged ``offdesign_<allocation>``)."""
    from .offdesign_transient import transient_rows

    return (offdesign_rows(thesis=False, tag=f"offdesign_{allocation}", cache=_cache(), allocation=allocation)
            + transient_rows(thesis=False, allocation=allocation))


def bench_offdesign_loads() -> list[dict]:
    """``fem2tmm bench offdesign_loads``: :func:`allocation_rows` with ``"loads"`` (the default since 2026-12-07:
    ``fem2tmm bench offdesign`` and ``offdesign_transient`` give the same)."""
    return allocation_rows("loads")


def bench_offdesign_area() -> list[dict]:
    """``fem2tmm bench offdesign_area``: :func:`allocation_rows` with ``"area"`` (equal areas, the default until
    2026-12-07): what the default's allocation changed."""
    return allocation_rows("area")


def bench_offdesign_books() -> list[dict]:
    """``fem2tmm bench offdesign_books``: the default network's heat books from its deck's own conductors and loads
    (applied, from the held edge, to space) against the detailed model's, at 30, 100 and 300 super nodes, every
    edited state (issue 41: within 1 % at the design state, 2 % at the edited states); with the temperatures."""
    return offdesign_rows(BOOKS, thesis=False, tag="offdesign_books", cache=_cache())
