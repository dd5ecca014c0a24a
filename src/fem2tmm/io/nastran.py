"""Nastran bulk data reader (in-house, vectorised).

:func:`read_nastran` turns a Nastran bulk data deck (``.bdf``, ``.nas``, ``.dat``) into a
:class:`fem2tmm.mesh.Mesh`.

Cards read
----------
=========================  ==========================================================================
GRID                       ID, CP, X1-X3 (CP: coordinate system of the position; CD, PS, SEID ignored)
GRDSET                     default CP (and CD, ignored) for GRIDs whose CP field is blank
CORD2R, CORD2C, CORD2S     rectangular, cylindrical (r, theta deg, z), spherical (r, theta deg, phi deg)
                           systems given by three points A, B, C in a reference system RID; RID chains
                           of any depth and in any order in the file; blank coordinates are 0.0
CTRIA3, CQUAD4             -> ``tri3``, ``quad4``; THETA/MCID, ZOFFS, TFLAG and T1-T4 are tolerated and
                           ignored; a blank PID means PID = EID (Nastran's default)
CTETRA, CHEXA, CPENTA      -> ``tet4``, ``hex8``, ``wedge6`` (4, 8, 6 nodes; Nastran's node order is the
                           VTK order of :mod:`fem2tmm.mesh.elements`); quadratic variants are an error
PSHELL                     PID, MID1 (the membrane material, the one heat transfer uses), T
PSOLID                     PID, MID
MAT4                       MID, K, CP, RHO
MAT1                       MID, RHO (E, G, NU, ... ignored); MAT4 values win when both exist
=========================  ==========================================================================

Every other card is counted and listed once in a single warning.

Formats
-------
Small field (8-character fields), large field (``GRID*``: 16-character fields, two physical lines per
eight data fields), free field (commas; ``GRID*,`` is large free field, four data fields per line) and any
mix of them within a deck or a card.  A continuation line starts with ``+`` (small field), ``*`` (large
field) or a blank first field; a blank first field continues in the width of the line before it.  The
markers in field 10 / field 1 are not matched: continuation lines must follow their parent, as modern
Nastran requires.  Tabs expand to 8-column stops.  ``$`` starts a comment anywhere on a line.  Real
numbers may use ``E`` or ``D`` exponents and Nastran's implicit exponent (``1.-3``, ``-.5+2``);
integers are accepted in real fields.  ``INCLUDE 'file'`` (quoted, possibly over several lines, or bare)
is read relative to the including file, recursively; an include cycle is an error.  When the top file
has a ``BEGIN BULK`` line, everything before it (executive and case control) is skipped; reading stops
at ``ENDDATA``.  Decks without either are read whole.  Columns past 72 of a fixed-format line (field
10) are ignored; a free-field line holds at most 8 data fields (4 in large free field) plus a marker.

Units
-----
Point coordinates are multiplied by ``length_scale(unit)`` (metres per deck length unit).  Property
data goes into ``Mesh.properties["PID <n>"]`` as :class:`~fem2tmm.mesh.PropertyData` in SI units:

* ``unit="m"``: the deck is taken to be SI (m, kg, s, K, W): values are used as they are.
* ``unit="mm"``: the deck is taken to be in the mm-tonne-s system: conductivity mW/(mm K) = W/(m K)
  (x1), density t/mm^3 (x1e12 -> kg/m^3), specific heat mJ/(t K) = mm^2/(s^2 K) (x1e-6 -> J/(kg K)),
  thickness mm (x1e-3 -> m).
* any other unit: the thickness is scaled to metres; material values are left ``None`` with a
  warning, because the deck's mass/energy units cannot be inferred: the case file must give them.

A blank K, CP or RHO gives ``None`` (Nastran's MAT4 default RHO = 1.0 is deliberately not applied),
and so does a material id that no MAT4/MAT1 card defines (with a warning).

Output
------
Points are kept in file order (GRIDs that no element uses are kept; the model builder ignores them),
``Mesh.node_ids`` holds the GRID ids, each block's ``ids`` the element ids, blocks follow
:data:`fem2tmm.mesh.elements.ELEMENT_TYPES` order with elements in file order.  Each property id becomes a
group ``"PID <n>"`` (dim 2 for shells, 3 for solids) with its elements and their nodes.

Implementation: one pass over the lines does only classification and slicing (a fixed-format card is
kept as the raw bytes of its data columns); every field of every card is then converted with numpy on
(n, width) byte arrays, and coordinate systems are applied vectorised per system.
"""

from __future__ import annotations

import re
from bisect import bisect_right
import warnings
from array import array
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Fem2TmmError, format_ids
from ..mesh.elements import DIM, ELEMENT_TYPES
from ..mesh import ElementBlock, Group, Mesh, PropertyData, unique_ints
from .units import length_scale

__all__ = ["read_nastran"]

# --------------------------------------------------------------------------------------------- cards

