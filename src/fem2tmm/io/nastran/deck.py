"""Nastran bulk data reader (in-house, vectorised).

:func:`read_nastran` turns a Nastran bulk data deck (``.bdf``, ``.nas``, ``.dat``) into a
:class:`fem2tmm.mesh.Mesh`.

Cards read
----------
Every card is either modelled, read as a thermal joint or load, listed as ignored (non-structural: PARAM,
loads, SEQGP, CONM2, ...: one warning, ``Mesh.cards["ignored"]``, summary.json ``mesh.ignored_cards``), or
refused: a structural card fem2tmm does not model (RBAR, RBE1, MPC, CELAS3, CQUADX, any other element card)
stops the read with one error listing each card and its count and naming ``[mesh] ignore_cards``.

=============================  ======================================================================
GRID                           ID, CP, X1-X3 (CP: coordinate system of the position; CD, PS, SEID ignored)
GRDSET                         default CP (and CD, ignored) for GRIDs whose CP field is blank
CORD2R, CORD2C, CORD2S         rectangular, cylindrical (r, theta deg, z), spherical (r, theta deg, phi deg)
                               systems given by three points A, B, C in a reference system RID; RID chains
                               of any depth and in any order in the file; blank coordinates are 0.0
CTRIA3 CTRIAR, CQUAD4 CQUADR   -> ``tri3``, ``quad4`` (THETA/MCID, ZOFFS, TFLAG, T1-T4 ignored; blank PID = EID)
CTRIA6, CQUAD8                 -> ``tri3``, ``quad4`` on the corner GRIDs; the mid-side GRIDs are not solved for:
                               ``Mesh.midside`` rows (node, a, b), their temperature is the mean of the edge
                               ends in the outputs (one warning; curved edges are straightened)
CSHEAR, NASTRAN-95 CQUAD1/2,   -> ``quad4`` / ``tri3`` with their property cards PSHEAR, PQUAD1/2, PQDMEM(1/2),
CQDMEM(1/2), CTRIA1/2, CTRMEM  PTRIA1/2, PTRMEM (PID, MID, T like PSHELL)
CTETRA, CHEXA, CPENTA          -> ``tet4``, ``hex8``, ``wedge6``; 10/20/15-node variants on their corners as above
CHEXA1, CHEXA2, CWEDGE         NASTRAN-95 solids -> ``hex8``, ``wedge6``: field 2 is a material id (no PSOLID);
                               a solid PID with no PSOLID whose id is a material's is read the same way
CBAR, CBEAM, CROD, CTUBE,      -> ``line2`` (conduction along the axis); areas from PBAR A, PBEAM A(A), PROD A,
CONROD                         PTUBE (OD, T), CONROD A, PBARL/PBEAML sections ROD, TUBE, TUBE2, BAR, BOX, I,
                               CHAN, T, L, H (MSC QRG areas; other section types refused by name);
                               ``Mesh.section_area``; CONROD groups ``"CONROD MID m"``
RBE2, RBE3, CBUSH, CELAS1,     thermal joints (``Mesh.joints``: one connection per independent/dependent GRID
CELAS2, CGAP                   pair, GA-GB for springs; grounded springs connect nothing); the case decides
                               their treatment (``[[joints]]``)
PSHELL, PSOLID                 PID, MID1 (the membrane material, the one heat transfer uses), T / PID, MID
PCOMP, PCOMPG                  thickness = sum of the plies (LAM = SYM doubles them); conductivity, density and
                               specific heat averaged over the plies by thickness (in-plane plies in parallel)
MAT4, MAT5                     K, CP, RHO; MAT5: the tensor KXX..KZZ (basic system), CP, RHO
MAT1, MAT8                     RHO only (MAT4/MAT5 values win)
SPC, SPC1, TEMP, TEMPD, QBDY*, with ``loads`` (``[mesh] nastran_loads``): see :mod:`fem2tmm.io.nastran_loads`
QHBDY, QVOL, CHBDY*, RADBC,
RADM, PHBDY
=============================  ======================================================================

Formats
-------
Small field (8-character fields), large field (``GRID*``: 16-character fields, two physical lines per
eight data fields), free field (commas; ``GRID*,`` is large free field, four data fields per line) and any
mix of them within a deck or a card.  A continuation line starts with ``+`` (small field), ``*`` (large
field) or a blank first field; a blank first field continues in the width of the line before it.  The
markers in field 10 / field 1 are not matched: continuation lines must follow their parent, as modern
Nastran requires.  Tabs expand to 8-column stops.  ``$`` starts a comment anywhere on a line.  Real
numbers may use ``E`` or ``D`` exponents, Nastran's implicit exponent (``1.-3``, ``-.5+2``) and embedded
blanks (``.2523 -3``); integers are accepted in real fields.  Free- and small-field replication: a card whose
first field is ``=`` repeats the card before it, field by field: ``=`` copies the field, ``==`` copies all the
remaining fields, ``*x`` / ``*(x)`` adds x; ``=n`` / ``=(n)`` repeats the last replication n times.  Only the
cards the model uses are parsed strictly: a malformed field in a property or material card no element uses is
one warning naming file:line.  ``INCLUDE 'file'`` (quoted, possibly over several lines, or bare) is searched
relative to the including file, then the top deck's folder, then the working directory (a missing file names
every place tried), recursively; an include cycle is an error.  When the top file
has a ``BEGIN BULK`` line, everything before it (executive and case control) is skipped; reading stops
at ``ENDDATA``.  Decks without either are read whole.  Columns past 72 of a fixed-format line (field
10) are ignored; a free-field line holds at most 8 data fields (4 in large free field) plus a marker.

Units
-----
Point coordinates are multiplied by metres per deck length unit.  Property data goes into
``Mesh.properties["PID <n>"]`` as :class:`~fem2tmm.mesh.PropertyData` in SI units, converted from the deck's
unit system (``unit_system``, :data:`fem2tmm.io.units.UNIT_SYSTEMS`: m-kg-s, mm-t-s, mm-kg-s, mm-kg-ms,
cm-g-s, in-lbf-s, ft-lbf-s; per-degree values with ``temperature_unit`` K/C/F/R).  Without ``unit_system``,
length unit ``m`` means SI and ``mm`` the mm-tonne-s system; any other unit leaves the material values
``None`` with a warning (the case must give them or declare the unit system); the lbf systems without a
temperature unit are refused as ambiguous.  A blank K, CP or RHO gives ``None`` (Nastran's MAT4 default
RHO = 1.0 is deliberately not applied), and so does a material id that no material card defines (warning).

Output
------
Points are kept in file order (GRIDs that no element uses are kept; the model builder ignores them),
``Mesh.node_ids`` holds the GRID ids, each block's ``ids`` the element ids, blocks follow
:data:`fem2tmm.mesh.elements.ELEMENT_TYPES` order with elements in file order.  Each property id becomes a
group ``"PID <n>"`` (dim 1 for bars, 2 for shells, 3 for solids) with its elements and their nodes.

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
from ..mesh.elements import DIM, ELEMENT_TYPES, MIDSIDE_EDGES
from ..mesh import ElementBlock, Group, JointBlock, Mesh, PropertyData, unique_ints
from .units import UNIT_SYSTEMS, length_scale, material_factors, unit_system_name

__all__ = ["read_nastran"]

# --------------------------------------------------------------------------------------------- cards

#: element card -> (fem2tmm type, corner nodes, mid-side node fields, property field): "P" a PID that
#: defaults to the EID when blank, "R" a required PID, "M" a NASTRAN-95 material id in the PID field
_ELEMENTS: dict[str, tuple[str, int, int, str]] = {
    "CTRIA3": ("tri3", 3, 0, "P"), "CTRIAR": ("tri3", 3, 0, "P"), "CTRIA6": ("tri3", 3, 3, "P"),
    "CTRIA1": ("tri3", 3, 0, "R"), "CTRIA2": ("tri3", 3, 0, "R"), "CTRMEM": ("tri3", 3, 0, "R"),
    "CQUAD4": ("quad4", 4, 0, "P"), "CQUADR": ("quad4", 4, 0, "P"), "CQUAD8": ("quad4", 4, 4, "P"),
    "CQUAD1": ("quad4", 4, 0, "R"), "CQUAD2": ("quad4", 4, 0, "R"), "CQDMEM": ("quad4", 4, 0, "R"),
    "CQDMEM1": ("quad4", 4, 0, "R"), "CQDMEM2": ("quad4", 4, 0, "R"), "CSHEAR": ("quad4", 4, 0, "R"),
    "CTETRA": ("tet4", 4, 6, "R"), "CHEXA": ("hex8", 8, 12, "R"), "CPENTA": ("wedge6", 6, 9, "R"),
    "CHEXA1": ("hex8", 8, 0, "M"), "CHEXA2": ("hex8", 8, 0, "M"), "CWEDGE": ("wedge6", 6, 0, "M"),
    "CBAR": ("line2", 2, 0, "P"), "CBEAM": ("line2", 2, 0, "P"), "CROD": ("line2", 2, 0, "P"),
    "CTUBE": ("line2", 2, 0, "R"),
}
#: shell property cards with (PID, MID, T) in their first three fields
_SHELL_PROPS = ("PSHELL", "PSHEAR", "PQUAD1", "PQUAD2", "PTRIA1", "PTRIA2", "PQDMEM", "PQDMEM1", "PQDMEM2",
                "PTRMEM")
_LINE_PROPS = ("PBAR", "PBARL", "PBEAM", "PBEAML", "PROD", "PTUBE")
_JOINTS = ("RBE2", "RBE3", "CBUSH", "CELAS1", "CELAS2", "CGAP")
_LOAD_CARDS = ("SPC", "SPC1", "TEMP", "TEMPD", "QBDY1", "QBDY2", "QBDY3", "QHBDY", "QVOL", "CHBDY", "CHBDYG",
               "CHBDYE", "CHBDYP", "RADBC", "RADM", "PHBDY")
_CORDS = {"CORD2R": "R", "CORD2C": "C", "CORD2S": "S"}
_CORD_FIELDS = ("A1", "A2", "A3", "B1", "B2", "B3", "C1", "C2", "C3")
_SUPPORTED = ("GRID", "GRDSET", *_CORDS, *_ELEMENTS, "CONROD", *_SHELL_PROPS, "PSOLID", "PCOMP", "PCOMPG",
              *_LINE_PROPS, "MAT4", "MAT5", "MAT1", "MAT8", *_JOINTS, *_LOAD_CARDS)

#: cards that carry structure (connect GRIDs) and that fem2tmm does not model: refused unless listed in
#: ``[mesh] ignore_cards``.  Any other unread card whose name starts with C (an element) is refused too,
#: except the non-structural ones in ``_NONSTRUCTURAL_C``.
_STRUCTURAL = {"RBAR", "RBAR1", "RBE1", "RROD", "RTRPLT", "RTRPLT1", "RSPLINE", "RSSCON", "RJOINT", "MPC",
               "MPCADD", "GENEL", "DMIG"}
_NONSTRUCTURAL_C = {"CONM1", "CONM2", "CMASS1", "CMASS2", "CMASS3", "CMASS4", "CDAMP1", "CDAMP2", "CDAMP3",
                    "CDAMP4", "CDAMP5", "CVISC", "CONV", "CONVM", "CAERO1", "CAERO2", "CAERO3", "CAERO4",
                    "CAERO5", "CSUPER", "CSUPEXT", "CYAX", "CYJOIN", "CYSUP", "CYSYM", "CBARAO", "CSSCHD",
                    "CSET", "CSET1", "CNGRNT", "CREEP", "CLOAD", "CORD1R", "CORD1C", "CORD1S", "CORD3G",
                    "CORD3R", "CHBDY", "CHBDYG", "CHBDYE", "CHBDYP", "CONTRLT", "CMARKN",
                    "CMARKB2"}


def is_structural(card: str) -> bool:
    """True for a card that connects GRIDs structurally (an element, a rigid element, an MPC)."""
    return card in _STRUCTURAL or (card.startswith("C") and card not in _NONSTRUCTURAL_C)


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
        self.top_dir: Path | None = None
        self.replication: list[bytes] | None = None  # the data fields of the last "=" line

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
        if top:
            self.top_dir = path.parent
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
            if head[:1] == b"=":
                # ---- replication of the previous card (free or small field): "=", "=n", "=(n)"
                if cur is None:
                    raise Fem2TmmError(f"{where_file}:{i + 1}: replication line with no card before it")
                if cur is False:
                    continue  # replication of an ignored card
                prev = cur[0][-1]
                prev = list(prev) if mode == _GENERIC else _split_fixed(prev, mode)
                times = head[1:].strip(b"()") or b"1"
                if head == b"=":
                    pattern = self._free_fields(rest, _SMALL, where_file, i + 1) if free else \
                        _split_fixed(raw[8:72], _SMALL)
                    self.replication = pattern
                    times = b"1"
                elif self.replication is None or not times.isdigit():
                    raise Fem2TmmError(f"{where_file}:{i + 1}: {head.decode('latin-1')!r}: repeated replication "
                                       "needs a replication line ('=' in field 1) before it")
                if mode != _GENERIC:
                    cur = self._generic_store(card)
                    mode = _GENERIC
                for _ in range(int(times)):
                    prev = _replicate(prev, self.replication, where_file, i + 1)
                    cur[0].append(list(prev))
                    cur[1].append(len(card_line))
                    card_line.append(i + 1)
                last = _SMALL
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
        name = Path(text.decode("latin-1").replace("\\", "/"))
        if name.is_absolute():
            tried = [name]
        else:  # the including file's folder, then the top deck's folder, then the working directory
            tried = list(dict.fromkeys([Path(where_file).parent / name, self.top_dir / name, Path.cwd() / name]))
        for target in tried:
            if target.is_file():
                self.read(target)
                return i
        raise Fem2TmmError(
            f"{where_file}:{i + 1}: INCLUDE file {str(name)!r} not found; tried "
            + ", ".join(str(t) for t in tried)
        )

    # ------------------------------------------------------------------ conversion to arrays
    def count(self, card: str) -> int:
        """Number of cards ``card`` read."""
        n = sum(len(seqs) for (c, _), (_, seqs) in self.fixed.items() if c == card)
        return n + len(self.generic.get(card, ([], []))[1])

    def records(self, card: str) -> list[tuple[int, list[bytes]]]:
        """``(sequence number, stripped data fields)`` of every card ``card`` in file order (for cards of
        variable length: RBE2, PCOMP, SPC1, ...)."""
        out = []
        for (cname, width), (records, seqs) in self.fixed.items():
            if cname == card:
                out += [(int(q), _split_fixed(r, width)) for r, q in zip(records, seqs)]
        lists, seqs = self.generic.get(card, ([], []))
        out += [(int(q), list(fl)) for fl, q in zip(lists, seqs)]
        out.sort(key=lambda x: x[0])
        return out

    def table(self, card: str, spec: dict[str, tuple[int, str]], lenient: bool = False) -> "_Table":
        """All cards ``card`` as columns.

        ``spec`` maps a column name to (0-based data field index, kind); kind ``"i"`` integer,
        ``"r"`` real, ``"b"`` only whether the field is blank.  Rows are in file order.  A malformed field
        is an error naming file and line, unless ``lenient``: then it reads as blank and the table
        remembers it (:meth:`_Table.check`), so that only the cards the model uses are strict.
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
        bad_rows: dict[int, str] = {}
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
                if lenient and not ok.all():
                    for r in np.flatnonzero(~ok):
                        bad_rows.setdefault(int(seqs[r]), f"{card} field {idx + 2} ({key}) "
                                            f"{bytes(f[r]).decode('latin-1').strip()!r} is malformed")
                    blank = blank | ~ok
                elif not ok.all():
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
        sseq = seq[order]
        return _Table(
            self,
            card,
            sseq,
            {k: np.concatenate(v)[order] for k, v in cols.items() if v},
            {k: np.concatenate(v)[order] for k, v in blanks.items()},
            {int(np.searchsorted(sseq, q)): msg for q, msg in bad_rows.items()},
        )


