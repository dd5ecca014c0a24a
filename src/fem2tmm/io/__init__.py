"""Mesh readers: Gmsh through meshio, Nastran bulk data in-house."""

from __future__ import annotations

from pathlib import Path

from ..errors import Fem2TmmError
from ..mesh import Mesh

GMSH_SUFFIXES = (".msh",)
NASTRAN_SUFFIXES = (".bdf", ".nas", ".dat", ".blk", ".bulk", ".fem")


def read_mesh(path: str | Path, unit: str = "m") -> Mesh:
    """Read a structural mesh: Gmsh ``.msh`` (2.2, 4.1) or Nastran bulk data (``.bdf .nas .dat ...``).

    ``unit`` is the length unit of the file; the returned :class:`~fem2tmm.mesh.Mesh` is in metres.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.exists():
        raise Fem2TmmError(f"mesh file {path} does not exist")
    if suffix in GMSH_SUFFIXES:
        from .gmsh import read_gmsh

        return read_gmsh(path, unit=unit)
    if suffix in NASTRAN_SUFFIXES:
        from .nastran import read_nastran

        return read_nastran(path, unit=unit)
    raise Fem2TmmError(
        f"{path}: unknown mesh format {suffix!r}; use a Gmsh .msh file or Nastran bulk data "
        f"({', '.join(NASTRAN_SUFFIXES)})"
    )


__all__ = ["read_mesh"]
