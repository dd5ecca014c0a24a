"""Transient conductive-radiative network solver (detailed and reduced models alike).

Solves for the free temperatures T(t) (K) of

    C dT/dt = F(t, T) = Q(t) − K T − σ L T⁴ − σ g (T⁴ − T_sink(t)⁴),      L = diag(GR·1) − GR,

with C (n,) lumped or (n, n) consistent capacitance (J/K), K (n, n) conduction (W/K), GR node couplings (m²,
dense / sparse, or factored faces ``Wᵀ G W``), g (n,) couplings to the sink (m²), Q(t) (n,) loads (W, a
:class:`~fem2tmm.timefunc.Series`), and fixed nodes at prescribed (possibly time-dependent) temperatures.

Schemes (one step from tₙ to tₙ₊₁ = tₙ + h), all written as ``C ΔTⁿ⁺¹ = β Fⁿ⁺¹ + rⁿ`` on the free rows:

* ``backward-euler``: β = h, r = 0;
* ``crank-nicolson``: β = h/2, r = h/2 Fⁿ; the first two steps are backward Euler (Rannacher start: damps the
  stiff modes a discontinuous start excites, keeps second order);
* ``bdf2`` (variable step, ω = h/hₙ₋₁): a = (1+2ω)/(1+ω), c = ω²/(1+ω), β = h/a, r = (c/a) C ΔTⁿ; the first
  step is trapezoidal (second order; BDF2's damping takes care of the stiff modes it leaves).

Newton on the radiation each step with a frozen (modified-Newton) Jacobian ``C_ff + β J_ff``: it is factorised
when β changes or when the iterations contract slower than :data:`REFACTOR_RATE`, so a linear problem is
factorised once per step size and a radiative one only now and then.  Factored face radiation (detailed model
with traced REFs) uses the lumped face conductance in the factorisation and GMRES on the exact Jacobian.

Adaptive steps (``tolerance`` K): the local error is estimated from the difference between the corrector and
an explicit extrapolation through the last points (Milne's device, valid for variable steps):
``LTE = (T_c − T_p) κ/(κ + π/m!)`` with κ the scheme's error constant (BE h²/2, CN h³/12, BDF2 from its
coefficients) and π = Π(tₙ₊₁ − tⱼ) the extrapolation's.  Steps are snapped so that every output time (and every
kink of an input table) is hit exactly: in each interval the step is the interval divided by an integer, which
also lets a linear problem reuse its factorisation.

Energy accounting, exact for the discrete scheme: per step, with Ĝ(x) the scheme's effective integral of a
pointwise quantity x (θ-schemes: h(θxⁿ⁺¹ + (1−θ)xⁿ); BDF2: β xⁿ⁺¹ + (c/a) Ĝⁿ(x)),

    stored = Σᵢ (C ΔT)ᵢ,   applied = Ĝ(ΣQ),   to_space = Ĝ(Σ σ g (T⁴ − T_sink⁴)),
    into_fixed = Ĝ(Σ_fixed F) − Σ_fixed (C ΔT)        (the reaction of the scheme's own fixed rows),

and ``imbalance = stored − (applied − to_space − into_fixed)`` equals the free rows' Newton residual plus the
conduction and radiation sums (zero for symmetric, zero-row-sum K and L): it is round-off when the solve is right.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import Fem2TmmError
from ..linalg import blas_threads, factorize
from ..progress import report
from ..constants import SIGMA
from .steady import MAX_DROP, FacedRadiation, SteadyProblem, _Operators, solve_steady, table_value
from ..timefunc import Series, Table

METHODS = ("crank-nicolson", "backward-euler", "bdf2")
#: chord iterations contracting slower than this trigger a new factorisation of the Newton matrix
REFACTOR_RATE = 0.2
#: Newton iterations per step before the step is declared failed (then halved when adaptive)
MAX_NEWTON = 30
#: the energy balance's per-step scale is at least the heat of this relative change of every temperature (books)
BALANCE_HEAT_REL = 1e-6
#: a transient step's Newton also stops once its residual (J) is below this fraction of the step's gross heat terms
STEP_RESIDUAL = 1e-12
#: the smallest substep, as a fraction of the run, before a failed Newton is reported
MIN_SUBSTEP = 1e-10
#: largest growth of the step between two accepted steps (adaptive stepping)
MAX_GROWTH = 3.0
#: the step is kept while the controller's factor stays in this range (fewer step changes, reused factors)
KEEP_STEP = (0.8, 1.3)
#: a radiative Newton matrix is reused for a new β within this relative change (the contraction check guards it)
REUSE_BETA = 0.3
#: BLAS threads inside the time loop: its dense work is matrix-vector products and solves of n ≤ a few
#: thousand, where threads only contend (measurements: docs/design-notes.md, solve/transient.py)
BLAS_THREADS = 1
#: backward-Euler steps at the start of a Crank-Nicolson run (Rannacher)
CN_STARTUP = 2


@dataclass(frozen=True)
class TransientProblem:
    """A transient network.  Shapes: n nodes.

    ``K`` (n, n) W/K sparse or dense; ``C`` (n,) J/K lumped or (n, n) sparse/dense consistent (row sums = the
    lumped capacitance); ``Q`` :class:`Series` (n,) W; ``fixed`` (n,) bool; ``T_fixed`` :class:`Series` (n,) K
    (read on the fixed rows); ``g_space`` (n,) m²; ``T_sink`` :class:`Table` K; ``GR`` (n, n) m² or None;
    ``faced`` :class:`FacedRadiation` or None; ``g_table`` ``(x (n, m) K, y (n, m) m²)`` or None: each node's
    coupling to space as a table of its own temperature (:attr:`SteadyProblem.g_table`; it replaces ``g_space``
    at every state, as the deck's ``GR(n, space) = INTRP1(Tn, …)`` does in ESATAN's transient).
    """

    K: object
    C: object
    Q: Series
    fixed: np.ndarray
    T_fixed: Series
    g_space: np.ndarray
    T_sink: Table
    GR: object | None = None
    faced: FacedRadiation | None = None
    names: tuple[str, ...] | None = None
    g_table: tuple | None = None

    @property
    def n(self) -> int:
        return self.K.shape[0]

    def steady_problem(self, t: float) -> SteadyProblem:
        """The steady problem with the inputs frozen at time ``t`` (s)."""
        return SteadyProblem(K=self.K, Q=self.Q(t), fixed=np.asarray(self.fixed, bool), T_fixed=self.T_fixed(t),
                             g_space=self.g_space, T_sink=self.T_sink(t), GR=self.GR, faced=self.faced,
                             names=self.names, g_table=self.g_table)

    def periodic(self, start: float, period: float) -> "TransientProblem":
        """The same problem with every input table read periodically (period ``period`` s from ``start``)."""
        from dataclasses import replace

        return replace(self, Q=self.Q.periodic(start, period), T_fixed=self.T_fixed.periodic(start, period),
                       T_sink=self.T_sink.periodic(start, period))


@dataclass(frozen=True)
class TransientSettings:
    """Time integration settings (seconds, kelvin).

    ``step`` fixed step (s), or, with ``tolerance`` (K, largest local error estimate per step), the first and
    largest step; ``output_every`` (s, default: only ``end``); ``periodic``: repeat the period ``end − start``
    until the largest change of the output temperatures between two successive periods is below
    ``periodic_tolerance`` (K).  ``newton_rtol``: Newton stops when the last correction is below this fraction
    of the step's largest temperature change (or at round-off).
    """

    end: float
    start: float = 0.0
    step: float | None = None
    tolerance: float | None = None
    output_every: float | None = None
    method: str = "crank-nicolson"
    periodic: bool = False
    periodic_tolerance: float = 0.01
    max_periods: int = 500
    newton_rtol: float = 1e-10

    def check(self, where: str = "[transient]") -> None:
        if not self.end > self.start:
            raise Fem2TmmError(f"{where}: end ({self.end} s) must be after start ({self.start} s)")
        if self.method not in METHODS:
            raise Fem2TmmError(f"{where}: method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if self.step is None and self.tolerance is None:
            raise Fem2TmmError(f"{where}: give 'step' (s, fixed steps) or 'tolerance' (K, adaptive steps)")
        for key in ("step", "tolerance", "output_every", "periodic_tolerance"):
            v = getattr(self, key)
            if v is not None and not v > 0:
                raise Fem2TmmError(f"{where}: {key} must be positive, got {v}")

    def output_times(self) -> np.ndarray:
        """(n_out,) output times (s): start, every ``output_every``, and end."""
        span = self.end - self.start
        if self.output_every is None:
            return np.array([self.start, self.end])
        k = int(np.floor(span / self.output_every * (1 + 1e-12)))
        t = self.start + self.output_every * np.arange(k + 1)
        if self.end - t[-1] > 1e-9 * span:
            t = np.append(t, self.end)
        else:
            t[-1] = self.end
        return t


@dataclass
class TransientSolution:
    """Temperatures at the output times and the books.

    ``times`` (n_out,) s; ``T`` (n_out, n) K; ``steps`` per accepted step (of the last period when periodic):
    ``t`` end time, ``h``, ``stored``, ``applied``, ``to_space``, ``into_fixed``, ``imbalance`` in J;
    ``energy`` their totals with ``relative`` = |Σ imbalance| / Σ gross flows and ``max_step_relative``;
    ``stats`` counters (steps, rejected, factorizations, newton_iterations, periods, period_changes_K).
    """

    times: np.ndarray
    T: np.ndarray
    steps: dict
    energy: dict
    stats: dict = field(default_factory=dict)


class _Newton:
    """Newton matrices ``C_ff + β J_ff`` of one problem: factorised, cached, refreshed."""

    def __init__(self, problem: TransientProblem, ops: _Operators, free: np.ndarray, stats: dict):
        self.ops, self.free, self.stats = ops, free, stats
        C = problem.C
        self.lumped = np.ndim(C) == 1
        if self.lumped:
            self.Cff = np.asarray(C, float)[free]
        elif ops.dense:
            self.Cff = np.asarray(C.toarray() if sp.issparse(C) else C, float)[np.ix_(free, free)]
        else:
            self.Cff = sp.csr_matrix(C)[free][:, free].tocsc()
        self.linear = not ops.radiative
        self.krylov = ops.Gf is not None and not ops.dense
        self.cache: dict[float, object] = {}  # linear: β -> factor
        self.current = None  # radiative: (β, factor)

    def _factor(self, beta: float, T: np.ndarray):
        d = 4 * SIGMA * T**3 if not self.linear else np.zeros_like(T)
        J = self.ops.jacobian(d, self.free, lumped_faces=self.krylov)
        if self.ops.dense:
            A = beta * J
            A[np.diag_indices_from(A)] += self.Cff if self.lumped else 0.0
            if not self.lumped:
                A += self.Cff
            lu = sla.lu_factor(A, check_finite=False)
            solve = lambda b: sla.lu_solve(lu, b, check_finite=False)  # noqa: E731
        else:
            A = beta * J + (sp.diags(self.Cff) if self.lumped else self.Cff)
            solve = factorize(A.tocsc(), "spd" if self.ops.L is None else "general").solve
        self.stats["factorizations"] += 1
        return solve

    def solver(self, beta: float, T: np.ndarray, refresh: bool = False):
        """The (possibly frozen) solve of the Newton matrix for β at temperatures ``T``."""
        if self.linear:
            s = self.cache.get(beta)
            if s is None:
                if len(self.cache) >= 8:
                    self.cache.pop(next(iter(self.cache)))
                s = self.cache[beta] = self._factor(beta, T)
            return s
        if refresh or self.current is None or abs(beta / self.current[0] - 1.0) > REUSE_BETA:
            self.current = (beta, self._factor(beta, T))
        return self.current[1]

    def exact_step(self, precond, beta: float, T: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Exact Newton correction by GMRES (factored face radiation), preconditioned by ``precond``."""
        import scipy.sparse.linalg as spla

        n, free = len(T), self.free
        d = 4 * SIGMA * T**3
        full = np.zeros(n)

        def matvec(x):
            full[:] = 0.0
            full[free] = x
            cx = self.Cff * x if self.lumped else self.Cff @ x
            return cx + beta * self.ops.jvp(d, full)[free]

        m = len(free)
        A = spla.LinearOperator((m, m), matvec=matvec, dtype=float)
        M = spla.LinearOperator((m, m), matvec=precond, dtype=float)
        x, info = spla.gmres(A, b, rtol=1e-12, atol=0.0, restart=40, maxiter=20, M=M)
        return x


