"""The reel's take-up response (`flighttest.metrics.reel`) and an engagement's
reel track (`flighttest.reel`), on generated tracks and records."""
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st
from numpy.testing import assert_allclose

from flighttest import LogError, make_record
from flighttest.metrics.reel import ReelResponse, fit_reel_response, held_out_misfit, misfit
from flighttest.reel import TRACK_HZ, reel_track

T = np.arange(-2.0, 22.0, 1.0 / TRACK_HZ)


def _closure(t, push_s=1.5, hold_s=14.0, depth_m=2.8):
    """A receiver pushing the drogue in over `push_s`, holding, and backing out as fast."""
    up = np.clip(t / push_s, 0.0, 1.0)
    down = np.clip((hold_s + push_s - t) / push_s, 0.0, 1.0)
    return depth_m * np.minimum(up, down) * (t >= 0.0)


TRUE = ReelResponse(0.3, 4.0, 0.5, 0.95)


def test_a_response_is_recovered_from_its_own_take_up_in_noise():
    rng = np.random.default_rng(7)
    u = _closure(T)
    y = TRUE.take_up(T, u) + rng.normal(0.0, 0.005, T.size)   # the pod's payout noise, ~5 mm
    fit = fit_reel_response([(T, u, y)])
    # measured over four noise seeds: the delay within 1.5 ms, the frequency within 0.35 %, the
    # damping within 0.4 %, the gain within 0.02 %; held here to about five times that
    assert fit.delay_s == pytest.approx(TRUE.delay_s, abs=0.008)
    assert_allclose([fit.natural_frequency_rad_s, fit.damping_ratio], [4.0, 0.5], rtol=0.02)
    assert fit.gain == pytest.approx(TRUE.gain, rel=0.001)
    assert misfit(fit, T, u, y) == pytest.approx(0.005, rel=0.1)


def test_the_take_up_of_a_fast_reel_is_the_delayed_closure_times_its_gain():
    # analytic: w = 40 rad/s settles in ~0.1 s; away from the corners the take-up is g u(t - T)
    r = ReelResponse(0.5, 40.0, 1.0, 0.9)
    u = _closure(T)
    y = r.take_up(T, u)
    steady = (T > 2.5) & (T < 14.0)
    assert_allclose(y[steady], 0.9 * np.interp(T[steady] - 0.5, T, u), atol=1e-3)


def test_a_later_reel_misses_the_reference_by_the_closure_speed_times_the_extra_delay():
    u = _closure(T)
    late = ReelResponse(0.6, 40.0, 1.0, 1.0).take_up(T, u)
    ref = ReelResponse(0.3, 40.0, 1.0, 1.0)
    # analytic: a 0.3 s shift of ramps at 2.8 / 1.5 m/s leaves 0.56 m for 1.5 s at each of the
    # two ramps of a 24 s track, less the corners: RMS 0.56 sqrt(3 / 24) = 0.198 m
    assert misfit(ref, T, u, late) == pytest.approx(0.56 * math.sqrt(3.0 / 24.0), rel=0.05)


def test_the_everyday_misfit_is_held_out_and_the_fit_is_joint():
    rng = np.random.default_rng(1)
    tracks = []
    for depth in (2.6, 2.9, 3.1):
        u = _closure(T, depth_m=depth)
        tracks.append((T, u, TRUE.take_up(T, u) + rng.normal(0.0, 0.01, T.size)))
    whole, everyday = held_out_misfit(tracks)
    assert_allclose(whole.as_vector(), TRUE.as_vector(), rtol=0.03, atol=0.01)
    assert everyday == pytest.approx(0.01, rel=0.15)          # the noise, every track explained alike
    one, own = held_out_misfit(tracks[:1])
    assert own == pytest.approx(misfit(one, *tracks[0]))


def _engagement(tc, td, delay, rng, drop=()):
    t_r = np.arange(0.0, td + 6.0, 0.02)
    t_p = np.arange(0.0, td + 6.0, 1 / 30)
    u_p = _closure(t_p - tc, hold_s=td - tc - 1.5)
    x_p = -3.0 - u_p + rng.normal(0.0, 0.003, t_p.size)
    grid = np.arange(0.0, td + 6.0, 0.01)
    take = ReelResponse(delay, 5.0, 0.6, 1.0).take_up(grid, _closure(grid - tc, hold_s=td - tc - 1.5))
    length = 25.0 - np.interp(t_r, grid, take) + rng.normal(0.0, 0.004, t_r.size)
    length[list(drop)] = np.nan
    topics = {
        "/reel/hose_out": pd.DataFrame({"length_m": length}, index=pd.Index(t_r, name="t_s")),
        "/receiver/probe": pd.DataFrame({"x_m": x_p, "y_m": 0.0 * x_p, "z_m": 0.0 * x_p},
                                        index=pd.Index(t_p, name="t_s")),
        "/probe/events": pd.DataFrame({"event": ["contact", "disconnect"]}, index=pd.Index([tc, td], name="t_s")),
    }
    info = {"schema_version": "1", "test_id": "EN-GEN", "test_kind": "engagement", "hose": "kdc10_pod",
            "reel": "kdc10_pod"}
    return make_record(info, topics, 0)


@settings(max_examples=15, deadline=None)
@given(tc=st.floats(3.0, 8.0), length_s=st.floats(10.0, 20.0), delay=st.floats(0.0, 0.6),
       seed=st.integers(0, 2 ** 16))
def test_a_records_reel_track_gives_back_the_reels_delay(tc, length_s, delay, seed):
    rng = np.random.default_rng(seed)
    rec = _engagement(tc, tc + length_s, delay, rng, drop=rng.integers(0, 500, 20))
    tr = reel_track(rec)
    assert tr.t[0] == pytest.approx(-2.0, abs=1 / TRACK_HZ) and tr.t[-1] >= length_s
    assert np.all(tr.closure[tr.t < 0] == 0.0) and tr.closure.max() == pytest.approx(2.8, abs=0.02)
    # a 4 mm payout noise and 3 mm probe noise: the delay to a fraction of the 40 ms sample
    assert fit_reel_response([tr.arrays()]).delay_s == pytest.approx(delay, abs=0.03)


def test_a_record_without_a_disconnect_or_a_payout_around_the_contact_is_refused():
    rng = np.random.default_rng(0)
    rec = _engagement(5.0, 20.0, 0.2, rng)
    no_disconnect = make_record(rec.info.raw, {**rec.topics, "/probe/events": pd.DataFrame(
        {"event": ["contact"]}, index=pd.Index([5.0], name="t_s"))}, 0)
    with pytest.raises(LogError, match="/probe/events"):
        reel_track(no_disconnect)
    late = rec.topic("/reel/hose_out")
    late = late[late.index > 4.9]
    with pytest.raises(LogError, match="/reel/hose_out"):
        reel_track(make_record(rec.info.raw, {**rec.topics, "/reel/hose_out": late}, 0))
