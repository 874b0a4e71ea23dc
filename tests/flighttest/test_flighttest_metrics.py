"""Metrics against signals whose answers are known by construction."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import signal

from flighttest import metrics as M

FS = 1000.0


def decaying(f_hz: float, zeta: float, duration_s: float, *, fs: float = FS, amp: float = 1.0,
             noise: float = 0.0, offset: float = 0.0, phase: float = 0.3, seed: int = 0,
             highpass_hz: float | None = None):
    """y = A exp(-zeta wn t) cos(wd t + phase) + offset (+ first-order high-pass) + white noise.

    f_hz is the damped frequency wd / 2 pi, the one a ring-down shows.
    """
    t = np.arange(int(round(duration_s * fs))) / fs
    wd = 2 * math.pi * f_hz
    wn = wd / math.sqrt(1 - zeta ** 2)
    y = amp * np.exp(-zeta * wn * t) * np.cos(wd * t + phase) + offset
    if highpass_hz:
        b, a = signal.butter(1, highpass_hz, btype="high", fs=fs)
        y = signal.lfilter(b, a, y)
    y = y + noise * amp * np.random.default_rng(seed).standard_normal(len(t))
    return t, y


def decay_duration(f_hz: float, zeta: float) -> float:
    # Until the envelope is down to exp(-6) = 0.25 %, below the 1-2 % noise used here,
    # and never shorter than five cycles.
    return max(6.0 / (zeta * 2 * math.pi * f_hz / math.sqrt(1 - zeta ** 2)), 5.0 / f_hz)


# ---------------------------------------------------------------- frequency

@pytest.mark.parametrize("f_hz", [0.37, 1.3, 2.3, 42.0])
def test_dominant_frequency_decaying_sinusoid_in_noise(f_hz):
    fs = 30.0 if f_hz < 1 else FS
    t, y = decaying(f_hz, 0.02, decay_duration(f_hz, 0.02), fs=fs, noise=0.02)
    est = M.dominant_frequency(y, fs)
    # Brief: within 0.2 %.  Hann window + zero padding + log-parabolic peak
    # leaves a bias well under 0.05 % at this damping and 2 % noise.
    assert_allclose(est.frequency_hz, f_hz, rtol=2e-3)
    # The stated uncertainty must not be smaller than the error actually made.
    assert abs(est.frequency_hz - f_hz) <= 3 * est.uncertainty_hz + 1e-12
    assert est.uncertainty_hz < 0.01 * f_hz


def test_dominant_frequency_sub_bin():
    # 10.37 Hz over 1 s: 0.37 of a Rayleigh bin off the grid; the unpadded bin
    # alone would be 0.37 Hz (3.6 %) off, interpolation must do far better.
    t = np.arange(1000) / FS
    y = np.sin(2 * math.pi * 10.37 * t)
    est = M.dominant_frequency(y, FS, pad=1)
    assert_allclose(est.frequency_hz, 10.37, rtol=2e-3)


def test_dominant_frequency_band_limits():
    t = np.arange(4000) / FS
    y = 5 * np.sin(2 * math.pi * 3.0 * t) + np.sin(2 * math.pi * 40.0 * t)
    assert_allclose(M.dominant_frequency(y, FS).frequency_hz, 3.0, rtol=1e-3)
    assert_allclose(M.dominant_frequency(y, FS, fmin=10).frequency_hz, 40.0, rtol=1e-3)


def test_dominant_frequency_rejects_bad_input():
    with pytest.raises(ValueError):
        M.dominant_frequency(np.array([1.0, np.nan] * 8), FS)
    with pytest.raises(ValueError):
        M.dominant_frequency(np.ones(4), FS)


# ------------------------------------------------------------------ damping

ZETAS = [0.01, 0.03, 0.07, 0.15]


@pytest.mark.parametrize("zeta", ZETAS)
@pytest.mark.parametrize("variant", ["plain", "offset", "highpass"])
def test_damping_ratio_recovered(zeta, variant):
    f_hz = 2.3
    kw = {"plain": {}, "offset": {"offset": 0.7},
          # AC coupling with its corner a fifth of the mode frequency: a harsh
          # case (real accelerometers sit lower) that adds a baseline transient.
          "highpass": {"highpass_hz": f_hz / 5, "offset": 0.3}}[variant]
    t, y = decaying(f_hz, zeta, decay_duration(f_hz, zeta), noise=0.02, seed=7, **kw)
    est = M.damping_ratio(t, y)
    # Brief: known zeta within 3 %.  At 2 % noise the fit's scatter is ~0.3 %
    # (checked over seeds), so 3 % is a real margin, not a fudge.
    assert_allclose(est.zeta, zeta, rtol=0.03)
    # The log decrement uses only the extrema, so it scatters more, but must
    # agree with the truth to the same 3 % once enough swings are above noise.
    assert_allclose(est.zeta_logdec, zeta, rtol=0.03 if zeta < 0.1 else 0.05)
    assert_allclose(est.frequency_hz, f_hz, rtol=2e-3)
    assert est.n_half_cycles >= 3


@pytest.mark.parametrize("zeta", ZETAS)
def test_damping_ratio_axial_rate(zeta):
    # The axial ring-down case: 42 Hz sampled at 1 kHz, ~24 samples a cycle.
    t, y = decaying(42.0, zeta, decay_duration(42.0, zeta), noise=0.01, seed=3)
    est = M.damping_ratio(t, y)
    assert_allclose(est.zeta, zeta, rtol=0.03)
    # At zeta 0.15 the ringing lasts ~6 cycles, so the frequency is known to
    # a few tenths of a percent only; the stated uncertainty must cover it.
    # That uncertainty includes the disagreement with the extremum spacing,
    # which over three half cycles is itself good to about 1.5 %.
    assert abs(est.frequency_hz - 42.0) <= 3 * est.frequency_uncertainty_hz
    assert est.frequency_uncertainty_hz < 0.015 * 42.0


def test_damping_noise_free_is_exact():
    t, y = decaying(1.7, 0.05, 8.0, offset=2.0)
    ld = M.log_decrement(t, y, f_hint=1.7, noise=1e-9)
    # Extrema of an exact damped sinusoid are exactly exp(-s T/2) apart; only
    # the parabolic refinement between samples limits the agreement.
    assert_allclose(ld.zeta, 0.05, rtol=1e-4)
    assert ld.spread < 1e-4
    fit = M.fit_damped_sinusoid(t, y, f0=1.6, zeta0=0.02, baseline="constant")
    assert_allclose(fit.zeta, 0.05, rtol=1e-6)
    assert_allclose(fit.frequency_hz, 1.7, rtol=1e-8)
    assert fit.rms_residual < 1e-8


def test_fit_handles_dropouts():
    t, y = decaying(0.375, 0.1, 30.0, fs=30.0, noise=0.02, offset=-2.6, seed=2)
    keep = np.random.default_rng(5).random(len(t)) > 0.1   # 10 % of fixes lost
    fit = M.fit_damped_sinusoid(t[keep], y[keep], f0=0.38, zeta0=0.05)
    assert_allclose(fit.zeta, 0.1, rtol=0.03)
    assert_allclose(fit.frequency_hz, 0.375, rtol=2e-3)


def test_log_decrement_refuses_noise():
    y = np.random.default_rng(0).standard_normal(3000) * 0.01
    with pytest.raises(ValueError):
        M.log_decrement(np.arange(3000) / FS, y, f_hint=2.0)


# --------------------------------------------------- ring-down segmentation

def test_free_decay_segment_after_release():
    fs = FS
    t = np.arange(int(10 * fs)) / fs
    rng = np.random.default_rng(4)
    y = 0.02 * rng.standard_normal(len(t))
    i_rel = 1500
    # Held displacement (slow wobble), a release spike, a fast mode that dies
    # within a few tenths of a second, and the first mode ringing down.
    y[:i_rel] += 0.3 * np.sin(2 * math.pi * 0.7 * t[:i_rel])
    tt = t[i_rel:] - t[i_rel]
    y[i_rel] += 20.0
    y[i_rel:] += 2.0 * np.exp(-60 * tt) * np.sin(2 * math.pi * 14.0 * tt)
    y[i_rel:] += 3.0 * np.exp(-0.8 * tt) * np.cos(2 * math.pi * 2.0 * tt)
    seg = M.free_decay_segment(t, y)
    assert seg.i_release == i_rel
    assert_allclose(seg.frequency_hz, 2.0, rtol=5e-3)
    assert t[seg.i_start] > t[i_rel] + 0.4          # one cycle of 2 Hz skipped
    # The envelope 3 exp(-0.8 t) meets the noise-based floor a few seconds on.
    assert 4.0 < t[seg.i_end] - t[i_rel] < 8.5
    est = M.damping_ratio(t[seg.i_start:seg.i_end], y[seg.i_start:seg.i_end],
                          f_hint=seg.frequency_hz)
    zeta = 0.8 / math.hypot(0.8, 2 * math.pi * 2.0)
    assert_allclose(est.zeta, zeta, rtol=0.03)


def test_axial_rocking_split():
    rng = np.random.default_rng(1)
    axial, rock = rng.standard_normal(100), rng.standard_normal(100)
    a, r = M.axial_rocking(axial + rock, axial - rock)
    assert_allclose(a, axial, atol=1e-12)
    assert_allclose(r, rock, atol=1e-12)


# ---------------------------------------------------------- grouping

def test_group_by_setpoint():
    sp = [0, 0, 0, 20, 20, 40]
    v = [1.0, 2.0, 3.0, 5.0, 7.0, 9.0]
    g = M.group_by_setpoint(sp, v)
    assert list(g.index) == [0, 20, 40]
    assert_allclose(g["mean"], [2.0, 6.0, 9.0])
    assert_allclose(g.loc[0, "std"], 1.0)
    assert_allclose(g.loc[20, "std"], math.sqrt(2.0))
    assert math.isnan(g.loc[40, "std"])
    assert_allclose(g.loc[0, "sem"], 1.0 / math.sqrt(3))
    assert list(g["n"]) == [3, 2, 1]


@given(st.lists(st.tuples(st.sampled_from([-50, -20, 0, 20, 40, 60]),
                          st.floats(-1e3, 1e3, allow_nan=False)), min_size=1, max_size=30))
@settings(max_examples=40, deadline=None)
def test_group_by_setpoint_property(pairs):
    sp, v = zip(*pairs)
    g = M.group_by_setpoint(sp, v)
    for s in set(sp):
        vals = [b for a, b in pairs if a == s]
        assert g.loc[s, "n"] == len(vals)
        assert_allclose(g.loc[s, "mean"], np.mean(vals), rtol=1e-9, atol=1e-9)
        assert g.loc[s, "min"] <= g.loc[s, "mean"] + 1e-9 <= g.loc[s, "max"] + 2e-9


# ---------------------------------------------------------- shape error

def test_shape_error_normal_distance_and_vertical():
    # Simulated line: straight, sloping down 10 % aft; measured points 5 cm
    # above it, measured perpendicular to the line.
    xs = np.linspace(0, 20, 41)
    zs = -0.1 * xs
    n = np.array([0.1, 1.0]) / math.hypot(0.1, 1.0)      # unit normal, pointing up-left
    sta = np.linspace(1, 19, 30)
    pts = np.column_stack([sta, -0.1 * sta]) + 0.05 * n
    e = M.shape_error(pts[:, 0], pts[:, 1], xs, zs, bin_m=5.0)
    assert_allclose(e.normal_error_m, 0.05, atol=1e-12)
    assert_allclose(e.rms_m, 0.05, atol=1e-12)
    assert_allclose(e.max_abs_m, 0.05, atol=1e-12)
    # Foot-point station: along-line distance of the projection.
    assert_allclose(e.station_m, sta * math.hypot(1, 0.1), rtol=1e-9)
    # At equal x, the vertical offset of a 5 cm normal offset on a 10 % slope
    # is 0.05 / cos(theta) = 0.05 * sqrt(1.01).
    assert_allclose(e.vertical_error_m, 0.05 * math.sqrt(1.01), rtol=1e-9)
    assert e.bins["n"].sum() == len(sta)
    assert_allclose(e.bins["mean_m"].dropna(), 0.05, atol=1e-12)


def test_shape_error_sign_and_ends():
    xs = np.array([0.0, 10.0])
    zs = np.array([0.0, 0.0])
    e = M.shape_error([5.0, 5.0, 12.0], [0.2, -0.3, 0.0], xs, zs)
    assert_allclose(e.normal_error_m[:2], [0.2, -0.3])
    assert list(e.inside) == [True, True, False]          # x = 12 is beyond the line's end
    assert_allclose(e.rms_m, math.sqrt((0.04 + 0.09) / 2))
    assert math.isnan(e.vertical_error_m[2])


@given(st.floats(-2, 2), st.floats(0.05, 3.0), st.floats(-1, 1))
@settings(max_examples=30, deadline=None)
def test_shape_error_of_line_with_itself_is_zero(curv, length_scale, offset):
    xs = np.linspace(0, 20 * length_scale, 50)
    zs = offset - 0.1 * xs - curv * 1e-3 * xs ** 2
    e = M.shape_error(xs[1:-1], zs[1:-1], xs, zs)
    assert e.max_abs_m < 1e-9
    assert np.nanmax(np.abs(e.vertical_error_m)) < 1e-9


@given(st.integers(0, 2 ** 31 - 1), st.integers(1, 40), st.integers(2, 7))
@settings(max_examples=40, deadline=None)
def test_projection_on_many_lines_is_the_projection_point_by_point(seed, n, n_lines):
    # Lines of mixed lengths, some with a repeated node (a zero-length segment,
    # dropped by the one-line projection), points near and beyond their ends:
    # the batched projection must give the one-line values, bit for bit.
    rng = np.random.default_rng(seed)
    lines = []
    for _ in range(n_lines):
        m = int(rng.integers(2, 6))
        x = np.cumsum(rng.uniform(0.5, 3.0, m))
        line = np.column_stack([x, -0.1 * x + rng.normal(0, 0.3, m)])
        if m > 2 and rng.random() < 0.3:
            line = np.insert(line, 1, line[1], axis=0)
        lines.append(line)
    q = np.column_stack([rng.uniform(-2, 16, n), rng.normal(-0.5, 1.0, n)])
    which = rng.integers(0, n_lines, n)
    err, station, inside = M.project_onto_polylines(q, lines, which, chunk=7)
    for i in range(n):
        e1, s1, in1, _, _ = M.project_onto_polyline(q[i:i + 1], lines[which[i]])
        assert (err[i], station[i], inside[i]) == (e1[0], s1[0], in1[0])


def test_mean_shape_bins():
    x = np.array([0.2, 0.7, 1.1, 1.9, 5.5])
    z = np.array([1.0, 3.0, 2.0, 4.0, 7.0])
    m = M.mean_shape(x, z, bin_m=1.0)
    assert_allclose(m["z_m"], [2.0, 3.0, 7.0])
    assert_allclose(m["x_m"], [0.45, 1.5, 5.5])
    assert list(m["n"]) == [2, 2, 1]


# ---------------------------------------------------- time-history error

def _chirp(t):
    return np.sin(2 * math.pi * (0.3 * t + 0.05 * t ** 2))


def test_time_history_error_lag_rms_overlap():
    ts = np.arange(0, 20, 0.01)                  # simulation: 100 Hz, 0-20 s
    tm = np.arange(5, 30, 1 / 30.0)              # measurement: 30 Hz, 5-30 s
    lag = 0.12
    ym = _chirp(tm - lag) + 0.1                  # measured late by 0.12 s, biased 0.1
    r = M.time_history_error(tm, ym, ts, _chirp(ts), max_lag_s=1.0)
    assert r.t_start == pytest.approx(tm[0])
    assert r.t_end <= 20.0                       # overlap only, no extrapolation
    assert r.n == int(np.sum(tm <= ts[-1]))
    # Linear resampling at 100 Hz and a parabolic peak: a few ms at most.
    assert_allclose(r.lag_s, lag, atol=5e-3)
    assert r.correlation > 0.9
    assert r.bias == pytest.approx(0.1, abs=0.02)


def test_time_history_error_identical_and_tube():
    t = np.arange(0, 10, 0.02)
    y = np.sin(2 * math.pi * 0.5 * t)
    r = M.time_history_error(t, y, t, y, tube_tol=0.01)
    assert r.rms == 0 and r.peak == 0
    assert abs(r.lag_s) < 1e-6
    assert r.tube_pass and r.tube_fraction == 1.0
    # A 50 ms timing error on a 0.5 Hz sine is a 0.157 amplitude error at the
    # zero crossings: it fails a 0.01 tube, and passes once 60 ms of lag is tolerated.
    # (Measured samples start 0.1 s in: before the simulation's first 60 ms
    # there is no simulated past to tolerate a lag against.)
    tm = t[5:]
    late = np.sin(2 * math.pi * 0.5 * (tm - 0.05))
    strict = M.time_history_error(tm, late, t, y, tube_tol=0.01)
    lenient = M.time_history_error(tm, late, t, y, tube_tol=0.01, tube_lag_s=0.06)
    assert not strict.tube_pass and strict.tube_fraction < 0.5
    assert lenient.tube_pass
    assert_allclose(strict.peak, 2 * math.sin(math.pi * 0.5 * 0.05), rtol=1e-2)


def test_time_history_error_skips_dropouts():
    t = np.arange(0, 10, 0.05)
    y = np.cos(t)
    ym = y.copy()
    ym[10:20] = np.nan
    r = M.time_history_error(t, ym, t, y)
    assert r.n == len(t) - 10 and r.rms == 0


def test_time_history_error_no_overlap():
    with pytest.raises(ValueError, match="do not overlap"):
        M.time_history_error([0, 1, 2], [0, 1, 2], [3, 4, 5], [0, 1, 2])


@given(st.floats(-0.5, 0.5), st.floats(0.2, 3.0))
@settings(max_examples=25, deadline=None)
def test_lag_property(lag, amp):
    fs = 50.0
    t = np.arange(0, 30, 1 / fs)
    ref = _chirp(t)
    lagged = amp * _chirp(t - lag)
    est, corr = M.cross_correlation_lag(ref, lagged, fs, max_lag_s=1.0)
    # Parabolic refinement of a sampled correlation peak: a small fraction of
    # the 20 ms sample period.
    assert abs(est - lag) < 0.2 / fs
    assert corr > 0.95


# ---------------------------------------------------------------- spectra

def test_welch_and_residual_spectrum():
    fs = 100.0
    t = np.arange(0, 60, 1 / fs)
    sim = np.sin(2 * math.pi * 2.0 * t)
    meas = sim + 0.3 * np.sin(2 * math.pi * 7.0 * t)       # a mode the model lacks
    f, p = M.welch_psd(meas, fs, segment_s=10)
    assert f[np.argmax(p)] == pytest.approx(2.0, abs=0.1)
    # Parseval: the PSD integrates to the variance.
    assert np.trapezoid(p, f) == pytest.approx(np.var(meas), rel=0.05)
    spec = M.residual_spectrum(t, meas, t, sim, segment_s=10)
    peak = spec["f_hz"][np.argmax(spec["psd_residual"])]
    assert peak == pytest.approx(7.0, abs=0.1)
    at2 = np.argmin(np.abs(spec["f_hz"] - 2.0))
    assert spec["psd_residual"][at2] < 1e-6 * spec["psd_meas"][at2]


def _shaped_noise(shape, fs: float, duration_s: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit white sensor noise plus a random signal whose one-sided PSD is
    shape(f) times the noise's (2 / fs), shaped exactly in the FFT domain."""
    rng = np.random.default_rng(seed)
    n = int(duration_s * fs)
    spec = np.fft.rfft(rng.standard_normal(n)) * np.sqrt(shape(np.fft.rfftfreq(n, 1 / fs)))
    return np.arange(n) / fs, np.fft.irfft(spec, n) + rng.standard_normal(n)


