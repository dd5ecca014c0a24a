"""``fem2tmm bench rom``: super nodes side by side with projection ROMs (POD-Galerkin, POD-DEIM), issue 32.

The same detailed model (fem2tmm's own FE model with its traced face-to-face exchange, the ``[reference]
detailed`` transient) is reduced three ways at equal reduced dimension r:

- **super nodes**: fem2tmm's reduction with r super nodes in all (the thesis' network: the radiation-aware one is
  steady only), its transient recovered on every FE node;
- **POD-Galerkin**: T ≈ T̄ + V y on the free nodes, V the r leading left singular vectors of the training
  snapshots (mean removed), Galerkin projection of C Ṫ = Q(t) − K T − σ g (T⁴ − T_s⁴) − σ L T⁴ with the radiation
  evaluated on the full model;
- **POD-DEIM**: the same with the T⁴ vector sampled at m = r DEIM points (u = T⁴ ≈ U (PᵀU)⁻¹ Pᵀ u, U the POD basis
  of the T⁴ snapshots), so that a step costs O(r m) instead of O(n r).

Plain numpy/scipy (no pymor: the Galerkin operators are a dozen lines here, and pymor's time steppers would not
reproduce fem2tmm's backward Euler to round-off).  Every model is integrated by backward Euler with the same fixed
step and output times as the detailed transient, so the errors are those of the reductions alone; the
detailed steady / transient solutions are fem2tmm's.

Each ROM is trained on one history (heater profile A on the composite box, the nominal orbit of the small
satellite) and tested on (a) that history, (b) another one (heater profile B; the orbit at another RAAN, β changed),
(c) a hot and a cold steady state.  Metrics as Qian et al.: node-wise error range (min, max of T_ROM − T_detailed
over nodes and times) in K, RMS in K, and Err_rms relative to absolute temperatures (RMS error / RMS T).  Offline
cost (snapshots = the training detailed transient, basis, reduction) and online cost per history, with the
speed-up against the detailed transient including and excluding training.

One JSON line per (study, method, r, test).
"""

from __future__ import annotations

import time
import tomllib
import warnings
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

REPO = Path(__file__).resolve().parents[1]
RS = (12, 24, 48, 100)
ROUNDS = 3  # interleaved rounds of the online timings
SIGMA = 5.670374419e-8


