"""What a flight log prescribes to the simulation: flight condition, tow-point
motion, reel payout and the drogue's path while the probe holds it.

Measured channels carry sensor noise, and the solver differentiates
prescribed motions and drives the hose with them: noise handed over rings
the model's hose where the logged hose is quiet (a fixed 3 Hz cut on the
probe track rang the engaged KDC-10 hose's ~1 Hz mode, 0.10-0.18 m at mid
hose against the log's 0.05-0.07 m). So each channel, axis by axis, is
low-passed with a zero-phase filter at its own signal bandwidth: where its
spectrum falls to twice its sensor-noise floor (signal and noise equal, the
half-power point of a Wiener filter; `flighttest.metrics.signal_bandwidth`),
never above a fixed ceiling per channel.
"""
from __future__ import annotations

import hashlib

import numpy as np
from scipy import signal

from flighttest import FlightRecord, LogError
from flighttest.metrics import signal_bandwidth
from solver.atmosphere import isa, cas_to_tas
from solver.model import EndConstraint, Trajectory

# the most each channel keeps, whatever its spectrum says (doublets and
# engagements live below 1 Hz); also the cut of an axis whose bandwidth cannot
# be measured (too short a record)
TOW_CUTOFF_HZ = 5.0
REEL_CUTOFF_HZ = 5.0
PROBE_CUTOFF_HZ = 3.0


def _lowpass(t: np.ndarray, y: np.ndarray, cutoff_hz: float) -> np.ndarray:
    fs = 1.0 / float(np.median(np.diff(t)))
    if cutoff_hz >= 0.45 * fs or len(t) < 30:
        return y
    sos = signal.butter(4, cutoff_hz, fs=fs, output="sos")
    return signal.sosfiltfilt(sos, y, axis=0)


# A diagnosis simulates one log thousands of times: each channel's filtered
# form is kept by content (a trail's static solve took 60 % longer measuring
# its tow point's bandwidth each time).
_MEASURED: dict[tuple, np.ndarray] = {}
_MEASURED_KEEP = 64


