"""The observation of a log, its residual against a simulation, and the
simulation of a log under a candidate's effects.

The gap (one scalar per log, in metres; a family's is the RMS over its logs)
------------------------------------------------------------------------------
Every log kind becomes a residual vector r = log - simulation of averaged,
hence nearly noise-free, components (metres):

* pitch_doublet: the optical tracker's drogue x, y, z, averaged in 0.25 s bins
  from 2 s before the doublet to the end of the log (steady offset and the
  dynamic response together; 0.25 s is a quarter of the fastest drogue period
  seen).
* trail: the signed normal distance of the video hose's mean shape (1 m bins
  along x) from the simulated static hose, and the median drogue x, y, z.
* engagement: the signed normal distance of the video hose points from the
  simulated hose of the same moment, averaged per 1 s window and 3 m station;
  and the drogue x, y, z in 0.25 s bins.

gap = sqrt(mean(r^2)). Its noise floor is what the averaging leaves of the
log's own scatter: for each component, the log's spread about its local mean
(tracker noise, turbulence, digitising) over sqrt(samples averaged), and
the RMS of those. A gap within `NOISE_FACTOR` times its floor is noise.

Every component is tagged with a time segment: alternating `BLOCK_S` blocks
(a trail: its video frames and fixes in those blocks, each averaged), which the
time-block folds (`fit.TimeBlocks`) train and score on.

Caches: a worker process reads each log once (`record`, `observed`: keyed by
path) and simulates each (log, effects, setup) once (`_simulate_frozen`);
all three are `functools.lru_cache`s, bounded, per process.
"""
from __future__ import annotations

import dataclasses
import functools
import math

from typing import Any, Mapping

import numpy as np
from scipy import signal

from flighttest import FlightRecord, analyze_record, read_record
from flighttest import metrics as M
from solver.effects import EFFECTS
from solver.chain import DivergenceError
from solver.statics import StaticSolveError
from workbench import log_inputs
from workbench.diagnosis.setup import BIN_S, BLOCK_S, STATION_M, VIDEO_WINDOW_S, Setup, family_of
from workbench.errors import InputError, SimulationFailed
from workbench.simulate import simulate_case

# what a simulation of a candidate can fail with: the solver diverging or
# finding no static shape, or a parameter combination the model refuses
SIM_FAILURES = (DivergenceError, StaticSolveError, ValueError, FloatingPointError)


# ---- the observation: what is compared, per log -------------------------------------

@dataclasses.dataclass
class Observed:
    """Everything measured once from a log: the binned targets with their time
    segment, phase and floor, and the raw channels for the where-map."""

    path: str
    test_id: str
    kind: str
    family: str
    t_end: float
    ors_t: np.ndarray
    ors_xyz: np.ndarray
    bins: np.ndarray              # drogue bin edges (s)
    phases: list                  # (name, t_from, t_to)
    f0: float
    video: Any = None             # engagement / trail video points (t, x, z) arrays
    trail_halves: Any = None
    contact: Any = None


def _bin_edges(t0: float, t1: float) -> np.ndarray:
    return np.arange(t0, t1 + 1e-9, BIN_S)


def _phases(rec: FlightRecord, a: dict) -> list:
    kind = rec.info.test_kind
    t_end = float(rec.topic("/ors/drogue").index[-1])
    t_start = float(rec.topic("/ors/drogue").index[0])
    if kind == "pitch_doublet":
        d0, d1 = a["doublet_start_s"], a["doublet_end_s"]
        settle = a["steady_window_s"][0] if a.get("steady_window_s") else t_end
        settle = max(settle, d1)
        return [("steady trail", t_start, d0), ("doublet", d0, d1), ("free response", d1, settle),
                ("settled", settle, t_end)]
    if kind == "trail":
        return [("steady trail", t_start, t_end)]
    from flighttest.compare import engagement_moments
    m = engagement_moments(rec)
    tc, td = m["contact"], m["disconnect"]
    t_wave = max(m["max_slack_wave"], tc + 0.5)
    t_take = min(max(m["max_reel_takeup"], t_wave), td)
    return [("approach", t_start, tc), ("contact", tc, tc + 0.5), ("slack and wave", tc + 0.5, t_wave + 1.0),
            ("reel take-up", t_wave + 1.0, max(t_take, t_wave + 1.0)),
            ("refuelling", max(t_take, t_wave + 1.0), td), ("disconnect", td, t_end)]


