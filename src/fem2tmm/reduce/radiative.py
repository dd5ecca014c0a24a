"""Radiation-aware reduction: the linearised emission inside the operator the local inversion reduces.

Why
---
The thesis' reduction (§4.3) condenses the conduction matrix K alone; every load that depends on the
temperature (radiation) is then assumed distributed like the super-node weights A.  Where heat spreads only a
fin length ``L_f = √(k t / h_rad)`` before it is radiated away and the super nodes are much larger than L_f
(Biot number per cluster ``h_rad A / (k t) ≫ 1``: thin low-conductivity panels, strong emission) the recovered
field inside a super node is the parabola of a uniform load while the true field decays within L_f of the
joints (issue 21).  Here the emission is linearised about a reference field and put *into* the reduced
operator, so the local condensation sees the fin physics (DESIGN §4.6).

The algebra (exact at the reference state)
------------------------------------------
Detailed steady equations: ``K T + E(T) − B(T) = Q`` with ``E(T) = σ e ⊙ (T⁴ − T_s⁴)`` the emission of each
DOF net of what a black environment at the sink temperature T_s returns (``e = Wᵀ(εA)`` of the faces, lumped
to nodes, m²) and ``B`` what it absorbs from the other faces beyond that.  With ``h = 4σ e ⊙ T_ref³`` (W/K) and ``K' = K + diag(h)`` the equations read, for any T_ref,

    K' T = Q + h ⊙ T − E(T) + B(T).

K' has the same sparsity as K, so the local augmented inversion (thesis §4.3.2) reduces it unchanged:
``M' = [[K', Aᵀ], [A, 0]]``, ``M'⁻¹ = [[X', Y'ᵀ], [Y', −K'_SN]]``, and, exactly,
``K'_SN T_SN = Y' q'`` and ``T = X' q' + Y'ᵀ T_SN`` for the right-hand side q' above.  K'_SN is symmetric but
no longer has zero row sums: since ``K' 1 = h`` (K 1 = 0) and A 1 = 1, ``H_SN := K'_SN 1 = Y' h`` is each super
node's linearised radiative conductance to the environment.  The network keeps a conduction matrix with zero
row sums, ``K̃ = K'_SN − diag(H_SN)``, and the super-node radiation ``R_SN(T_SN)`` of the thesis (the traced
couplings GR between super nodes and to space, σ T⁴ terms).  Substituting ``K'_SN = K̃ + diag(H_SN)`` into the
exact reduced equation and adding and subtracting R_SN gives the network

    K̃ T_SN + R_SN(T_SN) = Y' Q + Q_corr,
    Q_corr = [σ e_SN ⊙ (T_SN⁴ − T_s⁴) − H_SN ⊙ T_SN] − Y'[σ e ⊙ (T⁴ − T_s⁴) − h ⊙ T]    (at T = T_ref),

with ``e_SN`` the super nodes' emitting εA (so that ``σ e_SN (T_SN⁴ − T_s⁴)`` is R_SN's emission) and the absorbed
radiation B lumped per super node as in the thesis (``Y' Aᵀ = I``: a load spread like A is kept as it is).
Q_corr holds what neither the linear terms nor R_SN carry: the T⁴ nonlinearity about T_ref, the difference
between a super node's emission at its mean temperature and the sum of its faces' emissions, and the exact
power distribution Y'.  Both brackets are stationary at T_ref (their derivatives 4σe T³ − h vanish there,
exactly in the detailed one and to the within-cluster variation of T_ref³ in the super-node one), so Q_corr
depends on T_ref only to second order; at ``T_ref = T*`` (the detailed solution) the network gives exactly
``A T*`` and the recovery ``T = X'(Q + h ⊙ T_ref − E(T_ref)) + Y'ᵀ T_SN`` (B lumped: X' Aᵀ = 0) gives T*.
Nothing is counted twice: the linear emission sits in K'_SN only through H_SN, which K̃ removes again, and
R_SN is the only radiation term of the network.

The outer iteration (:func:`fem2tmm.reductors.radiation_aware.radiation_aware_network`) starts from a cheap pre-solve (the
thesis' reduced model, solved and recovered) and repeats at most ``[reduction] outer_iterations`` times:
linearise about T_ref and reduce K' -> Q_corr at T_ref -> solve the network -> recover -> T_ref.  Its fixed
point is the detailed solution up to the thesis' lumping of the absorbed radiation per super node (exactly the
detailed solution when every face sees only space).  Keeping h fixed also converges, but linearly, where
re-linearising converges like Newton's method, so each outer iteration re-reduces; the steps are reported
(measurements: docs/design-notes.md, reduce/radiative.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import SIGMA
from ..errors import InternalError
from ..fem.assembly import ElementCOO
from .conduction import ConductiveReduction


def emission_weights(face_W, eps_area: np.ndarray) -> np.ndarray:
    """(n_dof,) lumped emitting εA of every DOF, ``e = Wᵀ(εA)`` (m²).

    ``face_W`` (f, n_dof) sparse face averaging weights (rows sum to 1), ``eps_area`` (f,) εA of each face
    summed over its active sides (m²).
    """
    return np.asarray(face_W.T @ np.asarray(eps_area, float)).ravel()


def emission_entries(face_W, face_element: np.ndarray, eps_area: np.ndarray, T_ref: np.ndarray,
                     keep_face: np.ndarray | None = None) -> ElementCOO:
    """Linearised emission ``h = 4σ e ⊙ T_ref³`` as diagonal element entries (W/K), one per face node.

    Each face's ``4σ εA_f W_fj T_ref,j³`` goes on DOF j's diagonal and is attributed to the face's element, so
    the local reduction assigns it to that element's cluster like the element's conduction.

    Parameters
    ----------
    face_W : (f, n_dof) sparse face averaging weights
    face_element : (f,) element of each face, numbered like the conduction entries' ``elem``
    eps_area : (f,) εA of each face over its active sides, m²
    T_ref : (n_dof,) reference temperatures, K
    keep_face : (f,) bool or None: faces to include (e.g. those of clustered elements)

    Returns
    -------
    ElementCOO with rows = cols = DOF, vals W/K, elem = the face's element.
    """
    Wc = face_W.tocoo()
    f, j, w = Wc.row, Wc.col, Wc.data
    if keep_face is not None:
        sel = np.asarray(keep_face, bool)[f]
        f, j, w = f[sel], j[sel], w[sel]
    # a reference below 0 K would give a negative h and an indefinite K' (the thesis' recovered field, the first
    # reference without face-to-face radiation, reaches -1 125 K on a generated 0.1 mm box at 2 super nodes under
    # the Sun: tests/test_robustness.py); the correction's identity holds for any h, so clip at 0 K
    vals = 4.0 * SIGMA * np.asarray(eps_area, float)[f] * w * np.maximum(np.asarray(T_ref, float)[j], 0.0) ** 3
    return ElementCOO(j.astype(np.int64), j.astype(np.int64), vals, np.asarray(face_element, np.int64)[f])


def split_radiative(K_aug: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(K̃, H_SN)`` from the reduced augmented matrix ``K'_SN``: ``H_SN = K'_SN 1`` (W/K) and
    ``K̃ = K'_SN − diag(H_SN)`` (W/K, symmetric, zero row sums)."""
    H = K_aug.sum(axis=1)
    Kt = 0.5 * (K_aug + K_aug.T)
    np.fill_diagonal(Kt, 0.0)
    np.fill_diagonal(Kt, -Kt.sum(axis=1))
    return Kt, H


