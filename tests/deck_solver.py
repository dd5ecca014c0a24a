"""An independent reader and solver of the ESATAN and SINDA/FLUINT decks fem2tmm writes, for the tests.

Own code: nothing here imports fem2tmm, so a deck that fem2tmm writes, edits as an engineer would, and this module
solves is checked against a solver that shares no code with the run (issue 41).

ESATAN subset read
------------------
- comments ``#`` to the end of the line; statements end at ``;`` and continue over any number of lines;
- ``$NODES``: ``D12 = 'label', T = expr, C = expr, A = expr, ALP = expr, EPS = expr, QI = expr;`` (kinds D, B; X
  nodes are dropped; QS, QA, QE, QR add to QI);
- ``$CONDUCTORS``: ``GL(a, b) = expr;`` / ``GR(a, b) = expr;`` (parallel conductors add up);
- ``$CONSTANTS`` / ``$LOCALS`` (``$REAL``, ``$INTEGER``, ``$CONTROL``): ``NAME = expr;`` in any order;
- ``$ARRAYS``: ``NAME(n) = v1, v2, ...;`` or ``NAME(2, k) = ...;`` (doublet arrays x1, y1, x2, y2, ...);
- ``$VARIABLES1``: ``QI12 = expr;`` ``QI(12) = expr;`` ``T12 = expr;`` ``GL(a, b) = expr;`` ``GR(a, b) = expr;`` and
  ``NAME = expr;`` executed in order at every evaluation of the network (every Newton iterate of a steady solution,
  every time level of a transient);
- expressions: numbers (Fortran ``D`` exponents), constants, node temperatures ``T12`` (degC, as in ESATAN with
  TABS = 273.15), ``TIMEM`` / ``TIMEN`` (the time of the evaluation), ``+ - * / **``, parentheses, SQRT EXP LOG
  LOG10 SIN COS TAN ABS MIN MAX, and ``INTRP1(x, ARRAY)`` (linear interpolation in a doublet array, constant
  outside its range) of any expression x;
- ``$EXECUTION``: the solver called (``SOLVFM`` / ``SOLVIT`` steady; ``SLCRNC`` / ``SLFWBK`` Crank-Nicolson,
  ``SLGEAR`` fixed-step BDF2 here) and the control constants TIMEO, TIMEND, DTIMEI, OUTINT, STEFAN, TABS.

Equations (SI, kelvin inside): at every diffusion node i,
``C_i dT_i/dt = QI_i + sum_j GL_ij (T_j - T_i) + STEFAN sum_j GR_ij (T_j^4 - T_i^4)``; boundary nodes (B) hold their
temperature (``T12 = ...`` in ``$VARIABLES1`` sets it); diffusion nodes with C = 0 are arithmetic nodes (balance at
every time).  Steady: Newton on the balance, the ``$VARIABLES1`` terms re-evaluated at every iterate (Picard on
them).  Transient: the theta scheme ``C (T1 - T0) = h [theta F(t1, T1) + (1 - theta) F(t0, T0)]`` (theta = 1/2 for
SLCRNC / SLFWBK, 1 for backward Euler) or BDF2, fixed steps DTIMEI cut to land on every output time, each
nonlinear step solved by Newton with ``$VARIABLES1`` re-evaluated at the iterate (the temperature-dependent terms
follow the state).

Interface (what the tests call)::

    solve_esatan_steady(path, edits={"HEATER": 0.0}) -> {node number: T degC}
    solve_esatan_transient(path, edits, times) -> (times, {node number: T degC array})
    solve_sinda_steady(path, edits) -> {node number: T degC}
    solve_sinda_transient(path, edits, times) -> (times, {node number: T degC array})

The SINDA/FLUINT subset (:func:`read_sinda`) is read into the same model: registers are the named constants,
SOURCE DATA and VARIABLES 1 ``Q12 = ...`` the loads, ``D1DEG1`` is INTRP1, FWDBCK is Crank-Nicolson.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

STEFAN_DEFAULT = 5.670374419e-8
TABS_DEFAULT = 273.15


class DeckError(ValueError):
    """The deck has a statement this reader does not understand (message: file:line and the statement)."""


# ------------------------------------------------------------------------------------------------ expressions
_FUNCS = {"SQRT": math.sqrt, "EXP": math.exp, "LOG": math.log, "LOG10": math.log10, "SIN": math.sin,
          "COS": math.cos, "TAN": math.tan, "ABS": abs, "MIN": min, "MAX": max}
_TOKEN = re.compile(r"\s*(?:(\d+\.?\d*(?:[eEdD][-+]?\d+)?|\.\d+(?:[eEdD][-+]?\d+)?)|([A-Za-z_][A-Za-z0-9_]*)|"
                    r"(\*\*|[-+*/(),]))")


def _intrp1(x: float, a: np.ndarray) -> float:
    """ESATAN's INTRP1: linear interpolation in the doublet array a = (x1, y1, x2, y2, ...), constant outside."""
    return float(np.interp(x, a[0::2], a[1::2]))