class _Integrator:
    """One continuous integration of a :class:`TransientProblem`; :meth:`advance` moves it to a given time."""

    def __init__(self, problem: TransientProblem, settings: TransientSettings, T0: np.ndarray, t0: float):
        self.p, self.s = problem, settings
        n = problem.n
        self.fixed = np.asarray(problem.fixed, bool)
        self.free = np.flatnonzero(~self.fixed)
        self.ops = _Operators(SteadyProblem(K=problem.K, Q=np.zeros(n), fixed=self.fixed, T_fixed=np.zeros(n),
                                            g_space=problem.g_space, T_sink=0.0, GR=problem.GR, faced=problem.faced,
                                            g_table=problem.g_table))
        C = problem.C
        self.lumped = np.ndim(C) == 1
        self.C = np.asarray(C, float) if self.lumped else (C if sp.issparse(C) else np.asarray(C, float))
        self.c = self.C if self.lumped else np.asarray(self.C.sum(axis=1)).ravel()  # row sums
        self.stats = {"steps": 0, "rejected": 0, "factorizations": 0, "newton_iterations": 0}
        self.newton = _Newton(problem, self.ops, self.free, self.stats)
        self.t = float(t0)
        self.T = np.asarray(T0, float).copy()
        self.T[self.fixed] = problem.T_fixed(self.t)[self.fixed]
        if np.any(self.T[~self.fixed] <= 0) or np.any(self.T[self.fixed] < 0):  # a fixed space node may be at 0 K
            raise Fem2TmmError("initial temperatures must be above absolute zero, fixed ones at or above it")
        self.T_ref = float(np.mean(self.T))
        self.F, self.pieces = self._flux(self.t, self.T)
        self.G = {k: 0.0 for k in self.pieces}  # effective integrals of the previous step (BDF2)
        self.dT_prev = np.zeros(n)  # ΔT of the previous step (BDF2)
        self.h_prev = None
        self.hist = deque([(self.t, self.T.copy())], maxlen=3)
        self.n_steps = 0
        self.h_next = settings.step if settings.tolerance is None else None
        self.records = {k: [] for k in ("t", "h", "stored", "applied", "to_space", "into_fixed", "imbalance",
                                        "gross")}

    # ---------------------------------------------------------------------------------------- physics
    def _flux(self, t: float, T: np.ndarray):
        """F(t, T) (n,) W and the scalar pieces the energy books need."""
        T4 = T**4
        Q = self.p.Q(t)
        s4 = self.p.T_sink(t) ** 4
        if self.p.g_table is not None:  # the couplings to space at this state, and their slope for the Jacobian
            self.ops.g, dg = table_value(*self.p.g_table, T)
            self.ops.dg = SIGMA * dg * (T4 - s4)
        space = SIGMA * self.ops.g * (T4 - s4)
        # K and L have zero row sums: subtracting a uniform reference keeps the cancelling terms small, so
        # the books balance to round-off of the temperature differences, not of the absolute temperatures
        internal = np.asarray(self.ops.K @ (T - self.T_ref)).ravel() + self.ops.radiation(T4 - self.T_ref**4)
        F = Q - internal - space
        pieces = {"applied": float(Q.sum()), "to_space": float(space.sum()), "fixed": float(F[self.fixed].sum())}
        return F, pieces

    def _CdT(self, dT: np.ndarray) -> np.ndarray:
        return self.C * dT if self.lumped else np.asarray(self.C @ dT).ravel()

    # ---------------------------------------------------------------------------------------- one step
    def _scheme(self, h: float):
        """(kind, β, order, θ, c/a) of the next step."""
        m = self.s.method
        if m == "backward-euler" or (m == "crank-nicolson" and self.n_steps < CN_STARTUP):
            return "theta", h, 1, 1.0, 0.0
        if m == "crank-nicolson" or self.n_steps == 0:  # BDF2 starts with one trapezoidal step
            return "theta", 0.5 * h, 2, 0.5, 0.0
        w = h / self.h_prev
        a = (1 + 2 * w) / (1 + w)
        c = w * w / (1 + w)
        return "bdf2", h / a, 2, 1.0, c / a

    def _error_constant(self, kind: str, order: int, h: float, ca: float) -> float:
        """κ: the scheme's local error per unit of the (order+1)-th derivative."""
        if order == 1:
            return 0.5 * h * h
        if kind == "theta":
            return h**3 / 12.0
        # BDF2: a y₊ − b y₀ + c y₋ = h y'₊ with y = (t − t₊)³/6: residual τ = b h³/6 − c (h + h₋)³/6, error −τ/a
        w = h / self.h_prev
        a = (1 + 2 * w) / (1 + w)
        b, c = 1 + w, w * w / (1 + w)
        tau = b * h**3 / 6 - c * (h + self.h_prev) ** 3 / 6
        return abs(tau / a)

    def _predict(self, t1: float, order: int):
        """Extrapolation through the last ``order + 1`` points to t1: (T_p, π/m!) or (None, None)."""
        m = order + 1
        if len(self.hist) < m:
            return None, None
        pts = list(self.hist)[-m:]
        ts = np.array([p[0] for p in pts])
        Tp = np.zeros_like(self.T)
        for j, (tj, Tj) in enumerate(pts):
            lj = np.prod([(t1 - tk) / (tj - tk) for k, tk in enumerate(ts) if k != j])
            Tp += lj * Tj
        pi = float(np.prod(t1 - ts)) / float(np.prod(np.arange(1, m + 1)))
        return Tp, abs(pi)

    def _step(self, h: float):
        """Try one step of size h.  Returns (T1, F1, pieces1, err, order, scheme) or None if Newton failed."""
        t1 = self.t + h
        kind, beta, order, theta, ca = self._scheme(h)
        fixed, free = self.fixed, self.free
        T1 = self.T.copy()
        T1[fixed] = self.p.T_fixed(t1)[fixed]
        Tp, pi = self._predict(t1, order)
        if Tp is not None:
            T1[free] = Tp[free]
        if kind == "theta":
            r = (1 - theta) * h * self.F[free]
        else:
            r = ca * self._CdT(self.dT_prev)[free]
        newton = self.newton
        T1[free] = np.maximum(T1[free], 0.05 * self.T[free])
        solve = newton.solver(beta, T1)
        prev, it, ok = None, 0, False
        F1 = pieces = None
        dn = None
        damped = False
        while it < MAX_NEWTON:
            F1, pieces = self._flux(t1, T1)
            R = self._CdT(T1 - self.T)[free] - beta * F1[free] - r
            if newton.linear and it == 1 and not damped:  # (one undamped step solves a linear one)
                ok = True
                break
            # the residual criterion (J): the step's equation holds to STEP_RESIDUAL of its gross heat terms
            gross = (np.abs(self._CdT(T1 - self.T)[free]).sum() + beta * np.abs(F1[free]).sum()
                     + np.abs(r).sum() + 1e-300)
            res = float(np.abs(R).sum())
            self._last_newton = (float(dn) if it and dn is not None else float("nan"), res / gross)
            if it > 0 and res <= STEP_RESIDUAL * gross:
                ok = True
                break
            if newton.krylov:
                dx = newton.exact_step(solve, beta, T1, -R)
            else:
                dx = solve(-R)
            it += 1
            if not np.all(np.isfinite(dx)):
                break
            # positivity: a correction never takes a temperature down by more than MAX_DROP of itself; a damped
            # correction is not a converged one, and the next is computed on a fresh Jacobian
            neg = dx < 0
            a = min(1.0, float(np.min(MAX_DROP * T1[free][neg] / -dx[neg]))) if neg.any() else 1.0
            if a < 1.0:
                T1[free] += a * dx
                solve = newton.solver(beta, T1, refresh=True)
                prev, damped = None, True
                continue
            dn = float(np.max(np.abs(dx))) if dx.size else 0.0
            change = float(np.max(np.abs(T1[free] + dx - self.T[free]))) if dx.size else 0.0
            T1[free] += dx
            tol = self.s.newton_rtol * change + 4e-15 * float(np.max(np.abs(T1)))
            # converged when the correction, or the error left after it (contraction rate x correction), is small
            rate = dn / prev if prev else 1.0
            if dn <= tol or (rate < 0.5 and rate * dn <= tol) or (newton.linear and dx.size == 0):
                F1, pieces = self._flux(t1, T1)
                ok = True
                break
            if not newton.linear and prev is not None and dn > REFACTOR_RATE * prev:
                solve = newton.solver(beta, T1, refresh=True)
            prev = dn
        self.stats["newton_iterations"] += it
        if not ok:
            return None
        err = None
        if Tp is not None and self.s.tolerance is not None:
            kappa = self._error_constant(kind, order, h, ca)
            d = T1[free] - Tp[free]
            err = float(np.max(np.abs(d))) * kappa / (kappa + pi) if d.size else 0.0
        return T1, F1, pieces, err, order, (kind, beta, theta, ca)

    def _accept(self, h: float, T1, F1, pieces, scheme):
        kind, beta, theta, ca = scheme
        dT = T1 - self.T
        CdT = self._CdT(dT)
        G = {}
        for k, x1 in pieces.items():
            G[k] = beta * x1 + ((1 - theta) * h * self.pieces[k] if kind == "theta" else ca * self.G[k])
        stored = float(self.c @ dT) if self.lumped else float(CdT.sum())
        into_fixed = G["fixed"] - float(CdT[self.fixed].sum())
        applied, to_space = G["applied"], G["to_space"]
        imbalance = stored - (applied - to_space - into_fixed)
        gross = abs(stored) + abs(applied) + abs(to_space) + abs(into_fixed)
        rec = self.records
        for k, v in (("t", self.t + h), ("h", h), ("stored", stored), ("applied", applied), ("to_space", to_space),
                     ("into_fixed", into_fixed), ("imbalance", imbalance), ("gross", gross)):
            rec[k].append(v)
        self.G = G
        self.t += h
        self.T, self.F, self.pieces = T1, F1, pieces
        self.dT_prev = dT
        self.h_prev = h
        self.hist.append((self.t, T1.copy()))
        self.n_steps += 1
        self.stats["steps"] += 1

    def advance(self, t_target: float) -> None:
        """Integrate up to ``t_target`` exactly (steps snapped to land on it)."""
        s = self.s
        span = s.end - s.start
        while t_target - self.t > 1e-12 * span:
            remaining = t_target - self.t
            if self.h_next is None:
                self.h_next = self._first_step(remaining)
            h_want = min(self.h_next, s.step) if (s.step is not None and s.tolerance is not None) else self.h_next
            m = int(np.ceil(remaining / h_want * (1 - 1e-9)))
            h = remaining / max(m, 1)
            out = self._step(h)
            if out is None:
                # Newton failed on this step: retry on a quarter of it (with a fixed step too: the step in the case
                # file is then the output grid and the largest step, substeps land on it)
                if h < MIN_SUBSTEP * span:
                    dn, rel = getattr(self, "_last_newton", (float("nan"), float("nan")))
                    raise Fem2TmmError(
                        f"the transient Newton iterations did not converge at t = {self.t + h:.6g} s even on a step "
                        f"of {h:.3g} s ({MIN_SUBSTEP:g} of the run): the last correction was {dn:.3g} K against "
                        f"the tolerance ({self.s.newton_rtol:g} of the step's change) and the residual "
                        f"{rel:.3g} of the step's heat terms against {STEP_RESIDUAL:g}; check the loads and "
                        "boundary temperatures for a physical solution, or give a [transient] tolerance")
                self.stats["rejected"] += 1
                self.h_next = 0.25 * h
                continue
            T1, F1, pieces, err, order, scheme = out
            if s.tolerance is not None and err is not None:
                fac = 0.9 * (s.tolerance / max(err, 1e-300)) ** (1.0 / (order + 1))
                if err > s.tolerance and h > 1e-10 * span:
                    self.stats["rejected"] += 1
                    self.h_next = h * min(0.9, max(0.2, fac))
                    continue
                # hysteresis: keep the step (and its factorisation) unless the estimate asks for a clear change
                self.h_next = h if KEEP_STEP[0] <= fac <= KEEP_STEP[1] else h * min(MAX_GROWTH, max(0.2, fac))
            elif s.tolerance is None:
                # a fixed step: back to the case's step once a subdivided one has passed (grown 4x per step)
                self.h_next = min(s.step, 4 * h) if h < s.step * (1 - 1e-9) else s.step
            else:
                self.h_next = h  # not yet enough history for an estimate: keep the step
            self._accept(h, T1, F1, pieces, scheme)

    def _first_step(self, remaining: float) -> float:
        """First step of an adaptive run: the tolerance over the initial rate of change (K/s), capped."""
        s = self.s
        cap = remaining if s.step is None else min(s.step, remaining)
        free = self.free
        c = self.c[free]
        live = c > 0
        if not live.any():
            return cap
        rate = float(np.max(np.abs(self.F[free][live] / c[live])))
        if rate <= 0:
            return cap
        return min(cap, max(0.5 * s.tolerance / rate, 1e-9 * (s.end - s.start)))

    def books(self, first: int = 0) -> tuple[dict, dict]:
        """Per-step records from step ``first`` on and their totals."""
        steps = {k: np.asarray(v[first:], float) for k, v in self.records.items()}
        # each step's gross flows, floored at the heat of a BALANCE_HEAT_REL relative change of every temperature
        # (J; float64 resolves a stored heat of ~1e-16 C T per step): a run with no flow at all, or a 1e-13 W heater
        # on a 900 J/K part at 273 K, is measured against that, not against its round-off
        gross = np.maximum(steps.pop("gross"), BALANCE_HEAT_REL * float(np.abs(self.c) @ np.abs(self.T)))
        tot = {k: float(steps[k].sum()) for k in ("stored", "applied", "to_space", "into_fixed", "imbalance")}
        g = float(gross.sum())
        tot["relative"] = abs(tot["imbalance"]) / g if g > 0 else 0.0
        rel = np.divide(np.abs(steps["imbalance"]), gross, out=np.zeros_like(gross), where=gross > 0)
        tot["max_step_relative"] = float(rel.max(initial=0.0))
        tot["steps"] = int(len(gross))
        return steps, {k + ("_J" if k not in ("relative", "max_step_relative", "steps") else ""): v
                       for k, v in tot.items()}


