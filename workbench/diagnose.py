"""`workbench diagnose`: where the simulation departs from flight logs, which
unmodelled effect explains it, and how far the gap shrinks once it is added.

A log alone is enough. Its metadata names the hardware (`hardware.toml` ids)
and the flight condition; a template per test kind (`cases/templates/`) adds
the paper's baseline model, so the baseline is what `validate` would run.

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
(a trail: its video frames and fixes in those blocks, each averaged). A family with one log is
calibrated on segment A and scored on segment B, and the other way round; a family of several logs by
leaving one log out at a time (train on the others, score the one left out).

The method
----------
1. Where: the raw (unbinned) residual of every channel, split by station
   along the hose, by phase of the test and by frequency band (steady offset,
   around the hose-drogue fundamental, above it), each beside the log's own
   level in the same band and channel over a quiet segment.
2. Which: every library effect that can change the kind's observables is
   screened by its sensitivity pattern (probe runs below and above the baseline
   per parameter: the share of the residual their directions span); the best
   `SCREEN_KEEP` are calibrated (a grid over their one or two most
   influential parameters, 10 points for one, 5 x 5 for two, 4 per axis
   beyond; then bounded least squares from the best grid point, and for two or
   more parameters from the runner-up too) and scored held-out; pairs of
   the best three are fitted when one effect leaves a real gap. Ranked by
   held-out gap times (1 + `PARAM_PENALTY` per parameter); a pair ranks above
   its better member only if it cuts that member's held-out gap by
   `PAIR_GAIN` and by more than the noise (Occam's rule).
3. How much: gap before, after on training data, after held out, per log and
   per family, with each parameter's standard error (Gauss-Newton covariance
   of the fit on all logs).
"""
from __future__ import annotations

import dataclasses
import functools
import html as _html
import json
import math
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from flighttest import FlightRecord, analyze_record, read_record
from flighttest import metrics as M
from solver.effects import EFFECTS
from solver.integrate import DivergenceError, simulate
from solver.statics import StaticSolveError, solve_static
from workbench import log_inputs
from workbench.cases import Case, build_model, load_case
from workbench.effects_case import with_effects
from workbench.errors import InputError

TEMPLATES = Path(__file__).resolve().parent.parent / "cases" / "templates"
DIAG_KINDS = ("pitch_doublet", "trail", "engagement")

BIN_S = 0.25            # drogue channel averaging (a quarter of the shortest period seen)
VIDEO_WINDOW_S = 1.0    # video normal errors averaged per window and station
STATION_M = 3.0
BLOCK_S = 2.0           # alternating train / held-out time blocks within one log
NOISE_FACTOR = 2.0      # a gap under twice its noise floor is not a real gap
PARAM_PENALTY = 0.05    # each parameter must buy 5 % of held-out gap
SCREEN_KEEP = 5         # effects calibrated in full after the screen
PAIR_FROM = 3           # pairs among the best three singles
PAIR_WHEN_LEFT = 0.2    # fit a pair when the best single leaves this share of the gap
PAIR_GAIN = 0.25        # a pair ranks above its members only if it shrinks their best held-out gap by this share
DEFAULT_ELEMENTS = 20   # 20 elements move the static drogue by ~1 mm against 40, at half the cost

# The parameters calibrated, per effect: the one or two that move the
# observables most, with the search range (inside the registry's), the probe
# value for the sensitivity screen and whether the grid is logarithmic.
# Effects that are absent: why (reported in diagnosis.json).
CALIBRATE: dict[str, list[tuple[str, float, float, float, bool]]] = {
    "drogue_lift": [("scale", 0.0, 3.0, 0.5, False)],
    "drogue_drag": [("scale", 0.3, 3.0, 1.5, True)],
    "hose_drag": [("crossflow", 0.25, 4.0, 1.6, True)],
    "hose_stiffness": [("bending", 0.1, 10.0, 3.0, True)],
    "steady_wind": [("vertical_mps", -6.0, 6.0, 1.0, False), ("lateral_mps", -6.0, 6.0, 1.0, False)],
    "tanker_wake": [("strength", 0.0, 3.0, 0.5, False)],
    "bow_wave": [("strength", 0.0, 3.0, 1.0, False)],
    "sensor_lag": [("delay_s", -0.8, 0.8, 0.15, False)],
    "reel_lag": [("dead_time_s", 0.0, 1.0, 0.2, False)],
}
NOT_CALIBRATED = {
    "turbulence": "a random field: its realisation cannot be fitted to a time history; its level shows "
                  "in the where-map's band above the steady offset against the log's own noise",
    "gust": "a transient whose timing and shape are free; a localised residual in one phase of the "
            "where-map is its signature",
}


