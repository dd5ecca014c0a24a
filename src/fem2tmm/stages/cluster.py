"""The clustering stage: the case's parts, joints and super-node counts to :func:`~fem2tmm.cluster.cluster_parts`'s
inputs, its cache key, and the pre-solve of ``[clustering] allocation = "biot"``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..arrays import unique
from ..cache import digest
from ..case import Case
from ..cluster import Clustering, PartInput, cluster_parts, from_labels
from ..cluster.contact import join_dependent
from ..errors import Fem2TmmError
from ..fem.model import FEModel, boundary_nodes
from ..reduce.network import determined_elements, kept_dofs
from ..solve.problems import detailed_problem
from ..solve.steady import solve_steady


# ------------------------------------------------------------------------------------------- clustering
def cluster_model(model: FEModel, case: Case, progress=None, flux: np.ndarray | None = None,
                  labels: np.ndarray | None = None, weights: np.ndarray | None = None,
                  weights_report: dict | None = None, marks: np.ndarray | None = None) -> Clustering:
    """Cluster every part of ``model`` with its requested number of super nodes.

    ``labels`` (n_elements,) int: a user partition instead (:func:`fem2tmm.cluster.from_labels`; the parts'
    ``super_nodes`` are then ignored).
    Elements fully determined by fixed-temperature nodes (e.g. a face held at a temperature) are not
    clustered: every requested super node goes to elements with unknowns.  They get the label -1.
    ``flux`` (n_elements,) absorbed flux (W/m², e.g. :func:`solar_prepass`) the clusters should follow, or None.
    ``weights`` (m,) clustering weight of each model element (m²; NaN: the part keeps area/volume weights), e.g.
    :func:`biot_weights`; its ``weights_report`` goes into the clustering report as ``allocation``.
    ``marks`` (m,) int per model element, or None: no cluster holds elements of two marks (:func:`load_weights`).
    """
    args, kw = _cluster_inputs(model, case, flux, check_counts=labels is None, weights=weights, marks=marks)
    if labels is not None:
        return from_labels(*args, labels, feature_angle=kw["feature_angle"], where="run(labels=...)")
    index = kw.pop("part_index")
    clustering = cluster_parts(*args, **kw, progress=progress)
    clustering = _independent(model, clustering, kw["one_node"], index)
    clustering.report["allocation"] = {"method": case.clustering.allocation, **(weights_report or {})}
    return clustering


def _independent(model: FEModel, clustering: Clustering, one_node: np.ndarray, index: np.ndarray) -> Clustering:
    """Model part indices for the clusters, and clusters whose super-node rows would repeat others' merged into
    their best-connected neighbour (:func:`fem2tmm.cluster.contact.join_dependent`; the report's
    ``merged_dependent``), so that the reduction never meets linearly dependent super nodes."""
    cluster_part = index[clustering.cluster_part]
    rows = np.flatnonzero(clustering.labels[model.elements] >= 0)
    shares = model.capacity_shares if model.capacity_shares is not None else model.volume_shares
    lab, kept, merges = join_dependent(clustering.labels[model.elements[rows]], cluster_part,
                                       model.element_dofs[rows], shares[rows], one_node)
    report = clustering.report
    if not merges:
        return dataclasses.replace(clustering, cluster_part=cluster_part)
    labels = clustering.labels.copy()
    labels[model.elements[rows]] = lab
    report["merged_dependent"] = [{"cluster": int(a), "into": int(b), "part": model.parts[int(cluster_part[a])].name,
                                   "into_part": model.parts[int(cluster_part[b])].name} for a, b in merges]
    return dataclasses.replace(clustering, labels=labels, cluster_part=cluster_part[kept],
                               cluster_region=clustering.cluster_region[kept], report=report)


def _cluster_inputs(model: FEModel, case: Case, flux: np.ndarray | None, check_counts: bool = True,
                    weights: np.ndarray | None = None, marks: np.ndarray | None = None) -> tuple[tuple, dict]:
    """The arguments of :func:`~fem2tmm.cluster.cluster_parts` for ``model`` (what the clustering depends on);
    ``check_counts``: refuse impossible super-node counts first (:func:`_check_count`); ``marks`` (m,) int: cut the
    parts into regions where the mark changes, as where the element attribute does."""
    attribute = model.element_attribute
    if marks is not None and len(marks):
        attribute = attribute * (int(marks.max()) + 1) + marks
    kept = kept_dofs(model, case)
    determined = determined_elements(model, kept)
    one_node = np.zeros(model.n_dof, bool)  # DOFs that are super nodes of their own (fixed groups, kept nodes)
    one_node[[g.dof for g in model.fixed]] = True
    one_node[kept] = True
    parts, part_weights, index = [], [], []
    for p, info in enumerate(model.parts):
        rows = np.flatnonzero((model.element_part == p) & ~determined)
        if not len(rows):
            continue  # the whole part is held at fixed temperatures
        if check_counts:
            _check_count(case, info, model.element_dofs[rows], one_node)
        w = None if weights is None else weights[rows]
        part_weights.append(w if w is not None and np.isfinite(w).all() else None)
        index.append(p)
        parts.append(PartInput(name=info.name, kind=info.kind, elements=model.elements[rows],
                               cells=model.element_cells[rows], types=model.element_types[rows],
                               n_clusters=info.super_nodes, attribute=attribute[rows],
                               ids=model.mesh.element_ids[model.elements[rows]],
                               flux=None if (flux is None or info.kind == "line")
                               else np.nan_to_num(flux[model.elements[rows]]),
                               dofs=model.element_dofs[rows]))
    cs = case.clustering
    kw = {"feature_angle": cs.feature_angle, "seed": cs.seed, "smoothing_layers": cs.smoothing_layers,
          "balance": cs.balance, "method": cs.method, "one_node": one_node,
          "part_index": np.asarray(index, np.int64)}
    if any(w is not None for w in part_weights):
        kw["weights"] = part_weights
    return (model.mesh.points, parts, model.mesh.n_elements), kw


def check_super_node_counts(model: FEModel, case: Case) -> None:
    """Refuse super-node counts that cannot give independent super nodes (:func:`_check_count`), e.g. before a
    pre-solve that precedes the clustering."""
    _cluster_inputs(model, case, None, check_counts=True)


def _check_count(case: Case, info, element_dofs: np.ndarray, one_node: np.ndarray) -> None:
    """Refuse, before clustering, a super-node count that cannot give independent super nodes: the part's
    clusters and the one-node super nodes among its DOFs all average over the part's DOFs, so more of them than
    DOFs are linearly dependent."""
    dofs = unique(element_dofs[element_dofs >= 0])
    free = int(np.count_nonzero(~one_node[dofs]))
    if info.super_nodes > free:
        raise Fem2TmmError(
            f"{case.source}: [[parts]] {info.name!r} asks for {info.super_nodes} super nodes, but its elements have "
            f"only {free} nodes with an unknown temperature ({len(dofs)} nodes, a held group's nodes counted as one, "
            f"{len(dofs) - free} of them fixed or kept): more super nodes than that repeat each other's mean "
            f"temperature (linearly dependent).  Use at "
            f"most {free}; a useful reduction has far fewer (each super node should hold several elements)")


def cluster_key(model: FEModel, case: Case, flux: np.ndarray | None = None, labels: np.ndarray | None = None,
                weights: np.ndarray | None = None, marks: np.ndarray | None = None) -> str:
    """Key of :func:`cluster_model`: the points, every part's elements, cells, types, attributes (and ``marks``),
    flux and weights, the clustering settings and the user's ``labels``."""
    args, kw = _cluster_inputs(model, case, flux, check_counts=labels is None, weights=weights, marks=marks)
    return digest("cluster", *args, kw, labels)


