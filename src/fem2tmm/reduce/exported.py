"""The recovery that travels with the network: from super-node temperatures computed anywhere (fem2tmm, ESATAN,
SINDA, a test) back to every FE node, with nothing but what ``reduced.npz`` carries.

Why one constrained solve covers both reductions
------------------------------------------------
The super-node temperatures are means, ``T_SN = A T`` (DESIGN §3.2).  The thesis' recovery ``T = X q + Yᵀ T_SN``
is the solution of the saddle problem

    K T + Aᵀ μ = q,    A T = T_SN                                                    (linear mode)

(K the detailed conduction with the joints, q the known detailed loads; the loads that depend on T, radiation, are
taken as spread like A, which the constraint absorbs: X Aᵀ = 0).  The radiation-aware reduction
(:mod:`fem2tmm.reduce.radiative`) recovers with the emission linearised about a reference field; at its fixed
point that is the solution of the *nonlinear* problem

    K T + σ e ⊙ (T⁴ − T_s⁴) − q_abs(T) + Aᵀ μ = q,    A T = T_SN                      (emission mode)

with e the lumped emitting εA of every DOF and q_abs the IR the FE faces absorb from the others (with
``[radiation] ir_on = "faces"``: every active FE side emitting at its own temperature through its REFs; ``"detailed"``:
every super face at its super node's temperature), the rest of the absorbed radiation being spread like A.  This
form needs no reference state, so temperatures of any load state (a hot case, an orbit position) recover with it;
given the exact means ``A T*`` it returns the detailed field T* itself up to the REFs' ray noise (examples/composite,
100 super nodes: 0.12-0.19 K RMS against the reference over five load states, the reference's own noise 0.12-0.14 K).

Loads: the design loads ``q`` split into the named power/flux boundaries (``[[boundary]]`` with a ``name``; a unit
pattern each, so another value scales it) and the rest; the sink temperature enters the emission mode.  Orbital
loads traced on the FE faces (``[orbit] fluxes_on = "detailed"``) are carried per position with their periodic
piecewise-linear time functions: the design loads hold their orbit average, and a column given with its time gets
that time's orbital loads instead (``recover(..., times=...)``, the same interpolation as fem2tmm's own transient).

Cost: one sparse LU of the saddle matrix per Newton step (with the absorbed IR lagged: a fixed point over Newton
solves, 5-10 rounds); linear in the nonzeros of K and A, never a dense n_dof matrix.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..arrays import kept
from ..case.types import TRANSIENT_METHODS
from ..constants import SIGMA
from ..errors import Fem2TmmError
from ..linalg import ROUNDOFF_ULPS, roundoff, saddle_factor

#: Newton stops once the largest temperature step is below this (K), the IR fixed point likewise
RECOVERY_TOLERANCE = 1e-10
RECOVERY_MAX_NEWTON = 50
RECOVERY_MAX_ROUNDS = 60
#: the chord iteration (one factorisation per state) gives up after this many steps, or when a step is not below
#: CHORD_RATE times the one before; the Newton iteration then takes over from the start
CHORD_MAX = 100
CHORD_RATE = 0.7
#: the chord iteration is accelerated (Anderson mixing) over this many earlier steps; where an accelerated step does
#: not contract, the history is dropped and a plain step taken, at most CHORD_RESETS times
CHORD_DEPTH = 5
CHORD_RESETS = 2
#: the patient chord of ExportedRecovery.recover_about (a saddle factorised at another state): at most this many
#: steps, and none beyond PATIENT_GROWTH times the smallest so far.  examples/composite's heater at 4x and its sink
#: at the warmest temperature, from the design state's saddle: the plain chord diverges (steps of 229, 240, 257 ... K),
#: Anderson's converges in 11 and 13 steps (2026-12-07)
PATIENT_STEPS = 30
PATIENT_GROWTH = 10.0
#: :meth:`ExportedRecovery.recover_about` keeps at most this many saddle factorisations (the reference field's and
#: the last states' that needed their own) and this many recovered fields to start from.  examples/composite's 7 range
#: states: 4 factorisations -> 3, recoveries 0.86 -> 0.75 s (the fields the chord starts from nearer); a saddle of
#: detailed size each, so few
ABOUT_ANCHORS = 2
ABOUT_FIELDS = 16
#: a reference field within this of the kept one (K, anywhere) keeps its saddles and fields (:meth:`ExportedRecovery.
#: adopt_about`: another candidate network over the same range, exact at the same design state)
ABOUT_SAME_REF = 1e-6
#: the saddle the run's own recovery of the design state factorised (at its chord's start, the reductor's field) stands
#: for the one :meth:`ExportedRecovery.recover_about` would factorise at the recovered design field where their means
#: are within this (K): the chord from it is the same iteration on a preconditioner that far off
ABOUT_SEED_K = 1.0
#: the validity range's recoveries stop at this last step (K), not at RECOVERY_TOLERANCE: its figures are printed to
#: three digits against a reference noise of 1e-2 K or more and a campaign floor of 1e-3 K (verify.RANGE_FLOOR_K), and
#: the 4 decades below it cost 4-8 chord steps a state (examples/composite's 7 states 0.75 -> 0.59 s, 2026-12-07)
RANGE_RECOVERY_TOLERANCE = 1e-6
#: and where the range's error is estimated (no detailed reference), the edited decks' solves and recoveries stop at
#: this one (K): the estimate's own solves stop at a relative 1e-3 (stages.choice.ESTIMATE_TOL) and its figures are
#: compared with margins of their ray noise (>= 1e-2 K) and 20 % of their size
ESTIMATED_RANGE_TOLERANCE = 1e-3
#: and their recoveries at this one (K).  The chord's last step overstates what is left (Anderson-accelerated, it
#: contracts fast at its end): between a last step of 1e-6 K and of 1e-2 K the states' estimates move by at most
#: 8e-6 K on examples/composite, 1e-5 K on examples/satellite and 3e-7 K on examples/fin, and the composite's range
#: takes 55 chord steps instead of 66 at 1e-3 K (0.99 -> 0.81 s of its range, 2026-12-08)
ESTIMATED_RECOVERY_TOLERANCE = 1e-2

_PREFIX = "recovery_"


def _tables(g: dict) -> dict:
    """The ``load_tables`` and ``sink_table`` fields from stored arrays (none in files written before 2026-12-06)."""
    if "table_names" not in g:
        return {}
    ends = np.cumsum(g["table_lengths"])
    starts = ends - g["table_lengths"]
    tables = tuple((str(n), g["table_t"][a:b], g["table_v"][a:b]) for n, a, b in zip(g["table_names"], starts, ends))
    sink = (g["sink_table_t"], g["sink_table_v"]) if len(g["sink_table_t"]) else None
    return {"load_tables": tables, "sink_table": sink}


def _csr_arrays(name: str, M: sp.spmatrix) -> dict:
    M = sp.csr_matrix(M)
    return {f"{name}_data": M.data, f"{name}_indices": M.indices.astype(np.int64),
            f"{name}_indptr": M.indptr.astype(np.int64), f"{name}_shape": np.asarray(M.shape, np.int64)}


def _csr_from(z, name: str) -> sp.csr_matrix:
    return sp.csr_matrix((z[f"{name}_data"], z[f"{name}_indices"], z[f"{name}_indptr"]),
                         shape=tuple(int(v) for v in z[f"{name}_shape"]))


@dataclass(frozen=True)
class ExportedRecovery:
    """Everything the recovery needs, as plain arrays (stored in ``reduced.npz`` under ``recovery_*`` keys).

    Attributes
    ----------
    K : (n_dof, n_dof) csr, W/K: detailed conduction, joints included
    A : (n_sn, n_dof) csr: super-node weights (rows sum to 1; one-node super nodes: one 1)
    names : (n_sn,) str: super-node names, as in the decks and ``reduced.npz`` ``names``
    q0 : (n_dof,) W: the design loads that are not named
    load_names : (n_l,) str: the named power/flux boundaries
    load_q : (n_l, n_dof) csr, W per unit value (W for a power, W/m² for a flux)
    load_values : (n_l,) the design values (W or W/m²)
    node_dof : (n_nodes,) int: DOF of every mesh node, -1 outside the model
    node_ids : (n_nodes,) int: original node (GRID) ids
    midside : (k, 3) int: mid-side nodes of quadratic elements and their edge ends (mean of the ends)
    mode : "linear" (thesis) or "emission" (radiation-aware)
    e : (n_dof,) m²: lumped emitting εA (emission mode), else empty
    T_sink : K, the design sink temperature
    ir_A : (g, 2f) csr or None: fraction of emitter i's emission absorbed by FE side k (emission mode with IR)
    ir_owner : (g,) int: super node of each emitter (super-face emitters) ; ir_face : (g,) int or empty: the FE face of
        each emitter (per-FE-side emitters, ``ir_on = "faces"``), empty for super-face emitters
    ir_eps_area : (g,) m²: emitting εA of each emitter
    face_W : (f, n_dof) csr: face averaging weights (face temperature⁴ = W T⁴), with ``ir_A``
    orbit_q : (k, n_dof) csr W or None: the absorbed orbital loads at each of the k orbit positions (loads traced on
        the FE faces); the design loads ``q0`` hold their orbit average ``orbit_weights @ orbit_q``
    orbit_nodes : (m,) s: times of the periodic piecewise-linear time functions (absolute: the orbit's time 0 at
        ``orbit_start``, one period long); orbit_H : (m, k): position j's time function sampled at the nodes
    orbit_weights : (k,): orbit-average weights; orbit_period : s; orbit_start : s (the [transient] start)
    C : (n_dof, n_dof) csr J/K or None: the detailed capacitance (lumped: diagonal), for
        :meth:`recover_transient`; None where the model has no density and specific heat
    load_tables : ((name, t (m,) s, value (m,)), ...): the named loads that follow a time table (W or W/m², linear
        between rows, held beyond), as the deck's; sink_table : (t (m,) s, T (m,) K) or None: the sink's
    """

    K: sp.csr_matrix
    A: sp.csr_matrix
    names: np.ndarray
    q0: np.ndarray
    load_names: np.ndarray
    load_q: sp.csr_matrix
    load_values: np.ndarray
    node_dof: np.ndarray
    node_ids: np.ndarray
    midside: np.ndarray
    mode: str = "linear"
    e: np.ndarray = field(default_factory=lambda: np.zeros(0))
    T_sink: float = 3.0
    ir_A: sp.csr_matrix | None = None
    ir_owner: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    ir_face: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    ir_eps_area: np.ndarray = field(default_factory=lambda: np.zeros(0))
    face_W: sp.csr_matrix | None = None
    orbit_q: sp.csr_matrix | None = None
    orbit_nodes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    orbit_H: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    orbit_weights: np.ndarray = field(default_factory=lambda: np.zeros(0))
    orbit_period: float = 0.0
    orbit_start: float = 0.0
    C: sp.csr_matrix | None = None
    load_tables: tuple = ()
    sink_table: tuple | None = None
    # the factorised saddle [[K, Aᵀ], [A, 0]] of the linear recovery, kept for the next call (the same matrix at every
    # state: verifying a thesis' deck at 2m + 2 states factorised it once per state, 5.5 s of 5.8 s on
    # examples/composite); not a field of the file, nor of a copy (dataclasses.replace builds a new one; :meth:`linear`
    # shares it)
    _linear: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def linear(self) -> "ExportedRecovery":
        """This recovery in linear mode (the emission left out), sharing its factorised saddle: :meth:`recover` solves
        the same ``[[K, Aᵀ], [A, 0]]`` in both modes (the emission mode's start)."""
        if self.mode == "linear":
            return self
        out = replace(self, mode="linear")
        object.__setattr__(out, "_linear", self._linear)
        return out

    def __getstate__(self) -> dict:  # (a factorisation does not pickle: a Dask worker's result travels without it)
        return {k: v for k, v in self.__dict__.items() if k != "_linear"}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state, _linear={})

    @property
    def n_dof(self) -> int:
        return self.K.shape[0]

    @property
    def n_sn(self) -> int:
        return self.A.shape[0]

    # ------------------------------------------------------------------------------------------ storage
    def arrays(self) -> dict[str, np.ndarray]:
        """The ``recovery_*`` arrays of ``reduced.npz`` (see the class docstring for each)."""
        out = {"mode": np.array(self.mode), "names": np.asarray(self.names).astype(str), "q0": self.q0,
               "load_names": np.asarray(self.load_names).astype(str), "load_values": self.load_values,
               "node_dof": self.node_dof, "node_ids": self.node_ids, "midside": self.midside, "e": self.e,
               "T_sink": np.float64(self.T_sink), "ir_owner": self.ir_owner, "ir_face": self.ir_face,
               "ir_eps_area": self.ir_eps_area, "has_ir": np.array(self.ir_A is not None)}
        out.update(_csr_arrays("K", self.K))
        out.update(_csr_arrays("A", self.A))
        out.update(_csr_arrays("load_q", self.load_q))
        if self.ir_A is not None:
            out.update(_csr_arrays("ir_A", self.ir_A))
            out.update(_csr_arrays("face_W", self.face_W))
        out["table_names"] = np.array([n for n, _, _ in self.load_tables], dtype=str)
        out["table_lengths"] = np.array([len(t) for _, t, _ in self.load_tables], np.int64)
        out["table_t"] = np.concatenate([np.asarray(t, float) for _, t, _ in self.load_tables] or [np.zeros(0)])
        out["table_v"] = np.concatenate([np.asarray(v, float) for _, _, v in self.load_tables] or [np.zeros(0)])
        st, sv = self.sink_table if self.sink_table is not None else (np.zeros(0), np.zeros(0))
        out["sink_table_t"], out["sink_table_v"] = np.asarray(st, float), np.asarray(sv, float)
        out["has_C"] = np.array(self.C is not None)
        if self.C is not None:
            out.update(_csr_arrays("C", self.C))
        out["has_orbit"] = np.array(self.orbit_q is not None)
        if self.orbit_q is not None:
            out.update(_csr_arrays("orbit_q", self.orbit_q))
            out.update(orbit_nodes=self.orbit_nodes, orbit_H=self.orbit_H, orbit_weights=self.orbit_weights,
                       orbit_period=np.float64(self.orbit_period), orbit_start=np.float64(self.orbit_start))
        return {_PREFIX + k: v for k, v in out.items()}

    @classmethod
    def from_npz(cls, z, where: str = "reduced.npz") -> "ExportedRecovery":
        """Read it back from an opened ``reduced.npz`` (a mapping of arrays); ``where`` names the file in errors."""
        if _PREFIX + "mode" not in z:
            raise Fem2TmmError(f"{where}: holds no recovery (recovery_* arrays); it was written by an older fem2tmm: "
                               "run the case again to get a reduced.npz that carries its recovery")
        g = {k[len(_PREFIX):]: z[k] for k in z if k.startswith(_PREFIX)}
        has_ir = bool(g["has_ir"])
        orbit = {}
        if bool(g.get("has_orbit", False)):  # (files written before 2026-12-04 carry no orbital loads)
            orbit = dict(orbit_q=_csr_from(g, "orbit_q"), orbit_nodes=g["orbit_nodes"], orbit_H=g["orbit_H"],
                         orbit_weights=g["orbit_weights"], orbit_period=float(g["orbit_period"]),
                         orbit_start=float(g["orbit_start"]))
        return cls(K=_csr_from(g, "K"), A=_csr_from(g, "A"), names=g["names"].astype(str), q0=g["q0"],
                   load_names=g["load_names"].astype(str), load_q=_csr_from(g, "load_q"),
                   load_values=g["load_values"], node_dof=g["node_dof"], node_ids=g["node_ids"],
                   midside=g["midside"], mode=str(g["mode"]), e=g["e"], T_sink=float(g["T_sink"]),
                   ir_A=_csr_from(g, "ir_A") if has_ir else None, ir_owner=g["ir_owner"], ir_face=g["ir_face"],
                   ir_eps_area=g["ir_eps_area"], face_W=_csr_from(g, "face_W") if has_ir else None,
                   C=_csr_from(g, "C") if bool(g.get("has_C", False)) else None, **orbit, **_tables(g))

    # ----------------------------------------------------------------------------------------- recovery
    def loads(self, values: dict[str, float] | None = None) -> np.ndarray:
        """(n_dof,) W: the design loads with the named loads at ``values`` {name: W or W/m²} (others at design)."""
        v = np.array(self.load_values, float)
        for name, val in (values or {}).items():
            hit = np.flatnonzero(self.load_names == name)
            if not len(hit):
                raise Fem2TmmError(f"no named load {name!r} in this network (named loads: "
                                   f"{', '.join(map(str, self.load_names)) or 'none'})")
            v[hit[0]] = float(val)
        return self.q0 + (np.asarray(self.load_q.T @ v).ravel() if len(v) else 0.0)

    def orbit_departure(self, t: float) -> np.ndarray:
        """(n_dof,) W: the orbital loads at time ``t`` (s, the run's time axis: periodic from ``orbit_start``) minus
        their orbit average, which the design loads hold; zeros without orbital loads."""
        if self.orbit_q is None:
            return np.zeros(self.n_dof)
        tau = self.orbit_start + np.mod(float(t) - self.orbit_start, self.orbit_period)
        h = np.array([np.interp(tau, self.orbit_nodes, self.orbit_H[:, j]) for j in range(self.orbit_H.shape[1])])
        return np.asarray(self.orbit_q.T @ (h - self.orbit_weights)).ravel()

    def _position_departure(self, j: int) -> np.ndarray:
        """(n_dof,) W: orbit position ``j``'s loads (a row of ``orbit_q``) less their orbit average (the design's);
        zeros without orbital loads."""
        if self.orbit_q is None:
            return np.zeros(self.n_dof)
        w = -np.asarray(self.orbit_weights, float)
        w[j] += 1.0
        return np.asarray(self.orbit_q.T @ w).ravel()

    def _saddle(self, diag: np.ndarray | None = None, M: sp.spmatrix | None = None):
        """[[K + diag(diag) + M, Aᵀ], [A, 0]] factorised (:func:`fem2tmm.linalg.saddle_factor`): through the Schur
        complement where every connected piece of K gets a positive diagonal (emission, capacitance)."""
        Kd = self.K if diag is None else self.K + sp.diags(diag)
        if M is not None:
            Kd = Kd + M
        added = np.zeros(self.n_dof) if diag is None else np.asarray(diag, float).copy()
        if M is not None:
            added += np.asarray(M.diagonal(), float)
        try:
            return saddle_factor(Kd, self.A, definite=self._definite(added))
        except RuntimeError as exc:  # a singular saddle: dependent super nodes (DESIGN §3.2)
            raise Fem2TmmError(f"the recovery's saddle matrix is singular ({exc}): the super nodes do not fix every "
                               "connected part's mean temperature") from None

    def _definite(self, added: np.ndarray) -> bool:
        """Whether K + diag(added) is positive definite: K is a conduction matrix (positive semi-definite, zero row
        sums on each connected piece), so every piece needs a positive ``added`` somewhere."""
        if "pieces" not in self._linear:
            self._linear["pieces"] = connected_components(self.K, directed=False)
        count, piece = self._linear["pieces"]
        hit = np.bincount(piece, weights=(added > 0).astype(float), minlength=count)
        return bool(np.all(hit > 0) and np.all(added >= 0))

    def _absorbs(self) -> bool:
        """Whether the FE faces absorb any of the IR emitted (an IR operator with entries, and an emitter)."""
        return self.ir_A is not None and self.ir_A.nnz > 0 and bool(np.any(self.ir_eps_area > 0))

    def _absorbed(self, T: np.ndarray, T_sn: np.ndarray, T_sink: float) -> np.ndarray:
        """(n_dof,) W of IR absorbed by the FE faces (emission mode with the IR operator), else zeros."""
        if self.ir_A is None:
            return np.zeros(self.n_dof)
        if len(self.ir_face):
            T4 = np.asarray(self.face_W @ T**4).ravel()[self.ir_face]
        else:
            T4 = T_sn[self.ir_owner] ** 4
        emitted = SIGMA * self.ir_eps_area * (T4 - T_sink**4)
        if "ir_At" not in self._linear:  # (its transpose's view made once: a chord step each)
            self._linear["ir_At"] = self.ir_A.T
        side = np.asarray(self._linear["ir_At"] @ emitted).ravel()
        return np.asarray(self.face_W.T @ side.reshape(-1, 2).sum(axis=1)).ravel()

    def recover(self, T_sn: np.ndarray, loads: dict | None = None, T_sink: float | np.ndarray | None = None,
                T0: np.ndarray | None = None, times: np.ndarray | None = None,
                positions: np.ndarray | None = None) -> np.ndarray:
        """Temperatures of every DOF from super-node temperatures.

        Parameters
        ----------
        T_sn : (n_sn,) or (n_sn, k) K
            Super-node temperatures (boundary and kept nodes included), one column per state.
        loads : dict, optional
            {named load: value or (k,) values} (W, or W/m² for a flux); missing names keep their design value.
        T_sink : float or (k,), optional
            Sink temperature(s) in K (emission mode); default the design sink.
        T0 : (n_dof,) or (n_dof, k) K, optional
            Start of the emission mode's Newton (default: the linear recovery).
        times : (k,) s, optional
            The time of each column, for a network with orbital loads (:meth:`orbit_departure`): that time's
            orbital loads instead of their orbit average (the design).  Ignored without orbital loads.
        positions : (k,) int, optional
            Instead of ``times``: the orbit position (row of ``orbit_q``) of each column, its loads exactly (a
            position at an eclipse boundary is two rows at one time).

        Returns
        -------
        (n_dof,) or (n_dof, k) K
        """
        T_sn = np.asarray(T_sn, float)
        one = T_sn.ndim == 1
        Ts = T_sn[:, None] if one else T_sn
        if Ts.shape[0] != self.n_sn:
            raise Fem2TmmError(f"{Ts.shape[0]} super-node temperatures for a network of {self.n_sn}")
        self._absolute(Ts)
        k = Ts.shape[1]
        sinks = np.broadcast_to(np.asarray(self.T_sink if T_sink is None else T_sink, float), (k,))
        q = np.empty((self.n_dof, k))
        if times is not None and np.shape(times) != (k,):
            raise Fem2TmmError(f"{np.size(times)} times for {k} columns of super-node temperatures")
        for j in range(k):
            q[:, j] = self.loads({n: np.broadcast_to(np.asarray(v, float), (k,))[j] for n, v in (loads or {}).items()})
            if times is not None:
                q[:, j] += self.orbit_departure(times[j])
            elif positions is not None:
                q[:, j] += self._position_departure(int(positions[j]))
        def solve_linear(loads_q):  # the linear mode's field for these loads, its saddle factorised once
            if "lu" not in self._linear:
                self._linear["lu"] = self._saddle()
            return self._linear["lu"].solve(np.vstack([loads_q, Ts]))[: self.n_dof]

        # the linear field with the state's loads, formed only where it is needed: the linear mode's answer, the
        # emission mode's start, or its second start after a failed Newton (the factorisation of the floating K is
        # the costliest step of a recovery from a given start: examples/composite 0.78 s against 0.09 s)
        linear = functools.cache(lambda: solve_linear(q))
        if self.mode != "emission":
            T = linear()
            return T[:, 0] if one else T
        if T0 is None and loads:
            # the default start: these means with the loads held at design, as the run's validity check starts
            # (without the emission, a named load's change alone moves the linear field by hundreds of K: the
            # composite example's deck edited to its heater at 4x drove Newton into 0 K from there); that
            # linear field with the state's loads stays the second start
            starts = solve_linear(np.repeat(self.loads()[:, None], k, axis=1))
        else:
            starts = None if T0 is None else np.asarray(T0, float).reshape(self.n_dof, -1)
        T = np.empty((self.n_dof, k))
        for j in range(k):
            start = linear()[:, j] if starts is None else starts[:, min(j, starts.shape[1] - 1)]
            second = None if starts is None else (lambda j=j: linear()[:, j])
            self._linear.pop("chord_saddle", None)  # (one column's kept saddle let go before the next factorises)
            T[:, j] = self._nonlinear(Ts[:, j], q[:, j], float(sinks[j]), start, second)
        # the design state's last chord saddle (its start field, its factorisation) kept for recover_about's reference
        # (the validity range, about the field recovered here); any other state's let go
        last = self._linear.pop("chord_saddle", None)
        if k == 1 and not loads and T_sink is None and times is None and positions is None and last is not None:
            self._linear["design_saddle"] = last
        return T[:, 0] if one else T

    def recover_about(self, T_ref: np.ndarray, T_sn: np.ndarray, loads: dict | None = None,
                      T_sink: float | None = None, tol: float | None = None,
                      position: int | None = None) -> np.ndarray:
        """The emission mode's field at another state, from a field ``T_ref`` already recovered at a nearby one (the
        validity range's edited decks from the design state's field): the same answer as :meth:`recover` (to
        ``tol``), through saddles factorised once and shared by the states.

        The chord iteration with the saddle factorised at ``T_ref`` (or at the field of an earlier state nearer in
        its means: at most :data:`ABOUT_ANCHORS` saddles are kept), from the nearest field recovered so far: its first
        step is the linearised one (Newton's from there, the state's loads, sink and means), the rest the emission's
        and absorbed IR's departure from that linearisation, Anderson-accelerated without asking each step to
        contract (``patient``: a far state's plain chord diverges on a few modes that the accelerated one removes).
        Where it does not converge (a state far from every kept saddle), the saddle is factorised again at the
        nearest field moved by the linearised response to the change of means alone (clipped at 1 K) and the chord
        run from there; that saddle is kept for the next states.  Should that not contract either, :meth:`recover`
        takes over from the same start.  The kept saddles and fields are those of the last ``T_ref`` (or one within
        :data:`ABOUT_SAME_REF` of it): a call with another one starts afresh.

        Parameters
        ----------
        T_ref : (n_dof,) K
            A recovered field (the emission mode's solution at some state).
        T_sn : (n_sn,) K
            The state's super-node temperatures.
        loads, T_sink
            As :meth:`recover`: {named load: value} (missing names at their design value), the sink (K).
        tol : float, optional
            The chord's tolerance on its last step (K); default :data:`RECOVERY_TOLERANCE`.  The validity range's
            states take :data:`RANGE_RECOVERY_TOLERANCE`.
        position : int, optional
            An orbit position: its orbital loads in place of their average, as :meth:`recover` ``positions`` (the
            run's steady solves at every position share the design state's saddle this way).

        Returns
        -------
        (n_dof,) K
        """
        at = None if position is None else np.array([position])
        if self.mode != "emission":
            return self.recover(T_sn, loads=loads, T_sink=T_sink, positions=at)
        T_ref = np.asarray(T_ref, float)
        T_sn = np.asarray(T_sn, float)
        if T_sn.shape != (self.n_sn,):
            raise Fem2TmmError(f"{T_sn.size} super-node temperatures for a network of {self.n_sn}")
        self._absolute(T_sn[:, None])
        held = self._linear.get("about")
        if held is None or held["ref"].shape != T_ref.shape or np.abs(held["ref"] - T_ref).max() > ABOUT_SAME_REF:
            T0 = T_ref.copy()
            seed = self._linear.pop("design_saddle", None)  # the design state's recovery's (ABOUT_SEED_K)
            if seed is None or seed[0].shape != T0.shape or np.abs(self.A @ (seed[0] - T0)).max() > ABOUT_SEED_K:
                seed = (T0, self._saddle(4.0 * SIGMA * self.e * T0**3))
            held = {"ref": T0, "anchors": [seed], "fields": [T0]}
            self._linear["about"] = held
        q = self.loads(loads or {})
        if position is not None:
            q = q + self._position_departure(int(position))
        sink = float(self.T_sink if T_sink is None else T_sink)

        def far(F):  # how far a field's means are from the state's
            return float(np.abs(self.A @ F - T_sn).max(initial=0.0))

        anchor = min(held["anchors"], key=lambda a: far(a[0]))
        start = min(held["fields"], key=far)
        done = self._chord(T_sn, q, sink, start, None, anchor[1], tol=tol, patient=True)
        if done is None:
            # the nearest field moved by the linearised response to the change of means alone (the loads and sink
            # held: a named load's change moves a linearised field too far, 20x a heater drove it below 0 K), its
            # saddle factorised there
            shift = anchor[1].solve(np.concatenate([np.zeros(self.n_dof), T_sn - self.A @ start]))[: self.n_dof]
            T0 = np.maximum(start + shift, 1.0)
            # the oldest kept saddle let go before the new one is factorised: at most ABOUT_ANCHORS at any time
            del anchor
            held["anchors"] = held["anchors"][:1] + held["anchors"][1:][len(held["anchors"]) - ABOUT_ANCHORS + 1:]
            lu = self._saddle(4.0 * SIGMA * self.e * T0**3)
            done = self._chord(T_sn, q, sink, T0, None, lu, tol=tol)
            if done is None:
                done = self.recover(T_sn, loads=loads, T_sink=T_sink, T0=T0, positions=at)
            else:
                held["anchors"] = kept(held["anchors"], (T0, lu), ABOUT_ANCHORS)
        held["fields"] = kept(held["fields"], done, ABOUT_FIELDS)
        return done

    def adopt_about(self, other: ExportedRecovery | None) -> bool:
        """Share the saddles and fields :meth:`recover_about` kept on ``other``, a recovery of the same detailed
        operator (K, A, the emitting areas): another candidate network over the same range (the floor's two, exact at
        the same design state) then starts each state from the first's field there, and needs no saddle of its own
        while its reference field is within :data:`ABOUT_SAME_REF` of the first's.  Where ``other`` has no such
        fields yet, the saddle its recovery of the design state factorised (:meth:`recover` keeps it) moves here
        instead: the run's own recovery, whose saddle the range's first state then shares (:data:`ABOUT_SEED_K`).
        The saddles are only the chord's preconditioner and the fields its starts: the answers are this recovery's
        own.  True when something was shared."""
        if (other is None or other is self or self.mode != "emission" or other.mode != "emission"
                or self.n_dof != other.n_dof or self.n_sn != other.n_sn or not _same_csr(self.K, other.K)
                or not _same_csr(self.A, other.A) or not np.array_equal(self.e, other.e)):
            return False
        held = other._linear.get("about")
        if held is not None:
            self._linear["about"] = held
            return True
        seed = other._linear.pop("design_saddle", None)
        if seed is not None:
            self._linear["design_saddle"] = seed
        return seed is not None

    def release(self) -> None:
        """Let go of the saddles and fields kept for further states (:meth:`recover_about`, the design state's
        saddle :meth:`recover` keeps): each a factorisation of detailed size."""
        for key in ("about", "design_saddle", "chord_saddle"):
            self._linear.pop(key, None)

    def recover_transient(self, T_sn: np.ndarray, times: np.ndarray, loads=None, T_sink=None,
                          step: float | None = None, scheme: str = "crank-nicolson", orbital: bool = False,
                          T0: np.ndarray | None = None, initial: np.ndarray | None = None) -> np.ndarray:
        """The field in time, with the heat each super node stores inside it: ``(n_dof, k)`` K.

        :meth:`recover` gives each time the field the loads of that instant hold at steady state inside super nodes
        of the given means.  After a load step the heat a super node's elements store takes time to move: on the
        L-bracket of ``fem2tmm bench offdesign_transient`` (300 super nodes, heater 10 → 40 W), recovering the
        detailed transient's own means that way is 13 K off at its hot spot 200 s after the step, 3 K after 600 s.
        Here the constrained detailed equations are integrated in time instead,

            C dT/dt + K T + σ e ⊙ (T⁴ − T_s⁴) − q_abs(T) + Aᵀ μ = q(t),    A T = T_SN(t)

        (linear mode: no emission terms), with ``scheme`` over sub-steps of at most ``step`` and the super-node
        temperatures linear between the given times; the first column is :meth:`recover`'s (a steady start).
        Given the exact means of a detailed transient it returns that transient up to the sub-step's truncation
        (tests/test_recover_in_time.py).  Cost: one saddle solve of detailed size per sub-step, with one
        factorisation per step size (emission mode: the chord iteration of :meth:`recover` on a factorisation kept
        while it contracts, refreshed where it does not).

        Parameters
        ----------
        T_sn : (n_sn, k) K
            Super-node temperatures at ``times`` (boundary and kept nodes included).
        times : (k,) s
            Increasing output times.
        loads : callable or dict, optional
            ``loads(t) -> {name: value}`` (W, or W/m² for a flux) at any time, or ``{name: (k,) values}`` at
            ``times`` (linear between them); a name not given follows its time table (:attr:`load_tables`, as in
            the deck) or keeps its design value.
        T_sink : callable, float or (k,), optional
            Sink temperature (K): ``T_sink(t)``, one value, or one per time (linear between them); default its
            time table (:attr:`sink_table`), else the design sink.
        step : float, optional
            Largest sub-step (s); default one step per interval of ``times``.
        scheme : {"crank-nicolson", "backward-euler", "bdf2"}
            The time scheme (bdf2 starts with one backward-Euler step and restarts where the step changes).
        orbital : bool
            Add each time's orbital loads (:meth:`orbit_departure`); ignored without orbital loads.
        T0 : (n_dof,) K, optional
            Start of the first column's Newton (emission mode).
        initial : (n_dof,) K, optional
            The field at ``times[0]`` (a transient started from a uniform temperature) instead of :meth:`recover`'s.

        Returns
        -------
        (n_dof, k) K
        """
        if self.C is None:
            raise Fem2TmmError("this reduced.npz carries no capacitance (its case gives no density and specific heat): "
                               "recover in time needs it; recover() gives each time's quasi-static field")
        if scheme not in TRANSIENT_METHODS:
            raise Fem2TmmError(f"recover_transient: scheme {scheme!r}; use {', '.join(TRANSIENT_METHODS)}")
        times = np.asarray(times, float)
        T_sn = np.asarray(T_sn, float).reshape(self.n_sn, -1)
        k = len(times)
        if T_sn.shape[1] != k:
            raise Fem2TmmError(f"{T_sn.shape[1]} columns of super-node temperatures for {k} times")
        self._absolute(T_sn)
        if k > 1 and np.any(np.diff(times) <= 0.0):
            raise Fem2TmmError("recover in time: the times must increase")
        if step is not None and not step > 0.0:
            raise Fem2TmmError(f"recover in time: step {step} s; give a positive step")

        def between(values, t):  # a per-time value (k,) linear between the times, or a callable, or a constant
            if callable(values):
                return values(t)
            v = np.asarray(values, float)
            return float(v) if v.ndim == 0 else float(np.interp(t, times, v))

        def load_at(t):
            out = {n: float(np.interp(t, tt, vv)) for n, tt, vv in self.load_tables}
            if loads is not None:
                out.update(loads(t) if callable(loads) else {n: between(v, t) for n, v in loads.items()})
            return out

        def sink_at(t):
            if T_sink is not None:
                return between(T_sink, t)
            if self.sink_table is not None:
                return float(np.interp(t, *self.sink_table))
            return self.T_sink

        def q_at(t):
            q = self.loads(load_at(t))
            return q + self.orbit_departure(t) if orbital else q

        def flux(T, Tsn, s, q):  # the steady residual's known-field part: K T + emission − absorbed − q
            f = self.K @ T - q
            if self.mode == "emission":
                f = f + SIGMA * self.e * (T**4 - s**4) - self._absorbed(T, Tsn, s)
            return f

        out = np.empty((self.n_dof, k))
        if initial is not None:
            out[:, 0] = np.asarray(initial, float)
        else:
            out[:, 0] = self.recover(T_sn[:, 0], loads=load_at(times[0]), T_sink=sink_at(times[0]), T0=T0,
                                     times=np.array([times[0]]) if orbital else None)
        T, Tsn, s, q = out[:, 0], T_sn[:, 0], sink_at(times[0]), q_at(times[0])
        T_old, h_old = None, None
        factors, chord = {}, None
        for i in range(1, k):
            n_sub = 1 if step is None else max(1, int(np.ceil((times[i] - times[i - 1]) / step - 1e-9)))
            h = (times[i] - times[i - 1]) / n_sub
            for j in range(1, n_sub + 1):
                t1 = times[i] if j == n_sub else times[i - 1] + j * h
                w = j / n_sub
                Tsn1 = (1.0 - w) * T_sn[:, i - 1] + w * T_sn[:, i]
                s1, q1 = sink_at(t1), q_at(t1)
                if scheme == "crank-nicolson":
                    c = 2.0 / h
                    rhs = q1 + c * (self.C @ T) - flux(T, Tsn, s, q)
                elif scheme == "bdf2" and T_old is not None and h_old is not None and abs(h - h_old) < 1e-12 * h:
                    c = 1.5 / h
                    rhs = q1 + (self.C @ (2.0 * T - 0.5 * T_old)) / h
                else:
                    c = 1.0 / h
                    rhs = q1 + c * (self.C @ T)
                M = c * self.C
                try:
                    T1, chord = self._step(Tsn1, rhs, float(s1), T, M, c, chord, factors)
                except Fem2TmmError as exc:
                    raise Fem2TmmError(f"recovering in time, the step to t = {t1:g} s: {exc}") from None
                T_old, h_old = T, h
                T, Tsn, s, q = T1, Tsn1, s1, q1
            out[:, i] = T
        return out

    def _absolute(self, T_sn: np.ndarray) -> None:
        """Refuse super-node temperatures at or below 0 K in emission mode (the field there radiates as T⁴)."""
        if self.mode == "emission" and T_sn.size and not float(np.min(T_sn)) > 0.0:
            j = np.unravel_index(int(np.argmin(T_sn)), T_sn.shape)[0]
            raise Fem2TmmError(f"super node {self.names[j]} at {float(np.min(T_sn)):.3g} K, at or below absolute zero: "
                               "the recovery radiates as T⁴ and needs temperatures above 0 K (are they in K?  A model "
                               "whose whole field sits within millikelvins of 0 K, with no load, is below the "
                               "solvers' resolution: raise the sink or add a load)")

    def _step(self, Tsn1: np.ndarray, rhs: np.ndarray, s1: float, T: np.ndarray, M: sp.spmatrix, c: float,
              chord: tuple | None, factors: dict) -> tuple[np.ndarray, tuple | None]:
        """One step of :meth:`recover_transient` to the means ``Tsn1`` (K) with the step's right-hand side ``rhs``
        (W) and mass term ``M`` = c C: ``(T1, chord)``, ``chord`` the kept ``(c, factorisation)`` of the emission
        mode; ``factors`` the linear mode's factorisations by c."""
        if self.mode != "emission":
            lu = factors.get(c)
            if lu is None:
                if len(factors) >= 4:  # (step sizes that vary between intervals: keep the last few, not all)
                    factors.pop(next(iter(factors)))
                lu = factors[c] = self._saddle(None, M)
            return lu.solve(np.concatenate([rhs, Tsn1]))[: self.n_dof], chord
        # the chord iteration on a saddle factorised once and kept while it contracts (the capacitance term C/h
        # dominates its diagonal), refreshed at the current state, then Newton
        T1 = None if chord is None or chord[0] != c else self._chord(Tsn1, rhs, s1, T, M, chord[1])
        if T1 is None:
            chord = (c, self._saddle(4.0 * SIGMA * self.e * T**3, M))
            T1 = self._chord(Tsn1, rhs, s1, T, M, chord[1])
        if T1 is None:
            T1 = self._nonlinear(Tsn1, rhs, s1, T, None, M)
        return T1, chord

    def _nonlinear(self, T_sn: np.ndarray, q: np.ndarray, T_sink: float, T: np.ndarray,
                   linear=None, M: sp.spmatrix | None = None) -> np.ndarray:
        """The emission mode for one state: :meth:`_chord` from ``T``, else Newton on the constrained problem with
        the absorbed IR lagged (:meth:`_newton`), from ``T`` and, should that fail, from the linear recovery
        ``linear`` ((n_dof,) K, or a callable giving it on demand; a given start can be far off: a transient
        starting at 0 °C recovered from its linearisation about a hot steady state, tests/test_robustness.py)."""
        T = np.maximum(np.asarray(T, float).copy(), 1.0)
        done = self._chord(T_sn, q, T_sink, T, M)
        if done is not None:
            return done
        try:
            return self._newton(T_sn, q, T_sink, T, M)
        except Fem2TmmError:
            linear = linear() if callable(linear) else linear
            if linear is None or np.array_equal(linear, T):
                raise
            return self._newton(T_sn, q, T_sink, np.maximum(np.asarray(linear, float), 1.0), M)

    def _no_positive_field(self, T: np.ndarray, dT: np.ndarray) -> str:
        """The refusal where Newton is held back from 0 K at every step: the node it drives below 0 K (its GRID id)
        and the super node whose mean holds it there."""
        dof = int(np.argmin(T + dT))
        nodes = np.flatnonzero(self.node_dof == dof)
        grid = f"GRID {int(self.node_ids[nodes[0]])}" if len(nodes) else f"DOF {dof}"
        col = self.A[:, dof].tocoo()
        owner = str(self.names[int(col.row[np.argmax(col.data)])]) if col.nnz else "?"
        return (f"the recovery found no field above 0 K for these super-node temperatures: its Newton is held at "
                f"0 K at {grid} (super node {owner}).  The network's temperatures at this state may not be those "
                "of a physical field there, which happens far from the state fem2tmm reduced at (the deck's "
                "validity range says how far it was checked).  Run fem2tmm at this state (its loads in the case "
                "file, or a [[cases]] entry), or give that part more super nodes")

    def _chord(self, T_sn: np.ndarray, q: np.ndarray, T_sink: float, T: np.ndarray,
               M: sp.spmatrix | None = None, lu=None, tol: float | None = None,
               patient: bool = False) -> np.ndarray | None:
        """One factorisation, at the start: iterations on the whole residual (emission and absorbed IR at the
        current field) solved with the saddle matrix of the start's linearised emission.  Near the solution (a
        transient's output times from their linearised recovery: ~0.5 K off) it contracts like the IR
        fixed point, at a back-substitution per iteration instead of a factorisation per Newton step: on
        examples/composite's orbit, 51 output times 90 s -> (README).  Anderson-accelerated over the last
        :data:`CHORD_DEPTH` steps (the range's states from the design field, 150-185 K away on examples/composite:
        0.2-0.26 -> 0.09-0.1 s, docs/design-notes.md).  None when it does not contract; the Newton iteration then
        starts again from ``T``.  ``tol``: the last step's size that ends it (K; default
        :data:`RECOVERY_TOLERANCE`).  ``patient``: Anderson's steps need not contract one by one; it gives up after
        :data:`PATIENT_STEPS` steps, or once a step grows beyond :data:`PATIENT_GROWTH` times the smallest so far (a
        saddle factorised far from the state, whose plain chord diverges on a few modes that Anderson's history
        removes: :meth:`recover_about`)."""
        n = self.n_dof
        tol = RECOVERY_TOLERANCE if tol is None else float(tol)
        s4 = T_sink**4
        own = lu is None and M is None  # (kept where it converges: recover()'s design state, recover_about's seed)
        if lu is None:  # (a given lu: a saddle factorised at an earlier state, as a transient's steps reuse it)
            lu = self._saddle(4.0 * SIGMA * self.e * T**3, M)
        z = np.concatenate([T, np.zeros(self.n_sn)])  # the field and the constraints' multipliers
        prev, resets = None, 0
        dz, dg = [], []  # the Anderson history: differences of the last steps d and of the images z + d
        last = None
        least = np.inf
        for _ in range(PATIENT_STEPS if patient else CHORD_MAX):
            X, mu = z[:n], z[n:]
            r1 = self.K @ X + SIGMA * self.e * (X**4 - s4) + self.A.T @ mu - q - self._absorbed(X, T_sn, T_sink)
            if M is not None:
                r1 += M @ X
            d = lu.solve(-np.concatenate([r1, self.A @ X - T_sn]))
            size = float(np.abs(d[:n]).max())
            if not np.isfinite(size):
                return None
            damped = bool(np.any(X + d[:n] <= 0.0))
            if damped:  # a step through 0 K
                if not patient:
                    return None
                # patient: scaled to leave every node at least half its temperature (a saddle far from the state
                # overshoots at first: the L-bracket's heater at 4x with the sink at 20 °C from the design state's,
                # at a 3 K sink, 25 steps instead of a saddle of its own, 0.18 against 0.36 s, 2026-12-07)
                down = d[:n] < 0.0
                d = d * float(np.min(0.5 * X[down] / -d[:n][down]))
                size = float(np.abs(d[:n]).max())
            elif size < max(tol, 1e-13 * float(np.abs(X).max())):  # (only an undamped step ends it)
                if own:
                    self._linear["chord_saddle"] = (np.array(T, float), lu)
                return X + d[:n]
            least = least if damped else min(least, size)
            if patient:
                if size > PATIENT_GROWTH * least:
                    return None
            elif prev is not None and size > CHORD_RATE * prev:
                if not dz or resets == CHORD_RESETS:  # a plain chord step that does not contract: Newton's turn
                    return None
                # the accelerated step did not pay: a plain step from here, which must contract on the last step
                # that did
                dz, dg, last, resets = [], [], None, resets + 1
            else:
                prev = size
            g = z + d
            if last is not None:
                dz.append(d - last[0])
                dg.append(g - last[1])
                if len(dz) > CHORD_DEPTH:
                    del dz[0], dg[0]
            last = (d, g)
            z = g
            if dz:  # Anderson: the combination of the last images whose steps cancel best (least squares)
                D = np.column_stack(dz)
                gamma = np.linalg.lstsq(D, d, rcond=1e-10)[0]
                za = g - np.column_stack(dg) @ gamma
                if np.all(np.isfinite(za)) and np.all(za[:n] > 0.0):
                    z = za
        return None

    def _newton(self, T_sn: np.ndarray, q: np.ndarray, T_sink: float, T: np.ndarray,
                M: sp.spmatrix | None = None) -> np.ndarray:
        """Newton on the constrained problem (a factorisation per step), the absorbed IR lagged over rounds."""
        T = T.copy()
        n = self.n_dof
        s4 = T_sink**4
        mu = np.zeros(self.n_sn)
        for _ in range(RECOVERY_MAX_ROUNDS):
            qa = q + self._absorbed(T, T_sn, T_sink)
            T_start = T.copy()
            prev = None
            for _ in range(RECOVERY_MAX_NEWTON):
                r1 = self.K @ T + SIGMA * self.e * (T**4 - s4) + self.A.T @ mu - qa
                if M is not None:
                    r1 += M @ T
                r2 = self.A @ T - T_sn
                d = self._saddle(4.0 * SIGMA * self.e * T**3, M).solve(-np.concatenate([r1, r2]))
                dT = d[:n]
                step = 1.0
                while np.any(T + step * dT <= 0.0) and step > 1e-6:  # temperatures stay positive
                    step *= 0.5
                T = T + step * dT
                mu = mu + step * d[n:]
                # the tolerance, or the round-off of the temperatures (1e-13 of the hottest node: a model whose
                # temperatures reach 1e5 K)
                size = float(np.abs(step * dT).max())
                if size < max(RECOVERY_TOLERANCE, 1e-13 * float(np.abs(T).max())):
                    break
                # Newton no longer contracts with the residual at the round-off of the conduction terms: the
                # floating-point floor of an ill-conditioned model
                # (the emission and the loads count too: a 0 K start heated by 330 W, tests/test_robustness.py)
                floor = roundoff(self.K, T) + (0.0 if M is None else roundoff(M, T))
                # and the constraint forces A^T mu (a super node's multiplier carries the heat its cluster passes on)
                floor += ROUNDOFF_ULPS * float(np.finfo(float).eps) * float(
                    np.abs(SIGMA * self.e * (T**4 + s4)).sum() + np.abs(qa).sum() + np.abs(self.A.T @ mu).sum())
                if prev is not None and size > 0.5 * prev and np.abs(r1).sum() <= floor:
                    break
                prev = size
            else:
                if step < 1.0:  # held back from 0 K at every step
                    raise Fem2TmmError(self._no_positive_field(T, dT))
                raise Fem2TmmError(f"the recovery's Newton did not converge in {RECOVERY_MAX_NEWTON} steps (last "
                                   f"step {np.abs(step * dT).max():.3g} K): are the super-node temperatures in K and "
                                   "physical?")
            # nothing absorbs what is emitted (no IR operator, no entries, or nothing emitting: ε = 0), so the
            # absorbed IR is 0 at any field and one round is the answer: rounds of a 7·10⁶ K super node (886 W on a
            # 0.14 mm plate with ε = 0, tests/test_robustness.py) changed by round-off (5e-5 K), never below
            # RECOVERY_TOLERANCE; else the rounds' change, to the tolerance or the round-off of the hottest node
            if (not self._absorbs() or np.abs(T - T_start).max()
                    < max(RECOVERY_TOLERANCE, 1e-13 * float(np.abs(T).max()))):
                return T
            # the emission is solved for this round's IR: the rounds left are the IR fixed point, which the chord
            # iteration (whole residual, one factorisation) follows at a back-substitution per step (a state 100 K
            # off the start: 39 -> ~8 factorisations, examples/composite, docs/design-notes.md)
            done = self._chord(T_sn, q, T_sink, T, M)
            if done is not None:
                return done
        raise Fem2TmmError(f"the recovery's absorbed-IR fixed point did not settle in {RECOVERY_MAX_ROUNDS} rounds "
                           f"(last change {np.abs(T - T_start).max():.3g} K)")

    def node_temperatures(self, T_dof: np.ndarray) -> np.ndarray:
        """(n_nodes,) or (n_nodes, k) temperatures of every mesh node (NaN outside the model; mid-side nodes of
        quadratic elements the mean of their edge ends, as :meth:`fem2tmm.fem.model.FEModel.node_temperatures`)."""
        T_dof = np.asarray(T_dof, float)
        out = np.full((len(self.node_dof),) + T_dof.shape[1:], np.nan)
        ok = self.node_dof >= 0
        out[ok] = T_dof[self.node_dof[ok]]
        ms = self.midside
        if len(ms):
            out[ms[:, 0]] = 0.5 * (out[ms[:, 1]] + out[ms[:, 2]])
        return out


def _same_csr(a, b) -> bool:
    """Whether two csr matrices hold the same entries in the same layout."""
    return (a.shape == b.shape and np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices)
            and np.array_equal(a.data, b.data))


def load(path) -> ExportedRecovery:
    """The :class:`ExportedRecovery` of a ``reduced.npz`` file."""
    with np.load(path, allow_pickle=False) as z:
        return ExportedRecovery.from_npz(dict(z), where=str(path))


__all__ = ["ExportedRecovery", "load", "RECOVERY_TOLERANCE"]
