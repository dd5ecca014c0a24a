"""Tokenising a Nastran deck: the card tables, the one-pass scan of the lines (formats, continuations, replication,
``INCLUDE``, ``BEGIN BULK``/``ENDDATA``) and the vectorised field parsers (see :mod:`fem2tmm.io.nastran`)."""

from __future__ import annotations

import re
import warnings
from array import array
from bisect import bisect_right
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import Fem2TmmError


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
#: field 1 holding a card name, blanks and a number: data separated by blanks ("GRID 1 0 0.0 ..."), which
#: Nastran does not read (free field is comma-separated; MSC Nastran Quick Reference Guide, "Bulk Data Entry format")
_BLANK_SEPARATED = re.compile(rb"^([A-Z][A-Z0-9]{0,7})\*?\s+[-+.0-9]")


def _blank_separated(head: bytes, where: str, raw: bytes) -> Fem2TmmError | None:
    """The one error for a card written with blanks between its fields (``head``: field 1, upper case), or None."""
    m = _BLANK_SEPARATED.match(head)
    if m is None or (m.group(1) not in _NAMES and not is_structural(m.group(1).decode("latin-1"))):
        return None
    text = raw.decode("latin-1").strip()
    return Fem2TmmError(f"{where}: {text[:60]!r}: fields separated by blanks, which Nastran does not read: bulk data "
                        "is fixed field (8 columns a field, the card name in columns 1-8) or free field separated by "
                        f"commas ({','.join(text.split())[:60]!r}); rewrite the file with commas or in 8-column "
                        "fields")


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
                if not free and (bad := _blank_separated(uhead, f"{where_file}:{i + 1}", raw)) is not None:
                    raise bad
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