def _replicate(prev: list[bytes], pattern: list[bytes], where_file: str, line: int) -> list[bytes]:
    """Fields of a replicated card: ``=`` copies the previous card's field, ``==`` copies all the fields
    from there on, ``*x`` / ``*(x)`` adds x to it, anything else is taken as written."""
    out = []
    for j, f in enumerate(pattern):
        p = prev[j] if j < len(prev) else b""
        if f == b"==":
            return out + list(prev[j:])
        if f == b"=":
            out.append(p)
        elif f[:1] == b"*":
            inc = f[1:].strip().strip(b"()")
            ints = [re.fullmatch(rb"[+-]?\d+", x.strip()) for x in (p, inc)]
            if all(ints):
                out.append(str(int(p) + int(inc)).encode())
                continue
            a, b = _scalar_real(p), _scalar_real(inc)
            if a is None or b is None:
                raise Fem2TmmError(f"{where_file}:{line}: cannot increment field {j + 2} {p.decode('latin-1')!r} "
                                   f"by {inc.decode('latin-1')!r}")
            out.append(repr(a + b).encode())
        else:
            out.append(f)
    return out


def _scalar_real(f: bytes) -> float | None:
    """One Nastran real (any legacy form); None when malformed or blank."""
    w = max(len(f), 1)
    val, blank, ok = _parse_real(np.frombuffer(f.ljust(w), np.uint8).reshape(1, w).copy())
    return None if (blank[0] or not ok[0]) else float(val[0])