def translate(text: str, where: str) -> tuple[str, set, set, bool]:
    """Python source of a deck expression and (constants used, node numbers whose T is used, uses time).

    Names resolve at evaluation through ``_c`` (constants), ``_T`` (node temperature degC by number), ``_A``
    (arrays) and ``_t`` (time)."""
    out, consts, temps, timed = [], set(), set(), False
    pos, s = 0, text.strip()
    prev_name = None
    while pos < len(s):
        m = _TOKEN.match(s, pos)
        if not m or m.end() == pos:
            raise DeckError(f"{where}: cannot read {s[pos:pos + 40]!r} in {s[:80]!r}")
        pos = m.end()
        num, name, op = m.groups()
        if num is not None:
            out.append(repr(float(re.sub("[dD]", "e", num))))
            prev_name = None
        elif name is not None:
            up = name.upper()
            nxt = s[pos:].lstrip()[:1]
            if nxt == "(":
                if up == "INTRP1":
                    out.append("_I")
                elif up in _FUNCS:
                    out.append(f"_F[{up!r}]")
                else:
                    raise DeckError(f"{where}: unknown function {name!r} in {s[:80]!r}")
            elif prev_name == "INTRP1-ARG2":
                out.append(f"_A[{up!r}]")
            elif up in ("TIMEM", "TIMEN"):
                out.append("_t")
                timed = True
            else:
                mt = re.fullmatch(r"T(\d+)", up)
                if mt:
                    out.append(f"_T({int(mt.group(1))})")
                    temps.add(int(mt.group(1)))
                else:
                    out.append(f"_c[{up!r}]")
                    consts.add(up)
            prev_name = up
            continue
        else:
            out.append(op)
            prev_name = None
        # the second argument of INTRP1 is an array name: mark it
        if op == ",":
            depth, k = 0, len(out) - 2
            while k >= 0:  # find the call this comma belongs to
                if out[k] == ")":
                    depth += 1
                elif out[k] == "(":
                    if depth == 0:
                        break
                    depth -= 1
                k -= 1
            if k >= 1 and out[k - 1] == "_I":
                prev_name = "INTRP1-ARG2"
    src = " ".join(out)
    try:
        compile(src, where, "eval")
    except SyntaxError:
        raise DeckError(f"{where}: cannot read the expression {s[:80]!r}") from None
    return src, consts, temps, timed


@dataclass
class Expr:
    src: str
    consts: set
    temps: set
    timed: bool
    code: object = None

    def __post_init__(self):
        self.code = compile(self.src, "<deck>", "eval")

    @property
    def dynamic(self) -> bool:
        return bool(self.temps) or self.timed


def expr(text: str, where: str) -> Expr:
    return Expr(*translate(text, where))


# ------------------------------------------------------------------------------------------------ statements
def _strip_comment(line: str) -> str:
    out, quote = [], None
    for ch in line:
        if quote:
            out.append(ch)
            if ch == quote:
                quote = None
            continue
        if ch == "#":
            break
        if ch in "'\"":
            quote = ch
        out.append(ch)
    return "".join(out)


def esatan_statements(text: str, name: str):
    """(block, line, statement) of an ESATAN deck: comments removed, statements joined over lines up to ``;``."""
    block, buf, start = None, [], None
    for no, raw in enumerate(text.splitlines(), 1):
        line = _strip_comment(raw).strip()
        if not line:
            continue
        if not buf and line.startswith("$"):
            word = line[1:].split()[0].upper()
            if word not in ("REAL", "INTEGER", "CONTROL", "CHARACTER"):
                block = word
            continue
        if block in ("EXECUTION", "OUTPUTS", "SUBROUTINES", "INITIAL", "VARIABLES2", "EVENTS") and not buf:
            # Fortran-like blocks: one statement a line, ';' optional
            yield block, no, line.rstrip(";").strip()
            continue
        if start is None:
            start = no
        buf.append(line)
        joined = " ".join(buf)
        if ";" in _quoted_free(joined):
            parts = _split_semicolons(joined)
            for p in parts[:-1]:
                if p.strip():
                    yield block, start, p.strip()
            rest = parts[-1].strip()
            buf, start = ([rest], no) if rest else ([], None)
    if buf:
        raise DeckError(f"{name}:{start}: statement {' '.join(buf)[:60]!r} is not terminated by ';'")


