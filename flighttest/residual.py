"""The one comparison of a flight log with a simulated record in the log contract.

`residual(log, sim)` returns a `Residual`: log minus simulation as a vector of
averaged, hence nearly noise-free, components (m), each tagged with its
channel (drogue x / y / z, hose), station (m along the hose, NaN for the
drogue), the log's test phase, time, segment (alternating `BLOCK_S` blocks,
the held-out folds of the diagnosis), band (what the averaging passes) and its
noise floor.  Validation's metrics (`compare.compare`) and the diagnosis's gap
are both computed from it.

Components, by test kind:

* pitch_doublet: the tracker's drogue x, y, z minus the simulation's
  (interpolated at each fix), averaged in `BIN_S` bins from 2 s before the
  doublet to the last fix (steady offset and dynamic response together;
  0.25 s is a quarter of the fastest drogue period seen).
* trail: per segment, the signed normal distances of the video hose's mean
  shape (`SHAPE_BIN_M` bins along x) from the simulation's mean line over the
  segment, and the median drogue x, y, z minus the simulation's median.
  Every log bin stays a component whatever the simulated line does, so the
  vector's length does not depend on the simulation (least squares).
* engagement: the drogue as for a doublet, from the first fix; and the signed
  normal distances of every video point from the simulated hose of the same
  frame, averaged per `VIDEO_WINDOW_S` window and `STATION_M` station.

* every kind, after those (unless `signatures=False`): the signature
  components (`flighttest.signatures`, channel "signature"): the tracker's
  phase against the tow point, the drogue's growth before contact, the hose's
  curvature along a trail; each in metres, with its band naming the feature.
  Validation's metrics do not use them.

A component's noise floor is what the averaging leaves of the log's own
scatter: its spread about the average over sqrt(samples averaged).

The simulated record is anything in the log contract: `result_to_record`
output, a one-frame record of a static solution, or a log itself (a record
against itself gives a zero residual).  The log side is measured once
(`observe`), so that the diagnosis, which compares one log with hundreds of
simulations, pays only for the simulated side.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd
from scipy import signal

from . import metrics as M
from . import signatures as S
from .analyze import analyze_record
from .record import FlightRecord

BIN_S = 0.25            # s, drogue channel averaging
VIDEO_WINDOW_S = 1.0    # s, engagement video normal distances averaged per window...
STATION_M = 3.0         # m, ... and station
BLOCK_S = 2.0           # s, alternating segments (train / held-out blocks within one log)
SHAPE_BIN_M = 1.0       # m, the trail's mean shape bins along x
FRAME_MATCH_S = 0.06    # s, a simulated frame stands for a video frame within just over half the 0.1 s video interval
DROGUE = ("drogue x", "drogue y", "drogue z")


# ---- the log's test phases ---------------------------------------------------------------

def engagement_moments(rec: FlightRecord) -> dict[str, float]:
    """The paper's six moments of an engagement (Fig. 19), found in the log:
    contact and disconnect (probe events); maximum slack and wave (largest
    sag of the video hose from its tow-point-to-drogue chord in the 6 s after
    contact); slack developing (half way from contact to maximum slack);
    maximum reel take-up (least hose out); refuelling steady state (half way
    from maximum take-up to disconnect)."""
    tc, td = rec.contact_events()
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
        rel = p - p[0]
        sag = np.max(np.abs(chord[0] * rel[:, 1] - chord[1] * rel[:, 0]) / n)
        if sag > best:
            best, t_sag = sag, float(tf)
    reel = rec.topic("/reel/hose_out")
    tr = reel.index.to_numpy(float)
    L = reel["length_m"].to_numpy(float)
    w = (tr >= tc) & (tr <= td)
    t_take = float(tr[w][np.argmin(L[w])]) if w.any() else tc
    return {"contact": tc, "slack": 0.5 * (tc + t_sag), "max_slack_wave": t_sag,
            "max_reel_takeup": t_take, "refuelling_steady": 0.5 * (t_take + td), "disconnect": td}


def test_phases(rec: FlightRecord, a: dict) -> tuple[tuple[str, float, float], ...]:
    """(name, t_from, t_to) of the log's test phases; `a` its `analyze_record`."""
    kind = rec.info.test_kind
    ors = rec.topic("/ors/drogue")
    t_start, t_end = float(ors.index[0]), float(ors.index[-1])
    if kind == "pitch_doublet":
        d0, d1 = a["doublet_start_s"], a["doublet_end_s"]
        settle = a["steady_window_s"][0] if a.get("steady_window_s") else t_end
        settle = max(settle, d1)
        return (("steady trail", t_start, d0), ("doublet", d0, d1), ("free response", d1, settle),
                ("settled", settle, t_end))
    if kind == "trail":
        return (("steady trail", t_start, t_end),)
    m = engagement_moments(rec)
    tc, td = m["contact"], m["disconnect"]
    t_wave = max(m["max_slack_wave"], tc + 0.5)
    t_take = min(max(m["max_reel_takeup"], t_wave), td)
    return (("approach", t_start, tc), ("contact", tc, tc + 0.5), ("slack and wave", tc + 0.5, t_wave + 1.0),
            ("reel take-up", t_wave + 1.0, max(t_take, t_wave + 1.0)),
            ("refuelling", max(t_take, t_wave + 1.0), td), ("disconnect", td, t_end))