# ------------------------------------------------------------------------------------------- projection ROMs
class ProjectionROM:
    """POD-Galerkin (``deim=False``) or POD-DEIM ROM of a detailed :class:`fem2tmm.solve.transient.TransientProblem`.

    ``snapshots`` (n_t, n) K training temperatures (fixed nodes included); ``r`` basis size; ``m`` DEIM points.
    Inputs (loads, fixed temperatures, sink) are read from the problem given to :meth:`integrate` /
    :meth:`steady`, so one ROM runs any load history of the same model.
    """

    def __init__(self, problem, snapshots: np.ndarray, r: int, deim: bool = False, m: int | None = None,
                 complete: bool = False):
        from fem2tmm.solve.steady import _Operators

        t0 = time.perf_counter()
        self.fixed = np.asarray(problem.fixed, bool)
        self.f = np.flatnonzero(~self.fixed)
        self.b = np.flatnonzero(self.fixed)
        S = np.asarray(snapshots, float)
        self.mean = S.mean(axis=0)
        U, s, _ = np.linalg.svd((S[:, self.f] - self.mean[self.f]).T, full_matrices=False)
        rank = int(np.sum(s > 1e-12 * s[0])) if s.size and s[0] > 0 else 0
        # at most what the snapshots span (``complete``: completed orthonormally up to r, the full-dimension check)
        r = min(r, len(self.f)) if complete else min(r, rank)
        if r > rank:
            U = sla.qr(np.hstack([U[:, :rank], np.eye(len(self.f))]), mode="economic")[0]
        self.r = r
        self.V = U[:, :r]  # (n_f, r)
        self.ops = _Operators(problem.steady_problem(0.0))
        K = sp.csr_matrix(problem.K)
        Kff, Kfb = K[self.f][:, self.f], K[self.f][:, self.b]
        self.Kr = self.V.T @ (Kff @ self.V)
        self.k0 = self.V.T @ (Kff @ self.mean[self.f])
        self.Kb = (Kfb.T @ self.V).T if len(self.b) else np.zeros((r, 0))
        C = np.asarray(problem.C, float)
        if C.ndim != 1:
            raise ValueError("lumped capacitance expected")
        self.Cr = self.V.T @ (C[self.f, None] * self.V)
        self.g = np.asarray(problem.g_space, float)
        self.deim = deim
        if deim:
            u = S**4
            Uu, su, _ = np.linalg.svd(u.T, full_matrices=False)
            m = min(m or r, int(np.sum(su > 1e-14 * su[0])))
            self.U = Uu[:, :m]
            self.P = deim_points(self.U)
            GU = self._lin_rad(self.U)  # (n, m): σ (g u + L u)
            self.D = self.V.T @ GU[self.f] @ np.linalg.inv(self.U[self.P])  # (r, m)
            Vfull = np.zeros((len(self.mean), r))
            Vfull[self.f] = self.V
            self.VP = Vfull[self.P]  # (m, r): zero rows at fixed points
            self.meanP = self.mean[self.P]
            self.Pfixed = self.fixed[self.P]
            self.m = m
        self.offline_s = time.perf_counter() - t0

    def _lin_rad(self, u: np.ndarray) -> np.ndarray:
        """σ (g u + L u) W for T⁴ vectors u, (n,) or (n, k) (the emission to space and the face-to-face exchange,
        as fem2tmm.solve.steady's operators, for several columns at once)."""
        ops = self.ops
        g = self.g if u.ndim == 1 else self.g[:, None]
        out = g * u
        if ops.L is not None:
            out = out + ops.L @ u
        if ops.Gf is not None:
            fl = ops.face_lumped if u.ndim == 1 else ops.face_lumped[:, None]
            out = out + fl * u - ops.W.T @ (ops.Gf @ (ops.W @ u))
        return SIGMA * np.asarray(out)

    def _project_inputs(self, problem):
        """Vᵀ Q(t) as base + patterns · tables (cheap per step), fixed temperatures and sink as callables."""
        Q = problem.Q
        base = self.V.T @ Q.base[self.f]
        pats = [self.V.T @ p[self.f] for p in Q.patterns]
        tables = Q.tables
        gs = self.V.T @ self.g[self.f]  # the sink term σ g T_s⁴ projected

        def load(t):
            out = base.copy()
            for p, tb in zip(pats, tables):
                out += tb(t) * p
            return out + SIGMA * gs * problem.T_sink(t) ** 4

        return load

    def _F(self, y, t, load, Tb):
        """Projected flux Vᵀ F_f (r,) and its Jacobian (r, r)."""
        Tf = self.mean[self.f] + self.V @ y if not self.deim else None
        lin = -(self.Kr @ y + self.k0 + (self.Kb @ Tb if Tb.size else 0.0))
        if self.deim:
            TP = np.where(self.Pfixed, 0.0, self.meanP + self.VP @ y)
            if self.Pfixed.any():
                TP[self.Pfixed] = self._Tb_at_points
            nl = self.D @ TP**4
            J = -self.Kr - self.D @ (4 * TP[:, None] ** 3 * self.VP)
            return load(t) + lin - nl, J
        T = self.mean.copy()
        T[self.f] = Tf
        if Tb.size:
            T[self.b] = Tb
        R = self._lin_rad(T**4)
        nl = self.V.T @ R[self.f]
        X = np.zeros((len(self.mean), self.r))
        X[self.f] = 4 * T[self.f, None] ** 3 * self.V
        J = -self.Kr - self.V.T @ self._lin_rad(X)[self.f]
        return load(t) + lin - nl, J

    def _fixed(self, problem, t):
        Tb = problem.T_fixed(t)[self.b] if len(self.b) else np.zeros(0)
        if self.deim and self.Pfixed.any():
            self._Tb_at_points = problem.T_fixed(t)[self.P[self.Pfixed]]
        return Tb

    def steady(self, problem, t: float, y0=None, tol=1e-9) -> np.ndarray:
        """Steady full-length temperatures (n,) K with the inputs at time t."""
        load = self._project_inputs(problem)
        Tb = self._fixed(problem, t)
        y = np.zeros(self.r) if y0 is None else y0.copy()
        for _ in range(100):
            F, J = self._F(y, t, load, Tb)
            dy = np.linalg.solve(J, -F)
            y += dy
            if np.abs(self.V @ dy).max(initial=0.0) < tol:
                break
        return self.full(y, problem, t), y

    def integrate(self, problem, times: np.ndarray, h: float, y0: np.ndarray) -> np.ndarray:
        """Backward Euler with step ≈ h landing on every output time; (n_t, n) K."""
        load = self._project_inputs(problem)
        y = y0.copy()
        out = [self.full(y, problem, times[0])]
        t = times[0]
        for te in times[1:]:
            k = max(int(np.ceil((te - t) / h * (1 - 1e-9))), 1)
            hs = (te - t) / k
            for _ in range(k):
                t1 = t + hs
                Tb = self._fixed(problem, t1)
                y1 = y.copy()
                A = self.Cr / hs
                for _ in range(30):
                    F, J = self._F(y1, t1, load, Tb)
                    R = A @ (y1 - y) - F
                    dy = np.linalg.solve(A - J, -R)
                    y1 += dy
                    if np.abs(dy).max(initial=0.0) < 1e-11 * (1 + np.abs(y1).max(initial=0.0)):
                        break
                y, t = y1, t1
            out.append(self.full(y, problem, te))
        return np.array(out)

    def full(self, y, problem, t) -> np.ndarray:
        T = self.mean.copy()
        T[self.f] += self.V @ y
        if len(self.b):
            T[self.b] = problem.T_fixed(t)[self.b]
        return T


