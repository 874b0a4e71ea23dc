"""The where-map: a log's residual split by channel, station along the hose,
phase of the test and frequency band (steady offset, around the hose-drogue
fundamental, above it), each beside the log's own level in the same band and
channel (its noise floor, or its motion over a quiet segment)."""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

from flighttest import metrics as M
from flighttest.residual import STATION_M, Observation, Residual
from workbench.diagnosis.evaluate import gap
from workbench.diagnosis.setup import NOISE_FACTOR


def _band_rms(t, y, f0, fs=30.0):
    """RMS of y in the three bands: steady offset (mean), around f0 (f0/2..2 f0), above 2 f0."""
    if len(t) < 32:
        return {"steady_offset": float(np.mean(y)) if len(y) else None, "fundamental": None, "above": None}
    tg, yg = M.resample_uniform(t, y, fs)
    out = {"steady_offset": float(np.mean(yg))}
    hi = min(2.0 * f0, 0.45 * fs)
    sos = signal.butter(2, [max(f0 / 2.0, 0.02), hi], btype="bandpass", fs=fs, output="sos")
    out["fundamental"] = float(np.std(signal.sosfiltfilt(sos, yg - yg.mean())))
    sos = signal.butter(2, hi, btype="highpass", fs=fs, output="sos")
    out["above"] = float(np.std(signal.sosfiltfilt(sos, yg - yg.mean())))
    return out


def where_map(ob: Observation, R: Residual) -> dict:
    """The baseline residual split by channel, station, phase and band, each beside the log's own floor."""
    out: dict = {"test_id": ob.test_id, "kind": ob.kind, "gap_m": gap(R.r),
                 "noise_floor_m": gap(R.floor), "fundamental_hz": ob.fundamental_hz}
    out["real"] = bool(out["gap_m"] > NOISE_FACTOR * out["noise_floor_m"])
    chans = {}
    for lab in np.unique(R.channel):
        s = R.channel == lab
        g, fl = gap(R.r[s]), gap(R.floor[s])
        chans[str(lab)] = {"gap_m": g, "floor_m": fl, "real": bool(g > NOISE_FACTOR * fl)}
    out["by_channel"] = chans
    st = np.isfinite(R.station)
    if st.any():
        edges = np.arange(0.0, np.nanmax(R.station) + STATION_M, STATION_M)
        rows = []
        for lo in edges[:-1]:
            s = st & (R.station >= lo) & (R.station < lo + STATION_M)
            if s.sum():
                g, fl = gap(R.r[s]), gap(R.floor[s])
                rows.append({"station_from_m": float(lo), "station_to_m": float(lo + STATION_M), "gap_m": g,
                             "mean_m": float(np.mean(R.r[s])), "floor_m": fl,
                             "real": bool(g > NOISE_FACTOR * fl)})
        out["by_station"] = rows
    phases = []
    for name, a, b in ob.phases:
        s = (R.t >= a) & (R.t < b)
        if b <= a or not s.any():
            continue
        g, fl = gap(R.r[s]), gap(R.floor[s])
        phases.append({"phase": name, "t_from_s": float(a), "t_to_s": float(b), "gap_m": g, "floor_m": fl,
                       "real": bool(g > NOISE_FACTOR * fl)})
    out["by_phase"] = phases
    # bands of the drogue channels against the log's own motion in the same
    # band over its quietest phase (the first: trail before any event)
    t, d = R.drogue
    qa, qb = ob.phases[0][1], ob.phases[0][2]
    quiet = (ob.fix_t >= qa) & (ob.fix_t < qb)
    bands = {}
    for c, name in enumerate(("x", "y", "z")):
        res_b = _band_rms(t, d[:, c], ob.fundamental_hz)
        if quiet.sum() > 32:
            y = ob.fix_xyz[quiet, c]
            own = _band_rms(ob.fix_t[quiet], y - np.median(y), ob.fundamental_hz)
            own["steady_offset"] = float(np.std(y) / math.sqrt(max(quiet.sum() / 30.0, 1.0)))
        else:
            own = {"steady_offset": None, "fundamental": None, "above": None}
        bands[f"drogue {name}"] = {
            b: {"residual_m": res_b[b], "floor_m": own[b],
                "real": (None if res_b[b] is None or own[b] is None
                         else bool(abs(res_b[b]) > NOISE_FACTOR * own[b]))}
            for b in ("steady_offset", "fundamental", "above")}
    out["by_band"] = bands
    return out
