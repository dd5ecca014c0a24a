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
    first = np.full(comp.max() + 1 if m else 0, m, np.int64)
    np.minimum.at(first, comp, np.arange(m))
    rank = np.empty_like(first)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[comp].astype(np.int64), keep