def applicable(effect: str, kind: str, case: Case, rec: FlightRecord) -> str | None:
    """Why `effect` cannot change this log's observables, or None when it can."""
    if effect in NOT_CALIBRATED:
        return NOT_CALIBRATED[effect]
    if effect not in CALIBRATE:
        return "no calibration set up"
    if effect == "bow_wave" and kind != "engagement":
        return "no receiver near the drogue"
    if effect == "bow_wave" and "/receiver/probe" not in rec.topics:
        return "the log has no probe track"
    if effect == "reel_lag" and case["model"]["reel"] != "drum":
        return "the reel is not simulated (the baseline prescribes the logged payout or locks it)"
    if effect == "sensor_lag" and kind == "trail":
        return "a steady trail does not move: a time shift of the tracker changes nothing"
    if effect == "tanker_wake" and (not case["hardware"].get("tanker") or not rec.info.raw.get("tanker_gross_weight_lb")):
        return "needs the tanker and its gross weight on the test card"
    if effect == "hose_stiffness" and kind == "trail":
        return "a steady trail of a long hose hangs on tension, not bending"
    return None


# ---- baseline case from a log ---------------------------------------------------------

def baseline_case(rec: FlightRecord, n_elements: int | None = None) -> Case:
    """The kind's template with the log's hardware ids."""
    kind = rec.info.test_kind
    if kind not in DIAG_KINDS:
        raise InputError(f"{rec.path}: diagnose handles {', '.join(DIAG_KINDS)} logs, not {kind!r}")
    case = load_case(TEMPLATES / f"{kind}.toml")
    raw = rec.info.raw
    if not raw.get("hose"):
        raise InputError(f"{rec.path}: the test card names no hose")
    tables = dict(case.tables)
    tables["hardware"] = {k: raw.get(k) or None for k in ("hose", "drogue", "reel", "tanker")}
    case = dataclasses.replace(case, id=f"{case.id}:{rec.info.test_id}", path=str(rec.path), tables=tables)
    return _with_elements(case, n_elements)


def _with_elements(case: Case, n_elements: int | None) -> Case:
    """The case with `n_elements` hose elements (None: its own)."""
    if not n_elements:
        return case
    tables = dict(case.tables)
    tables["model"] = dict(tables["model"], n_elements=int(n_elements))
    return dataclasses.replace(case, tables=tables)


@dataclasses.dataclass(frozen=True)
class Setup:
    """What a diagnosis simulates a log with: the kind's template with the
    log's hardware ids (`case_path` None), or one case file with a variant's
    model overrides (a validation variant calibrated on its training logs);
    `n_elements` None keeps the case's own."""

    n_elements: int | None = DEFAULT_ELEMENTS
    case_path: str | None = None
    overrides: tuple = ()

    def case_for(self, rec: FlightRecord) -> Case:
        if self.case_path is None:
            return baseline_case(rec, self.n_elements)
        return _with_elements(load_case(self.case_path), self.n_elements)


def family_of(rec: FlightRecord) -> str:
    """Logs of one kind on one hose, drogue and tanker form a family."""
    r = rec.info.raw
    return f"{rec.info.test_kind}/{r.get('tanker') or '-'}/{r.get('hose')}"


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


def observe(path: str | Path) -> Observed:
    rec = read_record(path)
    return _observe(rec)


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

_REC_CACHE: dict = {}
_OBS_CACHE: dict = {}


def _record(path: str) -> FlightRecord:
    if path not in _REC_CACHE:
        _REC_CACHE.clear() if len(_REC_CACHE) > 16 else None
        _REC_CACHE[path] = read_record(path)
    return _REC_CACHE[path]


def _observed(path: str) -> Observed:
    if path not in _OBS_CACHE:
        _OBS_CACHE[path] = _observe(_record(path))
    return _OBS_CACHE[path]


def _freeze(effects: Mapping) -> tuple:
    return tuple(sorted((k, tuple(sorted((p, round(float(v), 9)) for p, v in d.items())))
                        for k, d in effects.items()))


