"""Lumped-parameter thermal networks: read ESATAN / SINDA decks and fem2tmm's own reductions, solve them, reduce
them (TMRT kept / suppressed / grouped nodes; Fernández Rico's automatic grouping) and turn fem2tmm's exact dense
reduced conduction into a positive sparse network.
"""

from __future__ import annotations

from .esatan import read_esatan
from .network import LoadCase, Network
from .readers import read_coordinates, read_network, read_reduced_npz
from .sinda import read_sinda
from .solve import NetworkSolution, solve_network

__all__ = ["LoadCase", "Network", "NetworkSolution", "read_coordinates", "read_esatan", "read_network",
           "read_reduced_npz", "read_sinda", "solve_network"]
