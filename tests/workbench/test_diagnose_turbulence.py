"""Turbulence from its statistics (workbench.diagnosis.turbulence): the
tracker noise and the excess band power on a synthetic record whose drogue
motion is a known random process, sigma and its error on synthetic ensembles,
the model's response linear in sigma, the steady floor's rule, and sigma on
proving-ground logs (independent physics, known truth)."""
from __future__ import annotations

import math
import types
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import lfilter

from flighttest.residual import rms
from workbench.diagnosis.evaluate import record
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import NOISE_FACTOR, Setup
from workbench.diagnosis.turbulence import (MAD_REL_SD, N_SEEDS, SIGMA_REF_MPS, RandomEffect, SigmaEstimate,
                                            _at_fixes, _run, estimate_sigma, log_statistics, statistics_of,
                                            tracker_noise)
from workbench.log_inputs import contact_window

FLIGHT = Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight"
NOISE_SD = np.array([0.025, 0.012, 0.012])     # m, a tracker noisier along its line of sight (x)
GAIN = np.array([0.05, 0.12, 0.10])             # m of drogue motion per m/s of sigma, per axis
HZ, T, TAU = 30.0, 40.0, 0.6                    # tracker rate, record length, the process's time constant


def _lagged(x):
    """`x` through two first-order lags of TAU (a drogue's low-pass)."""
    a = math.exp(-1.0 / (HZ * TAU))
    return lfilter([1.0 - a], [1.0, -a], lfilter([1.0 - a], [1.0, -a], x, axis=0), axis=0)


# the stationary sd of unit white noise through the two lags: impulse response
# (1-a)^2 (k+1) a^k, whose sum of squares is (1-a)^4 (1+a^2) / (1-a^2)^3
_A = math.exp(-1.0 / (HZ * TAU))
PROCESS_SD = math.sqrt((1 - _A) ** 4 * (1 + _A ** 2) / (1 - _A ** 2) ** 3)


def _process(rng, n):
    """A smooth random drogue motion of unit variance per axis: white noise
    through the two lags, started in its stationary state (a long lead-in)."""
    lead = int(20 * TAU * HZ)
    return _lagged(rng.normal(size=(n + lead, 3)))[lead:] / PROCESS_SD


def _record(rng, sigma, n_members=N_SEEDS):
    """Fixes at 30 Hz with 3 % dropouts and a 1 s burst out of view: the log
    (sigma's motion plus white noise), the members (SIGMA_REF_MPS's motion)
    and the log's clean motion."""
    t_all = np.arange(0.0, T, 1.0 / HZ)
    keep = rng.random(len(t_all)) > 0.03
    keep[300:330] = False
    t = t_all[keep]
    clean = sigma * GAIN * _process(rng, len(t_all))[keep]
    xyz = clean + rng.normal(size=clean.shape) * NOISE_SD
    members = [SIGMA_REF_MPS * GAIN * _process(rng, len(t_all))[keep] for _ in range(n_members)]
    return t, xyz, members, clean


def _stats(t, xyz, members):
    zero = np.zeros_like(xyz)
    return statistics_of("synthetic", t, xyz, zero, members, np.zeros((len(members), 4)), np.zeros(4, int))


def test_tracker_noise_is_recovered_from_the_log_within_its_error():
    rng = np.random.default_rng(7)
    t, xyz, _, _ = _record(rng, 1.0, 0)
    sd, n = tracker_noise(t, xyz)
    # the MAD estimate's standard error, 3 of them; the motion (below 2 Hz)
    # adds to the second difference far less than that
    assert_allclose(sd, NOISE_SD, rtol=3 * MAD_REL_SD / math.sqrt(n))


def test_excess_band_power_is_the_clean_motion_s_within_its_stated_error():
    rng = np.random.default_rng(8)
    t, xyz, members, clean = _record(rng, 0.6)
    st = _stats(t, xyz, members)
    e, noise, var = st.excess()
    clean_power = _stats(t, clean, members).d
    # the noise removed is the analytic white noise left in the bins
    assert noise > 0
    assert_allclose(e, float(np.sum(clean_power ** 2)), atol=3 * math.sqrt(var))


def test_sigma_hat_and_its_standard_error_are_calibrated_over_realisations():
    rng = np.random.default_rng(9)
    z = []
    for _ in range(40):
        t, xyz, members, _ = _record(rng, 0.8)
        est = estimate_sigma([_stats(t, xyz, members)])
        assert est.real
        z.append((est.sigma_mps - 0.8) / est.stderr_mps)
    z = np.array(z)
    # 40 realisations: the mean z-score's sd is 1/sqrt(40) = 0.16 (3 of them),
    # the RMS z's about 0.11 (bounds ~3.5 of them about 1)
    assert abs(z.mean()) < 0.5
    assert 0.6 < rms(z) < 1.4