@dataclass
class RadiationAware:
    """The pieces of a radiation-aware reduced model (see the module docstring).

    Attributes
    ----------
    reduction : the :class:`ConductiveReduction` of ``K' = K + diag(h)`` (its ``K`` is K'_SN, row sums H_SN)
    K : (n_SN, n_SN) W/K, K̃ = K'_SN − diag(H_SN), symmetric with zero row sums
    H : (n_SN,) W/K, H_SN = Y' h, the linearised radiative conductance of each super node to the environment
    e : (n_dof,) m², lumped emitting εA of each DOF
    h : (n_dof,) W/K, the linearised emission the reduction used (``4σ e T_ref,0³``)
    T_sink : K, the environment (space node) temperature
    history : one dict per outer iteration (``max_dT_K``, ``rms_dT_K`` of the recovered field)
    shared : True when the emission was linearised once for a whole load-case set (the deck's GL shared)
    T_lin : (n_dof,) K the field the network's correction load was computed at (its last outer iteration)
    q_tally : (n_dof,) W absorbed IR tallied per FE face at T_lin (``ir_on`` "faces"/"detailed"), else zeros: the
        recovery adds it to the applied loads
    T_built : (n_dof,) K the field the reduced operator was linearised about (``h = 4σ e T_built³``): T_lin after
        re-linearising outer iterations, the set's field for a shared network; another state reduced about it gets
        the same K̃ (``[reduction] parametric``)
    floor_linked : ``(network, solution)``: the same network with the heat its short super nodes lack fed along K̃'s
        links instead of from the held node (:func:`emission_floor_links`, ``source = "linked"``), where that differs;
        the run verifies it beside the network over the validity range and hands over the better (``fem2tmm.pipeline``),
        then drops it (None)
    """

    reduction: ConductiveReduction
    K: np.ndarray
    H: np.ndarray
    e: np.ndarray
    h: np.ndarray
    T_sink: float
    history: list = field(default_factory=list)
    shared: bool = False  # linearised once for a load-case set (h fixed), not re-linearised at this case's state
    T_lin: np.ndarray | None = None
    q_tally: np.ndarray | None = None
    T_built: np.ndarray | None = None
    floor_linked: tuple | None = None

    def correction(self, T_ref: np.ndarray, T_sn_ref: np.ndarray, e_sn: np.ndarray) -> np.ndarray:
        """Q_corr (n_SN,) W at the reference state.

        ``T_ref`` (n_dof,) K detailed reference field; ``T_sn_ref`` (n_SN,) K super-node temperatures (fixed
        super nodes: their fixed value); ``e_sn`` (n_SN,) m² the emitting εA of each super node in the network,
        ``g_space + GR 1`` (its R_SN is ``σ e_SN (T_SN⁴ − T_s⁴) − σ GR (T⁴ − T_s⁴)``).
        """
        s4 = self.T_sink**4
        return (SIGMA * e_sn * (T_sn_ref**4 - s4) - self.H * T_sn_ref
                - self.reduction.distribute(SIGMA * self.e * (T_ref**4 - s4) - self.h * T_ref))

    def recovery_load(self, q: np.ndarray, T_ref: np.ndarray) -> np.ndarray:
        """The load (n_dof,) W to recover with: ``q + h ⊙ T_ref − E(T_ref)`` (q the applied loads)."""
        return q + self.h * T_ref - SIGMA * self.e * (T_ref**4 - self.T_sink**4)

    def recover(self, T_sn: np.ndarray, q: np.ndarray, T_ref: np.ndarray) -> np.ndarray:
        """Detailed temperatures (n_dof,) K, ``T = X'(q + h T_ref − E(T_ref)) + Y'ᵀ T_SN``."""
        return self.reduction.recover(T_sn, self.recovery_load(q, T_ref))

    def recover_linearised(self, T_sn: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Detailed temperatures about the network's own linearisation ``T_lin`` (a transient's recovery):
        ``T_sn`` (n_SN, r) K, ``q`` (n_dof, r) W applied loads -> (n_dof, r) K.  First order in T − T_lin, like
        the network's correction is second order (both are exact at T_lin)."""
        extra = self.h * self.T_lin - SIGMA * self.e * (self.T_lin**4 - self.T_sink**4)
        if self.q_tally is not None:
            extra = extra + self.q_tally
        q = np.asarray(q, float)
        return self.reduction.recover(T_sn, q + (extra[:, None] if q.ndim == 2 else extra))


