"""One record against another: a simulation saved in the log contract against
the flight log it reproduces. The same path serves validation and diagnosis:
`compare(log, sim)` returns a `Comparison`, validation's metrics beside the
`residual.Residual` the diagnosis measures its gap with; the shape errors in
the metrics are computed from that residual's hose points, so there is one
definition of each.

The metrics measure both records with the same code (`analyze_record`, the
metrics) and report log value, simulated value and error side by side, with
units in the names.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pandas as pd

import flighttest.metrics as M
from .analyze import analyze_record
from .record import FlightRecord
from .residual import SHAPE_BIN_M, Residual, engagement_moments, observe, residual, rms


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
    fixes = rec.tracker_fixes()
    return fixes.index.to_numpy(float), fixes[col].to_numpy(float)


def compare_pitch_doublet(log: FlightRecord, sim: FlightRecord, a_log: dict, a_sim: dict,
                          R: Residual) -> dict[str, Any]:
    """Frequency, damping and steady position side by side, and the response
    about each record's own steady position."""
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


def _none_if_nan(v: float) -> float | None:
    return None if not np.isfinite(v) else float(v)


def compare_trail(log: FlightRecord, sim: FlightRecord, a_log: dict, a_sim: dict,
                  R: Residual) -> dict[str, Any]:
    """The steady drogue errors, and the trail shape error.

    Trail shape error: the RMS of the residual's hose components, i.e. the
    signed normal distances of the log's mean video shape (per segment,
    `SHAPE_BIN_M` bins along x) from the simulation's mean hose line over the
    same segment: the number the diagnosis fits, every bin counted (a bin
    beyond an end of the simulated line counts its distance from that end).
    It replaced the distance of every video point from the last simulated
    frame, which mixed the hose's own scatter (turbulence, digitising) and one
    instant of the simulation into a steady-shape error, weighted the hose by
    where the digitiser put most points, and left a record against itself
    with a non-zero error. The mean shape averages the scatter away and
    counts each metre of hose once.
    """
    out: dict[str, Any] = {}
    _side_by_side(out, a_log, a_sim, ["drogue_steady_x_m", "drogue_steady_y_m", "drogue_steady_z_m"])
    for c in "xyz":
        out[f"drogue_steady_{c}_error_m"] = _diff(a_sim[f"drogue_steady_{c}_m"], a_log[f"drogue_steady_{c}_m"])
    # across the stream, lateral and vertical together: where a receiver's probe must aim
    dy, dz = out["drogue_steady_y_error_m"], out["drogue_steady_z_error_m"]
    out["drogue_steady_cross_error_m"] = None if dy is None or dz is None else math.hypot(dy, dz)
    h = R.hose
    e = h["normal_m"].to_numpy(float)
    out["trail_shape_rms_error_m"] = rms(e)
    out["trail_shape_max_error_m"] = float(np.max(np.abs(e))) if len(e) else float("nan")
    out["trail_vertical_rms_error_m"] = rms(R.hose["vertical_m"].dropna())
    st = h["station_m"].to_numpy(float)
    edges = np.arange(0.0, (st.max() if len(st) else 0.0) + SHAPE_BIN_M, SHAPE_BIN_M)
    k = np.clip(np.digitize(st, edges) - 1, 0, max(len(edges) - 2, 0))
    by = [e[k == i] for i in range(len(edges) - 1)]
    out["trail_shape_error_by_station_m"] = {
        "station_lo_m": [float(v) for v in edges[:-1]],
        "rms_m": [_none_if_nan(rms(v)) if len(v) else None for v in by],
        "mean_m": [_none_if_nan(float(np.mean(v))) if len(v) else None for v in by],
    }
    return out


def compare_engagement(log: FlightRecord, sim: FlightRecord, a_log: dict, a_sim: dict,
                       R: Residual) -> dict[str, Any]:
    """Wave speed and reel figures side by side, and the hose shape error of
    each video frame (RMS of its points' normal distances from the simulated
    hose of that moment, feet inside the line) over time and at the paper's
    six moments."""
    out: dict[str, Any] = {}
    _side_by_side(out, a_log, a_sim, ["wave_speed_mps", "reel_delay_s", "reel_takeup_max_m",
                                      "drogue_pushback_max_m"])
    out["wave_speed_error_pct"] = _pct(a_sim.get("wave_speed_mps"), a_log.get("wave_speed_mps"))
    moments = engagement_moments(log)
    h = R.hose[np.isfinite(R.hose["normal_m"].to_numpy(float))]
    e = np.where(h["inside"].to_numpy(bool), h["normal_m"].to_numpy(float), np.nan)
    per_frame = pd.Series(e ** 2).groupby(h["t_s"].to_numpy(float)).mean()
    series_t = per_frame.index.to_numpy(float)
    series_rms = np.sqrt(per_frame.to_numpy(float))
    out["shape_error_time_s"] = series_t.tolist()
    out["shape_error_rms_m"] = [_none_if_nan(v) for v in series_rms]
    for name, tm in moments.items():
        out[f"moment_{name}_s"] = tm
        k = int(np.argmin(np.abs(series_t - tm))) if len(series_t) else None
        out[f"shape_rms_error_at_{name}_m"] = _none_if_nan(series_rms[k]) if k is not None else None
    engaged = (series_t >= moments["contact"]) & (series_t <= moments["disconnect"])
    vals = series_rms[engaged & np.isfinite(series_rms)]
    out["shape_rms_error_engaged_m"] = rms(vals) if len(vals) else None
    pre = (series_t < moments["contact"]) & np.isfinite(series_rms)
    out["shape_rms_error_pre_contact_m"] = rms(series_rms[pre]) if pre.any() else None
    return out


COMPARE = {
    "pitch_doublet": compare_pitch_doublet,
    "trail": compare_trail,
    "engagement": compare_engagement,
}


@dataclasses.dataclass(frozen=True, eq=False)
class Comparison:
    """A log against a simulated record: validation's `metrics` (name -> value,
    units in the names; None where a value cannot be measured) and the
    `residual` the diagnosis measures its gap with."""

    test_id: str
    kind: str
    metrics: dict[str, Any]
    residual: Residual

    def to_pandas(self) -> pd.Series:
        """The scalar metrics, indexed by name (lists and tables left out)."""
        return pd.Series({k: (np.nan if v is None else v) for k, v in self.metrics.items()
                          if v is None or isinstance(v, (int, float))}, name=self.test_id, dtype=float)


def compare(log: FlightRecord, sim: FlightRecord, *, delay_s: float = 0.0) -> Comparison:
    """`sim` against `log`: the metrics of the log's test kind and the residual.
    `delay_s`: the tracker's latency, applied to the residual's drogue channels."""
    kind = log.info.test_kind
    if kind not in COMPARE:
        raise ValueError(f"{log.path}: no record comparison for test kind {kind!r}")
    ob = observe(log)
    R = residual(ob, sim, delay_s=delay_s)
    out = COMPARE[kind](log, sim, ob.analysis, analyze_record(sim), R)
    metrics = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}
    return Comparison(log.info.test_id, kind, metrics, R)