def _quoted_free(s: str) -> str:
    return re.sub(r"'[^']*'|\"[^\"]*\"", "", s)


def _split_semicolons(s: str) -> list[str]:
    out, cur, quote = [], [], None
    for ch in s:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
            cur.append(ch)
        elif ch == ";":
            out.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    return out + ["".join(cur)]


def _split_top(text: str) -> list[str]:
    out, depth, quote, cur = [], 0, None, []
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
            continue
        if ch in "'\"":
            quote = ch
        elif ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append("".join(cur))
            cur = []
            continue
        cur.append(ch)
    return out + ["".join(cur)]


# ------------------------------------------------------------------------------------------------ the model
@dataclass
class Model:
    """A thermal network read from a deck; evaluate it with :meth:`state`."""

    source: str
    numbers: np.ndarray                      # (n,) node numbers
    labels: list
    boundary: np.ndarray                     # (n,) bool
    node_exprs: list                         # per node {KEY: Expr}
    cond: list                               # (kind 'GL'/'GR', a, b, Expr) of the conductor block
    variables1: list                         # (target kind, key, Expr) in order
    definitions: dict                        # NAME -> expression text
    arrays: dict                             # NAME -> np.ndarray
    calls: list = field(default_factory=list)  # the solution routines $EXECUTION calls, in order
    notes: list = field(default_factory=list)

    @property
    def solver(self) -> str:
        """The transient routine called (the last one of :data:`SCHEMES`), else the last steady one ("" if none)."""
        tr = [c for c in self.calls if c in SCHEMES]
        return tr[-1] if tr else (self.calls[-1] if self.calls else "")

    @property
    def steady_start(self) -> bool:
        """A steady solution precedes the transient routine (the transient starts from it)."""
        k = self.calls.index(self.solver) if self.solver in self.calls else 0
        return any(c.startswith("SOLV") for c in self.calls[:k])

    def index(self) -> dict:
        return {int(k): i for i, k in enumerate(self.numbers)}


def _resolve(definitions: dict, edits: dict | None, name: str) -> dict:
    """Values of the named constants, ``edits`` replacing definitions (names are case-insensitive)."""
    defs = dict(definitions)
    for k, v in (edits or {}).items():
        if k.upper() not in defs:
            raise DeckError(f"{name}: the deck has no constant {k!r} to edit")
        defs[k.upper()] = repr(float(v))
    values: dict = {}
    pending = {k: expr(v, f"{name}: constant {k}") for k, v in defs.items()}
    while pending:
        done = [k for k, e in pending.items() if e.consts <= values.keys() and not e.dynamic]
        if not done:
            raise DeckError(f"{name}: constants {sorted(pending)[:5]} refer to undefined names or to each other")
        for k in done:
            values[k] = float(eval(pending.pop(k).code, {"__builtins__": {}}, {"_c": values}))
    return values


