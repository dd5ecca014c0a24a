"""Reader of ESATAN input decks (the thermal-model part) into a :class:`~fem2tmm.lpm.network.Network`.

Understood (everything else in these blocks is refused with ``file:line``):

- ``$NODES``: ``D12 = 'label', T = 20.0, C = 5.0 * RHO, A = 0.1, ALP = 0.3, EPS = 0.8, QI = 2.0;`` with kinds D
  (diffusion; C = 0 is an arithmetic node), B (boundary) and X (inactive); the loads QS, QA, QE, QI, QR are summed
  into the node's dissipation; FX, FY, FZ (m) are the node's position when given.
- ``$CONDUCTORS``: ``GL(a, b) = expr;`` and ``GR(a, b) = expr;`` where a and b are node numbers or ranges
  ``n1:n2`` (a range against a single node couples every node of the range to it; two ranges of equal length are
  paired element by element).  Parallel conductors add up.
- ``$CONSTANTS`` / ``$LOCALS`` (sub-blocks ``$REAL``, ``$INTEGER``, ``$CONTROL``): ``NAME = expr;`` values usable
  in every expression above (the block may come after its use, as in ESATAN).  Control constants ``TABS``
  (absolute zero offset, default 273.15: temperatures in °C) and ``STEFAN`` (σ; GR values are rescaled to
  fem2tmm's σ) are honoured.
- ``$VARIABLES1``: assignments ``QI12 = expr;`` / ``QI(12) = expr;`` and ``T12 = expr;`` (as fem2tmm's writer
  emits); ``INTRP1(TIMEM, A)`` of a ``$ARRAYS`` doublet array ``A(2k) = t1, v1, …;`` is taken at the start time
  ``TIMEO`` (a steady network of a transient deck: its initial state); ``INTRP1(NAME, A)`` of a constant NAME is A
  (value, result) interpolated at NAME's value, constant outside (fem2tmm's parametric correction).  Other
  statements of the operation blocks are not interpreted: they are counted in ``Network.notes``.

Comments run from ``#`` to the end of the line; a statement ends at ``;`` and may span lines.
"""

from __future__ import annotations

import functools
import gc
import hashlib
import re
from pathlib import Path

import numpy as np

from ..constants import KELVIN, SIGMA
from ..errors import Fem2TmmError
from .expressions import ExpressionError, evaluate, number, resolve, split_quoted, split_top
from .network import Network, couplings_from_lists

_NODE = re.compile(r"^([A-Za-z])\s*(\d+)\s*=\s*(.*)$", re.S)
_COND = re.compile(r"^(G[A-Za-z]*)\s*\(\s*([^,()]+?)\s*,\s*([^,()]+?)\s*\)\s*=\s*(.+)$", re.S)
_ASSIGN = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.+)$", re.S)
_QI = re.compile(r"^(QI|T)\s*(?:\(\s*(\d+)\s*\)|(\d+))\s*=\s*(.+)$", re.S | re.I)
_ARRAY = re.compile(r"^([A-Za-z_]\w*)\s*\(\s*(\d+)\s*\)\s*=\s*(.+)$", re.S)
_INTRP1 = re.compile(r"INTRP1\s*\(\s*TIMEM\s*,\s*([A-Za-z_]\w*)\s*\)", re.I)
#: a conductor following a node's own temperature: ``GR(a, b) = INTRP1(Tk, A);`` in $VARIABLES1 (A a doublet array of
#: temperature, value; constant outside), as fem2tmm's writer emits for the effective emission to space
_GR_OF_T = re.compile(r"GR\s*\(\s*(\d+)\s*,\s*(\d+)\s*\)\s*=\s*INTRP1\s*\(\s*T\s*(\d+)\s*,\s*([A-Za-z_]\w*)\s*\)$",
                      re.I)
_INTRP1_OF = re.compile(r"INTRP1\s*\(\s*([A-Za-z_]\w*)\s*,\s*([A-Za-z_]\w*)\s*\)", re.I)  # of any name
# the plain conductor, one node to one node with a number (what fem2tmm writes, ~10⁶ of them at 1 000 super nodes):
# read without the general expression path
_PLAIN_COND = re.compile(r"^G([LR])\s*\(\s*(\d+)\s*,\s*(\d+)\s*\)\s*=\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)$",
                         re.I)
