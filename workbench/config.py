"""The workbench's defaults in one place, python-control's `config.defaults`
shape: `defaults['module.name']`, changed with `set_defaults` and restored
with `reset_defaults`. `simulate.*` and `parallel.*` are read when used, so a
change takes effect on the next call; the diagnosis's method constants
(`diagnosis.*` but `max_workers`, and `selftest.truth_elements`) are read once, when
`workbench.diagnosis` is imported, because its per-process caches of
observations and simulations are keyed by log, not by them.

    from workbench import config
    config.set_defaults("diagnosis", n_elements=40)
"""
from __future__ import annotations

_DEFAULTS = {
    # simulate: a run with neither [run] duration_s nor a log to span, s
    "simulate.duration_s": 10.0,
    # simulate: a steady trail is the static answer; a short run checks it holds, s
    "simulate.trail_run_s": 2.0,
    # parallel: worker processes (None: one per core)
    "parallel.workers": None,
    # diagnosis: local workers when none are given (a fit's jobs are few and large)
    "diagnosis.max_workers": 8,
    # diagnosis: 20 elements move the static drogue by ~1 mm against 40, at half the cost
    "diagnosis.n_elements": 20,
    # diagnosis: drogue channel averaging, s (a quarter of the shortest period seen)
    "diagnosis.bin_s": 0.25,
    # diagnosis: video normal errors averaged per window (s) and station (m)
    "diagnosis.video_window_s": 1.0,
    "diagnosis.station_m": 3.0,
    # diagnosis: alternating train / held-out time blocks within one log, s
    "diagnosis.block_s": 2.0,
    # diagnosis: a gap under this many times its noise floor is not a real gap
    "diagnosis.noise_factor": 2.0,
    # diagnosis: turbulence is an event of the flight from MIL-HDBK-1797's light
    # level where it is least, low altitude: sigma_w = 0.1 W20, W20 = 15 kt, m/s;
    # calmer air is in every flight
    "diagnosis.light_turbulence_mps": 0.77,
    # selftest: the generated logs' truth model: elements and sample step (s)
    "selftest.truth_elements": 40,
    "selftest.record_dt_s": 0.01,
}

defaults: dict = dict(_DEFAULTS)


def set_defaults(module: str, **keywords) -> None:
    """Set `module.name` defaults; an unknown name is a KeyError (a typo must not pass)."""
    for name, value in keywords.items():
        key = f"{module}.{name}"
        if key not in defaults:
            raise KeyError(f"unknown default {key!r}")
        defaults[key] = value


def reset_defaults() -> None:
    """Every default back to the shipped value."""
    defaults.clear()
    defaults.update(_DEFAULTS)