def read_esatan(path: str | Path) -> Model:
    """Read an ESATAN deck (the subset in the module docstring)."""
    path = Path(path)
    text = path.read_text(encoding="utf-8", errors="replace")
    name = str(path)
    nodes, cond, var1, defs, arrays_txt, calls = [], [], [], {}, {}, []
    for block, line, s in esatan_statements(text, name):
        where = f"{name}:{line}"
        if block in ("CONSTANTS", "LOCALS"):
            m = re.match(r"^([A-Za-z_]\w*)\s*=\s*(.+)$", s, re.S)
            if not m:
                raise DeckError(f"{where}: cannot read the constant {s[:60]!r}")
            defs[m.group(1).upper()] = m.group(2)
        elif block == "NODES":
            m = re.match(r"^([A-Za-z])\s*(\d+)\s*=\s*(.*)$", s, re.S)
            if not m:
                raise DeckError(f"{where}: cannot read the node {s[:60]!r}")
            kind, num = m.group(1).upper(), int(m.group(2))
            parts = [p.strip() for p in _split_top(m.group(3))]
            label = parts.pop(0).strip("'\"") if parts and parts[0][:1] in "'\"" else ""
            attrs = {}
            for p in parts:
                if not p:
                    continue
                key, val = (t.strip() for t in p.split("=", 1))
                attrs[key.upper()] = expr(val, f"{where}: node {num} {key}")
            if kind != "X":
                nodes.append((kind, num, label, attrs))
        elif block == "CONDUCTORS":
            m = re.match(r"^G([LR])\s*\(\s*(\d+)\s*,\s*(\d+)\s*\)\s*=\s*(.+)$", s, re.S | re.I)
            if not m:
                raise DeckError(f"{where}: cannot read the conductor {s[:60]!r}")
            cond.append(("G" + m.group(1).upper(), int(m.group(2)), int(m.group(3)),
                         expr(m.group(4), f"{where}: conductor")))
        elif block == "ARRAYS":
            m = re.match(r"^([A-Za-z_]\w*)\s*\(\s*(\d+)\s*(?:,\s*(\d+)\s*)?\)\s*=\s*(.+)$", s, re.S)
            if not m:
                raise DeckError(f"{where}: cannot read the array {s[:60]!r}")
            size = int(m.group(2)) * (int(m.group(3)) if m.group(3) else 1)
            arrays_txt[m.group(1).upper()] = (size, _split_top(m.group(4)), where)
        elif block == "VARIABLES1":
            m = re.match(r"^(QI|T)\s*(?:\(\s*(\d+)\s*\)|(\d+))\s*=\s*(.+)$", s, re.S | re.I)
            if m:
                var1.append((m.group(1).upper(), int(m.group(2) or m.group(3)), expr(m.group(4), where)))
                continue
            m = re.match(r"^G([LR])\s*\(\s*(\d+)\s*,\s*(\d+)\s*\)\s*=\s*(.+)$", s, re.S | re.I)
            if m:
                var1.append(("G" + m.group(1).upper(), (int(m.group(2)), int(m.group(3))), expr(m.group(4), where)))
                continue
            m = re.match(r"^([A-Za-z_]\w*)\s*=\s*(.+)$", s, re.S)
            if not m:
                raise DeckError(f"{where}: cannot read the $VARIABLES1 statement {s[:60]!r}")
            var1.append(("NAME", m.group(1).upper(), expr(m.group(2), where)))
        elif block == "EXECUTION":
            m = re.match(r"^CALL\s+([A-Za-z]\w*)", s, re.I)
            if m and m.group(1).upper().startswith(("SOLV", "SL")):
                calls.append(m.group(1).upper())
        elif block in ("MODEL", "ENDMODEL", "OUTPUTS", "SUBROUTINES", "INITIAL", "VARIABLES2", "EVENTS"):
            continue
        else:
            raise DeckError(f"{where}: statement in block ${block} not read: {s[:60]!r}")
    consts = _resolve(defs, None, name)
    arrays = {}
    for k, (size, items, where) in arrays_txt.items():
        vals = [float(eval(expr(v, where).code, {"__builtins__": {}}, {"_c": consts})) for v in items if v.strip()]
        if len(vals) != size:
            raise DeckError(f"{where}: array {k} declares {size} values and gives {len(vals)}")
        arrays[k] = np.array(vals)
    return Model(source=name, numbers=np.array([nd[1] for nd in nodes], np.int64), labels=[nd[2] for nd in nodes],
                 boundary=np.array([nd[0] == "B" for nd in nodes]), node_exprs=[nd[3] for nd in nodes], cond=cond,
                 variables1=var1, definitions=defs, arrays=arrays, calls=calls)


