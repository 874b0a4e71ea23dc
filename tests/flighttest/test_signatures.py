"""The residual's signature components (`flighttest.signatures`) against
answers known by construction: a sinusoid's phase and a known tracker delay,
a drogue pushed just before contact, a hose bent by a parabola, a record
against itself; and the floors against the scatter they stand for."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from flighttest import make_record
from flighttest.residual import SHAPE_BIN_M, observe, residual, segment_of
from flighttest.signatures import (BOW_EARLY_S, BOW_LATE_S, CHANNEL, CURVE_STRIDE_M, LogSignatures, _phase_log,
                                   components, phasor, scatter)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_residual import LOG_OF_KIND, _log, _observed  # noqa: E402  (the flight logs, read and observed once)

EXACT = 1e-9     # equal inputs through the same arithmetic, and sums of ~1e3 terms of ~10 m


def _sig(R):
    return R.channel == CHANNEL


def _with(rec, topic, df):
    topics = dict(rec.topics)
    topics[topic] = df
    return make_record(rec.info, topics, rec.start_time_ns)


@settings(max_examples=30, deadline=None)
@given(A=st.floats(0.05, 2.0), phi=st.floats(-3.0, 3.0), f=st.floats(0.2, 1.5), c=st.floats(-5, 5))
def test_the_phasor_of_a_sampled_sinusoid_is_its_amplitude_and_phase(A, phi, f, c):
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0.0, 20.0, 400))
    amp, ph, _ = phasor(t, c + A * np.cos(2 * math.pi * f * t + phi), f, 0.0)
    assert_allclose(amp, A, rtol=1e-9)
    assert_allclose(math.remainder(ph - phi, 2 * math.pi), 0.0, atol=1e-9)


def test_the_floors_are_the_scatter_they_stand_for():
    """`scatter` of white noise is its std; the phasor's phase error is the
    spread of phases fitted to repeated noisy samples (400 trials: the
    spread's own relative error is 1/sqrt(2 x 400) = 3.5 %, 4 of them allowed)."""
    rng = np.random.default_rng(1)
    sigma, f, A = 0.02, 0.5, 0.3
    t = np.arange(0.0, 12.0, 1 / 30)
    noise = rng.normal(0.0, sigma, (400, len(t)))
    clean = A * np.cos(2 * math.pi * f * t)
    # 360 samples: the std of second differences (correlated neighbours) within
    # about 3/sqrt(360) = 16 % at three sigma; the sinusoid adds A (w dt)^2 / sqrt 6 = 0.5 %
    assert_allclose([scatter(clean + n) for n in noise[:20]], sigma, rtol=3 / math.sqrt(360))
    fits = np.array([phasor(t, clean + n, f, sigma)[1:] for n in noise])
    assert_allclose(np.std(fits[:, 0]), np.mean(fits[:, 1]), rtol=4 / math.sqrt(800))


REALISATIONS = 60   # noise draws per drawn (tau, f, A): 2 segments each, 120 z-scores per delay


@settings(max_examples=6, deadline=None)
@given(tau=st.floats(-0.35, 0.35), f=st.floats(0.3, 1.0), A=st.floats(0.1, 1.0), seed=st.integers(0, 2 ** 20))
def test_a_known_tracker_delay_gives_the_phase_component_its_value_within_its_floor(tau, f, A, seed):
    """A tracker stamping the drogue tau late against a simulation without
    the delay: the phase component is -2 pi f tau A (the lag times the drogue's
    velocity amplitude); the delay applied, zero. Over many noise draws the
    component's error over its floor is a standard normal: mean 0 within
    4 / sqrt(n) (n = 120 z-scores), spread 1 within 4 x its relative error
    1 / sqrt(2 n) = 6.5 %. (A bound of 3 floors on each single draw fails by
    chance once in some 370 draws, and hypothesis makes hundreds.)"""
    rng = np.random.default_rng(seed)
    w = 2 * math.pi * f
    t = np.arange(0.0, 16.0, 1 / 30)
    tow_t = np.arange(0.0, 16.0, 0.01)
    sim_t = np.arange(0.0, 16.0, 0.01)
    sim_xyz = np.zeros((len(sim_t), 3))
    sim_xyz[:, 2] = A * np.cos(w * sim_t + 0.7)
    clean_tow = (tow_t, 0.2 * np.cos(w * tow_t))
    z = {0.0: [], tau: []}
    for _ in range(REALISATIONS):
        tow_z = 0.2 * np.cos(w * tow_t) + rng.normal(0, 0.003, len(tow_t))
        drogue = A * np.cos(w * (t - tau) + 0.7) + rng.normal(0, 0.015, len(t))
        log_phase = _phase_log(t, drogue, tow_t, tow_z, (0.0, 16.0), f, segment_of)
        assert len(log_phase) == 2
        sig = LogSignatures(phase=tuple(log_phase))
        for delay, expect in ((0.0, -w * tau * A), (tau, 0.0)):
            out = components(sig, t, sim_t, sim_xyz, clean_tow, None, delay, segment_of)
            r, floor = np.array([o[0] for o in out]), np.array([o[1] for o in out])
            assert all(o[5].startswith("tracker phase") for o in out)
            # the floor is the phase's; the fitted amplitude's relative error (the
            # same size, sigma sqrt(2/N) / A) adds floor x |phase difference|
            z[delay] += list((r - expect) / (floor * math.hypot(1.0, expect / A)))
    for delay, zs in z.items():
        n = len(zs)
        assert abs(np.mean(zs)) <= 4 / math.sqrt(n), (delay, np.mean(zs))
        assert_allclose(np.std(zs), 1.0, rtol=4 / math.sqrt(2 * n), err_msg=f"delay {delay}")


@pytest.mark.parametrize("kind", sorted(LOG_OF_KIND))
def test_every_kind_has_signature_components_and_a_record_against_itself_gives_zero(kind):
    R = residual(_observed(kind), _log(kind))
    s = _sig(R)
    assert s.sum() >= 2
    assert_allclose(R.r[s], 0.0, atol=EXACT)
    assert np.all(R.floor[s] > 0)
    assert len(residual(_observed(kind), _log(kind), signatures=False).r) == len(R.r) - s.sum()


def test_a_doublet_tracker_shifted_by_its_delay_gives_zero_signature():
    """The log's fixes stamped tau late, compared with the unshifted record at
    `delay_s` = tau: the same samples at the same stamps on both sides."""
    rec, tau = _log("pitch_doublet"), 0.2
    ors = rec.topics["/ors/drogue"].copy()
    ors.index = pd.Index(ors.index.to_numpy(float) + tau, name=ors.index.name)
    shifted = _with(rec, "/ors/drogue", ors)
    ob = observe(shifted)
    R0, R = residual(ob, rec), residual(ob, rec, delay_s=tau)
    assert _sig(R).sum() >= 1
    assert_allclose(R.r[_sig(R)], 0.0, atol=EXACT)
    assert np.all(np.abs(R0.r[_sig(R0)]) > 3 * R0.floor[_sig(R0)])   # and seen without it


def test_a_drogue_pushed_just_before_contact_is_the_bow_wave_component():
    rec = _log("engagement")
    tc, _ = rec.contact_events()
    ors = rec.topics["/ors/drogue"].copy()
    t = ors.index.to_numpy(float)
    late = (t >= tc - BOW_LATE_S[0]) & (t < tc - BOW_LATE_S[1])
    ors.loc[late, "y_m"] += 0.15
    ors.loc[late, "z_m"] += 0.25
    R = residual(_observed("engagement"), _with(rec, "/ors/drogue", ors))
    bow = R.band.astype(str)
    for c, d in (("y", 0.15), ("z", 0.25)):
        k = bow == f"bow wave: drogue {c} growth before contact"
        assert_allclose(R.r[k], -d, atol=EXACT)
    # a steady offset over both windows is no bow wave
    both = (t >= tc - BOW_EARLY_S[0]) & (t < tc)
    ors = rec.topics["/ors/drogue"].copy()
    ors.loc[both, "z_m"] += 0.3
    R = residual(_observed("engagement"), _with(rec, "/ors/drogue", ors))
    assert_allclose(R.r[np.char.startswith(R.band.astype(str), "bow wave")], 0.0, atol=EXACT)


@given(k=st.floats(-0.01, 0.01), a=st.floats(-0.2, 0.2), dz=st.floats(-1.0, 1.0))
@settings(max_examples=15, deadline=None)
def test_a_hose_bent_by_a_parabola_changes_the_curvature_by_its_second_difference(k, a, dz):
    """The simulated hose z + dz + a x + k x^2: every curvature component is
    minus the parabola's second difference, -2 k S^2; a tilted or raised hose
    adds nothing."""
    rec = _log("trail")
    h = rec.topics["/video/hose"].copy()
    h["z_m"] = h["z_m"] + dz + a * h["x_m"] + k * h["x_m"] ** 2
    R = residual(_observed("trail"), _with(rec, "/video/hose", h))
    curve = np.char.startswith(R.band.astype(str), "hose curvature")
    assert curve.sum() >= 2
    # both lines are mean shapes in 1 m bins (h): a bin's mean of k x^2 exceeds k
    # (its mean x)^2 by k times its x spread (< h^2 / 4), and the linear
    # interpolation between bins errs by at most k h^2 / 4: four such terms in a
    # second difference, 2 |k| h^2 in all (a line passes both exactly)
    assert_allclose(R.r[curve], -2 * k * CURVE_STRIDE_M ** 2, atol=2 * abs(k) * SHAPE_BIN_M ** 2 + EXACT)
