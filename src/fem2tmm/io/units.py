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


#: unit systems of Nastran decks: name -> (metres, kilograms, seconds) per deck unit of length, mass, time.
#: Mass units follow from force for the lbf systems (lbf·s²/in, the "slinch"; lbf·s²/ft, the slug).
UNIT_SYSTEMS: dict[str, tuple[float, float, float]] = {
    "m-kg-s": (1.0, 1.0, 1.0),
    "mm-t-s": (1e-3, 1e3, 1.0),
    "mm-kg-s": (1e-3, 1.0, 1.0),
    "mm-kg-ms": (1e-3, 1.0, 1e-3),
    "cm-g-s": (1e-2, 1e-3, 1.0),
    "in-lbf-s": (0.0254, 4.4482216152605 / 0.0254, 1.0),
    "ft-lbf-s": (0.3048, 4.4482216152605 / 0.3048, 1.0),
}
#: other spellings accepted in the case file
UNIT_SYSTEM_ALIASES = {"si": "m-kg-s", "si-m": "m-kg-s", "si-mm-tonne-s": "mm-t-s", "mm-tonne-s": "mm-t-s",
                       "si-mm": "mm-t-s", "inch-lbf-s": "in-lbf-s", "foot-lbf-s": "ft-lbf-s"}
#: deck temperature scale: name -> (kelvin per degree, kelvin at the scale's zero)
TEMPERATURE_UNITS: dict[str, tuple[float, float]] = {"K": (1.0, 0.0), "C": (1.0, 273.15),
                                                      "F": (5.0 / 9.0, 459.67 * 5.0 / 9.0), "R": (5.0 / 9.0, 0.0)}


def unit_system_name(name: str, where: str = "unit_system") -> str:
    """Canonical name of a unit system (see :data:`UNIT_SYSTEMS`); error for an unknown one."""
    key = str(name).strip().lower()
    key = UNIT_SYSTEM_ALIASES.get(key, key)
    if key not in UNIT_SYSTEMS:
        raise Fem2TmmError(f"{where}: unknown unit system {name!r}; supported: {', '.join(UNIT_SYSTEMS)} "
                           f"(also {', '.join(UNIT_SYSTEM_ALIASES)})")
    return key


def material_factors(system: str | None, temperature_unit: str | None) -> dict[str, float] | None:
    """SI factors of a deck's thermal values in unit system ``system``, or None when ``system`` is None.

    Keys: ``conductivity`` W/(m K), ``density`` kg/m³, ``specific_heat`` J/(kg K), ``flux`` W/m², ``power`` W,
    ``power_density`` W/m³, ``length`` m.  Per-degree values use the temperature unit: kelvin per degree is 1
    for K and C, 5/9 for F and R; for the lbf systems the temperature unit must be given (refused as
    ambiguous otherwise, by the caller).
    """
    if system is None:
        return None
    L, M, t = UNIT_SYSTEMS[system]
    theta = TEMPERATURE_UNITS[temperature_unit][0] if temperature_unit else 1.0
    return {"conductivity": M * L / t**3 / theta, "density": M / L**3, "specific_heat": L**2 / t**2 / theta,
            "flux": M / t**3, "power": M * L**2 / t**3, "power_density": M / L / t**3, "length": L}