# ------------------------------------------------------------------------------------------------ evaluation
class Network:
    """The model's equations with the constants resolved (``edits`` applied): :meth:`evaluate` gives QI, the
    boundary temperatures and the conductor matrices at a time and a temperature state."""

    def __init__(self, model: Model, edits: dict | None = None):
        self.m = model
        self.c = _resolve(model.definitions, edits, model.source)
        self.stefan = self.c.get("STEFAN", STEFAN_DEFAULT)
        self.tabs = self.c.get("TABS", TABS_DEFAULT)
        self.idx = model.index()
        self.n = len(model.numbers)
        ev = self._static
        get = lambda key: np.array([ev(a[key]) if key in a else 0.0 for a in model.node_exprs])  # noqa: E731
        self.T_start = get("T") + self.tabs
        self.C = get("C")
        self.Q_nodes = sum(get(k) for k in ("QI", "QS", "QA", "QE", "QR"))
        self.Q_other = self.Q_nodes - get("QI")  # QS, QA, QE, QR: not replaced by a QI assignment
        rows = {"GL": ([], [], []), "GR": ([], [], [])}
        self.dyn_cond = []
        for kind, a, b, e in model.cond:
            ia, ib = self._node(a), self._node(b)
            if e.dynamic:
                self.dyn_cond.append((kind, ia, ib, e))
            else:
                r = rows[kind]
                r[0].append(ia)
                r[1].append(ib)
                r[2].append(ev(e))
        self.G0 = {k: self._sym(*v) for k, v in rows.items()}

    def _node(self, num: int) -> int:
        if num not in self.idx:
            raise DeckError(f"{self.m.source}: node {num} is not defined in $NODES")
        return self.idx[num]

    def _sym(self, a, b, g) -> sp.csr_matrix:
        a, b, g = np.asarray(a, np.int64), np.asarray(b, np.int64), np.asarray(g, float)
        M = sp.coo_matrix((np.r_[g, g], (np.r_[a, b], np.r_[b, a])), shape=(self.n, self.n)).tocsr()
        M.setdiag(0.0)
        M.eliminate_zeros()
        return M

    def _static(self, e: Expr) -> float:
        if e.dynamic:
            raise DeckError(f"{self.m.source}: {e.src} depends on time or temperature outside $VARIABLES1")
        return float(eval(e.code, {"__builtins__": {}}, {"_c": self.c, "_F": _FUNCS, "_I": _intrp1,
                                                           "_A": self.m.arrays}))

    def evaluate(self, t: float, T: np.ndarray):
        """(Q (n,) W, T_boundary (n,) K (nan where not set), GL, GR (n, n) sparse) at time t, state T (n,) K."""
        c = dict(self.c)
        degC = T - self.tabs
        idx = self.idx
        env = {"_c": c, "_F": _FUNCS, "_I": _intrp1, "_A": self.m.arrays, "_t": float(t),
               "_T": lambda k: float(degC[idx[k]])}
        g = {"__builtins__": {}}
        Q = self.Q_nodes.copy()
        Tb = np.full(self.n, np.nan)
        extra = {"GL": ([], [], []), "GR": ([], [], [])}
        for kind, ia, ib, e in self.dyn_cond:
            r = extra[kind]
            r[0].append(ia)
            r[1].append(ib)
            r[2].append(float(eval(e.code, g, env)))
        setG = {}
        for kind, key, e in self.m.variables1:
            v = float(eval(e.code, g, env))
            if kind == "QI":
                Q[self._node(key)] = v + self.Q_other[self._node(key)]
                c[f"Q{key}"] = c[f"QI{key}"] = v  # (a SINDA sum continued in Q12 = Q12 + ...)
            elif kind == "T":
                i = self._node(key)
                Tb[i] = v + self.tabs
                degC = degC.copy()
                degC[i] = v
                env["_T"] = lambda k, d=degC: float(d[idx[k]])
            elif kind == "NAME":
                c[key] = v
            else:
                setG[(kind, self._node(key[0]), self._node(key[1]))] = v
        G = {}
        for kind in ("GL", "GR"):
            M = self.G0[kind]
            r = extra[kind]
            sets = [(a, b, v) for (k, a, b), v in setG.items() if k == kind]
            if sets:  # an assignment in $VARIABLES1 replaces the conductor's value
                a, b, v = (np.array(x) for x in zip(*sets))
                M = M.tolil(copy=True)
                M[a, b] = 0.0
                M[b, a] = 0.0
                M = M.tocsr()
                r = (r[0] + list(a), r[1] + list(b), r[2] + list(v))
            if r[0]:
                M = M + self._sym(*r)
            G[kind] = M
        return Q, Tb, G["GL"], G["GR"]

    def flux(self, t: float, T: np.ndarray):
        """F (n,) W (net heat into each node) and its Jacobian dF/dT (sparse) at (t, T K), and boundary T."""
        Q, Tb, GL, GR = self.evaluate(t, T)
        T = np.where(np.isnan(Tb), T, Tb)
        T4 = T**4
        dl = np.asarray(GL.sum(axis=1)).ravel()
        dr = np.asarray(GR.sum(axis=1)).ravel()
        F = Q + GL @ T - dl * T + self.stefan * (GR @ T4 - dr * T4)
        J = GL - sp.diags(dl) + self.stefan * (GR @ sp.diags(4 * T**3) - sp.diags(4 * dr * T**3))
        return F, J.tocsr(), Tb


def _fixed(net: Network, Tb: np.ndarray, T: np.ndarray) -> np.ndarray:
    T = T.copy()
    hold = net.m.boundary & ~np.isnan(Tb)
    T[hold] = Tb[hold]
    return T