def presolve_space(model: FEModel, case: Case) -> np.ndarray:
    """(n_dof,) K: the detailed steady field with every active side radiating to space only (no face-to-face
    exchange, no ray tracing) and the case's power loads — the cheap pre-solve of ``[clustering] allocation =
    "biot"``: sparse Newton on the FE mesh (one sparse LU per iteration), stopped at 0.1 K, since only T³ is used.
    It underestimates the temperatures of faces that see each other (their exchange is left out)."""
    return solve_steady(detailed_problem(model), tol=0.1, max_iter=case.solver.max_iterations).T


#: ``[clustering] allocation = "loads"``: how much more weight (so how much smaller the clusters) the elements near a
#: named power or flux load get.  Measured on the L-bracket of docs/studies.md at 300 super nodes: of 3, 6 and 9, 3 is
#: the one that left no edited state worse (heater 0 W RMS 1.03 K as with equal areas; 6 and 9 gave 1.15 and 1.17 K)
#: while the 40 W deck's maximum fell from 3.22 to 2.10 K and the stepped transient's from 10.1 to 6.2 K; at 100
#: super nodes it costs heater 0 W 1.56 → 2.0 K RMS for 40 W 17.7 → 2.3 K max
LOAD_DENSITY = 3.0
#: ``[clustering] allocation = "loads"`` acts on a load whose footprint covers at most this share of the shell area
#: of the parts it lies on: a concentrated load (the L-bracket's heater patch, 1.4 % of its part; examples/composite's,
#: 1.3 %: where it was measured to gain).  A load spread over its whole part sets up no field of its own inside the
#: part's clusters; weighting its reach only moved the neighbouring parts' clusters: over the robustness campaign
#: (2026-12-07, 519 models with the reference) the 21 records whose verified range came out worse with `loads` all
#: had a heater covering a whole part.  A heater on one face of a box (23 % of the part) is not a patch either: with
#: 0.25 the campaign's five such boxes moved, four within the noise and one worse at its design state (3e-10 ->
#: 0.009 K, its thesis' network then without a steady solution); with 0.1 every campaign record is as with `area`
LOAD_CONCENTRATED = 0.1


