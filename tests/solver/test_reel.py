"""Reel: drum dynamics (Eq. 12) and conservation of mass and momentum through the reel exit."""
import numpy as np
import pytest
from numpy.testing import assert_allclose

from solver.hose import HoseProperties
from solver.chain import DivergenceError
from solver.integrate import simulate
from solver.model import Model
from solver.reel import ReelProperties
from solver.statics import solve_static

from tests.solver.helpers import straight_state

G = 9.80665


def hanging(reel, mu=0.01, M=50.0, L=5.0, n=10, gravity=(0.0, 0.0, -G), EA=1e5):
    hose = HoseProperties(length=L, outer_diameter=0.01, inner_diameter=0.0, dry_mass_per_length=mu,
                          EI=1e-3, EA=EA, axial_damping=200.0, bending_damping=1e-3,
                          total_length=3 * L)
    return Model(hose, n, air_density=0.0, kinematic_viscosity=1.5e-5, reel=reel, tip_mass=M,
                 gravity=gravity)


def test_drum_spin_up_matches_eq12_for_fixed_radius_and_inertia():
    # A very wide drum keeps R at R0; a hose of 0.01 kg/m changes I by < 1e-4 over the run.
    # Eq. 12 with the load M g at radius R and a constant braking torque:
    #   (I/R^2 + M) L'' = M g - tau / R.
    R, I, M, tau = 0.2, 4.0, 50.0, 60.0
    reel = ReelProperties(mode="drum", drum_radius_empty=R, drum_width=1e9, drum_inertia_empty=I,
                          torque_law="constant_torque", torque=tau)
    m = hanging(reel, M=M, EA=1e7)
    s0 = straight_state(10, 5.0, direction=(0.0, 0.0, -1.0))
    s0 = solve_static(hanging(ReelProperties(), M=M, EA=1e7), guess=s0.pos)
    r = simulate(m, 2.0, s0, record_dt=0.01)
    m_hose = 0.01 * r.reel_length
    I_wound = I + 0.01 * (15.0 - 5.0) * R ** 2    # the 10 m still on the drum
    a = ((M + m_hose[0]) * G - tau / R) / (I_wound / R ** 2 + M + m_hose[0])
    L_an = 5.0 + 0.5 * a * r.t ** 2
    # Differences from the rigid closed form: the hose's axial spring rings with the
    # start-up force step, M a / (EA/L) ~ 3e-5 m; the 0.025 kg of hose paid out adds
    # ~2e-4 of the 150 kg effective mass and takes 1e-3 kg m^2 off the drum: < 5e-4 of
    # the 2.5 m travelled.
    assert_allclose(r.reel_length[-1] - 5.0, L_an[-1] - 5.0, rtol=5e-4)
    assert_allclose(r.reel_length, L_an, atol=1e-3)


@pytest.mark.parametrize("direction", [+1, -1])
def test_payout_conserves_mass_and_momentum(direction):
    # A free hose in space (no gravity, no air) paid out or taken in on a prescribed
    # schedule through several remeshes. Hose outside = mu * L at every record, and the
    # hose's momentum changes only by the tow point's impulse and what crosses the exit.
    L0, n, mu = 5.0, 10, 2.0
    t = np.linspace(0, 3.0, 61)
    L = L0 + direction * 1.5 * (1 - np.cos(np.pi * t / 3.0))
    reel = ReelProperties(mode="prescribed", payout_t=t, payout_length=L)
    hose = HoseProperties(length=L0, outer_diameter=0.02, inner_diameter=0.0, dry_mass_per_length=mu,
                          EI=5.0, EA=1e5, axial_damping=100.0, bending_damping=0.5, total_length=3 * L0)
    m = Model(hose, n, air_density=0.0, kinematic_viscosity=1.5e-5, reel=reel, gravity=(0, 0, 0))
    s0 = straight_state(n, L0, direction=(1.0, 0.0, -0.3))
    r = simulate(m, 3.0, s0, record_dt=0.01)
    assert abs(r.n_hose_elements[-1] - n) >= 4          # it remeshed several times
    b = r.balance
    outside = b[:, 0] + b[:, 1]
    assert_allclose(outside, mu * r.reel_length, rtol=1e-12)
    p = b[:, 2:5]
    flux = b[:, 5:8]
    impulse = b[:, 8:11]
    scale = np.max(np.abs(p)) + 1e-12
    assert_allclose(p - p[0], -(impulse - impulse[0]) + (flux - flux[0]), atol=1e-9 * scale)
    assert scale > 1.0   # the hose really moved


def test_reel_taking_in_the_whole_hose_is_reported():
    t = np.array([0.0, 1.0, 2.0])
    reel = ReelProperties(mode="prescribed", payout_t=t, payout_length=np.array([2.0, 0.3, 0.05]))
    hose = HoseProperties(length=2.0, outer_diameter=0.02, inner_diameter=0.0, dry_mass_per_length=1.0,
                          EI=1.0, EA=1e5, axial_damping=50.0, bending_damping=0.1)
    m = Model(hose, 4, air_density=0.0, kinematic_viscosity=1.5e-5, reel=reel, gravity=(0, 0, 0))
    with pytest.raises(DivergenceError, match=r"t=\d.*reel has taken in"):
        simulate(m, 2.0, straight_state(4, 2.0), record_dt=0.01)


def test_reel_rejects_bad_tables():
    with pytest.raises(ValueError, match="payout_t must increase"):
        ReelProperties(mode="prescribed", payout_t=np.array([0.0, 0.0]), payout_length=np.array([1.0, 1.0]))
    with pytest.raises(ValueError, match="reel mode 'spool'"):
        ReelProperties(mode="spool")