@functools.lru_cache(maxsize=256)
def _simulate_frozen(path: str, frozen: tuple, setup: Setup):
    effects = {k: dict(v) for k, v in frozen}
    rec = _record(path)
    case = setup.case_for(rec)
    if effects:
        case = with_effects(case, effects)
    model = build_model(case, record=rec, variant=dict(setup.overrides))
    t0 = float(model.tow.t[0])
    s0 = solve_static(model, t0)
    kind = rec.info.test_kind
    if kind == "trail":
        pts = s0.pos.copy()
        # the hose line the video sees ends at the drogue's hinge, i.e. the last hose node
        line = pts[:-1] if model.drogue is not None else pts
        return {"t": np.array([t0]), "end": pts[-1:].copy(), "hose": lambda t, line=line: line}
    if case["model"]["drogue_after_contact"] == "from_log":
        model.end = log_inputs.probe_held_drogue(case, model, rec, s0.pos[-1])
    t_end = float(rec.topic("/ors/drogue").index[-1])
    res = simulate(model, t_end, s0, record_dt=float(case["run"]["record_dt_s"]))
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
    ({name: {param: value}}; comparison-only ones act on the comparison)."""
    phys = {k: v for k, v in effects.items() if not EFFECTS[k].comparison_only}
    delay = float(effects.get("sensor_lag", {}).get("delay_s", 0.0))
    sim = dict(_simulate_frozen(path, _freeze(phys), setup))
    sim["delay"] = delay
    return residual(_observed(path), sim)


BAD = 5.0   # m: a residual component standing in for a diverged or unsolvable run


def _safe_eval(path, effects, setup, like: Residual | None):
    try:
        return evaluate(path, effects, setup)
    except (DivergenceError, StaticSolveError, ValueError, FloatingPointError):
        if like is None:
            raise
        return dataclasses.replace(like, r=np.full_like(like.r, BAD))


def gap(r) -> float:
    return float(np.sqrt(np.mean(np.square(r)))) if len(r) else float("nan")


# ---- calibration of one candidate -------------------------------------------------------

def _params_of(candidate: tuple) -> list[tuple[str, str, float, float, float, bool]]:
    return [(eff, *p) for eff in candidate for p in CALIBRATE[eff]]


def _effects_at(candidate, x) -> dict:
    out: dict = {}
    for (eff, name, *_), v in zip(_params_of(candidate), x):
        out.setdefault(eff, {})[name] = float(v)
    return out


def _to_u(p, v):
    _, _, lo, hi, _, log = p
    return (math.log(v / lo) / math.log(hi / lo)) if log else (v - lo) / (hi - lo)


def _from_u(p, u):
    _, _, lo, hi, _, log = p
    u = min(max(u, 0.0), 1.0)
    return lo * (hi / lo) ** u if log else lo + u * (hi - lo)


def _baseline_u(p) -> float:
    eff, name, lo, hi, _, _ = p
    return _to_u(p, min(max(EFFECTS[eff].params[name].default if eff in ("steady_wind", "sensor_lag") else
                            (0.0 if eff in ("tanker_wake", "bow_wave") else 1.0), lo), hi))


def fit(paths: list[str], candidate: tuple, setup: Setup, seg: int | None, base: dict) -> dict:
    """Calibrate `candidate`'s parameters on `paths` (all components, or only
    segment `seg` of each): a grid in the unit cube, then bounded least
    squares from its best point(s). Returns params (x), their standard errors and
    the training gap."""
    ps = _params_of(candidate)
    n = len(ps)

    def res(u):
        x = [_from_u(p, ui) for p, ui in zip(ps, u)]
        eff = _effects_at(candidate, x)
        out = []
        for pth in paths:
            R = _safe_eval(pth, eff, setup, base[pth])
            out.append(R.r if seg is None else R.r[R.seg == seg])
        return np.concatenate(out)
    # a dense first grid: the engagement's objective is rough in its parameters
    # (slack-hose dynamics), so the local polish only refines what the grid found
    grid_1d = np.linspace(0.0, 1.0, {1: 10, 2: 5}.get(n, 4))
    if n == 1:
        starts = [np.array([g]) for g in grid_1d]
    else:
        starts = [np.array(u) for u in np.stack(np.meshgrid(*[grid_1d] * n), -1).reshape(-1, n)]
    starts.append(np.array([_baseline_u(p) for p in ps]))
    scored = sorted((gap(res(u)), i) for i, u in enumerate(starts))
    # refine from the best grid point, and for two or more parameters from the
    # runner-up too (a valley across the grid); starts are nudged off the bounds,
    # where a projected gradient can vanish at a corner that is not a minimum
    best_gap, u, sol = scored[0][0], starts[scored[0][1]], None
    for _, i in scored[:1 if n == 1 else 2]:
        s = least_squares(res, np.clip(starts[i], 0.02, 0.98), bounds=(np.zeros(n), np.ones(n)), diff_step=0.02,
                          max_nfev=8 * n + 4, x_scale=np.full(n, 0.1))
        if sol is None or gap(s.fun) < gap(sol.fun):
            sol = s
    if gap(sol.fun) <= best_gap:
        u = sol.x
    r = res(u)
    x = [_from_u(p, ui) for p, ui in zip(ps, u)]
    # standard errors: Gauss-Newton covariance in the unit cube, mapped to the
    # parameters by the local slope of the (possibly logarithmic) map; the
    # Jacobian by steps into the cube from the final point (the solver's own is
    # zeroed on a parameter that ends at its bound)
    J = np.empty((len(r), n))
    for i in range(n):
        step = 0.02 if u[i] + 0.02 <= 1.0 else -0.02
        du = np.array(u, float)
        du[i] += step
        J[:, i] = (res(du) - r) / step
    dof = max(len(r) - n, 1)
    s2 = float(r @ r) / dof
    try:
        cov = np.linalg.pinv(J.T @ J) * s2
        su = np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        su = np.full(n, np.nan)
    se = []
    for p, ui, s in zip(ps, u, su):
        d = 1e-4
        slope = (_from_u(p, min(ui + d, 1)) - _from_u(p, max(ui - d, 0))) / (min(ui + d, 1) - max(ui - d, 0))
        se.append(abs(slope) * s)
    return {"x": x, "stderr": se, "gap_train": gap(r)}


def calibrate(case: Case, overrides: Mapping, effects: list[str], paths: list[str],
              n_elements: int | None = None) -> dict:
    """A validation variant's `effects` calibrated on its training logs
    (`paths`) with the case's own model and `overrides`: the diagnosis's fit
    on all components of those logs. Returns {"effects": {name: {param:
    value}}, "stderr": {...}, "gap_before", "gap_train", "on"}."""
    setup = Setup(n_elements, str(case.path), tuple(sorted(overrides.items())))
    candidate = tuple(sorted(effects, key=list(EFFECTS).index))
    base = {p: evaluate(p, {}, setup) for p in paths}
    f = fit(list(paths), candidate, setup, None, base)
    return {"effects": _effects_at(candidate, f["x"]), "stderr": _effects_at(candidate, f["stderr"]),
            "gap_train": f["gap_train"], "gap_before": gap([gap(base[p].r) for p in paths]),
            "on": [Path(p).stem for p in paths]}


def _score_candidate(job) -> dict:
    """One candidate on one family: fitted per fold and on all logs; each
    fold's held-out gap. Runs in a worker process (or a Dask worker)."""
    paths, candidate, setup = job
    t_start = time.perf_counter()
    base = {p: evaluate(p, {}, setup) for p in paths}
    folds = []
    if len(paths) == 1:
        # two folds: fit on the A blocks, score on B, and the other way round
        p = paths[0]
        fs = []
        for seg in (0, 1):
            f = fit(paths, candidate, setup, seg, base)
            eff = _effects_at(candidate, f["x"])
            R = _safe_eval(p, eff, setup, base[p])
            folds.append({"held_out": f"{Path(p).stem} segment {'BA'[seg]}", "params": f["x"],
                          "gap_train": gap(R.r[R.seg == seg]), "gap_heldout": gap(R.r[R.seg != seg])})
            fs.append(f)
        # reported: the mean of the two folds' values, their spread folded into the error
        f = {"x": [0.5 * (a + b) for a, b in zip(fs[0]["x"], fs[1]["x"])],
             "stderr": [math.hypot(0.5 * (sa + sb), 0.5 * (a - b))
                        for a, b, sa, sb in zip(fs[0]["x"], fs[1]["x"], fs[0]["stderr"], fs[1]["stderr"])]}
        per_log = {Path(p).stem: gap(_safe_eval(p, _effects_at(candidate, f["x"]), setup, base[p]).r)}
    else:
        per_log = {}
        for k, p in enumerate(paths):
            train = [q for q in paths if q != p]
            f = fit(train, candidate, setup, None, base)
            eff = _effects_at(candidate, f["x"])
            R = _safe_eval(p, eff, setup, base[p])
            folds.append({"held_out": Path(p).stem, "params": f["x"], "gap_train": f["gap_train"],
                          "gap_heldout": gap(R.r)})
    if len(paths) == 1:
        full = f      # one log: the parameters are those fitted on its training segment
    else:
        full = fit(paths, candidate, setup, None, base)
        eff = _effects_at(candidate, full["x"])
        for p in paths:
            per_log[Path(p).stem] = gap(_safe_eval(p, eff, setup, base[p]).r)
    params, unc = _effects_at(candidate, full["x"]), _effects_at(candidate, full["stderr"])
    return {"effect": "+".join(candidate), "effects": list(candidate), "n_params": len(_params_of(candidate)),
            "params": params if len(candidate) > 1 else params[candidate[0]],
            "param_stderr": unc if len(candidate) > 1 else unc[candidate[0]],
            "gap_after_train": gap([f["gap_train"] for f in folds]),
            "gap_after_heldout": gap([f["gap_heldout"] for f in folds]),
            "gap_after_all_fit_per_log": per_log, "folds": folds,
            "wall_s": time.perf_counter() - t_start}


