"""Measurement functions on plain arrays (no I/O, no records), one module per concern.

Every function takes NumPy arrays in SI units (time in s, lengths in m,
frequency in Hz) and returns SI values; none of them knows which test a
signal came from.  Each docstring states the method, so a number in a report
can be traced to how it was measured.

The package exposes the public measurement names here, so callers write
`from flighttest import metrics as M; M.damping_ratio(...)` whichever module
holds them:

- `sampling`: noise floor, uniform resampling, sample rate;
- `spectral`: dominant frequency, Welch and residual spectra, a channel's signal bandwidth;
- `damping`: damped-sinusoid fit, log decrement, ring-down segmentation,
  two-accelerometer decomposition, grouping repetitions by setpoint;
- `shape`: polyline projection, shape error, mean shape;
- `time_history`: lag, time-history error, ramp onset;
- `waves`: hose field on stations, wave speed.
"""
from .sampling import median_rate_hz, noise_std, resample_uniform
from .spectral import (
    FrequencyEstimate, dominant_frequency, residual_spectrum, signal_bandwidth, welch_psd,
)
from .damping import (
    DampedFit, DampingEstimate, DecaySegment, LogDecrement, axial_rocking, damping_ratio,
    fit_damped_sinusoid, free_decay_segment, group_by_setpoint, log_decrement,
)
from .shape import ShapeError, mean_shape, project_onto_polyline, project_onto_polylines, shape_error
from .time_history import TimeHistoryError, cross_correlation_lag, hinge_onset, time_history_error
from .waves import (
    WaveSpeed, front_arrival_times, hose_field, wave_speed_from_arrivals, wave_speed_xcorr,
)

__all__ = [
    "DampedFit", "DampingEstimate", "DecaySegment", "FrequencyEstimate", "LogDecrement",
    "ShapeError", "TimeHistoryError", "WaveSpeed", "axial_rocking", "cross_correlation_lag",
    "damping_ratio", "dominant_frequency", "fit_damped_sinusoid", "free_decay_segment",
    "front_arrival_times", "group_by_setpoint", "hinge_onset", "hose_field", "log_decrement",
    "mean_shape", "median_rate_hz", "noise_std", "project_onto_polyline", "project_onto_polylines",
    "resample_uniform",
    "residual_spectrum", "shape_error", "signal_bandwidth", "time_history_error", "wave_speed_from_arrivals",
    "wave_speed_xcorr", "welch_psd",
]
