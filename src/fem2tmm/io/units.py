"""Length units of mesh files."""

from __future__ import annotations

from ..errors import Fem2TmmError

#: metres per unit
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "in": 0.0254, "ft": 0.3048}


def length_scale(unit: str, where: str = "unit") -> float:
    """Metres per ``unit``; raises :class:`Fem2TmmError` for an unknown unit."""
    try:
        return LENGTH_UNITS[str(unit).strip().lower()]
    except KeyError:
        raise Fem2TmmError(
            f"{where}: unknown length unit {unit!r}; expected one of {', '.join(LENGTH_UNITS)}"
        ) from None
