"""What the model cannot reproduce does not count as evidence: the
reproducibility weights of the diagnosis's residual (`evaluate`), the
turbulence test's bins (`turbulence.statistics_of`), the prior under the
turbulence runs, and a one-log candidate's parameters fitting the whole log."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from flighttest.residual import Residual
from workbench.diagnosis import selftest as S
from workbench.diagnosis.evaluate import (evaluate, gap, pooled_spread, reproducibility_weight, reproducibility_weights,
                                          unweighted)
from workbench.diagnosis.fit import EffectCalibrator
from workbench.diagnosis.score import score_candidate
from workbench.diagnosis.setup import Setup, freeze
from workbench.diagnosis.turbulence import estimate_sigma, log_statistics, statistics_of

FLIGHT = Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight"
EXACT = 1e-12   # the same arithmetic on equal inputs


@settings(max_examples=60, deadline=None)
@given(f=st.lists(st.floats(1e-4, 1.0), min_size=1, max_size=20),
       m=st.lists(st.floats(0.0, 10.0), min_size=20, max_size=20))
def test_a_perfect_model_keeps_the_log_s_floor_where_it_reproduces_and_leaves_the_rest_out(f, m):
    f, m = np.array(f), np.array(m[:len(f)])
    w = reproducibility_weight(f, m)
    kept = m <= f
    assert np.all(w[kept] > 0) and np.all(w[kept] <= 1) and np.all(w[~kept] == 0.0)
    assert np.all(w[m == 0] == 1.0)
    # a perfect model's residual has variance f^2 + m^2; weighted, the log's own f^2
    assert_allclose(w[kept] ** 2 * (f[kept] ** 2 + m[kept] ** 2), f[kept] ** 2, rtol=1e-12)


def _residual(r, channel, t):
    n = len(r)
    return Residual(np.asarray(r, float), np.full(n, 0.01), np.asarray(channel, dtype=object), np.full(n, np.nan),
                    np.full(n, "engaged", dtype=object), np.asarray(t, float), np.zeros(n, int),
                    np.full(n, "band", dtype=object), (np.zeros(0), np.zeros((0, 3))), None, None)


def test_a_departure_its_own_pair_cancels_takes_the_spread_of_its_time_neighbours():
    # channel a: component 3's +/- pair is odd (a chaotic departure still growing in
    # proportion to the change), its later neighbours' pairs are not; channel b spreads nowhere
    t = np.tile(np.arange(6.0), 2)
    channel = ["a"] * 6 + ["b"] * 6
    base = _residual(np.zeros(12), channel, t)
    plus = np.array([0, 0, 0, 0.02, 0.30, 0.10, 0, 0, 0, 0, 0, 0])
    minus = np.array([0, 0, 0, -0.02, -0.10, 0.30, 0, 0, 0, 0, 0, 0])
    m = pooled_spread(base, [plus, minus])
    own = np.sqrt(4.0 / 3.0) * np.abs(0.5 * (plus + minus))     # `irreproducible`, a single pair
    assert_allclose(m[3], own[5], rtol=EXACT)                    # the envelope two steps on
    assert_allclose(m[:2], 0.0, atol=EXACT)                      # more than two steps before: none
    assert_allclose(m[6:], 0.0, atol=EXACT)                      # another channel never pools


@pytest.fixture(scope="module", params=[355781145, 11, 44])
def engagement(request, tmp_path_factory):
    """An own-model engagement: after disconnect the released drogue and the
    slack hose whip, and the model's realisation of that depends on anything.
    Three draws: the measure has to hold for a log, not for one realisation."""
    path, _ = S.generate("engagement", "sensor_lag", request.param, tmp_path_factory.mktemp("eng"))
    return str(path)


def test_an_imperceptible_change_moves_the_diagnosis_s_gap_by_far_less_than_its_floor(engagement):
    setup = Setup()
    floor = gap(unweighted(engagement, {}, setup).floor)
    scales = np.array([0.999, 1.0, 1.001, 1.002])
    weighted = [gap(evaluate(engagement, {"drogue_lift": {"scale": s}}, setup).r) for s in scales]
    # a tenth of the floor: the gap a fit sees is smooth where the raw one
    # jumps. Its trend is the lift's real effect, not a jump: the lift that
    # fits best lies 0.5-1 % off the truth here (0.4-0.5 m of gap per unit
    # scale), and once the prescribed channels stopped ringing the model's
    # hose with their noise the floor fell (0.019 -> 0.011 m on the first
    # draw) below what three steps of that trend add up to. So: one step's
    # trend, and the departures from the trend, each under a tenth
    trend = np.polyfit(scales, weighted, 1)
    assert abs(trend[0]) * 0.001 < 0.1 * floor
    assert np.ptp(weighted - np.polyval(trend, scales)) < 0.1 * floor
    w = reproducibility_weights(engagement, setup)
    R = unweighted(engagement, {}, setup)
    # what the model does not reproduce is left out, and only after the hose
    # slackens: the whipping drogue; the steady trail before contact weighs in full
    assert set(R.phase[w == 0]) <= {"refuelling", "disconnect"}
    assert np.all(w[R.phase == "approach"] > 0.9)
    if "355781145" in engagement:
        # a draw whose whip does not reproduce (a third of its disconnect bins;
        # the other two draws' did while the probe's noise drove the held drogue)
        assert np.min(w[R.phase == "disconnect"]) == 0.0
    # what is left out is left out of the floor the gap is judged against as well
    E = evaluate(engagement, {}, setup)
    assert_allclose(E.floor[w == 0], 0.0, atol=EXACT)
    assert_allclose(E.floor[w > 0], R.floor[w > 0], rtol=EXACT)


def test_one_log_s_parameters_fit_the_whole_log_at_least_as_well_as_either_fold_s(tmp_path):
    # a large G-III doublet with a draggy hose: between two good fold fits the
    # slack hose can fall into another motion
    path, _ = S.generate("pitch_doublet", "hose_drag", 171429434, tmp_path)
    setup = Setup()
    c = score_candidate(([str(path)], ("hose_drag",), setup, None))
    whole = c.gap_after_all_fit_per_log[Path(path).stem]
    for fold in c.folds:
        at_fold = EffectCalibrator(("hose_drag",), setup).set_fitted(fold["params"], [0.0]).score([str(path)])
        assert whole <= at_fold + EXACT
    # and so they reproduce the held-out quality, not a motion neither half shows
    assert whole <= 1.5 * c.gap_after_heldout


def test_the_turbulence_runs_carry_the_setup_s_prior():
    path = str(FLIGHT / "PD-G3-1.mcap")
    prior = {"drogue_lift": {"scale": 0.05}, "hose_drag": {"crossflow": 0.8}}
    with_prior = log_statistics((path, {}, Setup(prior=freeze(prior)), 1))
    explicit = log_statistics((path, prior, Setup(), 1))
    assert_allclose(with_prior.d, explicit.d, atol=EXACT)
    assert_allclose(with_prior.response, explicit.response, atol=EXACT)


def test_bins_the_model_cannot_reproduce_are_left_out_of_the_random_test():
    """A drogue moving at random (sigma 0.5 m/s of a known gain) whose second
    half the deterministic run misses by a large swing, as a whipping hose's
    realisation would: with probes that spread there, sigma is the first
    half's; without them, the swing passes for random air."""
    rng = np.random.default_rng(3)
    hz, T = 30.0, 40.0
    t = np.arange(0.0, T, 1.0 / hz)
    noise = np.array([0.02, 0.01, 0.01])
    gain = np.array([0.05, 0.12, 0.10])

    def motion(scale):   # a smooth random motion: white noise through a 0.5 s lag
        a = math.exp(-1.0 / (hz * 0.5))
        x = np.zeros((len(t), 3))
        e = rng.normal(size=(len(t), 3))
        for i in range(1, len(t)):
            x[i] = a * x[i - 1] + math.sqrt(1 - a * a) * e[i]
        return scale * gain * x
    sigma = 0.5
    swing = np.where(t[:, None] > T / 2, 0.4 * np.sin(2 * math.pi * 0.7 * t)[:, None] * [0.0, 1.0, 1.0], 0.0)
    xyz = motion(sigma) + swing + rng.normal(size=(len(t), 3)) * noise
    members = [motion(1.0) for _ in range(8)]
    probes = [np.where(t[:, None] > T / 2, rng.normal(0.0, 0.2, (len(t), 3)), 0.0) for _ in range(4)]   # +/- pairs
    y0 = np.zeros_like(xyz)
    blind = estimate_sigma([statistics_of("x", t, xyz, y0, members, np.zeros((8, 2)), np.zeros(2, int))])
    kept = statistics_of("x", t, xyz, y0, members, np.zeros((8, 2)), np.zeros(2, int), probes)
    est = estimate_sigma([kept])
    assert np.all(kept.mid <= T / 2 + 0.25)
    assert abs(est.sigma_mps - sigma) <= 2 * est.stderr_mps
    assert blind.sigma_mps > sigma + 2 * blind.stderr_mps