def initial_temperatures(problem: TransientProblem, settings: TransientSettings, initial) -> np.ndarray:
    """(n,) K: a uniform value (K), an array (n,), or ``"steady"`` (the steady solution at ``start``)."""
    n = problem.n
    if isinstance(initial, str):
        if initial != "steady":
            raise Fem2TmmError(f"[transient] initial_temperature must be a temperature or \"steady\", got {initial!r}")
        return solve_steady(problem.steady_problem(settings.start)).T
    T0 = np.broadcast_to(np.asarray(initial, float), (n,)).copy()
    return T0


def solve_transient(problem: TransientProblem, settings: TransientSettings, initial="steady") -> TransientSolution:
    """Integrate ``problem`` from ``settings.start`` to ``settings.end``.

    ``initial``: K (scalar or (n,)) or ``"steady"``.  Returns temperatures (K) at the output times (of the last
    period when ``periodic``) and the energy books of the same interval.
    """
    settings.check()
    with blas_threads(BLAS_THREADS):
        return _solve(problem, settings, initial)


def _solve(problem: TransientProblem, settings: TransientSettings, initial) -> TransientSolution:
    times = settings.output_times()
    P = settings.end - settings.start
    prob = problem.periodic(settings.start, P) if settings.periodic else problem
    T0 = initial_temperatures(prob, settings, initial)
    integ = _Integrator(prob, settings, T0, settings.start)
    # segment ends: output times, and kinks of the inputs when adaptive
    seg = times[1:]
    if settings.tolerance is not None:
        kinks = np.concatenate([prob.Q.breakpoints(settings.start, settings.end),
                                prob.T_fixed.breakpoints(settings.start, settings.end),
                                prob.T_sink.breakpoints(settings.start, settings.end)])
        seg = np.unique(np.concatenate([seg, kinks]))
    is_out = np.isin(seg, times)
    changes = []
    periods = 0
    last = None
    while True:
        offset = periods * P
        first = len(integ.records["t"])
        out = [integ.T.copy()]
        for j, te in enumerate(seg):
            integ.advance(te + offset)
            if is_out[j]:
                out.append(integ.T.copy())
            report(j + 1, len(seg), f"transient intervals, period {periods + 1}" if settings.periodic
                   else "transient intervals")
        periods += 1
        out = np.array(out)
        if not settings.periodic:
            break
        if last is not None:
            changes.append(float(np.max(np.abs(out - last))))
            if changes[-1] < settings.periodic_tolerance:
                break
        last = out
        if periods >= settings.max_periods:
            raise Fem2TmmError(f"[transient] periodic: no periodic state after {periods} periods (last change "
                               f"{changes[-1] if changes else float('nan'):.3g} K > periodic_tolerance "
                               f"{settings.periodic_tolerance} K); raise periodic_tolerance or check the model")
    steps, energy = integ.books(first)
    stats = dict(integ.stats, periods=periods, period_changes_K=changes)
    return TransientSolution(times=times, T=out, steps=steps, energy=energy, stats=stats)


