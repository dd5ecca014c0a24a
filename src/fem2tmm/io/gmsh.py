"""Gmsh ``.msh`` reader (formats 2.2 and 4.1) through meshio.

Physical groups become named :class:`~fem2tmm.mesh.Group` objects: 2-D and 3-D groups tag elements
(surface triangles/quads, volume tets/hexes/wedges); 0-D and 1-D groups (points, curves) tag only nodes,
which is how users mark boundary nodes.  Lines and points are not elements of the thermal model.

Gmsh writes an element that belongs to several physical groups once per group in format 2.2; such
duplicates (same type, same nodes) are merged and the element is a member of every group.
Nodes and elements get the ids 1..n / 1..m in file order (meshio does not keep Gmsh tags).
"""

from __future__ import annotations

import contextlib
import io
import warnings
from pathlib import Path

import numpy as np

from ..errors import Fem2TmmError
from ..mesh.elements import ELEMENT_TYPES
from ..mesh import ElementBlock, Mesh, make_group, pad_cells
from .units import length_scale

#: meshio cell type -> fem2tmm element type
MESHIO_TYPES = {"triangle": "tri3", "quad": "quad4", "tetra": "tet4", "hexahedron": "hex8", "wedge": "wedge6"}
#: meshio cell types that only tag nodes
NODE_TYPES = {"vertex", "line"}


def _physical_membership(mm, field_data) -> list[list[tuple[str, int, np.ndarray]]]:
    """Per meshio cell block, the list of (group name, dim, row indices in that block)."""
    out: list[list[tuple[str, int, np.ndarray]]] = [[] for _ in mm.cells]
    names_by_tag = {(int(v[1]), int(v[0])): k for k, v in field_data.items()}  # (dim, tag) -> name
    sets = {k: v for k, v in (mm.cell_sets or {}).items() if k in field_data}
    if sets:  # format 4.1: meshio gives membership per block, with multiple groups per entity
        for name, per_block in sets.items():
            dim = int(field_data[name][1])
            for b, rows in enumerate(per_block):
                if rows is not None and len(rows):
                    out[b].append((name, dim, np.asarray(rows, dtype=np.int64)))
        return out
    phys = (mm.cell_data or {}).get("gmsh:physical")
    if phys is None:
        return out
    for b, (block, tags) in enumerate(zip(mm.cells, phys)):
        tags = np.asarray(tags)
        for tag in np.unique(tags):
            dim = {"vertex": 0, "line": 1}.get(block.type, 3 if block.type in ("tetra", "hexahedron", "wedge") else 2)
            name = names_by_tag.get((dim, int(tag)), f"physical {dim}:{int(tag)}")
            out[b].append((name, dim, np.flatnonzero(tags == tag)))
    return out


def read_gmsh(path: str | Path, unit: str = "m") -> Mesh:
    """Read a Gmsh mesh; ``unit`` is the length unit of the file (m, cm, mm, in, ft).

    Returns a :class:`~fem2tmm.mesh.Mesh` with points in metres.
    """
    import meshio

    path = Path(path)
    scale = length_scale(unit, where=f"{path}: unit")
    bad = f"{path}: cannot be read as a Gmsh .msh file ({{}}); is it complete? Export it again from Gmsh (format " \
          "2.2 or 4.1)"
    chatter = io.StringIO()  # meshio prints warnings and errors itself (rich, to stderr): keep them out of the way
    try:
        with warnings.catch_warnings(), contextlib.redirect_stderr(chatter), contextlib.redirect_stdout(chatter):
            warnings.simplefilter("ignore")
            # the format's own reader: meshio.read() prints and calls sys.exit(1) when its reader fails
            mm = meshio.gmsh.read(str(path))
    except FileNotFoundError:
        raise Fem2TmmError(f"mesh file {path} does not exist") from None
    except (Exception, SystemExit) as exc:  # meshio raises many types on malformed files
        raise Fem2TmmError(bad.format(f"{type(exc).__name__}: {exc}")) from None
    if len(mm.points) == 0 or not any(len(c.data) for c in mm.cells):
        raise Fem2TmmError(bad.format("no nodes or no elements"))

    points = np.asarray(mm.points, dtype=np.float64)
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    points = points * scale
    field_data = dict(mm.field_data or {})
    membership = _physical_membership(mm, field_data)

    unsupported = sorted({c.type for c in mm.cells if c.type not in MESHIO_TYPES and c.type not in NODE_TYPES})
    if unsupported:
        raise Fem2TmmError(
            f"{path}: unsupported element type(s) {', '.join(unsupported)}; supported: {', '.join(ELEMENT_TYPES)} "
            "(linear elements only: re-mesh with element order 1), plus points and lines for node groups"
        )

    # Gather element cells per fem2tmm type, remembering (meshio block, row) -> position.
    per_type: dict[str, list[np.ndarray]] = {}
    where: list[tuple[str, int] | None] = []  # per meshio block: (type, start row in per_type concat)
    counts: dict[str, int] = {}
    for block in mm.cells:
        t = MESHIO_TYPES.get(block.type)
        if t is None:
            where.append(None)
            continue
        data = np.asarray(block.data, dtype=np.int64)
        where.append((t, counts.get(t, 0)))
        per_type.setdefault(t, []).append(data)
        counts[t] = counts.get(t, 0) + len(data)

    blocks: list[ElementBlock] = []
    remap: dict[str, np.ndarray] = {}  # row in per-type concatenation -> global element index
    offset = 0
    for t in ELEMENT_TYPES:
        if t not in per_type:
            continue
        cells = np.concatenate(per_type[t])
        key = np.sort(cells, axis=1)
        uniq, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
        order = np.sort(first)  # keep file order of first occurrences
        rank = np.empty(len(uniq), np.int64)
        rank[np.argsort(first)] = np.arange(len(uniq))
        remap[t] = offset + rank[inverse.ravel()]
        blocks.append(ElementBlock(t, cells[order], np.arange(offset + 1, offset + len(order) + 1, dtype=np.int64)))
        offset += len(order)

    padded = pad_cells(blocks)

    elements_of: dict[str, list[np.ndarray]] = {}
    nodes_of: dict[str, list[np.ndarray]] = {}
    dims: dict[str, int] = {}
    for b, (block, members) in enumerate(zip(mm.cells, membership)):
        for name, dim, rows in members:
            dims[name] = max(dims.get(name, dim), dim)
            if where[b] is not None:
                t, start = where[b]
                elements_of.setdefault(name, []).append(remap[t][start + rows])
            else:
                nodes_of.setdefault(name, []).append(np.asarray(block.data, np.int64)[rows].ravel())
    groups = {}
    for name in sorted(set(elements_of) | set(nodes_of)):
        el = np.concatenate(elements_of.get(name, [np.zeros(0, np.int64)]))
        nd = [np.concatenate(nodes_of[name])] if name in nodes_of else []
        if len(el):
            pc = padded[np.unique(el)]
            nd.append(pc[pc >= 0])
        groups[name] = make_group(name, dims[name], el, np.concatenate(nd) if nd else np.zeros(0, np.int64))
    return Mesh(points=points, blocks=tuple(blocks), groups=groups, source=str(path))