#: the effective emission's table spans [T*/EMISSION_SPAN, T*·EMISSION_SPAN] about each super node's design
#: temperature T*.  Measured on issue 41's L-bracket at 300 super nodes (heater 0 / 5 / 40 W, sink -100 °C, RMS / max
#: K): span 1.1: 1.04/2.3, 0.27/2.0, 1.03/9.5, 0.32/1.9; 1.2: 1.02/2.3, 0.23/1.3, 0.65/5.1, 0.25/1.6; 1.25:
#: 1.03/2.3, 0.17/0.9, 0.55/3.2, 0.36/2.6; 1.3: 1.03/2.4, 0.16/0.8, 0.60/3.8, 0.53/4.0; 1.5: a state without
#: solution (docs/design-notes.md)
EMISSION_SPAN = 1.25
#: where the linear table would change the sign of the design value or fall below this fraction of it, it holds
#: this fraction instead (an emission that vanishes would leave the node without its physical heat path)
EMISSION_FLOOR = 0.05


#: a super node whose design balance asks for a negative emitting area gets this fraction of its physical εA
#: (:func:`emission_floor_links`).  The sweep below lifted *every* node under the fraction (kept: only the negative
#: ones, 2026-12-06: 100 SN 1.55/4.00, 0.44/1.90, 3.02/17.7, 1.04/4.88; 300 SN has none).  Measured on issue 41's L-bracket (heater 0 / 5 / 40 W, sink -100 °C, RMS / max
#: K; 100 super nodes, then 300): none (6 super nodes with a negative εA at 100): 2.40/5.79, 0.46/1.95, 2.85/17.5, no
#: steady solution; 0.25: 2.00/4.99, 0.50/2.03, 3.02/17.7, 1.03/4.89; 0.5: 1.44/3.94, 0.42/1.89, 3.02/17.7,
#: 1.03/4.89 and 0.96/2.22, 0.17/0.92, 0.55/3.20, 0.37/2.65; 0.75: 1.01/3.46, 0.31/1.30, 3.00/17.7, 1.01/4.55 and
#: 0.82/2.03, 0.17/0.91, 0.55/3.15, 0.40/2.84; 1.0: 9.14/36.5 at 0 W (docs/design-notes.md)
EMISSION_MIN_FRACTION = 0.75


