"""Measurement functions on plain arrays (no I/O, no records).

Every function takes NumPy arrays in SI units (time in s, lengths in m,
frequency in Hz) and returns SI values; none of them knows which test a
signal came from.  Each docstring states the method, so a number in a report
can be traced to how it was measured.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import optimize, signal


# --------------------------------------------------------------------------
# Small helpers
# --------------------------------------------------------------------------

def _as_float(a) -> np.ndarray:
    return np.asarray(a, dtype=float)


def noise_std(y, order: int = 3) -> float:
    """Robust standard deviation of white noise riding on a smooth signal.

    Method: the `order`-th difference removes a slowly varying signal
    (for order 3, a sinusoid at f is attenuated by (2 pi f / fs)^3) while
    white noise of variance s^2 becomes variance C(2k, k) s^2 (20 s^2 for
    k = 3); the median absolute deviation of the differences, scaled by
    1.4826 / sqrt(C(2k, k)), estimates s and ignores the few samples where
    the signal is steep (an impulse, a release).
    """
    y = _as_float(y)
    y = y[np.isfinite(y)]
    if len(y) <= order + 2:
        return 0.0
    d = np.diff(y, n=order)
    med = np.median(d)
    return float(1.4826 * np.median(np.abs(d - med)) / math.sqrt(math.comb(2 * order, order)))


def resample_uniform(t, y, fs: float, t_start: float | None = None,
                     t_end: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation of (t, y) onto a uniform grid at `fs` Hz.

    NaN samples (dropouts) are skipped, so short gaps are bridged linearly;
    the grid never leaves [first valid t, last valid t] (no extrapolation).
    """
    t, y = _as_float(t), _as_float(y)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    if len(t) < 2:
        return np.zeros(0), np.zeros(0)
    lo = t[0] if t_start is None else max(t_start, t[0])
    hi = t[-1] if t_end is None else min(t_end, t[-1])
    if hi <= lo:
        return np.zeros(0), np.zeros(0)
    tg = lo + np.arange(int(math.floor((hi - lo) * fs + 1e-9)) + 1) / fs
    return tg, np.interp(tg, t, y)


def median_rate_hz(t) -> float:
    """Sample rate from the median sample spacing (robust to dropouts and jitter)."""
    t = _as_float(t)
    if len(t) < 2:
        return float("nan")
    return float(1.0 / np.median(np.diff(t)))


def _parabolic_vertex(y0: float, y1: float, y2: float) -> tuple[float, float]:
    """Offset (in samples, within +-0.5 normally) and height of the parabola through 3 points."""
    den = y0 - 2.0 * y1 + y2
    if den == 0.0:
        return 0.0, y1
    d = 0.5 * (y0 - y2) / den
    return d, y1 - 0.25 * (y0 - y2) * d


# --------------------------------------------------------------------------
# Frequency
# --------------------------------------------------------------------------

@dataclass(frozen=True)
class FrequencyEstimate:
    frequency_hz: float
    uncertainty_hz: float
    method: str


def dominant_frequency(y, fs: float, *, fmin: float = 0.0, fmax: float | None = None,
                       pad: int = 8) -> FrequencyEstimate:
    """Frequency of the largest spectral peak of a uniformly sampled segment.

    Method: remove a linear trend, apply a Hann window, zero-pad to at least
    `pad` times the length, take |FFT|, pick the largest bin in
    (fmin, fmax], and place the peak between bins by a parabola through the
    log magnitudes of the three bins around it (exact for a Gaussian peak,
    and the Hann main lobe is close to one).

    Uncertainty (stated, not rigorous): the root-sum-square of (a) the
    difference between the log-parabola and a linear-magnitude parabola
    (a measure of the interpolation error) and (b) the Rayleigh resolution
    fs/N scaled by the ratio of the median spectral magnitude in the band to
    the peak magnitude (how far noise can pull the peak).
    """
    y = _as_float(y)
    n = len(y)
    if n < 8 or not np.all(np.isfinite(y)):
        raise ValueError("dominant_frequency needs at least 8 finite samples")
    seg = signal.detrend(y, type="linear") * np.hanning(n)
    nfft = 1 << int(math.ceil(math.log2(max(pad, 1) * n)))
    mag = np.abs(np.fft.rfft(seg, nfft))
    freqs = np.fft.rfftfreq(nfft, 1.0 / fs)
    hi = fs / 2.0 if fmax is None else min(fmax, fs / 2.0)
    band = np.flatnonzero((freqs > fmin) & (freqs <= hi) & (freqs > 0))
    if len(band) < 3:
        raise ValueError("frequency band holds fewer than 3 spectral bins")
    k = band[np.argmax(mag[band])]
    df = fs / nfft
    if k - 1 < band[0] or k + 1 > band[-1] or mag[k] <= 0:
        return FrequencyEstimate(float(freqs[k]), float(fs / n), "fft-bin (peak at band edge)")
    a, b, c = mag[k - 1], mag[k], mag[k + 1]
    tiny = np.finfo(float).tiny
    d_log, _ = _parabolic_vertex(*np.log(np.maximum([a, b, c], tiny)))
    d_lin, _ = _parabolic_vertex(a, b, c)
    f = (k + d_log) * df
    noise_ratio = float(np.median(mag[band]) / mag[k])
    unc = math.hypot(abs(d_log - d_lin) * df, (fs / n) * noise_ratio)
    return FrequencyEstimate(float(f), float(unc), "hann+zero-pad FFT, log-parabolic peak")


