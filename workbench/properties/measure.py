"""Step 1 of the property build: measure the bench ring-down records.

The free decay after the release is the window `flighttest.analyze` finds (one
period after the release until the envelope sinks into the noise); the
first-mode frequency is the FFT peak of that window
(`metrics.dominant_frequency`), the damping ratio its logarithmic decrement
(`metrics.log_decrement` through `analyze_record`); the temperature is the mean
of the two thermocouples, not the setpoint. Axial records are first split into
axial and rocking motion (`metrics.axial_rocking`). The repetitions at one
setpoint are averaged, with their spread.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from flighttest import metrics as M
from flighttest.analyze import analyze_record
from flighttest import FlightRecord, LogError, read_record
from workbench.errors import InputError
from workbench.provenance import file_sha256


def _accel_channel(record: FlightRecord) -> tuple[str, str, np.ndarray, np.ndarray]:
    """(topic, key prefix of analyze_record, t, acceleration) of a ring-down."""
    kind = record.info.test_kind
    if kind == "ringdown_bending":
        df = record.topic("/rig/accel/tip")
        return "/rig/accel/tip", "", df.index.to_numpy(float), df["a_mps2"].to_numpy(float)
    if kind == "ringdown_axial":
        df = record.topic("/rig/accel/weight")
        axial, _ = M.axial_rocking(df["a1_mps2"], df["a2_mps2"])
        return "/rig/accel/weight", "axial_", df.index.to_numpy(float), axial
    raise LogError(record.path, "metadata key 'test_kind'",
                   f"{kind!r} is not a ring-down (ringdown_bending or ringdown_axial)")


def measure_ringdown(record: FlightRecord) -> dict:
    """First-mode frequency (FFT) and damping ratio (log decrement) of one ring-down.

    The window and the log decrement are `analyze_record`'s; the frequency is
    the FFT peak (`metrics.dominant_frequency`) of the same window, resampled
    uniformly across any dropout. The least-squares fit of `analyze_record`
    is kept beside them as a cross-check. The displacement amplitude at the
    release is estimated from the acceleration at the start of the window,
    a / omega^2, grown back to the release with the measured decay rate; the
    verification releases its simulated rig from that amplitude."""
    res = analyze_record(record)
    _, pre, t, y = _accel_channel(record)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    fs = M.median_rate_hz(t)
    t0, t1 = res[f"{pre}decay_start_s"], res[f"{pre}decay_end_s"]
    tw, yw = M.resample_uniform(t, y, fs, t0, t1)
    fft = M.dominant_frequency(yw, fs, fmin=3.0 / (t[-1] - t[0]))
    f = fft.frequency_hz
    zeta = res[f"{pre}damping_ratio_logdec"]
    w = 2.0 * math.pi * f
    first = yw[: max(int(round(fs / f)), 2)]
    amp_start = 0.5 * float(np.max(first) - np.min(first)) / w ** 2
    decay = zeta * w / math.sqrt(1.0 - zeta ** 2)
    amp_release = amp_start * math.exp(decay * (t0 - res[f"{pre}release_s"]))
    info = record.info
    temp = res.get("temperature_F")
    out = {
        "test_id": info.test_id,
        "test_kind": info.test_kind,
        "hose": info.hose,
        "repetition": info.repetition,
        "setpoint_F": info.temperature_setpoint_F,
        "temperature_F": temp if temp is not None else info.temperature_setpoint_F,
        "temperature_source": "thermocouples (mean of t1, t2)" if temp is not None
        else "setpoint (record has no thermocouples)",
        "temperature_spread_F": res.get("temperature_spread_F"),
        "frequency_hz": f,
        "frequency_uncertainty_hz": fft.uncertainty_hz,
        "damping_ratio": zeta,
        "damping_ratio_half_cycle_spread": res[f"{pre}damping_spread"],
        "half_cycles": res[f"{pre}half_cycles"],
        "frequency_fit_hz": res[f"{pre}frequency_hz"],
        "damping_ratio_fit": res[f"{pre}damping_ratio"],
        "release_s": res[f"{pre}release_s"],
        "decay_window_s": [t0, t1],
        "amplitude_at_release_m": amp_release,
        "section_length_m": info.section_length_m,
        "tip_mass_kg": info.tip_mass_kg,
        "accel_lever_m": info.accel_lever_m,
    }
    if info.test_kind == "ringdown_axial":
        out["rocking_rms_mps2"] = res.get("rocking_rms_mps2")
        out["axial_rms_mps2"] = res.get("axial_rms_mps2")
    return out


def measure_records(paths: Iterable[Path], progress: Callable[[str], None] | None = None) -> list[dict]:
    """`measure_ringdown` of every ring-down record in `paths`, with file and SHA-256.
    Records of other kinds are skipped; a record that cannot be measured is an error."""
    out = []
    for p in sorted(Path(x) for x in paths):
        rec = read_record(p)
        if rec.info.test_kind not in ("ringdown_bending", "ringdown_axial"):
            continue
        m = measure_ringdown(rec)
        m["file"] = p.name
        m["sha256"] = file_sha256(p)
        out.append(m)
        if progress:
            progress(f"measured {p.name}: {m['frequency_hz']:.4f} Hz, zeta {m['damping_ratio']:.5f}, "
                     f"{m['temperature_F']:.2f} F")
    return out


def group_measurements(meas: list[dict]) -> list[dict]:
    """Repetitions averaged per (hose, kind, setpoint), as the paper did.

    A record without a setpoint forms its own group. Each group carries the
    mean measured temperature (the coordinate of the table), the mean,
    sample standard deviation, min and max of frequency and damping ratio, and
    the records it came from."""
    groups: dict[tuple, list[dict]] = {}
    for m in meas:
        key = (m["hose"], m["test_kind"],
               m["setpoint_F"] if m["setpoint_F"] is not None else f"rec:{m['test_id']}")
        groups.setdefault(key, []).append(m)
    out = []
    for (hose, kind, _), ms in groups.items():
        def stats(k):
            v = np.array([x[k] for x in ms], dtype=float)
            return {"mean": float(v.mean()), "std": float(v.std(ddof=1)) if len(v) > 1 else None,
                    "min": float(v.min()), "max": float(v.max())}
        lengths = {x["section_length_m"] for x in ms}
        tips = {x["tip_mass_kg"] for x in ms}
        if len(lengths) > 1 or len(tips) > 1:
            raise InputError(f"records {', '.join(x['file'] for x in ms)} of {hose} at one setpoint "
                             f"disagree on section_length_m {sorted(map(str, lengths))} or "
                             f"tip_mass_kg {sorted(map(str, tips))}")
        out.append({
            "hose": hose, "test_kind": kind, "setpoint_F": ms[0]["setpoint_F"], "n": len(ms),
            "temperature_F": stats("temperature_F"),
            "frequency_hz": stats("frequency_hz"),
            "damping_ratio": stats("damping_ratio"),
            "amplitude_at_release_m": float(np.mean([x["amplitude_at_release_m"] for x in ms])),
            "section_length_m": ms[0]["section_length_m"],
            "tip_mass_kg": ms[0]["tip_mass_kg"],
            "records": [x["file"] for x in ms],
        })
    out.sort(key=lambda g: (g["hose"], g["test_kind"], g["temperature_F"]["mean"]))
    return out