def test_noise_alone_names_no_turbulence():
    rng = np.random.default_rng(10)
    t, xyz, members, _ = _record(rng, 0.0)
    est = estimate_sigma([_stats(t, xyz, members)])
    assert not est.real and est.why


def test_segments_pool_to_the_whole_record():
    rng = np.random.default_rng(11)
    t, xyz, members, _ = _record(rng, 0.5)
    st = _stats(t, xyz, members)
    assert_allclose(st.excess(0)[0] + st.excess(1)[0], st.excess()[0], rtol=1e-12)
    assert_allclose(st.unit_powers(0) + st.unit_powers(1), st.unit_powers(), rtol=1e-12)


@pytest.mark.parametrize("log", ["TR-KDC10-E7", "PD-G3-1", "EN-KDC10-E7"])
def test_the_model_s_drogue_response_is_linear_in_sigma(log):
    path = str(FLIGHT / f"{log}.mcap")
    setup = Setup()
    t = np.linspace(1.0, 20.0, 200)
    y0 = _at_fixes(_run(path, {}, setup), t)
    r = {s: _at_fixes(_run(path, {"turbulence": {"sigma_mps": s, "length_scale_m": 533.4, "seed": 5}}, setup), t) - y0
         for s in (0.25, 0.5, 1.0)}
    # the estimate scales the ensemble's band power by sigma^2: at 1 m/s against
    # 0.5 m/s the power must keep that ratio within 10 % (sigma^2's bias), the
    # probe-held drogue of an engagement included
    power = {s: float(np.mean(r[s] ** 2)) for s in r}
    assert abs(power[1.0] / (4.0 * power[0.5]) - 1.0) < 0.10
    # the drogue in the air: quadratic drag departs from linear by about sigma / U,
    # a few per cent at 1 m/s (the doublet's large motion included); 5 % would bias
    # sigma^2 by 10 %. Held on the probe (an engagement's contact to disconnect)
    # its motion is the coupling's give under the hose's load, which the hinge
    # reaching its stop makes non-smooth: there it is 1 % of the power, a response
    # the power check above holds.
    free = np.ones(len(t), bool)
    if log.startswith("EN-"):
        on, off = contact_window(record(path))
        free = (t < on) | (t > off)
    departure = {s: rms(r[s][free] - 2.0 * r[s / 2][free]) / rms(r[s][free]) for s in (0.5, 1.0)}
    assert departure[1.0] < 0.05
    # ... and the departure is second order: it halves with sigma (0.5; 0.6 leaves the third order room)
    assert departure[0.5] < 0.6 * departure[1.0]


def _cand(effect, gap_before, gap_heldout, score):
    return Candidate(effect, [effect], 1, gap_before=gap_before, gap_after_heldout=gap_heldout, score=score)


def test_a_steady_effect_within_the_turbulence_s_chance_offset_is_not_credited():
    turb = _cand("turbulence", 0.10, 0.09, 0.095)
    small = _cand("steady_wind", 0.10, 0.08, 0.084)     # gain 0.06 m
    large = _cand("drogue_lift", 0.10, 0.02, 0.021)     # gain 0.098 m
    floor = 0.04                                        # NOISE_FACTOR x 0.04 = 0.08 m
    real = SigmaEstimate(1.0, 0.1, 0.1, 0.01, True, "")
    ranked = RandomEffect(turb, real, floor).credit_steady(sorted([turb, small, large], key=lambda c: c.score))
    assert [c.effect for c in ranked] == ["drogue_lift", "turbulence", "steady_wind"]
    assert "by chance" in small.why_not_first and large.why_not_first is None
    assert NOISE_FACTOR * floor > math.sqrt(0.10 ** 2 - 0.08 ** 2)
    # the turbulence real but refused as an event (the everyday air): what is within its
    # chance offset, and the refused turbulence itself, go behind "none"
    small.score, small.why_not_first = 0.084, None
    none = Candidate("none", [], 0, gap_before=0.10, gap_after_heldout=0.10, score=0.10)
    ranked = RandomEffect(turb, real, floor).credit_steady(
        sorted([turb, small, large, none], key=lambda c: c.score), accepted=False)
    assert [c.effect for c in ranked] == ["drogue_lift", "none", "steady_wind", "turbulence"]
    assert "by chance" in small.why_not_first and "air of every flight" in turb.why_not_first
    # no real turbulence: nothing moves
    small.score = 0.084
    unreal = SigmaEstimate(0.1, 0.1, 0.0, 0.01, False, "within noise")
    ranked = RandomEffect(turb, unreal, floor).credit_steady(sorted([turb, small, large], key=lambda c: c.score))
    assert [c.effect for c in ranked] == ["drogue_lift", "steady_wind", "turbulence"]


