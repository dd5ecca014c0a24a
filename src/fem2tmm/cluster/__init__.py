"""Clustering of a structural mesh into super nodes (thesis §4.2, DESIGN §3.4).

Stages, each a module of plain functions on arrays:

* :mod:`.adjacency` — dual graph (shared edges / faces), CSR helpers;
* :mod:`.regions` — split at sharp edges, junctions, attribute changes, connected components;
* :mod:`.allocate` — a part's super nodes shared among its regions (area and characteristic length);
* :mod:`.seeding` — weighted k-means seeds;
* :mod:`.growing` — greedy multi-source region growing;
* :mod:`.smoothing` — pairwise min-cut boundary smoothing;
* :mod:`.metis` — METIS on each region (optional pymetis), ``method="metis"``;
* :mod:`.driver` — :func:`cluster_parts` (pipeline), :func:`partition` (one mesh) and :func:`from_labels`
  (a user partition).
"""

from __future__ import annotations

from .driver import Clustering, PartInput, cluster_parts, from_labels, partition

__all__ = ["Clustering", "PartInput", "cluster_parts", "from_labels", "partition"]
