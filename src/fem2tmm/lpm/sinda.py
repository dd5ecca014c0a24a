"""Reader of SINDA/FLUINT thermal input (node, conductor and source blocks) into a
:class:`~fem2tmm.lpm.network.Network`.

Understood (anything else inside these blocks is refused with ``file:line``):

- ``HEADER CONTROL DATA``: ``SIGMA`` (GR values are rescaled to fem2tmm's σ), ``ABSZRO`` (absolute zero in the
  deck's temperature unit; default −273.15: °C) and ``UID = SI`` (``ENG`` is refused).  Other control
  constants are noted and skipped.
- ``HEADER REGISTER DATA``: ``NAME = expr`` values usable in every expression below.
- ``HEADER NODE DATA, SUB``: ``id, T, C`` (negative id: boundary node; negative C: arithmetic node, C = 0) and
  ``GEN id, count, step, T, C``.  The ``$`` comment of a node line is its label.
- ``HEADER CONDUCTOR DATA, SUB``: ``id, a, b, G`` (negative id: radiation conductor, G = εAF in m²) and
  ``GEN id, count, id_step, a, a_step, b, b_step, G``; node references may carry their submodel (``SUB.12``).
- ``HEADER SOURCE DATA, SUB``: ``node, Q`` pairs (W).
- ``HEADER ARRAY DATA, SUB``: doublet arrays ``id = x1, y1, x2, y2, ...`` (continued over lines) ended by ``END``.
- ``HEADER VARIABLES 1, SUB``: Fortran assignments ``Q12 = expr`` (the node's load, replacing its SOURCE DATA) and
  ``T12 = expr`` (a boundary temperature), continued with a character in column 6; ``D1DEG1(TIMEM, An)`` is array
  n interpolated linearly at ``TIMEO`` (the start of a transient), ``D1DEG1(NAME, An)`` at a register's value
  (constant outside the array, as fem2tmm's writer means it).  Other logic statements are counted in
  ``Network.notes``.

Comments: lines starting with ``C`` followed by a blank (or alone) in column 1, ``REM`` lines, and everything after
``$``.  Node numbers must be unique across submodels (they are merged into one network).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..constants import SIGMA
from ..errors import Fem2TmmError
from .expressions import ExpressionError, evaluate, resolve, split_top
from .network import Network, couplings_from_lists

_HEADER = re.compile(r"^\s*HEADER\s+([A-Z ]+?)\s+DATA\s*(?:,\s*([A-Za-z0-9_]+))?", re.I)
# any other HEADER line (logic blocks: HEADER VARIABLES 1, SUB; HEADER OUTPUT CALLS, SUB)
_OTHER_HEADER = re.compile(r"^\s*HEADER\s+([A-Z]+)", re.I)


def _header(body: str):
    """(block word, submodel or None) of a HEADER line, else None."""
    h = _HEADER.match(body)
    if h:
        return h.group(1).upper().split()[0], h.group(2)
    h = _OTHER_HEADER.match(body)
    return (h.group(1).upper(), None) if h else None
_ASSIGN = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.+)$")
_ARRAY_START = re.compile(r"^\s*(\d+)\s*=\s*(.*)$")
_LOGIC = re.compile(r"^(Q|T)\s*(\d+)\s*=\s*(.+)$", re.I)
#: a conductor following a node's temperature: ``G12 = D1DEG1(T7, A3)`` (fem2tmm's GR to space of node 7)
_GTAB = re.compile(r"^G\s*(\d+)\s*=\s*D1DEG1\s*\(\s*T\s*(\d+)\s*,\s*A(\d+)\s*\)$", re.I)
_D1DEG1 = re.compile(r"D1DEG1\s*\(\s*([A-Za-z_]\w*)\s*,\s*A(\d+)\s*\)", re.I)


def _logic_statements(lines):
    """(line, statement) of Fortran fixed-form logic lines: a line with a character other than blank or 0 in column 6
    (and blanks before it) continues the previous statement."""
    out = []
    for lineno, body in lines:
        if len(body) > 5 and not body[:5].strip() and body[5] not in " 0" and out:
            out[-1] = (out[-1][0], out[-1][1] + " " + body[6:].strip())
        else:
            out.append((lineno, body.strip()))
    return out


def _lines(text: str):
    """Yield (line number, content, comment) of the meaningful lines."""
    for lineno, raw in enumerate(text.splitlines(), 1):
        if not raw.strip():
            continue
        if raw[:1] in "Cc" and (len(raw) == 1 or raw[1] in " \t"):
            continue
        if raw.strip().upper().startswith("REM "):
            continue
        body, _, comment = raw.partition("$")
        if body.strip():
            yield lineno, body.rstrip(), comment.strip()


def read_sinda(path: str | Path) -> Network:
    """Read SINDA/FLUINT node / conductor / source data (see the module docstring); temperatures to K.

    Raises :class:`Fem2TmmError` naming ``file:line`` for the first entry it cannot read.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise Fem2TmmError(f"{path}: cannot read the deck ({exc.strerror})") from None

    def fail(line, msg):
        raise Fem2TmmError(f"{path}:{line}: {msg}")

    lines = list(_lines(text))
    # pass 1: control and register data (registers may be used before they are defined)
    block = None
    control, registers_src = {}, []
    for lineno, body, _ in lines:
        h = _header(body)
        if h:
            block = h[0]
            continue
        if body.strip().upper().startswith("END OF DATA"):
            block = None
            continue
        m = _ASSIGN.match(body)
        if block == "CONTROL" and m:
            control[m.group(1).upper()] = (lineno, m.group(2).strip())
        elif block == "REGISTER":
            if not m:
                fail(lineno, f"cannot read the register {body.strip()[:60]!r} (expected NAME = value)")
            registers_src.append((lineno, m.group(1).upper(), m.group(2)))
    regs = resolve(registers_src, fail)
    # arrays and VARIABLES 1 (raw lines: the Fortran columns matter)
    arrays, logic_lines, cur = {}, [], None
    block = None
    for lineno, raw in enumerate(text.splitlines(), 1):
        if not raw.strip() or (raw[:1] in "Cc" and (len(raw) == 1 or raw[1] in " \t")):
            continue
        body = raw.split("$", 1)[0].rstrip()
        h = _header(body)
        if h:
            block, cur = h[0], None
            continue
        if not body.strip():
            continue
        if block == "ARRAY":
            if body.strip().upper() == "END":
                cur = None
                continue
            m = _ARRAY_START.match(body)
            if m:
                cur = int(m.group(1))
                arrays[cur] = (lineno, [])
                rest = m.group(2)
            elif cur is not None:
                rest = body
            else:
                fail(lineno, f"cannot read the array data {body.strip()[:60]!r} (expected id = x1, y1, ...)")
            arrays[cur][1].extend(t for t in (x.strip() for x in rest.split(",")) if t)
        elif block == "VARIABLES":
            logic_lines.append((lineno, body))
    array_values = {}
    for k, (lineno, items) in arrays.items():
        try:
            array_values[k] = np.array([evaluate(t, regs) for t in items], float)
        except ExpressionError as exc:
            fail(lineno, f"array {k}: {exc}")
    notes = []
    uid = control.get("UID", (0, "SI"))
    if uid[1].upper() != "SI":
        fail(uid[0], f"UID = {uid[1]} is not supported: give the deck in SI units (UID = SI)")

    def val(lineno, expr, what):
        try:
            return evaluate(expr, regs)
        except ExpressionError as exc:
            fail(lineno, f"{what}: {exc}")

    abszro = val(*control["ABSZRO"], "ABSZRO") if "ABSZRO" in control else -273.15
    if "ABSZRO" not in control:
        notes.append("no ABSZRO in CONTROL DATA: temperatures read as degC")
    gr_scale = val(*control["SIGMA"], "SIGMA") / SIGMA if "SIGMA" in control else 1.0
    other = sorted(set(control) - {"UID", "ABSZRO", "SIGMA", "TIMEO"})
    time0 = val(*control["TIMEO"], "TIMEO") if "TIMEO" in control else 0.0

    def d1deg1(lineno):
        def sub(m):
            a = array_values.get(int(m.group(2)))
            if a is None or len(a) < 2:
                fail(lineno, f"D1DEG1 of the undefined array A{m.group(2)}")
            x = time0 if m.group(1).upper() == "TIMEM" else regs.get(m.group(1).upper())
            if x is None:
                fail(lineno, f"D1DEG1 of {m.group(1)!r}, which is neither TIMEM nor a register")
            return repr(float(np.interp(x, a[0::2], a[1::2])))
        return sub

    assigned, skipped, current = [], 0, {}
    g_tables = []  # (line, conductor id, node number, array id)
    for lineno, stmt in _logic_statements(logic_lines):
        g = _GTAB.match(stmt)
        if g:
            if int(g.group(3)) not in array_values:
                fail(lineno, f"D1DEG1 of the undefined array A{g.group(3)}")
            g_tables.append((lineno, int(g.group(1)), int(g.group(2)), int(g.group(3))))
            continue
        m = _LOGIC.match(stmt)
        if not m:
            skipped += 1
            continue
        name = f"{m.group(1).upper()}{m.group(2)}"
        try:  # (a long sum goes on in Q12 = Q12 + ...: the statements before it give Q12)
            v = evaluate(_D1DEG1.sub(d1deg1(lineno), m.group(3)), {**regs, **current})
        except ExpressionError as exc:
            fail(lineno, f"{name}: {exc}")
        current[name] = v
        assigned.append((lineno, m.group(1).upper(), int(m.group(2)), v))
    if skipped:
        notes.append(f"{skipped} VARIABLES 1 statements not interpreted")
    if other:
        notes.append(f"control constants not used: {', '.join(other)}")

    nodes: dict[int, tuple] = {}  # number -> (line, kind, T, C, label)
    conds: list[tuple] = []  # (line, radiative, a, b, G)
    single: dict[int, tuple] = {}  # conductor id -> (line, a, b) of the one-pair conductors
    sources: list[tuple] = []
    block = None
    submodels = set()

    def node_ref(lineno, tok):
        tok = tok.strip()
        if "." in tok:
            sub, _, tok = tok.partition(".")
            submodels.add(sub.upper())
        try:
            return int(tok)
        except ValueError:
            fail(lineno, f"cannot read the node reference {tok!r}")

    for lineno, body, comment in lines:
        h = _header(body)
        if h:
            block = h[0]
            if h[1] and block in ("NODE", "CONDUCTOR", "SOURCE"):
                submodels.add(h[1].upper())
            continue
        if body.strip().upper().startswith("END OF DATA"):
            block = None
            continue
        if block not in ("NODE", "CONDUCTOR", "SOURCE"):
            continue
        fields = [f.strip() for f in split_top(body.strip())]
        gen = fields[0].upper().startswith("GEN")
        if gen:
            fields[0] = fields[0][3:].strip()
        if block == "NODE":
            if len(fields) != (5 if gen else 3):
                form = "GEN id, count, step, T, C" if gen else "id, T, C"
                fail(lineno, f"node data needs {form}; got {body.strip()!r}")
            first = node_ref(lineno, fields[0])
            count, step = (int(val(lineno, fields[1], "count")), int(val(lineno, fields[2], "step"))) if gen else (1, 1)
            T = val(lineno, fields[-2], "temperature")
            C = val(lineno, fields[-1], "capacitance")
            if count < 1:
                fail(lineno, f"GEN count {count} must be at least 1")
            for k in range(count):
                num = abs(first) + k * step
                if num in nodes:
                    fail(lineno, f"node {num} is defined twice (first at line {nodes[num][0]})")
                nodes[num] = (lineno, "B" if first < 0 else "D", T, max(C, 0.0), comment if count == 1 else
                              f"{comment}_{k + 1}" if comment else "")
            if C < 0:
                notes.append(f"line {lineno}: negative capacitance read as an arithmetic node (C = 0)")
        elif block == "CONDUCTOR":
            if len(fields) != (8 if gen else 4):
                fail(lineno, "conductor data needs " + ("GEN id, count, id_step, a, a_step, b, b_step, G" if gen
                                                         else "id, a, b, G") + f"; got {body.strip()!r}")
            cid = int(val(lineno, fields[0], "conductor id"))
            G = val(lineno, fields[-1], "conductance")
            if gen:
                count = int(val(lineno, fields[1], "count"))
                a0, da = node_ref(lineno, fields[3]), int(val(lineno, fields[4], "a step"))
                b0, db = node_ref(lineno, fields[5]), int(val(lineno, fields[6], "b step"))
                ks = np.arange(max(count, 0))
                a, b = a0 + ks * da, b0 + ks * db
            else:
                a, b = np.array([node_ref(lineno, fields[1])]), np.array([node_ref(lineno, fields[2])])
            conds.append((lineno, cid < 0, np.abs(a), np.abs(b), G))
            if not gen:
                single[abs(cid)] = (lineno, int(abs(a[0])), int(abs(b[0])))
        else:  # SOURCE
            if len(fields) % 2:
                fail(lineno, f"source data needs node, Q pairs; got {body.strip()!r}")
            for k in range(0, len(fields), 2):
                sources.append((lineno, abs(node_ref(lineno, fields[k])), val(lineno, fields[k + 1], "source")))
    if not nodes:
        raise Fem2TmmError(f"{path}: no HEADER NODE DATA entries: not a SINDA/FLUINT thermal deck")
    numbers = np.array(sorted(nodes), np.int64)
    n = len(numbers)

    def rows(lineno, refs):
        refs = np.asarray(refs, np.int64)
        pos = np.minimum(np.searchsorted(numbers, refs), n - 1)
        bad = numbers[pos] != refs
        if bad.any():
            fail(lineno, f"reference to undefined node(s) {', '.join(str(int(v)) for v in np.unique(refs[bad])[:10])}")
        return pos

    parts = {False: ([], [], []), True: ([], [], [])}
    for lineno, rad, a, b, G in conds:
        ia, ib = rows(lineno, a), rows(lineno, b)
        la, lb, lg = parts[rad]
        la.append(ia)
        lb.append(ib)
        lg.append(np.full(len(ia), G * (gr_scale if rad else 1.0)))
    mats = {rad: couplings_from_lists(n, *parts[rad]) for rad in parts}
    Q = np.zeros(n)
    for lineno, num, q in sources:
        Q[rows(lineno, [num])[0]] += q
    T_set = {}
    for lineno, what, num, v in assigned:  # VARIABLES 1 sets the load (or temperature) of the node
        i = int(rows(lineno, [num])[0])
        if what == "Q":
            Q[i] = v
        else:
            T_set[i] = v
    info = [nodes[int(v)] for v in numbers]
    info = [(a, b, T_set.get(i, c), d, e) for i, (a, b, c, d, e) in enumerate(info)]
    gr_tables = []
    for lineno, cid, num, aid in g_tables:  # GR to a node following a node's own temperature
        if cid not in single:
            fail(lineno, f"G{cid}: no one-pair conductor {cid} in CONDUCTOR DATA")
        _, a, b = single[cid]
        arr = array_values[aid]
        ia, ib, it = (int(rows(lineno, [v])[0]) for v in (a, b, num))
        gr_tables.append((ia, ib, it, arr[0::2] - abszro, arr[1::2] * gr_scale))
    if gr_scale != 1.0:
        notes.append(f"radiation conductors rescaled from SIGMA = {gr_scale * SIGMA!r} to {SIGMA!r}")
    return Network(numbers=numbers, labels=np.array([i[4] for i in info], dtype=object).astype(str),
                   kind=np.array([i[1] for i in info]), T=np.array([i[2] for i in info], float) - abszro,
                   C=np.array([i[3] for i in info], float), A=np.zeros(n), alp=np.zeros(n), eps=np.zeros(n),
                   QI=Q, GL=mats[False], GR=mats[True], source=str(path), notes=tuple(notes),
                   gr_tables=tuple(gr_tables))


__all__ = ["read_sinda"]