def _scalar_int(f: bytes) -> int | None:
    """One integer field; None when blank or not an integer."""
    f = f.strip()
    return int(f) if re.fullmatch(rb"[+-]?\d+", f) else None


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
    bad: dict = None  # row -> message of a malformed field (lenient tables)

    def check(self, used: np.ndarray) -> None:
        """Malformed fields (lenient tables): an error on the first row with ``used[row]``; one warning
        naming file:line of the others (cards the model does not use)."""
        if not self.bad:
            return
        rows = sorted(self.bad)
        hard = [r for r in rows if used[r]]
        if hard:
            r = hard[0]
            raise Fem2TmmError(f"{self.where(r)}: {self.bad[r]}" + (f" ({len(hard)} such cards in all)"
                                                                     if len(hard) > 1 else ""))
        listed = "; ".join(f"{self.where(r)}: {self.bad[r]}" for r in rows[:5])
        warnings.warn(f"malformed fields in {len(rows)} {self.card} card(s) the model does not use (ignored): "
                      f"{listed}{' ...' if len(rows) > 5 else ''}", stacklevel=4)

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

    Accepts ``1.5``, ``1.5E-3``, ``1.5D-3`` (any case), the implicit exponent ``1.5-3`` / ``-.5+2``,
    embedded blanks (``.2523 -3``) and integers.  Returns ``(value (n,) float64, blank (n,) bool, ok (n,) bool)``.
    """
    n, w = u.shape
    up = np.where((u >= 97) & (u <= 122), u - 32, u).astype(np.uint8)
    up[up == 68] = 69  # D -> E
    sp_ = up == _SPACE
    blank = sp_.all(axis=1)
    if (sp_[:, 1:] & ~sp_[:, :-1]).any() and (~sp_[:, 1:] & sp_[:, :-1]).any():
        # embedded blanks (legacy ".2523 -3"): squeeze them out, keeping the order of the characters
        up = np.take_along_axis(up, np.argsort(sp_, axis=1, kind="stable"), axis=1)
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


def _deck_units(unit: str, unit_system: str | None, temperature_unit: str | None, where: str):
    """SI factors of the deck's material/load values (:func:`~fem2tmm.io.units.material_factors`) or None.

    Without ``unit_system``: ``m`` means SI and ``mm`` the mm-tonne-s system (as before); any other length
    unit leaves the values undefined (the case must give them, or declare ``[mesh] unit_system``).
    """
    if unit_system is None:
        unit_system = {"m": "m-kg-s", "mm": "mm-t-s"}.get(str(unit).strip().lower())
    if unit_system is None:
        return None
    system = unit_system_name(unit_system, where=f"{where}: unit_system")
    if "lbf" in system and temperature_unit is None:
        raise Fem2TmmError(
            f"{where}: unit system {system!r} is ambiguous about temperature: conductivity per degree F "
            "or per kelvin? set [mesh] temperature_unit = \"F\" (or \"R\", \"K\", \"C\")"
        )
    return material_factors(system, temperature_unit)


def _materials(deck: _Deck, used_mids: set[int]) -> dict[int, dict]:
    """MID -> {"k": float|None, "tensor": (6,)|None, "rho", "cp"} in deck units (MAT4, MAT5, MAT1, MAT8)."""
    m4 = deck.table("MAT4", {"MID": (0, "i"), "K": (1, "r"), "CP": (2, "r"), "RHO": (3, "r")}, lenient=True)
    m5 = deck.table("MAT5", {"MID": (0, "i"), **{k: (1 + j, "r") for j, k in enumerate(_TENSOR)},
                             "CP": (7, "r"), "RHO": (8, "r")}, lenient=True)
    m1 = deck.table("MAT1", {"MID": (0, "i"), "RHO": (4, "r")}, lenient=True)
    m8 = deck.table("MAT8", {"MID": (0, "i"), "RHO": (7, "r")}, lenient=True)
    for t in (m4, m5, m1, m8):
        t.check(np.isin(t.val["MID"], list(used_mids)) | t.blank["MID"])
        t.require("MID")
        _check_unique(t.val["MID"], t.seq, t.card, deck)

    def v(t, key, r):
        return None if t.blank[key][r] else float(t.val[key][r])

    mats: dict[int, dict] = {}
    for t in (m1, m8):
        for r in range(len(t)):
            mats.setdefault(int(t.val["MID"][r]), {"k": None, "tensor": None, "rho": None, "cp": None})["rho"] = v(t, "RHO", r)
    for r in range(len(m4)):
        m = mats.setdefault(int(m4.val["MID"][r]), {"k": None, "tensor": None, "rho": None, "cp": None})
        m["k"] = v(m4, "K", r)
        for key, col in (("rho", "RHO"), ("cp", "CP")):
            m[key] = v(m4, col, r) if v(m4, col, r) is not None else m[key]
    for r in range(len(m5)):
        mid = int(m5.val["MID"][r])
        m = mats.setdefault(mid, {"k": None, "tensor": None, "rho": None, "cp": None})
        ten = np.array([m5.val[k][r] for k in _TENSOR])  # blanks are 0.0 (MAT5 defaults)
        if m["k"] is not None:
            raise Fem2TmmError(f"{m5.where(r)}: material {mid} is defined by both MAT4 and MAT5; keep one")
        m["tensor"] = ten
        for key, col in (("rho", "RHO"), ("cp", "CP")):
            m[key] = v(m5, col, r) if v(m5, col, r) is not None else m[key]
    return mats


_TENSOR = ("KXX", "KXY", "KXZ", "KYY", "KYZ", "KZZ")

#: PBARL / PBEAML section types: number of dimensions and area A(DIM1, DIM2, ...) (MSC Nastran QRG, PBARL)
_SECTIONS = {
    "ROD": (1, lambda d: np.pi * d[0] ** 2),
    "TUBE": (2, lambda d: np.pi * (d[0] ** 2 - d[1] ** 2)),
    "TUBE2": (2, lambda d: np.pi * (d[0] ** 2 - (d[0] - d[1]) ** 2)),
    "BAR": (2, lambda d: d[0] * d[1]),
    "BOX": (4, lambda d: 2 * d[0] * d[2] + 2 * (d[1] - 2 * d[2]) * d[3]),
    "I": (6, lambda d: d[1] * d[4] + d[2] * d[5] + (d[0] - d[4] - d[5]) * d[3]),
    "CHAN": (4, lambda d: 2 * d[0] * d[3] + (d[1] - 2 * d[3]) * d[2]),
    "T": (4, lambda d: d[0] * d[2] + (d[1] - d[2]) * d[3]),
    "L": (4, lambda d: d[0] * d[2] + (d[1] - d[2]) * d[3]),
    "H": (4, lambda d: d[1] * d[2] + d[0] * d[3]),
}


def _section_area(deck: _Deck, card: str, pid: int, fields: list[bytes], where: str) -> float:
    """Area of a PBARL/PBEAML section (end A) in deck units."""
    stype = fields[3].strip().upper().decode("latin-1") if len(fields) > 3 else ""
    if stype not in _SECTIONS:
        raise Fem2TmmError(
            f"{where}: {card} {pid}: section type {stype!r} is not supported (area known for "
            f"{', '.join(_SECTIONS)}); give the area with a PBAR/PBEAM card, or set the part's 'area' in the case"
        )
    n, fn = _SECTIONS[stype]
    dims = [_scalar_real(f) for f in fields[8 : 8 + n]]
    if len(dims) < n or any(d is None or d <= 0 for d in dims):
        raise Fem2TmmError(f"{where}: {card} {pid} ({stype}) needs {n} positive dimensions DIM1..DIM{n}")
    area = float(fn(dims))
    if not area > 0:
        raise Fem2TmmError(f"{where}: {card} {pid} ({stype}): the dimensions give a non-positive area {area}")
    return area


def _ply_average(mats, plies, where: str):
    """Thickness-weighted conductivity (scalar or tensor), density and specific heat of a laminate
    (in-plane conduction of plies in parallel: k t = Σ kᵢ tᵢ; ρ c t = Σ ρᵢ cᵢ tᵢ)."""
    t = sum(th for _, th in plies)
    if any(mid not in mats for mid, _ in plies):
        return None, None, None, None
    ks = [mats[mid] for mid, _ in plies]
    if all(m["k"] is not None for m in ks):
        k, ten = sum(m["k"] * th for m, (_, th) in zip(ks, plies)) / t, None
    elif all(m["k"] is not None or m["tensor"] is not None for m in ks):
        iso = np.array([1.0, 0, 0, 1.0, 0, 1.0])
        ten = sum((m["tensor"] if m["tensor"] is not None else m["k"] * iso) * th for m, (_, th) in zip(ks, plies)) / t
        k = None
    else:
        k = ten = None
    rho = cp = None
    if all(m["rho"] is not None for m in ks):
        mass = sum(m["rho"] * th for m, (_, th) in zip(ks, plies))
        rho = mass / t
        if all(m["cp"] is not None for m in ks) and mass > 0:
            cp = sum(m["rho"] * m["cp"] * th for m, (_, th) in zip(ks, plies)) / mass
    return k, ten, rho, cp


def _laminates(deck: _Deck, used: dict[int, int]) -> dict[int, tuple[list, str]]:
    """PCOMP/PCOMPG PID -> (plies [(MID, T)], where) in deck units, for the used PIDs (LAM = SYM doubled)."""
    out = {}
    for card in ("PCOMP", "PCOMPG"):
        for seq, f in deck.records(card):
            where = deck.where(seq)
            pid = _scalar_int(f[0])
            if pid is None:
                raise Fem2TmmError(f"{where}: {card} PID {f[0].decode('latin-1')!r} is not an integer")
            if pid not in used:
                continue
            if pid in out:
                raise Fem2TmmError(f"property id {pid} is defined twice: {out[pid][1]} and {where}")
            lam = f[7].strip().upper() if len(f) > 7 else b""
            plies, mid, th = [], None, None
            step, off = (4, 0) if card == "PCOMP" else (8, 1)
            for j in range(8, len(f), step):
                block = f[j + off : j + off + 2]
                if len(block) < 2 or (not block[0] and not block[1]):
                    continue
                m = _scalar_int(block[0]) if block[0] else mid
                t = _scalar_real(block[1]) if block[1] else th
                if m is None or t is None or t <= 0:
                    raise Fem2TmmError(f"{where}: {card} {pid}: ply {len(plies) + 1} needs a MID and a positive T")
                plies.append((m, t))
                mid, th = m, t
            if not plies:
                raise Fem2TmmError(f"{where}: {card} {pid} has no plies")
            if lam == b"SYM":
                plies = plies + plies[::-1]
            elif lam not in (b"", b"MEM", b"BEND", b"SMEAR", b"SMCORE"):
                warnings.warn(f"{where}: {card} {pid}: LAM = {lam.decode('latin-1')} read as a plain ply list",
                              stacklevel=4)
            out[pid] = (plies, where)
    return out


def _properties(deck: _Deck, used: dict[int, int], factors: dict | None, scale: float,
                nastran95: set[int]) -> dict[str, PropertyData]:
    """``"PID n"`` -> PropertyData (SI) for the property ids in ``used`` (PID -> element dimension).

    ``nastran95``: PIDs of NASTRAN-95 solids (CHEXA1/2, CWEDGE) whose field is a material id; a solid PID
    with no PSOLID whose id is a material's is read the same way (NASTRAN-95 CTETRA).
    """
    spec = {"PID": (0, "i"), "MID": (1, "i"), "T": (2, "r")}
    tables = [(deck.table(c, spec, lenient=True), c, 2) for c in _SHELL_PROPS]
    tables.append((deck.table("PSOLID", {"PID": (0, "i"), "MID": (1, "i")}, lenient=True), "PSOLID", 3))
    line_spec = {"PID": (0, "i"), "MID": (1, "i"), "A": (2, "r")}
    for c in ("PBAR", "PBEAM", "PROD"):
        tables.append((deck.table(c, line_spec, lenient=True), c, 1))
    tables.append((deck.table("PTUBE", {"PID": (0, "i"), "MID": (1, "i"), "OD": (2, "r"), "T": (3, "r")},
                              lenient=True), "PTUBE", 1))
    used_pids = np.array(sorted(used), np.int64)
    for t, _, _ in tables:
        t.check(np.isin(t.val["PID"], used_pids) | t.blank["PID"])
        t.require("PID")
    sections = {}
    for c in ("PBARL", "PBEAML"):
        for seq, f in deck.records(c):
            pid = _scalar_int(f[0])
            if pid in used:
                sections[pid] = (c, _scalar_int(f[1]) if len(f) > 1 else None,
                                 _section_area(deck, c, pid, f, deck.where(seq)), deck.where(seq))
    laminates = _laminates(deck, used)
    pid_all = np.concatenate([t.val["PID"] for t, _, _ in tables] + [np.array(list(sections) + list(laminates), np.int64)])
    seq_all = np.concatenate([t.seq for t, _, _ in tables] + [np.zeros(len(sections) + len(laminates), np.int64)])
    _check_unique(pid_all, seq_all, "property id", deck)

    # rows: pid -> (card, dim, mid, thickness or area (deck units) or plies, where)
    rows: dict[int, tuple] = {}
    for t, card, dim in tables:
        for r in np.flatnonzero(np.isin(t.val["PID"], used_pids)):
            pid = int(t.val["PID"][r])
            mid = None if t.blank["MID"][r] else int(t.val["MID"][r])
            size = None
            if card == "PTUBE":
                od = float(t.val["OD"][r])
                th = od / 2 if t.blank["T"][r] else float(t.val["T"][r])
                size = np.pi * (od**2 - (od - 2 * th) ** 2) / 4
            elif "T" in t.val and not t.blank["T"][r]:
                size = float(t.val["T"][r])
            elif "A" in t.val and not t.blank["A"][r]:
                size = float(t.val["A"][r])
            rows[pid] = (card, dim, mid, size, t.where(r))
    for pid, (card, mid, area, where) in sections.items():
        rows[pid] = (card, 1, mid, area, where)
    for pid, (plies, where) in laminates.items():
        rows[pid] = ("PCOMP", 2, None, plies, where)
    mats_used = {r[2] for r in rows.values() if r[2] is not None}
    mats_used |= {m for r in rows.values() if r[0] == "PCOMP" for m, _ in r[3]}
    mats_used |= {pid for pid, dim in used.items() if dim == 3 and pid not in rows}
    mats = _materials(deck, mats_used)
    for pid, dim in used.items():
        if pid not in rows and (dim == 3 and (pid in nastran95 or pid in mats)):
            rows[pid] = ("MID", 3, pid, None, "NASTRAN-95 solid: material id in the element card")

    out: dict[str, PropertyData] = {}
    missing: list[str] = []
    dropped = False
    for pid, (card, dim, mid, size, where) in rows.items():
        if used[pid] != dim:
            word = {1: "line", 2: "shell", 3: "solid"}
            raise Fem2TmmError(
                f"{where}: {card} {pid} is used by {word[used[pid]]} elements; a {card} is for {word[dim]} elements"
            )
        thick = area = None
        k = ten = rho = cp = None
        if card == "PCOMP":
            thick = sum(th for _, th in size) * scale
            vals = _ply_average(mats, size, where)
            if vals[0] is None and vals[1] is None:
                missing.extend(f"MID {m} (PID {pid})" for m, _ in size if m not in mats)
        else:
            if size is not None:
                if dim == 2:
                    thick = size * scale
                elif dim == 1:
                    area = size * scale**2
            vals = (None, None, None, None)
            if mid is not None:
                if mid not in mats:
                    missing.append(f"MID {mid} (PID {pid})")
                else:
                    m = mats[mid]
                    vals = (m["k"], m["tensor"], m["rho"], m["cp"])
        if factors is None:
            dropped = dropped or any(v is not None for v in vals)
        else:
            f = factors
            k = None if vals[0] is None else vals[0] * f["conductivity"]
            ten = None if vals[1] is None else tuple(float(x) for x in np.asarray(vals[1]) * f["conductivity"])
            rho = None if vals[2] is None else vals[2] * f["density"]
            cp = None if vals[3] is None else vals[3] * f["specific_heat"]
        out[f"PID {pid}"] = PropertyData(thickness=thick, conductivity=k, density=rho, specific_heat=cp,
                                         material_id=mid, conductivity_tensor=ten, area=area,
                                         card=card if card != "MID" else "NASTRAN-95 MID")
    if missing:
        warnings.warn(
            f"{deck.files[0]}: properties reference materials with no MAT4/MAT5/MAT1 card: {', '.join(missing)}; "
            "their conductivity, density and specific heat must come from the case file",
            stacklevel=3,
        )
    if dropped:
        warnings.warn(
            f"{deck.files[0]}: material values (MAT4/MAT5/MAT1) cannot be interpreted without a unit system "
            "(only length units 'm' = SI and 'mm' = mm-tonne-s imply one); they are ignored: set [mesh] "
            "unit_system, or give conductivity, density and specific_heat in the case file",
            stacklevel=3,
        )
    return out


# --------------------------------------------------------------------------------------------- reader


class _Grids:
    """GRID id -> mesh node index lookups with one error naming the missing ids."""

    def __init__(self, gid: np.ndarray):
        self.gid = gid
        self.order = np.argsort(gid, kind="stable")
        self.sorted = gid[self.order]

    def find(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(index (same shape), found (bool, same shape))."""
        ids = np.asarray(ids, np.int64)
        if not len(self.gid):
            return np.zeros(ids.shape, np.int64), np.zeros(ids.shape, bool)
        pos = np.minimum(np.searchsorted(self.sorted, ids), len(self.gid) - 1)
        return self.order[pos], self.sorted[pos] == ids

    def index(self, ids, what: str) -> np.ndarray:
        idx, ok = self.find(ids)
        if not ok.all():
            raise Fem2TmmError(f"{what} reference GRIDs {format_ids(unique_ints(np.asarray(ids)[~ok]))} that are "
                               "not defined")
        return idx


