"""Damping of ring-downs (damped-sinusoid fit, logarithmic decrement, the
estimate that picks between them), ring-down segmentation, the
two-accelerometer decomposition and grouping repetitions by setpoint.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import optimize, signal

from .sampling import as_float, noise_std
from .spectral import dominant_frequency


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
    t, y = as_float(t), as_float(y)
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
    t, y = as_float(t), as_float(y)
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
    t, y = as_float(t), as_float(y)
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
    t, y = as_float(t), as_float(y)
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
    a1, a2 = as_float(a1), as_float(a2)
    return 0.5 * (a1 + a2), 0.5 * (a1 - a2)


# --------------------------------------------------------------------------


def group_by_setpoint(setpoints, values) -> pd.DataFrame:
    """Mean and spread of repeated measurements at each setpoint.

    Returns one row per setpoint (sorted) with n, mean, std (sample std,
    ddof=1; NaN for a single repetition), sem = std/sqrt(n), min and max.
    NaN values are left out of their group.
    """
    df = pd.DataFrame({"setpoint": as_float(setpoints), "value": as_float(values)})
    df = df[np.isfinite(df["value"])]
    g = df.groupby("setpoint")["value"]
    out = pd.DataFrame({"n": g.count(), "mean": g.mean(), "std": g.std(ddof=1),
                        "min": g.min(), "max": g.max()})
    out["sem"] = out["std"] / np.sqrt(out["n"])
    return out


# --------------------------------------------------------------------------
