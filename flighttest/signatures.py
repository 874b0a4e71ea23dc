"""Signature components of the one comparison: features of a log that effects
moving things in time or along the hose leave, as log minus simulation in
metres so that they join the gap (`residual.residual`, channel `CHANNEL`,
the feature named in the component's band).

* tracker phase (doublet, engagement): the phase of the tracker's drogue z
  against the tow point's z at the drogue's fundamental, per segment, times
  the drogue's amplitude there: a tracker lag tau shows as -2 pi f tau A,
  i.e. the lag times the drogue's velocity amplitude. Kept only where both
  channels carry the fundamental at `REF_SNR` times their noise (decided on
  the log, so the residual's length does not depend on the simulation).
* bow wave (engagement with a probe track): how far the drogue moved (y, z)
  between `BOW_EARLY_S` and `BOW_LATE_S` before contact, while the probe
  closed: a steady offset (lift, drag, wind) cancels, a push that grows as
  the probe nears does not.
* hose curvature (trail): the second difference of the mean hose shape along
  x over `CURVE_STRIDE_M`, per segment: a distributed load (hose drag) bends
  the hose along its length, an end load (drogue drag) mostly re-tensions it,
  which the drogue's steady position components see.

The reel's take-up start against contact is no component: the baseline
prescribes the logged payout (`[model] reel = "from_log"`), so the simulated
reel is the log's own and the feature would be zero whatever the effects.
The reel is measured against the receiver's closure instead (`reel`).

Noise floors are the log's own scatter: the tracker's and tow point's
sample-to-sample scatter (std of second differences / sqrt 6) through the
least-squares phase fit (the phase's error times the amplitude: the error of
a phase difference near zero; a difference dphi adds the amplitude's
relative error, as large, times dphi); the spread about each window's mean over sqrt(n);
the mean shape's spread per bin over sqrt(n), through the second difference.
The log side is measured once (`measure`); `components` adds the simulated
side. A record against itself gives zero components.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

CHANNEL = "signature"
REF_SNR = 5.0                 # a channel's amplitude at the fundamental over its phase-fit noise, to be kept
BOW_EARLY_S = (2.5, 2.0)      # s before contact: the drogue before the probe's bow wave reaches it ...
BOW_LATE_S = (0.5, 0.0)       # ... and in the last half second before contact
CURVE_STRIDE_M = 5.0          # m, the second difference's stride along x (five 1 m shape bins)


def scatter(y) -> float:
    """The sample-to-sample scatter of a series: the std of its second
    differences over sqrt 6, i.e. that of white noise (motion slow against the
    sampling leaves A (w dt)^2 in a second difference, which first differences
    would keep at A w dt)."""
    y = np.asarray(y, float)
    return float(np.std(np.diff(y, 2)) / math.sqrt(6.0)) if len(y) > 3 else 0.0


def phasor(t, y, f_hz: float, sigma: float) -> tuple[float, float, float]:
    """Least-squares fit of y ~ c + A cos(2 pi f t + phi): (A, phi, the
    standard error of phi for samples of white noise `sigma`)."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    w = 2.0 * math.pi * f_hz
    X = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
    (_, a, b), *_ = np.linalg.lstsq(X, y, rcond=None)
    A = math.hypot(a, b)
    if A == 0.0 or len(t) < 4:
        return A, 0.0, math.inf
    C = sigma ** 2 * np.linalg.pinv(X.T @ X)[1:, 1:]
    g = np.array([b, -a]) / A ** 2          # phi = atan2(-b, a)
    return A, math.atan2(-b, a), float(math.sqrt(max(g @ C @ g, 0.0)))


def wrap(phi):
    """Angle(s) into [-pi, pi)."""
    return (np.asarray(phi, float) + math.pi) % (2.0 * math.pi) - math.pi


def relative_phase(t, y, t_ref, y_ref, f_hz: float, sigma: float, sigma_ref: float):
    """(amplitude of y, phase of y against the reference, its standard error,
    and the two channels' own phase errors: each one's noise over amplitude)."""
    A, phi, s = phasor(t, y, f_hz, sigma)
    _, phr, sr = phasor(t_ref, y_ref, f_hz, sigma_ref)
    return A, float(wrap(phi - phr)), math.hypot(s, sr), s, sr


@dataclasses.dataclass(frozen=True, eq=False)
class LogSignatures:
    """The log side of the signature components: per feature its log values,
    floors and tags, and what the simulated side is measured on."""

    phase: tuple = ()      # (segment, t0, t1, f, A, phi, floor_m)
    bow: tuple = ()        # (channel index, early mask, late mask, growth, floor_m, t, segment)
    curve: tuple = ()      # (segment, t, xs, second differences, floor_m)


def _phase_log(fix_t, z, tow_t, tow_z, window, f_hz, seg_of) -> list:
    out = []
    s, sr = scatter(z), scatter(tow_z)
    for seg in (0, 1):
        m = (fix_t >= window[0]) & (fix_t <= window[1]) & (seg_of(fix_t) == seg)
        mr = (tow_t >= window[0]) & (tow_t <= window[1]) & (seg_of(tow_t) == seg)
        if m.sum() < 8 or mr.sum() < 8:
            continue
        A, phi, sphi, s_own, s_ref = relative_phase(fix_t[m], z[m], tow_t[mr], tow_z[mr], f_hz, s, sr)
        # kept only where both phases are measured: a phase error of 1 / REF_SNR
        # rad is the amplitude at REF_SNR times its noise
        if max(s_own, s_ref) * REF_SNR > 1.0:
            continue
        out.append((seg, window[0], window[1], f_hz, A, phi, A * sphi))
    return out