#: relative to max |K̃|: a least eigenvalue of K̃ on the free nodes below −this counts as negative.  Far above a
#: Cholesky factorisation's round-off (~n ε max|K̃|, 1e-13 at 300 super nodes), so the exact zero of a network without
#: a held node (its uniform mode) is not taken for one; far below the −3e-4 to −2.2e-3 of the MLI model it guards,
#: over its outer iterations (tests/test_robustness.py, "mli_emissionless_radiator_negative_share")
INDEFINITE_TOLERANCE = 1e-9


def conduction_indefinite(K: np.ndarray, fixed: np.ndarray) -> bool:
    """Whether the network's conduction ``K`` (n, n) W/K (K̃, symmetric, zero row sums) has a negative eigenvalue on
    its free nodes (``fixed`` (n,) bool).

    A conduction network with its held nodes fixed is positive semi-definite: heat flows down the temperature
    differences.  K̃ = K'_SN − diag(H_SN) need not be (:class:`RadiationAware`): where the exact shape functions give
    a super node a large positive share H_SN of its neighbours' linearised emission (an emissionless radiator's
    clusters beside an emitting panel's shared edge, weights ±4 on a 2 × 2 mesh), taking it off the diagonal leaves a
    mode along which the network's conduction alone would drive heat uphill.  Its Jacobian is then positive definite
    only while the emission slopes make up for it: a network whose emitting nodes cool has no steady state there.
    """
    free = ~np.asarray(fixed, bool)
    if not free.any():
        return False
    Kf = np.asarray(K.toarray() if hasattr(K, "toarray") else K, float)[np.ix_(free, free)]
    Kf = 0.5 * (Kf + Kf.T)
    scale = float(np.abs(Kf).max(initial=0.0))
    if not scale > 0:
        return False
    try:  # positive definite once shifted by the tolerance: no eigenvalue below −INDEFINITE_TOLERANCE × scale
        np.linalg.cholesky(Kf + INDEFINITE_TOLERANCE * scale * np.eye(len(Kf)))
    except np.linalg.LinAlgError:
        return True
    return False


