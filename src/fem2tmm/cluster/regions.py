"""Regions: the pieces of a part that clusters may not cross (thesis §4.2).

Shell parts are cut

* at **sharp edges**: the angle between the two surfaces meeting at an edge exceeds ``feature_angle``;
* at **junctions**: edges shared by more than two elements (already unlinked in the dual graph);
* where the element ``attribute`` changes (material, thickness, optics: any integer the caller gives);

and what is left is split into connected components.  Solid parts are cut only where the attribute
changes, then split into face-connected components (thesis: 3-D parts are clustered whole).

Orientation of shell normals
----------------------------
The angle at an edge is measured between the *surfaces*, not between the raw element normals: when the
two elements run through their shared edge in the same direction their orientations are inconsistent
(one of them is locally flipped), and the normal of one of them is reversed before the comparison.
This is exact, unlike taking ``|cos|``: a flipped element does not create a false sharp edge, and a
genuine fold sharper than ``180° - feature_angle`` (a hairpin) is still detected.
"""

from __future__ import annotations

import heapq

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .adjacency import DualGraph


def sharp_links(graph: DualGraph, normals: np.ndarray, feature_angle: float) -> np.ndarray:
    """(p,) bool: links of a shell dual graph whose dihedral angle exceeds ``feature_angle`` (degrees).

    ``normals`` (m, 3) unit element normals.  The normal of ``b`` is reversed where the link is not
    consistently oriented (see the module docstring).
    """
    cos = np.einsum("ij,ij->i", normals[graph.a], normals[graph.b])
    cos = np.where(graph.consistent, cos, -cos)
    # a small tolerance so that an angle of exactly feature_angle (a polygonal tube) is not sharp
    return cos < np.cos(np.radians(feature_angle)) - 1e-12


def regions(graph: DualGraph, m: int, kind: str, normals: np.ndarray | None = None,
            attribute: np.ndarray | None = None, feature_angle: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
    """Split a part into regions.

    Parameters
    ----------
    graph : the part's :class:`DualGraph`
    m : number of elements of the part
    kind : "shell" or "solid"
    normals : (m, 3) unit normals (shells)
    attribute : (m,) int or None; elements with different values never share a region
    feature_angle : degrees (shells)

    Returns
    -------
    region : (m,) int64 region of each element, numbered by increasing smallest element index
    keep : (p,) bool the links of ``graph`` that lie inside a region
    """
    keep = np.ones(len(graph.a), bool)
    if kind == "shell":
        keep &= ~sharp_links(graph, normals, feature_angle)
    if attribute is not None:
        attribute = np.asarray(attribute)
        keep &= attribute[graph.a] == attribute[graph.b]
    a, b = graph.a[keep], graph.b[keep]
    g = sp.csr_matrix((np.ones(len(a), np.int8), (a, b)), shape=(m, m))
    _, comp = connected_components(g, directed=False)
    # renumber by smallest element index so the numbering does not depend on scipy's traversal
    return _by_first_element(comp), keep


def _by_first_element(labels: np.ndarray) -> np.ndarray:
    """(m,) int64 labels renumbered 0, 1, ... in the order of their smallest element index (unused labels dropped)."""
    m = len(labels)
    first = np.full(int(labels.max()) + 1 if m else 0, m, np.int64)
    np.minimum.at(first, labels, np.arange(m))
    used = np.flatnonzero(first < m)
    rank = np.full(len(first), -1, np.int64)
    rank[used[np.argsort(first[used], kind="stable")]] = np.arange(len(used))
    return rank[labels]


def merge_regions(graph: DualGraph, region: np.ndarray, keep: np.ndarray, measure: np.ndarray, n_target: int
                  ) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """Merge regions until there are ``n_target`` (a part asking for fewer super nodes than it has regions).

    Order: the region of smallest area (volume, length) first, into the neighbour it shares the strongest link
    with (the longest shared edges, the largest shared faces: the largest conductance for a given sheet); repeated
    on the merged regions.  Regions that touch no other region through an edge (face) of the part, disconnected
    pieces, are never merged (a cluster stays contiguous), so fewer than ``n_target`` may be impossible: the caller
    then refuses with the regions listed.

    Parameters
    ----------
    graph : the part's :class:`DualGraph`
    region : (m,) int64 region of each element (from :func:`regions`)
    keep : (p,) bool links inside regions
    measure : (m,) area (m²), volume (m³) or length (m) of each element
    n_target : regions wanted

    Returns
    -------
    region : (m,) int64 merged regions, renumbered by increasing smallest element index
    keep : (p,) bool links inside the merged regions (the merged boundaries' links added)
    merges : one dict per merge, in order: ``region`` (the absorbed one, original numbering of its smallest
        element's region), ``into``, ``measure`` of the absorbed region, ``link`` (shared edge length m / face m²)
    """
    region = np.asarray(region, np.int64)
    r = int(region.max()) + 1 if len(region) else 0
    if n_target >= r:
        return region, keep, []
    a, b = graph.a, graph.b
    cross = region[a] != region[b]
    ra, rb = region[a[cross]], region[b[cross]]
    lo, hi = np.minimum(ra, rb), np.maximum(ra, rb)
    links: dict[int, dict[int, float]] = {i: {} for i in range(r)}
    for i, j, w in zip(lo.tolist(), hi.tolist(), graph.measure[cross].tolist()):
        links[i][j] = links[i].get(j, 0.0) + w
        links[j][i] = links[j].get(i, 0.0) + w
    size = np.bincount(region, measure, minlength=r).astype(float)
    parent = np.arange(r)
    alive = set(range(r))
    merges: list[dict] = []
    heap = [(size[i], i) for i in range(r)]
    heapq.heapify(heap)
    while len(alive) > n_target and heap:
        s, i = heapq.heappop(heap)
        if i not in alive or s != size[i]:
            continue  # stale entry
        if not links[i]:
            continue  # a disconnected piece: never merged
        j = max(links[i], key=lambda k: (links[i][k], -k))
        merges.append({"region": int(i), "into": int(j), "measure": float(size[i]), "link": float(links[i][j])})
        # i into j
        for k, w in links.pop(i).items():
            del links[k][i]
            if k != j:
                links[j][k] = links[j].get(k, 0.0) + w
                links[k][j] = links[k].get(j, 0.0) + w
        parent[i] = j
        size[j] += size[i]
        alive.discard(i)
        heapq.heappush(heap, (size[j], j))
    # resolve the chains of merges, then renumber by smallest element index
    root = np.arange(r)
    for i in range(r):
        k = i
        while parent[k] != k:
            k = parent[k]
        root[i] = k
    new = _by_first_element(root[region])
    keep = keep | ((region[a] != region[b]) & (new[a] == new[b]))
    return new, keep, merges