def _newton(net: Network, t: float, T: np.ndarray, residual, tol: float = 1e-9, max_it: int = 200):
    """Solve residual(F, J, T) -> (R, dR/dT) = 0 on the free nodes, the boundary nodes held; the $VARIABLES1
    terms are re-evaluated at every iterate (their derivatives are left out of the Jacobian: Picard on them)."""
    free = np.flatnonzero(~net.m.boundary)
    T = np.asarray(T, float).copy()
    for it in range(max_it):
        F, J, Tb = net.flux(t, T)
        T = _fixed(net, Tb, T)
        R, dR = residual(F, J, T)
        if not free.size:
            return T, it
        dx = np.atleast_1d(spla.spsolve(dR[free][:, free].tocsc(), -R[free]))
        neg = dx < 0
        a = min(1.0, float(np.min(0.5 * T[free][neg] / -dx[neg]))) if neg.any() else 1.0
        T[free] += a * dx
        if a == 1.0 and np.max(np.abs(dx)) < tol:  # K
            _, _, Tb = net.flux(t, T)
            return _fixed(net, Tb, T), it + 1
    raise RuntimeError(f"{net.m.source}: Newton did not converge in {max_it} iterations at t = {t}")


def _steady(net: Network, t: float, T0: np.ndarray) -> np.ndarray:
    return _newton(net, t, T0, lambda F, J, T: (F, J))[0]


def solve_esatan_steady(path: str | Path, edits: dict | None = None) -> dict:
    """Steady temperatures {node number: T degC} of an ESATAN deck with its constants ``edits`` {NAME: value}
    (the $VARIABLES1 terms evaluated at TIMEO)."""
    net = Network(read_esatan(path), edits)
    T = _steady(net, net.c.get("TIMEO", 0.0), net.T_start)
    return {int(k): float(v - net.tabs) for k, v in zip(net.m.numbers, T)}


#: the transient routines this solver integrates and the scheme of each (ESATAN SLCRNC and SLFWBK: Crank-Nicolson;
#: SLGEAR: Gear's BDF, integrated here as fixed-step BDF2; SINDA/FLUINT FWDBCK: forward-backward, Crank-Nicolson)
SCHEMES = {"SLCRNC": "crank-nicolson", "SLFWBK": "crank-nicolson", "SLGEAR": "bdf2", "FWDBCK": "crank-nicolson"}


def integrate(net: Network, times: np.ndarray, scheme: str, step: float, T0: np.ndarray,
              startup: int = 0) -> np.ndarray:
    """(len(times), n) K: the theta scheme (``crank-nicolson``, ``backward-euler``) or ``bdf2`` from T0 at
    times[0], fixed steps of at most ``step`` cut evenly to land on each time; ``startup`` backward-Euler steps
    first (a Crank-Nicolson start that damps its oscillation of a non-smooth start)."""
    out = [T0.copy()]
    t, T = float(times[0]), T0.copy()
    F0, _, _ = net.flux(t, T)
    C = net.C
    n_steps, prev = 0, None  # prev: (h, dT) of the previous step for BDF2
    for te in times[1:]:
        m = max(int(np.ceil((te - t) / step * (1 - 1e-9))), 1)
        h = (te - t) / m
        for _ in range(m):
            t1 = t + h
            # backward Euler, and the startup steps of Crank-Nicolson, are theta = 1; BDF2 starts with one
            # trapezoidal step (theta = 1/2), as its history needs a previous step
            theta = 1.0 if scheme == "backward-euler" or (scheme == "crank-nicolson" and n_steps < startup) else 0.5
            if scheme == "bdf2" and prev is not None:
                hp, dTp = prev
                w = h / hp
                a = (1 + 2 * w) / (1 + w)
                cc = w * w / (1 + w)

                def res(F, J, T1, T=T, a=a, cc=cc, dTp=dTp, h=h):
                    return C * (a * (T1 - T) - cc * dTp) - h * F, sp.diags(a * C) - h * J
            else:
                def res(F, J, T1, T=T, F0=F0, theta=theta, h=h):
                    arith = C == 0  # arithmetic nodes: balance at t1
                    R = C * (T1 - T) - h * (theta * F + (1 - theta) * F0)
                    R[arith] = -F[arith]
                    dR = sp.diags(C) - h * theta * J
                    dR = sp.csr_matrix(dR)
                    if arith.any():
                        D = sp.diags(arith.astype(float))
                        dR = (sp.diags((~arith).astype(float)) @ dR - D @ J).tocsr()
                    return R, dR
            T1, _ = _newton(net, t1, T, res)
            prev = (h, T1 - T)
            T = T1
            t = t1
            F0, _, _ = net.flux(t, T)
            n_steps += 1
        out.append(T.copy())
    return np.array(out)