def load_weights(model: FEModel, case: Case) -> tuple[np.ndarray, dict, np.ndarray]:
    """Clustering weight per element for ``[clustering] allocation = "loads"``: smaller super nodes around the named
    power and flux loads, where the field a load sets up inside its clusters changes most when the engineer edits the
    load or steps it in time.

    A load's footprint is the elements of its groups (for a load on nodes: the elements that touch them); its reach
    ℓ is the footprint's equivalent radius √(A/π).  A shell element whose centroid lies within ℓ of a footprint
    element's centroid (the footprint included) weighs its area × :data:`LOAD_DENSITY`, the part's other shell
    elements their area; solids, bars, parts that mix shells with them and parts with no element within reach keep
    their own measure (NaN).  A load whose footprint covers more than :data:`LOAD_CONCENTRATED` of the shell area of
    the parts it lies on is not concentrated: it changes no weight (its report says so, ``"spread"``).  The elements
    within reach are also a region of their own (``marks`` 1, else 0): no cluster straddles the reach's edge, and the
    region gets its share of the part's super nodes by weight.  Measured on the L-bracket, the region matters: the
    same weights without it left cluster boundaries across the edge of the heavy region and the results erratic
    (docs/studies.md).  Each part keeps its number of super nodes.  O(m log m) (a KD-tree per load).

    Returns ``(weights (m,) m² or NaN, report {load: {"area_m2", "reach_m", "elements", "share"}}, marks (m,)
    int)``: ``share`` the footprint's share of its parts' shell area; ``elements`` 0 and ``"spread"`` True where the
    load is not concentrated.
    """
    from scipy.spatial import cKDTree

    mesh = model.mesh
    cells = model.element_cells
    m = len(model.elements)
    # the areas (NaN: not a shell) of the parts a load lies on, computed on first need: a model whose loads are all
    # spread costs the areas of their parts only (the default runs this on every model: 0.3 s for all 266 832 quads
    # of the pipeline_1m family, where its one load is spread)
    area, known = np.full(m, np.nan), np.zeros(m, bool)

    def areas(mask: np.ndarray) -> None:
        todo = mask & ~known
        if todo.any():
            area[todo] = mesh.element_areas(model.elements[todo])
            known[todo] = True

    centroid = None
    near = np.zeros(m, bool)
    report = {}
    for b in case.boundaries:
        if b.kind not in ("power", "flux"):
            continue
        # its footprint: its element groups, or (a power on nodes: the model refuses a load that mixes both) the
        # elements that touch its nodes
        groups = [mesh.groups[g].elements for g in b.groups if len(mesh.groups[g].elements)]
        if groups:
            rows = np.isin(model.elements, np.concatenate(groups))
        else:
            touched = np.zeros(mesh.n_nodes, bool)
            touched[boundary_nodes(mesh, case, b)] = True
            rows = np.any(np.where(cells >= 0, touched[np.maximum(cells, 0)], False), axis=1)
        if not rows.any():
            continue
        parts = np.isin(model.element_part, np.unique(model.element_part[rows]))
        areas(parts)
        rows &= np.isfinite(area)
        if not rows.any():
            continue
        a = float(area[rows].sum())
        reach = float(np.sqrt(a / np.pi))
        share = a / float(np.nansum(area[parts]))
        if share > LOAD_CONCENTRATED:
            report[b.name] = {"area_m2": a, "reach_m": reach, "elements": 0, "share": share, "spread": True}
            continue
        if centroid is None:  # a concentrated load: its reach is looked for over every shell element
            centroid = mesh.element_centroids(model.elements)
            areas(np.ones(m, bool))
        d, _ = cKDTree(centroid[rows]).query(centroid, distance_upper_bound=reach * (1.0 + 1e-9))
        within = np.isfinite(d) & np.isfinite(area)
        near |= within
        report[b.name] = {"area_m2": a, "reach_m": reach, "elements": int(within.sum()), "share": share}
    weights = np.full(m, np.nan)
    if near.any():
        shell = np.isfinite(area)
        for p in range(len(model.parts)):
            rows = np.flatnonzero((model.element_part == p) & shell)
            if len(rows) and near[rows].any():
                weights[rows] = area[rows] * np.where(near[rows], LOAD_DENSITY, 1.0)
    return weights, report, near.astype(np.int64)
