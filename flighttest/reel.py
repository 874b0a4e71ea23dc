"""An engagement's reel track: the take-up and the receiver's closure over
the contact, on one uniform grid (`metrics.reel` measures the reel's
response from them).

Both come from channels the drogue tracker has no part in: the pod's payout
(`/reel/hose_out`) and the receiver's probe (`/receiver/probe`), timed by the
probe's contact and disconnect events, so a tracker lag cannot pass for a
late reel.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .metrics.sampling import resample_uniform
from .record import FlightRecord, LogError

TRACK_HZ = 25.0        # a reel response of a few rad/s, sampled well above it
MARGIN_S = 2.0         # the grid's reach before contact (the payout at rest) and after disconnect


@dataclasses.dataclass(frozen=True)
class ReelTrack:
    """Time from contact (s), the probe's closure towards the tanker since
    contact (m, 0 outside the contact) and the reel's take-up (m, payout
    before contact minus payout)."""

    t: np.ndarray
    closure: np.ndarray
    take_up: np.ndarray

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.t, self.closure, self.take_up


def reel_track(record: FlightRecord) -> ReelTrack:
    """The record's reel track from `MARGIN_S` before contact to `MARGIN_S`
    after disconnect (the end of the payout where it ends sooner). LogError
    naming the topic when the record has no contact and disconnect, or too
    little payout or probe track around them."""
    tc, td = record.contact_events()
    if tc is None or td is None:
        raise LogError(record.path, "/probe/events", "needs a contact and a disconnect after it")
    reel, probe = record.topic("/reel/hose_out"), record.topic("/receiver/probe")
    t_r, length = reel.index.to_numpy(float), reel["length_m"].to_numpy(float)
    t_p, x_p = probe.index.to_numpy(float), probe["x_m"].to_numpy(float)
    t, payout = resample_uniform(t_r, length, TRACK_HZ, tc - MARGIN_S, td + MARGIN_S)
    before = t < tc
    if before.sum() < 3 or t[-1] < td:
        raise LogError(record.path, "/reel/hose_out", "the payout does not cover the contact with a margin before it")
    ok = np.isfinite(x_p)
    if ok.sum() < 3 or t_p[ok][0] > tc or t_p[ok][-1] < td:
        raise LogError(record.path, "/receiver/probe", "the probe track does not cover the contact")
    x = np.interp(t, t_p[ok], x_p[ok])
    x_contact = float(np.interp(tc, t_p[ok], x_p[ok]))
    engaged = (t >= tc) & (t <= td)
    closure = np.where(engaged, x_contact - x, 0.0)
    take_up = float(np.median(payout[before])) - payout
    return ReelTrack(t - tc, closure, take_up)
