"""analyze_record: known answers on synthetic records, consistency on the shipped logs."""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from scipy import signal

from flighttest import analyze_record, make_record, read_record
from flighttest.analyze import summarize_by_setpoint

LOGS = Path(__file__).resolve().parents[2] / "flighttest" / "logs"
ALL_LOGS = sorted(LOGS.glob("*/*.mcap"))
START = 1_700_000_000_000_000_000


def frame(t, **cols):
    return pd.DataFrame(cols, index=pd.Index(np.asarray(t, float), name="t_s"))


def meta(kind, **extra):
    return {"schema_version": "1", "test_id": f"SYN-{kind}", "test_kind": kind,
            "hose": "fa18_buddy", **{k: str(v) for k, v in extra.items()}}


def temperature_topic(duration, t1, t2):
    t = np.arange(0.3, duration, 1.0)
    return frame(t, t1_F=np.full(len(t), t1), t2_F=np.full(len(t), t2))


# ------------------------------------------------------------ synthetic records

def synthetic_bending(f_hz=2.1, zeta=0.05, seed=0):
    rng = np.random.default_rng(seed)
    fs, dur, t_rel = 1000.0, 11.0, 1.3
    t = np.arange(int(dur * fs)) / fs
    y = 0.03 * rng.standard_normal(len(t))
    hold = t < t_rel
    y[hold] += 0.4 * np.sin(2 * math.pi * 0.9 * t[hold])             # hand on the rod
    tt = np.maximum(t - t_rel, 0.0)
    after = t >= t_rel
    wn = 2 * math.pi * f_hz / math.sqrt(1 - zeta ** 2)
    y[after] += 4.0 * np.exp(-zeta * wn * tt[after]) * np.cos(2 * math.pi * f_hz * tt[after])
    y[after] += 2.5 * np.exp(-40 * tt[after]) * np.sin(2 * math.pi * 13.0 * tt[after])  # 2nd mode
    y[np.searchsorted(t, t_rel)] += 20.0                                 # release snap
    # AC-coupled accelerometer, corner at 0.2 Hz.
    b, a = signal.butter(1, 0.2, btype="high", fs=fs)
    y = signal.lfilter(b, a, y)
    topics = {"/rig/accel/tip": frame(t, a_mps2=y),
              "/rig/temperature": temperature_topic(dur, 19.6, 20.8)}
    return make_record(meta("ringdown_bending", temperature_F=20, repetition=1), topics, START)


def synthetic_axial(f_hz=41.0, zeta=0.055, seed=1):
    rng = np.random.default_rng(seed)
    fs, dur, t_hit = 1000.0, 3.0, 0.55
    t = np.arange(int(dur * fs)) / fs
    tt = np.maximum(t - t_hit, 0.0)
    on = t >= t_hit
    wn = 2 * math.pi * f_hz / math.sqrt(1 - zeta ** 2)
    axial = np.where(on, 8.0 * np.exp(-zeta * wn * tt) * np.cos(2 * math.pi * f_hz * tt), 0.0)
    rocking = np.where(on, 0.1 * np.exp(-0.5 * tt) * np.sin(2 * math.pi * 1.9 * tt), 0.0)
    axial[np.searchsorted(t, t_hit)] += 15.0
    a1 = axial + rocking + 0.02 * rng.standard_normal(len(t))
    a2 = axial - rocking + 0.02 * rng.standard_normal(len(t))
    topics = {"/rig/accel/weight": frame(t, a1_mps2=a1, a2_mps2=a2),
              "/rig/temperature": temperature_topic(dur, 70.2, 70.6)}
    return make_record(meta("ringdown_axial", temperature_F=70, accel_lever_m=0.1), topics, START)


def flight_common(dur, rng):
    t_air = np.arange(0, dur, 0.1)
    air = frame(t_air, altitude_ft=12000 + 0 * t_air, kcas=230 + 0 * t_air, ktas=276 + 0 * t_air,
                oat_C=-5.75 + 0 * t_air)
    return {"/air_data": air}


