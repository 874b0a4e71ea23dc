import pytest

from solver.hose import HoseProperties


@pytest.fixture
def light_hose():
    def make(length=10.0, EI=1.0, EA=1e5, mu=1.0, **kw):
        return HoseProperties(length=length, outer_diameter=0.05, inner_diameter=0.0,
                              dry_mass_per_length=mu, EI=EI, EA=EA, **kw)
    return make
