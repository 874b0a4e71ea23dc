"""Linearised chain dynamics (`solver.linear`) against closed-form beam results."""
import math

import numpy as np
import pytest

from solver.hose import HoseProperties
from solver.linear import linearize
from solver.model import Clamp, Model
from solver.statics import solve_static


def test_linear_modes_match_euler_bernoulli_cantilever():
    # no gravity, no air: the chain's first mode against the beam's (the cantilever
    # convergence test of tests/solver: 0.1 % at 32 elements)
    L, EI, mu, eta, n = 1.5, 50.0, 3.0, 0.4, 32
    hose = HoseProperties(length=L, outer_diameter=0.05, inner_diameter=0.0, dry_mass_per_length=mu,
                          EI=EI, EA=1e6, bending_damping=eta)
    m = Model(hose, n, air_density=0.0, kinematic_viscosity=1.5e-5, clamp=Clamp((1, 0, 0)),
              gravity=(0.0, 0.0, 0.0))
    # the default string guess hangs the cantilever straight down: start it straight out
    st = solve_static(m, tol=1e-8, guess=np.outer(np.linspace(0, L, n + 1), [1, 0, 0]))
    f_d, zeta = linearize(m, st).first_mode(2)
    wn = 1.8751 ** 2 * math.sqrt(EI / (mu * L ** 4))
    z_eb = eta * wn / (2 * EI)      # stiffness-proportional damping of the continuum
    assert zeta == pytest.approx(z_eb, rel=5e-3)
    assert f_d == pytest.approx(wn * math.sqrt(1 - z_eb ** 2) / (2 * math.pi), rel=2e-3)
