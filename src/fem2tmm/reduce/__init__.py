"""Super nodes and the exact conductive reduction (thesis §4.3, DESIGN §3.2–3.3).

Pure functions on arrays: :func:`build_supernodes` (A), :func:`reduce_conduction` (K_SN with
``distribute`` / ``recover``), capacitance of the super nodes, and the TMRT link filter.
"""

from __future__ import annotations

from .capacitance import cluster_capacitance, equivalent_capacitance, supernode_capacitance
from .conduction import ConductiveReduction, reduce_conduction
from .filters import filter_links, negative_links
from .radiative import RadiationAware, emission_entries, emission_weights, split_radiative
from .supernodes import SuperNodes, build_supernodes

__all__ = [
    "SuperNodes",
    "build_supernodes",
    "ConductiveReduction",
    "reduce_conduction",
    "cluster_capacitance",
    "supernode_capacitance",
    "equivalent_capacitance",
    "filter_links",
    "negative_links",
    "RadiationAware",
    "emission_entries",
    "emission_weights",
    "split_radiative",
]