#: element card -> (fem2tmm type, number of nodes read, number of further node fields that must be blank)
_ELEMENTS: dict[str, tuple[str, int, int]] = {
    "CTRIA3": ("tri3", 3, 0),
    "CQUAD4": ("quad4", 4, 0),
    "CTETRA": ("tet4", 4, 6),
    "CHEXA": ("hex8", 8, 12),
    "CPENTA": ("wedge6", 6, 9),
}
_CORDS = {"CORD2R": "R", "CORD2C": "C", "CORD2S": "S"}
_CORD_FIELDS = ("A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3")
_SUPPORTED = ("GRID", "GRDSET", *_CORDS, *_ELEMENTS, "PSHELL", "PSOLID", "MAT4", "MAT1")

#: card name as written in field 1 (bytes, upper case, optionally with '*') -> (card, line width)
_NAMES: dict[bytes, tuple[str, int]] = {}
for _n in _SUPPORTED:
    _NAMES[_n.encode()] = (_n, 8)
    _NAMES[_n.encode() + b"*"] = (_n, 16)

_BEGIN_BULK = re.compile(rb"^[ \t]*BEGIN[ \t]+BULK", re.IGNORECASE | re.MULTILINE)
_SMALL, _LARGE, _GENERIC = 8, 16, 1  # card storage modes (fixed widths, or a list of field strings)
_SPACE, _PLUS, _STAR, _COMMA = 32, 43, 42, 44


# --------------------------------------------------------------------------------------------- scanning