def _generated(tmp_path, kind, effects, seed):
    from workbench.proving.generate import generate
    path, truth = generate(kind, effects, seed, tmp_path)
    return str(path), truth


def test_sigma_on_a_proving_ground_trail_with_turbulence_and_one_without(tmp_path):
    path, truth = _generated(tmp_path, "trail", ["turbulence"], 12)
    est = estimate_sigma([log_statistics((path, {}, Setup(), 1))])
    assert est.real
    assert abs(est.sigma_mps - truth["params"]["turbulence"]["sigma_mps"]) <= 2 * est.stderr_mps
    # a steady wind: the random motion is the log's light nuisance turbulence, and only that
    path, truth = _generated(tmp_path, "trail", ["steady_wind"], 11)
    est = estimate_sigma([log_statistics((path, {}, Setup(), 1))])
    assert abs(est.sigma_mps - truth["nuisance_turbulence"]["sigma_mps"]) <= 2 * est.stderr_mps


@pytest.mark.slow
def test_the_diagnosis_ranks_turbulence_first_on_a_turbulent_doublet_and_not_on_a_steady_wind_trail(tmp_path):
    from workbench.diagnosis.rank import diagnose_family
    from workbench.parallel import Mapper
    path, truth = _generated(tmp_path, "pitch_doublet", ["turbulence"], 11)
    with Mapper(2) as mapper:
        d = diagnose_family([path], Setup(), mapper)
    top = d.ranking[0]
    assert top.named == ["turbulence"]   # beside the tracked point, model form fitted first
    assert abs(top.params["turbulence"]["sigma_mps"] - truth["params"]["turbulence"]["sigma_mps"]) \
        <= 2 * top.param_stderr["turbulence"]["sigma_mps"]
    assert "turbulence" not in d.not_applicable
    path, truth = _generated(tmp_path, "trail", ["steady_wind"], 11)
    with Mapper(2) as mapper:
        d = diagnose_family([path], Setup(), mapper)
    assert d.ranking[0].named == ["steady_wind"]   # the tracked point, model form, may stand beside it
    assert [c.effect for c in d.ranking].index("turbulence") > 0


class _Base:
    """A baseline residual: components `r` with their noise `floor` and segments."""

    def __init__(self, r, floor, segment):
        self.r, self.floor, self.segment = np.asarray(r, float), np.asarray(floor, float), np.asarray(segment)


def _family(rng, sigma, g=0.1):
    """One synthetic log's statistics with four gap components (two per
    segment) whose members shift them by 0.05 m per m/s, and a baseline of
    components `g` with a 0.005 m noise floor."""
    t, xyz, members, _ = _record(rng, sigma)
    seg = np.array([0, 1, 0, 1])
    shift = 0.05 * np.array([[1, -1, 1, -1]] * len(members)) * rng.choice([-1.0, 1.0], (len(members), 1))
    st = statistics_of("synthetic", t, xyz, np.zeros_like(xyz), members, SIGMA_REF_MPS * shift, seg)
    return st, {"synthetic": _Base([g, -g, g, g], [0.005] * 4, seg)}


def test_held_out_gap_removes_the_random_mean_square_sigma_predicts_and_nothing_unless_real():
    from workbench.diagnosis.fit import TimeBlocks
    from workbench.diagnosis.turbulence import turbulence_candidate
    rng = np.random.default_rng(12)
    st, base = _family(rng, 0.8)
    folds = list(TimeBlocks(2.0).split(["synthetic"]))
    c, est = turbulence_candidate([st], base, folds)
    held = []
    for fold, row in zip(folds, c.folds):
        s2 = estimate_sigma([st], [(0, fold.train[0][1])]).sigma_mps ** 2
        # each held-out component's mean square 0.1^2, the random share sigma^2 0.05^2
        held.append(math.sqrt(max(0.1 ** 2 - s2 * 0.05 ** 2, 0.005 ** 2)))
        assert_allclose(row["gap_heldout"], held[-1], rtol=1e-12)
    assert_allclose(c.gap_after_heldout, rms(held), rtol=1e-12)
    assert c.params["turbulence"]["sigma_mps"] == est.sigma_mps and est.real
    # noise alone: it explains nothing, the held-out gap is the baseline's
    st, base = _family(rng, 0.0)
    c, est = turbulence_candidate([st], base, folds)
    assert not est.real
    assert_allclose(c.gap_after_heldout, 0.1, rtol=1e-12)
    assert "no random motion" in c.why_not_first


