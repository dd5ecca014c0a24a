"""Scrambled Halton points for the ray tracer (thesis §2.2.4, coupled 4-D sampling §2.3.2).  The maps that turn
them into origins and directions (area-preserving triangle map eq. 2.18, Malley's cosine law §2.2.1) are the
compiled kernels of :mod:`fem2tmm.radiation._tracer_kernels`.

The scrambled Halton generator is written
here (instead of one ``scipy.stats.qmc.Halton`` object per super face) because a model may have 10^4-10^5 emitting
groups, each needing its own random segment of the sequence: the generator below takes an arbitrary array of
integer indices, so every group reads ``offset_g + k`` for its k-th ray in one vectorised call.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

HALTON_BASES = (2, 3, 5, 7, 11, 13)
_ONE_MINUS = float(np.nextafter(1.0, 0.0))
_TABLE_SIZE = 1024  # digits of one base are processed in blocks whose b^m combinations fit in this table


class ScrambledHalton:
    """Random-digit-scrambled Halton sequence (default bases 2, 3, 5, 7, 11, 13) at arbitrary integer indices.

    Each base has an independent random permutation of the digits {0..b-1} for every digit position (the
    scrambling of Matoušek / scipy's ``Halton(scramble=True)``); a permutation per position maps elementary
    intervals onto elementary intervals, so every stratification property of the plain sequence is kept
    (n = 2^k 3^l consecutive indices put exactly one point in each 2^-k x 3^-l box of the first two coordinates).
    ``scramble=False`` gives the plain radical inverses (identical to ``scipy.stats.qmc.Halton(scramble=False)``).

    The radical inverse is evaluated m digits at a time through a lookup table of the b^m digit combinations
    (m = 10, 6, 4, 3, 2, 2 for the bases 2 ... 13), in a compiled loop that steps runs of consecutive indices
    (about 6 ns per 6-D point).
    """

    def __init__(self, rng: np.random.Generator | None = None, bases=HALTON_BASES, scramble: bool = True):
        if scramble and rng is None:
            raise ValueError("a scrambled Halton sequence needs a random generator")
        self.bases = tuple(int(b) for b in bases)
        self._tables = []
        for b in self.bases:
            ndig = math.ceil(53 / math.log2(b))  # digits until b^-ndig < 2^-53
            m = max(1, int(math.floor(math.log(_TABLE_SIZE) / math.log(b))))
            nblocks = math.ceil(ndig / m)
            if scramble:
                perms = np.argsort(rng.random((nblocks * m, b)), axis=1)
            else:
                perms = np.tile(np.arange(b), (nblocks * m, 1))
            B = b**m
            combos = np.arange(B)
            tables = np.zeros((nblocks, B))
            for k in range(nblocks):
                rest = combos.copy()
                for j in range(m):  # loop over digit positions (<= 53), vectorised over the b^m combinations
                    pos = k * m + j
                    digit = rest % b
                    rest //= b
                    tables[k] += perms[pos, digit] * float(b) ** (-(pos + 1))
            # contribution of all blocks from k on when the remaining index is zero (digit 0 everywhere)
            tails = np.concatenate([np.cumsum(tables[::-1, 0])[::-1], [0.0]])
            self._tables.append((B, tables, tails))

    @property
    def dim(self) -> int:
        return len(self.bases)

    def points(self, index: np.ndarray, dims: int | None = None) -> np.ndarray:
        """Points of the sequence at ``index`` (r,) non-negative int: returns (r, dims) floats in [0, 1), the first
        ``dims`` coordinates (default all ``dim``)."""
        index = np.ascontiguousarray(index, dtype=np.int64)
        dims = self.dim if dims is None else int(dims)
        if not 0 < dims <= self.dim:
            raise ValueError(f"dims must be in 1..{self.dim}, got {dims}")
        out = np.empty((index.size, dims))
        top = int(index.max()) if index.size else 0
        if index.size and int(index.min()) < 0:
            raise ValueError("Halton indices must be non-negative")
        for c, (B, tables, tails) in enumerate(self._tables[:dims]):
            nb = 1
            while B**nb <= top and nb < len(tables):
                nb += 1
            _radical_inverse(index, np.int64(B), tables, float(tails[nb]), nb, out, c)
        return out


@njit(cache=True, nogil=True)
def _radical_inverse(index, B, tables, tail, nb, out, c):
    """out[:, c] = scrambled radical inverse of ``index`` (r,): ``nb`` blocks of digits in base ``B`` (= b^m), each
    looked up in ``tables`` (nblocks, B), plus ``tail`` for the all-zero higher blocks; clipped below 1.  Runs of
    consecutive indices (each group's rays) step the lowest block and carry, instead of dividing every index."""
    low = B  # no run yet
    high = 0.0
    one = np.int64(1)
    prev = index[0] if index.shape[0] else 0
    for k in range(index.shape[0]):
        i = index[k]
        if k > 0 and i == prev + one and low + one < B:
            low += one
        else:
            q = i // B
            low = i - q * B
            high = tail
            rest = q
            for j in range(1, nb):
                qq = rest // B
                high += tables[j, rest - qq * B]
                rest = qq
        out[k, c] = min(high + tables[0, low], _ONE_MINUS)
        prev = i
