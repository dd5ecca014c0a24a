"""fem2tmm: structural finite-element mesh -> small, accurate thermal model.

Public API (see DESIGN §4.4)::

    import fem2tmm as ft
    mesh = ft.read_mesh("part.bdf", unit="mm")
"""

from __future__ import annotations

__version__ = "0.1.0"

from .errors import Fem2TmmError
from .mesh import ElementBlock, Group, Mesh

__all__ = ["Fem2TmmError", "Mesh", "ElementBlock", "Group", "__version__"]
