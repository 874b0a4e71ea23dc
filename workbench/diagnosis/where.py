"""The where-map: a log's residual split by channel, station along the hose,
phase of the test and frequency band (steady offset, around the hose-drogue
fundamental, above it), each beside the log's own level in the same band and
channel (its noise floor, or its motion over a quiet segment).

Beside the one-way splits, two tables the report draws as heat maps, each
cell the RMS of the residual's components tagged with its row and column
beside the RMS of their noise floors (a cell with no component is None):
channel x phase, and for the hose station x band. And the log against the
simulation, thinned for an overlay: the drogue's x, y, z over time (doublet,
engagement) or the hose's mean shape (trail)."""
from __future__ import annotations

import math

import numpy as np
from scipy import signal

from flighttest import metrics as M
from flighttest.residual import SHAPE_BIN_M, STATION_M, Observation, Residual
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
    out["channel_phase"] = cross_table(R, R.channel, R.phase, [p[0] for p in ob.phases])
    hose = R.channel == "hose"
    if hose.any():
        lo = np.floor(R.station[hose] / STATION_M) * STATION_M
        rows = np.array([f"{a:g} to {a + STATION_M:g} m" for a in lo], dtype=object)
        order = [f"{a:g} to {a + STATION_M:g} m" for a in np.unique(lo)]
        out["station_band"] = cross_table(R, rows, R.band[hose], row_order=order, keep=hose)
    out["series"] = overlay_series(ob, R)
    return out


def cross_table(R: Residual, rows, cols, col_order=None, row_order=None, keep=None) -> dict:
    """RMS residual and RMS noise floor (m) of the components of `R` (those
    where `keep`, default all) by row tag x column tag (one tag per kept
    component each): rows in `row_order` (default first seen), columns in
    `col_order` then any other seen; an empty cell is None."""
    keep = np.ones(len(R.r), bool) if keep is None else np.asarray(keep, bool)
    r, fl = R.r[keep], R.floor[keep]
    rows, cols = np.asarray(rows, dtype=object), np.asarray(cols, dtype=object)
    row_names = list(row_order) if row_order is not None else list(dict.fromkeys(rows))
    seen = list(dict.fromkeys(cols))
    col_names = [c for c in (col_order or []) if c in seen] + [c for c in seen if c not in (col_order or [])]
    g = [[None] * len(col_names) for _ in row_names]
    f = [[None] * len(col_names) for _ in row_names]
    n = [[0] * len(col_names) for _ in row_names]
    for i, a in enumerate(row_names):
        for j, b in enumerate(col_names):
            s = (rows == a) & (cols == b)
            if s.any():
                g[i][j], f[i][j], n[i][j] = gap(r[s]), gap(fl[s]), int(s.sum())
    return {"rows": [str(a) for a in row_names], "cols": [str(b) for b in col_names],
            "gap_m": g, "floor_m": f, "n": n}


OVERLAY_POINTS = 300    # at most this many points per overlaid trace: enough to show a 2 Hz drogue over 60 s


def _thin(t, y):
    """Means of `y` (n, k) over at most `OVERLAY_POINTS` equal time bins of `t`; empty bins dropped."""
    edges = np.linspace(t[0], t[-1] + 1e-9, min(OVERLAY_POINTS, len(t)) + 1)
    k = np.digitize(t, edges) - 1
    n = np.bincount(k, minlength=len(edges) - 1)
    ok = n > 0

    def mean(v):
        return np.bincount(k, weights=v, minlength=len(edges) - 1)[ok] / n[ok]
    return mean(t), np.column_stack([mean(y[:, c]) for c in range(y.shape[1])])


def _round(a) -> list:
    # 0.1 mm and 0.1 ms: far below the noise floors the figures compare with
    return [None if not math.isfinite(v) else round(float(v), 4) for v in np.asarray(a, float)]


def overlay_series(ob: Observation, R: Residual) -> dict:
    """The log and the simulation `R` compares it with, thinned for an overlay
    (m, s): a trail's hose mean shape (x, z; the simulated z is the log's mean
    shape at the compared point's x minus its vertical distance), else the
    drogue's x, y, z at the tracker's fixes (the simulated = log - residual)."""
    if ob.kind == "trail":
        _, xv, zv = ob.video
        shape = M.mean_shape(xv, zv, bin_m=SHAPE_BIN_M)
        h = R.hose[np.isfinite(R.hose["vertical_m"])]
        x = h["x_m"].to_numpy(float)
        z_sim = np.interp(x, shape["x_m"], shape["z_m"]) - h["vertical_m"].to_numpy(float)
        sim = M.mean_shape(x, z_sim, bin_m=SHAPE_BIN_M) if len(x) else shape.iloc[:0]
        return {"kind": "hose shape", "log": {"x_m": _round(shape["x_m"]), "z_m": _round(shape["z_m"])},
                "sim": {"x_m": _round(sim["x_m"]), "z_m": _round(sim["z_m"])}}
    t, d = R.drogue
    ok = np.all(np.isfinite(d), axis=1) & (t >= ob.bins[0])
    tt, both = _thin(t[ok], np.column_stack([ob.fix_xyz[ok], ob.fix_xyz[ok] - d[ok]]))
    return {"kind": "drogue", "t_s": _round(tt),
            "log": {c: _round(both[:, i]) for i, c in enumerate("xyz")},
            "sim": {c: _round(both[:, 3 + i]) for i, c in enumerate("xyz")}}