def synthetic_doublet(f_hz=0.4, zeta=0.1, z_steady=-2.6, seed=2):
    rng = np.random.default_rng(seed)
    dur = 40.0
    t_tp = np.arange(0, dur, 0.01)
    z_tp = np.where((t_tp > 8) & (t_tp < 9), -0.25, 0.0) + np.where((t_tp >= 9) & (t_tp < 10), 0.25, 0.0)
    t = np.arange(0, dur, 1 / 30)
    tt = np.maximum(t - 10.0, 0.0)
    wn = 2 * math.pi * f_hz / math.sqrt(1 - zeta ** 2)
    z = z_steady + np.where(t >= 10.0, 0.8 * np.exp(-zeta * wn * tt) * np.cos(2 * math.pi * f_hz * tt), 0.0)
    z[(t > 8) & (t < 10)] -= 0.3 * np.sin(math.pi * (t[(t > 8) & (t < 10)] - 8))
    z += 0.015 * rng.standard_normal(len(t))
    x = 15.0 + 0.02 * rng.standard_normal(len(t))
    valid = rng.random(len(t)) > 0.05
    ors = frame(t, x_m=np.where(valid, x, np.nan), y_m=np.where(valid, 0.0, np.nan),
                z_m=np.where(valid, z, np.nan), valid=valid)
    topics = flight_common(dur, rng)
    topics.update({"/tanker/tow_point": frame(t_tp, x_m=0 * t_tp, y_m=0 * t_tp, z_m=z_tp),
                   "/ors/drogue": ors})
    return make_record(dict(meta("pitch_doublet"), hose="fa18_buddy"), topics, START)


def hose_shape(x):
    """A trailing hose: drooping from the tow point, flattening toward the drogue."""
    return -2.8 * (1 - np.exp(-x / 8.0)) / (1 - math.exp(-22.6 / 8.0))


def video(t_frames, z_of, rng, x_end=22.6, spacing=1.5):
    rows = []
    for tf in t_frames:
        xs = np.arange(0.0, x_end + 1e-9, spacing) + rng.normal(0, 0.05, int(x_end / spacing) + 1)
        xs[0] = 0.0
        zs = z_of(tf, xs) + rng.normal(0, 0.04, len(xs))
        for k, (xv, zv) in enumerate(zip(xs, zs)):
            rows.append((tf, k, xv, zv))
    return pd.DataFrame(rows, columns=["t_s", "point", "x_m", "z_m"])


def synthetic_trail(seed=3):
    rng = np.random.default_rng(seed)
    dur = 25.0
    t = np.arange(0, dur, 1 / 30)
    valid = rng.random(len(t)) > 0.05
    ors = frame(t, x_m=np.where(valid, 22.6 + 0.02 * rng.standard_normal(len(t)), np.nan),
                y_m=np.where(valid, 1.3, np.nan),
                z_m=np.where(valid, -2.8 + 0.03 * rng.standard_normal(len(t)), np.nan), valid=valid)
    topics = flight_common(dur, rng)
    t_tp = np.arange(0, dur, 0.01)
    topics.update({"/tanker/tow_point": frame(t_tp, x_m=0 * t_tp, y_m=0 * t_tp, z_m=0 * t_tp),
                   "/ors/drogue": ors,
                   "/video/hose": video(np.arange(0.05, dur, 0.1), lambda tf, xs: hose_shape(xs), rng)})
    return make_record(dict(meta("trail"), hose="kdc10_pod"), topics, START)


def synthetic_engagement(delay=0.22, c=30.0, seed=4):
    rng = np.random.default_rng(seed)
    dur, tc, td = 30.0, 10.0, 22.0
    push, ramp = 2.7, 1.4
    t = np.arange(0, dur, 1 / 30)

    def pushed(tq, t0, dur_ramp):
        return push * np.clip((tq - t0) / dur_ramp, 0, 1) * (tq < td) + \
            push * np.clip(1 - (tq - td) / 3.0, 0, 1) * (tq >= td)

    valid = rng.random(len(t)) > 0.05
    x = 22.6 - pushed(t, tc, ramp) + 0.02 * rng.standard_normal(len(t))
    ors = frame(t, x_m=np.where(valid, x, np.nan), y_m=np.where(valid, 1.3, np.nan),
                z_m=np.where(valid, -2.8, np.nan), valid=valid)
    t_r = np.arange(0, dur, 0.02)
    # The reel starts late and catches up (a faster take-up), as constant-tension reels do.
    L = 22.85 - pushed(t_r, tc + delay, ramp - delay) + 0.003 * rng.standard_normal(len(t_r))
    t_tp = np.arange(0, dur, 0.01)

    # Fronts enter at both ends (reel at the tow point, probe at the drogue)
    # and travel at c: arrival at station x is the earlier of the two.
    def arrival(xs):
        return np.minimum(0.1 + xs / c, 0.05 + (22.6 - xs) / c)

    def z_of(tf, xs):
        tau = tf - tc - arrival(xs)
        amp = 1.5 * np.sin(np.pi * np.clip(xs / 22.6, 0, 1)) + 0.3
        lobe = np.where(tau > 0, np.exp(-((tau - 0.35) / 0.25) ** 2), 0.0)
        lobe = np.where(tau > 0.35, np.exp(-((tau - 0.35) / 0.25) ** 2), lobe * (tau > 0))
        return hose_shape(xs) - amp * lobe

    topics = flight_common(dur, rng)
    topics.update({
        "/tanker/tow_point": frame(t_tp, x_m=0 * t_tp, y_m=0 * t_tp, z_m=0 * t_tp),
        "/ors/drogue": ors,
        "/reel/hose_out": frame(t_r, length_m=L),
        "/receiver/probe": frame(t, x_m=x + 0.3, y_m=1.3 + 0 * t, z_m=-2.8 + 0 * t),
        "/probe/events": frame([tc, td], event=np.array(["contact", "disconnect"], dtype=object)),
        "/video/hose": video(np.arange(0.05, dur, 0.1), z_of, rng),
    })
    return make_record(dict(meta("engagement"), hose="kdc10_pod"), topics, START)