def _elements(deck: _Deck, grids: _Grids, source: str):
    """Element cards -> per fem2tmm type lists of (eid, group key, cells, card name); the mid-side rows
    (k, 3) of quadratic elements; CONROD (eid, mid, area) rows; NASTRAN-95 material-id group keys."""
    per_type: dict[str, list] = {t: [] for t in ELEMENT_TYPES}
    all_eids, all_seqs = [], []
    missing_el, missing_gr, missing_seq = [], [], []
    midside, counts, n95 = [], Counter(), set()
    for card, (etype, k, nmid, pmode) in _ELEMENTS.items():
        spec = {"EID": (0, "i"), "PID": (1, "i")}
        spec.update({f"G{j + 1}": (2 + j, "i") for j in range(k + nmid)})
        t = deck.table(card, spec)
        if not len(t):
            continue
        counts[card] = len(t)
        t.require("EID", *(f"G{j + 1}" for j in range(k)))
        eid = t.val["EID"]
        if pmode == "P":
            pid = t.get("PID", eid)  # Nastran: PID defaults to EID
        else:
            t.require("PID")
            pid = t.val["PID"]
            if pmode == "M":
                n95.update(int(p) for p in unique_ints(pid))
        _bad_ids(eid, card, t.where)
        g = np.stack([t.val[f"G{j + 1}"] for j in range(k)], axis=1)
        cells, found = grids.find(g)
        gm = np.stack([t.val[f"G{k + j + 1}"] for j in range(nmid)], axis=1) if nmid else np.zeros((len(t), 0), np.int64)
        has_m = ~np.stack([t.blank[f"G{k + j + 1}"] for j in range(nmid)], axis=1) if nmid else gm.astype(bool)
        mcells, mfound = grids.find(gm)
        mfound |= ~has_m
        if not (found.all() and mfound.all()):
            rows = np.flatnonzero(~(found.all(axis=1) & mfound.all(axis=1)))
            missing_el.append(eid[rows])
            missing_gr.append(np.concatenate([g[~found], gm[~mfound]]))
            missing_seq.append(t.seq[rows[0]])
        if has_m.any():
            edges = np.array(MIDSIDE_EDGES[etype])
            r, j = np.nonzero(has_m)
            midside.append(np.stack([mcells[r, j], cells[r, edges[j, 0]], cells[r, edges[j, 1]]], axis=1))
            counts[f"{card} (quadratic)"] = int(has_m.any(axis=1).sum())
        per_type[etype].append((eid, pid, cells, card))
        all_eids.append(eid)
        all_seqs.append(t.seq)
    t = deck.table("CONROD", {"EID": (0, "i"), "G1": (1, "i"), "G2": (2, "i"), "MID": (3, "i"), "A": (4, "r")})
    conrod = None
    if len(t):
        counts["CONROD"] = len(t)
        t.require("EID", "G1", "G2", "MID", "A")
        eid = t.val["EID"]
        _bad_ids(eid, "CONROD", t.where)
        g = np.stack([t.val["G1"], t.val["G2"]], axis=1)
        cells, found = grids.find(g)
        if not found.all():
            rows = np.flatnonzero(~found.all(axis=1))
            missing_el.append(eid[rows])
            missing_gr.append(g[~found])
            missing_seq.append(t.seq[rows[0]])
        # group key of a CONROD: minus its material id ("CONROD MID m")
        per_type["line2"].append((eid, -t.val["MID"], cells, "CONROD"))
        conrod = (eid, t.val["MID"], t.val["A"])
        all_eids.append(eid)
        all_seqs.append(t.seq)
    if missing_el:
        raise Fem2TmmError(
            f"{source}: elements {format_ids(unique_ints(np.concatenate(missing_el)))} reference GRIDs "
            f"{format_ids(unique_ints(np.concatenate(missing_gr)))} that are not defined "
            f"(first at {deck.where(int(min(missing_seq)))})"
        )
    if all_eids:
        _check_unique(np.concatenate(all_eids), np.concatenate(all_seqs), "element id", deck)
    ms = np.concatenate(midside) if midside else np.zeros((0, 3), np.int64)
    return per_type, ms, conrod, counts, n95