def deim_points(U: np.ndarray) -> np.ndarray:
    """Greedy DEIM interpolation indices (m,) of a basis U (n, m) (Chaturantabut & Sorensen 2010, Algorithm 1)."""
    n, m = U.shape
    P = [int(np.argmax(np.abs(U[:, 0])))]
    for j in range(1, m):
        c = np.linalg.solve(U[P, :j], U[P, j])
        res = U[:, j] - U[:, :j] @ c
        res[P] = 0.0
        P.append(int(np.argmax(np.abs(res))))
    return np.array(P, np.int64)


# ------------------------------------------------------------------------------------------------ studies
def _capture_runs(case, mesh=None):
    """Run ``case`` (on ``mesh``, or its own) through the pipeline; (result, (detailed TransientProblem, settings,
    solution) or None)."""
    import fem2tmm.stages.transient as stages
    from fem2tmm.pipeline import run

    seen = {}
    real, real_rec = stages.solve_transient, stages.recover_series

    def spy(prob, settings, initial="steady"):
        sol = real(prob, settings, initial)
        seen.setdefault("calls", []).append((prob, settings, sol, initial))
        return sol

    def spy_rec(*args, **kw):
        seen["recover"] = (args, kw)
        return real_rec(*args, **kw)

    stages.solve_transient, stages.recover_series = spy, spy_rec
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = run(case, mesh=mesh, cache=False)  # every run pays its own offline stages
    finally:
        stages.solve_transient, stages.recover_series = real, real_rec
    det = None
    online = None  # the reduced network's transient and its recovery, to be timed again: a callable
    if res.model is not None:
        for prob, settings, sol, initial in seen.get("calls", []):
            if prob.n == res.model.n_dof:
                det = (prob, settings, sol)
                res.detailed_again = lambda prob=prob, settings=settings, initial=initial: real(prob, settings,
                                                                                                initial)
            elif "recover" in seen:
                args, kw = seen["recover"]

                def online(prob=prob, settings=settings, initial=initial, args=args, kw=kw):
                    real(prob, settings, initial)
                    real_rec(*args, **kw)
    res.online = online
    return res, det


