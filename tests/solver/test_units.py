"""Unit conversions: the fixed points that define them."""
import numpy as np
from numpy.testing import assert_allclose

from solver.units import FT, KT, LB, degC_to_K, degF_to_K, K_to_degF


def test_temperature_fixed_points():
    # water freezes at 32 degF = 0 degC = 273.15 K and boils at 212 degF = 100 degC;
    # -40 is the same in both scales. Round-off only: rtol 1e-15.
    assert_allclose(degF_to_K(np.array([32.0, 212.0, -40.0])), [273.15, 373.15, degC_to_K(-40.0)], rtol=1e-15)
    assert_allclose(K_to_degF(degF_to_K(59.0)), 59.0, rtol=1e-15)


def test_length_speed_mass_definitions():
    # 1 nmi = 1852 m = 6076.115... ft; a knot is 1852 m per hour; 1 lb = 0.45359237 kg
    assert_allclose(1852.0 / FT, 6076.115485564304, rtol=1e-15)
    assert_allclose(KT * 3600.0, 1852.0, rtol=1e-15)
    assert_allclose(2.2046226218487757 * LB, 1.0, rtol=1e-15)