# Where the bandwidth may land off an edge of the spectrum: the Hann window's
# main lobe (2 bins of 1 / segment_s = 0.125 Hz each) and half the 0.3 Hz
# smoothing on either side of it.
EDGE_HZ = 2 / 8.0 + 0.3 / 2


@pytest.mark.parametrize("band_hz", [0.6, 1.5, 3.0])
def test_signal_bandwidth_is_the_edge_of_a_band_limited_signal(band_hz):
    t, y = _shaped_noise(lambda f: np.where(f < band_hz, 100.0, 0.0), 30.0, 120.0, seed=3)
    assert_allclose(M.signal_bandwidth(t, y), band_hz, atol=EDGE_HZ)


@pytest.mark.parametrize("shelf, snr, edge_hz", [(3.0, 1.0, 2.5), (0.3, 1.0, 1.0), (3.0, 5.0, 1.0)])
def test_signal_bandwidth_counts_a_shelf_as_signal_only_above_its_snr(shelf, snr, edge_hz):
    # 100 x the noise up to 1 Hz, then a shelf to 2.5 Hz: at 3 x the noise it
    # is signal for snr 1 (as much signal as noise) and not for snr 5; at 0.3 x
    # it is not
    shape = lambda f: np.select([f < 1.0, f < 2.5], [100.0, shelf], 0.0)
    t, y = _shaped_noise(shape, 30.0, 120.0, seed=4)
    assert_allclose(M.signal_bandwidth(t, y, snr=snr), edge_hz, atol=EDGE_HZ)


