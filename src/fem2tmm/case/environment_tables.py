"""The parser's environment tables: ``[environment]`` (with its time tables) and ``[orbit]``.
"""

from __future__ import annotations

import math
from typing import Mapping, get_args

from ..constants import ABSOLUTE_ZERO_C, KELVIN
from ..timefunc import Table, parse_table
from .types import Environment, OrbitSettings, SolarOn, _default


class _EnvironmentTables:
    def time_table(self, value, where: str, kelvin: bool, unit: str = "°C") -> Table:
        """A value given as ``[[t, v], ...]`` or a two-column CSV file (values in ``unit``); °C -> K when
        ``kelvin``."""
        table = parse_table(value, f"{self.src}: {where}", self.base, unit=unit)
        if kelvin:
            if not table.v.min() > ABSOLUTE_ZERO_C:
                raise self.err(where, f"temperatures must be above {ABSOLUTE_ZERO_C} °C, got {table.v.min()}")
            table = table.mapped(lambda v: v + KELVIN)
        return table

    def environment(self, d) -> Environment:
        w = "[environment]"
        d = self.table(d, w, {"sink_temperature", "sun_direction", "solar_flux", "solar_on", "solar_rays_per_face"})
        sink_table = None
        if isinstance(d.get("sink_temperature"), (list, str)):
            sink_table = self.time_table(d["sink_temperature"], f"{w}.sink_temperature", kelvin=True)
            sink = sink_table(self.t0)
        else:
            sink = self.number(d, "sink_temperature", w, default=_default(Environment, "sink_temperature") - KELVIN,
                               lo=ABSOLUTE_ZERO_C) + KELVIN
        sun = d.get("sun_direction")
        if sun is not None:
            if (not isinstance(sun, list) or len(sun) != 3
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in sun)):
                raise self.err(f"{w}.sun_direction", f"expected three numbers [x, y, z], got {sun!r}")
            norm = math.sqrt(sum(float(x) ** 2 for x in sun))
            if not norm > 0:
                raise self.err(f"{w}.sun_direction", "must not be the zero vector")
            sun = tuple(float(x) / norm for x in sun)
        flux = self.number(d, "solar_flux", w, default=_default(Environment, "solar_flux"), lo=0)
        if flux > 0 and sun is None:
            raise self.err(w, "solar_flux is given but sun_direction is not")
        return Environment(sink_temperature=sink, sun_direction=sun, solar_flux=flux, sink_table=sink_table,
                           solar_on=self.string(d, "solar_on", w, default=_default(Environment, "solar_on"),
                                                choices=get_args(SolarOn)),
                           solar_rays_per_face=self.number(d, "solar_rays_per_face", w, lo=1, integer=True,
                                                           default=_default(Environment, "solar_rays_per_face")))

    def orbit(self, d, environment) -> OrbitSettings:
        from ..orbit import Attitude, Orbit, Planet

        w = "[orbit]"
        d = self.table(d, "[orbit]", {"altitude", "semi_major_axis", "eccentricity", "inclination", "raan",
                                      "argument_of_perigee", "beta", "sun_argument", "date", "solar_flux", "positions",
                                      "eclipse", "kinds", "rays_per_face", "fluxes_on", "steady", "planet",
                                      "attitude"})
        if isinstance(environment, Mapping) and ("sun_direction" in environment or "solar_flux" in environment):
            raise self.err("[environment]", "sun_direction / solar_flux are set by [orbit] (the Sun by beta or date, "
                                            "[orbit] solar_flux); remove them from [environment]")
        wp = "[orbit.planet]"
        p = self.table(d.get("planet", {}), "[orbit.planet]", {"radius", "mu", "albedo", "ir_temperature",
                                                              "ir_emissivity", "ir_flux"})
        ir_t = self.number(p, "ir_temperature", wp, default=288.0 - KELVIN, lo=ABSOLUTE_ZERO_C)
        planet = Planet(radius=self.number(p, "radius", wp, default=6_378_136.0, lo=0, lo_open=True),
                        mu=self.number(p, "mu", wp, default=3.986004418e14, lo=0, lo_open=True),
                        albedo=self.number(p, "albedo", wp, default=0.3, lo=0, hi=1),
                        ir_temperature=ir_t + KELVIN,
                        ir_emissivity=self.number(p, "ir_emissivity", wp, default=1.0, lo=0, hi=1),
                        ir_flux=self.number(p, "ir_flux", wp, lo=0))
        date = d.get("date")
        if date is not None and not isinstance(date, str) and not hasattr(date, "year"):
            raise self.err(f"{w}.date", f"expected a date (2026-06-21T12:00:00 or a TOML date-time), got {date!r}")
        flux = d.get("solar_flux", 1366.1)
        if not (flux == "distance" or (isinstance(flux, (int, float)) and not isinstance(flux, bool))):
            raise self.err(f"{w}.solar_flux", f"expected a flux in W/m² or \"distance\", got {flux!r}")
        positions = d.get("positions", 24)
        if not ((isinstance(positions, int) and not isinstance(positions, bool)) or (
                isinstance(positions, list) and all(isinstance(x, (int, float)) for x in positions))):
            raise self.err(f"{w}.positions", f"expected a number of positions or a list of true anomalies (deg), "
                                             f"got {positions!r}")
        num = lambda k, default=None: self.number(d, k, w, default=default)  # noqa: E731
        try:
            orbit = Orbit.make(planet, altitude=num("altitude"), semi_major_axis=num("semi_major_axis"),
                               eccentricity=num("eccentricity", 0.0), inclination=num("inclination", 0.0),
                               raan=num("raan", 0.0), argument_of_perigee=num("argument_of_perigee", 0.0),
                               beta=num("beta"), sun_argument=num("sun_argument", 0.0), date=date, solar_flux=flux,
                               positions=positions, eclipse=self.string(d, "eclipse", w, default="cylindrical"),
                               where=f"{self.src}: {w}")
            a = self.table(d.get("attitude", {}), "[orbit.attitude]", {"kind", "primary", "secondary", "axes",
                                                                        "rotation"})
            attitude = Attitude.make(self.string(a, "kind", "[orbit.attitude]", default="nadir"), a.get("primary"),
                                     a.get("secondary"), a.get("axes"), a.get("rotation"),
                                     where=f"{self.src}: [orbit.attitude]")
        except (TypeError, ValueError) as exc:
            raise self.err(w, f"invalid value: {exc}") from None
        kinds = self.strings(d, "kinds", w) or ("solar", "albedo", "ir")
        bad = [k for k in kinds if k not in ("solar", "albedo", "ir")]
        if bad or len(set(kinds)) != len(kinds):
            raise self.err(f"{w}.kinds", f"expected distinct names among solar, albedo, ir, got {list(kinds)}")
        return OrbitSettings(orbit=orbit, attitude=attitude, kinds=tuple(kinds),
                             rays_per_face=self.number(d, "rays_per_face", w, default=100, lo=1, integer=True),
                             fluxes_on=self.string(d, "fluxes_on", w, default="detailed",
                                                   choices=("detailed", "super_faces")),
                             steady=self.string(d, "steady", w, default="average", choices=("average", "positions")))