# ------------------------------------------------------------ known answers

def test_bending_known_answer():
    r = analyze_record(synthetic_bending(f_hz=2.1, zeta=0.05))
    # A second mode, a release snap, a hand-held start and AC coupling are all
    # in the record; the first mode must still come out within the metric
    # tolerances (0.2 % frequency, 3 % damping).
    assert_allclose(r["frequency_hz"], 2.1, rtol=2e-3)
    assert_allclose(r["damping_ratio"], 0.05, rtol=0.03)
    assert_allclose(r["damping_ratio_logdec"], 0.05, rtol=0.03)
    assert r["temperature_F"] == pytest.approx(20.2)
    assert r["temperature_setpoint_F"] == 20.0
    assert r["release_s"] == pytest.approx(1.3, abs=2e-3)


def test_axial_known_answer():
    r = analyze_record(synthetic_axial(f_hz=41.0, zeta=0.055))
    assert_allclose(r["axial_frequency_hz"], 41.0, rtol=2e-3)
    assert_allclose(r["axial_damping_ratio"], 0.055, rtol=0.03)
    assert r["rocking_frequency_hz"] == pytest.approx(1.9, rel=0.1)
    # Rocking was built 80 times smaller than the axial swing.
    assert r["rocking_rms_mps2"] < 0.1 * r["axial_rms_mps2"]


def test_doublet_known_answer():
    r = analyze_record(synthetic_doublet(f_hz=0.4, zeta=0.1, z_steady=-2.6))
    assert r["doublet_start_s"] == pytest.approx(8.0, abs=0.02)
    assert r["doublet_end_s"] == pytest.approx(10.0, abs=0.02)
    # 30 Hz fixes with 5 % dropouts and 1.5 cm noise on a 0.8 m swing.
    assert_allclose(r["drogue_frequency_hz"], 0.4, rtol=5e-3)
    assert_allclose(r["drogue_damping_ratio"], 0.1, rtol=0.03)
    assert r["drogue_steady_z_m"] == pytest.approx(-2.6, abs=0.01)
    assert r["drogue_steady_x_m"] == pytest.approx(15.0, abs=0.01)
    assert r["drogue_valid_fraction"] == pytest.approx(0.95, abs=0.02)


def test_trail_known_answer():
    r = analyze_record(synthetic_trail())
    assert r["drogue_steady_x_m"] == pytest.approx(22.6, abs=0.01)
    assert r["drogue_steady_z_m"] == pytest.approx(-2.8, abs=0.01)
    shape = r["hose_shape"]
    x = np.array(shape["x_m"])
    z = np.array(shape["z_m"])
    # Bin means of 250 noisy frames: the 4 cm point noise averages to ~3 mm;
    # the curvature within a 1 m bin adds at most ~1 cm near the tow point.
    assert_allclose(z, hose_shape(x), atol=0.015)
    assert x[0] == pytest.approx(0.0, abs=0.1) and x[-1] > 21.5


def test_engagement_known_answer():
    r = analyze_record(synthetic_engagement(delay=0.22, c=30.0))
    assert r["contact_time_s"] == pytest.approx(10.0)
    assert r["disconnect_time_s"] == pytest.approx(22.0)
    assert r["reel_takeup_max_m"] == pytest.approx(2.7, abs=0.01)
    assert r["drogue_pushback_max_m"] == pytest.approx(2.7, abs=0.05)
    # Onsets from hinge fits on 30 Hz / 50 Hz samples: a frame or so.
    assert r["reel_delay_s"] == pytest.approx(0.22, abs=0.03)
    assert r["drogue_motion_onset_s"] == pytest.approx(10.0, abs=0.03)
    # Arrival times from 10 Hz video and 1.5 m point spacing: 10 %.
    assert r["wave_speed_mps"] == pytest.approx(30.0, rel=0.1)
    assert r["wave_direction"] == 0
    # The prescribed channels' own noise, as drawn (the median-based estimate:
    # a few % on a thousand samples), and their band above it: the reel's
    # 1.4 s take-up within a few Hz; a still probe's y and a still, noiseless
    # tow point have no noise and no band to measure
    assert r["reel_noise_m"] == pytest.approx(0.003, rel=0.1)
    assert r["probe_x_noise_m"] == pytest.approx(0.02, rel=0.1)
    assert 0.5 < r["reel_bandwidth_hz"] < 5.0
    assert r["probe_y_noise_m"] == 0.0 and r["tow_point_z_bandwidth_hz"] is None


