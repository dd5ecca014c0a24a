"""Physical constants and shared numerical tolerances (one definition each)."""

from __future__ import annotations

KELVIN = 273.15
"""Offset between °C and K: T[K] = T[°C] + KELVIN."""

ABSOLUTE_ZERO_C = -KELVIN
"""Absolute zero in °C."""

SIGMA = 5.670374419e-8
"""Stefan-Boltzmann constant, W/(m² K⁴) (CODATA 2018, exact since the 2019 SI)."""

POWER_RTOL = 1e-12
"""Relative tolerance of an energy book-keeping check (power that must be zero up to round-off)."""