def measured(t: np.ndarray, y: np.ndarray, ceiling_hz: float) -> np.ndarray:
    """A measured channel (samples along axis 0, one column per axis) with each
    axis low-passed at its signal bandwidth, at most `ceiling_hz`."""
    t = np.ascontiguousarray(t, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    key = (ceiling_hz, y.shape, hashlib.blake2b(t.tobytes() + y.tobytes(), digest_size=16).digest())
    out = _MEASURED.get(key)
    if out is None:
        cols = y.reshape(len(t), -1)
        out = np.column_stack([_lowpass(t, c, min(ceiling_hz, np.nan_to_num(signal_bandwidth(t, c),
                                                                             nan=ceiling_hz)))
                               for c in cols.T]).reshape(y.shape)
        if len(_MEASURED) >= _MEASURED_KEEP:
            _MEASURED.pop(next(iter(_MEASURED)))
        _MEASURED[key] = out
    return out.copy()


def probe_track(rec: FlightRecord) -> tuple[np.ndarray, np.ndarray]:
    """The probe tip's path from /receiver/probe, (t, xyz), as `measured`."""
    probe = rec.topic("/receiver/probe")
    t = probe.index.to_numpy(float)
    return t, measured(t, probe[["x_m", "y_m", "z_m"]].to_numpy(float), PROBE_CUTOFF_HZ)


def flight_condition(rec: FlightRecord) -> dict:
    """Altitude, true airspeed and air properties from the test card (the air
    temperature is the logged OAT where there is one, else the standard day)."""
    info = rec.info
    if info.altitude_m is None or info.calibrated_airspeed_mps is None:
        raise LogError(rec.path, "metadata altitude_ft/airspeed_kcas", "needed for a flight condition")
    std = isa(info.altitude_m)
    d_t = (info.oat_K - std.temperature) if info.oat_K is not None else 0.0
    atm = isa(info.altitude_m, d_t)
    tas = cas_to_tas(info.calibrated_airspeed_mps, info.altitude_m, d_t)
    return {"altitude_m": info.altitude_m, "delta_temperature_K": d_t, "density": atm.density,
            "kinematic_viscosity": atm.kinematic_viscosity, "true_airspeed_mps": tas}


def tow_trajectory(rec: FlightRecord) -> Trajectory:
    df = rec.topic("/tanker/tow_point")
    t = df.index.to_numpy(float)
    xyz = df[["x_m", "y_m", "z_m"]].to_numpy(float)
    return Trajectory(t, measured(t, xyz, TOW_CUTOFF_HZ))


def payout(rec: FlightRecord) -> tuple[np.ndarray, np.ndarray]:
    df = rec.topic("/reel/hose_out")
    t = df.index.to_numpy(float)
    return t, measured(t, df["length_m"].to_numpy(float), REEL_CUTOFF_HZ)


# The drogue's steady position before contact is read over this window (s),
# in the log and in the model alike, so the two are placed on the same span.
PRE_CONTACT_S = 3.0


def contact_window(rec: FlightRecord) -> tuple[float, float]:
    """(contact, disconnect) of an engagement: a log without contact is refused,
    one without disconnect is held to its end (inf)."""
    t_on, t_off = rec.contact_events()
    if t_on is None:
        raise LogError(rec.path, "topic /probe/events", "no contact event")
    return t_on, (np.inf if t_off is None else t_off)


def drogue_while_engaged(rec: FlightRecord, drogue_start: np.ndarray, stiffness: float = 0.0,
                         damping: float = 0.0) -> EndConstraint:
    """The drogue held by the probe from contact to disconnect, as the paper
    prescribed it: its displacement from the steady trail before contact,
    added to the model's own steady drogue position `drogue_start`.

    The probe track (no dropouts) carries the motion; the drogue centre sits at
    a fixed offset from the probe tip once engaged, measured as the median of
    (drogue - probe) over the engaged fixes the optical tracker kept. The
    steady position is the median of the valid fixes in the PRE_CONTACT_S
    before contact.
    `stiffness` and `damping` are the probe coupling's (see EndConstraint)."""
    t_on, t_off = contact_window(rec)
    probe = rec.topic("/receiver/probe")
    tp = probe.index.to_numpy(float)
    pp = probe[["x_m", "y_m", "z_m"]].to_numpy(float)
    fixes = rec.tracker_fixes()
    td_all = fixes.index.to_numpy(float)
    dd_all = fixes[["x_m", "y_m", "z_m"]].to_numpy(float)
    ok = (td_all >= t_on + 0.5) & (td_all <= min(t_off, tp[-1]) - 0.5)
    pre = (td_all >= t_on - PRE_CONTACT_S) & (td_all < t_on)
    if ok.sum() < 5 or pre.sum() < 5:
        raise LogError(rec.path, "topic /ors/drogue",
                       "too few valid fixes around contact to place the drogue on the probe")
    at_probe = np.column_stack([np.interp(td_all[ok], tp, pp[:, c]) for c in range(3)])
    offset = np.median(dd_all[ok] - at_probe, axis=0)
    steady = np.median(dd_all[pre], axis=0)
    path = probe_track(rec)[1] + offset - steady + np.asarray(drogue_start, dtype=float)
    return EndConstraint(Trajectory(tp, path), t_on=t_on, t_off=t_off, stiffness=stiffness, damping=damping)


def probe_held_drogue(case, model, rec: FlightRecord, drogue_start: np.ndarray) -> EndConstraint:
    """`drogue_while_engaged` with the case's probe coupling: stiffness
    probe_coupling_N_m and the damping of probe_coupling_damping_ratio on the
    drogue's (or tip's) mass."""
    k = float(case["model"]["probe_coupling_N_m"])
    m_end = model.drogue.mass if model.drogue else model.tip_mass
    c = 2.0 * float(case["model"]["probe_coupling_damping_ratio"]) * np.sqrt(k * m_end)
    return drogue_while_engaged(rec, drogue_start, stiffness=k, damping=c)
