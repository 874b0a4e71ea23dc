"""The reel's take-up against the receiver's closure over a contact.

A constant-tension reel takes up the hose the receiver pushes back: the
take-up (payout before contact minus payout) follows the probe's closure
(how far it has moved towards the tanker since contact). How it follows,
how late and how briskly, is the reel's response, which a data sheet giving
only the drum and its mode does not state. It is measured here as a dead
time T with a second-order lag and a gain,

    take-up(s) = g w^2 / (s^2 + 2 z w s + w^2) e^(-s T) closure(s),

fitted by least squares on a uniform grid. The form is a summary, not the
reel's physics: the hose's slack and its waves leave a misfit of their own,
which a response fitted on the program's own engagements leaves on each of
them held out (`held_out_misfit`), the everyday misfit a new engagement's is
measured against.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import optimize, signal

# search box of the response: delays up to 2 s, responses from about 20 s to
# 0.15 s, damping from a ringing 0.05 to an overdamped 3, gain 0.3-2
RESPONSE_BOX = {"delay_s": (0.0, 2.0), "natural_frequency_rad_s": (0.3, 40.0), "damping_ratio": (0.05, 3.0),
                "gain": (0.3, 2.0)}
RESPONSE_KEYS = tuple(RESPONSE_BOX)
_LO, _HI = zip(*RESPONSE_BOX.values())
_DELAY_STARTS_S = (0.1, 0.3, 0.6)   # least squares in a dead time has local minima


@dataclasses.dataclass(frozen=True)
class ReelResponse:
    """A reel's take-up response to the closure: dead time (s), natural
    frequency (rad/s), damping ratio and gain."""

    delay_s: float
    natural_frequency_rad_s: float
    damping_ratio: float
    gain: float

    def as_vector(self) -> np.ndarray:
        return np.array([self.delay_s, self.natural_frequency_rad_s, self.damping_ratio, self.gain])

    def take_up(self, t, closure) -> np.ndarray:
        """The take-up this response gives to `closure` sampled at the uniform
        times `t` (s), from rest."""
        return _take_up(self.as_vector(), np.asarray(t, float), np.asarray(closure, float))


def _take_up(p, t, u) -> np.ndarray:
    delay, w, z, g = p
    delayed = np.interp(t - delay, t, u, left=u[0])
    _, y, _ = signal.lsim(signal.lti([g * w * w], [1.0, 2.0 * z * w, w * w]), delayed, t - t[0])
    return np.asarray(y, float)


def misfit(response: ReelResponse, t, closure, take_up) -> float:
    """RMS of the measured `take_up` minus `response`'s, m."""
    r = response.take_up(t, closure) - np.asarray(take_up, float)
    return float(math.sqrt(np.mean(r ** 2)))


def fit_reel_response(tracks) -> ReelResponse:
    """The response fitted jointly to `tracks`, each (t, closure, take_up) on
    a uniform grid, by least squares from several dead times (the best)."""
    tracks = [tuple(np.asarray(a, float) for a in tr) for tr in tracks]
    if not tracks or any(len(t) < 8 for t, _, _ in tracks):
        raise ValueError("a reel response needs at least one track of 8 samples or more")

    def resid(p):
        return np.concatenate([_take_up(p, t, u) - y for t, u, y in tracks])

    best = None
    for d in _DELAY_STARTS_S:
        r = optimize.least_squares(resid, [d, 5.0, 0.7, 1.0], bounds=(_LO, _HI))
        if best is None or r.cost < best.cost:
            best = r
    return ReelResponse(*(float(v) for v in best.x))


def held_out_misfit(tracks) -> tuple[ReelResponse, float]:
    """(the response fitted on all `tracks`, the everyday misfit): the largest
    RMS misfit of a track under the response fitted on the others; with one
    track, its own fit's (which flatters it)."""
    tracks = list(tracks)
    whole = fit_reel_response(tracks)
    if len(tracks) == 1:
        return whole, misfit(whole, *tracks[0])
    return whole, max(misfit(fit_reel_response(tracks[:i] + tracks[i + 1:]), *tr) for i, tr in enumerate(tracks))
