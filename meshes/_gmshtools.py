"""Small helpers shared by the mesh-generation scripts in this folder.

Only the ``make_*.py`` scripts import this module (run them with a Python that has the ``gmsh`` package, see
README.md).  gmsh is GPL-licensed: nothing in the fem2tmm package imports gmsh or this module.
"""

from __future__ import annotations

import os

import gmsh
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def start(name: str) -> None:
    """Initialise gmsh quietly and deterministically (one thread, fixed random factor)."""
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.option.setNumber("General.NumThreads", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads1D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads2D", 1)
    gmsh.option.setNumber("Mesh.MaxNumThreads3D", 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)
    gmsh.model.add(name)


def element_normals(surface_tag: int) -> tuple[np.ndarray, np.ndarray]:
    """Centroids (m,3) and unit normals (m,3) of the 2-D elements of one surface entity.

    The normal is the right-hand normal of the element's node order (for a quad the cross product of its
    diagonals), i.e. the normal a shell reader derives from the file.
    """
    centroids, normals = [], []
    for etype, _tags, nodes in zip(*gmsh.model.mesh.getElements(2, surface_tag)):
        nn = gmsh.model.mesh.getElementProperties(etype)[3]  # number of nodes per element
        xyz = _node_coords(np.asarray(nodes)).reshape(-1, nn, 3)
        if nn == 3:
            n = np.cross(xyz[:, 1] - xyz[:, 0], xyz[:, 2] - xyz[:, 0])
        elif nn == 4:
            n = np.cross(xyz[:, 2] - xyz[:, 0], xyz[:, 3] - xyz[:, 1])
        else:
            raise ValueError(f"unexpected surface element with {nn} nodes on surface {surface_tag}")
        centroids.append(xyz.mean(axis=1))
        normals.append(n / np.linalg.norm(n, axis=1, keepdims=True))
    return np.concatenate(centroids), np.concatenate(normals)


def _node_coords(node_tags: np.ndarray) -> np.ndarray:
    tags, coords, _ = gmsh.model.mesh.getNodes()
    lookup = np.empty(int(tags.max()) + 1, dtype=np.int64)
    lookup[tags.astype(np.int64)] = np.arange(len(tags))
    return coords.reshape(-1, 3)[lookup[node_tags.astype(np.int64)]]


def orient_surfaces(wanted) -> dict[int, str]:
    """Reverse whole surface meshes so that every element normal agrees with ``wanted``.

    ``wanted(surface_tag, centroids) -> (m,3)`` gives the desired direction at each element centroid (only its
    sign relative to the element normal matters).  A surface is reversed when the majority of its elements
    disagree; afterwards every element of every surface must agree, otherwise ValueError.  Returns
    {surface tag: "kept" | "reversed"}.
    """
    report = {}
    for _dim, tag in gmsh.model.getEntities(2):
        c, n = element_normals(tag)
        dots = np.einsum("ij,ij->i", n, wanted(tag, c))
        if np.count_nonzero(dots < 0) > len(dots) // 2:
            gmsh.model.mesh.reverse([(2, tag)])
            report[tag] = "reversed"
        else:
            report[tag] = "kept"
        c, n = element_normals(tag)
        bad = np.count_nonzero(np.einsum("ij,ij->i", n, wanted(tag, c)) <= 0)
        if bad:
            raise ValueError(f"surface {tag}: {bad} element(s) still against the wanted orientation")
    return report


def write(filename: str, version: float = 4.1) -> str:
    """Write the current model's mesh (physical groups only) as ASCII Gmsh ``version`` into this folder."""
    gmsh.option.setNumber("Mesh.MshFileVersion", version)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.option.setNumber("Mesh.SaveAll", 0)
    path = os.path.join(HERE, filename)
    gmsh.write(path)
    return path


def summary(path: str) -> None:
    """Print what was written: node count and element counts per type over the entities of physical groups."""
    entities = sorted({(dim, ent) for dim, tag in gmsh.model.getPhysicalGroups()
                       for ent in gmsh.model.getEntitiesForPhysicalGroup(dim, tag)})
    counts: dict[str, int] = {}
    nodes = set()
    for dim, ent in entities:
        for etype, etags, enodes in zip(*gmsh.model.mesh.getElements(dim, ent)):
            name = gmsh.model.mesh.getElementProperties(etype)[0]
            counts[name] = counts.get(name, 0) + len(etags)
            nodes.update(np.asarray(enodes).tolist())
    print(f"{os.path.relpath(path)}: {len(nodes)} nodes; " + ", ".join(f"{k}: {v}" for k, v in counts.items()))
