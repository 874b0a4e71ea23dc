"""ISA against the tabulated ICAO standard atmosphere, by geopotential altitude."""
import numpy as np
import pytest
from numpy.testing import assert_allclose

from solver.atmosphere import cas_to_tas, isa, kcas_to_tas

# altitude m, T K, p Pa, rho kg/m^3, mu Pa s — table values printed to 4-5 digits
TABLE = [
    (0.0, 288.15, 101325.0, 1.2250, 1.7894e-5),
    (1000.0, 281.65, 89874.6, 1.11164, 1.7579e-5),
    (3000.0, 268.65, 70108.5, 0.90912, 1.6938e-5),
    (5000.0, 255.65, 54019.9, 0.73612, 1.6282e-5),
    (8000.0, 236.15, 35599.8, 0.52517, 1.5268e-5),
    (11000.0, 216.65, 22632.1, 0.36392, 1.4216e-5),
    (15000.0, 216.65, 12044.6, 0.19367, 1.4216e-5),
    (20000.0, 216.65, 5474.89, 0.088035, 1.4216e-5),
]


@pytest.mark.parametrize("h,t,p,rho,mu", TABLE)
def test_isa_matches_table(h, t, p, rho, mu):
    st = isa(h)
    # the tables print 5 significant figures: 2e-4 relative covers their rounding
    assert_allclose(st.temperature, t, rtol=2e-4)
    assert_allclose(st.pressure, p, rtol=2e-4)
    assert_allclose(st.density, rho, rtol=2e-4)
    assert_allclose(st.dynamic_viscosity, mu, rtol=5e-4)


def test_cas_equals_tas_at_sea_level():
    assert_allclose(cas_to_tas(100.0, 0.0), 100.0, rtol=1e-9)


def test_low_speed_limit_is_equivalent_airspeed_ratio():
    # At 10 m/s (M ~ 0.03) the compressibility terms of the impact pressure are of order
    # M^2/8 ~ 1e-4, so CAS->TAS reduces to TAS = CAS sqrt(rho0/rho) to that order.
    st = isa(4572.0)
    assert_allclose(cas_to_tas(10.0, 4572.0), 10.0 * np.sqrt(1.225 / st.density), rtol=2e-4)


def test_compressible_round_trip():
    # Independent inverse: impact pressure from TAS at altitude, then CAS from it at sea level.
    st = isa(4572.0)
    tas = kcas_to_tas(254.0, 15000.0)
    mach = tas / st.speed_of_sound
    qc = st.pressure * ((1 + 0.2 * mach**2) ** 3.5 - 1)
    a0 = np.sqrt(1.4 * 287.05287 * 288.15)
    cas = a0 * np.sqrt(5 * ((qc / 101325.0 + 1) ** (2 / 7) - 1))
    assert_allclose(cas, 254.0 * 1852 / 3600, rtol=1e-10)
    assert 150.0 < tas < 170.0  # 254 KCAS at 15000 ft is roughly 315 kt TAS


def test_out_of_range_altitude_is_an_error():
    with pytest.raises(ValueError, match="altitude_m"):
        isa(30000.0)


def test_hotter_day_is_thinner_air():
    assert isa(3000.0, 15.0).density < isa(3000.0).density
    assert np.isclose(isa(3000.0, 15.0).pressure, isa(3000.0).pressure)
