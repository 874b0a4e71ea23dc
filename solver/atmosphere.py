"""International Standard Atmosphere (ISO 2533 / ICAO Doc 7488) and airspeed conversions.

Valid from sea level to 20 km geopotential altitude (troposphere and the
isothermal lower stratosphere), which covers every refueling envelope.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from solver.units import FT, G0, KT

R_AIR = 287.05287       # J/(kg K), specific gas constant of dry air
GAMMA = 1.4
T0 = 288.15             # K, sea-level temperature
P0 = 101325.0           # Pa, sea-level pressure
RHO0 = P0 / (R_AIR * T0)  # 1.225 kg/m^3
LAPSE = -0.0065         # K/m, troposphere
H_TROPOPAUSE = 11000.0  # m
H_MAX = 20000.0         # m, top of the isothermal layer
SUTHERLAND_C = 110.4    # K
SUTHERLAND_BETA = 1.458e-6  # kg/(m s K^0.5)


@dataclass(frozen=True)
class AtmosphereState:
    altitude_m: float
    temperature: float   # K
    pressure: float      # Pa
    density: float       # kg/m^3
    dynamic_viscosity: float   # Pa s
    speed_of_sound: float      # m/s

    @property
    def kinematic_viscosity(self) -> float:
        return self.dynamic_viscosity / self.density


def isa(altitude_m: float, delta_temperature: float = 0.0) -> AtmosphereState:
    """ISA state at a geopotential altitude, optionally with a temperature offset
    (ISA+dT day: pressure follows the standard profile, density follows from the
    warmer or colder air, as in flight-test practice)."""
    h = float(altitude_m)
    if not (-500.0 <= h <= H_MAX):
        raise ValueError(f"altitude_m={h:g} is outside the ISA model range -500..{H_MAX:g} m")
    if h <= H_TROPOPAUSE:
        t_std = T0 + LAPSE * h
        p = P0 * (t_std / T0) ** (-G0 / (LAPSE * R_AIR))
    else:
        t_trop = T0 + LAPSE * H_TROPOPAUSE
        p_trop = P0 * (t_trop / T0) ** (-G0 / (LAPSE * R_AIR))
        t_std = t_trop
        p = p_trop * np.exp(-G0 * (h - H_TROPOPAUSE) / (R_AIR * t_trop))
    t = t_std + delta_temperature
    rho = p / (R_AIR * t)
    mu = SUTHERLAND_BETA * t ** 1.5 / (t + SUTHERLAND_C)
    a = np.sqrt(GAMMA * R_AIR * t)
    return AtmosphereState(h, t, p, rho, mu, a)


def cas_to_tas(cas: float, altitude_m: float, delta_temperature: float = 0.0) -> float:
    """True airspeed (m/s) from calibrated airspeed (m/s), compressible subsonic flow.

    Impact pressure from CAS at sea-level conditions, then the Mach number at the
    local static pressure (St Venant), then TAS = M a.
    """
    if cas < 0:
        raise ValueError(f"calibrated airspeed {cas:g} m/s is negative")
    st = isa(altitude_m, delta_temperature)
    a0 = np.sqrt(GAMMA * R_AIR * T0)
    qc = P0 * ((1.0 + 0.2 * (cas / a0) ** 2) ** 3.5 - 1.0)
    mach = np.sqrt(5.0 * ((qc / st.pressure + 1.0) ** (2.0 / 7.0) - 1.0))
    if mach >= 1.0:
        raise ValueError(f"calibrated airspeed {cas:g} m/s at {altitude_m:g} m is supersonic")
    return float(mach * st.speed_of_sound)


def kcas_to_tas(kcas: float, altitude_ft: float, delta_temperature: float = 0.0) -> float:
    """True airspeed (m/s) from knots calibrated at a pressure altitude in feet."""
    return cas_to_tas(kcas * KT, altitude_ft * FT, delta_temperature)
