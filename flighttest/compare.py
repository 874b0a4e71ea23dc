"""One record against another: a simulation saved in the log contract against
the flight log it reproduces. The same path serves validation and diagnosis.

Each comparison measures both records with the same code (`analyze_record`,
the metrics) and reports log value, simulated value and error side by side,
with units in the names.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

import flighttest.metrics as M
from .analyze import analyze_record
from .record import FlightRecord


def _pct(sim, log):
    if sim is None or log is None or not np.isfinite(sim) or not np.isfinite(log) or log == 0:
        return None
    return 100.0 * (sim - log) / abs(log)


def _diff(sim, log):
    if sim is None or log is None:
        return None
    return float(sim - log)


def _side_by_side(out: dict, a_log: dict, a_sim: dict, keys) -> None:
    for k in keys:
        out[f"{k}_log"] = a_log.get(k)
        out[f"{k}_sim"] = a_sim.get(k)


def _drogue_series(rec: FlightRecord, col: str):
    ors = rec.topic("/ors/drogue")
    ok = ors["valid"].to_numpy(bool)
    return ors.index.to_numpy(float)[ok], ors[col].to_numpy(float)[ok]


def _last_frame_shape(rec: FlightRecord, t: float | None = None):
    hose = rec.topic("/video/hose")
    times = np.unique(hose["t_s"].to_numpy(float))
    tf = times[-1] if t is None else times[np.argmin(np.abs(times - t))]
    fr = hose[hose["t_s"] == tf].sort_values("point")
    return tf, fr["x_m"].to_numpy(float), fr["z_m"].to_numpy(float)


def compare_pitch_doublet(log: FlightRecord, sim: FlightRecord) -> dict[str, Any]:
    a_log, a_sim = analyze_record(log), analyze_record(sim)
    out: dict[str, Any] = {}
    _side_by_side(out, a_log, a_sim, ["drogue_frequency_hz", "drogue_damping_ratio",
                                      "drogue_steady_x_m", "drogue_steady_z_m"])
    out["drogue_frequency_error_pct"] = _pct(a_sim["drogue_frequency_hz"], a_log["drogue_frequency_hz"])
    out["drogue_damping_error_pct"] = _pct(a_sim["drogue_damping_ratio"], a_log["drogue_damping_ratio"])
    out["drogue_steady_x_error_m"] = _diff(a_sim["drogue_steady_x_m"], a_log["drogue_steady_x_m"])
    out["drogue_steady_z_error_m"] = _diff(a_sim["drogue_steady_z_m"], a_log["drogue_steady_z_m"])
    # The response about each record's own steady position: the dynamic match,
    # apart from the steady offset reported above.
    t0 = a_log["doublet_start_s"] - 2.0
    tl, zl = _drogue_series(log, "z_m")
    ts, zs = _drogue_series(sim, "z_m")
    kl, ks = tl >= t0, ts >= t0
    th = M.time_history_error(tl[kl], zl[kl] - a_log["drogue_steady_z_m"],
                              ts[ks], zs[ks] - a_sim["drogue_steady_z_m"], max_lag_s=1.0)
    out["drogue_z_response_rms_error_m"] = th.rms
    out["drogue_z_response_peak_error_m"] = th.peak
    out["drogue_z_response_lag_s"] = th.lag_s
    out["drogue_z_response_peak_log_m"] = a_log.get("drogue_z_peak_response_m")
    out["drogue_z_response_peak_sim_m"] = a_sim.get("drogue_z_peak_response_m")
    return out


def compare_trail(log: FlightRecord, sim: FlightRecord) -> dict[str, Any]:
    a_log, a_sim = analyze_record(log), analyze_record(sim)
    out: dict[str, Any] = {}
    _side_by_side(out, a_log, a_sim, ["drogue_steady_x_m", "drogue_steady_y_m", "drogue_steady_z_m"])
    for c in "xyz":
        out[f"drogue_steady_{c}_error_m"] = _diff(a_sim[f"drogue_steady_{c}_m"], a_log[f"drogue_steady_{c}_m"])
    hose = log.topic("/video/hose")
    _, xs, zs = _last_frame_shape(sim)
    se = M.shape_error(hose["x_m"], hose["z_m"], xs, zs)
    out["trail_shape_rms_error_m"] = se.rms_m
    out["trail_shape_max_error_m"] = se.max_abs_m
    out["trail_vertical_rms_error_m"] = se.vertical_rms_m
    out["trail_shape_error_by_station_m"] = {
        "station_lo_m": [float(v) for v in se.bins["station_lo_m"]],
        "rms_m": [None if not np.isfinite(v) else float(v) for v in se.bins["rms_m"]],
        "mean_m": [None if not np.isfinite(v) else float(v) for v in se.bins["mean_m"]],
    }
    return out


def engagement_moments(rec: FlightRecord) -> dict[str, float]:
    """The paper's six moments of an engagement (Fig. 19), found in the log:
    contact and disconnect (probe events); maximum slack and wave (largest
    sag of the video hose from its tow-point-to-drogue chord in the 6 s after
    contact); slack developing (half way from contact to maximum slack);
    maximum reel take-up (least hose out); refuelling steady state (half way
    from maximum take-up to disconnect)."""
    a = analyze_record(rec)
    tc, td = a["contact_time_s"], a["disconnect_time_s"]
    if tc is None:
        raise ValueError(f"{rec.path}: no contact event")
    td = td if td is not None else float(rec.topic("/ors/drogue").index[-1])
    hose = rec.topic("/video/hose")
    best, t_sag = -1.0, tc
    for tf, fr in hose.groupby("t_s"):
        if not (tc <= tf <= tc + 6.0):
            continue
        fr = fr.sort_values("point")
        p = fr[["x_m", "z_m"]].to_numpy(float)
        chord = p[-1] - p[0]
        n = np.hypot(*chord)
        if n <= 0:
            continue
        sag = np.max(np.abs(np.cross(chord, p - p[0]) / n))
        if sag > best:
            best, t_sag = sag, float(tf)
    reel = rec.topic("/reel/hose_out")
    tr = reel.index.to_numpy(float)
    L = reel["length_m"].to_numpy(float)
    w = (tr >= tc) & (tr <= td)
    t_take = float(tr[w][np.argmin(L[w])]) if w.any() else tc
    return {"contact": tc, "slack": 0.5 * (tc + t_sag), "max_slack_wave": t_sag,
            "max_reel_takeup": t_take, "refuelling_steady": 0.5 * (t_take + td), "disconnect": td}


def compare_engagement(log: FlightRecord, sim: FlightRecord) -> dict[str, Any]:
    a_log, a_sim = analyze_record(log), analyze_record(sim)
    out: dict[str, Any] = {}
    _side_by_side(out, a_log, a_sim, ["wave_speed_mps", "reel_delay_s", "reel_takeup_max_m",
                                      "drogue_pushback_max_m"])
    out["wave_speed_error_pct"] = _pct(a_sim.get("wave_speed_mps"), a_log.get("wave_speed_mps"))
    moments = engagement_moments(log)
    hose = log.topic("/video/hose")
    shim = sim.topic("/video/hose")
    sim_times = np.unique(shim["t_s"].to_numpy(float))
    series_t, series_rms = [], []
    for tf, fr in hose.groupby("t_s"):
        ts = sim_times[np.argmin(np.abs(sim_times - tf))]
        if abs(ts - tf) > 0.06:
            continue
        sf = shim[shim["t_s"] == ts].sort_values("point")
        se = M.shape_error(fr["x_m"], fr["z_m"], sf["x_m"], sf["z_m"])
        series_t.append(float(tf))
        series_rms.append(se.rms_m)
    series_t = np.array(series_t)
    series_rms = np.array(series_rms)
    out["shape_error_time_s"] = series_t.tolist()
    out["shape_error_rms_m"] = [None if not np.isfinite(v) else float(v) for v in series_rms]
    for name, tm in moments.items():
        out[f"moment_{name}_s"] = tm
        k = int(np.argmin(np.abs(series_t - tm))) if len(series_t) else None
        out[f"shape_rms_error_at_{name}_m"] = (float(series_rms[k]) if k is not None and
                                              np.isfinite(series_rms[k]) else None)
    engaged = (series_t >= moments["contact"]) & (series_t <= moments["disconnect"])
    vals = series_rms[engaged & np.isfinite(series_rms)]
    out["shape_rms_error_engaged_m"] = float(np.sqrt(np.mean(vals ** 2))) if len(vals) else None
    pre = (series_t < moments["contact"]) & np.isfinite(series_rms)
    out["shape_rms_error_pre_contact_m"] = (float(np.sqrt(np.mean(series_rms[pre] ** 2)))
                                           if pre.any() else None)
    return out


COMPARE = {
    "pitch_doublet": compare_pitch_doublet,
    "trail": compare_trail,
    "engagement": compare_engagement,
}


def compare_records(log: FlightRecord, sim: FlightRecord) -> dict[str, Any]:
    """Metrics of `sim` against `log` for the log's test kind."""
    kind = log.info.test_kind
    if kind not in COMPARE:
        raise ValueError(f"{log.path}: no record comparison for test kind {kind!r}")
    out = COMPARE[kind](log, sim)
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}