def _free_balance(K: np.ndarray, Q: np.ndarray, GR, T: np.ndarray) -> np.ndarray:
    """(n,) W: what each node must still lose to space at ``T``: Q − K T − σ L_GR T⁴."""
    n = len(T)
    G = np.zeros((n, n)) if GR is None else np.array(GR.todense() if hasattr(GR, "todense") else GR, float)
    np.fill_diagonal(G, 0.0)
    T4 = T**4
    return Q - K @ T - SIGMA * (G.sum(axis=1) * T4 - G @ T4)


def emission_floor_links(K: np.ndarray, Q: np.ndarray, GR: np.ndarray | None, fixed: np.ndarray, T_sn: np.ndarray,
                         T_sink: float, g_space: np.ndarray, fraction: float = EMISSION_MIN_FRACTION,
                         source: str = "held") -> np.ndarray:
    """Conductances that let every super node close its design balance with a non-negative emitting area.

    In the network of :func:`effective_emission` a cold super node far from the loads can be left with less heat
    than its own emission: Y'q and K̃ are dense (every super node gets a share of a distant heater and K̃ has
    negative links), and where the cluster emits little (tens of kelvin above a deep-space sink) their balance is a
    small difference of large terms.  Closing it with the node's coupling to space then asks for a *negative*
    emitting area (issue 41's L-bracket at 100 super nodes: 6 super nodes at 72-86 K, εA −0.002 to −0.023 m² against
    0.046 physical), whose emission falls as T⁴ grows: the network has no steady state once the sink is warmer.
    Here each such node (negative εA at T*) gets the heat it lacks, up to ``fraction`` × its physical εA ``g_space``,
    by conduction from the hottest fixed (held) node warmer than it (the structure's heat source).  Without one the
    node is left as it is: taking the heat from its warmer neighbours instead (in proportion to what K̃'s positive
    links bring it) made examples/smallsat (no held node) worse in 5 of its 7 verified states (docs/design-notes.md).  The design
    state stays exact: the added flows are part of K̃ T.

    ``source = "linked"`` takes it instead from the warmer super nodes K̃ already links to the node with a positive
    conductance, each such link scaled up by the same factor (1 + need / the heat those links bring at T*): the
    deficit follows the heat paths the reduction found.  Neither source holds everywhere (examples/satellite, sink
    at its warmest design temperature: held 12.8 K RMS, linked 1.36 K; its optics-``none`` twin, all constants
    high: held 4.18 K, linked 11.0 K; docs/design-notes.md, "Where a short node's heat comes from"), so where a run
    verifies its range it builds both and keeps the one that holds the range better (``fem2tmm.pipeline``).

    Parameters
    ----------
    K : (n, n) W/K, K̃ (zero row sums) ; Q : (n,) W ; GR : (n, n) m² or None ; fixed : (n,) bool
    T_sn : (n,) K design state ; T_sink : K ; g_space : (n,) m² physical εA to space
    fraction : the least emitting area, as a fraction of ``g_space``
    source : ``"held"`` (the hottest warmer held node) or ``"linked"`` (the warmer super nodes K̃ links it to)

    Returns
    -------
    (n, n) W/K: a Laplacian (zero row sums) to add to ``K`` (zero where no node is short).
    """
    T = np.asarray(T_sn, float)
    n = len(T)
    fixed = np.asarray(fixed, bool)
    K = np.array(K, float)
    dK = np.zeros((n, n))
    d4 = T**4 - T_sink**4
    r = _free_balance(K, np.asarray(Q, float), GR, T)
    # only the nodes whose balance asks for a negative emitting area: lifting small positive ones as well made
    # examples/composite worse in every verified state (heater 0 W 3.76 / 28.8 K against 2.40 / 15.7)
    need = np.where(~fixed & (d4 > 0) & (r < 0), SIGMA * fraction * np.asarray(g_space, float) * d4 - r, 0.0)
    if source not in ("held", "linked"):
        raise InternalError(f"emission_floor_links: source {source!r}, not 'held' or 'linked'")
    held = np.flatnonzero(fixed)
    for i in np.flatnonzero(need > 0):
        if source == "linked":  # every warmer node K̃ links to i, its link scaled by 1 + need / their inflow
            link = np.maximum(-K[i], 0.0)
            link[i] = 0.0
            js = np.flatnonzero((link > 0) & (T > T[i]))
            inflow = float(np.sum(link[js] * (T[js] - T[i])))
            if not inflow > 0:
                continue
            g = link[js] * (need[i] / inflow)
        else:
            warm = held[T[held] > T[i]]
            if not len(warm):  # no held node to feed it: left as it is (see the docstring)
                continue
            js = warm[np.argmax(T[warm])][None]
            g = need[i] / (T[js] - T[i])
        dK[i, js] -= g
        dK[js, i] -= g
        dK[i, i] += g.sum()
        dK[js, js] += g
    return dK


