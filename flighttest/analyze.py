"""Measure each record on its own (no simulation involved).

`analyze_record(record)` returns a flat, JSON-ready dict of SI numbers (plus
the deg F thermocouple reading, named so).  The methods are in
`flighttest.metrics`; this module only decides which channel, which time
window and which method each kind of test calls for, from what the record
itself shows (release spike, end of the doublet input, probe events), never
from constants tuned to particular files.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from scipy import signal

from solver.units import FT, KT

from .metrics import (
    axial_rocking, cross_correlation_lag, damping_ratio, dominant_frequency,
    free_decay_segment, front_arrival_times, group_by_setpoint, hinge_onset, hose_field,
    mean_shape, median_rate_hz, noise_std, resample_uniform, signal_bandwidth, wave_speed_from_arrivals,
)
from .record import FlightRecord, LogError


def _f(x: Any) -> float | None:
    """JSON-ready float (None for NaN/inf, which JSON cannot carry)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _series(df: pd.DataFrame, col: str) -> tuple[np.ndarray, np.ndarray]:
    t = df.index.to_numpy(dtype=float)
    y = df[col].to_numpy(dtype=float)
    keep = np.isfinite(y)
    return t[keep], y[keep]


def _fail(record: FlightRecord, topic: str, problem: str) -> LogError:
    return LogError(record.path, f"topic {topic}", problem)


# --------------------------------------------------------------------------
# Ring-downs
# --------------------------------------------------------------------------

def _temperature(record: FlightRecord) -> dict[str, Any]:
    df = record.topics.get("/rig/temperature")
    if df is None or len(df) == 0:
        return {}
    both = np.concatenate([df["t1_F"].to_numpy(float), df["t2_F"].to_numpy(float)])
    return {
        # Mean of both thermocouples over the record: the section temperature.
        "temperature_F": _f(both.mean()),
        "temperature_ends_difference_F": _f(np.mean(df["t2_F"] - df["t1_F"])),
        "temperature_spread_F": _f(both.std(ddof=1)) if len(both) > 1 else None,
    }


def _ring_down(record: FlightRecord, topic: str, t: np.ndarray, y: np.ndarray,
               prefix: str) -> dict[str, Any]:
    if len(t) < 64:
        raise _fail(record, topic, f"only {len(t)} samples: too short for a ring-down")
    fs = median_rate_hz(t)
    # Frequencies with fewer than ~3 cycles in the record are drift, not the mode.
    fmin = 3.0 / (t[-1] - t[0])
    try:
        seg = free_decay_segment(t, y, fmin=fmin)
        tt, yy = t[seg.i_start:seg.i_end], y[seg.i_start:seg.i_end]
        if seg.i_end - seg.i_start < 4 * fs / seg.frequency_hz:
            raise ValueError("free decay shorter than 4 cycles")
        est = damping_ratio(tt, yy, f_hint=seg.frequency_hz)
    except ValueError as exc:
        raise _fail(record, topic, f"no measurable free decay ({exc})") from None
    return {
        f"{prefix}frequency_hz": _f(est.frequency_hz),
        f"{prefix}frequency_uncertainty_hz": _f(est.frequency_uncertainty_hz),
        f"{prefix}natural_frequency_hz": _f(est.natural_frequency_hz),
        f"{prefix}damping_ratio": _f(est.zeta),
        f"{prefix}damping_ratio_stderr": _f(est.fit.zeta_stderr),
        f"{prefix}damping_ratio_logdec": _f(est.zeta_logdec),
        f"{prefix}damping_spread": _f(est.spread),
        f"{prefix}half_cycles": est.n_half_cycles,
        f"{prefix}release_s": _f(t[seg.i_release]),
        f"{prefix}decay_start_s": _f(tt[0]),
        f"{prefix}decay_end_s": _f(tt[-1]),
    }


def _ringdown_bending(record: FlightRecord) -> dict[str, Any]:
    t, y = _series(record.topic("/rig/accel/tip"), "a_mps2")
    out = _ring_down(record, "/rig/accel/tip", t, y, "")
    out.update(_temperature(record))
    return out


def _ringdown_axial(record: FlightRecord) -> dict[str, Any]:
    df = record.topic("/rig/accel/weight")
    t = df.index.to_numpy(float)
    axial, rocking = axial_rocking(df["a1_mps2"], df["a2_mps2"])
    out = _ring_down(record, "/rig/accel/weight", t, axial, "axial_")
    i_rel = int(np.argmax(np.abs(axial - np.median(axial))))
    # Rocking after the strike: how much of the weight's motion is not axial.
    after = rocking[i_rel:]
    fs = median_rate_hz(t)
    out["rocking_rms_mps2"] = _f(np.std(after))
    out["axial_rms_mps2"] = _f(np.std(axial[i_rel:]))
    if len(after) >= 64:
        try:
            out["rocking_frequency_hz"] = _f(dominant_frequency(
                after, fs, fmin=3.0 / (t[-1] - t[i_rel])).frequency_hz)
        except ValueError:
            out["rocking_frequency_hz"] = None
    lever = record.info.accel_lever_m
    if lever:
        out["rocking_angular_accel_rms_radps2"] = _f(np.std(after) / lever)
    out.update(_temperature(record))
    return out