_LOADS = ("QS", "QA", "QE", "QI", "QR")
_NODE_KEYS = ("T", "C", "A", "ALP", "EPS", "FX", "FY", "FZ") + _LOADS
_BLOCKS = {"MODEL", "LOCALS", "NODES", "CONDUCTORS", "CONSTANTS", "ARRAYS", "EVALUATION", "VARIABLES1",
           "VARIABLES2", "EXECUTION", "OUTPUTS", "SUBROUTINES", "ENDMODEL", "REPEAT", "INITIAL", "EVENTS"}
_SUBBLOCKS = {"REAL", "INTEGER", "CHARACTER", "CONTROL"}
_HEADER = re.compile(r"\$([A-Za-z]\w*)")  # a block header where only blanks precede it on its line
#: the last $CONDUCTORS block of plain conductors read: ``(first line, length, digest of its text, (lines, is GR, a, b,
#: value) arrays)`` (lines None for a block read at once, :func:`_plain_block`).  A deck read again with only its
#: constants edited (each state of the validity range) skips the parse of its conductors, most of its lines:
#: examples/composite's deck (10⁴ statements) 0.10 -> 0.02 s a read
_LAST_CONDUCTORS: list = [None]


def _segments(raw: str) -> list[str]:
    """One deck line cut at its ``;`` (outside quotes), the comment from ``#`` removed: the statement ends, then the
    rest of the line (possibly empty)."""
    if "'" not in raw and '"' not in raw:  # no quotes: str methods (a 10⁶-conductor deck, issue 29)
        return raw.split("#", 1)[0].split(";")
    cut = split_quoted(raw, ";", "#")  # single quotes (node lines)
    return cut if cut is not None else _segments_scan(raw)


def _segments_scan(raw: str) -> list[str]:
    """:func:`_segments` character by character: any quotes."""
    out, line, quote = [], [], None
    for ch in raw:
        if quote:
            line.append(ch)
            if ch == quote:
                quote = None
            continue
        if ch == "#":
            break
        if ch in "'\"":
            quote = ch
        if ch == ";":
            out.append("".join(line))
            line = []
            continue
        line.append(ch)
    return out + ["".join(line)]


def statements(text: str):
    """Yield ``(block, subblock, line, statement)`` of an ESATAN deck: comments removed, statements split at ``;``
    (outside quotes), ``$`` block headers tracked.  ``line`` is the 1-based line where the statement starts."""
    block = sub = None
    buf, start = [], None
    for lineno, raw in enumerate(text.splitlines(), 1):
        if not raw or raw.isspace():  # (the lines of a conductor block whose parse is reused are left blank)
            continue
        pieces = _segments(raw)
        if not buf and len(pieces) == 2 and not pieces[1].strip():  # one whole statement on its line (the usual)
            stmt = pieces[0].strip()
            if stmt:
                yield block, sub, lineno, stmt
            continue
        for piece in pieces[:-1]:
            buf.append(piece)
            stmt = " ".join(x.strip() for x in buf if x.strip())
            if stmt:
                yield block, sub, lineno if start is None else start, stmt
            buf, start = [], None
        rest = pieces[-1].strip()
        if not rest:
            continue
        if not buf and rest.startswith("$"):
            word = rest[1:].split()[0].upper() if len(rest) > 1 else ""
            if word in _SUBBLOCKS:
                sub = word
            else:
                block, sub = word, None
            continue
        if start is None:
            start = lineno
        buf.append(rest)
    tail = " ".join(s.strip() for s in buf if s.strip())
    if tail:
        yield block, sub, start, tail + "\0"  # unterminated: reported by the caller


def _range(token: str) -> np.ndarray:
    token = token.strip()
    if ":" in token:
        a, b = (int(t) for t in token.split(":", 1))
        if b < a:
            raise ValueError(f"empty node range {token!r}")
        return np.arange(a, b + 1, dtype=np.int64)
    return np.array([int(token)], np.int64)