def effective_emission(K: np.ndarray, Q: np.ndarray, GR: np.ndarray | None, fixed: np.ndarray, T_sn: np.ndarray,
                       T_sink: float, H: np.ndarray, g_fixed: np.ndarray, g_space: np.ndarray,
                       span: float = EMISSION_SPAN) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Each super node's coupling to space as a function of its own temperature, in place of a correction load.

    The network ``K T + σ e(T) ⊙ (T⁴ − T_s⁴) + σ L_GR T⁴ = Q`` (``K`` = K̃ with zero row sums, ``Q`` the applied
    loads as the exact reduction distributes them, Y'q, ``L_GR`` the Laplacian of the super nodes' exchange GR)
    holds at the design state ``T_sn`` when ``e(T*)`` is what closes each node's balance there, and its Jacobian
    there is the exact reduced operator K'_SN = K̃ + diag(H) when ``e'(T*)`` makes the node's emission slope
    ``σ e' (T⁴ − T_s⁴) + 4σ e T³ + 4σ GR1 T³`` equal ``H``, the linearised emission of the field it stands for
    (Y'h, :class:`RadiationAware`).  So the network is exact at the design state and exact to first order about
    it, whatever load or sink moves it; further off, e(T) is linear in T up to ``T*·span`` (down to ``T*/span``)
    and constant beyond, where the emission grows as T⁴.  The slope is held at −4 e/T* or above (the emission to
    deep space, e T⁴, does not fall as the node warms); a node short of heat at T* gets it from
    :func:`emission_floor_links` first, so that e(T*) stays positive.

    Parameters
    ----------
    K : (n, n) W/K, K̃ ; Q : (n,) W ; GR : (n, n) m² or None ; fixed : (n,) bool ; T_sn : (n,) K design state
    T_sink : K ; H : (n,) W/K ; g_fixed : (n,) m² the couplings of the fixed nodes (kept as they are)
    g_space : (n,) m² each node's physical coupling to space (kept by a node at the sink's temperature)
    span : the table's reach about T*

    Returns
    -------
    ``(e_star (n,) m², (x (n, 3) K, y (n, 3) m²))``: the design values and the tables (fixed nodes: constant).
    """
    n = len(T_sn)
    T = np.asarray(T_sn, float)
    G = np.zeros((n, n)) if GR is None else np.array(GR, float)
    np.fill_diagonal(G, 0.0)
    GR1 = G.sum(axis=1)
    T4 = T**4
    r = Q - K @ T - SIGMA * (GR1 * T4 - G @ T4)  # heat each node must still lose to space at T*
    d4 = T4 - T_sink**4
    free = ~np.asarray(fixed, bool) & (np.abs(d4) > 1e-12 * np.maximum(T4, 1e-300))
    # a node at the sink's temperature has no balance to close: it keeps its physical coupling
    e = np.where(np.asarray(fixed, bool), g_fixed, g_space)
    de = np.zeros(n)
    # a balance at the round-off of its own terms is no emission: where nothing emits (ε = 0) r is that round-off,
    # and an e(T*) made of it (1e-14 m²) gave a transient's books spurious watts to space (7.7e-9 relative).  Unless
    # the node also sits at the sink's temperature to within that round-off (σ e_H |T*⁴ − T_s⁴| inside it, e_H what
    # its linearised emission H says): then any e closes its balance, and it keeps e_H, the design state exact either
    # way (a floating network at its sink's temperature that lost its coupling to space settled 17 K below the sink)
    tol = 64.0 * np.finfo(float).eps * (np.abs(Q) + np.abs(K) @ np.abs(T) + SIGMA * (GR1 * T4 + G @ T4))
    noise = free & (np.abs(r) <= tol)
    e_H = np.maximum(H / (4.0 * SIGMA * np.maximum(T, 1e-300) ** 3) - GR1, 0.0)
    at_sink = noise & (SIGMA * e_H * np.abs(d4) <= tol)
    bal = free & ~at_sink
    r = np.where(noise, 0.0, r)
    e[bal] = r[bal] / (SIGMA * d4[bal])
    de[bal] = (H[bal] - 4.0 * SIGMA * (GR1[bal] + e[bal]) * T[bal] ** 3) / (SIGMA * d4[bal])
    e[at_sink] = e_H[at_sink]
    # the emission to deep space, e T⁴, does not fall as the node warms: a slope below −4 e/T* would make a warmer
    # node lose less heat (no steady state, or Newton lost, once an edit moves it there)
    pos = free & (e > 0)
    de[pos] = np.maximum(de[pos], -4.0 * e[pos] / T[pos])
    x = T[:, None] * np.array([1.0 / span, 1.0, span])[None, :]
    y = e[:, None] + de[:, None] * (x - T[:, None])
    weak = (np.sign(y) != np.sign(e)[:, None]) | (np.abs(y) < EMISSION_FLOOR * np.abs(e)[:, None])
    y = np.where(weak, EMISSION_FLOOR * e[:, None], y)
    y[:, 1] = e
    return e, (x, y)


@dataclass(frozen=True)
class HotSpots:
    """The heat each load's footprint radiates inside its own super nodes: one radiator node per load.

    The exact reduction passes a load q to the network as Y'q, which sums to less than q: from ``K'X' + AᵀY' = I``,
    ``1ᵀY' q = 1ᵀq − hᵀX' q``, and ``hᵀX' q`` is the linearised emission of the within-cluster field X'q that the
    load raises above its super nodes' mean (a heater's hot spot; zero for a load spread like A, ``X'Aᵀ = 0``).  In
    the network that heat is neither applied nor radiated, so its books read the applied power and the emission to
    space short by it (issue 41: 17 % of the L-bracket's heater at 100 super nodes).  Here it is applied as applied
    and radiated to space by a node of its own: its load the unpassed share of the load (``unit`` × the load's value,
    so it follows the deck's constant like the load), its only coupling a GR to space.  It is coupled to no super
    node, as X'q is to no T_SN in the reduction (``T = X'q' + Y'ᵀT_SN``), so no super-node temperature moves: the
    network's temperatures are those without it, and its books are the detailed model's to the linearisation (the
    share is exact at the design state and linear in the load, as the condensation makes it).  Its GR to space
    puts it at the load footprint's mean design temperature at the design state (at the footprint's physical εA
    where the load is 0 there); its temperature off the design state follows σ GR T⁴ = share, not the footprint.

    Attributes
    ----------
    load : (r,) str the ``[[boundary]]`` name of each load ("" for the loads without a name)
    part : (r,) int the part of the super node that receives most of the load (-1: none)
    unit : (r,) W per unit of the load's value (W for a power, W/m² for a flux): the share radiated inside
    Q : (r,) W the share at the design state ; g : (r,) m² GR to space ; T : (r,) K design temperature
    """

    load: np.ndarray
    part: np.ndarray
    unit: np.ndarray
    Q: np.ndarray
    g: np.ndarray
    T: np.ndarray

    @property
    def n(self) -> int:
        return len(self.Q)

    def labels(self) -> list[str]:
        """The nodes' labels in a deck."""
        return [f"{nm or 'other loads'} hot spot" for nm in self.load]