@dataclass
class TransientRun:
    """The transient stage's output.

    ``times`` (n_t,) s; ``reduced`` / ``detailed`` the :class:`TransientSolution` of each model (None when not
    run); ``T_recovered`` (n_t, n_dof) K recovered on every FE DOF at every output time (None without reduced
    model); ``settings`` the :class:`TransientSettings`; ``timings`` s per part (reduced, recover, detailed).
    """

    times: np.ndarray
    settings: TransientSettings
    reduced: TransientSolution | None = None
    detailed: TransientSolution | None = None
    T_recovered: np.ndarray | None = None
    timings: dict = field(default_factory=dict)
    reduced_problem: TransientProblem | None = None  # its time-dependent inputs go into the ESATAN/SINDA decks

    @property
    def T_result(self) -> np.ndarray:
        """(n_t, n_dof) K: recovered when reduced, detailed otherwise."""
        return self.T_recovered if self.T_recovered is not None else self.detailed.T

    def accuracy(self) -> dict | None:
        """RMS and max of recovered − detailed over every DOF and output time (K), the time (s) and DOF of the
        max, and the max per output time; None without both models."""
        if self.T_recovered is None or self.detailed is None:
            return None
        err = self.T_recovered - self.detailed.T
        k = int(np.argmax(np.abs(err)))
        i, j = np.unravel_index(k, err.shape)
        return {"rms_K": float(np.sqrt(np.mean(err**2))), "max_K": float(abs(err[i, j])),
                "time_of_max_s": float(self.times[i]), "dof_of_max": int(j),
                "max_per_time_K": np.abs(err).max(axis=1)}