def _bow_log(log, fix_t, fix_xyz, seg_of) -> list:
    tc, _ = log.contact_events()
    if tc is None:
        return []
    early = (fix_t >= tc - BOW_EARLY_S[0]) & (fix_t < tc - BOW_EARLY_S[1])
    late = (fix_t >= tc - BOW_LATE_S[0]) & (fix_t < tc - BOW_LATE_S[1])
    if early.sum() < 3 or late.sum() < 3:
        return []
    t = float(tc - 0.5 * sum(BOW_LATE_S))
    out = []
    for c in (1, 2):
        y0, y1 = fix_xyz[early, c], fix_xyz[late, c]
        out.append((c, early, late, float(np.mean(y1) - np.mean(y0)),
                    math.sqrt(np.var(y0, ddof=1) / len(y0) + np.var(y1, ddof=1) / len(y1)), t, int(seg_of(t))))
    return out


def _curve_log(mean_shapes, seg_times) -> list:
    out = []
    for seg, (shp, t) in enumerate(zip(mean_shapes, seg_times)):
        x, z = shp["x_m"].to_numpy(float), shp["z_m"].to_numpy(float)
        f = np.nan_to_num(shp["z_std_m"].to_numpy(float) / np.sqrt(np.maximum(shp["n"].to_numpy(float), 1.0)))
        xs = np.arange(x[0] + CURVE_STRIDE_M, x[-1] - CURVE_STRIDE_M + 1e-9, CURVE_STRIDE_M)
        if not len(xs):
            continue
        # the floors of z(xs - S), z(xs), z(xs + S), independent, through 1, -2, 1
        fl = np.sqrt(np.interp(xs - CURVE_STRIDE_M, x, f) ** 2 + 4.0 * np.interp(xs, x, f) ** 2
                     + np.interp(xs + CURVE_STRIDE_M, x, f) ** 2)
        out.append((seg, t, xs, second_difference(xs, x, z), fl))
    return out


def measure(log, kind: str, fix_t, fix_xyz, t_from: float, f_hz: float, seg_of,
            mean_shapes=None, seg_times=None) -> LogSignatures:
    """The log side: `fix_t`, `fix_xyz` the valid tracker fixes, `t_from` the
    drogue bins' first edge, `f_hz` the fundamental, `seg_of` the segment of
    times; for a trail the video hose's mean shape per segment and the
    segments' mid times."""
    phase = bow = curve = ()
    if kind in ("pitch_doublet", "engagement"):
        tow = log.topic("/tanker/tow_point")
        phase = _phase_log(fix_t, fix_xyz[:, 2], tow.index.to_numpy(float), tow["z_m"].to_numpy(float),
                           (t_from, float(fix_t[-1])), f_hz, seg_of)
    if kind == "engagement" and "/receiver/probe" in log.topics:
        bow = _bow_log(log, fix_t, fix_xyz, seg_of)
    if kind == "trail" and mean_shapes is not None:
        curve = _curve_log(mean_shapes, seg_times)
    return LogSignatures(tuple(phase), tuple(bow), tuple(curve))


def second_difference(xs, x, z) -> np.ndarray:
    """z(xs - S) - 2 z(xs) + z(xs + S) of the line (x, z), S = `CURVE_STRIDE_M` (m)."""
    return (np.interp(xs - CURVE_STRIDE_M, x, z) - 2.0 * np.interp(xs, x, z)
            + np.interp(xs + CURVE_STRIDE_M, x, z))


def components(sig: LogSignatures, fix_t, sim_t, sim_xyz, sim_tow, sim_lines, delay_s: float, seg_of):
    """(r, floor, station, t, segment, band) per signature component: log
    minus simulation. `sim_t`, `sim_xyz` the simulated tracker, `sim_tow`
    (t, z) its tow point, `sim_lines` its mean hose line per segment (trail),
    `delay_s` the tracker latency applied to the simulated side (a fix
    stamped t shows the drogue at t - delay_s)."""
    out = []
    st = None if sim_t is None else sim_t + delay_s
    for seg, t0, t1, f, A, phi, fl in sig.phase:
        m = (st >= t0) & (st <= t1) & (seg_of(st) == seg)
        mr = (sim_tow[0] >= t0) & (sim_tow[0] <= t1) & (seg_of(sim_tow[0]) == seg)
        _, phi_s, *_ = relative_phase(st[m], sim_xyz[m, 2], sim_tow[0][mr], sim_tow[1][mr], f, 0.0, 0.0)
        out.append((float(wrap(phi - phi_s)) * A, fl, math.nan, 0.5 * (t0 + t1), seg,
                    f"tracker phase at {f:.2f} Hz"))
    for c, early, late, v, fl, t, seg in sig.bow:
        y = np.interp(fix_t - delay_s, sim_t, sim_xyz[:, c])
        out.append((v - (np.mean(y[late]) - np.mean(y[early])), fl, math.nan, t, seg,
                    f"bow wave: drogue {'xyz'[c]} growth before contact"))
    for seg, t, xs, v, fl in sig.curve:
        line = sim_lines[seg]
        c = v - second_difference(xs, line[:, 0], line[:, 1])
        out += [(c[k], fl[k], xs[k], t, seg, f"hose curvature over {CURVE_STRIDE_M:g} m") for k in range(len(xs))]
    return out