def _joints(deck: _Deck, grids: _Grids) -> tuple[list[JointBlock], Counter]:
    """RBE2/RBE3 (independent node -> each dependent node), CBUSH/CGAP/CELAS1/CELAS2 (GA -> GB) connections.

    Grounded springs (a blank second node) connect nothing thermally and are skipped."""
    blocks, counts = [], Counter()
    for card in _JOINTS:
        recs = deck.records(card)
        if not recs:
            continue
        counts[card] = len(recs)
        ids, pids, pa, pb, owner = [], [], [], [], []
        for row, (seq, f) in enumerate(recs):
            where = deck.where(seq)
            f = list(f) + [b""] * 8
            eid = _scalar_int(f[0])
            if eid is None:
                raise Fem2TmmError(f"{where}: {card} EID {f[0].decode('latin-1')!r} is not an integer")
            if card == "RBE2":
                a, pid, deps, thru = _scalar_int(f[1]), 0, [], False
                for x in f[3:]:
                    if not x.strip():
                        continue
                    if x.strip().upper() == b"THRU" and deps:
                        thru = True
                        continue
                    v = _scalar_int(x)
                    if v is None:
                        break  # ALPHA / TREF (reals) end the node list
                    if thru:
                        deps.extend(range(deps[-1] + 1, v + 1))
                        thru = False
                    else:
                        deps.append(v)
            elif card == "RBE3":
                a, pid, deps = _scalar_int(f[2]), 0, []
                j, state = 4, "w"
                while j < len(f):
                    x = f[j].strip()
                    j += 1
                    if not x:
                        continue
                    if x.upper() in (b"UM", b"ALPHA", b"TEMP"):
                        break
                    if state == "w":  # a weight, then a component number, then GRIDs
                        state = "c"
                    elif state == "c":
                        state = "g"
                    else:
                        v = _scalar_int(x)
                        if v is None:
                            state = "c"  # the next weight
                        else:
                            deps.append(v)
            else:
                pid = 0 if card == "CELAS2" else (_scalar_int(f[1]) or eid)
                if card in ("CELAS1", "CELAS2"):
                    a, b = _scalar_int(f[2]), _scalar_int(f[4])
                else:
                    a, b = _scalar_int(f[2]), _scalar_int(f[3])
                deps = [] if not b else [b]
            if a is None or a <= 0:
                raise Fem2TmmError(f"{where}: {card} {eid}: the independent / first GRID is missing")
            ids.append(eid)
            pids.append(pid)
            pa.extend([a] * len(deps))
            pb.extend(deps)
            owner.extend([row] * len(deps))
        pairs = np.stack([np.asarray(pa, np.int64), np.asarray(pb, np.int64)], axis=1).reshape(-1, 2)
        idx = grids.index(pairs.ravel(), f"{card} elements").reshape(-1, 2) if len(pairs) else pairs
        blocks.append(JointBlock(card, np.asarray(ids, np.int64), np.asarray(pids, np.int64), idx,
                                 np.asarray(owner, np.int64)))
    return blocks, counts