#: m²: the smallest coupling to space a hot-spot node gets (a square micrometre: at 300 K it carries 5e-10 W).  Below
#: it the node (no capacitance, that coupling its only one) makes a transient's matrix singular in floating point: a
#: generated model whose heater was 2.2e-309 W gave its node 1e-300 m² and the deck's integration stopped ("Factor is
#: exactly singular", `fem2tmm bench robustness` 2026-12-06); the load it would carry is negligible
HOT_SPOT_MIN_M2 = 1e-12


def hot_spots(distribute, free: np.ndarray, part: np.ndarray, patterns: np.ndarray, values: np.ndarray,
              names: list[str], T_field: np.ndarray, e: np.ndarray, T_sink: float,
              rel_tol: float = 1e-6) -> HotSpots | None:
    """The :class:`HotSpots` of the loads ``patterns`` (r, n_dof) W per unit value, ``values`` (r,), on a network whose
    load distribution is ``distribute`` ((n_dof,) W -> (n,) W, Y'), ``free`` (n,) bool its free nodes, ``part`` (n,)
    their parts; ``T_field`` (n_dof,) K the design field, ``e`` (n_dof,) m² each DOF's emitting εA, ``T_sink`` K.
    A load whose share is not positive (Y' passes all of it, or more: no emission to give it), that is negative at
    the design state, or whose node's coupling would be below :data:`HOT_SPOT_MIN_M2`, gets no node; None when none
    does."""
    rows = []
    for pat, v, nm in zip(np.atleast_2d(patterns), values, names):
        pat = np.asarray(pat, float)
        total = float(np.sum(pat))
        d = np.asarray(distribute(pat), float)
        unit = total - float(np.sum(d[free]))
        if not unit > rel_tol * max(float(np.sum(np.abs(pat))), 1e-300):
            continue
        w = np.abs(pat)
        T = float(w @ T_field / w.sum())
        d4 = T**4 - T_sink**4
        if not d4 > 0:
            continue
        Q = unit * float(v)
        if Q < 0:  # a load taken out (a cooler): no emission to give it a node of its own
            continue
        g = Q / (SIGMA * d4) if Q > 0 else float(np.sum(np.asarray(e, float)[pat != 0]))
        if not g >= HOT_SPOT_MIN_M2:
            continue
        rows.append((nm, int(part[int(np.argmax(np.where(free, d, -np.inf)))]), unit, Q, g, T))
    if not rows:
        return None
    cols = list(zip(*rows))
    unit, Q, g, T = (np.array(c, float) for c in cols[2:])
    return HotSpots(load=np.array(cols[0], dtype=str), part=np.array(cols[1], np.int64), unit=unit, Q=Q, g=g, T=T)


