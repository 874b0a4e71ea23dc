"""Unit constants and conversions: the one place the project's exact factors live.

Everything inside the solver is SI; test cards and flight logs speak feet, knots,
pounds and degrees Fahrenheit. The factors are exact by definition (international
foot and pound, 1959; nautical mile 1852 m; standard gravity, CGPM 1901).
"""
from __future__ import annotations

FT = 0.3048                 # m per international foot
KT = 1852.0 / 3600.0        # m/s per knot (nautical mile per hour)
LB = 0.45359237             # kg per pound (mass)
G0 = 9.80665                # m/s^2, standard gravity
ZERO_C = 273.15             # K at 0 degC


def degF_to_K(t_F):
    """Temperature in degrees Fahrenheit to kelvin (numbers or arrays)."""
    return (t_F - 32.0) * 5.0 / 9.0 + ZERO_C


def K_to_degF(t_K):
    """Temperature in kelvin to degrees Fahrenheit (numbers or arrays)."""
    return (t_K - ZERO_C) * 9.0 / 5.0 + 32.0


def degC_to_K(t_C):
    """Temperature in degrees Celsius to kelvin (numbers or arrays)."""
    return t_C + ZERO_C
