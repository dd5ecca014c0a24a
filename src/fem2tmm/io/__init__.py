"""Mesh readers: Gmsh through meshio, Nastran bulk data in-house."""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import Fem2TmmError
from ..mesh import Mesh

GMSH_SUFFIXES = (".msh",)
NASTRAN_SUFFIXES = (".bdf", ".nas", ".dat", ".blk", ".bulk", ".fem")


_NASTRAN_HEAD = re.compile(rb"^(?:BEGIN\s+BULK|CEND|SOL\s|INCLUDE|GRID\*?[\s,]|CQUAD4|CTRIA3|CHEXA|CTETRA|CPENTA|"
                           rb"CBAR|CROD|PSHELL|PSOLID|MAT[145]|CORD2[RCS]|ID\s|APP\s)", re.IGNORECASE | re.MULTILINE)


def mesh_format(path: Path) -> str:
    """``"gmsh"`` or ``"nastran"``, decided by the content of the first 256 kB (any suffix: ``.inp``, ``.dat``,
    ``.nas``, ``.bdf``, ``.blk`` ...); an error naming what was found otherwise."""
    with open(path, "rb") as fh:
        head = fh.read(1 << 18)
    if head.lstrip().startswith(b"$MeshFormat"):
        return "gmsh"
    if _NASTRAN_HEAD.search(head):
        return "nastran"
    if re.search(rb"^\*(?:NODE|HEADING|ELEMENT)", head, re.IGNORECASE | re.MULTILINE):
        raise Fem2TmmError(f"{path}: this is an Abaqus input file (*NODE/*ELEMENT), not Nastran bulk data or Gmsh; "
                           "export the mesh as Nastran bulk data (.bdf) or Gmsh (.msh)")
    raise Fem2TmmError(f"{path}: neither Gmsh ($MeshFormat) nor Nastran bulk data (GRID, element or BEGIN BULK "
                       "lines) found in the file; use a Gmsh .msh file or a Nastran deck")


def read_mesh(path: str | Path, unit: str = "m", **options) -> Mesh:
    """Read a structural mesh: Gmsh ``.msh`` (2.2, 4.1) or Nastran bulk data (any suffix, by content).

    ``unit`` is the length unit of the file; the returned :class:`~fem2tmm.mesh.Mesh` is in metres.
    ``options`` go to :func:`fem2tmm.io.nastran.read_nastran` (``unit_system``, ``temperature_unit``,
    ``loads``, ``ignore_cards``, ``strict``, ``load_set``, ``spc_set``); Gmsh files take none.

    Parameters
    ----------
    path : str or Path
        Mesh file; ``.msh`` is read as Gmsh, any other suffix is recognised by its content.
    unit : str
        Length unit of the file ("m", "mm", ...); coordinates are converted to metres.
    **options
        Nastran reader options (see above).

    Returns
    -------
    Mesh
        Nodes (n, 3) in m, element blocks and named groups; validated once when built.

    Raises
    ------
    Fem2TmmError
        Missing or empty file, unrecognised format (e.g. an Abaqus deck), or an invalid mesh.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.exists():
        raise Fem2TmmError(f"mesh file {path} does not exist")
    if path.is_file() and path.stat().st_size == 0:
        raise Fem2TmmError(f"mesh file {path} is empty (0 bytes): export the mesh again")
    fmt = "gmsh" if suffix in GMSH_SUFFIXES else mesh_format(path)
    if fmt == "gmsh":
        from .gmsh import read_gmsh

        return read_gmsh(path, unit=unit)
    from .nastran import read_nastran

    return read_nastran(path, unit=unit, **options)


__all__ = ["read_mesh"]