def test_signal_bandwidth_reads_the_noise_as_logged_on_jittered_stamps():
    # a tow point's channel: 100 Hz stamps jittered by 1.6 % of a sample, the
    # signal band-limited at 1.5 Hz; interpolated onto a uniform grid the
    # noise looks half as large and the bandwidth came out at 13-16 Hz
    rng = np.random.default_rng(6)
    fs, n = 100.0, 12000
    t = np.arange(n) / fs + rng.normal(0, 0.016 / fs, n)
    tf, clean = _shaped_noise(lambda f: np.where(f < 1.5, 100.0, 0.0), fs, n / fs, seed=7)
    _, noise_only = _shaped_noise(lambda f: np.zeros_like(f), fs, n / fs, seed=7)
    y = np.interp(t, tf, clean - noise_only) + rng.standard_normal(n)
    assert_allclose(M.signal_bandwidth(t, y), 1.5, atol=EDGE_HZ)


def test_signal_bandwidth_of_white_noise_is_its_first_bin_and_nan_without_a_spectrum():
    rng = np.random.default_rng(5)
    t = np.arange(0, 60, 1 / 30)
    assert M.signal_bandwidth(t, rng.standard_normal(len(t))) == pytest.approx(1 / 8.0)
    assert math.isnan(M.signal_bandwidth(t[:200], rng.standard_normal(200)))    # under two windows
    assert math.isnan(M.signal_bandwidth(t, 0.5 * t))                               # no noise at all


