"""`simulate_case`: where the probe-held drogue is placed at contact."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from flighttest import read_record
from workbench import log_inputs
from workbench.cases import load_case
from workbench.simulate import simulate_case

ROOT = Path(__file__).resolve().parents[2]
E7 = ROOT / "flighttest" / "logs" / "flight" / "EN-KDC10-E7.mcap"
COARSE = {"n_elements": 12}     # the placement does not depend on the discretisation; a run is seconds
TAKE_UP_M = 1.0
EXACT = 1e-12                   # the same arithmetic on equal inputs


@pytest.fixture(scope="module")
def e7():
    return load_case(ROOT / "cases" / "kdc10_engagement7.toml"), read_record(E7)


@pytest.fixture
def reeled_in_before_contact(monkeypatch, e7):
    """Engagement 7's payout with 1 m taken up between 2 and 6 s, 4.4 s
    before contact: the drogue comes forward and settles before the probe
    meets it."""
    _, rec = e7
    logged = log_inputs.payout

    def payout(r):
        t, length = logged(r)
        return t, length - TAKE_UP_M * np.clip((t - 2.0) / 4.0, 0.0, 1.0)
    monkeypatch.setattr(log_inputs, "payout", payout)
    return rec.contact_events()[0]


def test_the_probe_holds_the_drogue_where_it_was_just_before_contact(e7, reeled_in_before_contact):
    case, rec = e7
    t_on = reeled_in_before_contact
    sim = simulate_case(case, rec, variant=COARSE, until=t_on + 0.2, record_dt=0.01)
    res = sim.result
    pre = (res.t >= t_on - log_inputs.PRE_CONTACT_S) & (res.t < t_on)
    settled = np.median(res.end_xyz[pre], axis=0)
    from_start = log_inputs.probe_held_drogue(case, sim.model, rec, sim.static.pos[-1])
    # the held path is the one placed on the steady trail at the start, moved by
    # where the model's drogue got to: the 1 m the reel took up, along the hose
    shift = sim.model.end.path.xyz - from_start.path.xyz
    assert_allclose(shift, np.broadcast_to(shift[0], shift.shape), atol=1e-9)
    assert_allclose(shift[0], settled - sim.static.pos[-1], atol=1e-9)
    assert 0.8 * TAKE_UP_M < np.linalg.norm(shift[0]) < 1.2 * TAKE_UP_M
    # no snap at contact: the held path starts within the log's own pre-contact
    # motion of the drogue the run brought there, not a metre away
    at_contact = np.array([np.interp(t_on, sim.model.end.path.t, sim.model.end.path.xyz[:, c]) for c in range(3)])
    assert np.linalg.norm(at_contact - res.end_xyz[np.searchsorted(res.t, t_on) - 1]) < 0.2 * TAKE_UP_M


def test_where_the_drogue_is_held_does_not_depend_on_one_draw_of_the_turbulence(e7):
    case, rec = e7
    t_on = rec.contact_events()[0]
    paths = [simulate_case(case, rec, variant=COARSE, until=t_on + 0.1,
                           effects={"turbulence": {"sigma_mps": 1.0, "seed": seed}}).model.end.path.xyz
             for seed in (1, 2)]
    assert_allclose(paths[0], paths[1], rtol=EXACT, atol=EXACT)


def test_a_channel_is_cut_where_its_spectrum_meets_its_noise_and_kept_by_content():
    # a 0.4 Hz motion under white sensor noise at 30 Hz: the cut lies between
    # the motion and the ceiling, so the noise above it is gone and the motion stays
    rng = np.random.default_rng(7)
    t = np.arange(0, 60, 1 / 30)
    motion = 0.5 * np.sin(2 * np.pi * 0.4 * t)
    y = np.column_stack([motion + 0.02 * rng.standard_normal(len(t)), 0.02 * rng.standard_normal(len(t))])
    out = log_inputs.measured(t, y, 3.0)
    kept = slice(150, -150)    # away from the zero-phase filter's ends
    # the 0.02 m noise left at the 3 Hz ceiling would be 0.02 sqrt(3 / 15) =
    # 0.009 m; the noise-only axis is cut at the first bin (0.125 Hz), the
    # motion's at 1.0 Hz (the line stands 44 dB over the floor, and its Hann
    # leakage falls to twice the floor 0.6 Hz away): 0.02 sqrt(1 / 15) = 0.005 m
    assert np.std(out[kept, 0] - motion[kept]) < 0.007
    assert np.std(out[kept, 1]) < 0.003
    # the same content gives the same channel, and changing what came back
    # does not change what the next call gets
    out[:] = 0.0
    assert_allclose(log_inputs.measured(t, y, 3.0), log_inputs.measured(t.copy(), y.copy(), 3.0))
    assert np.std(log_inputs.measured(t, y, 3.0)[kept, 0] - motion[kept]) < 0.007