# ------------------------------------------------------------ shipped logs

@lru_cache(maxsize=None)
def results():
    return {p.name: analyze_record(read_record(p)) for p in ALL_LOGS}


def by_kind(kind):
    return {k: v for k, v in results().items() if v["test_kind"] == kind}


def test_every_log_analyzes():
    res = results()
    assert len(res) == len(ALL_LOGS)
    keys = {
        "ringdown_bending": ["frequency_hz", "damping_ratio", "temperature_F"],
        "ringdown_axial": ["axial_frequency_hz", "axial_damping_ratio"],
        "pitch_doublet": ["drogue_frequency_hz", "drogue_damping_ratio", "drogue_steady_x_m",
                          "drogue_steady_z_m"],
        "trail": ["drogue_steady_x_m", "drogue_steady_z_m", "hose_shape"],
        "engagement": ["contact_time_s", "disconnect_time_s", "reel_takeup_max_m", "reel_delay_s",
                       "wave_speed_mps"],
    }
    for name, r in res.items():
        for key in keys[r["test_kind"]]:
            assert r.get(key) is not None, (name, key)


def test_ringdowns_self_consistent():
    bend = by_kind("ringdown_bending")
    for name, r in bend.items():
        assert 0 < r["damping_ratio"] < 0.3
        # Two independent damping methods on the same decay.
        assert r["damping_ratio_logdec"] == pytest.approx(r["damping_ratio"], rel=0.05), name
        # The enclosure held its setpoint: thermocouples read it within a few F.
        assert abs(r["temperature_F"] - r["temperature_setpoint_F"]) < 3.0, name
    for hose in ("fa18_buddy", "kc130_long"):
        rows = [r for r in bend.values() if r["hose"] == hose]
        g = summarize_by_setpoint(rows, "frequency_hz")
        # Repetitions agree far better than setpoints differ ...
        assert (g["std"] / g["mean"]).max() < 0.01
        # ... and a rubber hose stiffens (frequency up) and damps more as it gets colder.
        assert g["mean"].is_monotonic_decreasing
        d = summarize_by_setpoint(rows, "damping_ratio")
        assert d["mean"].is_monotonic_decreasing
    for name, r in by_kind("ringdown_axial").items():
        assert r["axial_damping_ratio_logdec"] == pytest.approx(r["axial_damping_ratio"], rel=0.05)
        assert r["rocking_rms_mps2"] < 0.5 * r["axial_rms_mps2"], name


def test_flight_logs_self_consistent():
    pd_ = by_kind("pitch_doublet")
    freqs = [r["drogue_frequency_hz"] for r in pd_.values()]
    # Three repetitions at one flight condition.
    assert np.std(freqs) / np.mean(freqs) < 0.02
    for name, r in pd_.items():
        assert 0 < r["drogue_damping_ratio"] < 0.5
        assert r["doublet_start_s"] < r["doublet_end_s"] < r["steady_window_s"][0]
        assert r["drogue_steady_x_m"] > 0 > r["drogue_steady_z_m"]
    for name, r in by_kind("trail").items():
        shape = r["hose_shape"]
        # The video hose ends at the drogue the ORS sees.
        assert shape["x_m"][-1] == pytest.approx(r["drogue_steady_x_m"], abs=1.0), name
        assert shape["z_m"][-1] == pytest.approx(r["drogue_steady_z_m"], abs=0.3), name
        assert abs(shape["z_m"][0]) < 0.1                      # starts at the tow point
    for name, r in by_kind("engagement").items():
        assert r["contact_time_s"] < r["disconnect_time_s"]
        # The reel takes up the slack the receiver pushes in.
        assert r["reel_takeup_max_m"] == pytest.approx(r["drogue_pushback_max_m"], rel=0.1), name
        assert 0.0 < r["reel_delay_s"] < 1.0
        assert r["drogue_motion_onset_s"] == pytest.approx(r["contact_time_s"], abs=0.2)
        assert 5.0 < r["wave_speed_mps"] < 150.0