def solve_esatan_transient(path: str | Path, edits: dict | None = None, times=None, scheme: str | None = None,
                           step: float | None = None, initial: str | None = None, startup: int = 0):
    """The transient an ESATAN deck defines: ``(times (k,) s, {node number: T degC (k,)})``.

    ``times`` default: TIMEO to TIMEND every OUTINT; ``scheme`` default: the one the deck's $EXECUTION calls
    (:data:`SCHEMES`); ``step`` default DTIMEI; ``initial``: ``"steady"`` (the steady state at TIMEO, as a deck
    that calls SOLVFM before the transient) or ``"deck"`` (the $NODES temperatures)."""
    return _transient(read_esatan(path), edits, times, scheme, step, initial, startup)


def _transient(model: Model, edits, times, scheme=None, step=None, initial=None, startup=0):
    net = Network(model, edits)
    c = net.c
    if scheme is None:
        if model.solver not in SCHEMES:
            raise DeckError(f"{model.source}: $EXECUTION calls {model.solver or 'no solver'}, not a transient "
                            f"routine this reader integrates ({', '.join(SCHEMES)})")
        scheme = SCHEMES[model.solver]
    t0, t1 = c.get("TIMEO", 0.0), c["TIMEND"]
    if times is None:
        dt = c.get("OUTINT", t1 - t0)
        times = np.append(np.arange(t0, t1 - 1e-9 * (t1 - t0), dt), t1)
    times = np.asarray(times, float)
    h = step if step is not None else c["DTIMEI"]
    if initial is None:
        initial = "steady" if model.steady_start else "deck"
    T0 = _steady(net, times[0], net.T_start) if initial == "steady" else net.T_start
    T = integrate(net, times, scheme, h, T0, startup)
    return times, {int(k): T[:, i] - net.tabs for i, k in enumerate(model.numbers)}