def read_nastran(path, unit: str = "m", unit_system: str | None = None, temperature_unit: str | None = None,
                 loads: bool | tuple[str, ...] = False, ignore_cards=(), strict: bool = True,
                 load_set: int | None = None, spc_set: int | None = None) -> Mesh:
    """Read a Nastran bulk data deck into a :class:`~fem2tmm.mesh.Mesh`.

    Parameters
    ----------
    path : str or Path
        The deck (any name).  INCLUDEd files are searched relative to the including file, then the top
        deck's folder, then the working directory.
    unit : str
        Length unit of the deck (``m``, ``cm``, ``mm``, ``um``, ``in``, ``ft``).
    unit_system : str or None
        Unit system of the material and load values (:data:`fem2tmm.io.units.UNIT_SYSTEMS`); None: implied
        by ``unit`` (``m`` SI, ``mm`` mm-tonne-s, others undefined: material values are dropped).
    temperature_unit : "K", "C", "F", "R" or None
        Temperature scale of the deck (per-degree material values, SPC/TEMP values).
    loads : bool or tuple of card names
        Read the deck's thermal boundary conditions (all, or only these cards) into ``Mesh.loads``.
    ignore_cards : card names
        Structural cards fem2tmm does not model that the user drops explicitly.
    strict : bool
        Refuse unmodelled structural cards (one error listing them); False lists them in
        ``Mesh.cards["refused"]`` instead (``fem2tmm inspect``).
    load_set, spc_set : int or None
        The load / SPC set id to read when the deck has several.

    Returns
    -------
    Mesh
        ``points`` (n, 3) float64 in metres, in GRID file order; ``node_ids`` (n,) GRID ids; one block per
        element type with the original element ids; groups ``"PID <n>"`` (``"CONROD MID <m>"``);
        ``properties``; ``section_area`` of line elements; ``midside``; ``joints``; ``cards``; ``loads``.

    Raises
    ------
    Fem2TmmError
        Unreadable file or INCLUDE (every place tried named), include cycle, malformed field of a used card
        (file and line named), duplicate ids, undefined or cyclic coordinate systems, elements referencing
        missing GRIDs, unsupported PBARL section types, unmodelled structural cards (``strict``), property
        cards used by the wrong kind of element, a deck with no supported element.
    """
    path = Path(path)
    if unit_system is not None:
        us = unit_system_name(unit_system, where=f"{path}: unit_system")
        scale = UNIT_SYSTEMS[us][0]
    else:
        scale = length_scale(unit, where=f"{path}: unit")
    factors = _deck_units(unit, unit_system, temperature_unit, str(path))
    deck = _Deck()
    deck.read(path, top=True)
    source = str(path)

    # cards: refused (structural, not modelled), ignored (everything else unread)
    ignore = {str(c).upper() for c in ignore_cards}
    load_cards = set(_LOAD_CARDS) if loads is True else ({c.upper() for c in loads} if loads else set())
    unread = Counter(deck.unknown)
    support = {"CHBDY", "CHBDYG", "CHBDYE", "CHBDYP", "PHBDY", "RADM"}  # read when any load card is
    for c in _LOAD_CARDS:
        n = deck.count(c)
        if n and not (load_cards and (c in load_cards or c in support)):
            unread[c] += n
    refused = {c: n for c, n in unread.items() if is_structural(c) and c not in ignore}
    ignored = {c: n for c, n in unread.items() if c not in refused}
    if refused and strict:
        listed = ", ".join(f"{c} ({n})" for c, n in sorted(refused.items(), key=lambda kv: (-kv[1], kv[0])))
        names = ", ".join(f'"{c}"' for c in sorted(refused))
        raise Fem2TmmError(
            f"{source}: structural cards that fem2tmm does not model: {listed}; they connect GRIDs, so the "
            f"thermal model would silently lose those connections. To drop them explicitly set "
            f"[mesh] ignore_cards = [{names}] in the case file"
        )

    systems = _coordinate_systems(deck)
    gid, x, gtab = _grids(deck, systems)
    _bad_ids(gid, "GRID", gtab.where)
    _check_unique(gid, gtab.seq, "GRID", deck)
    grids = _Grids(gid)

    per_type, midside, conrod, counts, n95 = _elements(deck, grids, source)
    joints, jcounts = _joints(deck, grids)
    counts.update(jcounts)

    blocks, pids, dims, line_cards = [], [], [], []
    for etype in ELEMENT_TYPES:
        if per_type[etype]:
            eid = np.concatenate([p[0] for p in per_type[etype]])
            pid = np.concatenate([p[1] for p in per_type[etype]])
            cells = np.concatenate([p[2] for p in per_type[etype]])
            blocks.append(ElementBlock(etype, cells.astype(np.int64), eid.astype(np.int64)))
            pids.append(pid)
            dims.append(np.full(len(eid), DIM[etype], np.int8))
    groups, used = _pid_groups(blocks, pids, dims, len(gid), source)
    used_pid = {p: d for p, d in used.items() if p > 0}
    properties = _properties(deck, used_pid, factors, scale, n95)

    # CONROD: a material group per MID, the area per element
    section_area = None
    if any(b.type == "line2" for b in blocks):
        allpid = np.concatenate(pids)
        section_area = np.full(len(allpid), np.nan)
        for name, grp in groups.items():
            pdata = properties.get(name)
            if pdata is not None and pdata.area is not None:
                section_area[grp.elements] = pdata.area
        if conrod is not None:
            eids = np.concatenate([b.ids for b in blocks])
            ceid, cmid, carea = conrod
            pos = np.flatnonzero(allpid < 0)
            section_area[pos] = _lookup(ceid, carea, eids[pos]) * scale**2
            mats = _materials(deck, set(int(m) for m in cmid))
            for m in unique_ints(cmid):
                mat = mats.get(int(m))
                f = factors
                properties[f"CONROD MID {int(m)}"] = PropertyData(
                    conductivity=None if (mat is None or mat["k"] is None or f is None) else mat["k"] * f["conductivity"],
                    conductivity_tensor=None if (mat is None or mat["tensor"] is None or f is None)
                    else tuple(float(v) for v in mat["tensor"] * f["conductivity"]),
                    density=None if (mat is None or mat["rho"] is None or f is None) else mat["rho"] * f["density"],
                    specific_heat=None if (mat is None or mat["cp"] is None or f is None)
                    else mat["cp"] * f["specific_heat"],
                    material_id=int(m), card="CONROD")

    ms = _check_midside(midside, blocks, joints, gid, source)
    if len(ms):
        quad = {c.split(" ")[0]: n for c, n in counts.items() if c.endswith("(quadratic)")}
        off = _midside_offset(x * scale, ms)
        warnings.warn(
            f"{source}: quadratic elements ({', '.join(f'{c} {n}' for c, n in quad.items())}) are modelled by their "
            f"corner nodes; their {len(ms)} mid-side GRIDs take the mean temperature of the edge ends in the outputs"
            + (f"; mid-side nodes lie up to {off:.3g} of the edge length off the straight edge (curved edges are "
               "straightened: areas and volumes are approximate)" if off > 1e-9 else ""),
            stacklevel=2,
        )
    if ignored:
        listed = ", ".join(f"{n} ({c})" for n, c in sorted(ignored.items(), key=lambda kv: (-kv[1], kv[0])))
        warnings.warn(f"{source}: ignored non-structural cards (listed in summary.json mesh.ignored_cards): {listed}",
                      stacklevel=2)
    deck_loads = None
    if load_cards:
        from .nastran_loads import read_loads

        deck_loads = read_loads(deck, grids, blocks, x * scale, load_cards, factors, temperature_unit,
                                load_set, spc_set, source)
    cards = {"modelled": dict(counts), "ignored": dict(ignored), "refused": dict(refused)}
    mesh = Mesh(
        points=x * scale,
        blocks=tuple(blocks),
        groups=groups,
        node_ids=gid.astype(np.int64),
        source=source,
        properties=properties,
        section_area=section_area,
        midside=ms if len(ms) else None,
        joints=tuple(joints),
        cards=cards,
        loads=deck_loads,
    )
    return mesh