# ---- screening --------------------------------------------------------------------------

def _screen_job(job):
    """One effect's sensitivity directions on one log: per parameter, the
    residual change at its probe value and at the probe mirrored about the
    baseline (in the search's own scale), so that a response that bends, or
    differs below and above the baseline, still spans the residual."""
    path, effect, setup = job
    base = evaluate(path, {}, setup)
    cols = []
    for p in [(effect, *q) for q in CALIBRATE[effect]]:
        u0 = _baseline_u(p)
        for u in (_to_u(p, p[4]), 2.0 * u0 - _to_u(p, p[4])):
            if not 0.0 <= u <= 1.0 or abs(u - u0) < 1e-9:
                continue
            R = _safe_eval(path, {effect: {p[1]: _from_u(p, u)}}, setup, base)
            cols.append((R.r - base.r) / (u - u0))
    return path, effect, np.column_stack(cols)


def screen_scores(paths, effects, setup, base: dict, mapper) -> dict:
    """Share of the baseline residual (all logs together) that each effect's
    sensitivity directions span: 1 - |r - S a|^2 / |r|^2 at the least-squares a."""
    jobs = [(p, e, setup) for e in effects for p in paths]
    sens: dict = {}
    for p, e, S in mapper(_screen_job, jobs):
        sens.setdefault(e, {})[p] = S
    r = np.concatenate([base[p].r for p in paths])
    out = {}
    for e in effects:
        S = np.vstack([sens[e][p] for p in paths])
        if not np.any(np.abs(S) > 0):
            out[e] = 0.0
            continue
        a, *_ = np.linalg.lstsq(S, -r, rcond=None)
        out[e] = float(1.0 - np.sum((r + S @ a) ** 2) / max(np.sum(r ** 2), 1e-30))
    return out


