"""Nastran joint cards: RBE2, RBE3, CBUSH, CELAS1, CELAS2, CGAP as thermal connections (see :mod:`fem2tmm.io.nastran`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from ...errors import Fem2TmmError
from ...mesh import JointBlock
from .deck import _Deck, _JOINTS, _scalar_int
from .geometry import _Grids


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