@given(st.floats(5.0, 200.0), st.floats(1e-3, 10.0), st.floats(0.0, 5.0), st.integers(0, 2 ** 16))
@settings(max_examples=25, deadline=None)
def test_signal_bandwidth_lies_between_the_first_bin_and_nyquist(fs, noise, drift, seed):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 40, int(40 * fs)))          # jittered stamps, resampled inside
    y = drift * np.sin(2 * math.pi * 0.2 * t) + noise * rng.standard_normal(len(t))
    b = M.signal_bandwidth(t, y)
    fs_med = 1 / np.median(np.diff(t))
    # the first bin is fs / round(8 fs): 1/8 Hz to within a sample of the window
    assert 1 / (8.0 + 1 / fs_med) - 1e-9 <= b <= fs_med / 2 + 1e-9


# ------------------------------------------------------------ wave speed

def _travelling(c: float, direction: int, fs: float = 10.0, dx: float = 1.0, noise: float = 0.0,
                seed: int = 0):
    """A Gaussian pulse travelling at c along stations 0..20 m, sampled like video."""
    t = np.arange(0, 6, 1 / fs)
    xs = np.arange(0, 20 + 1e-9, dx)
    x0 = 0.0 if direction > 0 else 20.0
    arrive = 1.0 + np.abs(xs - x0) / c
    Z = 0.5 * np.exp(-((t[:, None] - arrive[None, :]) / 0.25) ** 2)
    Z += noise * np.random.default_rng(seed).standard_normal(Z.shape)
    return t, xs, Z