def _rounds(fns: dict, rounds: int = ROUNDS) -> dict:
    """Median wall time (s) of each callable over ``rounds`` interleaved rounds (a shared machine)."""
    times = {k: [] for k in fns}
    for _ in range(rounds):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: float(np.median(v)) for k, v in times.items()}


def _integrate_periodic(rom, prob, times, h, y0, tol, max_periods=30):
    """The ROM along a periodic history until two successive periods agree within ``tol`` K: (outputs of the last
    period (n_t, n), periods, wall s)."""
    P = times[-1] - times[0]
    pp = prob.periodic(times[0], P)
    last, y = None, y0
    t0 = time.perf_counter()
    for k in range(max_periods):
        out = rom.integrate(pp, times + k * P, h, y)
        y = np.linalg.lstsq(rom.V, out[-1][rom.f] - rom.mean[rom.f], rcond=None)[0]
        if last is not None and np.abs(out - last).max() < tol:
            break
        last = out
    return out, k + 1, time.perf_counter() - t0


def _sn_counts(base: list[int], r: int) -> list[int]:
    """Super nodes per part for r in all: one each, the rest in proportion to ``base`` - 1 (largest remainders)."""
    extra = np.array(base, float) - 1
    q = (r - len(base)) * extra / extra.sum()
    n = np.floor(q).astype(int)
    for i in np.argsort(-(q - n), kind="stable")[: r - len(base) - n.sum()]:
        n[i] += 1
    return [int(x) + 1 for x in n]


def _smallsat(raan: float, r: int | None, detailed: bool):
    from fem2tmm.case import Case

    folder = REPO / "examples" / "smallsat"
    raw = tomllib.loads((folder / "case_transient.toml").read_text())
    raw["orbit"]["raan"] = raan
    raw["orbit"]["rays_per_face"] = 50
    raw["radiation"]["rays_per_face"] = 500
    raw["reference"] = {"detailed": detailed, "rays_per_face": 60, "noise": False}
    if r is not None:
        for part, n in zip(raw["parts"], _sn_counts([p["super_nodes"] for p in raw["parts"]], r)):
            part["super_nodes"] = n
    raw["transient"] = {"periodic": True, "step": SAT_STEP, "method": "backward-euler", "output_every": SAT_STEP,
                        "periodic_tolerance": SAT_PERIODIC}
    return Case.from_dict(raw, base_dir=folder)


SAT_STEP, SAT_PERIODIC = 60.0, 0.05
RAAN_A, RAAN_B = 247.5, 277.5  # the example's 10:30 orbit (β +17°) and the same orbit 30° of RAAN later


