"""Where the emitted IR is absorbed on the detailed mesh (``[radiation] ir_on = "detailed"`` or ``"faces"``): the
operator a radiation-aware reduction recovers the FE sides' absorbed IR with."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..constants import SIGMA


@dataclass(frozen=True)
class IRAbsorption:
    """Where the emitted IR is absorbed on the detailed mesh (``[radiation] ir_on = "detailed"`` or ``"faces"``).

    ``A`` (g, 2f) csr: fraction of emitter i's emitted energy absorbed by FE side k; ``owner`` (g,) the super node
    of each emitter; ``eps_area`` (g,) m² its emitting εA.  ``"detailed"``: the emitters are the super faces,
    each at its super node's temperature (raw ray tally); ``"faces"``: the emitters are the active FE face sides,
    ``face`` (g,) the FE face of each, at the recovered field's face temperature ((W T⁴)^¼, as the detailed
    model's REFs), and A their REFs after reciprocity and closure (the detailed reference's estimator, own rays).
    ``unblocked``, ``to_space`` (2f,): per FE side, the traced fraction of its emission not stopped by inactive sides
    and the fraction that leaves to space (:func:`~fem2tmm.radiation.tracer.side_fractions`; per emitter).
    """

    A: sp.csr_matrix
    owner: np.ndarray
    eps_area: np.ndarray
    face: np.ndarray | None = None
    unblocked: np.ndarray | None = None
    to_space: np.ndarray | None = None

    def face_power(self, T_sn: np.ndarray, T_sink: float, T4_face: np.ndarray | None = None) -> np.ndarray:
        """(f,) W absorbed by each FE face (both sides) when each emitter emits σ εA (T⁴ − T_sink⁴): T the super
        node's ``T_sn`` (n,) K, or with per-face emitters the face's ``T4_face`` (f,) K⁴ (required then)."""
        T4 = T_sn[self.owner] ** 4 if self.face is None else T4_face[self.face]
        emitted = SIGMA * self.eps_area * (T4 - T_sink**4)
        return np.asarray(self.A.T @ emitted).ravel().reshape(-1, 2).sum(axis=1)