class _Deck:
    """Cards of a deck, collected line by line, converted to numpy arrays on demand.

    A fixed-format card whose lines all have one width (8 or 16) is kept as one bytes record: the data
    columns 9-72 of its lines, each padded to 64 characters.  Any other card (free field, mixed widths)
    is kept as a list of stripped field strings.  Each card has a sequence number (file order) that
    locates it (file, line) for error messages.
    """

    def __init__(self):
        self.files: list[str] = []
        self.card_line = array("q")  # per card (sequence number): 1-based line number
        self.seg_start: list[int] = []  # cards seg_start[k] .. come from file seg_file[k]
        self.seg_file: list[int] = []
        #: (card, width) -> (records, sequence numbers) of fixed-format cards
        self.fixed: dict[tuple[str, int], tuple[list[bytes], array]] = {}
        #: field-1 spelling (b"GRID", b"GRID*") -> (card, width, records, sequence numbers)
        self.names: dict[bytes, tuple[str, int, list, array]] = {}
        for spelled, (card, width) in _NAMES.items():
            store = self.fixed.setdefault((card, width), ([], array("q")))
            self.names[spelled] = (card, width, *store)
        #: card -> (field lists, sequence numbers) of the other cards
        self.generic: dict[str, tuple[list[list[bytes]], array]] = {}
        self.unknown: Counter = Counter()
        self.stack: list[Path] = []
        self.ended = False
        self.bulk_started = False

    # ------------------------------------------------------------------ locations
    def where(self, seq: int) -> str:
        k = bisect_right(self.seg_start, seq) - 1
        return f"{self.files[self.seg_file[k]]}:{self.card_line[seq]}"

    def _segment(self, fi: int) -> None:
        self.seg_start.append(len(self.card_line))
        self.seg_file.append(fi)

    def reset(self) -> None:
        """Forget every card read so far (a BEGIN BULK met after executive/case control lines)."""
        for recs, seqs in [*self.fixed.values(), *self.generic.values()]:
            recs.clear()
            del seqs[:]
        self.unknown.clear()

    def _generic_store(self, card: str) -> tuple[list, array]:
        store = self.generic.get(card)
        if store is None:
            store = self.generic[card] = ([], array("q"))
        return store

    # ------------------------------------------------------------------ reading
    def read(self, path: Path, top: bool = False) -> None:
        path = path.resolve()
        if path in self.stack:
            chain = " -> ".join(str(p) for p in [*self.stack, path])
            raise Fem2TmmError(f"INCLUDE cycle: {chain}; remove the INCLUDE that closes the loop")
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise Fem2TmmError(f"cannot read Nastran file {path}: {exc.strerror or exc}") from None
        self.stack.append(path)
        self.files.append(str(path))
        try:
            self._scan(data, len(self.files) - 1, top)
        finally:
            self.stack.pop()

    def _scan(self, data: bytes, fi: int, top: bool) -> None:  # noqa: C901 - the one hot loop
        if b"\t" in data:
            data = data.expandtabs(8)
        lines = data.splitlines()
        start = 0
        if top and _BEGIN_BULK.search(data):
            while not _BEGIN_BULK.match(lines[start]):
                start += 1
            start += 1
            self.bulk_started = True
        has_dollar = b"$" in data
        has_comma = b"," in data
        del data  # the lines hold the text from here on
        names = self.names
        card_line = self.card_line
        where_file = self.files[fi]
        self._segment(fi)

        # the card being built: its store (None: no card yet, False: an ignored card), its mode
        # (_SMALL/_LARGE: one record in store[0]; _GENERIC: a field list), its number of lines and the
        # width of its last line
        cur = None
        mode = _SMALL
        nparts = 0
        last = _SMALL

        rows = iter(range(start, len(lines)))
        for i in rows:
            raw = lines[i]
            if has_dollar:
                k = raw.find(b"$")
                if k >= 0:
                    raw = raw[:k]
            if not raw:
                continue
            c = raw[0]
            if c != _SPACE and c != _PLUS and c != _STAR and c != _COMMA and not (has_comma and b"," in raw):
                # ---- fast path: a new fixed-format card whose name starts in column 1
                key = names.get(raw[:8].rstrip())
                if key is not None:
                    card, mode, recs, seqs = key
                    recs.append(raw[8:72])
                    seqs.append(len(card_line))
                    card_line.append(i + 1)
                    cur = (recs, seqs)
                    nparts = 1
                    last = mode
                    continue
            # ---- everything else: blank lines, continuations, free field, special and unknown cards
            if raw.isspace():
                continue
            free = has_comma and b"," in raw
            if free:
                head, _, rest = raw.partition(b",")
                head = head.strip()
            else:
                head = raw[:8].strip()
            if not head or head[0] == _PLUS or head[0] == _STAR:
                # continuation line
                if cur is None:
                    raise Fem2TmmError(
                        f"{where_file}:{i + 1}: continuation line with no card before it: "
                        f"{raw.decode('latin-1').rstrip()!r}"
                    )
                if cur is False:
                    continue  # continuation of an ignored card
                width = _LARGE if (head[:1] == b"*" or (not head and last == _LARGE)) else _SMALL
                last = width
                if not free and width == mode:
                    recs = cur[0]
                    recs[-1] = recs[-1].ljust(64 * nparts) + raw[8:72]
                    nparts += 1
                    continue
                if mode != _GENERIC:  # the card mixes formats: keep it as a list of fields
                    rec, sq = cur[0].pop(), cur[1].pop()
                    cur = self._generic_store(card)
                    cur[0].append(_split_fixed(rec, mode))
                    cur[1].append(sq)
                    mode = _GENERIC
                cur[0][-1].extend(
                    self._free_fields(rest, width, where_file, i + 1) if free else _split_fixed(raw[8:72], width)
                )
                continue
            # ---- a new card that is not on the fast path
            cur = False
            uhead = head.upper()
            if uhead.startswith(b"INCLUDE"):
                for _ in range(self._include(lines, i, where_file) - i):
                    next(rows)  # lines the INCLUDE statement used
                self._segment(fi)
                cur = None
                if self.ended:
                    return
                continue
            if uhead.startswith(b"ENDDATA"):
                self.ended = True
                return
            if uhead.startswith(b"BEGIN"):
                if b"BULK" in raw.upper():
                    if not self.bulk_started:
                        self.reset()  # everything before was executive / case control
                        self.bulk_started = True
                    cur = None
                    continue
                self.unknown[uhead.decode("latin-1")] += 1
                continue
            key = names.get(uhead)
            if key is None:
                self.unknown[uhead.rstrip(b"*").decode("latin-1")] += 1
                continue
            card, width, recs, seqs = key
            last = width
            if free:
                mode = _GENERIC
                cur = self._generic_store(card)
                cur[0].append(self._free_fields(rest, width, where_file, i + 1))
            else:  # a fixed-format name not starting in column 1, or in lower case
                mode = width
                cur = (recs, seqs)
                recs.append(raw[8:72])
                nparts = 1
            cur[1].append(len(card_line))
            card_line.append(i + 1)

    @staticmethod
    def _free_fields(rest: bytes, width: int, where_file: str, line: int) -> list[bytes]:
        """Data fields of a free-field line (``rest`` = text after the first comma)."""
        fields = [f.strip() for f in rest.split(b",")]
        n = 8 if width == _SMALL else 4
        if len(fields) > n + 1:
            raise Fem2TmmError(
                f"{where_file}:{line}: free-field line has {len(fields)} data fields; at most {n} "
                f"(plus a continuation marker) fit on one {'small' if n == 8 else 'large'}-field line: "
                "continue the card on a new line starting with ','"
            )
        return fields[:n] + [b""] * (n - min(len(fields), n))

    def _include(self, lines: list[bytes], i: int, where_file: str) -> int:
        """Read the file named by the INCLUDE statement at line ``i``; return the last line it used."""
        text = lines[i].split(b"$", 1)[0].strip()[len(b"INCLUDE") :].strip()
        if text[:1] in (b"'", b'"'):
            quote = text[:1]
            text = text[1:]
            while quote not in text:  # a quoted name may continue on the next lines
                i += 1
                if i >= len(lines):
                    raise Fem2TmmError(f"{where_file}:{i}: INCLUDE file name has no closing quote")
                text += lines[i].strip()
            text = text[: text.index(quote)]
        if not text:
            raise Fem2TmmError(f"{where_file}:{i + 1}: INCLUDE without a file name")
        target = Path(text.decode("latin-1").replace("\\", "/"))
        if not target.is_absolute():
            target = Path(where_file).parent / target
        if not target.is_file():
            raise Fem2TmmError(f"{where_file}:{i + 1}: INCLUDE file {str(target)!r} does not exist")
        self.read(target)
        return i

    # ------------------------------------------------------------------ conversion to arrays
    def table(self, card: str, spec: dict[str, tuple[int, str]]) -> "_Table":
        """All cards ``card`` as columns.

        ``spec`` maps a column name to (0-based data field index, kind); kind ``"i"`` integer,
        ``"r"`` real, ``"b"`` only whether the field is blank.  Rows are in file order.
        """
        nf = max(idx for idx, _ in spec.values()) + 1
        chunks = []
        for (cname, width), (records, seqs) in self.fixed.items():
            if cname == card and records:
                chunks.append((records, width, np.frombuffer(seqs, dtype=np.int64)))
        lists, seqs = self.generic.get(card, ([], None))
        if lists:
            width = max(16, max((len(f) for fl in lists for f in fl[:nf]), default=1))
            records = [b"".join([f.ljust(width) for f in fl[:nf]]) for fl in lists]
            chunks.append((records, width, np.frombuffer(seqs, dtype=np.int64)))
        cols: dict[str, list] = {k: [] for k in spec}
        blanks: dict[str, list] = {k: [] for k in spec}
        seq_parts = []
        for records, width, seqs in chunks:
            u = np.array(records, dtype=f"S{width * nf}").view(np.uint8).reshape(len(records), nf, width)
            u = np.where(u == 0, np.uint8(_SPACE), u)
            seq_parts.append(seqs)
            for key, (idx, kind) in spec.items():
                f = u[:, idx, :]
                if kind == "b":
                    blanks[key].append((f == _SPACE).all(axis=1))
                    continue
                val, blank, ok = (_parse_int if kind == "i" else _parse_real)(f)
                if not ok.all():
                    r = int(np.flatnonzero(~ok)[0])
                    what = "an integer" if kind == "i" else "a real number"
                    raise Fem2TmmError(
                        f"{self.where(int(seqs[r]))}: {card} field {idx + 2} ({key}) "
                        f"{bytes(f[r]).decode('latin-1').strip()!r} is not {what}"
                        + (f" ({int((~ok).sum())} such fields in all)" if (~ok).sum() > 1 else "")
                    )
                cols[key].append(val)
                blanks[key].append(blank)
        if not seq_parts:
            empty = {k: np.zeros(0, np.int64 if kind == "i" else np.float64) for k, (_, kind) in spec.items()}
            return _Table(self, card, np.zeros(0, np.int64), empty, {k: np.zeros(0, bool) for k in spec})
        seq = np.concatenate(seq_parts)
        order = np.argsort(seq, kind="stable")
        return _Table(
            self,
            card,
            seq[order],
            {k: np.concatenate(v)[order] for k, v in cols.items() if v},
            {k: np.concatenate(v)[order] for k, v in blanks.items()},
        )


