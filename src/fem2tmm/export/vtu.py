"""VTU output of the detailed mesh with point and cell data (through meshio)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..mesh import Mesh

_MESHIO = {"tri3": "triangle", "quad4": "quad", "tet4": "tetra", "hex8": "hexahedron", "wedge6": "wedge", "line2": "line"}


def write_vtu(path: str | Path, mesh: Mesh, point_data: dict[str, np.ndarray] | None = None,
              cell_data: dict[str, np.ndarray] | None = None, elements: np.ndarray | None = None) -> None:
    """Write ``mesh`` (restricted to ``elements``, global indices, if given) to a VTU file.

    ``point_data`` name -> (n_nodes,) arrays; ``cell_data`` name -> (n_elements,) arrays over ALL mesh
    elements (they are restricted like the cells).  NaN marks missing values.
    """
    import meshio

    cells, cdata = [], {k: [] for k in (cell_data or {})}
    for t, c, gidx in mesh.iter_blocks(elements):
        cells.append((_MESHIO[t], np.asarray(c)))
        for k, v in (cell_data or {}).items():
            cdata[k].append(np.asarray(v)[gidx])
    pdata = {k: np.asarray(v, dtype=np.float64) for k, v in (point_data or {}).items()}
    pdata["node_id"] = mesh.node_ids.astype(np.int64)
    cdata["element_id"] = [mesh.element_ids[g] for _, _, g in mesh.iter_blocks(elements)]
    meshio.write(str(path), meshio.Mesh(mesh.points, cells, point_data=pdata, cell_data=cdata), file_format="vtu")
