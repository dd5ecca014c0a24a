"""Read every committed .msh file back with meshio and print what a reader gets.

For each file: size, number of points, cell blocks (type, count), physical groups as meshio's cell_sets
(number of cells per group and, for 1-D groups, the number of distinct nodes), the bounding box, total area or
volume per group, and the orientation of shell normals (checked against the rule each mesh documents).

Run with the project's environment (meshio, numpy; no gmsh needed):  python meshes/check_meshes.py [files...]
"""

from __future__ import annotations

import os
import sys

import meshio
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def _area_normals(points: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Area (m,) and unit right-hand normal (m,3) of tri3 (m,3) or quad4 (m,4) cells."""
    p = points[cells]
    if cells.shape[1] == 3:
        a = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    else:
        a = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    norm = np.linalg.norm(a, axis=1)
    return 0.5 * norm, a / norm[:, None]


def _tet_volumes(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    p = points[cells]
    return np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0]) / 6.0


# The documented normal rule of each shell mesh: a function (centroids (m,3), group name) -> wanted (m,3).
def _baffle_rule(c: np.ndarray, group: str) -> np.ndarray:
    radial = np.column_stack([c[:, 0], c[:, 1], np.zeros(len(c))])
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    z = np.tile([0.0, 0.0, 1.0], (len(c), 1))
    return {"aperture_lip": -radial, "front_cone": z, "outer_skin": radial, "middle_annulus": -z,
            "main_cone": -radial, "back_annulus": z}[group]


def _cylinders_rule(c: np.ndarray, group: str) -> np.ndarray:
    axis_point, axis = {"cylinder_1": ([-75.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
                        "cylinder_2": ([75.0, 0.0, 0.0], [0.0, 0.0, 1.0])}[group]
    d = c - np.asarray(axis_point)
    return d - np.outer(d @ np.asarray(axis), axis)


RULES = {
    "baffle.msh": _baffle_rule,
    "cylinders.msh": _cylinders_rule,
    "fin.msh": lambda c, g: np.tile([0.0, 0.0, 1.0], (len(c), 1)),
    "fin_v22.msh": lambda c, g: np.tile([0.0, 0.0, 1.0], (len(c), 1)),
}


def groups_of(m: meshio.Mesh) -> dict[str, dict[str, np.ndarray]]:
    """{physical name: {cell type: cells (k, nodes)}}, from cell_sets (MSH 4.1) or, when meshio gives no
    cell_sets (its MSH 2.2 reader), from field_data + cell_data["gmsh:physical"]."""
    out: dict[str, dict[str, list]] = {}
    names = [k for k in m.cell_sets if not k.startswith("gmsh:")]
    if names:
        for name in names:
            for block, idx in zip(m.cells, m.cell_sets[name]):
                if idx is not None and len(idx):
                    out.setdefault(name, {}).setdefault(block.type, []).append(block.data[idx])
    else:
        dims = {"vertex": 0, "line": 1, "triangle": 2, "quad": 2, "tetra": 3, "hexahedron": 3, "wedge": 3}
        for name, (tag, dim) in m.field_data.items():
            for block, phys in zip(m.cells, m.cell_data["gmsh:physical"]):
                if dims[block.type] == dim and np.any(phys == tag):
                    out.setdefault(name, {}).setdefault(block.type, []).append(block.data[phys == tag])
    return {g: {t: np.concatenate(v) for t, v in d.items()} for g, d in out.items()}


def edge_census(points: np.ndarray, shells: list[np.ndarray]) -> str:
    """Count the edges of a shell mesh by the number of elements sharing them (1 = free, 2 = manifold, 3+ =
    junction) and say where the free edges lie (distinct z, radius about z): a non-conformal junction shows up
    as free edges where two surfaces should meet."""
    edges = []
    for cells in shells:
        k = cells.shape[1]
        edges += [cells[:, [i, (i + 1) % k]] for i in range(k)]
    e = np.sort(np.concatenate(edges), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    free = uniq[count == 1]
    census = {int(n): int(np.count_nonzero(count == n)) for n in np.unique(count)}
    text = f"edges by number of elements sharing them: {census}"
    if len(free):
        p = points[np.unique(free)]
        r = np.hypot(p[:, 0], p[:, 1])
        text += (f"; free-edge nodes: {len(p)}, distinct z (first 8): {sorted(set(np.round(p[:, 2], 3).tolist()))[:8]}, "
                 f"r in [{r.min():.2f}, {r.max():.2f}]")
    return text


def check(path: str) -> None:
    name = os.path.basename(path)
    m = meshio.read(path)
    pts = m.points
    print(f"== {name}: {os.path.getsize(path) / 1e6:.2f} MB, {len(pts)} points, "
          f"bbox min {np.round(pts.min(0), 3).tolist()} max {np.round(pts.max(0), 3).tolist()}")
    used = np.unique(np.concatenate([b.data.ravel() for b in m.cells]))
    counts: dict[str, int] = {}
    for b in m.cells:
        counts[b.type] = counts.get(b.type, 0) + len(b.data)
    print(f"   points used by cells: {len(used)} (unused: {len(pts) - len(used)}); {len(m.cells)} cell blocks: "
          + ", ".join(f"{t}:{n}" for t, n in counts.items()))
    print(f"   cell_sets keys: {sorted(m.cell_sets)}")
    shells = [b.data for b in m.cells if b.type in ("triangle", "quad")]
    if shells and not any(b.type in ("tetra", "hexahedron", "wedge") for b in m.cells):
        print("   " + edge_census(pts, shells))
    for group, by_type in groups_of(m).items():
        parts, extra = [], []
        for ctype, cells in by_type.items():
            parts.append(f"{ctype}:{len(cells)}")
            if ctype in ("triangle", "quad"):
                area, normal = _area_normals(pts, cells)
                extra.append(f"area {area.sum():.1f} mm2")
                rule = RULES.get(name)
                if rule is not None:
                    dots = np.einsum("ij,ij->i", normal, rule(pts[cells].mean(axis=1), group))
                    extra.append(f"normals as documented {np.count_nonzero(dots > 0)}/{len(dots)}")
            elif ctype == "tetra":
                vol = _tet_volumes(pts, cells)
                extra.append(f"volume {vol.sum():.0f} mm3, min tet {vol.min():.3g} mm3, "
                             f"non-positive {np.count_nonzero(vol <= 0)}")
            elif ctype == "line":
                extra.append(f"{len(np.unique(cells))} distinct nodes")
        print(f"   {group}: " + ", ".join(parts) + ("; " + "; ".join(extra) if extra else ""))


def main(argv: list[str]) -> None:
    files = argv or sorted(os.path.join(HERE, f) for f in os.listdir(HERE) if f.endswith(".msh"))
    for f in files:
        check(f)


if __name__ == "__main__":
    main(sys.argv[1:])