def _lookup(keys: np.ndarray, values: np.ndarray, query: np.ndarray) -> np.ndarray:
    order = np.argsort(keys, kind="stable")
    return values[order[np.searchsorted(keys[order], query)]]


def _check_midside(ms: np.ndarray, blocks, joints, gid: np.ndarray, source: str) -> np.ndarray:
    """Unique mid-side rows; an error for mid-side GRIDs that are also corner nodes of other elements (bars
    included; joints may reach mid-side GRIDs: the model expresses them through the edge ends)."""
    if not len(ms):
        return ms
    _, first = np.unique(ms[:, 0], return_index=True)
    ms = ms[np.sort(first)]
    corner = np.zeros(len(gid), bool)
    for b in blocks:
        corner[b.cells.ravel()] = True
    clash = ms[corner[ms[:, 0]], 0]
    if len(clash):
        raise Fem2TmmError(
            f"{source}: GRIDs {format_ids(gid[clash])} are mid-side nodes of quadratic elements and also corner "
            "nodes of other elements (bars, linear elements); fem2tmm models quadratic elements by their corner "
            "nodes, so connect those elements to corner nodes"
        )
    return ms


def _midside_offset(points: np.ndarray, ms: np.ndarray) -> float:
    """Largest distance of a mid-side node from its edge midpoint, relative to the edge length."""
    mid = 0.5 * (points[ms[:, 1]] + points[ms[:, 2]])
    L = np.linalg.norm(points[ms[:, 2]] - points[ms[:, 1]], axis=1)
    return float((np.linalg.norm(points[ms[:, 0]] - mid, axis=1) / np.where(L > 0, L, 1.0)).max())


def _pid_groups(blocks, pids, dims, n_nodes: int, source: str):
    """Groups ``"PID n"`` (``"CONROD MID m"`` for negative keys -m) and key -> dimension, without a loop over
    elements."""
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
            f"{source}: property ids {format_ids(upid[mixed])} are used by elements of different kinds (bars, "
            "shells, solids); give each kind its own PIDs"
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
        name = f"PID {int(p)}" if p > 0 else f"CONROD MID {-int(p)}"
        groups[name] = Group(
            name=name,
            dim=int(dmin[r]),
            elements=el_order[el_bounds[r] : el_bounds[r + 1]].astype(np.int64),
            nodes=keys[nd_bounds[r] : nd_bounds[r + 1]] % n_nodes,
        )
        used[int(p)] = int(dmin[r])
    return groups, used
