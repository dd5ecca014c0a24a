"""fem2tmm: structural finite-element mesh -> small, accurate thermal model, and back.

Public API (DESIGN §4.4)::

    import fem2tmm as ft
    case = ft.Case.from_toml("case.toml")
    result = ft.run(case, out="out")
    mesh = ft.read_mesh("part.bdf", unit="mm")
    labels = ft.partition(points, cells, n_clusters)
    ft.recover("out", "temperatures.csv", out="out-recovered")  # outside temperatures -> FE nodes
"""

from __future__ import annotations

from ._version import __version__

from .case import Case
from .cluster import partition
from .errors import Fem2TmmError
from .io import read_mesh
from .mesh import ElementBlock, Group, Mesh, shapes
from .pipeline import run
from .recovering import recover
from .result import Result
from .radiation import exchange_factors
from .orbit import Attitude, Orbit, Planet
from .radiation.orbital import orbital_fluxes
from .radiation.planet import planet_fluxes
from .radiation.solar import solar_fluxes

meshes = shapes  # the former name of fem2tmm.mesh.shapes (``ft.meshes.plate(...)`` keeps working)

__all__ = [
    "Attitude",
    "Case",
    "ElementBlock",
    "Fem2TmmError",
    "Group",
    "Mesh",
    "Result",
    "__version__",
    "meshes",
    "shapes",
    "Orbit",
    "orbital_fluxes",
    "Planet",
    "planet_fluxes",
    "exchange_factors",
    "partition",
    "solar_fluxes",
    "read_mesh",
    "recover",
    "run",
]