@pytest.mark.parametrize("c,direction", [(25.0, 1), (40.0, -1), (15.0, -1)])
def test_wave_speed_xcorr_travelling_wave(c, direction):
    t, xs, Z = _travelling(c, direction, noise=0.01)
    ws = M.wave_speed_xcorr(t, xs, Z, max_lag_s=1.5)
    assert ws.direction == direction
    # Travel times of 0.5-1.3 s over the span, resolved to a few ms by the
    # parabolic peak: 3 % on the speed.
    assert_allclose(ws.speed_mps, c, rtol=0.03)


@pytest.mark.parametrize("c,direction", [(30.0, 1), (30.0, -1)])
def test_wave_speed_from_front_arrivals_one_way(c, direction):
    t, xs, Z = _travelling(c, direction, noise=0.01)
    arr = M.front_arrival_times(t, Z, 0.5, baseline_s=0.5)
    # The half-height point of the rising front arrives 0.25*sqrt(ln 2) s
    # before the pulse centre, everywhere alike.  Frames are 0.1 s apart and
    # the crossing is interpolated linearly on a curved front: a quarter
    # frame is the error that allows.
    expect = 0.5 + np.abs(xs - (0.0 if direction > 0 else 20.0)) / c - 0.25 * math.sqrt(math.log(2))
    assert_allclose(arr, expect, atol=0.025)
    ws = M.wave_speed_from_arrivals(xs, arr)
    assert ws.direction == direction
    assert_allclose(ws.speed_mps, c, rtol=0.03)