# ------------------------------------------------------------------------------------------------ SINDA/FLUINT
def read_sinda(path: str | Path) -> Model:
    """Read the SINDA/FLUINT subset fem2tmm writes into the same :class:`Model`.

    ``HEADER REGISTER DATA`` (``NAME = expr``: the named constants), ``CONTROL DATA`` (SIGMA, ABSZRO, TIMEO, TIMEND,
    DTIMEI, OUTPUT), ``NODE DATA`` (``id, T, C``; negative id: boundary; negative C: arithmetic; ``$ label``), ``CONDUCTOR DATA``
    (``id, a, b, G``; negative id: radiation), ``SOURCE DATA`` (``node, expr``), ``ARRAY DATA`` (``id = x1, y1,
    ...`` continued, ``END``), ``VARIABLES 1`` (Fortran ``Q12 = expr`` / ``T12 = expr`` / ``G7 = expr`` (conductor 7's value), ``&`` in column 6
    continues; ``D1DEG1(x, An)`` is linear interpolation of array n at x) and ``OPERATIONS DATA`` (``CALL STEADY``,
    ``CALL FWDBCK``).  Comments: ``C`` in column 1, everything after ``$``."""
    path = Path(path)
    name = str(path)
    text = path.read_text(encoding="utf-8", errors="replace")
    block, nodes, cond, var1, calls = None, [], [], [], []
    conductor_id = {}  # conductor id -> (kind, a, b)
    defs = {"TABS": "273.15"}
    arrays, cur = {}, None
    logic = []
    for no, raw in enumerate(text.splitlines(), 1):
        if not raw.strip() or (raw[:1] in "Cc" and (len(raw) == 1 or raw[1] in " \t")):
            continue
        body, _, comment = raw.partition("$")
        where = f"{name}:{no}"
        if body.strip().upper().startswith("HEADER"):
            block = body.split()[1].upper()
            continue
        if body.strip().upper().startswith("END OF DATA") or not body.strip():
            continue
        if block == "REGISTER":
            k, v = body.split("=", 1)
            defs[k.strip().upper()] = v.strip()
        elif block == "CONTROL":
            k, v = (x.strip() for x in body.split("=", 1))
            key = {"SIGMA": "STEFAN", "OUTPUT": "OUTINT"}.get(k.upper(), k.upper())
            if key == "ABSZRO":
                defs["TABS"] = f"-({v})"
            elif key != "UID":
                defs[key] = v
        elif block == "NODE":
            f = _split_top(body.strip())
            if len(f) != 3:
                raise DeckError(f"{where}: node data 'id, T, C' expected, got {body.strip()!r}")
            nid = int(f[0])
            # (a negative capacitance is SINDA/FLUINT's arithmetic node: C = 0 here)
            nodes.append(("B" if nid < 0 else "D", abs(nid), comment.strip(),
                          {"T": expr(f[1], where), "C": expr(f"MAX({f[2]}, 0.0)", where)}))
        elif block == "CONDUCTOR":
            f = _split_top(body.strip())
            cid = int(f[0])
            cond.append(("GR" if cid < 0 else "GL", abs(int(f[1])), abs(int(f[2])), expr(f[3], where)))
            conductor_id[abs(cid)] = cond[-1][:3]
        elif block == "SOURCE":
            f = _split_top(body.strip())
            var1.append(("QI", abs(int(f[0])), expr(f[1], where)))
        elif block == "ARRAY":
            if body.strip().upper() == "END":
                cur = None
                continue
            m = re.match(r"^\s*(\d+)\s*=\s*(.*)$", body)
            if m:
                cur = f"A{int(m.group(1))}"
                arrays[cur] = []
                rest = m.group(2)
            else:
                rest = body
            arrays[cur] += [float(x) for x in rest.split(",") if x.strip()]
        elif block == "VARIABLES":
            if len(body) > 5 and not body[:5].strip() and body[5] not in " 0":
                logic[-1] = (logic[-1][0], logic[-1][1] + " " + body[6:].strip())
            else:
                logic.append((where, body.strip()))
        elif block == "OPERATIONS":
            m = re.match(r"^\s*CALL\s+([A-Za-z]\w*)", body, re.I)
            if m:
                calls.append({"STEADY": "SOLVFM"}.get(m.group(1).upper(), m.group(1).upper()))
    for where, stmt in logic:
        g = re.match(r"^G\s*(\d+)\s*=\s*(.+)$", stmt, re.I)  # a conductor's value (G<id>), e.g. D1DEG1 of a T
        if g:
            if int(g.group(1)) not in conductor_id:
                raise DeckError(f"{where}: G{g.group(1)}: no conductor {g.group(1)} in CONDUCTOR DATA")
            kind, a, b = conductor_id[int(g.group(1))]
            var1.append((kind, (a, b), expr(re.sub(r"D1DEG1\s*\(", "INTRP1(", g.group(2), flags=re.I), where)))
            continue
        m = re.match(r"^(Q|T)\s*(\d+)\s*=\s*(.+)$", stmt, re.I)
        if not m:
            raise DeckError(f"{where}: cannot read the VARIABLES 1 statement {stmt[:60]!r}")
        rhs = re.sub(r"D1DEG1\s*\(", "INTRP1(", m.group(3), flags=re.I)
        var1.append(("QI" if m.group(1).upper() == "Q" else "T", int(m.group(2)), expr(rhs, where)))
    # sources first (SOURCE DATA), then the logic that may replace them: the order of var1 already is that
    return Model(source=name, numbers=np.array([nd[1] for nd in nodes], np.int64), labels=[nd[2] for nd in nodes],
                 boundary=np.array([nd[0] == "B" for nd in nodes]), node_exprs=[nd[3] for nd in nodes], cond=cond,
                 variables1=var1, definitions=defs, arrays={k: np.array(v) for k, v in arrays.items()}, calls=calls)


def solve_sinda_steady(path: str | Path, edits: dict | None = None) -> dict:
    """Steady temperatures {node number: T degC} of a SINDA/FLUINT deck with its registers ``edits``."""
    net = Network(read_sinda(path), edits)
    T = _steady(net, net.c.get("TIMEO", 0.0), net.T_start)
    return {int(k): float(v - net.tabs) for k, v in zip(net.m.numbers, T)}


def solve_sinda_transient(path: str | Path, edits: dict | None = None, times=None, **kw):
    """The transient a SINDA/FLUINT deck defines (FWDBCK: Crank-Nicolson), as :func:`solve_esatan_transient`."""
    return _transient(read_sinda(path), edits, times, **kw)


__all__ = ["DeckError", "read_esatan", "read_sinda", "Network", "solve_esatan_steady", "solve_esatan_transient",
           "solve_sinda_steady", "solve_sinda_transient", "integrate"]