# --------------------------------------------------------------------------
# Flight tests
# --------------------------------------------------------------------------

def _air_data(record: FlightRecord) -> dict[str, Any]:
    df = record.topics.get("/air_data")
    if df is None or len(df) == 0:
        return {}
    return {
        "altitude_m": _f(df["altitude_ft"].mean() * FT),
        "calibrated_airspeed_mps": _f(df["kcas"].mean() * KT),
        "true_airspeed_mps": _f(df["ktas"].mean() * KT),
        "oat_C": _f(df["oat_C"].mean()),
    }


def _drogue(record: FlightRecord) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, Any]]:
    """(all tracker rows, for the time base; the valid fixes, for the values; figures)."""
    ors = record.topic("/ors/drogue")
    fixes = record.tracker_fixes()
    if len(fixes) < 3:
        raise _fail(record, "/ors/drogue", "fewer than 3 valid drogue fixes")
    return ors, fixes, {"drogue_valid_fraction": _f(len(fixes) / len(ors))}


def _steady(fixes: pd.DataFrame, t_from: float, t_to: float) -> dict[str, Any]:
    sel = fixes[(fixes.index >= t_from) & (fixes.index <= t_to)]
    # Median: robust to a stray ORS fix without assuming anything about it.
    return {
        "drogue_steady_x_m": _f(sel["x_m"].median()),
        "drogue_steady_y_m": _f(sel["y_m"].median()),
        "drogue_steady_z_m": _f(sel["z_m"].median()),
        "drogue_x_std_m": _f(sel["x_m"].std(ddof=1)),
        "drogue_z_std_m": _f(sel["z_m"].std(ddof=1)),
        "steady_window_s": [_f(t_from), _f(t_to)],
    }


def _pitch_doublet(record: FlightRecord) -> dict[str, Any]:
    ors, fixes, out = _drogue(record)
    tp = record.topic("/tanker/tow_point")
    t_tp = tp.index.to_numpy(float)
    z_tp = tp["z_m"].to_numpy(float)
    dev = np.abs(z_tp - np.median(z_tp))
    # The doublet is where the tow point is displaced by more than a fifth of
    # its largest excursion; the free response starts when that ends.
    big = np.flatnonzero(dev > 0.2 * dev.max())
    t_in0, t_in1 = float(t_tp[big[0]]), float(t_tp[big[-1]])
    out.update({"doublet_start_s": _f(t_in0), "doublet_end_s": _f(t_in1),
                "tow_point_z_amplitude_m": _f(dev.max())})
    td, zd = _series(fixes, "z_m")
    fs = median_rate_hz(ors.index.to_numpy(float))
    tg, zg = resample_uniform(td, zd, fs, t_in1, None)
    if len(tg) < 16:
        raise _fail(record, "/ors/drogue", "record ends before the drogue response to the doublet")
    # Disturbance level before the doublet (turbulence, ORS noise), band-limited
    # like the response, sets where the log decrement stops trusting peaks.
    tq, zq = resample_uniform(td, zd, fs, None, t_in0)
    try:
        f0 = dominant_frequency(zg, fs, fmin=3.0 / (tg[-1] - tg[0])).frequency_hz
        floor = None
        if len(tq) > 4 * fs / f0:
            sos = signal.butter(2, [f0 / 2, min(2 * f0, 0.45 * fs)], btype="bandpass",
                                fs=fs, output="sos")
            floor = 3.0 * float(np.std(signal.sosfiltfilt(sos, zq - zq.mean())))
        est = damping_ratio(tg, zg, f_hint=f0, min_amplitude=floor)
    except ValueError as exc:
        raise _fail(record, "/ors/drogue", f"no measurable drogue response ({exc})") from None
    out.update({
        "drogue_frequency_hz": _f(est.frequency_hz),
        "drogue_frequency_uncertainty_hz": _f(est.frequency_uncertainty_hz),
        "drogue_damping_ratio": _f(est.zeta),
        "drogue_damping_ratio_stderr": _f(est.fit.zeta_stderr),
        "drogue_damping_ratio_logdec": _f(est.zeta_logdec),
        "drogue_z_peak_response_m": _f(np.max(np.abs(zg - np.median(zg)))),
    })
    # Steady state: once the fitted envelope has sunk below the disturbance
    # level (or, failing that, the last quarter of the record).
    amp, s = est.fit.amplitude, est.fit.decay_rate_per_s
    level = floor if floor else 3.0 * est.fit.rms_residual
    t_end = float(ors.index[-1])
    t_settle = t_in1 + math.log(max(amp / max(level, 1e-9), 1.0)) / s if s > 0 else t_end
    if not t_end - t_settle >= 2.0:
        t_settle = t_end - 0.25 * (t_end - t_in1)
    out.update(_steady(fixes, t_settle, t_end))
    out.update(_air_data(record))
    return out