def _split_fixed(record: bytes, width: int) -> list[bytes]:
    """Stripped fields of a fixed-format record (data columns 9-72 of its lines, 64 per line)."""
    n = -(-max(len(record), 1) // 64) * 64
    record = record.ljust(n)
    return [record[j : j + width].strip() for j in range(0, n, width)]


@dataclass
class _Table:
    """Columns of one card type: ``val[key]`` (n,) values, ``blank[key]`` (n,) bool, ``seq`` (n,)."""

    deck: _Deck
    card: str
    seq: np.ndarray
    val: dict
    blank: dict

    def __len__(self) -> int:
        return len(self.seq)

    def where(self, row: int) -> str:
        return self.deck.where(int(self.seq[row]))

    def require(self, *keys: str) -> None:
        """Error if any of the columns ``keys`` is blank on some card."""
        for key in keys:
            bad = np.flatnonzero(self.blank[key])
            if len(bad):
                raise Fem2TmmError(
                    f"{self.where(bad[0])}: {self.card} field {key!r} is blank; it is required"
                    + (f" ({len(bad)} {self.card} cards in all)" if len(bad) > 1 else "")
                )

    def get(self, key: str, default):
        """Column ``key`` with blanks replaced by ``default`` (a scalar or an (n,) array)."""
        return np.where(self.blank[key], default, self.val[key])


# --------------------------------------------------------------------------------------------- fields


def _parse_int(u: np.ndarray):
    """Integers of an (n, w) uint8 array of fixed-width ASCII fields (blanks = space).

    Returns ``(value (n,) int64, blank (n,) bool, ok (n,) bool)``; a valid field is an optional sign
    followed by 1-18 digits, with blanks only around it.
    """
    n, w = u.shape
    nonsp = u != _SPACE
    blank = ~nonsp.any(axis=1)
    isdig = (u >= 48) & (u <= 57)
    first = nonsp.argmax(axis=1)
    lastc = w - 1 - nonsp[:, ::-1].argmax(axis=1)
    count = nonsp.sum(axis=1)
    lead = u[np.arange(n), first]
    signed = (lead == 45) | (lead == 43)
    ndig = isdig.sum(axis=1)
    ok = blank | ((count == lastc - first + 1) & (ndig == count - signed) & (ndig >= 1) & (ndig <= 18))
    val = np.zeros(n, np.int64)
    for j in range(w):  # Horner over the columns: w vector operations, not n Python steps
        d = isdig[:, j]
        val = np.where(d, val * 10 + (u[:, j].astype(np.int64) - 48), val)
    val = np.where(lead == 45, -val, val)
    val[blank | ~ok] = 0
    return val, blank, ok


_REAL_CHARS = np.zeros(256, bool)
_REAL_CHARS[list(b"0123456789.+-E ")] = True


def _parse_real(u: np.ndarray):
    """Reals of an (n, w) uint8 array of fixed-width ASCII fields, Nastran style.

    Accepts ``1.5``, ``1.5E-3``, ``1.5D-3`` (any case), the implicit exponent ``1.5-3`` / ``-.5+2``
    and integers.  Returns ``(value (n,) float64, blank (n,) bool, ok (n,) bool)``.
    """
    n, w = u.shape
    up = np.where((u >= 97) & (u <= 122), u - 32, u).astype(np.uint8)
    up[up == 68] = 69  # D -> E
    blank = (up == _SPACE).all(axis=1)
    has_e = (up == 69).any(axis=1)
    sign = (up == 43) | (up == 45)
    prev = np.zeros_like(sign)
    prev[:, 1:] = ((up[:, :-1] >= 48) & (up[:, :-1] <= 57)) | (up[:, :-1] == 46)
    implicit = sign & prev & ~has_e[:, None]
    if implicit.any():
        pos = np.where(implicit.any(axis=1), implicit.argmax(axis=1), w + 1)[:, None]
        j = np.arange(w + 1)[None, :]
        src = np.clip(j - (j > pos), 0, w - 1)
        up = np.take_along_axis(up, src, axis=1)
        up = np.where(j == pos, np.uint8(69), up)
        up[:, w] = np.where(pos[:, 0] <= w - 1, up[:, w], _SPACE)
        w += 1
    up[blank, 0] = 48  # '0'
    ok = _REAL_CHARS[up].all(axis=1)
    up[~ok] = _SPACE
    up[~ok, 0] = 48
    flat = np.ascontiguousarray(up).view(f"S{w}").ravel()
    try:
        val = flat.astype(np.float64)
    except ValueError:
        val = np.zeros(n)
        for r in range(n):  # only reached when some field is malformed: find which
            try:
                val[r] = float(flat[r])
            except ValueError:
                ok[r] = False
    ok &= np.isfinite(val)
    val[blank | ~ok] = 0.0
    return val, blank, ok


# --------------------------------------------------------------------------------------------- geometry


def _cartesian(kind: str, x: np.ndarray) -> np.ndarray:
    """Local Cartesian coordinates (k, 3) of positions ``x`` (k, 3) given in a system of ``kind``.

    R: (x, y, z); C: (r, theta deg, z); S: (r, theta deg from the z axis, phi deg azimuth).
    """
    if kind == "R":
        return x
    r = x[:, 0]
    t = np.radians(x[:, 1])
    if kind == "C":
        return np.stack([r * np.cos(t), r * np.sin(t), x[:, 2]], axis=1)
    p = np.radians(x[:, 2])
    return np.stack([r * np.sin(t) * np.cos(p), r * np.sin(t) * np.sin(p), r * np.cos(t)], axis=1)


def _coordinate_systems(deck: _Deck) -> dict[int, tuple[str, np.ndarray, np.ndarray]]:
    """CID -> (kind, origin (3,), rows ex, ey, ez (3, 3)) in the basic system, deck length units."""
    spec = {"CID": (0, "i"), "RID": (1, "i")}
    spec.update({name: (2 + j, "r") for j, name in enumerate(_CORD_FIELDS)})
    cards: dict[int, tuple[str, int, np.ndarray, str]] = {}
    for card, kind in _CORDS.items():
        t = deck.table(card, spec)
        t.require("CID")  # blank A, B, C coordinates are 0.0
        rid = t.get("RID", 0)
        pts = np.stack([t.val[name] for name in _CORD_FIELDS], axis=1).reshape(-1, 3, 3)
        for r in range(len(t)):
            cid = int(t.val["CID"][r])
            if cid <= 0:
                raise Fem2TmmError(f"{t.where(r)}: {card} id must be a positive integer, got {cid}")
            if cid in cards:
                raise Fem2TmmError(
                    f"coordinate system {cid} is defined twice: {cards[cid][3]} and {t.where(r)}"
                )
            cards[cid] = (kind, int(rid[r]), pts[r], t.where(r))
    systems: dict[int, tuple[str, np.ndarray, np.ndarray]] = {0: ("R", np.zeros(3), np.eye(3))}
    for cid in cards:
        path = []
        c = cid
        while c not in systems:  # walk up the reference chain to a resolved system
            if c in path:
                chain = " -> ".join(str(x) for x in [*path[path.index(c) :], c])
                raise Fem2TmmError(
                    f"coordinate systems reference each other in a cycle: {chain} ({cards[c][3]})"
                )
            if c not in cards:
                child = path[-1]
                raise Fem2TmmError(
                    f"{cards[child][3]}: coordinate system {child} is defined in system {c}, which is not "
                    f"defined{_cord_hint(deck)}"
                )
            path.append(c)
            c = cards[c][1]
        for c in reversed(path):
            kind, rid, abc, where = cards[c]
            rkind, rorig, raxes = systems[rid]
            a, b, cc = rorig + _cartesian(rkind, abc) @ raxes
            ez = b - a
            lz = np.linalg.norm(ez)
            ac = cc - a
            if lz == 0.0 or np.linalg.norm(ac) == 0.0:
                raise Fem2TmmError(f"{where}: coordinate system {c}: points A, B, C must be distinct")
            ez = ez / lz
            ex = ac - (ac @ ez) * ez
            lx = np.linalg.norm(ex)
            if lx <= 1e-10 * np.linalg.norm(ac):
                raise Fem2TmmError(
                    f"{where}: coordinate system {c}: point C lies on the z axis through A and B; "
                    "it must define the xz plane"
                )
            ex = ex / lx
            systems[c] = (kind, a, np.stack([ex, np.cross(ez, ex), ez]))
    return systems


def _cord_hint(deck: _Deck) -> str:
    other = sorted(n for n in deck.unknown if n.startswith("CORD"))
    if not other:
        return ""
    return f" (this reader supports CORD2R/CORD2C/CORD2S only; the deck has {', '.join(other)} cards)"


def _grids(deck: _Deck, systems) -> tuple[np.ndarray, np.ndarray, "_Table"]:
    """GRID ids (n,) and basic coordinates (n, 3) in deck length units."""
    gs = deck.table("GRDSET", {"CP": (1, "i")})
    if len(gs) > 1:
        raise Fem2TmmError(f"more than one GRDSET card: {gs.where(0)} and {gs.where(1)}; keep one")
    cp_default = int(gs.get("CP", 0)[0]) if len(gs) else 0
    t = deck.table("GRID", {"ID": (0, "i"), "CP": (1, "i"), "X1": (2, "r"), "X2": (3, "r"), "X3": (4, "r")})
    t.require("ID")
    ids = t.val["ID"]
    cp = t.get("CP", cp_default)
    x = np.stack([t.val["X1"], t.val["X2"], t.val["X3"]], axis=1)  # blanks parse as 0.0 (default)
    for c in unique_ints(cp):
        c = int(c)
        if c == 0:
            continue
        sel = np.flatnonzero(cp == c)
        if c not in systems:
            raise Fem2TmmError(
                f"{t.where(sel[0])}: GRIDs {format_ids(ids[sel])} are given in coordinate system {c}, "
                f"which is not defined{_cord_hint(deck)}"
            )
        kind, orig, axes = systems[c]
        x[sel] = orig + _cartesian(kind, x[sel]) @ axes
    return ids, x, t


def _check_unique(ids: np.ndarray, seq: np.ndarray, what: str, deck: _Deck) -> None:
    """Error naming the first duplicated id and its first two locations (cards ``seq``)."""
    if len(ids) < 2:
        return
    order = np.lexsort((seq, ids))
    s = ids[order]
    dup = np.flatnonzero(s[1:] == s[:-1])
    if len(dup):
        r0, r1 = order[dup[0]], order[dup[0] + 1]
        n_dup = len(unique_ints(s[dup]))
        raise Fem2TmmError(
            f"{what} {int(s[dup[0]])} is defined twice: {deck.where(int(seq[r0]))} and {deck.where(int(seq[r1]))}"
            + (f"; {n_dup} ids are duplicated: {format_ids(unique_ints(s[dup]))}" if n_dup > 1 else "")
            + "; ids must be unique"
        )


def _bad_ids(ids: np.ndarray, what: str, where) -> None:
    bad = np.flatnonzero(ids <= 0)
    if len(bad):
        raise Fem2TmmError(f"{where(bad[0])}: {what} ids must be positive integers: {format_ids(ids[bad])}")


# --------------------------------------------------------------------------------------------- properties


def _material_factors(unit: str) -> tuple[float, float, float] | None:
    """SI factors for (conductivity, density, specific heat) of a deck in ``unit``; None: unknown."""
    u = str(unit).strip().lower()
    if u == "m":
        return 1.0, 1.0, 1.0
    if u == "mm":  # mm-tonne-s: mW/(mm K) = W/(m K); t/mm^3 = 1e12 kg/m^3; mJ/(t K) = 1e-6 J/(kg K)
        return 1.0, 1e12, 1e-6
    return None


def _properties(deck: _Deck, used: dict[int, int], unit: str, scale: float) -> dict[str, PropertyData]:
    """``"PID n"`` -> PropertyData (SI) for the property ids in ``used`` (PID -> element dimension)."""
    ps = deck.table("PSHELL", {"PID": (0, "i"), "MID": (1, "i"), "T": (2, "r")})
    pv = deck.table("PSOLID", {"PID": (0, "i"), "MID": (1, "i")})
    m4 = deck.table("MAT4", {"MID": (0, "i"), "K": (1, "r"), "CP": (2, "r"), "RHO": (3, "r")})
    m1 = deck.table("MAT1", {"MID": (0, "i"), "RHO": (4, "r")})
    for t in (ps, pv, m4, m1):
        t.require(*(("PID",) if "PID" in t.val else ("MID",)))
    pid_all = np.concatenate([ps.val["PID"], pv.val["PID"]])
    _check_unique(pid_all, np.concatenate([ps.seq, pv.seq]), "property id (PSHELL/PSOLID)", deck)
    _check_unique(m4.val["MID"], m4.seq, "MAT4", deck)
    _check_unique(m1.val["MID"], m1.seq, "MAT1", deck)

    mats: dict[int, list] = {}
    for r in range(len(m1)):
        rho = None if m1.blank["RHO"][r] else float(m1.val["RHO"][r])
        mats[int(m1.val["MID"][r])] = [None, rho, None]
    for r in range(len(m4)):
        vals = [None if m4.blank[k][r] else float(m4.val[k][r]) for k in ("K", "RHO", "CP")]
        old = mats.get(int(m4.val["MID"][r]), [None, None, None])
        mats[int(m4.val["MID"][r])] = [v if v is not None else o for v, o in zip(vals, old)]

    factors = _material_factors(unit)
    out: dict[str, PropertyData] = {}
    missing: list[str] = []
    dropped = False
    for table, card, dim in ((ps, "PSHELL", 2), (pv, "PSOLID", 3)):
        for r in range(len(table)):
            pid = int(table.val["PID"][r])
            if pid not in used:
                continue
            if used[pid] != dim:
                raise Fem2TmmError(
                    f"{table.where(r)}: {card} {pid} is used by {'shell' if used[pid] == 2 else 'solid'} "
                    f"elements; a {card} is for {'shell' if dim == 2 else 'solid'} elements"
                )
            mid = None if table.blank["MID"][r] else int(table.val["MID"][r])
            t = None
            if card == "PSHELL" and not table.blank["T"][r]:
                t = float(table.val["T"][r]) * scale
            k = rho = cp = None
            if mid is not None:
                if mid not in mats:
                    missing.append(f"MID {mid} (PID {pid})")
                elif factors is None:
                    dropped = dropped or any(v is not None for v in mats[mid])
                else:
                    vals = [None if v is None else v * f for v, f in zip(mats[mid], factors)]
                    k, rho, cp = vals
            out[f"PID {pid}"] = PropertyData(
                thickness=t, conductivity=k, density=rho, specific_heat=cp, material_id=mid
            )
    if missing:
        warnings.warn(
            f"{deck.files[0]}: properties reference materials with no MAT4/MAT1 card: {', '.join(missing)}; "
            "their conductivity, density and specific heat must come from the case file",
            stacklevel=3,
        )
    if dropped:
        warnings.warn(
            f"{deck.files[0]}: material values (MAT4/MAT1) cannot be interpreted for unit {unit!r} "
            "(only 'm' = SI and 'mm' = mm-tonne-s are defined); they are ignored: give conductivity, "
            "density and specific_heat in the case file",
            stacklevel=3,
        )
    return out


# --------------------------------------------------------------------------------------------- reader


def read_nastran(path, unit: str = "m") -> Mesh:
    """Read a Nastran bulk data deck into a :class:`~fem2tmm.mesh.Mesh`.

    Parameters
    ----------
    path : str or Path
        The deck (``.bdf``, ``.nas``, ``.dat``; any name works).  INCLUDEd files are read relative to
        the file that includes them.
    unit : str
        Length unit of the deck (``m``, ``cm``, ``mm``, ``um``, ``in``, ``ft``); also selects how
        material values are interpreted (see the module docstring: ``m`` = SI, ``mm`` = mm-tonne-s).

    Returns
    -------
    Mesh
        ``points`` (n, 3) float64 in metres, in GRID file order; ``node_ids`` (n,) GRID ids; one block per
        element type with the original element ids; groups ``"PID <n>"``; ``properties["PID <n>"]``
        with PSHELL thickness (m) and MAT4/MAT1 values (SI) where the deck gives them.

    Raises
    ------
    Fem2TmmError
        Unreadable file or INCLUDE, include cycle, malformed field (file and line named), duplicate
        GRID/element/property/material/coordinate-system ids, undefined or cyclic coordinate systems,
        elements referencing missing GRIDs (element and GRID ids named), quadratic solid elements,
        PSHELL used by solids or PSOLID by shells, a deck with no supported element.

    Warns
    -----
    One warning listing the unsupported card types and their counts; one for materials that are
    referenced but not defined; one when material values cannot be converted for ``unit``.
    """
    path = Path(path)
    scale = length_scale(unit, where=f"{path}: unit")
    deck = _Deck()
    deck.read(path, top=True)
    source = str(path)

    systems = _coordinate_systems(deck)
    gid, x, gtab = _grids(deck, systems)
    _bad_ids(gid, "GRID", gtab.where)
    _check_unique(gid, gtab.seq, "GRID", deck)
    order = np.argsort(gid, kind="stable")
    sorted_gid = gid[order]

    # elements, per card type
    per_type: dict[str, list] = {t: [] for t in ELEMENT_TYPES}
    all_eids, all_seqs = [], []
    missing_el, missing_gr, missing_seq = [], [], []
    quadratic = []
    for card, (etype, k, extra) in _ELEMENTS.items():
        spec = {"EID": (0, "i"), "PID": (1, "i")}
        spec.update({f"G{j + 1}": (2 + j, "i") for j in range(k)})
        spec.update({f"G{k + j + 1}": (2 + k + j, "b") for j in range(extra)})
        t = deck.table(card, spec)
        if not len(t):
            continue
        t.require("EID", *(f"G{j + 1}" for j in range(k)))
        if etype in ("tri3", "quad4"):
            pid = t.get("PID", t.val["EID"])  # Nastran: PID defaults to EID for shells
        else:
            t.require("PID")
            pid = t.val["PID"]
        eid = t.val["EID"]
        _bad_ids(eid, card, t.where)
        if extra:
            quad = ~np.all([t.blank[f"G{k + j + 1}"] for j in range(extra)], axis=0)
            if quad.any():
                quadratic.append((card, eid[quad], t.where(np.flatnonzero(quad)[0])))
                continue
        g = np.stack([t.val[f"G{j + 1}"] for j in range(k)], axis=1)
        pos = np.searchsorted(sorted_gid, g)
        found = sorted_gid[np.minimum(pos, len(sorted_gid) - 1)] == g if len(gid) else np.zeros(g.shape, bool)
        if not found.all():
            rows = np.flatnonzero(~found.all(axis=1))
            missing_el.append(eid[rows])
            missing_gr.append(g[~found])
            missing_seq.append(t.seq[rows[0]])
        cells = order[np.minimum(pos, len(gid) - 1)] if len(gid) else pos
        per_type[etype].append((eid, pid, cells))
        all_eids.append(eid)
        all_seqs.append(t.seq)
    if quadratic:
        msg = "; ".join(
            f"{card} elements {format_ids(ids)} (first at {w}) have midside nodes" for card, ids, w in quadratic
        )
        raise Fem2TmmError(
            f"{msg}: only linear elements are supported (CTETRA 4 nodes, CPENTA 6, CHEXA 8); "
            "convert the mesh to linear elements"
        )
    if missing_el:
        raise Fem2TmmError(
            f"{source}: elements {format_ids(unique_ints(np.concatenate(missing_el)))} reference GRIDs "
            f"{format_ids(unique_ints(np.concatenate(missing_gr)))} that are not defined "
            f"(first at {deck.where(int(min(missing_seq)))})"
        )
    if all_eids:
        _check_unique(np.concatenate(all_eids), np.concatenate(all_seqs), "element id", deck)

    blocks, pids, dims = [], [], []
    for etype in ELEMENT_TYPES:
        if per_type[etype]:
            eid = np.concatenate([p[0] for p in per_type[etype]])
            pid = np.concatenate([p[1] for p in per_type[etype]])
            cells = np.concatenate([p[2] for p in per_type[etype]])
            blocks.append(ElementBlock(etype, cells.astype(np.int64), eid.astype(np.int64)))
            pids.append(pid)
            dims.append(np.full(len(eid), DIM[etype], np.int8))
    groups, used = _pid_groups(blocks, pids, dims, len(gid), source)
    properties = _properties(deck, used, unit, scale)

    if deck.unknown:
        listed = ", ".join(f"{n} ({c})" for n, c in sorted(deck.unknown.items(), key=lambda kv: (-kv[1], kv[0])))
        warnings.warn(
            f"{source}: ignored {len(deck.unknown)} unsupported card type{'s' if len(deck.unknown) > 1 else ''}: "
            f"{listed}",
            stacklevel=2,
        )
    mesh = Mesh(
        points=x * scale,
        blocks=tuple(blocks),
        groups=groups,
        node_ids=gid.astype(np.int64),
        source=source,
        properties=properties,
    )
    return mesh


def _pid_groups(blocks, pids, dims, n_nodes: int, source: str):
    """Groups ``"PID n"`` (elements and their nodes) and PID -> dimension, without a loop over elements."""
    if not blocks:
        return {}, {}
    pid = np.concatenate(pids)
    dim = np.concatenate(dims)
    el_order = np.argsort(pid, kind="stable")  # elements of each PID, ascending within it
    sp = pid[el_order]
    first = np.ones(len(sp), bool)
    np.not_equal(sp[1:], sp[:-1], out=first[1:])
    starts = np.flatnonzero(first)
    upid = sp[starts]
    el_bounds = np.append(starts, len(sp))
    rank = np.empty(len(pid), np.int64)
    rank[el_order] = np.cumsum(first) - 1
    dmin = np.minimum.reduceat(dim[el_order], starts)
    dmax = np.maximum.reduceat(dim[el_order], starts)
    mixed = np.flatnonzero(dmin != dmax)
    if len(mixed):
        raise Fem2TmmError(
            f"{source}: property ids {format_ids(upid[mixed])} are used by both shell and solid elements; "
            "give shells and solids different PIDs"
        )
    # node lists: unique (PID rank, node) pairs over every element corner
    offs = np.cumsum([0] + [len(b.cells) for b in blocks])
    keys = unique_ints(
        np.concatenate([(rank[o : o + len(b.cells), None] * n_nodes + b.cells).ravel() for b, o in zip(blocks, offs)])
    )
    nd_bounds = np.searchsorted(keys // n_nodes, np.arange(len(upid) + 1))
    groups = {}
    used = {}
    for r, p in enumerate(upid):
        name = f"PID {int(p)}"
        groups[name] = Group(
            name=name,
            dim=int(dmin[r]),
            elements=el_order[el_bounds[r] : el_bounds[r + 1]].astype(np.int64),
            nodes=keys[nd_bounds[r] : nd_bounds[r + 1]] % n_nodes,
        )
        used[int(p)] = int(dmin[r])
    return groups, used