def _conductor_block(text: str) -> tuple[int, int, int, int, bytes] | None:
    """``(start, end, first line, length, digest)`` of the text of the deck's one ``$CONDUCTORS`` block (the lines after
    its header up to the next block's header), or None where it has none or several."""
    # (every "$" and what precedes it on its line: an anchored multi-line pattern tries every line, 3 ms a 0.5 MB deck)
    heads = [m for m in _HEADER.finditer(text) if m.group(1).upper() not in _SUBBLOCKS
             and not text[text.rfind("\n", 0, m.start()) + 1: m.start()].strip(" \t")]
    at = [i for i, m in enumerate(heads) if m.group(1).upper() == "CONDUCTORS"]
    if len(at) != 1:
        return None
    start = text.find("\n", heads[at[0]].end()) + 1
    end = heads[at[0] + 1].start() if at[0] + 1 < len(heads) else len(text)
    if start <= 0 or end < start:
        return None
    digest = hashlib.blake2b(text[start:end].encode("utf-8", "surrogatepass"), digest_size=20).digest()
    return start, end, text.count("\n", 0, start) + 1, end - start, digest


#: the plain conductor block read at once (:func:`_plain_block`): ``GL(a, b) = v;`` becomes ``0,a,b,v#`` (GR: 1), the
#: letters G, the closing brackets and the blanks deleted
_PLAIN_ROW = bytes.maketrans(b"LlRr(=;", b"0011,,#")
_PLAIN_DROP = b"Gg) \t"
_PLAIN_DTYPE = np.dtype([("kind", np.int64), ("a", np.int64), ("b", np.int64), ("g", np.float64)])


def _plain_block(block: str) -> tuple | None:
    """``(None, is GR, a, b, value)`` arrays of a ``$CONDUCTORS`` block's text whose every statement is a plain
    conductor, one to a line (what fem2tmm writes), read at once by NumPy's text reader; None for any other block,
    which the statement-by-statement reader then reads (and refuses, where it must, with ``file:line``).

    Each statement ``GL(a, b) = v;`` is translated to ``0,a,b,v#`` (GR: 1; the ``;`` ends the row, what follows is
    a comment) and the rows read by :func:`numpy.loadtxt`: a block is taken only where every row has those four
    fields, the kind is 0 or 1, the nodes integers, the value finite, and the rows are as many as the ``GL(`` and
    ``GR(`` in the text and as the ``;`` that end a number.  5·10⁵ conductors: 1.88 -> 0.61 s (the
    statement-by-statement reader takes about 4 µs a statement).  The statements' lines are not kept (None):
    :func:`_statement_lines` finds them for an error message."""
    import io

    if "'" in block or '"' in block:
        return None
    try:
        raw = block.encode("ascii")
    except UnicodeEncodeError:
        return None
    up = raw.upper()
    count = up.count(b"GL(") + up.count(b"GR(")
    if not count:
        return None
    tr = raw.translate(_PLAIN_ROW, _PLAIN_DROP)
    b = np.frombuffer(tr, np.uint8)
    # (a "#" after a digit or "." was a ";" ending a number: a comment's own "#" follows a line end or a ";")
    digit = ((b[:-1] >= ord("0")) & (b[:-1] <= ord("9"))) | (b[:-1] == ord("."))
    ends = np.count_nonzero((b[1:] == ord("#")) & digit)
    if ends != count:
        return None
    try:  # (the node numbers as integers: "1.0" or "1e0" is refused, as the statement reader refuses it)
        rows = np.loadtxt(io.StringIO(tr.decode("ascii")), delimiter=",", comments="#", ndmin=1, dtype=_PLAIN_DTYPE)
    except ValueError:
        return None
    if rows.shape != (count,) or not (np.isin(rows["kind"], (0, 1)).all() and np.isfinite(rows["g"]).all()):
        return None
    return (None, rows["kind"] == 1, np.ascontiguousarray(rows["a"]), np.ascontiguousarray(rows["b"]),
            np.ascontiguousarray(rows["g"]))


def _statement_lines(block: str, first: int) -> np.ndarray:
    """(m,) int: the deck lines of a plain conductor block's statements (:func:`_plain_block`), its text starting at
    line ``first``."""
    return np.array([first + i for i, ln in enumerate(block.split("\n")) if ln.lstrip()[:1] in ("G", "g")], np.int64)


