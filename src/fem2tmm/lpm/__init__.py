"""Lumped-parameter thermal networks: read ESATAN / SINDA decks and fem2tmm's own reductions, solve them, reduce
them (TMRT kept / suppressed / grouped nodes; Fernández Rico's automatic grouping) and turn fem2tmm's exact dense
reduced conduction into a positive sparse network.
"""

from __future__ import annotations

from .esatan import read_esatan
from .grouping import Criteria, group, prepare, sweep
from .network import LoadCase, Network
from .positive import positive_network
from .readers import read_coordinates, read_network, read_reduced_npz
from .sinda import read_sinda
from .solve import NetworkSolution, solve_network
from .tmrt import tmrt_reduce

__all__ = ["Criteria", "LoadCase", "Network", "NetworkSolution", "group", "positive_network", "prepare",
           "read_coordinates", "read_esatan", "read_network", "read_reduced_npz", "read_sinda", "solve_network",
           "sweep", "tmrt_reduce"]
