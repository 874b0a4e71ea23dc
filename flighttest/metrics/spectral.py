"""Frequency of a signal, power spectra of measured, simulated and residual
channels, and the band a channel holds above its own sensor noise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import signal

from .sampling import as_float, median_rate_hz, noise_std, parabolic_vertex, resample_uniform


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
    y = as_float(y)
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
    d_log, _ = parabolic_vertex(*np.log(np.maximum([a, b, c], tiny)))
    d_lin, _ = parabolic_vertex(a, b, c)
    f = (k + d_log) * df
    noise_ratio = float(np.median(mag[band]) / mag[k])
    unc = math.hypot(abs(d_log - d_lin) * df, (fs / n) * noise_ratio)
    return FrequencyEstimate(float(f), float(unc), "hann+zero-pad FFT, log-parabolic peak")


# --------------------------------------------------------------------------


def welch_psd(y, fs: float, *, segment_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One-sided power spectral density (units^2/Hz) by Welch's method.

    Hann windows of `segment_s` seconds (default: an eighth of the record,
    at least 16 samples) with 50 % overlap, linear detrend per segment.
    """
    y = as_float(y)
    n = len(y)
    nper = n // 8 if segment_s is None else int(round(segment_s * fs))
    nper = int(min(max(nper, 16), n))
    return signal.welch(y, fs=fs, window="hann", nperseg=nper, noverlap=nper // 2,
                        detrend="linear")


def signal_bandwidth(t, y, *, snr: float = 1.0, segment_s: float = 8.0,
                     smooth_hz: float = 0.3) -> float:
    """The frequency (Hz) above which a channel holds nothing but its own
    white sensor noise: the lowest frequency at which its power spectrum,
    averaged over `smooth_hz`, falls to (1 + `snr`) times the noise floor
    (signal power `snr` times the noise's there; 1: as much signal as noise).

    Method: the channel resampled onto its median rate fs; Welch's PSD of
    `segment_s` windows (`welch_psd`); the floor 2 s^2 / fs of white noise of
    the standard deviation s that `noise_std` estimates on the samples as
    logged (third differences, independent of the spectrum). The search
    starts above the first bin (the detrended mean). A channel whose
    spectrum never falls to the floor returns
    the Nyquist frequency; one too short for a spectrum of two windows, or
    without noise (a synthetic channel), returns nan (nothing to say).
    """
    t, y = as_float(t), as_float(y)
    fs = median_rate_hz(t)
    if not fs > 0.0:
        return math.nan
    _, yu = resample_uniform(t, y, fs)
    # the noise of the samples as logged: interpolated onto the uniform grid
    # between jittered stamps they average neighbours, which lowers the
    # estimate (a tow point at 100 Hz: 0.0005 m against 0.0010 m) but not the
    # noise's power at the low frequencies where the signal meets it
    s = noise_std(y[np.isfinite(t)])
    # below the float resolution of the channel's range there is no noise to meet
    if len(yu) < 2 * segment_s * fs or not s > 1e-9 * np.ptp(yu):
        return math.nan
    f, p = welch_psd(yu, fs, segment_s=segment_s)
    width = max(1, int(round(smooth_hz / (f[1] - f[0]))))
    p = np.convolve(p, np.ones(width) / width, mode="same")
    at_floor = np.flatnonzero(p[1:] <= (1.0 + snr) * 2.0 * s * s / fs)
    return float(f[1 + at_floor[0]]) if len(at_floor) else fs / 2.0


def residual_spectrum(t_meas, y_meas, t_sim, y_sim, *, fs: float | None = None,
                      segment_s: float | None = None) -> pd.DataFrame:
    """Welch PSDs of measured, simulated and residual (measured - simulated).

    Both channels are resampled linearly onto one uniform grid over their
    overlap (at `fs`, default the finer median rate); columns f_hz,
    psd_meas, psd_sim, psd_residual.  A residual PSD that is flat near the
    measurement noise floor means the model explains the dynamics; a peak
    in it marks a mode the model misses or misplaces.
    """
    tm, ym = as_float(t_meas), as_float(y_meas)
    ts, ys = as_float(t_sim), as_float(y_sim)
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
