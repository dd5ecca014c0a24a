"""The mesh: the data type every stage reads (:class:`Mesh`, :class:`ElementBlock`, :class:`Group`, ...), its element
tables and geometry (:mod:`.elements`, :mod:`.geometry`), and parametric generators (:mod:`.shapes`).

This package imports no later stage (the FE model in :mod:`fem2tmm.fem` imports it, never the reverse).  A mesh
is validated once, when it is built.
"""

from __future__ import annotations

from .core import (DeckLoads, ElementBlock, Group, JointBlock, Mesh, PropertyData, make_group, pad_cells,
                   unique_ints)

__all__ = ["DeckLoads", "ElementBlock", "Group", "JointBlock", "Mesh", "PropertyData", "make_group", "pad_cells",
           "unique_ints"]
