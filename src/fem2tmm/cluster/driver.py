"""The clustering stage: parts -> regions -> allocation -> seeds -> region growing -> smoothing.

Public entry points (re-exported by :mod:`fem2tmm.cluster`):

* :func:`cluster_parts` — the per-part driver the pipeline calls on a whole mesh;
* :func:`partition` — one part given as plain arrays (``fem2tmm.partition``, DESIGN §4.4).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..arrays import unique
from ..errors import Fem2TmmError, format_ids
from ..mesh import geometry
from ..mesh.elements import ELEMENT_TYPES, LINE_TYPES, N_NODES, SHELL_TYPES, SOLID_TYPES, TYPE_CODE
from .adjacency import DualGraph, dual_graph, induced_csr, to_csr
from .allocate import allocate
from .contact import RANK, element_rank, embedded, join_units, kind_of_rank
from .growing import grow, grow_balanced
from .metis import metis_region, require as require_metis
from .regions import merge_regions, regions as split_regions
from .seeding import seed_elements, weighted_kmeans
from .smoothing import smooth

_KIND_TYPES = {"shell": SHELL_TYPES, "solid": SOLID_TYPES, "line": LINE_TYPES,
               "mixed": (*LINE_TYPES, *SHELL_TYPES, *SOLID_TYPES)}
_MEASURE_UNIT = {"shell": "m2", "solid": "m3", "line": "m"}
_BOUNDARY_UNIT = {"shell": "m", "solid": "m2", "line": "ends"}
_STEPS = ("geometry", "regions", "allocation", "seeding", "growing", "smoothing")


@dataclass(frozen=True)
class PartInput:
    """One part to cluster.

    Attributes
    ----------
    name : part name (error messages, report)
    kind : "shell", "solid", "line" (bars: regions are the chains between junctions, clusters grow
        along the bars, no boundary smoothing) or "mixed" (several kinds: the part's super nodes are shared
        among its kinds in proportion to their elements not embedded in another kind, :mod:`.contact`)
    elements : (m,) int64 global element indices of the part
    cells : (m, 8) int64 node indices padded with -1 (rows of ``Mesh.padded_cells``)
    types : (m,) int8 type codes (:data:`fem2tmm.mesh.elements.TYPE_CODE`); shells tri3/quad4, solids
        tet4/hex8/wedge6, mixed freely within the kind
    n_clusters : super nodes requested for the part
    attribute : (m,) int or None; elements with different values never share a region (material,
        thickness, optics)
    ids : (m,) int or None; original element ids used in error messages (default: ``elements``)
    flux : (m,) float or None; absorbed external flux of each element (W/m², e.g. a cheap solar pre-pass).
        Given, the clusters follow it (:func:`flux_feature`): super faces whose loads are lumped stay
        nearly uniformly loaded (ignored for line elements)
    dofs : (m, 8) int or None; the thermal unknown of each cell node (-1 padded), for contact between parts
        and kinds (:mod:`.contact`: nodes merged by an isothermal joint touch); default the cells' nodes.  Give
        it for every part or for none
    """

    name: str
    kind: str
    elements: np.ndarray
    cells: np.ndarray
    types: np.ndarray
    n_clusters: int
    attribute: np.ndarray | None = None
    ids: np.ndarray | None = None
    flux: np.ndarray | None = None
    dofs: np.ndarray | None = None


@dataclass(frozen=True)
class Clustering:
    """Result of :func:`cluster_parts`.

    Attributes
    ----------
    labels : (n_elements,) int64 global cluster id, -1 for elements in no part; the clusters of part p
        are numbered consecutively after those of part p-1
    regions : (n_elements,) int64 global region id, -1 outside the parts (numbered the same way)
    cluster_part : (n_clusters,) int64 index of the part of each cluster
    cluster_region : (n_clusters,) int64 global region of each cluster
    report : JSON-serialisable quality report, ``{"parts": [...], "total": {...}}``
    """

    labels: np.ndarray
    regions: np.ndarray
    cluster_part: np.ndarray
    cluster_region: np.ndarray
    report: dict


@dataclass
class _Prepared:
    """Per-part data computed before any clustering (so that all input errors come first)."""

    part: PartInput
    weights: np.ndarray  # (m,)
    measure: np.ndarray  # (m,) area or volume
    centroids: np.ndarray  # (m, 3)
    graph: DualGraph
    keep: np.ndarray  # (p,) links inside regions
    region: np.ndarray  # (m,)
    alloc: np.ndarray  # (r,)
    times: dict
    merged: dict | None = None  # regions merged to meet the requested count (merge_regions)
    deferred: tuple = ()  # (global element indices,) of the pieces given no cluster of their own (.contact)


def _ids(part: PartInput, local: np.ndarray) -> str:
    src = part.ids if part.ids is not None else part.elements
    word = "element ids" if part.ids is not None else "element indices"
    return f"{word} {format_ids(np.asarray(src)[local])}"


def _check_part(points: np.ndarray, part: PartInput, n_elements: int | None) -> None:
    """Shape, kind, type and range checks of one part; raises Fem2TmmError."""
    where = f"part {part.name!r}"
    if part.kind not in _KIND_TYPES:
        raise Fem2TmmError(f"{where}: kind must be 'shell', 'solid', 'line' or 'mixed', got {part.kind!r}")
    m = len(part.elements)
    if m == 0:
        raise Fem2TmmError(f"{where} has no elements; check its groups")
    if part.cells.shape != (m, 8) or part.types.shape != (m,):
        raise Fem2TmmError(f"{where}: cells must be (m, 8) and types (m,) for its {m} elements")
    if part.attribute is not None and np.shape(part.attribute) != (m,):
        raise Fem2TmmError(f"{where}: attribute must have one value per element ({m})")
    if part.flux is not None and (np.shape(part.flux) != (m,) or not np.isfinite(part.flux).all()):
        raise Fem2TmmError(f"{where}: flux must have one finite value per element ({m})")
    if part.dofs is not None and np.shape(part.dofs) != (m, 8):
        raise Fem2TmmError(f"{where}: dofs must be (m, 8) like cells, one row per element ({m})")
    if n_elements is not None and (part.elements.min() < 0 or part.elements.max() >= n_elements):
        raise Fem2TmmError(f"{where}: element indices outside 0..{n_elements - 1}")
    allowed = [TYPE_CODE[t] for t in _KIND_TYPES[part.kind]]
    bad = ~np.isin(part.types, allowed)
    if bad.any():
        got = sorted({ELEMENT_TYPES[int(t)] if 0 <= t < len(ELEMENT_TYPES) else str(int(t))
                      for t in part.types[bad]})
        raise Fem2TmmError(
            f"{where} is a {part.kind} part but contains {', '.join(got)} elements ({_ids(part, np.flatnonzero(bad))});"
            f" a {part.kind} part takes only {', '.join(_KIND_TYPES[part.kind])}"
        )
    nn = np.array([N_NODES[t] for t in ELEMENT_TYPES])[part.types]
    used = np.arange(8)[None, :] < nn[:, None]
    c = part.cells
    bad = ((c < 0) | (c >= len(points))) & used
    if bad.any():
        raise Fem2TmmError(f"{where}: {_ids(part, np.flatnonzero(bad.any(1)))} reference nodes that do not exist")
    n_cl = part.n_clusters
    if not isinstance(n_cl, (int, np.integer)) or isinstance(n_cl, bool) or n_cl < 1:
        raise Fem2TmmError(f"{where}: the number of super nodes must be a positive integer, got {n_cl!r}")
    if n_cl > m:
        raise Fem2TmmError(
            f"{where}: {n_cl} super nodes requested but the part has only {m} elements; ask for at most {m}"
        )


def _geometry(points: np.ndarray, part: PartInput):
    """(measure (m,), normals (m, 3) or None, centroids (m, 3)) with degenerate-element checks."""
    m = len(part.elements)
    measure = np.zeros(m)
    diag = np.zeros(m)
    centroids = np.zeros((m, 3))
    normals = np.zeros((m, 3)) if part.kind == "shell" else None
    for t in _KIND_TYPES[part.kind]:
        sel = np.flatnonzero(part.types == TYPE_CODE[t])
        if len(sel) == 0:
            continue
        c = part.cells[sel, : N_NODES[t]]
        X = points[c]
        diag[sel] = np.linalg.norm(X.max(1) - X.min(1), axis=1)
        centroids[sel] = geometry.centroids(points, c)
        if part.kind == "shell":
            measure[sel] = geometry.shell_areas(points, c, t)
            normals[sel] = geometry.shell_normals(points, c, t)
        elif part.kind == "line":
            measure[sel] = np.linalg.norm(X[:, 1] - X[:, 0], axis=1)
        else:
            measure[sel] = np.abs(geometry.solid_volumes(points, c, t))
    if not np.isfinite(centroids).all() or not np.isfinite(measure).all():
        bad = ~(np.isfinite(centroids).all(1) & np.isfinite(measure))
        raise Fem2TmmError(f"part {part.name!r}: non-finite coordinates in {_ids(part, np.flatnonzero(bad))}")
    s = np.sort(np.where(part.cells >= 0, part.cells, -1 - np.arange(8)[None, :]), axis=1)
    repeated = (s[:, 1:] == s[:, :-1]).any(axis=1)
    dim = {"shell": 2, "solid": 3, "line": 1}[part.kind]
    tiny = measure <= 1e-10 * diag**dim
    bad = repeated | tiny
    if bad.any():
        what = {"shell": "zero area", "solid": "zero volume", "line": "zero length"}[part.kind]
        raise Fem2TmmError(
            f"part {part.name!r}: degenerate elements (repeated nodes or {what}): "
            f"{_ids(part, np.flatnonzero(bad))}; fix or remove them"
        )
    return measure, normals, centroids


FLUX_CONTRAST = 2.0  # a flux step of one part-wide deviation σ weighs as much as 2 cluster sizes h


def flux_feature(flux: np.ndarray, weights: np.ndarray, region: np.ndarray, n_clusters: int, kind: str):
    """Feature coordinate and allocation densities that make the clusters follow an absorbed-flux map.

    Thesis §6.3: with the super-face solar scheme each cluster's absorbed power is spread uniformly over it, so
    "shadowing and concentration effects are inherently lost" where a cluster straddles a shadow line or a
    reflected spot, and regions "where abrupt changes of the external heat fluxes are expected" are the ones to
    refine.  Two things follow from a flux map ``q`` (a cheap, noisy solar pre-pass is enough):

    * the element centroids get a fourth coordinate ``s = c · h · q / σ`` (m), with ``h = (W/k)^(1/dim)`` the
      part's mean cluster size, σ the part's weighted flux deviation and c = :data:`FLUX_CONTRAST`; k-means,
      region growing and boundary smoothing then measure distances in (x, y, z, s), so a cluster boundary is
      drawn along a shadow line rather than across it (clusters stay contiguous: growing is on the mesh graph);
    * region r gets the allocation density ``1 + σ_r/σ`` (σ_r its own flux deviation), see :mod:`.allocate`.

    ``flux`` (m,) W/m², ``weights`` (m,) area/volume, ``region`` (m,) region ids.  Returns ``(s (m,) m,
    density (r,))`` or None when the flux is uniform (nothing to follow).
    """
    r = int(region.max()) + 1
    W = weights.sum()
    mean = float(np.dot(weights, flux) / W)
    sigma = float(np.sqrt(np.dot(weights, (flux - mean) ** 2) / W))
    if not sigma > 1e-9 * max(abs(mean), np.abs(flux).max(initial=0.0)):
        return None
    Wr = np.bincount(region, weights, minlength=r)
    mr = np.bincount(region, weights * flux, minlength=r) / Wr
    sr = np.sqrt(np.bincount(region, weights * (flux - mr[region]) ** 2, minlength=r) / Wr)
    h = (W / n_clusters) ** (1.0 / (2 if kind == "shell" else 3))
    return FLUX_CONTRAST * h * (flux - mean) / sigma, 1.0 + sr / sigma


def _prepare(points: np.ndarray, part: PartInput, weights: np.ndarray | None, feature_angle: float,
             balance: bool = True) -> _Prepared:
    times = dict.fromkeys(_STEPS, 0.0)
    t0 = time.perf_counter()
    measure, normals, centroids = _geometry(points, part)
    m = len(measure)
    if weights is None:
        weights = measure
    else:
        weights = np.asarray(weights, float)
        if weights.shape != (m,) or not np.isfinite(weights).all() or (weights <= 0).any():
            raise Fem2TmmError(f"part {part.name!r}: weights must be {m} finite positive numbers, one per element")
    t1 = time.perf_counter()
    graph = dual_graph(points, part.cells, part.types, part.kind)
    # more disconnected pieces than super nodes: the largest pieces keep the part's super nodes, the others join
    # the clusters they touch (contact.join_units) instead of being refused
    n_pieces, piece = connected_components(sp.csr_matrix((np.ones(len(graph.a), np.int8), (graph.a, graph.b)),
                                                         shape=(m, m)), directed=False)
    if n_pieces > part.n_clusters:
        size = np.bincount(piece, measure, minlength=n_pieces)
        order = np.lexsort((np.arange(n_pieces), -size))
        mine = np.isin(piece, order[: part.n_clusters])
        deferred = tuple(part.elements[piece == q] for q in np.sort(order[part.n_clusters:]))
        sub = _subset(part, np.flatnonzero(mine))
        pr = _prepare(points, sub, None if weights is None else np.asarray(weights)[mine], feature_angle, balance)
        return replace(pr, deferred=deferred)
    region, keep = split_regions(graph, m, part.kind, normals, part.attribute, feature_angle)
    # fewer super nodes than regions: merge regions (smallest first, across the strongest link) instead of refusing;
    # what cannot merge (disconnected pieces) is refused by allocate with the regions listed
    n_split = int(region.max()) + 1 if m else 0
    merges = []
    if part.n_clusters < n_split:
        region, keep, merges = merge_regions(graph, region, keep, measure, part.n_clusters)
    t2 = time.perf_counter()
    r = int(region.max()) + 1
    reg_measure = np.bincount(region, measure, minlength=r)
    inner = np.bincount(region[graph.a[keep]], graph.measure[keep], minlength=r)
    boundary = np.bincount(region, graph.side_total, minlength=r) - 2 * inner
    reg_weight = np.bincount(region, weights, minlength=r)
    feature = None if part.flux is None else flux_feature(np.asarray(part.flux, float), weights, region,
                                                          part.n_clusters, part.kind)
    if feature is not None:
        feature, density = feature
        centroids = np.hstack([centroids, feature[:, None]])
        reg_weight = reg_weight * density
    alloc = allocate(part.n_clusters, part.kind, reg_measure, np.maximum(boundary, 0),
                     np.bincount(region, minlength=r), reg_weight, part=part.name,
                     shape=feature is None and not balance)
    t3 = time.perf_counter()
    times.update(geometry=t1 - t0, regions=t2 - t1, allocation=t3 - t2)
    return _Prepared(part, weights, measure, centroids, graph, keep, region, alloc, times,
                     merged={"regions_before": n_split, "merges": merges} if merges else None)


def _subset(part: PartInput, rows: np.ndarray, kind: str | None = None, n_clusters: int | None = None
            ) -> PartInput:
    """The part restricted to its elements ``rows`` (local indices)."""
    pick = lambda a: None if a is None else np.asarray(a)[rows]  # noqa: E731
    return PartInput(part.name, kind or part.kind, part.elements[rows], part.cells[rows], part.types[rows],
                     part.n_clusters if n_clusters is None else n_clusters, pick(part.attribute), pick(part.ids),
                     pick(part.flux), pick(part.dofs))


def _split_count(n: int, free: dict) -> dict:
    """Share ``n`` super nodes among kinds with ``free[kind]`` elements to cluster: in proportion to the counts,
    at least one per kind while ``n`` allows (the kinds with the most elements first), largest remainders."""
    kinds = sorted((k for k in free if free[k] > 0), key=lambda k: (-free[k], RANK[k]))
    out = dict.fromkeys(free, 0)
    if not kinds:
        return out
    if n <= len(kinds):
        for k in kinds[:n]:
            out[k] = 1
        return out
    c = np.array([free[k] for k in kinds], float)
    q = 1 + (n - len(kinds)) * c / c.sum()
    base = np.floor(q).astype(int)
    rest = n - int(base.sum())
    base[np.argsort(-(q - base), kind="stable")[:rest]] += 1
    for k, v in zip(kinds, base):
        out[k] = int(v)
    return out


METHODS = ("growing", "metis")
BALANCE_TOL = 0.05  # clusters of a region within ±5 % of their mean weight where growing and smoothing allow


def _cluster_region(ptr, ind, lengths, X, w, k, seed, smoothing_layers, times, balance=True,
                    method="growing"):
    """Labels 0..k-1 of one connected region and the smoothing statistics.

    ``method="metis"``: METIS k-way instead of seeds + growing + smoothing (:mod:`.metis`; its time is
    reported under "growing").

    ``balance``: grow clusters of equal weight (:func:`.growing.grow_balanced`); off when the clusters
    follow a flux feature (their sizes are then meant to differ)."""
    n = len(X)
    if k == 1:
        return np.zeros(n, np.int64), None
    if k == n:
        return np.arange(n, dtype=np.int64), None
    t0 = time.perf_counter()
    if method == "metis":
        labels = metis_region(ptr, ind, lengths, X, w, k, seed=int(np.sum(seed)))
        times["growing"] += time.perf_counter() - t0
        return labels, None
    # balanced growing evens the weights out itself (boundary moves): one k-means++ start and a few Lloyd
    # iterations are enough (measurements: docs/design-notes.md, cluster/driver.py)
    kw = dict(n_init=1, max_iter=10) if balance else {}
    seeds = seed_elements(X, weighted_kmeans(X, w, k, seed=seed, **kw))
    t1 = time.perf_counter()
    if balance:
        labels, seeds, _ = grow_balanced(ptr, ind, X, w, seeds, lengths=lengths, tol=BALANCE_TOL / 2)
    else:
        labels = grow(ptr, ind, X, seeds)
    t2 = time.perf_counter()
    labels, stats = smooth(ptr, ind, lengths, labels, X, w, seeds, layers=smoothing_layers,
                           balance_tol=BALANCE_TOL if balance else None)
    t3 = time.perf_counter()
    times["seeding"] += t1 - t0
    times["growing"] += t2 - t1
    times["smoothing"] += t3 - t2
    return labels, stats


def _part_report(prep: _Prepared, labels: np.ndarray, k_offset: int, smoothing: list[dict]) -> dict:
    part, g = prep.part, prep.graph
    k = part.n_clusters
    local = labels - k_offset
    cm = np.bincount(local, prep.measure, minlength=k)
    same = prep.keep & (local[g.a] == local[g.b])
    m = len(local)
    n_comp = connected_components(
        sp.csr_matrix((np.ones(int(same.sum()), np.int8), (g.a[same], g.b[same])), shape=(m, m)), directed=False
    )[0]
    # boundary between clusters inside regions (region borders are fixed and not counted)
    after = float(g.measure[prep.keep & ~same].sum())
    before = after + sum(s["boundary_before"] - s["boundary_after"] for s in smoothing)
    sm = {key: int(sum(s[key] for s in smoothing))
          for key in ("pairs", "accepted", "rejected_longer", "rejected_disconnected", "rejected_unbalanced",
                          "moved")}
    return {
        "name": part.name,
        "kind": part.kind,
        "elements": int(m),
        "clusters": int(k),
        "regions": int(len(prep.alloc)),
        **({} if prep.merged is None else {"regions_merged": {
            "regions_before": prep.merged["regions_before"], "merges": len(prep.merged["merges"]),
            "smallest_first": prep.merged["merges"][:20]}}),
        "junctions": int(g.n_junctions),
        "measure": float(prep.measure.sum()),
        "measure_unit": _MEASURE_UNIT[part.kind],
        "cluster_measure_cv": float(cm.std() / cm.mean()) if k > 1 else 0.0,
        "cluster_measure_min": float(cm.min()),
        "cluster_measure_max": float(cm.max()),
        "contiguous": bool(n_comp == k and (np.bincount(local, minlength=k) > 0).all()),
        "boundary_before": before,
        "boundary_after": after,
        "boundary_unit": _BOUNDARY_UNIT[part.kind],
        "smoothing": sm,
        "time_s": {s: round(v, 6) for s, v in prep.times.items()},
    }


def _total_report(parts: list[dict]) -> dict:
    tot = {
        "parts": len(parts),
        "elements": sum(p["elements"] for p in parts),
        "clusters": sum(p["clusters"] for p in parts),
        "regions": sum(p["regions"] for p in parts),
        "contiguous": all(p["contiguous"] for p in parts),
        "time_s": {s: round(sum(p["time_s"][s] for p in parts), 6) for s in _STEPS},
    }
    for kind, key in (("shell", "boundary_length_m"), ("solid", "boundary_area_m2")):
        sel = [p for p in parts if p["kind"] == kind]
        if sel:
            tot[key] = {"before": sum(p["boundary_before"] for p in sel),
                        "after": sum(p["boundary_after"] for p in sel)}
    tot["time_s"]["total"] = round(sum(tot["time_s"].values()), 6)
    return tot


def _run(points, parts: Sequence[PartInput], n_elements: int, weights: Sequence[np.ndarray | None],
         feature_angle: float, seed: int, smoothing_layers: int,
         progress: Callable[[int, int], None] | None, balance: bool = True,
         method: str = "growing", one_node: np.ndarray | None = None) -> Clustering:
    if method not in METHODS:
        raise Fem2TmmError(f"clustering method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "metis":
        require_metis()
    points = np.asarray(points, float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise Fem2TmmError(f"points must be an (n, 3) array, got shape {points.shape}")
    if not (0.0 < feature_angle <= 180.0):
        raise Fem2TmmError(f"feature_angle must be in (0, 180] degrees, got {feature_angle}")
    if int(smoothing_layers) < 0:
        raise Fem2TmmError(f"smoothing_layers must be >= 0, got {smoothing_layers}")
    parts = [PartInput(p.name, p.kind, np.asarray(p.elements, np.int64), np.asarray(p.cells, np.int64),
                       np.asarray(p.types, np.int8), p.n_clusters, p.attribute, p.ids, p.flux,
                       None if p.dofs is None else np.asarray(p.dofs, np.int64)) for p in parts]
    for p in parts:
        _check_part(points, p, n_elements)
    all_elements = np.concatenate([p.elements for p in parts]) if parts else np.zeros(0, np.int64)  # the rows
    owner = np.bincount(all_elements, minlength=n_elements) if parts else None
    if owner is not None and (owner > 1).any():
        raise Fem2TmmError(f"elements {format_ids(np.flatnonzero(owner > 1))} belong to more than one part")
    if len({p.dofs is None for p in parts}) > 1:
        raise Fem2TmmError("dofs: give the unknowns of every part or of none")

    # contact across parts and kinds (.contact): rows = the parts' elements concatenated in part order
    start = np.concatenate([[0], np.cumsum([len(p.elements) for p in parts])]).astype(np.int64)
    n_rows = int(start[-1])
    cells_all = np.concatenate([p.cells for p in parts]) if parts else np.zeros((0, 8), np.int64)
    dofs_all = cells_all if not parts or parts[0].dofs is None else np.concatenate([p.dofs for p in parts])
    n_space = len(points) if one_node is None else len(one_node)
    if one_node is not None and dofs_all.size and dofs_all.max() >= n_space:
        raise Fem2TmmError(f"dofs refer to unknowns beyond the {n_space} of one_node")
    rank = element_rank(np.concatenate([p.types for p in parts])) if parts else np.zeros(0, np.int8)
    emb = embedded(dofs_all, rank, n_space, one_node)
    row_part = np.repeat(np.arange(len(parts)), np.diff(start))
    unit = np.full(n_rows, -1, np.int64)
    n_units = 0
    joined = {}

    def defer(rows: np.ndarray, whole: bool) -> None:  # rows: global row numbers; one unit, or one per row
        nonlocal n_units
        if not len(rows):
            return
        unit[rows] = n_units if whole else n_units + np.arange(len(rows))
        n_units += 1 if whole else len(rows)

    subs = []  # (part index, the part's elements of one kind not embedded, their weights, their rows)
    for pi, (p, w) in enumerate(zip(parts, weights)):
        rows = np.arange(start[pi], start[pi + 1])
        free = ~emb[rows]
        kinds = [kind_of_rank(r) for r in unique(rank[rows])]
        counts = _split_count(p.n_clusters, {k: int(np.count_nonzero(free & (rank[rows] == RANK[k])))
                                             for k in kinds})
        defer(rows[~free], whole=False)  # embedded elements join, one by one, the cluster holding their nodes
        n_emb = int(np.count_nonzero(~free))
        joined[p.name] = {"embedded": n_emb, "pieces": 0, "elements": n_emb}
        for k in kinds:
            local = np.flatnonzero(free & (rank[rows] == RANK[k]))
            if not len(local):
                continue
            sub = _subset(p, local, kind=k, n_clusters=min(counts[k], len(local)) or 1)
            if k == "line":
                sub = replace(sub, flux=None)
            sw = None if w is None else np.asarray(w)[local]
            if counts[k] == 0:  # the part's count went to its other kinds: its pieces join them
                g = dual_graph(points, sub.cells, sub.types, k)
                n_pc, pc = connected_components(sp.csr_matrix((np.ones(len(g.a), np.int8), (g.a, g.b)),
                                                              shape=(len(local),) * 2), directed=False)
                for q in range(n_pc):
                    defer(start[pi] + local[pc == q], whole=True)
                joined[p.name]["pieces"] += n_pc
                joined[p.name]["elements"] += len(local)
                continue
            subs.append((pi, sub, sw, start[pi] + local))

    prepared = [_prepare(points, sub, w, feature_angle, balance) for _, sub, w, _ in subs]
    row_of = np.full(n_elements, -1, np.int64)
    row_of[all_elements] = np.arange(n_rows)
    for (pi, _, _, _), pr in zip(subs, prepared):
        for piece in pr.deferred:
            defer(row_of[piece], whole=True)
            joined[parts[pi].name]["pieces"] += 1
            joined[parts[pi].name]["elements"] += len(piece)
    if n_units and not prepared:
        raise Fem2TmmError("every element lies on the nodes of another kind or part: nothing to cluster (give the "
                           "parts' host elements, e.g. the panels the bars stiffen, a part of their own)")

    labels = np.full(n_elements, -1, np.int64)
    region_out = np.full(n_elements, -1, np.int64)
    cluster_part, cluster_region, reports = [], [], []
    n_regions_total = sum(len(pr.alloc) for pr in prepared)
    done, k_off, r_off = 0, 0, 0
    for (pi, _, _, _), pr in zip(subs, prepared):
        part, g = pr.part, pr.graph
        m = len(pr.region)
        G = to_csr(m, g.a[pr.keep], g.b[pr.keep], g.measure[pr.keep])
        order = np.argsort(pr.region, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(np.bincount(pr.region))])
        scratch = np.full(m, -1, np.int64)
        local = np.empty(m, np.int64)
        smoothing = []
        k_reg = 0
        for r, k in enumerate(pr.alloc.tolist()):
            el = order[bounds[r]:bounds[r + 1]]
            ptr, ind, lengths = induced_csr(G.indptr, G.indices, G.data, el, scratch)
            lab, stats = _cluster_region(ptr, ind, lengths, pr.centroids[el], pr.weights[el], k,
                                         (int(seed), r), 0 if part.kind == "line" else int(smoothing_layers),
                                         pr.times, balance=balance and pr.centroids.shape[1] == 3,
                                         method=method)
            local[el] = lab + k_reg
            if stats is not None:
                smoothing.append(stats)
            cluster_region.extend([r_off + r] * k)
            k_reg += k
            done += 1
            if progress is not None:
                progress(done, n_regions_total)
        labels[part.elements] = local + k_off
        region_out[part.elements] = pr.region + r_off
        cluster_part.extend([pi] * part.n_clusters)
        rep = _part_report(pr, labels[part.elements], k_off, smoothing)
        if parts[pi].kind == "mixed" or parts[pi].n_clusters != part.n_clusters:  # shared among kinds, or capped
            rep["requested"] = int(parts[pi].n_clusters)
        reports.append(rep)
        k_off += part.n_clusters
        r_off += len(pr.alloc)
    cluster_part = np.asarray(cluster_part, np.int64)
    report = {"parts": reports, "total": _total_report(reports)}
    if n_units:
        lab_rows = labels[all_elements]
        pts = points[np.maximum(cells_all, 0)]
        valid = (cells_all >= 0)[:, :, None]
        centroid = (pts * valid).sum(1) / valid.sum(1)
        unit_part = np.zeros(n_units, np.int64)
        unit_part[unit[unit >= 0]] = row_part[unit >= 0]
        lab_rows, jstats = join_units(lab_rows, unit, unit_part, cluster_part, dofs_all, centroid, n_space,
                                      one_node)
        if jstats["unanchored"]:
            lost = np.asarray(jstats.pop("unanchored"))
            pi = int(unit_part[lost[0]])
            mine = lost[unit_part[lost] == pi]
            p = parts[pi]
            els = [np.flatnonzero(unit[start[pi]:start[pi + 1]] == u) for u in mine[:5]]
            have = sum(1 for c in cluster_part if c == pi)
            raise Fem2TmmError(
                f"part {p.name!r}: {len(mine)} disconnected piece(s) touch no node of another part or kind and hold "
                f"no fixed or kept node, so they cannot share a super node with the rest of the part: "
                + "; ".join(f"piece of {len(e)} element(s) ({_ids(p, e)})" for e in els)
                + f".  Ask for at least {have + len(mine)} super nodes (`fem2tmm inspect`: min), or connect the "
                "pieces (a joint)")
        jstats.pop("unanchored")
        in_units = unit >= 0
        labels[all_elements[in_units]] = lab_rows[in_units]
        region_out[all_elements[in_units]] = np.asarray(cluster_region, np.int64)[lab_rows[in_units]]
        report["joined"] = {"parts": {k: v for k, v in joined.items() if v["elements"]}, **jstats,
                            "elements": int(in_units.sum())}
        report["total"]["joined_elements"] = int(in_units.sum())
    return Clustering(labels=labels, regions=region_out, cluster_part=cluster_part,
                      cluster_region=np.asarray(cluster_region, np.int64), report=report)


def cluster_parts(points: np.ndarray, parts: Sequence[PartInput], n_elements: int, feature_angle: float = 30.0,
                  seed: int = 0, smoothing_layers: int = 2,
                  progress: Callable[[int, int], None] | None = None, balance: bool = True,
                  method: str = "growing", weights: Sequence[np.ndarray | None] | None = None,
                  one_node: np.ndarray | None = None) -> Clustering:
    """Cluster every part of a mesh into its requested number of contiguous clusters (super nodes).

    Elements lying on the nodes of another kind (bars along panel edges) and pieces beyond a part's count join
    the clusters they touch (:mod:`.contact`; ``report["joined"]``).  Each part is split into regions
    (:mod:`.regions`), its super nodes are shared among them
    (:mod:`.allocate`), and each region is clustered on its own: weighted k-means seeds (:mod:`.seeding`),
    greedy region growing (:mod:`.growing`), min-cut boundary smoothing (:mod:`.smoothing`).  Element
    weights are areas (shells, m²) and volumes (solids, m³).

    Parameters
    ----------
    points : (n, 3) float, node coordinates in m
    parts : the parts, see :class:`PartInput`; an element may belong to at most one part
    n_elements : number of elements of the whole mesh (size of the returned arrays)
    feature_angle : degrees; shell edges where the surfaces meet at a larger angle cut regions
    seed : random seed; the same input and seed give identical labels
    smoothing_layers : band depth of the boundary smoothing on each side (0 disables smoothing)
    progress : optional ``progress(n_done, n_total)``, called after each region
    balance : True (default): clusters of equal area (volume, or weight): the part's super nodes are shared
        among its regions in proportion to area, the growing is capacity-constrained
        (:func:`.growing.grow_balanced`) and smoothing keeps the balance; False: the thesis' scheme (regions
        get clusters for their characteristic length too, plain growing).  Clusters that follow a flux
        feature are never balanced (their sizes follow the flux on purpose)
    method : "growing" (default: k-means seeds, region growing, min-cut smoothing) or "metis" (METIS k-way on
        each region, contiguous, through the optional package pymetis; see :mod:`.metis`)
    weights : one (m,) array of positive element weights per part (or None: area/volume), in the part's element
        order; they replace area/volume in the allocation among regions and in the balance of the clusters (e.g.
        :func:`fem2tmm.reduce.biot.biot_weights`)
    one_node : (n,) bool or None; unknowns (the parts' ``dofs``, or mesh nodes) that are one-node super nodes
        (fixed temperature, kept): a bar whose nodes are all such nodes or shell/solid nodes is embedded

    Returns
    -------
    :class:`Clustering`

    Raises
    ------
    Fem2TmmError
        bad shapes or types, degenerate elements, a part asking for more super nodes than it has elements.
    """
    weights = [None] * len(parts) if weights is None else list(weights)
    if len(weights) != len(parts):
        raise Fem2TmmError(f"weights: one entry per part ({len(parts)}), got {len(weights)}")
    return _run(points, parts, int(n_elements), weights, feature_angle, seed, smoothing_layers,
                progress, balance, method, one_node)


def partition(points: np.ndarray, cells: np.ndarray, n_clusters: int, kind: str = "shell",
              weights: np.ndarray | None = None, feature_angle: float = 30.0, seed: int = 0,
              return_regions: bool = False, balance: bool = True, method: str = "growing"):
    """Partition one mesh into ``n_clusters`` contiguous clusters (``fem2tmm.partition``, DESIGN §4.4).

    Parameters
    ----------
    points : (n, 3) float, node coordinates in m
    cells : (m, 3) tri3 or (m, 4) quad4 shells (``kind="shell"``); (m, 4) tet4, (m, 8) hex8 or (m, 6)
        wedge6 solids (``kind="solid"``); VTK/Nastran node order
    n_clusters : number of clusters, shared among the regions of the mesh (see :mod:`.allocate`)
    kind : "shell" or "solid"
    weights : (m,) positive element weights for seeding and allocation (default: area m² / volume m³)
    feature_angle : degrees; shells are cut into regions at sharper edges (and at junctions)
    seed : random seed
    return_regions : also return the region of each element
    balance : equal-weight clusters (default) or the thesis' scheme, see :func:`cluster_parts`
    method : "growing" (default) or "metis", see :func:`cluster_parts`

    Returns
    -------
    labels : (m,) int64 in 0..n_clusters-1; every cluster non-empty and contiguous (edge-adjacent for
        shells, face-adjacent for solids)
    regions : (m,) int64, only with ``return_regions=True``

    Raises
    ------
    Fem2TmmError
        Unknown ``kind``, ``cells`` not a 2-D integer array of a supported width, or weights that are not
        one finite positive number per element.
    """
    cells = np.asarray(cells)
    if kind not in _KIND_TYPES:
        raise Fem2TmmError(f"kind must be 'shell' or 'solid', got {kind!r}")
    if cells.ndim != 2 or not np.issubdtype(cells.dtype, np.integer):
        raise Fem2TmmError(f"cells must be a 2-D integer array, got shape {cells.shape} and dtype {cells.dtype}")
    by_width = {N_NODES[t]: t for t in _KIND_TYPES[kind]}
    if cells.shape[1] not in by_width:
        widths = ", ".join(f"{w} ({t})" for w, t in by_width.items())
        raise Fem2TmmError(f"{kind} cells must have {widths} nodes per element, got {cells.shape[1]}")
    m = len(cells)
    padded = np.full((m, 8), -1, np.int64)
    padded[:, : cells.shape[1]] = cells
    part = PartInput(name="mesh", kind=kind, elements=np.arange(m, dtype=np.int64), cells=padded,
                     types=np.full(m, TYPE_CODE[by_width[cells.shape[1]]], np.int8), n_clusters=n_clusters)
    res = _run(points, [part], m, [weights], feature_angle, seed, 2, None, balance, method)
    return (res.labels, res.regions) if return_regions else res.labels


def from_labels(points: np.ndarray, parts: Sequence[PartInput], n_elements: int, labels: np.ndarray,
                feature_angle: float = 30.0, where: str = "labels") -> Clustering:
    """A :class:`Clustering` from a user partition (the ``labels=`` route of :func:`fem2tmm.run`).

    Parameters
    ----------
    points : (n, 3) float node coordinates, m
    parts : the parts to cluster (their ``n_clusters`` is ignored: the labels decide)
    n_elements : number of elements of the mesh
    labels : (n_elements,) int cluster of every mesh element; elements of the parts need a label >= 0, the
        labels used by the parts must be exactly 0 … K−1 and each must stay within one part; other elements
        are ignored
    feature_angle : degrees; regions are still computed (report, quadric fitting)
    where : what to call the labels in messages

    Returns
    -------
    :class:`Clustering` with the given clusters, numbered as given.  A cluster that is not connected through
    shared edges (faces), or that crosses a sharp edge or junction, is allowed (the reduction stays exact) but
    reported and warned about.

    Raises
    ------
    Fem2TmmError
        wrong length or type, elements of a part without a label, unused label numbers, a label in two parts.
    """
    labels = np.asarray(labels)
    if labels.shape != (n_elements,) or not np.issubdtype(labels.dtype, np.integer):
        raise Fem2TmmError(f"{where}: expected {n_elements} integer cluster labels, one per mesh element "
                           f"(-1 for elements outside the parts), got shape {labels.shape} and dtype {labels.dtype}")
    labels = labels.astype(np.int64)
    points = np.asarray(points, float)
    # n_clusters = the element count: only so that the regions' allocation (unused here) is always defined
    parts = [PartInput(p.name, p.kind, np.asarray(p.elements, np.int64), np.asarray(p.cells, np.int64),
                       np.asarray(p.types, np.int8), len(p.elements), p.attribute, p.ids, None) for p in parts]
    for p in parts:
        _check_part(points, p, n_elements)
        bad = labels[p.elements] < 0
        if bad.any():
            raise Fem2TmmError(f"{where}: part {p.name!r} has elements without a cluster label (-1): "
                               f"{_ids(p, np.flatnonzero(bad))}; give every element of the parts a label >= 0")
    used = np.concatenate([labels[p.elements] for p in parts]) if parts else np.zeros(0, np.int64)
    k = int(used.max()) + 1 if used.size else 0
    missing = np.setdiff1d(np.arange(k), used)
    if missing.size:
        raise Fem2TmmError(f"{where}: labels must be 0 … K-1 with every number used; {format_ids(missing)} are not "
                           "used by any element of the parts (renumber them consecutively)")
    part_of = np.full(k, -1, np.int64)
    for pi, p in enumerate(parts):
        lab = unique(labels[p.elements])
        clash = lab[part_of[lab] >= 0]
        if clash.size:
            raise Fem2TmmError(f"{where}: clusters {format_ids(clash)} span part {p.name!r} and another part; a "
                               "super node belongs to one part")
        part_of[lab] = pi
    region_out = np.full(n_elements, -1, np.int64)
    cluster_region = np.zeros(k, np.int64)
    reports, r_off = [], 0
    for pi, p in enumerate(parts):
        prep = _prepare(points, p, None, feature_angle, balance=False) if len(p.elements) else None
        local = labels[p.elements]
        region_out[p.elements] = prep.region + r_off
        cluster_region[local] = prep.region + r_off  # (one of) the region(s) each cluster covers
        offset = int(local.min())
        lab_p = unique(local)
        renum = np.searchsorted(lab_p, local)
        part = PartInput(p.name, p.kind, p.elements, p.cells, p.types, int(lab_p.size), p.attribute, p.ids)
        prep = _Prepared(part, prep.weights, prep.measure, prep.centroids, prep.graph, prep.keep, prep.region,
                         prep.alloc, prep.times)
        rep = _part_report(prep, renum, 0, [])
        # contiguity through every shared edge (face), not only inside regions, and region crossings
        g = prep.graph
        same = renum[g.a] == renum[g.b]
        m = len(renum)
        n_comp = connected_components(sp.csr_matrix((np.ones(int(same.sum()), np.int8), (g.a[same], g.b[same])),
                                                    shape=(m, m)), directed=False)[0]
        n_reg = int(prep.region.max()) + 1
        spans = np.bincount(unique(renum * n_reg + prep.region) // n_reg, minlength=lab_p.size)
        crossing = int(np.count_nonzero(spans > 1))
        rep.update(contiguous=bool(n_comp == lab_p.size), clusters_crossing_regions=crossing, user_labels=True,
                   first_label=offset)
        if n_comp != lab_p.size:
            warnings.warn(f"{where}: part {p.name!r}: {n_comp - lab_p.size} cluster piece(s) not connected to the "
                          "rest of their cluster; the reduction stays exact, but such super nodes are not compact",
                          stacklevel=2)
        reports.append(rep)
        r_off += int(prep.region.max()) + 1
    report = {"parts": reports, "total": _total_report(reports), "source": where}
    return Clustering(labels=np.where(np.isin(np.arange(n_elements), np.concatenate([p.elements for p in parts])),
                                      labels, -1) if parts else np.full(n_elements, -1, np.int64),
                      regions=region_out, cluster_part=part_of, cluster_region=cluster_region, report=report)