def test_wave_speed_from_arrivals_both_ends():
    # Fronts entering at both ends at different times, meeting near x = 12 m.
    c = 33.0
    xs = np.arange(2.0, 16.0)
    arr = np.minimum(0.2 + xs / c, 0.75 - xs / c)
    arr = arr + np.random.default_rng(3).normal(0, 0.005, len(xs))
    ws = M.wave_speed_from_arrivals(xs, arr)
    assert ws.direction == 0
    assert_allclose(ws.speed_mps, c, rtol=0.05)


def test_hose_field_grids_frames():
    t = np.array([0.0, 0.0, 0.0, 0.1, 0.1])
    x = np.array([0.0, 2.0, 4.0, 0.0, 3.0])
    z = np.array([0.0, -1.0, -2.0, 0.0, -3.0])
    frames, Z = M.hose_field(t, x, z, [1.0, 3.0, 4.0])
    assert_allclose(frames, [0.0, 0.1])
    assert_allclose(Z[0], [-0.5, -1.5, -2.0])
    assert_allclose(Z[1, :2], [-1.0, -3.0])
    assert math.isnan(Z[1, 2])                 # beyond that frame's last point


# ------------------------------------------------------------ misc helpers

def test_hinge_onset_recovers_start_of_ramp():
    t = np.arange(0, 3, 0.02)
    t0 = 1.234
    y = 5.0 - 2.0 * np.maximum(t - t0, 0) + np.random.default_rng(0).normal(0, 0.01, len(t))
    est, rate = M.hinge_onset(t, y)
    assert est == pytest.approx(t0, abs=0.02)
    assert rate == pytest.approx(-2.0, rel=0.02)