def bench_rom_smallsat(rs=RS) -> list[dict]:
    """examples/smallsat along its periodic orbit: trained on RAAN 247.5°, tested on it, on RAAN 277.5° (β changed),
    and on the steady states at the hottest and the coldest instant of the training orbit."""
    from fem2tmm.solve.steady import solve_steady

    rows = []
    t0 = time.perf_counter()
    resA, (probA, setA, solA) = _capture_runs(_smallsat(RAAN_A, None, True))
    t_train = time.perf_counter() - t0
    t_detA = resA.transient.timings.get("detailed", float("nan"))
    resB, (probB, setB, solB) = _capture_runs(_smallsat(RAAN_B, None, True))
    model = resA.model
    ok = model.node_dof >= 0
    times = solA.times

    def nodes(T):
        return np.array([model.node_temperatures(x) for x in np.atleast_2d(T)])

    T_ref = {"A": nodes(solA.T), "B": nodes(solB.T)}
    load = probA.Q.at(times).sum(axis=0)
    steady_ref = {name: (float(times[i]), solve_steady(probA.steady_problem(float(times[i]))).T)
                  for name, i in (("hot", int(np.argmax(load))), ("cold", int(np.argmin(load))))}
    common = {"bench": "rom", "study": "smallsat periodic orbit", "n_dof": int(probA.n),
              "detailed_transient_s": round(t_detA, 2), "detailed_periods": solA.stats["periods"]}
    timers = {"detailed": resA.detailed_again}
    for r in rs:
        for hist, raan in (("A (training orbit)", RAAN_A), ("B (RAAN +30 deg)", RAAN_B)):
            res = _super_node_transient(_smallsat(raan, r, False), hist, T_ref[hist[0]], common, rows, timers,
                                        nodes, ok)
            if hist.startswith("A"):
                red = res.transient.reduced_problem
                for name, (t, Tref) in steady_ref.items():
                    T_sn = solve_steady(red.steady_problem(t)).T
                    T = np.asarray(res.reduced.network.reduction.recover(T_sn[:, None], probA.Q(t)[:, None]))[:, 0]
                    rows.append({**common, "method": "super nodes", "r": int(len(res.reduced.network.names)),
                                 "test": f"steady {name}", **_errors(model.node_temperatures(T),
                                                                     model.node_temperatures(Tref), ok)})
        for deim in (False, True):
            label = "POD-DEIM" if deim else "POD-Galerkin"
            rom = ProjectionROM(probA, solA.T, r, deim=deim)
            for hist, prob in (("A (training orbit)", probA), ("B (RAAN +30 deg)", probB)):
                _, y0 = rom.steady(prob, times[0])  # its own steady state at the start, as fem2tmm's runs
                T, periods, online = _integrate_periodic(rom, prob, times, SAT_STEP, y0, SAT_PERIODIC)
                if hist.startswith("A"):
                    timers[(label, rom.r)] = (lambda rom=rom, y0=y0.copy():
                                              _integrate_periodic(rom, probA, times, SAT_STEP, y0, SAT_PERIODIC))
                rows.append({**common, "method": label, "r": rom.r, **({"m": rom.m} if deim else {}),
                             "test": hist, **_errors(nodes(T), T_ref[hist[0]], ok), "periods": periods,
                             **_costs(online, rom.offline_s, t_train)})
            for name, (t, Tref) in steady_ref.items():
                T, _ = rom.steady(probA, t)
                rows.append({**common, "method": label, "r": rom.r, "test": f"steady {name}",
                             **_errors(model.node_temperatures(T), model.node_temperatures(Tref), ok)})
    return _timed(rows, timers)


def _composite(profile: list, n_sn: int | None, detailed: bool, steady_heater: float | None = None,
               aware: bool = False):
    from fem2tmm.case import Case

    folder = REPO / "examples" / "composite"
    raw = tomllib.loads((folder / "case.toml").read_text())
    if not aware:  # the radiation-aware reduction (the example's own) is steady only
        raw["reduction"] = {"radiation_aware": False}
        raw["radiation"].pop("ir_on", None)
    raw["radiation"]["rays_per_face"] = 500
    raw["reference"] = {"detailed": detailed, "rays_per_face": 60, "noise": False}
    if n_sn is not None:
        raw["parts"][0]["super_nodes"] = max(n_sn - 1, 1)  # the deck is one more (held)
    heater = next(b for b in raw["boundary"] if b["name"] == "heater")
    if steady_heater is None:
        heater["value"] = profile
        raw["transient"] = {"end": PROFILE_END, "step": STEP, "method": "backward-euler",
                            "initial_temperature": "steady", "output_every": OUTPUT_EVERY}
    else:
        heater["value"] = steady_heater
    return Case.from_dict(raw, base_dir=folder)


# heater profiles (W): A trains, B tests
PROFILE_END, STEP, OUTPUT_EVERY = 7200.0, 30.0, 120.0
PROFILE_A = [[0.0, 30.0], [1800.0, 30.0], [1800.1, 0.0], [3600.0, 0.0], [3600.1, 60.0], [5400.0, 60.0],
             [5400.1, 15.0], [7200.0, 15.0]]
