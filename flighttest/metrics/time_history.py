"""Time histories: lag by cross-correlation, time-history error and the onset
of a ramp (hinge fit).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize, signal

from .sampling import as_float, median_rate_hz, parabolic_vertex, resample_uniform


@dataclass(frozen=True)
class TimeHistoryError:
    rms: float
    peak: float                  # max |measured - simulated|
    bias: float                  # mean(measured - simulated)
    lag_s: float                 # > 0: measured is late with respect to simulated
    correlation: float           # normalised cross-correlation at lag_s
    n: int
    t_start: float
    t_end: float
    tube_fraction: float | None  # share of measured samples inside the tube
    tube_pass: bool | None


def cross_correlation_lag(y_ref, y, fs: float, max_lag_s: float | None = None) -> tuple[float, float]:
    """Delay of `y` relative to `y_ref` (s; > 0 means y is late), and the peak correlation.

    Method: both de-meaned, full cross-correlation normalised by the
    product of norms, maximum within +-max_lag_s, refined between samples
    by a parabola through the three correlation values at the maximum.
    """
    a = as_float(y_ref) - np.mean(y_ref)
    b = as_float(y) - np.mean(y)
    norm = float(np.linalg.norm(a) * np.linalg.norm(b))
    if norm == 0:
        return float("nan"), float("nan")
    c = signal.correlate(b, a, mode="full", method="fft") / norm
    lags = signal.correlation_lags(len(b), len(a), mode="full")
    if max_lag_s is not None:
        m = np.abs(lags) <= max_lag_s * fs
        c, lags = c[m], lags[m]
    k = int(np.argmax(c))
    if 0 < k < len(c) - 1:
        d, peak = parabolic_vertex(c[k - 1], c[k], c[k + 1])
    else:
        d, peak = 0.0, c[k]
    return float((lags[k] + d) / fs), float(peak)


def time_history_error(t_meas, y_meas, t_sim, y_sim, *, max_lag_s: float | None = None,
                       tube_tol: float | None = None, tube_lag_s: float = 0.0) -> TimeHistoryError:
    """Compare a measured and a simulated channel on their own time bases.

    Method: only the overlap of the two time spans is used (never
    extrapolated); the simulation is interpolated linearly at the measured
    sample times (NaN dropouts skipped), giving the residual
    measured - simulated, its RMS, peak and bias.  The lag comes from
    `cross_correlation_lag` of both signals resampled onto a common uniform
    grid at the finer of the two median rates.  The tube test (when
    `tube_tol` is given) accepts a measured sample if it lies within
    `tube_tol` of the simulated values anywhere in [t - tube_lag_s,
    t + tube_lag_s], so small timing differences are tolerated.
    """
    tm, ym = as_float(t_meas), as_float(y_meas)
    ts, ys = as_float(t_sim), as_float(y_sim)
    okm = np.isfinite(tm) & np.isfinite(ym)
    oks = np.isfinite(ts) & np.isfinite(ys)
    tm, ym, ts, ys = tm[okm], ym[okm], ts[oks], ys[oks]
    if len(tm) < 2 or len(ts) < 2:
        raise ValueError("each channel needs at least 2 finite samples")
    lo, hi = max(tm[0], ts[0]), min(tm[-1], ts[-1])
    if hi <= lo:
        raise ValueError("the measured and simulated time spans do not overlap")
    m = (tm >= lo) & (tm <= hi)
    tmo, ymo = tm[m], ym[m]
    res = ymo - np.interp(tmo, ts, ys)
    fs = max(median_rate_hz(tm), median_rate_hz(ts))
    tg, ym_g = resample_uniform(tm, ym, fs, lo, hi)
    _, ys_g = resample_uniform(ts, ys, fs, lo, hi)
    n = min(len(ym_g), len(ys_g))
    if n >= 4:
        lag, corr = cross_correlation_lag(ys_g[:n], ym_g[:n], fs,
                                          max_lag_s if max_lag_s is not None else 0.25 * (hi - lo))
    else:
        lag, corr = float("nan"), float("nan")
    frac = ok_all = None
    if tube_tol is not None:
        fine = max(fs, 4.0 / max(tube_lag_s, 1e-9)) if tube_lag_s > 0 else fs
        fine = min(fine, 20.0 * fs)
        tf, yf = resample_uniform(ts, ys, fine)
        w = max(int(round(tube_lag_s * fine)), 0)
        if w > 0:
            from scipy.ndimage import maximum_filter1d, minimum_filter1d
            up = maximum_filter1d(yf, 2 * w + 1, mode="nearest")
            dn = minimum_filter1d(yf, 2 * w + 1, mode="nearest")
        else:
            up = dn = yf
        hi_env = np.interp(tmo, tf, up) + tube_tol
        lo_env = np.interp(tmo, tf, dn) - tube_tol
        inside = (ymo <= hi_env) & (ymo >= lo_env)
        frac = float(np.mean(inside)) if len(inside) else float("nan")
        ok_all = bool(np.all(inside))
    return TimeHistoryError(
        rms=float(np.sqrt(np.mean(res ** 2))), peak=float(np.max(np.abs(res))),
        bias=float(np.mean(res)), lag_s=lag, correlation=corr, n=int(len(res)),
        t_start=float(lo), t_end=float(hi), tube_fraction=frac, tube_pass=ok_all)


# --------------------------------------------------------------------------


def hinge_onset(t, y) -> tuple[float, float]:
    """Time at which a steady signal starts to ramp, and the ramp rate.

    Method: least-squares fit of y = b for t < t0, b + r (t - t0) after,
    over the samples given (a quiet stretch followed by the start of a
    move); for each trial t0 the level b and rate r are linear, and t0 is
    found by a scan over the sample times refined by a bounded scalar
    minimisation.  Unlike a threshold crossing, the result does not depend
    on how fast the ramp is, so two signals moving at different rates can
    be compared.  NaN samples are ignored.
    """
    t, y = as_float(t), as_float(y)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    if len(t) < 6:
        raise ValueError("hinge_onset needs at least 6 samples")

    def sse(t0: float) -> float:
        A = np.column_stack([np.ones_like(t), np.maximum(t - t0, 0.0)])
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = A @ coef - y
        return float(r @ r)

    cands = t[2:-2]
    costs = np.array([sse(c) for c in cands])
    k = int(np.argmin(costs))
    lo = cands[max(k - 1, 0)]
    hi = cands[min(k + 1, len(cands) - 1)]
    if hi > lo:
        sol = optimize.minimize_scalar(sse, bounds=(lo, hi), method="bounded",
                                       options={"xatol": 1e-5})
        t0 = float(sol.x) if sol.fun <= costs[k] else float(cands[k])
    else:
        t0 = float(cands[k])
    A = np.column_stack([np.ones_like(t), np.maximum(t - t0, 0.0)])
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return t0, float(coef[1])