def _fundamental(t: np.ndarray, z: np.ndarray, a: dict) -> float:
    """The drogue's fundamental (Hz): the analysed frequency, else the dominant
    one of the detrended height between 0.1 and 3 Hz, else 0.5 Hz."""
    if a.get("drogue_frequency_hz"):
        return float(a["drogue_frequency_hz"])
    fs = M.median_rate_hz(t)
    _, zg = M.resample_uniform(t, z, fs)
    try:
        return float(M.dominant_frequency(signal.detrend(zg), fs, fmin=0.1, fmax=3.0).frequency_hz)
    except ValueError:
        return 0.5


# ---- the log side, measured once ---------------------------------------------------------

def segment_of(t) -> np.ndarray:
    """0 or 1: which alternating `BLOCK_S` block the times fall in."""
    return np.floor(np.asarray(t, float) / BLOCK_S).astype(int) % 2


@dataclasses.dataclass(frozen=True, eq=False)
class Observation:
    """What `residual` needs of a log, measured once: the valid tracker fixes,
    the drogue bin edges, the test phases, the drogue's fundamental and the
    video hose points (finite ones; trail and engagement)."""

    path: str
    test_id: str
    kind: str
    fix_t: np.ndarray
    fix_xyz: np.ndarray
    bins: np.ndarray
    phases: tuple
    fundamental_hz: float
    video: tuple | None = None      # (t, x, z) of every video point
    analysis: dict = dataclasses.field(default_factory=dict)
    shapes: tuple | None = None     # trail: the video hose's mean shape per segment
    signatures: S.LogSignatures = S.LogSignatures()


def observe(log: FlightRecord) -> Observation:
    """The log side of every comparison of `log`."""
    kind = log.info.test_kind
    a = analyze_record(log)
    fixes = log.tracker_fixes()
    t = fixes.index.to_numpy(float)
    xyz = fixes[["x_m", "y_m", "z_m"]].to_numpy(float)
    t0 = max(a["doublet_start_s"] - 2.0, t[0]) if kind == "pitch_doublet" else t[0]
    video = shapes = seg_times = None
    if kind in ("trail", "engagement"):
        h = log.topic("/video/hose")
        tv, xv, zv = (h[c].to_numpy(float) for c in ("t_s", "x_m", "z_m"))
        ok = np.isfinite(tv) & np.isfinite(xv) & np.isfinite(zv)
        video = (tv[ok], xv[ok], zv[ok])
    if kind == "trail":
        sel = [segment_of(video[0]) == seg for seg in (0, 1)]
        shapes = tuple(M.mean_shape(video[1][s], video[2][s], bin_m=SHAPE_BIN_M) for s in sel)
        seg_times = [float(np.median(video[0][s])) for s in sel]
    f = _fundamental(t, xyz[:, 2], a)
    sig = S.measure(log, kind, t, xyz, t0, f, segment_of, shapes, seg_times)
    return Observation(str(log.path), log.info.test_id, kind, t, xyz, np.arange(t0, t[-1] + 1e-9, BIN_S),
                       test_phases(log, a), f, video, a, shapes, sig)


