"""Helpers shared by the measurement modules: array coercion, the noise floor,
uniform resampling, the sample rate and the three-point peak vertex.
"""
from __future__ import annotations

import math

import numpy as np


def as_float(a) -> np.ndarray:
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
    y = as_float(y)
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
    t, y = as_float(t), as_float(y)
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
    t = as_float(t)
    if len(t) < 2:
        return float("nan")
    return float(1.0 / np.median(np.diff(t)))


def parabolic_vertex(y0: float, y1: float, y2: float) -> tuple[float, float]:
    """Offset (in samples, within +-0.5 normally) and height of the parabola through 3 points."""
    den = y0 - 2.0 * y1 + y2
    if den == 0.0:
        return 0.0, y1
    d = 0.5 * (y0 - y2) / den
    return d, y1 - 0.25 * (y0 - y2) * d