def _fundamental(rec: FlightRecord, a: dict) -> float:
    if a.get("drogue_frequency_hz"):
        return float(a["drogue_frequency_hz"])
    ors = rec.topic("/ors/drogue")
    ok = ors["valid"].to_numpy(bool)
    t = ors.index.to_numpy(float)[ok]
    z = ors["z_m"].to_numpy(float)[ok]
    fs = M.median_rate_hz(t)
    tg, zg = M.resample_uniform(t, z, fs)
    try:
        return float(M.dominant_frequency(signal.detrend(zg), fs, fmin=0.1, fmax=3.0).frequency_hz)
    except ValueError:
        return 0.5


def _observe(rec: FlightRecord) -> Observed:
    kind = rec.info.test_kind
    a = analyze_record(rec)
    ors = rec.topic("/ors/drogue")
    ok = ors["valid"].to_numpy(bool)
    t = ors.index.to_numpy(float)[ok]
    xyz = ors[["x_m", "y_m", "z_m"]].to_numpy(float)[ok]
    phases = _phases(rec, a)
    t0 = a["doublet_start_s"] - 2.0 if kind == "pitch_doublet" else float(t[0])
    ob = Observed(str(rec.path), rec.info.test_id, kind, family_of(rec), float(ors.index[-1]), t, xyz,
                  _bin_edges(max(t0, float(t[0])), float(t[-1])), phases, _fundamental(rec, a))
    if kind in ("trail", "engagement"):
        h = rec.topic("/video/hose")
        ob.video = (h["t_s"].to_numpy(float), h["x_m"].to_numpy(float), h["z_m"].to_numpy(float))
    if kind == "engagement":
        ob.contact = log_inputs.contact_window(rec)
    return ob


# ---- residuals --------------------------------------------------------------------------

@dataclasses.dataclass
class Residual:
    r: np.ndarray            # components, m
    floor: np.ndarray        # each component's noise floor, m
    seg: np.ndarray          # 0: segment A, 1: segment B
    label: np.ndarray        # channel of each component
    station: np.ndarray      # m along the hose (NaN: drogue)
    t: np.ndarray            # s, mid-time of the component
    raw: dict                # unbinned residual channels for the where-map


def _segment(t) -> np.ndarray:
    return (np.floor(np.asarray(t, float) / BLOCK_S).astype(int) % 2)


def _bin_stats(t, y, edges):
    """Per bin: mean, spread/sqrt(n), mid time; bins with under 3 samples dropped."""
    k = np.digitize(t, edges) - 1
    inside = (k >= 0) & (k < len(edges) - 1)
    k, y = k[inside], y[inside]
    n = np.bincount(k, minlength=len(edges) - 1)
    s = np.bincount(k, weights=y, minlength=len(edges) - 1)
    s2 = np.bincount(k, weights=y * y, minlength=len(edges) - 1)
    keep = n >= 3
    mean = s[keep] / n[keep]
    var = np.maximum(s2[keep] / n[keep] - mean ** 2, 0.0) * n[keep] / (n[keep] - 1)
    mid = 0.5 * (edges[:-1] + edges[1:])[keep]
    return mean, np.sqrt(var / n[keep]), mid


def _drogue_residual(ob: Observed, t_sim, end_sim, delay: float):
    """Log minus simulation of the drogue at the tracker's fixes; a tracker
    latency `delay` means a fix stamped t shows the drogue at t - delay."""
    tq = ob.ors_t - delay
    sim = np.column_stack([np.interp(tq, t_sim, end_sim[:, c]) for c in range(3)])
    return ob.ors_xyz - sim


def _shape_normals(px, pz, lx, lz):
    """Signed normal distance (+ above a hose trailing aft) and arc-length
    station of points from a polyline, and whether the foot lies inside it:
    `metrics.shape_error`'s projection without its tables (this runs per frame)."""
    q = np.column_stack([np.asarray(px, float), np.asarray(pz, float)])
    q = q[np.all(np.isfinite(q), axis=1)]
    P = np.column_stack([np.asarray(lx, float), np.asarray(lz, float)])
    err, station, inside, _, _ = M.project_onto_polyline(q, P)
    return err, station, inside