# ---- the where-map ----------------------------------------------------------------------

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


def where_map(ob: Observed, R: Residual) -> dict:
    """The baseline residual split by channel, station, phase and band, each beside the log's own floor."""
    out: dict = {"test_id": ob.test_id, "kind": ob.kind, "gap_m": gap(R.r),
                 "noise_floor_m": gap(R.floor), "fundamental_hz": ob.f0}
    out["real"] = bool(out["gap_m"] > NOISE_FACTOR * out["noise_floor_m"])
    chans = {}
    for lab in np.unique(R.label):
        s = R.label == lab
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
    t, d = R.raw["drogue"]
    qa, qb = ob.phases[0][1], ob.phases[0][2]
    quiet = (ob.ors_t >= qa) & (ob.ors_t < qb)
    bands = {}
    for c, name in enumerate(("x", "y", "z")):
        res_b = _band_rms(t, d[:, c], ob.f0)
        if quiet.sum() > 32:
            y = ob.ors_xyz[quiet, c]
            own = _band_rms(ob.ors_t[quiet], y - np.median(y), ob.f0)
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


# ---- the diagnosis ----------------------------------------------------------------------

def _local_mapper(workers: int | None):
    workers = workers or max(1, min(os.cpu_count() or 1, 8))

    def mapper(fn, jobs):
        jobs = list(jobs)
        if workers <= 1 or len(jobs) <= 1:
            return [fn(j) for j in jobs]
        with ProcessPoolExecutor(max_workers=min(workers, len(jobs))) as pool:
            return list(pool.map(fn, jobs))
    return mapper


def _dask_mapper(address: str):
    from distributed import Client
    client = Client(address)

    def mapper(fn, jobs):
        futs = client.map(fn, list(jobs), pure=False)
        return client.gather(futs)
    mapper.client = client
    return mapper


