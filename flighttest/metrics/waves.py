"""Waves along the hose: gridding video shapes onto stations and wave speed
from cross-correlation or front arrivals.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import optimize

from .sampling import as_float
from .time_history import cross_correlation_lag


def hose_field(t_s, x_m, z_m, x_stations) -> tuple[np.ndarray, np.ndarray]:
    """Grid hose shapes (long format: one row per point) onto fixed x stations.

    Returns (frame times, Z) with Z[frame, station] = z interpolated
    linearly along x within that frame's points, NaN outside its x-range.
    """
    t, x, z = as_float(t_s), as_float(x_m), as_float(z_m)
    xs = as_float(x_stations)
    order = np.argsort(t, kind="stable")
    t, x, z = t[order], x[order], z[order]
    frames, start = np.unique(t, return_index=True)
    bounds = np.append(start, len(t))
    Z = np.full((len(frames), len(xs)), np.nan)
    for i in range(len(frames)):
        fx, fz = x[bounds[i]:bounds[i + 1]], z[bounds[i]:bounds[i + 1]]
        if len(fx) < 2:
            continue
        o = np.argsort(fx)
        fx, fz = fx[o], fz[o]
        m = (xs >= fx[0]) & (xs <= fx[-1])
        Z[i, m] = np.interp(xs[m], fx, fz)
    return frames, Z


@dataclass(frozen=True)
class WaveSpeed:
    speed_mps: float              # magnitude
    direction: int                # +1 toward +x (downstream), -1 upstream, 0 both ends
    stderr_mps: float
    x_m: np.ndarray = field(repr=False)
    times_s: np.ndarray = field(repr=False)   # lags or arrival times per station
    method: str = ""


def wave_speed_xcorr(t, x_stations, Z, *, ref: int | None = None,
                     max_lag_s: float | None = None) -> WaveSpeed:
    """Speed of a wave travelling one way along the stations, by space-time correlation.

    Method: each station's time history (uniform t; NaN bridged linearly)
    is de-meaned and cross-correlated with a reference station (middle by
    default); the lag of the correlation peak, refined by a parabola,
    is the travel time.  A straight line lag = a + x / c fitted to the lags
    gives the signed speed c (> 0: toward +x); the standard error follows
    from the slope's standard error.
    """
    t, xs, Z = as_float(t), as_float(x_stations), as_float(Z)
    fs = 1.0 / float(np.median(np.diff(t)))
    ref = len(xs) // 2 if ref is None else ref
    cols = []
    for j in range(len(xs)):
        zj = Z[:, j]
        ok = np.isfinite(zj)
        cols.append(np.interp(t, t[ok], zj[ok]) if ok.sum() >= 2 else np.full(len(t), np.nan))
    lags = np.full(len(xs), np.nan)
    for j in range(len(xs)):
        if np.all(np.isfinite(cols[j])) and np.all(np.isfinite(cols[ref])):
            lags[j], _ = cross_correlation_lag(cols[ref], cols[j], fs, max_lag_s)
    ok = np.isfinite(lags)
    if ok.sum() < 3:
        raise ValueError("fewer than 3 stations with a correlation lag")
    (slope, icpt), cov = np.polyfit(xs[ok], lags[ok], 1, cov=True)
    if slope == 0:
        return WaveSpeed(float("inf"), 0, float("nan"), xs, lags, "space-time correlation")
    c = 1.0 / slope
    se = float(math.sqrt(max(cov[0, 0], 0.0)) / slope ** 2)
    return WaveSpeed(float(abs(c)), int(np.sign(c)), se, xs, lags, "space-time correlation")


def front_arrival_times(t, Z, t_event: float, *, baseline_s: float = 2.0, frac: float = 0.5,
                        min_snr: float = 4.0, lobe_fraction: float = 0.5,
                        horizon_s: float = 5.0) -> np.ndarray:
    """Arrival time, after `t_event`, of the first disturbance at each station.

    Method: each station's deviation from its mean over the `baseline_s`
    before the event; the first lobe is the first run of same-sign
    deviation whose peak exceeds both `min_snr` baseline standard
    deviations and `lobe_fraction` of the largest deviation within
    `horizon_s` (so a noise blip before the front is not taken for it); the
    arrival is where the deviation first reaches `frac` of that lobe's peak
    (linear interpolation between frames).  Using a fixed fraction of each
    station's own peak times the same phase of the front everywhere,
    whatever its amplitude there.  NaN where no lobe is found.
    """
    t, Z = as_float(t), as_float(Z)
    pre = (t >= t_event - baseline_s) & (t < t_event)
    post = (t >= t_event) & (t <= t_event + horizon_s)
    out = np.full(Z.shape[1], np.nan)
    for j in range(Z.shape[1]):
        zb = Z[pre, j]
        zb = zb[np.isfinite(zb)]
        zp, tp = Z[post, j], t[post]
        ok = np.isfinite(zp)
        zp, tp = zp[ok], tp[ok]
        if len(zb) < 3 or len(zp) < 3:
            continue
        d = zp - zb.mean()
        thr = max(min_snr * zb.std(ddof=1), lobe_fraction * np.abs(d).max(), 1e-12)
        # Runs of one sign: [a, b) index ranges.
        sgn_all = np.sign(d)
        cuts = np.flatnonzero(np.diff(sgn_all)) + 1
        starts = np.concatenate([[0], cuts])
        stops = np.concatenate([cuts, [len(d)]])
        first = next(((a, b) for a, b in zip(starts, stops) if np.abs(d[a:b]).max() > thr), None)
        if first is None:
            continue
        a, b = first
        sgn = sgn_all[a]
        lobe = sgn * d[a:b]
        level = frac * lobe.max()
        i = a + int(np.argmax(lobe >= level))
        if i == 0:
            out[j] = tp[0] - t_event
            continue
        d0, d1 = sgn * d[i - 1], sgn * d[i]
        w = (level - d0) / (d1 - d0) if d1 != d0 else 0.0
        out[j] = tp[i - 1] + w * (tp[i] - tp[i - 1]) - t_event
    return out


def wave_speed_from_arrivals(x, t_arrival) -> WaveSpeed:
    """Wave speed from front arrival times, allowing fronts from both ends.

    Method: a disturbance entering at either end of the hose reaches
    station x at t = min(a + x/c, b - x/c) (downstream-going front from the
    tow point, upstream-going front from the drogue, one wave speed c).
    The model is fitted by robust (soft-L1) least squares; when one branch
    is never the earlier it reduces to a single straight line and
    `direction` gives its sense.  The standard error of c comes from the
    Jacobian at the solution.
    """
    x, ta = as_float(x), as_float(t_arrival)
    ok = np.isfinite(x) & np.isfinite(ta)
    x, ta = x[ok], ta[ok]
    if len(x) < 4:
        raise ValueError("fewer than 4 stations with an arrival time")
    span = float(x.max() - x.min())
    slope1 = float(np.polyfit(x, ta, 1)[0])

    def model(p):
        a, b, s = p
        return np.minimum(a + s * x, b - s * x)

    best = None
    for s0 in (abs(slope1), 0.5 * abs(slope1) + 1e-3, 2 * abs(slope1) + 1e-3, 0.01, 0.05):
        for split in np.quantile(x, [0.25, 0.5, 0.75, 1.0]):
            a0 = float(np.median(ta[x <= split] - s0 * x[x <= split])) if np.any(x <= split) else 0.0
            b0 = float(np.median(ta[x >= split] + s0 * x[x >= split])) if np.any(x >= split) \
                else a0 + 2 * s0 * x.max()
            sol = optimize.least_squares(lambda p: model(p) - ta, [a0, b0, s0],
                                         bounds=([-np.inf, -np.inf, 1e-6], [np.inf, np.inf, np.inf]),
                                         loss="soft_l1", f_scale=0.02)
            if best is None or sol.cost < best.cost:
                best = sol
    a, b, s = best.x
    # Where the two branches meet decides whether both fronts were seen.
    x_meet = (b - a) / (2 * s)
    both = x.min() + 0.1 * span < x_meet < x.max() - 0.1 * span
    r = best.fun
    dof = max(len(x) - 3, 1)
    J = best.jac
    cov = np.linalg.pinv(J.T @ J) * float(r @ r) / dof
    se = float(math.sqrt(max(cov[2, 2], 0.0)) / s ** 2)
    direction = 0
    if not both:
        # One front only: a straight line is the model; its slope sign is the sense.
        (sl, _), cv = np.polyfit(x, ta, 1, cov=True)
        s = abs(sl)
        direction = 1 if sl > 0 else -1
        se = float(math.sqrt(max(cv[0, 0], 0.0)) / sl ** 2)
    return WaveSpeed(float(1.0 / s), direction, se, x, ta, "front arrival times")


# --------------------------------------------------------------------------
