"""The MoorDyn peer benchmark's own helpers (benchmarks/peer_moordyn.py).

MoorDyn is an optional extra: everything here but the last test runs without
it, and that one skips when it is not installed."""
import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def peer():
    spec = importlib.util.spec_from_file_location("peer_moordyn", ROOT / "benchmarks" / "peer_moordyn.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules["peer_moordyn"] = mod      # its dataclass looks itself up there
    spec.loader.exec_module(mod)
    return mod


def test_tow_motion_is_four_seconds_of_sine_then_held(peer):
    t = np.array([-0.1, 0.0, 0.5, 1.0, 3.999, 4.0, 10.0])
    z, vz = peer.tow_motion(t)
    assert_allclose(z, [0.0, 0.0, 0.3, 0.0, 0.3 * math.sin(math.pi * 3.999), 0.0, 0.0], atol=1e-12)
    assert_allclose(vz[[1, 3]], [0.3 * math.pi, -0.3 * math.pi])
    assert vz[0] == 0.0 and vz[5] == 0.0


def test_end_angles_below_the_horizontal(peer):
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, -1.0], [2.0, 1.0, -1.0], [3.0, 1.0, -1.0 + math.sqrt(3)]])
    a_tow, a_end = peer.end_angles_deg(pts)
    assert a_tow == pytest.approx(45.0)
    assert a_end == pytest.approx(-60.0)       # pointing up


@pytest.mark.parametrize("f, zeta", [(0.32, 0.13), (1.1, 0.03), (0.5, 0.35)])
def test_damped_fit_recovers_a_known_ring_down(peer, f, zeta):
    t = np.arange(0.0, 12.0, 0.01)
    wn = 2 * math.pi * f
    wd = wn * math.sqrt(1 - zeta ** 2)
    rng = np.random.default_rng(3)
    y = 0.02 + 0.4 * np.exp(-zeta * wn * t) * np.cos(wd * t + 0.7) + 1e-4 * rng.standard_normal(len(t))
    f_fit, zeta_fit, resid = peer.damped_fit(t + 4.5, y)
    assert f_fit == pytest.approx(f, rel=1e-3)
    assert zeta_fit == pytest.approx(zeta, abs=2e-3)
    assert resid < 0.01


def test_free_response_skips_the_stop_transient(peer):
    # a ring-down that starts at the stop, with a different fast wiggle in the first half second
    t = np.arange(0.0, 16.0, 0.01)
    wn = 2 * math.pi * 0.3
    z = np.where(t >= 4.0, np.exp(-0.1 * wn * (t - 4.0)) * np.cos(wn * (t - 4.0) * math.sqrt(0.99)), 0.0)
    z += np.where((t >= 4.0) & (t < 4.5), 0.3 * np.sin(40 * t), 0.0)
    f, zeta, _ = peer.free_response(t, z)
    assert f == pytest.approx(0.3, rel=1e-3)
    assert zeta == pytest.approx(0.1, abs=2e-3)


def test_damped_fit_needs_an_oscillation(peer):
    t = np.linspace(0.0, 5.0, 500)
    with pytest.raises(ValueError, match="mean crossings"):
        peer.damped_fit(t, np.exp(-t))


def test_moordyn_input_carries_the_case(peer):
    text = peer.moordyn_input(20, 6.5e-4)
    c = peer.CASE
    lines = text.splitlines()
    hose = next(line.split() for line in lines if line.startswith("hose "))
    d, w, EA, BA, EI, cdn, can, cdt, cat = (float(x) for x in hose[1:])
    assert (d, EA, BA, EI, cdn, cdt) == (c.diameter, c.EA, c.axial_damping, c.EI, c.cdn, c.ca0)
    assert can == 0.0 and cat == 0.0          # no added mass: air
    # MoorDyn subtracts rho A g from the weight: its line mass carries it back
    assert (w - c.rho * math.pi / 4 * c.diameter ** 2) == pytest.approx(c.mass_per_length, rel=1e-12)
    drogue = next(line.split() for line in lines if line.startswith("2 "))
    assert drogue[1] == "Free" and float(drogue[5]) == c.drogue_mass and float(drogue[7]) == c.drogue_cda
    tow = next(line.split() for line in lines if line.startswith("1 "))
    assert tow[1] == "Coupled" and float(tow[4]) == -c.depth      # well under MoorDyn's surface
    line = next(line.split() for line in lines if line.startswith("1     hose"))
    assert float(line[4]) == c.length and int(line[5]) == 20
    opts = {ln.split()[1]: ln.split()[0] for ln in lines[lines.index(next(x for x in lines if "OPTIONS" in x)) + 1:-1]}
    assert float(opts["dtM"]) == 6.5e-4 and opts["tScheme"] == "RK2"
    assert float(opts["rho"]) == c.rho and opts["Currents"] == "1"
    assert float(opts["WtrDpth"]) > c.depth + c.length


def test_current_profile_is_the_relative_wind_at_every_depth(peer):
    rows = [line.split() for line in peer.current_profile().splitlines()[3:]]
    assert len(rows) == 2
    depths = sorted(float(r[0]) for r in rows)
    assert depths[0] < -peer.CASE.depth - peer.CASE.length and depths[1] == 0.0
    assert all(float(r[1]) == peer.CASE.wind and float(r[2]) == 0.0 and float(r[3]) == 0.0 for r in rows)


def test_our_peer_model_is_the_case(peer):
    m = peer.our_model(20)
    c = peer.CASE
    assert m.hose.mass_per_length == c.mass_per_length
    assert m.drogue.drag_area == pytest.approx(c.drogue_cda)
    assert m.drogue.lift_area == 0.0
    assert m.drogue.cp_aft_of_hinge == m.drogue.link_length == c.link   # drag at the mass: a point
    assert m.air_density == c.rho and m.wind.mean_speed == c.wind
    z = m.tow.at(np.array([1.5, 4.0, 9.0]))[:, 2]
    assert_allclose(z, [-0.3, 0.0, 0.0], atol=1e-9)


def test_moordyn_reads_the_generated_input(peer):
    pytest.importorskip("moordyn")
    h = peer.MoorDynHose(8, 1e-3)
    try:
        p0 = h.drogue_pos()
        h._step(0.0, 0.0, 0.01)
        assert np.all(np.isfinite(h.drogue_pos()))
        assert h.nodes().shape == (9, 3)
        assert p0[0] == pytest.approx(0.99 * peer.CASE.length)
    finally:
        h.close()