def diagnose_family(paths: list[str], setup: Setup = Setup(), mapper: Callable | None = None,
                    progress: Callable[[str], None] | None = None) -> dict:
    """The where-map, ranking and gaps of one family of logs."""
    mapper = mapper or _local_mapper(None)
    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    paths = [str(p) for p in paths]
    recs = {p: _record(p) for p in paths}
    kind = recs[paths[0]].info.test_kind
    case = setup.case_for(recs[paths[0]])
    base = {p: evaluate(p, {}, setup) for p in paths}
    obs = {p: _observed(p) for p in paths}
    gap_before = gap([gap(base[p].r) for p in paths])
    floor = gap([gap(base[p].floor) for p in paths])
    if len(paths) == 1:
        R = base[paths[0]]
        gap_before_heldout = gap_before_train = gap(R.r)
    else:
        gap_before_heldout = gap_before_train = gap_before
    where = {Path(p).stem: where_map(obs[p], base[p]) for p in paths}
    say(f"{family_of(recs[paths[0]])}: baseline gap {gap_before:.3f} m, noise floor {floor:.3f} m")

    excluded = {}
    cands = []
    for e in EFFECTS:
        why = applicable(e, kind, case, recs[paths[0]])
        if why:
            excluded[e] = why
        else:
            cands.append(e)
    scores = screen_scores(paths, cands, setup, base, mapper)
    order = sorted(cands, key=lambda e: -scores[e])
    keep = [e for e in order[:SCREEN_KEEP]]
    say("screen: " + ", ".join(f"{e} {scores[e]:.2f}" for e in order))
    jobs = [(paths, (e,), setup) for e in keep]
    singles = list(mapper(_score_candidate, jobs))
    singles.sort(key=lambda c: c["gap_after_heldout"] * (1 + PARAM_PENALTY * c["n_params"]))
    results = list(singles)
    best = singles[0] if singles else None
    if best and best["gap_after_heldout"] > PAIR_WHEN_LEFT * gap_before_heldout and \
            best["gap_after_heldout"] > NOISE_FACTOR * floor and len(singles) > 1:
        top = [c["effects"][0] for c in singles[:PAIR_FROM]]
        pairs = [(a, b) for i, a in enumerate(top) for b in top[i + 1:]]
        pairs = [tuple(sorted(pr, key=list(EFFECTS).index)) for pr in pairs]
        say("pairs: " + ", ".join("+".join(p) for p in pairs))
        results += list(mapper(_score_candidate, [(paths, pr, setup) for pr in pairs]))
    for c in results:
        c["gap_before"] = gap_before_heldout if len(paths) == 1 else gap_before
        c["gap_before_train"] = gap_before_train
        c["shrink_heldout"] = 1.0 - c["gap_after_heldout"] / gap_before_heldout if gap_before_heldout else None
        c["score"] = c["gap_after_heldout"] * (1 + PARAM_PENALTY * c["n_params"])
        c["screen_share"] = {e: scores.get(e) for e in c["effects"]}
    # Occam's rule for pairs: the second effect must earn its place on held-out data,
    # cutting the better member's gap by PAIR_GAIN and by more than the noise; a pair
    # that only polishes a single effect's fit ranks behind that single effect.
    by_effect = {c["effects"][0]: c for c in singles}
    for c in results:
        if len(c["effects"]) < 2:
            continue
        member = min((by_effect[e] for e in c["effects"] if e in by_effect),
                     key=lambda m: m["score"], default=None)
        if member is None:
            continue
        gain = member["gap_after_heldout"] - c["gap_after_heldout"]
        if not (gain > PAIR_GAIN * member["gap_after_heldout"] and gain > NOISE_FACTOR * floor):
            c["score"] = max(c["score"], member["score"] * (1 + 1e-9))
            c["why_not_first"] = (f"does not cut {member['effects'][0]}'s held-out gap by "
                                  f"{PAIR_GAIN:.0%} and more than the noise")
    results.sort(key=lambda c: c["score"])
    none = {"effect": "none", "effects": [], "n_params": 0, "params": {}, "param_stderr": {},
            "gap_before": gap_before_heldout if len(paths) == 1 else gap_before,
            "gap_after_train": gap_before_train, "gap_after_heldout": gap_before_heldout,
            "shrink_heldout": 0.0, "score": gap_before_heldout}
    within_noise = gap_before <= NOISE_FACTOR * floor
    if within_noise or not results or results[0]["score"] >= none["score"]:
        none["why"] = ("the baseline explains the logs to within their noise" if within_noise else
                       "no effect shrinks the held-out gap by more than its parameter penalty")
        ranking = [none] + results
    else:
        ranking = results + [none]
    remaining = ranking[0]["gap_after_heldout"]
    # where the gap lies once the best explanation is in (its parameters fitted
    # on all logs): what is left for the next effect to explain
    after = {}
    if ranking[0]["effect"] != "none":
        best_eff = (ranking[0]["params"] if len(ranking[0]["effects"]) > 1
                    else {ranking[0]["effect"]: ranking[0]["params"]})
        after = {Path(p).stem: where_map(obs[p], _safe_eval(p, best_eff, setup, base[p])) for p in paths}
    return {"family": family_of(recs[paths[0]]), "kind": kind, "logs": [Path(p).stem for p in paths],
            "n_elements": setup.n_elements, "gap_definition": GAP_DEFINITION[kind],
            "gap_before": gap_before, "noise_floor": floor, "gap_real": not within_noise,
            "held_out_scheme": ("two folds over alternate %.0f s blocks of the one log (fit on A, score on B; "
                                "fit on B, score on A)" % BLOCK_S
                                if len(paths) == 1 else "leave one log out"),
            "screen": {e: scores[e] for e in order}, "screened_out": order[SCREEN_KEEP:],
            "not_applicable": excluded, "ranking": ranking,
            "remaining_unexplained": {"gap_m": remaining,
                                      "above_noise_m": math.sqrt(max(remaining ** 2 - floor ** 2, 0.0))},
            "gap": where, "gap_after_best": after, "wall_s": time.perf_counter() - t_start}


def _bound_note(effect: str, name: str, v: float) -> str:
    """' (at the search bound ...)' when a calibrated value ended on a bound:
    the logs want it there or beyond, and its error is one-sided."""
    for n, lo, hi, *_ in CALIBRATE.get(effect, []):
        if n == name and (abs(v - lo) <= 1e-6 * (hi - lo) or abs(v - hi) <= 1e-6 * (hi - lo)):
            return f" (at the search bound {lo:g}..{hi:g}: the logs want it there or beyond)"
    return ""


