"""``fem2tmm inspect MESH``: what a user needs to know about a mesh before writing a case file.

:func:`inspect_mesh` returns a JSON-serialisable report; :func:`inspection_text` formats it.  For every group
(Nastran PID, Gmsh physical group): element types and counts, area / volume / length, thickness and where it
comes from, the number of regions the clustering splits it into at the default feature angle (the smallest
number of super nodes the group can take), and whether its shell normals are consistently oriented.  For the
whole mesh: its connected pieces (elements and joints together) and whether each touches a joint or a deck
SPC, and every card the reader modelled, ignored or refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .case import ClusteringSettings
from .cluster.adjacency import dual_graph
from .cluster.regions import merge_regions, regions as split_regions
from .errors import Fem2TmmError
from .fem.plausibility import extent_note
from .mesh import Mesh

_KIND = {1: "line", 2: "shell", 3: "solid"}


def _node_use(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """(n,) how many elements use each node, and (n,) bool nodes of a shell or solid element or a joint."""
    pc = mesh.padded_cells
    ok = pc >= 0
    use = np.bincount(pc[ok], minlength=mesh.n_nodes)
    host = np.zeros(mesh.n_nodes, bool)
    hi = pc[mesh.element_dims >= 2]
    host[hi[hi >= 0]] = True
    for j in mesh.joints:
        host[j.pairs.ravel()] = True
        use[j.pairs.ravel()] += 1
    return use, host


def _regions(mesh: Mesh, el: np.ndarray, kind: str, feature_angle: float, node_use,
             attribute: np.ndarray | None = None) -> dict:
    """Regions, pieces, the fewest super nodes and the first merges of the elements ``el`` of one kind (a group, or
    a part's elements of that kind with ``attribute`` their group: regions stop at a change, as in the clustering)."""
    use, host = node_use
    types = mesh.element_types[el]
    rep = {}
    cells = mesh.padded_cells[el]
    if len(el) > 1 or kind != "line":
        graph = dual_graph(mesh.points, cells, types, kind)
        normals = mesh.element_normals(el) if kind == "shell" else None
        region, keep = split_regions(graph, len(el), kind, normals, attribute, feature_angle)
        rep["regions"] = int(region.max()) + 1 if len(el) else 0
        # fewer super nodes merge regions, smallest first across the strongest link (cluster.regions.merge_regions);
        # pieces that touch another element or a joint by a node join the clusters they touch (cluster.contact):
        # only the pieces touching nothing else need a super node of their own
        meas = (mesh.element_areas(el) if kind == "shell" else mesh.element_volumes(elements=el) if kind == "solid"
                else mesh.element_lengths(el))
        merged, _, merges = merge_regions(graph, region, keep, np.nan_to_num(np.asarray(meas, float)), 1)
        own = np.bincount(cells[cells >= 0], minlength=mesh.n_nodes)
        touching = np.where(cells >= 0, (use > own)[np.maximum(cells, 0)], False).any(axis=1)
        n_pieces = int(merged.max()) + 1 if len(el) else 0
        alone = n_pieces - len(np.unique(merged[touching]))
        rep["pieces"] = n_pieces
        rep["fewest_super_nodes"] = max(1, alone) if len(el) else 0
        rep["merges_below_regions"] = [{"measure": m["measure"], "link": m["link"]} for m in merges[:10]]
        if kind == "shell":
            bad = int(np.count_nonzero(~graph.consistent))
            rep["normals"] = "consistent" if bad == 0 else f"inconsistent across {bad} edges"
    else:
        rep.update(regions=1, pieces=1, fewest_super_nodes=1, merges_below_regions=[])
    if kind == "line":  # bars on shell/solid nodes only: reduced with the elements they lie on (cluster.contact)
        rep["on_other_elements"] = int(np.count_nonzero(np.where(cells >= 0, host[np.maximum(cells, 0)],
                                                                 True).all(axis=1)))
    return rep


def _part_reports(mesh: Mesh, parts, feature_angle: float, node_use) -> list[dict]:
    """Per case part and element kind: its elements, regions, pieces, the fewest super nodes and the first merges,
    beside the count the case asks for.  ``parts``: (name, groups, super_nodes) of each ``[[parts]]`` entry."""
    out = []
    for name, groups, asked in parts:
        owner = np.full(mesh.n_elements, -1, np.int64)
        for gi, g in enumerate(groups):
            grp = mesh.group(g, where=f"[[parts]] {name!r}.groups")
            owner[grp.elements] = gi
        el = np.flatnonzero(owner >= 0)
        dims = mesh.element_dims[el]
        for d in np.unique(dims):
            sel = el[dims == d]
            kind = _KIND[int(d)]
            rep = {"part": name, "kind": kind, "elements": int(len(sel)), "super_nodes": int(asked),
                   "mixed": bool(len(np.unique(dims)) > 1)}
            rep.update(_regions(mesh, sel, kind, feature_angle, node_use, owner[sel]))
            out.append(rep)
    return out


def _group_report(mesh: Mesh, name: str, feature_angle: float, node_use=None) -> dict:
    g = mesh.groups[name]
    use, host = node_use if node_use is not None else _node_use(mesh)
    el = g.elements
    names = {}
    for t, c, _ in mesh.iter_blocks(el):
        names[t] = names.get(t, 0) + len(c)
    kind = _KIND[int(mesh.element_dims[el].max())]
    rep = {"group": name, "kind": kind, "elements": int(len(el)), "types": names}
    prop = mesh.properties.get(name)
    if kind == "shell":
        area = mesh.element_areas(el)
        rep["area_m2"] = float(np.nansum(area))
        t = None if prop is None else prop.thickness
        rep["thickness_m"] = t
        rep["thickness_source"] = (prop.card if (prop is not None and t is not None) else
                                   "none: the part's thickness")
        rep["volume_m3"] = None if t is None else float(np.nansum(area) * t)
    elif kind == "solid":
        rep["volume_m3"] = float(np.nansum(mesh.element_volumes(elements=el)))
    else:
        rep["length_m"] = float(np.nansum(mesh.element_lengths(el)))
        a = None if mesh.section_area is None else mesh.section_area[el]
        rep["section_area_m2"] = None if a is None or np.isnan(a).all() else float(np.nanmean(a))
        rep["section_source"] = prop.card if prop is not None and prop.card else None
    if prop is not None:
        rep["conductivity"] = prop.conductivity if prop.conductivity_tensor is None else list(prop.conductivity_tensor)
    rep.update(_regions(mesh, el, kind, feature_angle, (use, host)))
    return rep


def _pieces(mesh: Mesh, spc_nodes: np.ndarray) -> list[dict]:
    """Connected pieces of elements and joints (through shared nodes)."""
    n = mesh.n_nodes
    pc = mesh.padded_cells
    a = np.repeat(pc[:, :1], pc.shape[1], axis=1)
    ok = pc >= 0
    ea, eb = [a[ok]], [pc[ok]]
    joint = np.zeros(n, bool)
    for j in mesh.joints:
        ea.append(j.pairs[:, 0])
        eb.append(j.pairs[:, 1])
        joint[j.pairs.ravel()] = True
    ea, eb = np.concatenate(ea), np.concatenate(eb)
    _, comp = connected_components(sp.csr_matrix((np.ones(len(ea)), (ea, eb)), shape=(n, n)), directed=False)
    used = mesh.used_nodes() | joint
    el_comp = comp[pc[:, 0]]
    out = []
    for c in np.unique(comp[used]):
        els = np.flatnonzero(el_comp == c)
        nodes = (comp == c) & used
        groups = sorted(name for name, g in mesh.groups.items() if len(g.elements) and np.isin(g.elements, els).any())
        out.append({"elements": int(len(els)), "nodes": int(nodes.sum()), "groups": groups,
                    "touches_joint": bool(joint[nodes].any()), "touches_spc": bool(np.isin(np.flatnonzero(nodes),
                                                                                            spc_nodes).any())})
    out.sort(key=lambda p: -p["elements"])
    return out


#: what a group without elements was in the file (Gmsh physical dimension / Nastran set): for a [[boundary]]
_NODE_KIND = {0: "node", 1: "line", 2: "surface", 3: "volume"}


def _node_groups(mesh: Mesh) -> list[dict]:
    """The groups without model elements (Gmsh physical points / lines, Nastran node sets): name, what they were
    in the file and their node count; a ``[[boundary]]`` names them in ``groups``."""
    out = []
    for name in sorted(mesh.groups):
        g = mesh.groups[name]
        if len(g.elements) == 0 and g.nodes is not None and len(g.nodes):
            out.append({"group": name, "kind": _NODE_KIND.get(getattr(g, "dim", None), "node"),
                        "nodes": int(len(g.nodes))})
    return out


def with_case_thickness(rep: dict, case) -> dict:
    """``rep`` (:func:`inspect_mesh`) with each shell group that the mesh gives no thickness showing the one its
    case's part sets (``thickness_source``: "case, part '<name>'"), where one does."""
    given = {g: p for p in case.parts if getattr(p, "thickness", None) is not None for g in p.groups}
    for g in rep["groups"]:
        p = given.get(g["group"])
        if g["kind"] == "shell" and g.get("thickness_m") is None and p is not None:
            g["thickness_m"], g["thickness_source"] = float(p.thickness), f"case, part '{p.name}'"
            g["volume_m3"] = g["area_m2"] * float(p.thickness)
    return rep


def inspect_mesh(path, unit: str = "m", feature_angle: float | None = None, parts=None, **options) -> dict:
    """Report on the mesh file ``path`` (see the module docstring); ``options`` go to the reader.

    Unmodelled structural cards are listed (not refused); the deck's SPC/SPC1 GRIDs are read to tell which
    pieces are held.  ``parts``: (name, groups, super_nodes) of a case's ``[[parts]]``, reported per part and kind
    (``report["parts"]``: regions, the fewest count, the merges a count below the regions implies).
    """
    from .io import mesh_format, read_mesh

    path = Path(path)
    if not path.exists():
        raise Fem2TmmError(f"mesh file {path} does not exist")
    feature_angle = ClusteringSettings().feature_angle if feature_angle is None else feature_angle
    spc = np.zeros(0, np.int64)
    if path.suffix.lower() != ".msh" and mesh_format(path) == "nastran":
        options = {"strict": False, **options}
        try:
            mesh = read_mesh(path, unit=unit, loads=("SPC", "SPC1"), temperature_unit=options.pop(
                "temperature_unit", None) or "K", **options)
            spc = mesh.loads.fixed_nodes if mesh.loads is not None else spc
        except Fem2TmmError:  # several SPC sets, SPC1 without TEMP ...: inspect without them
            mesh = read_mesh(path, unit=unit, **options)
    else:
        mesh = read_mesh(path, unit=unit)
    use = _node_use(mesh)
    groups = [_group_report(mesh, name, feature_angle, use) for name in sorted(mesh.groups)
              if len(mesh.groups[name].elements)]
    node_groups = _node_groups(mesh)
    cards = {k: dict(v) for k, v in (mesh.cards or {}).items()}
    ext = np.ptp(mesh.points, axis=0) if mesh.n_nodes else np.zeros(3)
    extra = {} if parts is None else {"parts": _part_reports(mesh, parts, feature_angle, use)}
    return {"file": str(path), "unit": unit, "nodes": int(mesh.n_nodes), "elements": int(mesh.n_elements),
            "extent_m": [float(x) for x in ext], **extra,
            "feature_angle_deg": feature_angle, "groups": groups, "node_groups": node_groups,
            "pieces": _pieces(mesh, spc),
            "joints": {j.card: int(len(j.ids)) for j in mesh.joints},
            "midside_nodes": 0 if mesh.midside is None else int(len(mesh.midside)), "cards": cards}


def inspection_text(rep: dict) -> str:
    """The report as plain text tables."""
    ext = rep.get("extent_m") or [0.0, 0.0, 0.0]
    lines = [f"{rep['file']}: {rep['nodes']} nodes, {rep['elements']} elements (unit {rep['unit']})",
             "size {} m (bounding box, file lengths x the unit)".format(" x ".join(f"{x:.4g}" for x in ext))
             + (f": {note}" if (note := extent_note(max(ext), rep["unit"], rep.get("unit_key", "--unit"))) else ""), "",
             f"groups (regions at the default feature angle {rep['feature_angle_deg']:g} deg = the fewest super "
             "nodes a part of that group takes without merging; 'min' the fewest it can take: fewer regions are "
             "merged smallest first across the strongest link, and pieces beyond the count join the clusters they "
             "touch by a node; only pieces touching nothing need their own; bars lying on shell or solid nodes are "
             "reduced with those elements):"]
    lines.append(f"  {'group':<18} {'kind':<6} {'elements':>8} {'regions':>7} {'min':>5}  {'size':<22} "
                 f"{'thickness / section':<30} normals / types")
    for g in rep["groups"]:
        if g["kind"] == "shell":
            size = f"{g['area_m2']:.6g} m2"
            t = g.get("thickness_m")
            th = f"{t:.6g} m ({g['thickness_source']})" if t is not None else g["thickness_source"]
        elif g["kind"] == "solid":
            size, th = f"{g['volume_m3']:.6g} m3", "-"
        else:
            size = f"{g['length_m']:.6g} m"
            a = g.get("section_area_m2")
            th = f"A {a:.6g} m2 ({g.get('section_source')})" if a is not None else "no area: set the part's 'area'"
        types = ", ".join(f"{t} {n}" for t, n in g["types"].items())
        extra = g.get("normals", "")
        if g.get("on_other_elements"):
            extra = f"{g['on_other_elements']} on shell/solid nodes"
        lines.append(f"  {g['group']:<18} {g['kind']:<6} {g['elements']:>8} {g['regions']:>7} "
                     f"{g['fewest_super_nodes']:>5}  {size:<22} {th:<30} {(extra + '; ') if extra else ''}{types}")
    if rep.get("node_groups"):
        lines += ["", "line and node groups (nodes only, no model elements: a [[boundary]] names them in 'groups'):",
                  f"  {'group':<18} {'kind':<6} {'nodes':>8}"]
        lines += [f"  {g['group']:<18} {g['kind']:<6} {g['nodes']:>8}" for g in rep["node_groups"]]
    merging = [g for g in rep["groups"] if g.get("merges_below_regions")]
    if merging:
        unit = {"shell": ("m2", "m of shared edge"), "solid": ("m3", "m2 of shared face"), "line": ("m", "shared end")}
        lines += ["", "below its regions a group's regions merge, smallest first into the neighbour sharing the "
                      "strongest link (the first merges; summary.json reduced.clustering.parts[].regions_merged lists "
                      "a run's):"]
        for g in merging:
            mu, lu = unit[g["kind"]]
            first = "; ".join(f"{m['measure']:.3g} {mu} across {m['link']:.3g} {lu}"
                              for m in g["merges_below_regions"][:3])
            lines.append(f"  {g['group']:<18} {g['regions']} regions -> {g['fewest_super_nodes']}: {first}"
                         + (" ..." if len(g["merges_below_regions"]) > 3 else ""))
    if rep.get("parts"):
        lines += ["", "parts of the case (regions = the fewest super nodes without merging; min = the fewest at all):",
                  f"  {'part':<18} {'kind':<6} {'elements':>8} {'regions':>7} {'min':>5} {'asked':>6}  what the count does"]
        unit = {"shell": ("m2", "m"), "solid": ("m3", "m2"), "line": ("m", "end")}
        for p in rep["parts"]:
            asked = p["super_nodes"]
            if p["mixed"]:
                what = "the part's count is shared among its kinds"
            elif asked < p["fewest_super_nodes"]:
                what = f"refused: at least {p['fewest_super_nodes']} (pieces touching nothing else)"
            elif asked < p["regions"]:
                mu, lu = unit[p["kind"]]
                parts_ = []
                if asked < p["pieces"]:  # the smallest pieces join the clusters they touch (cluster.contact)
                    k = p["pieces"] - asked
                    parts_.append(f"{k} of its {p['pieces']} pieces " + ("joins the cluster it touches" if k == 1
                                                                         else "join the clusters they touch"))
                n_merge = p["regions"] - max(asked, p["pieces"])
                if n_merge > 0:
                    first = ", ".join(f"{m['measure']:.3g} {mu} across {m['link']:.3g} {lu}"
                                      for m in p["merges_below_regions"][:2])
                    parts_.append(f"{n_merge} region merge(s), smallest first: {first}")
                what = "; ".join(parts_)
            else:
                what = "no merge"
            if p.get("on_other_elements"):
                what += f"; {p['on_other_elements']} bars on shell/solid nodes join those clusters"
            lines.append(f"  {p['part']:<18} {p['kind']:<6} {p['elements']:>8} {p['regions']:>7} "
                         f"{p['fewest_super_nodes']:>5} {asked:>6}  {what}")
    lines += ["", f"connected pieces (elements and joints): {len(rep['pieces'])}"]
    for i, p in enumerate(rep["pieces"]):
        lines.append(f"  {i + 1}: {p['elements']} elements, {p['nodes']} nodes, groups {', '.join(p['groups']) or '-'}; "
                     f"joint: {'yes' if p['touches_joint'] else 'no'}, SPC: {'yes' if p['touches_spc'] else 'no'}")
    if rep["joints"]:
        lines += ["", "joints (need [[joints]] entries): " + ", ".join(f"{c} {n}" for c, n in rep["joints"].items())]
    if rep["midside_nodes"]:
        lines.append(f"quadratic elements: {rep['midside_nodes']} mid-side nodes (interpolated in the outputs)")
    for key, word in (("modelled", "cards modelled"), ("ignored", "cards ignored"),
                      ("refused", "cards refused (structural, not modelled: [mesh] ignore_cards drops them)")):
        c = rep["cards"].get(key)
        if c:
            lines.append(f"{word}: " + ", ".join(f"{k} ({v})" for k, v in sorted(c.items())))
    return "\n".join(lines)


__all__ = ["inspect_mesh", "inspection_text"]