def recover_series(recover, T_sn: np.ndarray, q: Series | None, times: np.ndarray,
                   max_bytes: float = 256e6) -> np.ndarray:
    """Recovered detailed temperatures at several times: ``T(t) = X q(t) + Yᵀ T_SN(t)`` (n_t, n_dof).

    ``recover(T_sn (n_SN, r), q (n_dof, r)) -> (n_dof, r)`` (the reduction's ``recover``); ``T_sn`` (n_t, n_SN);
    ``q`` the detailed load series (W) or None; batches of times keep the load columns under ``max_bytes``.
    """
    T_sn = np.asarray(T_sn, float)
    times = np.asarray(times, float)
    nt = len(times)
    if q is None:
        return np.asarray(recover(T_sn.T)).T
    n = q.n
    batch = max(1, int(max_bytes // (8 * max(n, 1))))
    out = None
    for a in range(0, nt, batch):
        b = min(nt, a + batch)
        T = np.asarray(recover(T_sn[a:b].T, q.at(times[a:b]))).T
        if out is None:
            out = np.empty((nt, T.shape[1]))
        out[a:b] = T
    return out


__all__ = ["METHODS", "TransientProblem", "TransientSettings", "TransientSolution", "TransientRun", "solve_transient",
           "initial_temperatures", "recover_series"]