def findings(d: dict) -> list[str]:
    """Plain sentences from a family's numbers: what was found, how sure, what is left."""
    top = d["ranking"][0]
    out = []
    head = (f"{d['family']} ({', '.join(d['logs'])}): baseline gap {d['gap_before']:.3f} m against a noise floor "
            f"of {d['noise_floor']:.3f} m.")
    if top["effect"] == "none":
        out.append(head + f" No effect needed: {top.get('why', '')}.")
        return out
    p, se = top["params"], top["param_stderr"]
    if "+" not in top["effect"]:
        p, se = {top["effect"]: p}, {top["effect"]: se}
    ptxt = ", ".join(f"{e}.{k} = {v:.3g} +/- {se[e][k]:.2g}{_bound_note(e, k, v)}"
                     for e, dd in p.items() for k, v in dd.items())
    out.append(head + f" Best explanation: {top['effect']} ({ptxt}); held-out gap {top['gap_before']:.3f} -> "
               f"{top['gap_after_heldout']:.3f} m ({100 * top['shrink_heldout']:.0f} % smaller), "
               f"{d['remaining_unexplained']['above_noise_m']:.3f} m of it above the noise floor.")
    for log, w in (d.get("gap_after_best") or {}).items():
        real = sorted((p for p in w["by_phase"] if p["real"]), key=lambda p: -p["gap_m"])
        chans = sorted(((k, v) for k, v in w["by_channel"].items() if v["real"]), key=lambda kv: -kv[1]["gap_m"])
        if not real and not chans:
            out.append(f"{log}: with {top['effect']} the residual is within the noise in every phase and channel.")
            continue
        out.append(f"{log}: with {top['effect']} the gap is {w['gap_m']:.3f} m; what is left lies in "
                   + ", ".join(f"{p['phase']} {p['gap_m']:.3f} m" for p in real[:3])
                   + (" and in " + ", ".join(f"{k} {v['gap_m']:.3f} m" for k, v in chans[:2]) if chans else "")
                   + ".")
    folds = top.get("folds") or []
    if len(d["logs"]) > 1 and folds:
        per = ", ".join(f"{f['held_out']} {f['gap_heldout']:.3f} m" for f in folds)
        out.append(f"Held out one at a time, each log's gap with {top['effect']} fitted on the others: {per}.")
        singles = [c for c in d["ranking"] if c["effect"] != "none" and "+" not in c["effect"]]
        for c in singles[:3]:
            vals = [f["params"] for f in c["folds"]]
            if vals and len(vals[0]) == 1:
                v = np.array([x[0] for x in vals])
                out.append(f"{c['effect']} fitted without each log in turn: "
                           + ", ".join(f"without {f['held_out']} {x:.3g}" for f, x in zip(c["folds"], v))
                           + f" (held-out gap {c['gap_after_heldout']:.3f} m).")
    return out


GAP_DEFINITION = {
    "pitch_doublet": "RMS over 0.25 s bins (2 s before the doublet to the end) of the tracker's drogue x, y, z "
                     "minus the simulation's, m",
    "trail": "RMS of the signed normal distances of the video hose's mean shape (1 m bins) from the simulated "
             "static hose, together with the median drogue x, y, z residuals, m",
    "engagement": "RMS of the video hose points' normal distances from the simulated hose, averaged per 1 s and "
                  "3 m station, together with the drogue x, y, z residuals in 0.25 s bins, m",
}


def group_families(paths) -> dict[str, list[str]]:
    fam: dict[str, list[str]] = {}
    for p in paths:
        rec = _record(str(p))
        fam.setdefault(family_of(rec), []).append(str(p))
    return {k: sorted(v) for k, v in fam.items()}


def diagnose(paths, out_dir: Path | None = None, n_elements: int = DEFAULT_ELEMENTS, workers: int | None = None,
             scheduler: str | None = None, progress: Callable[[str], None] | None = None) -> dict:
    """Diagnose every family among `paths`; write diagnosis.json and
    diagnosis.html under out_dir when given."""
    mapper = _dask_mapper(scheduler) if scheduler else _local_mapper(workers)
    try:
        fams = group_families(paths)
        out = {"logs": [str(p) for p in paths], "families": {}, "gap": {}, "ranking": [],
               "gap_definition": GAP_DEFINITION, "noise_factor": NOISE_FACTOR, "param_penalty": PARAM_PENALTY,
               "pair_gain": PAIR_GAIN,
               "scheduler": scheduler or "local processes"}
        for name, ps in fams.items():
            d = diagnose_family(ps, Setup(n_elements), mapper, progress)
            out["families"][name] = d
            out["gap"].update(d["gap"])
        out["findings"] = [f for d in out["families"].values() for f in findings(d)]
        if len(fams) == 1:
            out["ranking"] = next(iter(out["families"].values()))["ranking"]
        else:
            out["ranking"] = [{"family": k, **r} for k, d in out["families"].items() for r in d["ranking"][:1]]
    finally:
        if scheduler:
            mapper.client.close()
    if out_dir is not None:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "diagnosis.json").write_text(json.dumps(_clean(out), indent=1) + "\n")
        sec = report_section(out)
        (out_dir / "diagnosis.html").write_text(
            f"<!doctype html><meta charset='utf-8'><title>{sec['title']}</title><body>"
            f"<h1>{sec['title']}</h1>{sec['html']}</body>", encoding="utf-8")
    return out


def _clean(v):
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, (np.floating, np.integer)):
        return _clean(v.item())
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.ndarray):
        return _clean(v.tolist())
    return v


# ---- the report section -----------------------------------------------------------------

def _f(v, fmt="{:.3f}"):
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "&ndash;"
    return fmt.format(v)


def _params_text(c) -> str:
    if not c["params"]:
        return ""
    p, s = c["params"], c["param_stderr"]
    if c["effect"] and "+" not in c["effect"]:
        p, s = {c["effect"]: p}, {c["effect"]: s}
    return "; ".join(f"{e}.{k} = {v:.3g} &plusmn; {s[e][k]:.2g}" for e, d in p.items() for k, v in d.items())


