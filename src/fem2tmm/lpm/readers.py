"""Read any supported network file: ESATAN deck, SINDA/FLUINT deck, fem2tmm's ``reduced.npz``; node coordinates.

:func:`read_network` picks the reader from the suffix (``.npz``; ``.sinda``/``.sin``/``.inp`` → SINDA) or, for
other names, from the content (``HEADER … DATA`` → SINDA, ``$NODES`` → ESATAN).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..constants import KELVIN
from ..errors import Fem2TmmError
from ..export.esatan import node_numbers
from .esatan import read_esatan
from .network import Network
from .sinda import read_sinda


def read_reduced_npz(path: str | Path) -> Network:
    """fem2tmm's ``reduced.npz`` (DESIGN §4.3) as a network.

    Node numbers follow :func:`fem2tmm.export.esatan.node_numbers` (the numbers of the ESATAN / SINDA decks written
    beside it); the space node (last row/column of ``GR``) becomes a boundary node labelled SPACE at ``T_sink``.
    Off-diagonal ``−K`` are the GL (negative ones included: the exact reduction's).  ``positions`` (n, 3) m, when
    the file holds them, are the nodes' coordinates (what sizes the couplings of ``fem2tmm network reduce``).
    """
    path = Path(path)
    try:
        z = np.load(path, allow_pickle=False)
        names, fixed, K, GRs, T = z["names"], z["is_boundary"], z["K"], z["GR"], z["T"]
        C = np.nan_to_num(z["C"]) if "C" in z else np.zeros(len(names))
        Q = z["Q"]
        part = z["part"] if "part" in z else np.full(len(names), -1)
        T_sink = float(z["T_sink"]) if "T_sink" in z else -270.0
        X = np.asarray(z["positions"], float) if "positions" in z else None  # (n, 3) m; older files: none
    except (OSError, KeyError, ValueError) as exc:
        raise Fem2TmmError(f"{path}: not a fem2tmm reduced.npz ({exc})") from None
    n = len(names)
    if K.shape != (n, n) or GRs.shape != (n + 1, n + 1):
        raise Fem2TmmError(f"{path}: K {K.shape} / GR {GRs.shape} do not match {n} nodes (+ space)")
    if "hot_spot_Q" in z.files:  # the loads' hot-spot nodes: arithmetic, their GR to space only
        r = len(z["hot_spot_Q"])
        K = np.pad(np.asarray(K, float), (0, r))
        G = np.zeros((n + r + 1, n + r + 1))
        G[:n, :n], G[:n, -1], G[-1, :n] = GRs[:n, :n], GRs[:n, n], GRs[n, :n]
        G[n:n + r, -1] = G[-1, n:n + r] = z["hot_spot_GR"]
        GRs, n = G, n + r
        names, fixed = np.r_[names.astype(str), z["hot_spot_labels"].astype(str)], np.r_[fixed, np.zeros(r, bool)]
        C, Q, T = np.r_[C, np.zeros(r)], np.r_[Q, z["hot_spot_Q"]], np.r_[T, z["hot_spot_T"]]
        part = np.r_[part, z["hot_spot_part"]]
        X = None if X is None else np.r_[X, np.full((r, 3), np.nan)]
    n_parts = int(part.max(initial=-1)) + 1
    numbers, space = node_numbers(part, n_parts)
    GL = -np.array(K, float)
    np.fill_diagonal(GL, 0.0)
    GLf = np.zeros((n + 1, n + 1))
    GLf[:n, :n] = 0.5 * (GL + GL.T)
    GR = 0.5 * (GRs + GRs.T)
    np.fill_diagonal(GR, 0.0)
    kind = np.where(fixed, "B", "D")
    coords = None if X is None or X.shape != (n, 3) else np.r_[X, np.full((1, 3), np.nan)]  # space: nowhere
    return Network(numbers=np.r_[numbers, space], labels=np.r_[names.astype(str), ["SPACE"]],
                   kind=np.r_[kind, ["B"]], T=np.r_[T, T_sink] + KELVIN, C=np.r_[C, 0.0], A=np.zeros(n + 1),
                   alp=np.zeros(n + 1), eps=np.zeros(n + 1), QI=np.r_[Q, 0.0], GL=sp.csr_matrix(GLf),
                   GR=sp.csr_matrix(GR), coordinates=coords, source=str(path))


def read_network(path: str | Path) -> Network:
    """Read a network file (ESATAN, SINDA/FLUINT or ``reduced.npz``), format from the suffix or the content."""
    path = Path(path)
    if not path.is_file():
        raise Fem2TmmError(f"{path}: no such network file")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return read_reduced_npz(path)
    if suffix in (".sinda", ".sin", ".inp"):
        return read_sinda(path)
    if suffix in (".esatan", ".erg", ".d"):
        return read_esatan(path)
    head = path.read_text(encoding="utf-8", errors="replace")[:200_000].upper()
    if "HEADER" in head and "NODE DATA" in head:
        return read_sinda(path)
    if "$NODES" in head:
        return read_esatan(path)
    raise Fem2TmmError(f"{path}: neither an ESATAN deck ($NODES), a SINDA/FLUINT deck (HEADER NODE DATA) nor a "
                       "fem2tmm reduced.npz")


def read_coordinates(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``nodes.csv`` with columns ``node,x,y,z`` (m): returns numbers (k,) int64 and xyz (k, 3) m."""
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise Fem2TmmError(f"{path}: cannot read the coordinates ({exc.strerror})") from None
    if not rows or [c.strip().lower() for c in rows[0]][:4] != ["node", "x", "y", "z"]:
        raise Fem2TmmError(f"{path}:1: the first line must be the header node,x,y,z (coordinates in m)")
    nums, xyz = [], []
    for lineno, r in enumerate(rows[1:], 2):
        if not r or not "".join(r).strip():
            continue
        try:
            nums.append(int(r[0]))
            xyz.append([float(v) for v in r[1:4]])
            if len(xyz[-1]) != 3:
                raise ValueError
        except (ValueError, IndexError):
            raise Fem2TmmError(f"{path}:{lineno}: expected node,x,y,z (an integer and three numbers in m), "
                               f"got {','.join(r)!r}") from None
    nums = np.array(nums, np.int64)
    u, c = np.unique(nums, return_counts=True)
    if (c > 1).any():
        raise Fem2TmmError(f"{path}: node {int(u[c > 1][0])} appears twice")
    return nums, np.array(xyz, float).reshape(-1, 3)


__all__ = ["read_coordinates", "read_network", "read_reduced_npz"]