PROFILE_B = [[0.0, 10.0], [2400.0, 50.0], [3000.0, 50.0], [3000.1, 5.0], [7200.0, 45.0]]
STEADY = {"hot": 60.0, "cold": 0.0}


def _errors(T, T_ref, ok=None) -> dict:
    e = T - T_ref
    if ok is not None:
        e, T_ref = e[..., ok], T_ref[..., ok]
    return {"err_min_K": float(e.min()), "err_max_K": float(e.max()), "rms_K": float(np.sqrt(np.mean(e**2))),
            "max_abs_K": float(np.abs(e).max()),
            "err_rms_relative": float(np.sqrt(np.mean(e**2)) / np.sqrt(np.mean(T_ref**2)))}


def bench_rom(rs=RS) -> list[dict]:
    """The composite box with heater profiles (train A, test A, B, steady hot / cold) at r in ``rs``."""
    from fem2tmm.solve.steady import solve_steady

    rows = []
    # the detailed model and its transients (training = profile A)
    t0 = time.perf_counter()
    resA, detA = _capture_runs(_composite(PROFILE_A, 12, True))
    t_train = time.perf_counter() - t0
    probA, setA, solA = detA
    t_detA = resA.transient.timings.get("detailed", float("nan"))
    resB, detB = _capture_runs(_composite(PROFILE_B, 12, True))
    probB, setB, solB = detB
    t_detB = resB.transient.timings.get("detailed", float("nan"))
    model = resA.model
    ok = model.node_dof >= 0
    times = solA.times

    def nodes(T):  # (n_t, n_dof) -> (n_t, n_nodes)
        return np.array([model.node_temperatures(x) for x in np.atleast_2d(T)])

    T_refA, T_refB = nodes(solA.T), nodes(solB.T)
    # steady hot / cold: the detailed steady of the same model with the heater held
    steady_ref = {}
    for name, t in (("hot", 4500.0), ("cold", 2700.0)):  # profile A holds 60 W at 4500 s and 0 W at 2700 s
        steady_ref[name] = (t, solve_steady(probA.steady_problem(t)).T)
    common = {"bench": "rom", "study": "composite heater profile", "n_dof": int(probA.n),
              "detailed_transient_s": {"A": round(t_detA, 2), "B": round(t_detB, 2)}}
    timers = {"detailed": resA.detailed_again}
    for r in rs:
        # super nodes: fem2tmm's reduced transient (profile A, B) and steady hot / cold, all recovered
        for hist, prof, T_ref in (("A (training history)", PROFILE_A, T_refA), ("B", PROFILE_B, T_refB)):
            _super_node_transient(_composite(prof, r, False), hist, T_ref, common, rows, timers, nodes, ok)
        for name, (t, Tref) in steady_ref.items():
            for aware in (False, True):
                res, _ = _capture_runs(_composite(None, r, False, steady_heater=STEADY[name], aware=aware))
                rows.append({**common, "method": "super nodes" + (" (radiation-aware)" if aware else ""),
                             "r": int(len(res.reduced.network.names)), "test": f"steady {name}",
                             **_errors(model.node_temperatures(res.reduced.T_recovered), model.node_temperatures(Tref),
                                       ok)})
        for deim in (False, True):
            label = "POD-DEIM" if deim else "POD-Galerkin"
            rom = ProjectionROM(probA, solA.T, r, deim=deim)
            y0 = np.linalg.lstsq(rom.V, solA.T[0][rom.f] - rom.mean[rom.f], rcond=None)[0]
            for hist, prob, T_ref, sol in (("A (training history)", probA, T_refA, solA), ("B", probB, T_refB, solB)):
                # the start: the ROM's own steady state at t = 0 (as the detailed run starts from its own)
                _, y0 = rom.steady(prob, times[0], y0)
                t0 = time.perf_counter()
                T = rom.integrate(prob, times, STEP, y0)
                online = time.perf_counter() - t0
                if hist.startswith("A"):
                    timers[(label, rom.r)] = lambda rom=rom, y0=y0.copy(): rom.integrate(probA, times, STEP, y0)
                rows.append({**common, "method": label, "r": rom.r, **({"m": rom.m} if deim else {}),
                             "test": hist, **_errors(nodes(T), T_ref, ok),
                             **_costs(online, rom.offline_s, t_train)})
            for name, (t, Tref) in steady_ref.items():
                T, _ = rom.steady(probA, t, y0)
                rows.append({**common, "method": label, "r": rom.r, "test": f"steady {name}",
                             **_errors(model.node_temperatures(T), model.node_temperatures(Tref), ok)})
    return _timed(rows, timers)