def _trail(record: FlightRecord, bin_m: float = 1.0) -> dict[str, Any]:
    ors, fixes, out = _drogue(record)
    out.update(_steady(fixes, float(ors.index[0]), float(ors.index[-1])))
    hose = record.topic("/video/hose")
    shape = mean_shape(hose["x_m"], hose["z_m"], bin_m=bin_m)
    out["hose_shape"] = {
        "bin_m": bin_m,
        "x_m": [_f(v) for v in shape["x_m"]],
        "z_m": [_f(v) for v in shape["z_m"]],
        "z_std_m": [_f(v) for v in shape["z_std_m"]],
        "n": [int(v) for v in shape["n"]],
    }
    out["hose_frames"] = int(hose["t_s"].nunique())
    out.update(_air_data(record))
    return out


def _move_window(t: np.ndarray, y: np.ndarray, t0: float, t_end: float,
                 pre_s: float = 1.0, frac: float = 0.3) -> np.ndarray:
    """Samples from pre_s before t0 until y has covered `frac` of its travel after t0."""
    base = np.median(y[(t >= t0 - pre_s) & (t < t0)])
    post = (t >= t0) & (t <= t_end)
    travel = y[post] - base
    k = int(np.argmax(np.abs(travel)))
    reach = np.flatnonzero(np.abs(travel[:k + 1]) >= frac * abs(travel[k]))
    t_hi = t[post][reach[0]] if len(reach) else t[post][k]
    return (t >= t0 - pre_s) & (t <= t_hi)


def _smooth(t: np.ndarray, y: np.ndarray, window_s: float = 0.3) -> np.ndarray:
    """Running median over `window_s`: an extreme taken from it is an extreme
    of the motion, not of one noisy sample; 0.3 s is short beside the
    seconds-long pushes and take-ups it is used on."""
    k = int(round(window_s * median_rate_hz(t))) | 1
    return signal.medfilt(y, k) if k > 1 and len(y) > k else y


def _engagement(record: FlightRecord) -> dict[str, Any]:
    ors, fixes, out = _drogue(record)
    tc, td = record.contact_events()
    out.update({"contact_time_s": _f(tc), "disconnect_time_s": _f(td)})
    if tc is None:
        return out
    t_stop = td if td is not None else float(ors.index[-1])

    reel = record.topic("/reel/hose_out")
    t_r, L = _series(reel, "length_m")
    base_L = float(np.median(L[(t_r >= tc - 2.0) & (t_r < tc)])) if np.any(t_r < tc) else L[0]
    during = (t_r >= tc) & (t_r <= t_stop)
    out["reel_takeup_max_m"] = _f(base_L - _smooth(t_r, L)[during].min()) if during.any() else None

    t_x, x = _series(fixes, "x_m")
    base_x = float(np.median(x[(t_x >= tc - 2.0) & (t_x < tc)]))
    in_contact = (t_x >= tc) & (t_x <= t_stop)
    out["drogue_pushback_max_m"] = (_f(base_x - _smooth(t_x, x)[in_contact].min())
                                    if in_contact.any() else None)

    # Reel lag: onset of the reel take-up minus onset of the drogue's forward
    # motion, each from a hinge fit (see metrics.hinge_onset).
    try:
        wx = _move_window(t_x, x, tc, t_stop)
        wl = _move_window(t_r, L, tc, t_stop)
        t0x, _ = hinge_onset(t_x[wx], x[wx])
        t0l, _ = hinge_onset(t_r[wl], L[wl])
        out.update({"drogue_motion_onset_s": _f(t0x), "reel_motion_onset_s": _f(t0l),
                    "reel_delay_s": _f(t0l - t0x)})
    except ValueError:
        out["reel_delay_s"] = None
    # Cross-check: lag maximising the correlation of the two velocities over the contact.
    fs = 50.0
    lo, hi = tc - 1.0, t_stop
    tg, xg = resample_uniform(t_x, x, fs, lo, hi)
    _, lg = resample_uniform(t_r, L, fs, lo, hi)
    n = min(len(xg), len(lg))
    if n > 16:
        lag, corr = cross_correlation_lag(np.gradient(xg[:n]), np.gradient(lg[:n]), fs,
                                            max_lag_s=1.0)
        out["reel_lag_xcorr_s"] = _f(lag)

    out.update(_wave_speed(record, tc, t_stop))
    out.update(_air_data(record))
    return out