def test_noise_std_ignores_smooth_signal():
    t = np.arange(20000) / FS
    y = 3 * np.sin(2 * math.pi * 2 * t) + 0.05 * np.random.default_rng(0).standard_normal(len(t))
    assert M.noise_std(y) == pytest.approx(0.05, rel=0.05)


def test_resample_uniform_never_extrapolates():
    tg, yg = M.resample_uniform([0.0, 1.0, np.nan, 2.0], [0.0, 1.0, 5.0, 0.0], 10.0, -1.0, 5.0)
    assert tg[0] == 0.0 and tg[-1] == pytest.approx(2.0)
    assert_allclose(yg[10], 1.0)


@given(st.floats(1.0, 10.0), st.floats(0.02, 0.12), st.floats(-5, 5), st.floats(0.1, 10.0))
@settings(max_examples=20, deadline=None)
def test_damping_invariant_to_offset_and_scale(f_hz, zeta, offset, scale):
    fs = 50.0 * f_hz
    t, y = decaying(f_hz, zeta, decay_duration(f_hz, zeta), fs=fs, noise=0.005, seed=1)
    a = M.damping_ratio(t, y)
    b = M.damping_ratio(t, scale * y + offset)
    # A linear change of units must not change the damping ratio (beyond
    # round-off in the fit).
    assert_allclose(b.zeta, a.zeta, rtol=1e-4)
    assert_allclose(a.zeta, zeta, rtol=0.03)