# ---- the residual ------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True, eq=False)
class Residual:
    """Log minus simulation, component by component (see the module's docstring).

    `r`, `floor` (m) and the tags `channel`, `station` (m, NaN: drogue),
    `phase`, `t` (s), `segment` (0/1), `band` have one entry per component.
    `drogue` is the unaveraged drogue residual at the fixes, (t, (n, 3) m);
    `hose` one row per compared hose point (a trail: per mean-shape bin; an
    engagement: per video point) with its time, x, station, signed normal
    distance, vertical distance at equal x, and whether its foot lies inside
    the simulated line (not clamped to an end), None for a doublet.
    """

    r: np.ndarray
    floor: np.ndarray
    channel: np.ndarray
    station: np.ndarray
    phase: np.ndarray
    t: np.ndarray
    segment: np.ndarray
    band: np.ndarray
    drogue: tuple
    hose: pd.DataFrame | None
    observation: Observation

    def __post_init__(self):
        n = len(self.r)
        for name in ("floor", "channel", "station", "phase", "t", "segment", "band"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"Residual: {name} has {len(getattr(self, name))} entries for {n} components")

    @property
    def gap(self) -> float:
        """RMS of the components (m), NaN when there are none."""
        return rms(self.r)

    @property
    def noise_floor(self) -> float:
        """RMS of the components' noise floors (m)."""
        return rms(self.floor)

    def to_pandas(self) -> pd.DataFrame:
        """One row per component, units in the column names."""
        return pd.DataFrame({"channel": self.channel, "station_m": self.station, "phase": self.phase,
                             "t_s": self.t, "segment": self.segment, "band": self.band,
                             "residual_m": self.r, "floor_m": self.floor})


def rms(v) -> float:
    """Root mean square, NaN for no values."""
    v = np.asarray(v, float)
    return float(np.sqrt(np.mean(np.square(v)))) if len(v) else float("nan")


def _phase_of(t: np.ndarray, phases) -> np.ndarray:
    """The name of the phase each time falls in (the first whose [from, to)
    holds it; before the first phase its name, after the last the last's)."""
    names = np.full(len(t), phases[-1][0], dtype=object)
    names[t < phases[0][1]] = phases[0][0]
    for name, a, b in reversed(phases):
        names[(t >= a) & (t < b)] = name
    return names


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


class _Parts:
    """Components as they are built, concatenated at the end."""

    def __init__(self):
        self.cols = {k: [] for k in ("r", "floor", "channel", "station", "t", "segment", "band")}

    def add(self, r, floor, channel, station, t, segment, band):
        n = len(r)
        for k, v in zip(self.cols, (r, floor, channel, station, t, segment, band)):
            self.cols[k].append(np.broadcast_to(np.asarray(v), (n,)) if np.ndim(v) == 0 else np.asarray(v))

    def done(self, ob: Observation, drogue, hose) -> Residual:
        c = {k: (np.concatenate(v) if v else np.array([])) for k, v in self.cols.items()}
        return Residual(c["r"].astype(float), c["floor"].astype(float), c["channel"].astype(object),
                        c["station"].astype(float), _phase_of(c["t"], ob.phases), c["t"].astype(float),
                        c["segment"].astype(int), c["band"].astype(object), drogue, hose, ob)