def residual(ob: Observed, sim) -> Residual:
    """The residual of one log against one simulation (`sim`: dict with t,
    end (n,3), and hose: callable(t) -> (points (k,3))), under a tracker
    latency `sim['delay']`."""
    delay = sim.get("delay", 0.0)
    comps_r, comps_f, comps_s, comps_l, comps_st, comps_t = [], [], [], [], [], []
    raw = {}
    if ob.kind == "trail":
        tv, xv, zv = ob.video
        pts = sim["hose"](None)
        for seg, sel in ((0, _segment(tv) == 0), (1, _segment(tv) == 1)):
            shp = M.mean_shape(xv[sel], zv[sel], bin_m=1.0)
            # every log bin stays a component whatever the simulated line does
            # (a fixed-length residual for the least squares); the station is the
            # log's own x, which a hose trailing aft advances along
            e, _, _ = _shape_normals(shp["x_m"], shp["z_m"], pts[:, 0], pts[:, 2])
            n = np.maximum(shp["n"].to_numpy(float), 1.0)
            fl = np.nan_to_num(shp["z_std_m"].to_numpy(float) / np.sqrt(n))
            st = shp["x_m"].to_numpy(float)
            comps_r.append(e); comps_f.append(fl); comps_s.append(np.full(len(e), seg))
            comps_l.append(np.full(len(e), "hose")); comps_st.append(st)
            comps_t.append(np.full(len(e), float(np.median(tv[sel]))))
            so = _segment(ob.ors_t) == seg
            d = ob.ors_xyz[so] - sim["end"][0]
            comps_r.append(np.median(d, axis=0))
            comps_f.append(np.std(ob.ors_xyz[so], axis=0) / math.sqrt(max(so.sum(), 1)))
            comps_s.append(np.full(3, seg)); comps_l.append(np.array(["drogue x", "drogue y", "drogue z"]))
            comps_st.append(np.full(3, np.nan)); comps_t.append(np.full(3, float(np.median(ob.ors_t[so]))))
        raw["hose"] = (tv, _shape_normals(xv, zv, pts[:, 0], pts[:, 2])[0], xv)
        raw["drogue"] = (ob.ors_t, ob.ors_xyz - sim["end"][0])
    else:
        d = _drogue_residual(ob, sim["t"], sim["end"], delay)
        raw["drogue"] = (ob.ors_t, d)
        for c, name in enumerate(("drogue x", "drogue y", "drogue z")):
            mean, fl, mid = _bin_stats(ob.ors_t, d[:, c], ob.bins)
            comps_r.append(mean); comps_f.append(fl); comps_s.append(_segment(mid))
            comps_l.append(np.full(len(mean), name)); comps_st.append(np.full(len(mean), np.nan))
            comps_t.append(mid)
        if ob.kind == "engagement":
            tv, xv, zv = ob.video
            e = sim["frames_normals"](tv, xv, zv)
            st, tt = xv, tv
            raw["hose"] = (tt, e, st)
            w = np.floor(tt / VIDEO_WINDOW_S).astype(int)
            b = np.clip(np.floor(st / STATION_M).astype(int), 0, 999)
            key = w * 1000 + b
            uk, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
            s = np.bincount(inv, weights=e)
            s2 = np.bincount(inv, weights=e * e)
            good = cnt >= 3
            mean = s / cnt
            var = np.maximum(s2 / cnt - mean ** 2, 0.0) * cnt / np.maximum(cnt - 1, 1)
            mid_t = (uk // 1000 + 0.5) * VIDEO_WINDOW_S
            comps_r.append(mean[good]); comps_f.append(np.sqrt(var[good] / cnt[good]))
            comps_s.append(_segment(mid_t[good])); comps_l.append(np.full(good.sum(), "hose"))
            comps_st.append(((uk % 1000) + 0.5)[good] * STATION_M); comps_t.append(mid_t[good])
    return Residual(np.concatenate(comps_r), np.concatenate(comps_f), np.concatenate(comps_s),
                    np.concatenate(comps_l), np.concatenate(comps_st), np.concatenate(comps_t), raw)


# ---- simulation of one log under effects ------------------------------------------------

@functools.lru_cache(maxsize=16)
def record(path: str) -> FlightRecord:
    """The log at `path`, read once per process."""
    return read_record(path)


@functools.lru_cache(maxsize=16)
def observed(path: str) -> Observed:
    """Everything measured once from the log at `path`."""
    return _observe(record(path))


def _freeze(effects: Mapping) -> tuple:
    return tuple(sorted((k, tuple(sorted((p, round(float(v), 9)) for p, v in d.items())))
                        for k, d in effects.items()))


@functools.lru_cache(maxsize=256)
def _simulate_frozen(path: str, frozen: tuple, setup: Setup):
    effects = {k: dict(v) for k, v in frozen}
    rec = record(path)
    kind = rec.info.test_kind
    # a trail is compared with its steady line (no time run); the others up to the tracker's last fix
    until = None if kind == "trail" else float(rec.topic("/ors/drogue").index[-1])
    sim = simulate_case(setup.case_for(rec), rec, variant=dict(setup.overrides), effects=effects,
                        duration=0.0 if kind == "trail" else None, until=until)
    if kind == "trail":
        pts = sim.static.pos.copy()
        # the hose line the video sees ends at the drogue's hinge, i.e. the last hose node
        line = pts[:-1] if sim.model.drogue is not None else pts
        return {"t": np.array([float(sim.model.tow.t[0])]), "end": pts[-1:].copy(), "hose": lambda t, line=line: line}
    res = sim.result
    ts = res.t

    def hose(t, res=res, ts=ts):
        k = int(np.argmin(np.abs(ts - t)))
        return res.hose_points(k)

    def frames_normals(tv, xv, zv, res=res, ts=ts):
        return _frames_normals(res, ts, tv, xv, zv)
    return {"t": ts, "end": res.end_xyz.copy(), "hose": hose, "frames_normals": frames_normals}


def _frames_normals(res, ts, tv, xv, zv):
    """Signed normal distance of every video point from the simulated hose at
    its frame's moment, all frames at once (`_shape_normals` per frame, the
    lines padded with their last point: a zero-length segment never wins a tie)."""
    frames, inv = np.unique(tv, return_inverse=True)
    k = np.clip(np.searchsorted(ts, frames), 0, len(ts) - 1)
    k0 = np.clip(k - 1, 0, len(ts) - 1)
    k = np.where(np.abs(ts[k0] - frames) < np.abs(ts[k] - frames), k0, k)
    H = res.hose_xyz[k][:, :, [0, 2]].copy()               # frames, nodes, (x, z)
    nh = np.asarray(res.n_hose_elements)[k]
    idx = np.minimum(np.arange(H.shape[1])[None, :], nh[:, None])
    H = np.take_along_axis(H, idx[:, :, None], axis=1)
    P0 = H[inv, :-1, :]                                    # points, segments, 2
    d = H[inv, 1:, :] - P0
    L2 = np.maximum(d[..., 0] ** 2 + d[..., 1] ** 2, 1e-18)
    rx = xv[:, None] - P0[..., 0]
    rz = zv[:, None] - P0[..., 1]
    u = np.clip((rx * d[..., 0] + rz * d[..., 1]) / L2, 0.0, 1.0)
    dist = np.hypot(rx - u * d[..., 0], rz - u * d[..., 1])
    j = np.argmin(dist, axis=1)
    rows = np.arange(len(xv))
    cross = d[rows, j, 0] * rz[rows, j] - d[rows, j, 1] * rx[rows, j]
    return np.sign(cross) * dist[rows, j]


def evaluate(path: str, effects: Mapping, setup: Setup = Setup()) -> Residual:
    """The residual of the log at `path` against the baseline with `effects`
    ({name: {param: value}}; comparison-only ones act on the comparison).
    Raises `SimulationFailed` when the simulation fails."""
    phys = {k: v for k, v in effects.items() if not EFFECTS[k].comparison_only}
    delay = float(effects.get("sensor_lag", {}).get("delay_s", 0.0))
    try:
        sim = dict(_simulate_frozen(path, _freeze(phys), setup))
        sim["delay"] = delay
        return residual(observed(path), sim)
    except InputError:
        raise
    except SIM_FAILURES as exc:
        raise SimulationFailed(path, effects, exc) from exc


def gap(r) -> float:
    return float(np.sqrt(np.mean(np.square(r)))) if len(r) else float("nan")