def _wave_speed(record: FlightRecord, tc: float, t_stop: float) -> dict[str, Any]:
    hose = record.topic("/video/hose")
    t_all = hose["t_s"].to_numpy(float)
    win = (t_all >= tc - 2.0) & (t_all <= t_stop)
    h = hose[win]
    if h["t_s"].nunique() < 10:
        return {"wave_speed_mps": None}
    # Stations every metre where at least 80 % of the frames in the window
    # see the hose, so each station has a full time history.
    ends = h.groupby("t_s")["x_m"].agg(["min", "max"])
    x_lo = float(np.quantile(ends["min"], 0.8))
    x_hi = float(np.quantile(ends["max"], 0.2))
    xs = np.arange(math.ceil(x_lo) + 1.0, math.floor(x_hi) + 1e-9, 1.0)
    if len(xs) < 4:
        return {"wave_speed_mps": None}
    frames, Z = hose_field(h["t_s"], h["x_m"], h["z_m"], xs)
    arrivals = front_arrival_times(frames, Z, tc, horizon_s=min(5.0, t_stop - tc))
    try:
        ws = wave_speed_from_arrivals(xs, arrivals)
    except ValueError:
        return {"wave_speed_mps": None}
    return {"wave_speed_mps": _f(ws.speed_mps), "wave_speed_stderr_mps": _f(ws.stderr_mps),
            "wave_direction": ws.direction,
            "wave_stations_used": int(np.isfinite(arrivals).sum())}


# The channels a simulation is driven by (workbench.log_inputs), by the name
# their figures carry: what each holds above its own sensor noise.
_INPUT_CHANNELS = {"/tanker/tow_point": ("tow_point", ("x_m", "y_m", "z_m")),
                   "/receiver/probe": ("probe", ("x_m", "y_m", "z_m")),
                   "/reel/hose_out": ("reel", ("length_m",))}


def _input_channels(record: FlightRecord) -> dict[str, Any]:
    """Each prescribed channel's white sensor noise (`noise_std`, m) and signal
    bandwidth (`signal_bandwidth`, Hz: where its spectrum falls to twice that
    noise), per axis: `probe_x_noise_m`, `probe_x_bandwidth_hz`, ..."""
    out: dict[str, Any] = {}
    for topic, (name, cols) in _INPUT_CHANNELS.items():
        df = record.topics.get(topic)
        if df is None or len(df) < 2:
            continue
        t = df.index.to_numpy(float)
        for col in cols:
            y = df[col].to_numpy(float)
            axis = "" if len(cols) == 1 else f"_{col[0]}"
            out[f"{name}{axis}_noise_m"] = _f(noise_std(y))
            out[f"{name}{axis}_bandwidth_hz"] = _f(signal_bandwidth(t, y))
    return out


_ANALYSES = {
    "ringdown_bending": _ringdown_bending,
    "ringdown_axial": _ringdown_axial,
    "pitch_doublet": _pitch_doublet,
    "trail": _trail,
    "engagement": _engagement,
}


def analyze_record(record: FlightRecord) -> dict[str, Any]:
    """Measured quantities of one record (see the module docstring).

    Raises LogError naming the topic when the record lacks what its kind
    needs or the signal does not allow the measurement.  `warnings` (present
    only when there are any) lists what the reader reported of the record:
    gaps, a recording read without its summary.
    """
    info = record.info
    out: dict[str, Any] = {"test_id": info.test_id, "test_kind": info.test_kind,
                           "hose": info.hose}
    if info.temperature_setpoint_F is not None:
        out["temperature_setpoint_F"] = info.temperature_setpoint_F
    if info.repetition is not None:
        out["repetition"] = info.repetition
    out.update(_ANALYSES[info.test_kind](record))
    out.update(_input_channels(record))
    if record.warnings:
        # What the reader found suspicious but kept (gaps, a cut recording):
        # reported beside the figures measured from it, never hidden.
        out["warnings"] = list(record.warnings)
    return out


def summarize_by_setpoint(results: list[dict[str, Any]], key: str) -> pd.DataFrame:
    """Mean and spread of `key` over repetitions, grouped by (hose, temperature setpoint)."""
    rows = [(r["hose"], r.get("temperature_setpoint_F"), r.get(key)) for r in results
            if r.get(key) is not None and r.get("temperature_setpoint_F") is not None]
    frames = []
    for hose in sorted({h for h, _, _ in rows}):
        sp = [s for h, s, _ in rows if h == hose]
        val = [v for h, _, v in rows if h == hose]
        g = group_by_setpoint(sp, val)
        g.insert(0, "hose", hose)
        frames.append(g)
    return pd.concat(frames) if frames else pd.DataFrame()