def _nearest(times: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Index of the sorted `times` nearest each of `t`, the earlier on a tie."""
    j = np.clip(np.searchsorted(times, t), 1, max(len(times) - 1, 1))
    return np.where(np.abs(times[j - 1] - t) <= np.abs(times[j] - t), j - 1, j) if len(times) > 1 \
        else np.zeros(len(t), int)


def _frames(sim: FlightRecord):
    """The simulated video: frame times and each frame's (x, z) line, points in order."""
    h = sim.topic("/video/hose").sort_values(["t_s", "point"], kind="stable")
    t = h["t_s"].to_numpy(float)
    xz = h[["x_m", "z_m"]].to_numpy(float)
    times, first = np.unique(t, return_index=True)
    return times, np.split(xz, first[1:])


def _mean_line(times, lines, seg: int) -> np.ndarray:
    """The simulation's mean hose line over segment `seg` (all its frames when
    none fall in it, e.g. a static solution's one frame): node by node when the
    frames share their points (a simulation's nodes), else the mean shape of
    the points in `SHAPE_BIN_M` bins along x (a digitised video)."""
    w = segment_of(times) == seg
    sel = [ln for ln, k in zip(lines, w) if k] if w.any() else list(lines)
    if len({len(ln) for ln in sel}) == 1:
        return np.mean(np.stack(sel), axis=0)
    p = np.concatenate(sel)
    shp = M.mean_shape(p[:, 0], p[:, 1], bin_m=SHAPE_BIN_M)
    return shp[["x_m", "z_m"]].to_numpy(float)


def _vertical(x, z, line) -> np.ndarray:
    """z minus the line's z at equal x, NaN outside its x-range or where it does not advance in x."""
    out = np.full(len(x), np.nan)
    if np.all(np.diff(line[:, 0]) > 0):
        inx = (x >= line[0, 0]) & (x <= line[-1, 0])
        out[inx] = z[inx] - np.interp(x[inx], line[:, 0], line[:, 1])
    return out


def _trail(ob: Observation, sim: FlightRecord, fixes: np.ndarray, parts: _Parts):
    tv, xv, zv = ob.video
    times, lines = _frames(sim)
    sd = sim.tracker_fixes()
    sd_t, sd_xyz = sd.index.to_numpy(float), sd[["x_m", "y_m", "z_m"]].to_numpy(float)
    rows, drogue, seg_lines = [], np.full_like(ob.fix_xyz, np.nan), []
    for seg in (0, 1):
        sel = segment_of(tv) == seg
        line = _mean_line(times, lines, seg)
        seg_lines.append(line)
        shp = ob.shapes[seg]
        x, z = shp["x_m"].to_numpy(float), shp["z_m"].to_numpy(float)
        e, station, inside, _, _ = M.project_onto_polyline(np.column_stack([x, z]), line)
        n = np.maximum(shp["n"].to_numpy(float), 1.0)
        t_mid = float(np.median(tv[sel]))
        # the station of a bin is the log's own x, which a hose trailing aft advances along
        parts.add(e, np.nan_to_num(shp["z_std_m"].to_numpy(float) / np.sqrt(n)), "hose", x, t_mid, seg, "steady")
        rows.append(pd.DataFrame({"t_s": t_mid, "x_m": x, "station_m": station, "normal_m": e,
                                  "vertical_m": _vertical(x, z, line), "inside": inside}))
        so = segment_of(ob.fix_t) == seg
        w = segment_of(sd_t) == seg
        sim_end = np.median(sd_xyz[w] if w.any() else sd_xyz, axis=0)
        d = fixes[so] - sim_end
        drogue[so] = d
        parts.add(np.median(d, axis=0), np.std(fixes[so], axis=0) / math.sqrt(max(so.sum(), 1)),
                  np.array(DROGUE), np.nan, float(np.median(ob.fix_t[so])), seg, "steady")
    return drogue, pd.concat(rows, ignore_index=True), seg_lines


def _drogue_bins(ob: Observation, sim: FlightRecord, fixes: np.ndarray, delay_s: float, parts: _Parts):
    """The drogue residual at the fixes (a tracker latency `delay_s` means a fix
    stamped t shows the drogue at t - delay_s) and its `BIN_S` bin means."""
    sd = sim.tracker_fixes()
    ts, xyz = sd.index.to_numpy(float), sd[["x_m", "y_m", "z_m"]].to_numpy(float)
    tq = ob.fix_t - delay_s
    d = fixes - np.column_stack([np.interp(tq, ts, xyz[:, c]) for c in range(3)])
    band = f"below {0.5 / BIN_S:g} Hz"
    for c, name in enumerate(DROGUE):
        mean, fl, mid = _bin_stats(ob.fix_t, d[:, c], ob.bins)
        parts.add(mean, fl, name, np.nan, mid, segment_of(mid), band)
    return d


def _engagement_hose(ob: Observation, sim: FlightRecord, parts: _Parts) -> pd.DataFrame:
    """Every video point's signed normal distance from the simulated hose of
    its frame (the simulated frame nearest in time, within `FRAME_MATCH_S`),
    then averaged per window and station."""
    tv, xv, zv = ob.video
    times, lines = _frames(sim)
    frames = np.unique(tv)
    k = _nearest(times, frames)
    matched = np.abs(times[k] - frames) <= FRAME_MATCH_S
    of_point = np.searchsorted(frames, tv)
    use = matched[of_point]
    e = np.full(len(tv), np.nan)
    station = np.full(len(tv), np.nan)
    inside = np.zeros(len(tv), bool)
    e[use], station[use], inside[use] = M.project_onto_polylines(
        np.column_stack([xv[use], zv[use]]), lines, k[of_point[use]])
    ok = np.isfinite(e)
    tt, ee, xx = tv[ok], e[ok], xv[ok]
    w = np.floor(tt / VIDEO_WINDOW_S).astype(int)
    b = np.clip(np.floor(xx / STATION_M).astype(int), 0, 999)
    uk, inv, cnt = np.unique(w * 1000 + b, return_inverse=True, return_counts=True)
    s = np.bincount(inv, weights=ee)
    s2 = np.bincount(inv, weights=ee * ee)
    good = cnt >= 3
    mean = s / cnt
    var = np.maximum(s2 / cnt - mean ** 2, 0.0) * cnt / np.maximum(cnt - 1, 1)
    mid_t = (uk // 1000 + 0.5) * VIDEO_WINDOW_S
    parts.add(mean[good], np.sqrt(var[good] / cnt[good]), "hose", ((uk % 1000) + 0.5)[good] * STATION_M,
              mid_t[good], segment_of(mid_t[good]), f"below {0.5 / VIDEO_WINDOW_S:g} Hz")
    return pd.DataFrame({"t_s": tv, "x_m": xv, "station_m": station, "normal_m": e,
                         "vertical_m": np.nan, "inside": inside})


def residual(log: FlightRecord | Observation, sim: FlightRecord, *, delay_s: float = 0.0,
             tracker_offset_m: float = 0.0, signatures: bool = True) -> Residual:
    """Log minus `sim` (a record in the log contract), component by component;
    `log` may be its `observe`d form, measured once for many simulations.
    `delay_s`: the tracker's latency, applied to the log's fix times (doublet
    and engagement drogue channels). `tracker_offset_m`: how far aft (x) of the
    simulated drogue point the tracked point lies, taken off the log's fixes.
    `signatures`: with the signature components (`flighttest.signatures`,
    channel "signature") after the others."""
    ob = log if isinstance(log, Observation) else observe(log)
    parts = _Parts()
    hose = lines = None
    fixes = ob.fix_xyz - np.array([tracker_offset_m, 0.0, 0.0]) if tracker_offset_m else ob.fix_xyz
    if ob.kind == "trail":
        d, hose, lines = _trail(ob, sim, fixes, parts)
    elif ob.kind in ("pitch_doublet", "engagement"):
        d = _drogue_bins(ob, sim, fixes, delay_s, parts)
        if ob.kind == "engagement":
            hose = _engagement_hose(ob, sim, parts)
    else:
        raise ValueError(f"{ob.path}: no residual for test kind {ob.kind!r}")
    if signatures:
        _signatures(ob, sim, lines, delay_s, parts)
    return parts.done(ob, (ob.fix_t, d), hose)


def _signatures(ob: Observation, sim: FlightRecord, lines, delay_s: float, parts: _Parts):
    """The signature components of `sim` against the log's, measured at `observe`."""
    sig = ob.signatures
    if not (sig.phase or sig.bow or sig.curve):
        return
    sim_t = sim_xyz = tow = None
    if sig.phase or sig.bow:
        sd = sim.tracker_fixes()
        sim_t, sim_xyz = sd.index.to_numpy(float), sd[["x_m", "y_m", "z_m"]].to_numpy(float)
    if sig.phase:
        tw = sim.topic("/tanker/tow_point")
        tow = (tw.index.to_numpy(float), tw["z_m"].to_numpy(float))
    for r, fl, station, t, seg, band in S.components(sig, ob.fix_t, sim_t, sim_xyz, tow, lines, delay_s, segment_of):
        parts.add(np.array([r]), fl, S.CHANNEL, station, t, seg, band)