def test_statistics_measured_again_about_a_set_that_takes_up_a_transient_leave_the_air_s_sigma():
    # The chance yardstick is the random motion the larger set leaves (an F-test's denominator):
    # a ring-down the deterministic run misses (a gust's, as much band power as the air's) is in
    # sigma_hat (held above 1.3 x the air's 0.5 m/s, over 20 realisations); about a run that
    # carries it, the statistics are the air's again (held to 15 %, twice one realisation's
    # scatter of about 0.07 over 0.5), and about the run they were measured with, bit for bit
    # the same
    rng = np.random.default_rng(14)
    pooled, about = [], []
    for _ in range(20):
        t, xyz, members, _ = _record(rng, 0.5)
        ring = np.where((t > 21.0) & (t < 26.0), np.exp(-(t - 21.0) / 1.5) * np.sin(2 * np.pi * (t - 21.0)), 0.0)
        transient = 0.6 * ring[:, None] * np.array([0.3, 1.0, 1.0])
        st = _stats(t, xyz + transient, members)
        pooled.append(estimate_sigma([st]).sigma_mps)
        about.append(estimate_sigma([st.about(transient)]).sigma_mps)
        again = st.about(np.zeros_like(xyz))
        assert_allclose(again.d, st.d, rtol=0, atol=0)
        assert_allclose(again.response, st.response, rtol=0, atol=0)
    assert np.median(pooled) > 1.3 * 0.5
    assert abs(np.median(about) - 0.5) < 0.15 * 0.5


def test_the_chance_offset_is_scaled_to_the_random_motion_the_larger_set_leaves(monkeypatch):
    # `sigma_under`: the statistics measured again about a candidate's own time run (stubbed
    # here: the log's ring-down for a gust, nothing for a steady wind), at most sigma_hat, one
    # run per log and parameter set; the chance offset along a change's pattern scales with it
    import workbench.diagnosis.turbulence as TURB
    from workbench.errors import SimulationFailed
    rng = np.random.default_rng(15)
    t, xyz, members, _ = _record(rng, 0.5)
    ring = np.where((t > 21.0) & (t < 26.0), np.exp(-(t - 21.0) / 1.5) * np.sin(2 * np.pi * (t - 21.0)), 0.0)
    transient = 0.6 * ring[:, None] * np.array([0.3, 1.0, 1.0])
    st = _stats(t, xyz + transient, members)
    est = estimate_sigma([st])
    runs = []

    def run(path, effects, setup):
        runs.append(effects)
        if "hose_drag" in effects:
            raise SimulationFailed(path, effects, RuntimeError("diverged"))
        return transient if "gust" in effects else np.zeros_like(xyz)
    monkeypatch.setattr(TURB, "_run", run)
    monkeypatch.setattr(TURB, "_at_fixes", lambda sim, fix_t: sim)
    gust = Candidate("gust", ["gust"], 2, params={"gust": {"vertical_mps": 2.0, "start_s": 21.0}})
    wind = Candidate("steady_wind", ["steady_wind"], 2, params={"steady_wind": {"vertical_mps": 1.0}})
    failed = Candidate("hose_drag", ["hose_drag"], 1, params={"hose_drag": {"crossflow": 1.5}})
    turb = Candidate("turbulence", ["turbulence"], 1, params={"turbulence": {"sigma_mps": 0.6}})
    shift = 0.01 * rng.normal(size=(N_SEEDS, 6))
    base = [types.SimpleNamespace(r=np.zeros(6))]
    effect = RandomEffect(turb, est, 0.01, shift=shift, baseline=base, stats=[st], setup=Setup())
    under = effect.sigma_under(gust)
    assert_allclose(under, estimate_sigma([st.about(transient)]).sigma_mps, rtol=1e-12)
    assert under < 0.8 * est.sigma_mps
    # a steady effect's run is the statistics' own: sigma_hat; a failed run, turbulence, none: sigma_hat
    for c in (wind, failed, turb, None):
        assert_allclose(effect.sigma_under(c), est.sigma_mps, rtol=1e-12)
    effect.sigma_under(gust)
    assert len(runs) == 3      # gust, wind, the failed hose drag: each parameter set run once
    # the chance offset of a change to the gust is the one at sigma_hat times under / sigma_hat
    gust.held_out = [types.SimpleNamespace(r=np.arange(6.0))]
    plain = RandomEffect(turb, est, 0.01, shift=shift, baseline=base)
    assert_allclose(effect.chance_offset(None, gust), plain.chance_offset(None, gust) * under / est.sigma_mps,
                    rtol=1e-12)
