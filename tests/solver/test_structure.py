"""Structural verification against analytic references (no air)."""
import numpy as np
from numpy.testing import assert_allclose

from solver.drogue import DrogueProperties
from solver.integrate import simulate
from solver.model import Clamp, EndConstraint, Model, Trajectory

from tests.solver.helpers import crossings_frequency, straight_state

NO_GRAVITY = (0.0, 0.0, 0.0)


def cantilever_frequency(light_hose, n, EI=50.0, mu=3.0, L=1.5):
    hose = light_hose(length=L, EI=EI, EA=1e5, mu=mu)
    m = Model(hose, n, air_density=0.0, kinematic_viscosity=1.5e-5, clamp=Clamp((1, 0, 0)),
              gravity=NO_GRAVITY)
    s0 = straight_state(n, L)
    x = s0.pos[:, 0]
    s0.pos[:, 2] = 1e-3 * (1 - np.cos(np.pi * x / (2 * L)))   # close to the first mode
    f_eb = 3.516 / (2 * np.pi) * np.sqrt(EI / (mu * L ** 4))
    r = simulate(m, 10 / f_eb, s0, record_dt=1 / (200 * f_eb))
    return crossings_frequency(r.t, r.hose_xyz[:, n, 2]), f_eb


def test_cantilever_converges_to_euler_bernoulli(light_hose):
    ns = [4, 8, 16, 32]
    errs = []
    for n in ns:
        f, f_eb = cantilever_frequency(light_hose, n)
        errs.append(abs(f / f_eb - 1))
    # measured: 4.9 %, 1.3 %, 0.28 %, 0.10 % -- second order in the element length, as
    # the lumped rotary inertia (m l^2/4 against m l^2/12) and the joint stencil predict.
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.diff(errs) < 0)
    assert np.mean(rates) > 1.7, f"convergence rate {rates}"
    assert errs[-1] < 2e-3


def test_string_wave_speed(light_hose):
    # Both ends held, EI negligible: a string. Fundamental f1 = c / (2 L), c = sqrt(T/mu').
    L, n, mu, EA, strain = 10.0, 80, 1.0, 1e5, 0.01
    hose = light_hose(length=L, EI=1e-6, EA=EA, mu=mu)
    end = Trajectory.fixed((L * (1 + strain), 0.0, 0.0))
    m = Model(hose, n, air_density=0.0, kinematic_viscosity=1.5e-5, gravity=NO_GRAVITY,
              end=EndConstraint(end, t_on=-1.0))
    s0 = straight_state(n, L * (1 + strain))
    s0.rest[:] = L / n
    s0.reel_length = L
    x = s0.pos[:, 0]
    s0.pos[:, 2] = 1e-3 * np.sin(np.pi * x / x[-1])
    T = EA * strain
    c = np.sqrt(T / (mu / (1 + strain)))
    f1 = c / (2 * L * (1 + strain))
    r = simulate(m, 8 / f1, s0, record_dt=1 / (100 * f1))
    f = crossings_frequency(r.t, r.hose_xyz[:, n // 2, 2])
    # discrete string: f = f1 * sin(pi/2n)/(pi/2n) -> 1e-4 low at n = 80; 2 % is the bound
    assert_allclose(2 * L * (1 + strain) * f, c, rtol=0.02)
    assert_allclose(2 * L * (1 + strain) * f, c, rtol=2e-3)


def test_energy_conserved_without_damping_or_air(light_hose):
    # A hose with a tip mass swings down from horizontal under gravity; no dissipation.
    hose = light_hose(length=5.0, EI=20.0, EA=2e5, mu=2.0)
    m = Model(hose, 20, air_density=0.0, kinematic_viscosity=1.5e-5, tip_mass=5.0)
    s0 = straight_state(20, 5.0, direction=(1.0, 0.0, 0.2))
    r = simulate(m, 10.0, s0, dt=5e-5, record_dt=0.01)
    e = r.energy_total
    scale = np.max(r.energy_kinetic)   # the energy exchanged between kinetic and potential
    drift = np.max(np.abs(e - e[0])) / scale
    assert drift < 1e-4, drift
    assert np.max(r.energy_kinetic) > 100.0   # it really swung


def test_hinge_free_inside_play_and_stopped_beyond(light_hose):
    # Hose clamped and stiff, drogue spun about the hinge in a plane with no loads.
    hose = light_hose(length=1.0, EI=1e4, EA=1e6, mu=2.0)
    d = DrogueProperties(mass=10.0, diameter=0.5, cd=0.8, cp_aft_of_hinge=0.4, cg_aft_of_hinge=0.4)
    m = Model(hose, 2, air_density=0.0, kinematic_viscosity=1.5e-5, drogue=d,
              clamp=Clamp((1, 0, 0), stiffness_factor=1.0), gravity=NO_GRAVITY)
    s0 = straight_state(2, 1.0, extra=(0.4, 0.0, 0.0))
    omega = 0.5   # rad/s about y: the drogue swings in the x-z plane
    s0.vel[-1] = [0.0, 0.0, -omega * 0.4]
    r = simulate(m, 3.0, s0, record_dt=0.002)
    ang = r.hinge_angle_deg
    free = ang < 22.0
    # inside the play the drogue coasts: the angle grows at the initial rate
    t_free = r.t[free & (r.t < 0.5)]
    rate = np.polyfit(t_free, ang[free & (r.t < 0.5)], 1)[0]
    assert_allclose(np.radians(rate), omega, rtol=0.02)
    # the stop holds it: overshoot from kinetic energy 1/2 I w^2 = 1/2 k dth^2
    I = 10.0 * 0.4 ** 2
    overshoot = np.degrees(omega * np.sqrt(I / d.hinge_stop_stiffness))
    assert np.max(ang) < 22.5 + 1.5 * overshoot + 0.05
    assert np.max(ang) > 22.5
    # and it came back into the play
    assert ang[-1] < 22.5