# --------------------------------------------------------------------------
# Damping
# --------------------------------------------------------------------------

@dataclass(frozen=True)
class DampedFit:
    """Least-squares fit of y = exp(-s t)(a cos wt + b sin wt) + baseline."""

    frequency_hz: float           # damped (observed) frequency w / 2 pi
    natural_frequency_hz: float   # sqrt(s^2 + w^2) / 2 pi
    zeta: float                   # s / sqrt(s^2 + w^2)
    decay_rate_per_s: float       # s
    amplitude: float              # sqrt(a^2 + b^2) at the first sample
    frequency_stderr_hz: float
    zeta_stderr: float
    rms_residual: float
    baseline: str
    t0: float


def _fit_basis(tt: np.ndarray, p: np.ndarray, baseline: str) -> np.ndarray:
    s, w = p[0], p[1]
    env = np.exp(-s * tt)
    cols = [env * np.cos(w * tt), env * np.sin(w * tt)]
    if baseline in ("constant", "exp"):
        cols.append(np.ones_like(tt))
    if baseline == "exp":
        cols.append(np.exp(-p[2] * tt))
    return np.column_stack(cols)


def fit_damped_sinusoid(t, y, *, f0: float, zeta0: float = 0.05,
                        baseline: str = "exp") -> DampedFit:
    """Fit one exponentially decaying sinusoid to (t, y) by least squares.

    Method: variable projection: for each trial (decay rate s, angular
    frequency w [, baseline rate l]) the amplitudes and baseline are solved
    by linear least squares; scipy's trust-region least_squares searches the
    nonlinear parameters, started from f0 and a few decay rates around
    zeta0.  Times need not be uniform, so dropouts are simply absent samples.

    baseline: "none"; "constant" (DC offset); or "exp" (offset plus
    c exp(-l t)), which is exactly what a first-order high-pass (AC-coupled
    accelerometer) adds to a decaying sinusoid: the filter keeps the mode's
    poles and contributes one real pole of its own.

    Standard errors come from the Jacobian of the projected residual,
    scaled by the residual variance (they assume white noise).
    """
    t, y = _as_float(t), _as_float(y)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    if baseline not in ("none", "constant", "exp"):
        raise ValueError(f"unknown baseline {baseline!r}")
    if len(t) < 8:
        raise ValueError("fit_damped_sinusoid needs at least 8 samples")
    t0 = float(t[0])
    tt = t - t0
    span = float(tt[-1]) if tt[-1] > 0 else 1.0
    w0 = 2.0 * math.pi * f0

    def resid(p):
        A = _fit_basis(tt, p, baseline)
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        return A @ coef - y

    lo = [-5.0 / span, 0.5 * w0]
    hi = [max(5.0 * w0, 50.0 / span), 1.5 * w0]
    if baseline == "exp":
        lo.append(0.01 / span)
        hi.append(max(4.0 * w0, 100.0 / span))
    best = None
    for z in (zeta0, 0.3 * zeta0, 3.0 * zeta0):
        p0 = [min(max(z * w0, lo[0] + 1e-9), hi[0] - 1e-9), w0]
        if baseline == "exp":
            p0.append(min(max(w0 / 5.0, lo[2] * 2), hi[2] / 2))
        sol = optimize.least_squares(resid, p0, bounds=(lo, hi), x_scale="jac",
                                     xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
        # The other starts are insurance against a poor initial guess; a
        # solution near the guess, away from the bounds, does not need them.
        s_fit, w_fit = best.x[0], best.x[1]
        z_fit = s_fit / math.hypot(s_fit, w_fit)
        if (best.success and 0.5 * zeta0 < z_fit < 2.0 * zeta0
                and not np.any(np.isclose(best.x, lo)) and not np.any(np.isclose(best.x, hi))):
            break
    p = best.x
    s, w = float(p[0]), float(p[1])
    r = best.fun
    dof = max(len(y) - len(p) - (4 if baseline == "exp" else 3 if baseline == "constant" else 2), 1)
    var = float(r @ r) / dof
    J = best.jac
    try:
        cov = np.linalg.pinv(J.T @ J) * var
    except np.linalg.LinAlgError:
        cov = np.full((len(p), len(p)), np.nan)
    wn = math.hypot(s, w)
    zeta = s / wn
    # zeta = s / sqrt(s^2 + w^2): propagate (s, w) covariance.
    g = np.array([w * w / wn ** 3, -s * w / wn ** 3])
    zeta_se = float(math.sqrt(max(g @ cov[:2, :2] @ g, 0.0)))
    A = _fit_basis(tt, p, baseline)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    return DampedFit(
        frequency_hz=w / (2 * math.pi), natural_frequency_hz=wn / (2 * math.pi), zeta=zeta,
        decay_rate_per_s=s, amplitude=float(math.hypot(coef[0], coef[1])),
        frequency_stderr_hz=float(math.sqrt(max(cov[1, 1], 0.0)) / (2 * math.pi)),
        zeta_stderr=zeta_se, rms_residual=float(math.sqrt(float(r @ r) / len(r))),
        baseline=baseline, t0=t0)


@dataclass(frozen=True)
class LogDecrement:
    zeta: float
    spread: float                 # sample std of the per-half-cycle damping ratios
    frequency_hz: float           # damped frequency from the extremum spacing
    n_half_cycles: int
    times_s: np.ndarray = field(repr=False)
    peak_to_peak: np.ndarray = field(repr=False)
    zeta_per_half_cycle: np.ndarray = field(repr=False)


def _extrema(y: np.ndarray, fs: float, period: float) -> list[tuple[int, int]]:
    """Alternating (index, sign) extrema at least ~0.6 period apart."""
    dist = max(int(0.6 * period * fs), 1)
    pk, _ = signal.find_peaks(y, distance=dist)
    tr, _ = signal.find_peaks(-y, distance=dist)
    ev = sorted([(i, 1) for i in pk] + [(i, -1) for i in tr])
    out: list[tuple[int, int]] = []
    for i, sgn in ev:
        if out and out[-1][1] == sgn:
            if sgn * y[i] > sgn * y[out[-1][0]]:
                out[-1] = (i, sgn)
            continue
        out.append((i, sgn))
    return out


def _refine_extremum(t: np.ndarray, y: np.ndarray, i: int, half: int) -> tuple[float, float] | None:
    """Vertex of a least-squares parabola over +-half samples; None if not a true extremum.

    An extremum whose window is cut by the segment edge, or whose vertex
    falls outside its window, is a slope that noise made look like a peak
    (typically the first sample of a segment); it is dropped.
    """
    lo, hi = i - half, i + half + 1
    if lo < 0 or hi > len(y) or half < 1:
        return None
    tt = t[lo:hi] - t[i]
    c2, c1, c0 = np.polyfit(tt, y[lo:hi], 2)
    if c2 == 0.0:
        return None
    dt = -c1 / (2 * c2)
    if not tt[0] < dt < tt[-1]:
        return None
    return float(t[i] + dt), float(c0 - c1 * c1 / (4 * c2))


def log_decrement(t, y, *, f_hint: float | None = None, noise: float | None = None,
                  min_snr: float = 10.0, min_amplitude: float | None = None,
                  max_half_cycles: int | None = None) -> LogDecrement:
    """Damping ratio from the logarithmic decrement of successive extrema.

    Method: find alternating maxima and minima (at least 0.6 period apart),
    refine each by a least-squares parabola over +-period/10 (averages the
    noise), and form half-cycle peak-to-peak amplitudes D_k = |v_k - v_k+1|.
    Differencing adjacent extrema cancels a DC offset and, to first order,
    a slowly drifting baseline such as the tail of an AC-coupling high-pass.
    For y = A exp(-s t) cos(w t + p), D_k+1 / D_k = exp(-s pi / w) exactly,
    so s is minus the slope of a straight-line fit of ln D_k on time, w is
    pi over the mean extremum spacing, and zeta = s / sqrt(s^2 + w^2).
    Extrema are used while D_k exceeds `min_snr` times its own noise,
    derived from the white sample noise std (`noise`, or `noise_std(y)`),
    and `min_amplitude` when given (for coloured disturbances such as
    turbulence, which no averaging over a peak removes).  `spread` is the scatter of the
    half-cycle-to-half-cycle estimates, a measure of noise and of
    amplitude-dependent (nonlinear) damping.  Needs uniform sampling.
    """
    t, y = _as_float(t), _as_float(y)
    fs = 1.0 / float(np.median(np.diff(t)))
    if f_hint is None:
        f_hint = dominant_frequency(y, fs).frequency_hz
    period = 1.0 / f_hint
    sigma_n = noise_std(y) if noise is None else float(noise)
    ext = _extrema(y, fs, period)
    half = max(int(round(period * fs / 10.0)), 1)
    pts = [_refine_extremum(t, y, i, half) for i, _ in ext]
    # Keep the longest run of consecutive valid extrema (alternation intact).
    runs, cur = [], []
    for p in pts:
        if p is None:
            runs.append(cur)
            cur = []
        else:
            cur.append(p)
    runs.append(cur)
    # The run holding the biggest swing is the decay; long runs of noise
    # "extrema" after the decay must not win.
    mid = float(np.median(y))
    pts = max((r for r in runs if r), key=lambda r: max(abs(v - mid) for _, v in r), default=[])
    if len(pts) < 3:
        raise ValueError("fewer than 3 clean extrema: no oscillation to measure")
    te = np.array([p[0] for p in pts])
    ve = np.array([p[1] for p in pts])
    # Second difference of the extremum sequence: for alternating extrema
    # v_k = c + (-1)^k A r^k it is (-1)^k A r^k (1 + r)^2, so the ratio r
    # survives while a constant and a linearly drifting baseline cancel.
    D = np.abs(ve[:-2] - 2.0 * ve[1:-1] + ve[2:]) / 4.0
    tm = te[1:-1]
    # Start at the largest swing (the release) and stop at the first swing lost in noise.
    if len(D) == 0:
        raise ValueError("no oscillation found")
    # Noise of D: the vertex of a least-squares parabola over n samples has a
    # standard deviation of about 1.5 sigma / sqrt(n); the second difference
    # over 4 multiplies that by sqrt(6) / 4.
    n_win = 2 * half + 1
    sigma_d = sigma_n * 1.5 / math.sqrt(n_win) * math.sqrt(6.0) / 4.0
    cut = max(min_snr * sigma_d, min_amplitude or 0.0)
    k0 = int(np.argmax(D))
    keep = [k0]
    for k in range(k0 + 1, len(D)):
        if D[k] < cut or (max_half_cycles and len(keep) >= max_half_cycles):
            break
        keep.append(k)
    if len(keep) < 3:
        raise ValueError("fewer than 3 half cycles above the noise: damping not measurable")
    D, tm = D[keep], tm[keep]
    te_used = te[keep[0]:keep[-1] + 3]
    # ln D has variance ~ (noise / D)^2: weight by D so the last, noisiest
    # swings (which also sit just above the cut and are biased upward by it)
    # do not flatten the line.
    slope, _ = np.polyfit(tm, np.log(D), 1, w=D)
    s = -float(slope)
    half_period = float(np.polyfit(np.arange(len(te_used)), te_used, 1)[0])
    w = math.pi / half_period
    zeta = s / math.hypot(s, w)
    sk = -np.diff(np.log(D)) / np.diff(tm)
    zk = sk / np.hypot(sk, w)
    spread = float(np.std(zk, ddof=1)) if len(zk) > 1 else float("nan")
    return LogDecrement(zeta=float(zeta), spread=spread, frequency_hz=w / (2 * math.pi),
                        n_half_cycles=len(D), times_s=tm, peak_to_peak=D,
                        zeta_per_half_cycle=zk)


@dataclass(frozen=True)
class DampingEstimate:
    zeta: float                   # least-squares fit (primary)
    zeta_logdec: float
    zeta_fit: float
    spread: float                 # std of per-half-cycle log-decrement estimates
    method_difference: float      # |zeta_fit - zeta_logdec|
    frequency_hz: float           # damped frequency from the fit
    natural_frequency_hz: float
    frequency_uncertainty_hz: float
    n_half_cycles: int
    fit: DampedFit = field(repr=False)
    logdec: LogDecrement = field(repr=False)


def damping_ratio(t, y, *, f_hint: float | None = None, noise: float | None = None,
                  baseline: str = "exp", min_snr: float = 10.0,
                  min_amplitude: float | None = None) -> DampingEstimate:
    """Damping ratio of a free decay by two independent methods.

    Method: `log_decrement` (extremum amplitudes) and `fit_damped_sinusoid`
    (least squares on every sample, started from the log-decrement values).
    The fit is reported as `zeta` because it uses all samples; the
    log decrement is the cross-check, and their difference is reported.
    `t` must be uniformly sampled (the log decrement needs it); resample
    first with `resample_uniform` if the record has dropouts.
    """
    t, y = _as_float(t), _as_float(y)
    fs = 1.0 / float(np.median(np.diff(t)))
    if f_hint is None:
        f_hint = dominant_frequency(y, fs).frequency_hz
    ld = log_decrement(t, y, f_hint=f_hint, noise=noise, min_snr=min_snr,
                       min_amplitude=min_amplitude)
    fit = fit_damped_sinusoid(t, y, f0=ld.frequency_hz, zeta0=max(ld.zeta, 1e-3),
                              baseline=baseline)
    return DampingEstimate(
        zeta=fit.zeta, zeta_logdec=ld.zeta, zeta_fit=fit.zeta, spread=ld.spread,
        method_difference=abs(fit.zeta - ld.zeta), frequency_hz=fit.frequency_hz,
        natural_frequency_hz=fit.natural_frequency_hz,
        frequency_uncertainty_hz=math.hypot(fit.frequency_stderr_hz,
                                            abs(fit.frequency_hz - ld.frequency_hz)),
        n_half_cycles=ld.n_half_cycles, fit=fit, logdec=ld)


# --------------------------------------------------------------------------
# Ring-down segmentation and two-accelerometer decomposition
# --------------------------------------------------------------------------

@dataclass(frozen=True)
class DecaySegment:
    i_release: int
    i_start: int
    i_end: int
    frequency_hz: float


def free_decay_segment(t, y, *, f_hint: float | None = None, fmin: float = 0.0,
                       fmax: float | None = None, skip_cycles: float = 1.0,
                       end_fraction: float = 0.02, end_snr: float = 3.0) -> DecaySegment:
    """Locate the free decay of a ring-down (uniform sampling).

    Method: the release (hand let go, hammer strike) is the largest excursion
    from the median, |y - median(y)|.  The decay frequency is the dominant
    FFT peak of what follows (in (fmin, fmax]).  The segment starts
    `skip_cycles` periods after the release, once the release transient and
    faster modes have died away, and ends where the Hilbert envelope of the
    signal band-passed around that frequency (one octave each side) first
    falls below both `end_fraction` of its value at the start and `end_snr`
    times the noise floor; beyond that there is no information on the decay.
    """
    t, y = _as_float(t), _as_float(y)
    fs = 1.0 / float(np.median(np.diff(t)))
    i_rel = int(np.argmax(np.abs(y - np.median(y))))
    tail = y[i_rel:]
    if f_hint is None:
        f_hint = dominant_frequency(tail, fs, fmin=fmin, fmax=fmax).frequency_hz
    i0 = min(i_rel + int(round(skip_cycles * fs / f_hint)), len(y) - 1)
    lo, hi = f_hint / 2.0, min(2.0 * f_hint, 0.45 * fs)
    sos = signal.butter(2, [lo, hi], btype="bandpass", fs=fs, output="sos")
    bp = signal.sosfiltfilt(sos, y - np.median(y))
    env = np.abs(signal.hilbert(bp))
    # Smooth the envelope over one period so noise does not end the segment early.
    n_per = max(int(round(fs / f_hint)), 1)
    env = np.convolve(env, np.ones(n_per) / n_per, mode="same")
    floor = float(np.median(env[-max(len(env) // 10, n_per):]))
    # Mean envelope of white noise after the band-pass: the band keeps a
    # share 2 (hi - lo) / fs of its variance, and a Rayleigh envelope
    # averages sqrt(pi / 2) standard deviations.
    sigma = noise_std(y) * math.sqrt(2.0 * (hi - lo) / fs) * math.sqrt(math.pi / 2)
    # The floor is the larger of that and what the record's quiet tail shows
    # (sustained vibration of the rig, say), the latter capped at a tenth of
    # the starting amplitude in case the record ends before the decay does.
    thresh = max(end_fraction * env[i0], end_snr * max(sigma, min(floor, env[i0] / 10)))
    below = np.flatnonzero(env[i0:] < thresh)
    i1 = i0 + int(below[0]) if len(below) else len(y) - 1
    return DecaySegment(i_release=i_rel, i_start=i0, i_end=max(i1, i0 + 1), frequency_hz=f_hint)


def axial_rocking(a1, a2) -> tuple[np.ndarray, np.ndarray]:
    """Split two accelerometers at +-lever from the centre line.

    (a1 + a2)/2 is the axial (common) motion of the weight; (a1 - a2)/2 is
    the rocking part, the tangential acceleration at the lever arm (divide
    by the lever, m, for the angular acceleration in rad/s^2).
    """
    a1, a2 = _as_float(a1), _as_float(a2)
    return 0.5 * (a1 + a2), 0.5 * (a1 - a2)


# --------------------------------------------------------------------------
# Grouping repetitions
# --------------------------------------------------------------------------

def group_by_setpoint(setpoints, values) -> pd.DataFrame:
    """Mean and spread of repeated measurements at each setpoint.

    Returns one row per setpoint (sorted) with n, mean, std (sample std,
    ddof=1; NaN for a single repetition), sem = std/sqrt(n), min and max.
    NaN values are left out of their group.
    """
    df = pd.DataFrame({"setpoint": _as_float(setpoints), "value": _as_float(values)})
    df = df[np.isfinite(df["value"])]
    g = df.groupby("setpoint")["value"]
    out = pd.DataFrame({"n": g.count(), "mean": g.mean(), "std": g.std(ddof=1),
                        "min": g.min(), "max": g.max()})
    out["sem"] = out["std"] / np.sqrt(out["n"])
    return out


# --------------------------------------------------------------------------
# Shape comparison
# --------------------------------------------------------------------------

@dataclass(frozen=True)
class ShapeError:
    normal_error_m: np.ndarray      # signed, + when the point lies above/left of the line
    station_m: np.ndarray           # arc length of the foot point along the simulated line
    inside: np.ndarray              # foot point strictly within the line (not an end clamp)
    rms_m: float
    max_abs_m: float
    bins: pd.DataFrame              # per arc-length station bin: n, mean, rms
    vertical_error_m: np.ndarray    # z_meas - z_sim(x_meas), NaN outside the simulated x-range
    vertical_rms_m: float
    vertical_max_abs_m: float


def project_onto_polyline(q: np.ndarray, P: np.ndarray):
    """Foot points of points q (n, 2) on the polyline P (m, 2): the signed normal
    distance (positive on the left of the line walked from its first point,
    i.e. above a hose trailing aft), the arc-length station of the foot, and
    whether the foot lies strictly inside the line (not clamped to an end).
    Zero-length segments are dropped. Returns (err, station, inside, P, s_nodes)
    with the cleaned polyline and its nodes' arc lengths."""
    d = np.diff(P, axis=0)
    seg_len = np.hypot(d[:, 0], d[:, 1])
    if np.any(seg_len == 0):
        keep = np.concatenate([[True], seg_len > 0])
        P = P[keep]
        d = np.diff(P, axis=0)
        seg_len = np.hypot(d[:, 0], d[:, 1])
    s_nodes = np.concatenate([[0.0], np.cumsum(seg_len)])
    r = q[:, None, :] - P[None, :-1, :]
    u = np.clip((r[..., 0] * d[:, 0] + r[..., 1] * d[:, 1]) / seg_len ** 2, 0.0, 1.0)
    foot = P[None, :-1, :] + u[..., None] * d[None, :, :]
    dist = np.hypot(q[:, None, 0] - foot[..., 0], q[:, None, 1] - foot[..., 1])
    j = np.argmin(dist, axis=1)
    rows = np.arange(len(q))
    uj = u[rows, j]
    cross = d[j, 0] * r[rows, j, 1] - d[j, 1] * r[rows, j, 0]
    err = np.sign(cross) * dist[rows, j]
    station = s_nodes[j] + uj * seg_len[j]
    inside = ~(((j == 0) & (uj <= 0.0)) | ((j == len(d) - 1) & (uj >= 1.0)))
    return err, station, inside, P, s_nodes


def shape_error(x_meas, z_meas, x_sim, z_sim, *, bin_m: float = 1.0) -> ShapeError:
    """Distance of measured hose points from a simulated centre line.

    Method: for each measured point the nearest point of the simulated
    polyline (segment by segment projection) gives the signed normal
    distance (positive on the left of the line walked from the tow point,
    i.e. above a hose trailing aft) and the arc-length station of the foot.
    Points whose nearest foot is an end of the line are not normal
    distances and are left out of the statistics (`inside` is False).
    RMS and max use the inside points; `bins` groups them by station.
    The vertical error compares z at equal downstream distance x, by linear
    interpolation of the simulated line (which must advance in x), only
    where x lies inside the simulated range.
    """
    q = np.column_stack([_as_float(x_meas), _as_float(z_meas)])
    q = q[np.all(np.isfinite(q), axis=1)]
    P = np.column_stack([_as_float(x_sim), _as_float(z_sim)])
    if len(P) < 2:
        raise ValueError("simulated line needs at least 2 points")
    err, station, inside, P, s_nodes = project_onto_polyline(q, P)
    e_in = err[inside]
    rms = float(np.sqrt(np.mean(e_in ** 2))) if len(e_in) else float("nan")
    mx = float(np.max(np.abs(e_in))) if len(e_in) else float("nan")
    edges = np.arange(0.0, s_nodes[-1] + bin_m, bin_m)
    idx = np.clip(np.digitize(station[inside], edges) - 1, 0, len(edges) - 2)
    bdf = pd.DataFrame({"bin": idx, "e": e_in})
    g = bdf.groupby("bin")["e"]
    bins = pd.DataFrame({"station_lo_m": edges[:-1], "station_hi_m": edges[1:]})
    bins["n"] = g.count().reindex(range(len(edges) - 1), fill_value=0).to_numpy()
    bins["mean_m"] = g.mean().reindex(range(len(edges) - 1)).to_numpy()
    bins["rms_m"] = np.sqrt((bdf.assign(e2=bdf["e"] ** 2).groupby("bin")["e2"].mean())
                            .reindex(range(len(edges) - 1))).to_numpy()
    xs, zs = P[:, 0], P[:, 1]
    if np.all(np.diff(xs) > 0):
        inx = (q[:, 0] >= xs[0]) & (q[:, 0] <= xs[-1])
        vert = np.full(len(q), np.nan)
        vert[inx] = q[inx, 1] - np.interp(q[inx, 0], xs, zs)
    else:
        vert = np.full(len(q), np.nan)
    vv = vert[np.isfinite(vert)]
    return ShapeError(
        normal_error_m=err, station_m=station, inside=inside, rms_m=rms, max_abs_m=mx, bins=bins,
        vertical_error_m=vert,
        vertical_rms_m=float(np.sqrt(np.mean(vv ** 2))) if len(vv) else float("nan"),
        vertical_max_abs_m=float(np.max(np.abs(vv))) if len(vv) else float("nan"))


def mean_shape(x, z, *, bin_m: float = 1.0, x_min: float | None = None,
               x_max: float | None = None) -> pd.DataFrame:
    """Mean shape of a cloud of (x, z) points binned along x.

    Returns per bin: x_m (mean x of the points in the bin), z_m (mean z),
    z_std_m, n.  Bins with no points are dropped.
    """
    x, z = _as_float(x), _as_float(z)
    ok = np.isfinite(x) & np.isfinite(z)
    x, z = x[ok], z[ok]
    lo = np.floor(x.min() / bin_m) * bin_m if x_min is None else x_min
    hi = x.max() if x_max is None else x_max
    edges = np.arange(lo, hi + bin_m, bin_m)
    idx = np.digitize(x, edges) - 1
    df = pd.DataFrame({"bin": idx, "x": x, "z": z})
    df = df[(df["bin"] >= 0) & (df["bin"] < len(edges) - 1)]
    g = df.groupby("bin")
    out = pd.DataFrame({"x_m": g["x"].mean(), "z_m": g["z"].mean(),
                        "z_std_m": g["z"].std(ddof=1), "n": g["z"].count()})
    return out.reset_index(drop=True)


# --------------------------------------------------------------------------
# Time-history comparison
# --------------------------------------------------------------------------

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
    a = _as_float(y_ref) - np.mean(y_ref)
    b = _as_float(y) - np.mean(y)
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
        d, peak = _parabolic_vertex(c[k - 1], c[k], c[k + 1])
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
    tm, ym = _as_float(t_meas), _as_float(y_meas)
    ts, ys = _as_float(t_sim), _as_float(y_sim)
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
# Spectra
# --------------------------------------------------------------------------

def welch_psd(y, fs: float, *, segment_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectral density (units^2/Hz) by Welch's method.

    Hann windows of `segment_s` seconds (default: an eighth of the record,
    at least 16 samples) with 50 % overlap, linear detrend per segment.
    """
    y = _as_float(y)
    n = len(y)
    nper = n // 8 if segment_s is None else int(round(segment_s * fs))
    nper = int(min(max(nper, 16), n))
    return signal.welch(y, fs=fs, window="hann", nperseg=nper, noverlap=nper // 2,
                        detrend="linear")


def residual_spectrum(t_meas, y_meas, t_sim, y_sim, *, fs: float | None = None,
                      segment_s: float | None = None) -> pd.DataFrame:
    """Welch PSDs of measured, simulated and residual (measured - simulated).

    Both channels are resampled linearly onto one uniform grid over their
    overlap (at `fs`, default the finer median rate); columns f_hz,
    psd_meas, psd_sim, psd_residual.  A residual PSD that is flat near the
    measurement noise floor means the model explains the dynamics; a peak
    in it marks a mode the model misses or misplaces.
    """
    tm, ym = _as_float(t_meas), _as_float(y_meas)
    ts, ys = _as_float(t_sim), _as_float(y_sim)
    if fs is None:
        fs = max(median_rate_hz(tm), median_rate_hz(ts))
    lo = max(np.nanmin(tm), np.nanmin(ts))
    hi = min(np.nanmax(tm), np.nanmax(ts))
    tg, a = resample_uniform(tm, ym, fs, lo, hi)
    _, b = resample_uniform(ts, ys, fs, lo, hi)
    n = min(len(a), len(b))
    if n < 16:
        raise ValueError("overlap too short for a spectrum")
    f, pm = welch_psd(a[:n], fs, segment_s=segment_s)
    _, ps = welch_psd(b[:n], fs, segment_s=segment_s)
    _, pr = welch_psd(a[:n] - b[:n], fs, segment_s=segment_s)
    return pd.DataFrame({"f_hz": f, "psd_meas": pm, "psd_sim": ps, "psd_residual": pr})


# --------------------------------------------------------------------------
# Waves along the hose
# --------------------------------------------------------------------------

def hose_field(t_s, x_m, z_m, x_stations) -> tuple[np.ndarray, np.ndarray]:
    """Grid hose shapes (long format: one row per point) onto fixed x stations.

    Returns (frame times, Z) with Z[frame, station] = z interpolated
    linearly along x within that frame's points, NaN outside its x-range.
    """
    t, x, z = _as_float(t_s), _as_float(x_m), _as_float(z_m)
    xs = _as_float(x_stations)
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
    t, xs, Z = _as_float(t), _as_float(x_stations), _as_float(Z)
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
    t, Z = _as_float(t), _as_float(Z)
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
    x, ta = _as_float(x), _as_float(t_arrival)
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
# Onsets and delays
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
    t, y = _as_float(t), _as_float(y)
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