def _where_paragraph(head: str, w: dict) -> str:
    """One log's where-map as a paragraph: channels, phases, stations, bands."""
    e = _html.escape
    cells = ", ".join(f"{e(k)} {_f(v['gap_m'])}/{_f(v['floor_m'])}{'' if v['real'] else ' (noise)'}"
                      for k, v in w["by_channel"].items())
    ph = ", ".join(f"{e(p['phase'])} {_f(p['gap_m'])}{'' if p['real'] else ' (noise)'}" for p in w["by_phase"])
    st = ""
    if w.get("by_station"):
        st = "; by station (m along the hose: mean residual) " + ", ".join(
            f"{r['station_from_m']:.0f}-{r['station_to_m']:.0f}: {r['mean_m']:+.2f}" for r in w["by_station"])
    bz = w["by_band"].get("drogue z", {})
    bands = ", ".join(f"{k} {_f(v['residual_m'])}/{_f(v['floor_m'])}" for k, v in bz.items())
    return (f"<p><b>{e(head)}</b>: gap {_f(w['gap_m'])} m (floor {_f(w['noise_floor_m'])}); by channel "
            f"(gap/floor) {cells}; by phase {ph}{st}; drogue z by band around "
            f"{_f(w['fundamental_hz'], '{:.2f}')} Hz (residual/log's own) {bands}.</p>")


def report_section(diag: dict, title: str = "Sim-to-real gap diagnosis") -> dict:
    """{"title", "html"} for validate's report (or diagnosis.html)."""
    e = _html.escape
    parts = [f"<p>Gap per family (m, defined below), before and after each effect, calibrated on training "
             f"data and scored held out; ranked by held-out gap &times; (1 + {PARAM_PENALTY:g} per parameter). "
             f"A gap under {NOISE_FACTOR:g}&times; its noise floor is noise. Scheduler: "
             f"{e(str(diag.get('scheduler')))}.</p>"]
    for name, d in diag["families"].items():
        parts.append(f"<h3>{e(name)}: {e(', '.join(d['logs']))}</h3>")
        parts.append(f"<p>{e(d['gap_definition'])}. Baseline gap {_f(d['gap_before'])} m against a noise floor of "
                     f"{_f(d['noise_floor'])} m ({'real' if d['gap_real'] else 'within noise'}); held out by "
                     f"{e(d['held_out_scheme'])}; {d['n_elements']} elements; {d['wall_s']:.0f} s.</p>")
        rows = "".join(
            f"<tr><td>{i + 1}</td><td>{e(c['effect'])}</td><td>{_params_text(c)}</td><td>{_f(c['gap_before'])}</td>"
            f"<td>{_f(c['gap_after_train'])}</td><td>{_f(c['gap_after_heldout'])}</td>"
            f"<td>{_f(100 * c['shrink_heldout'] if c.get('shrink_heldout') is not None else None, '{:.0f} %')}</td></tr>"
            for i, c in enumerate(d["ranking"]))
        parts.append("<table><tr><th>#</th><th>effect</th><th>parameters (&plusmn; 1 s.e.)</th><th>gap before</th>"
                     "<th>after, train</th><th>after, held out</th><th>held-out shrink</th></tr>" + rows + "</table>")
        parts.append(f"<p>Remaining after the best: {_f(d['remaining_unexplained']['gap_m'])} m, of which "
                     f"{_f(d['remaining_unexplained']['above_noise_m'])} m above the noise floor. Screen (share of "
                     f"the residual each effect's sensitivities span): "
                     + ", ".join(f"{e(k)} {v:.2f}" for k, v in d["screen"].items()) + ". Not calibrated: "
                     + "; ".join(f"{e(k)} ({e(v)})" for k, v in d["not_applicable"].items()) + ".</p>")
        for log, w in d["gap"].items():
            parts.append(_where_paragraph(f"{log}, baseline", w))
        for log, w in (d.get("gap_after_best") or {}).items():
            parts.append(_where_paragraph(f"{log}, with {d['ranking'][0]['effect']}", w))
    if diag.get("findings"):
        parts.append("<h3>Findings</h3><ul>" + "".join(f"<li>{e(s)}</li>" for s in diag["findings"]) + "</ul>")
    if diag.get("selftest"):
        s = diag["selftest"]
        kinds = "; ".join(f"{e(k)}: {v['n']} logs, top-1 {100 * v['top1']:.0f} %, median shrink "
                          f"{100 * v['median_shrink']:.0f} %" for k, v in s.get("by_kind", {}).items())
        parts.append(f"<h3>Proof on withheld effects</h3><p>{s['n']} generated logs (the solver with one library "
                     f"effect at random parameters, light turbulence, sensor noise and dropouts; "
                     f"{s.get('n_elements_truth', '?')} elements against the diagnosis's "
                     f"{s.get('n_elements_diagnosis', '?')}), effect withheld: right effect first in "
                     f"{100 * s['top1']:.0f} %, median held-out shrink {100 * s['median_shrink']:.0f} % "
                     f"(at least 70 % in {100 * s.get('share_shrink_ge_70pct', float('nan')):.0f} % of the logs); "
                     f"{kinds}; {s['wall_s']:.0f} s.</p>")
    return {"title": title, "html": "\n".join(parts)}