def parametric_weights(values_si: np.ndarray, sink: bool, samples: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """Interpolation weights of the parametric states as functions of the parameter, sampled for a deck table.

    ``values_si`` (m,) the states' values (SI: W, W/m², K), ``sink``: the parameter is the sink temperature, whose
    correction follows σ T_s⁴ (the interpolation variable is then T⁴).  Between two values, Lagrange on the three
    nearest values (quadratic; linear with two values); constant beyond the ends (as ESATAN's INTRP1 tables).
    Returns ``(x (s,) SI, W (m, s))``: ``samples`` points per interval, every value itself among them (where the
    weights are exactly 0 and 1), so that a deck's piecewise-linear table of x → W reproduces the design state
    exactly and the quadratic between values to (interval/samples)² of its curvature.
    """
    v = np.asarray(values_si, float)
    order = np.argsort(v)
    xs = v[order]
    if len(xs) == 1:
        return xs.copy(), np.ones((1, 1))
    grid = np.unique(np.concatenate([np.linspace(a, b, samples + 1) for a, b in zip(xs[:-1], xs[1:])]))
    grid[np.searchsorted(grid, xs)] = xs  # the values exactly
    u = (lambda x: np.asarray(x, float) ** 4) if sink else (lambda x: np.asarray(x, float))
    U, ug = u(xs), u(grid)
    k = min(3, len(xs))
    W = np.zeros((len(xs), len(grid)))
    for g, x in enumerate(ug):
        j = min(max(int(np.searchsorted(U, x)) - (k - 1), 0), len(U) - k)
        for i in range(j, j + k):
            W[i, g] = np.prod([(x - U[m]) / (U[i] - U[m]) for m in range(j, j + k) if m != i])
    at = np.searchsorted(grid, xs)
    W[:, at] = np.eye(len(xs))  # exactly 0 and 1 at the values
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order))
    return grid, W[inverse]


__all__ = ["HotSpots", "RadiationAware", "conduction_indefinite", "effective_emission", "emission_entries",
           "emission_floor_links", "emission_weights", "hot_spots", "parametric_weights", "split_radiative"]