def _costs(online: float, offline: float, training: float) -> dict:
    """The cost fields of a transient row (s); the speed-ups are :func:`_timed`'s, from interleaved rounds."""
    return {"online_s": round(online, 3), "offline_s": round(offline, 2), "training_s": round(training, 1)}


def _super_node_transient(case, hist: str, T_ref: np.ndarray, common: dict, rows: list, timers: dict, nodes, ok):
    """Run ``case`` with super nodes, append its row for history ``hist`` (errors against ``T_ref`` (n_t, n_nodes)
    K), register its online part for the timing rounds when ``hist`` is the training one; the run's result."""
    t0 = time.perf_counter()
    res, _ = _capture_runs(case)
    wall = time.perf_counter() - t0
    online = res.transient.timings.get("reduced", 0.0) + res.transient.timings.get("recover", 0.0)
    r = int(len(res.reduced.network.names))
    if hist.startswith("A"):
        timers[("super nodes", r)] = res.online
    rows.append({**common, "method": "super nodes", "r": r, "test": hist,
                 **_errors(nodes(res.transient.T_recovered), T_ref, ok), **_costs(online, wall - online, 0.0)})
    return res


def _timed(rows: list[dict], timers: dict) -> list[dict]:
    """The online costs of history A again, as medians of interleaved rounds with the detailed transient (the
    baseline of the speed-ups, measured in the same rounds): patched into the "A" rows."""
    med = _rounds(timers)
    base = med.pop("detailed")
    for row in rows:
        key = (row["method"], row["r"])
        if row["test"].startswith("A") and key in med:
            on = med[key]
            train = row.get("training_s", 0.0)
            row.update(online_s=round(on, 3), detailed_transient_median_s=round(base, 2), timing="median of "
                       f"{ROUNDS} interleaved rounds", speedup_excl_training=round(base / max(on, 1e-9), 1),
                       speedup_incl_training=round(base / max(on + row.get("offline_s", 0.0) + train, 1e-9), 2))
        elif "online_s" in row:  # the other histories: one run each, no speed-up claimed
            row["timing"] = "one run"
    return rows


PROPERTIES = [
    {"property": "physical network exportable to ESATAN/SINDA", "super nodes": "yes (GL, GR, C, QI)",
     "POD-Galerkin": "no (dense r x r operators, full-order radiation)", "POD-DEIM": "no"},
    {"property": "energy conservation", "super nodes": "yes (balances to 1e-9)",
     "POD-Galerkin": "only in the projected sense", "POD-DEIM": "no (interpolated emission)"},
    {"property": "exact steady state for a new load", "super nodes": "exact for conduction (any load)",
     "POD-Galerkin": "only within the trained span", "POD-DEIM": "only within the trained span"},
    {"property": "coupling to other spacecraft nodes", "super nodes": "yes (nodes with names and numbers)",
     "POD-Galerkin": "no", "POD-DEIM": "no"},
]


def bench_rom_all(rs=RS) -> list[dict]:
    """Both studies (``fem2tmm bench rom``) and the structural properties."""
    rows = bench_rom(rs) + bench_rom_smallsat(rs)
    return rows + [{"bench": "rom", "table": "properties", **p} for p in PROPERTIES]