def read_esatan(path: str | Path, time: float | None = None) -> Network:
    """Read an ESATAN input deck (see the module docstring for the subset); temperatures to K, GR to fem2tmm's σ.

    ``time`` (s): evaluate the ``$VARIABLES1`` tables (``INTRP1(TIMEM, A)``) at that time instead of the start
    ``TIMEO``: the loads and boundary temperatures of a transient deck at any time.

    Raises :class:`Fem2TmmError` with ``file:line`` and what to fix for the first statement it cannot read.
    """
    return _read(path, time, None)[0]


def read_esatan_in_time(path: str | Path, start: float, end: float
                        ) -> tuple[Network, np.ndarray, np.ndarray, np.ndarray]:
    """A transient deck read once: ``(network at TIMEO, times (k,) s, QI (k, n) W, T (k, n) K)``, the
    ``$VARIABLES1`` loads and temperatures evaluated at ``start``, ``end`` and every time of the deck's ``$ARRAYS``
    tables in between (``INTRP1`` tables interpolated linearly, constant outside, as :func:`read_esatan` with
    ``time``): linear interpolation between those times gives them at any time in [start, end]."""
    return _read(path, None, (float(start), float(end)))


def _read(path, time, window):
    """The deck read with the cyclic garbage collector paused: a deck of 8·10⁵ conductor lines makes millions of small
    objects (statements, matches, tuples), each batch of which triggers a collection that walks all of them (CPU
    3.3 s → 2.4 s on such a deck, docs/benchmarks.md "Speed-ups of 2026-12-06"); reference counting still frees
    everything, and the collector runs again on return."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        return _read_deck(path, time, window)
    finally:
        if enabled:
            gc.enable()


@functools.lru_cache(maxsize=1 << 15)
def _plain_numbers(text: str) -> np.ndarray | None:
    """An array's values ``text`` (comma-separated) where each is a plain number, else None (read-only).  Kept for the
    next read of the same text: the validity range reads its deck again at every state with only the constants
    edited (a node's temperature table of ``$ARRAYS``)."""
    values = [number(p) for p in split_top(text)]
    if None in values:
        return None
    out = np.array(values, float)
    out.flags.writeable = False
    return out


def _node_fields(text: str) -> tuple[str, list[str]]:
    """A node definition after its ``=``: its label (quotes removed; "" without one) and its ``KEY = value`` pieces."""
    parts = [p.strip() for p in split_top(text)]
    label = ""
    if parts and parts[0][:1] in "'\"":
        label = parts.pop(0).strip("'\"")
    return label, parts


@functools.lru_cache(maxsize=1 << 15)
def _plain_node(text: str) -> tuple[str, tuple[tuple[str, float], ...]] | None:
    """A node definition after its ``=`` (``'label', T = 20, C = 5``): its label and attributes where each is a known
    KEY = plain number, else None (the statement is then read attribute by attribute, with its errors).  Kept for the
    next read of the same text, as :func:`_plain_numbers`."""
    label, parts = _node_fields(text)
    out = []
    for p in parts:
        if not p:
            continue
        key, eq, expr = p.partition("=")
        key, v = key.strip().upper(), number(expr)
        if not eq or key not in _NODE_KEYS or v is None:
            return None
        out.append((key, v))
    return label, tuple(out)


def _read_deck(path, time, window):
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise Fem2TmmError(f"{path}: cannot read the deck ({exc.strerror})") from None
    span, held, cond_text = _conductor_block(text), None, ""
    if span is not None:
        key = _LAST_CONDUCTORS[0]
        cond_text = text[span[0]: span[1]]
        if key is not None and key[:3] == span[2:]:  # the same block as the last read
            held = key[3]
        else:  # every statement a plain conductor: read at once, kept for the next read
            held = _plain_block(cond_text)
            if held is not None:
                for v in held[1:]:
                    v.flags.writeable = False
                _LAST_CONDUCTORS[0] = (*span[2:], held)
        if held is not None:  # its lines left blank here
            text = text[: span[0]] + "\n" * text.count("\n", span[0], span[1]) + text[span[1]:]
    stmts = list(statements(text))

    def fail(line, msg):
        raise Fem2TmmError(f"{path}:{line}: {msg}")

    for block, _, line, s in stmts:
        if s.endswith("\0"):
            fail(line, f"statement {s[:-1][:60]!r} is not terminated by ';'")
    if not any(b == "NODES" for b, *_ in stmts) and "$NODES" not in text.upper():
        raise Fem2TmmError(f"{path}: no $NODES block: not an ESATAN input deck")
    # constants first (they may be defined after their use)
    definitions = []
    for block, sub, line, s in stmts:
        if block in ("CONSTANTS", "LOCALS") and sub != "CHARACTER":
            m = _ASSIGN.match(s)
            if not m:
                fail(line, f"cannot read the constant definition {s[:60]!r} (expected NAME = value;)")
            definitions.append((line, m.group(1).upper(), m.group(2)))
    consts = resolve(definitions, fail)
    tabs = consts.get("TABS", KELVIN)
    gr_scale = consts.get("STEFAN", SIGMA) / SIGMA

    arrays = {}
    for block, sub, line, s in stmts:
        if block == "ARRAYS":
            m = _ARRAY.match(s)
            if m:
                vals = _plain_numbers(m.group(3))
                if vals is None:
                    try:
                        vals = [evaluate(v, consts) for v in split_top(m.group(3))]
                    except ExpressionError as exc:
                        fail(line, f"array {m.group(1)}: {exc}")
                arrays[m.group(1).upper()] = np.array(vals[: int(m.group(2))], float)
    time0 = consts.get("TIMEO", 0.0) if time is None else float(time)
    times = None
    if window is not None:  # the window's ends and every time of a time table (INTRP1 of TIMEM) inside it
        lo, hi = window
        of_time = {m.group(1).upper() for *_, s in stmts for m in _INTRP1.finditer(s)}
        times = np.array(sorted({lo, hi} | {float(t) for name, a in arrays.items() if name in of_time
                                            for t in a[0::2] if lo <= t <= hi}))

    def at(t):
        def sub(m):  # INTRP1(TIMEM, A): the doublet array A (time, value) interpolated at time t
            a = arrays.get(m.group(1).upper())
            if a is None or len(a) < 2:
                raise ExpressionError(f"INTRP1 of the unknown doublet array {m.group(1)!r}")
            return repr(float(np.interp(t, a[0::2], a[1::2])))
        return sub

    at_start = at(time0)

    def of_constant(m):  # INTRP1(NAME, A) of a constant NAME: the doublet array A interpolated at NAME's value
        if m.group(1).upper() == "TIMEM":
            return m.group(0)
        a = arrays.get(m.group(2).upper())
        if a is None or len(a) < 2:
            raise ExpressionError(f"INTRP1 of the unknown doublet array {m.group(2)!r}")
        if m.group(1).upper() not in consts:
            raise ExpressionError(f"INTRP1 of {m.group(1)!r}, which is neither TIMEM nor a constant of $CONSTANTS")
        return repr(float(np.interp(consts[m.group(1).upper()], a[0::2], a[1::2])))

    def value(line, expr, what, sub=at_start):
        try:
            if "INTRP1" not in expr.upper():  # (most values: a number or a constant's expression, no table)
                return evaluate(expr, consts)
            return evaluate(_INTRP1.sub(sub, _INTRP1_OF.sub(of_constant, expr)), consts)
        except ExpressionError as exc:
            fail(line, f"{what}: {exc}")

    nodes: list[tuple] = []
    conds: list[tuple] = []
    plain: list[tuple] = []  # (line, is GR, a, b, value) of the plain conductors
    qi_set: list[tuple] = []
    gr_of_t: list[tuple] = []
    skipped = 0
    for block, sub, line, s in stmts:
        if block == "NODES":
            m = _NODE.match(s)
            if not m:
                fail(line, f"cannot read the node definition {s[:60]!r} (expected e.g. D12 = 'label', T = 20, C = 5;)")
            kind = m.group(1).upper()
            if kind not in "DBX":
                fail(line, f"node kind {kind!r} of node {m.group(2)} is not D, B or X")
            numeric = _plain_node(m.group(3))
            if numeric is not None:  # (every attribute a number: the usual, read once per text)
                nodes.append((line, kind, int(m.group(2)), numeric[0], dict(numeric[1])))
                continue
            label, parts = _node_fields(m.group(3))
            attrs = {}
            for p in parts:
                if not p:
                    continue
                if "=" not in p:
                    fail(line, f"node {m.group(2)}: cannot read {p!r} (expected KEY = value)")
                key, expr = (t.strip() for t in p.split("=", 1))
                key = key.upper()
                if key not in _NODE_KEYS:
                    fail(line, f"node {m.group(2)}: unknown attribute {key!r} (understood: {', '.join(_NODE_KEYS)})")
                attrs[key] = value(line, expr, f"node {m.group(2)} {key}")
            nodes.append((line, kind, int(m.group(2)), label, attrs))
        elif block == "CONDUCTORS":
            m = _PLAIN_COND.match(s)
            if m:
                plain.append((line, m.group(1).upper() == "R", int(m.group(2)), int(m.group(3)), float(m.group(4))))
                continue
            m = _COND.match(s)
            if not m:
                fail(line, f"cannot read the conductor {s[:60]!r} (expected GL(a, b) = value; or GR(a, b) = value;)")
            kind = m.group(1).upper()
            if kind not in ("GL", "GR"):
                fail(line, f"conductor type {kind} is not supported (only GL and GR; fluid conductors are not)")
            try:
                a, b = _range(m.group(2)), _range(m.group(3))
            except ValueError:
                fail(line, f"cannot read the node references ({m.group(2)}, {m.group(3)}) (node numbers or n1:n2 "
                           "ranges; submodel references are not supported: flatten the model)")
            if len(a) != len(b) and min(len(a), len(b)) != 1:
                fail(line, f"node ranges of different lengths ({len(a)} and {len(b)}) in {kind}")
            a, b = np.broadcast_arrays(a, b)
            conds.append((line, kind, a, b, value(line, m.group(4), kind)))
        elif block == "VARIABLES1":
            m = _QI.match(s)
            g = _GR_OF_T.match(s)
            if g:
                a = arrays.get(g.group(4).upper())
                if a is None or len(a) < 2:
                    fail(line, f"INTRP1 of the unknown doublet array {g.group(4)!r}")
                gr_of_t.append((line, int(g.group(1)), int(g.group(2)), int(g.group(3)), a[0::2] + tabs,
                                a[1::2] * gr_scale))
            elif m:
                qi_set.append((line, m.group(1).upper(), int(m.group(2) or m.group(3)), value(line, m.group(4),
                                                                                        m.group(1).upper()),
                               m.group(4)))
            else:
                skipped += 1
        elif block == "ARRAYS":
            if not _ARRAY.match(s):
                skipped += 1
        elif block in ("VARIABLES2", "EXECUTION", "OUTPUTS", "SUBROUTINES", "EVALUATION", "INITIAL", "EVENTS"):
            skipped += 1
        elif block not in ("CONSTANTS", "LOCALS", "MODEL", "ENDMODEL") and block is not None:
            fail(line, f"statement in unknown block ${block}")
        elif block is None:
            fail(line, f"statement {s[:60]!r} before any $ block")
    if not nodes:
        raise Fem2TmmError(f"{path}: the $NODES block defines no node")
    numbers = np.array([nd[2] for nd in nodes], np.int64)
    u, c = np.unique(numbers, return_counts=True)
    if (c > 1).any():
        dup = int(u[c > 1][0])
        lines = [nd[0] for nd in nodes if nd[2] == dup]
        fail(lines[1], f"node {dup} is defined twice (first at line {lines[0]})")
    order = np.argsort(numbers)
    sorted_numbers = numbers[order]

    def rows(line, refs):
        pos = np.minimum(np.searchsorted(sorted_numbers, refs), len(numbers) - 1)
        bad = sorted_numbers[pos] != refs
        if bad.any():
            fail(line, f"conductor to undefined node(s) {', '.join(str(int(v)) for v in np.unique(refs[bad])[:10])}")
        return order[pos]

    n = len(numbers)
    lists = {"GL": ([], [], []), "GR": ([], [], [])}
    if plain and held is None:
        held = tuple(np.array(v) for v in zip(*plain))
        if span is not None and not conds:  # every conductor of the one block plain: kept for the next read
            for v in held:
                v.flags.writeable = False
            _LAST_CONDUCTORS[0] = (*span[2:], held)
    if held is not None:  # all at once; an undefined node is reported at the first statement (in file order) using it
        p_line, p_gr, p_a, p_b, p_g = held
        refs = np.concatenate([p_a, p_b]).astype(np.int64)
        pos = np.minimum(np.searchsorted(sorted_numbers, refs), n - 1)
        bad = (sorted_numbers[pos] != refs).reshape(2, -1).any(axis=0)
        first_general = next((ln for ln, _, a, b, _ in conds
                              if not np.isin(np.r_[a, b], sorted_numbers).all()), None)
        if bad.any() and p_line is None:  # (a block read at once: its lines found for the message)
            p_line = _statement_lines(cond_text, span[2])
        if bad.any() and (first_general is None or p_line[bad].min() < first_general):
            k = int(np.flatnonzero(bad)[np.argmin(p_line[bad])])
            rows(int(p_line[k]), np.array([p_a[k], p_b[k]], np.int64))
        ia, ib = order[pos].reshape(2, -1)
        for kind, sel in (("GL", ~p_gr), ("GR", p_gr)):
            lists[kind][0].append(ia[sel])
            lists[kind][1].append(ib[sel])
            lists[kind][2].append(p_g[sel] * (gr_scale if kind == "GR" else 1.0))
    for line, kind, a, b, g in conds:
        ia, ib = rows(line, a), rows(line, b)
        la, lb, lg = lists[kind]
        la.append(ia)
        lb.append(ib)
        lg.append(np.full(len(ia), g * (gr_scale if kind == "GR" else 1.0)))
    mats = {kind: couplings_from_lists(n, *lists[kind]) for kind in lists}
    get = lambda key, default=0.0: np.array([nd[4].get(key, default) for nd in nodes], float)  # noqa: E731
    Q = sum(get(k) for k in _LOADS)
    T = get("T") + tabs
    Q_t = T_t = None
    if times is not None:
        Q_t, T_t = np.tile(Q, (len(times), 1)), np.tile(T, (len(times), 1))
    nums = np.array([x[2] for x in qi_set], np.int64)
    at_rows = rows(0, nums) if np.isin(nums, sorted_numbers).all() else None  # all at once, else each one's message
    for j, (line, what, num, q, expr) in enumerate(qi_set):
        i = rows(line, np.array([num]))[0] if at_rows is None else at_rows[j]
        others = sum(nodes[i][4].get(k, 0.0) for k in _LOADS if k != "QI") if what == "QI" else tabs
        if what == "QI":
            Q[i] = q + others
        else:
            T[i] = q + others
        if times is not None:
            vals = [value(line, expr, what, at(t)) + others for t in times] if _INTRP1.search(expr) else \
                [q + others] * len(times)
            (Q_t if what == "QI" else T_t)[:, i] = vals
    refs = np.array([g[1:4] for g in gr_of_t], np.int64).reshape(-1, 3)
    if np.isin(refs, sorted_numbers).all():
        gr_tables = tuple((*(int(v) for v in r), g[4], g[5]) for r, g in zip(rows(0, refs.ravel()).reshape(-1, 3),
                                                                               gr_of_t))
    else:
        gr_tables = tuple((*(rows(line, np.array([v]))[0] for v in (a, b, k)), x, y)
                          for line, a, b, k, x, y in gr_of_t)
    coords = None
    if any(("FX" in nd[4] or "FY" in nd[4] or "FZ" in nd[4]) for nd in nodes):
        has = np.array([any(k in nd[4] for k in ("FX", "FY", "FZ")) for nd in nodes])
        coords = np.where(has[:, None], np.c_[get("FX"), get("FY"), get("FZ")], np.nan)
    notes = ()
    if skipped:
        notes += (f"{skipped} statements of the operation blocks ($VARIABLES1/2, $EXECUTION, …) not interpreted",)
    if gr_scale != 1.0:
        notes += (f"GR rescaled from STEFAN = {consts['STEFAN']!r} to sigma = {SIGMA!r}",)
    net = Network(numbers=numbers, labels=np.array([nd[3] for nd in nodes], dtype=object).astype(str),
                  kind=np.array([nd[1] for nd in nodes]), T=T, C=get("C"), A=get("A"),
                  alp=get("ALP"), eps=get("EPS"), QI=Q, GL=mats["GL"], GR=mats["GR"], coordinates=coords,
                  source=str(path), notes=notes, gr_tables=gr_tables)
    return net, times, Q_t, T_t


__all__ = ["read_esatan", "read_esatan_in_time", "statements"]
