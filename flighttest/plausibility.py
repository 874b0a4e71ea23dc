"""Values the contract allows one by one but that do not make a recording together.

Each message field is checked alone when it is read (`messages`, with the
ranges of `schema.FIELD_RANGES`); this module checks what only the whole
record shows.  Decided per case, as issue 14 asks (refused or reported,
never silently turned into a number):

- a tracker fix farther from the tow point than the hose reaches (a z logged
  in mm, or scaled by -1000) is **refused**: no drogue can be there, and
  every drogue figure would be computed from it;
- consecutive valid tracker fixes more than `MAX_TRACKER_STEP_M` apart are
  **refused**: the tracker has locked onto something else, and the steady
  position, frequency and damping would all carry the jump;
- a topic silent for longer than `gap_limit_s` of its nominal rate, or the
  tracker without a valid fix for longer than `MAX_TRACKER_LOST_S`, is
  **reported** (`FlightRecord.warnings`, which `analyze_record` carries into
  its output): a gap is a fact of the recording, and the figures from the
  samples around it are still measurements.
"""
from __future__ import annotations

import numpy as np

from solver.units import FT

from .record import TRACKER_TOPIC, FlightRecord, LogError
from .schema import METADATA_RANGES, TOPICS

# Hose stretch under drag is a few per cent (at most 0.4 % in this program's
# logs); 20 % leaves room for tracker bias, never for a mis-scaled coordinate.
REACH_MARGIN = 1.2
# Ten times the largest step between consecutive fixes in this program's logs
# (0.46 m, pitch doublet at 30 Hz with sub-second dropouts).
MAX_TRACKER_STEP_M = 5.0
# The longest stretch without a valid fix in this program's logs is 0.8 s.
MAX_TRACKER_LOST_S = 2.0


def gap_limit_s(rate_hz: float) -> float:
    """Longest silence of a topic sampled at `rate_hz` that is not reported."""
    return max(1.0, 10.0 / rate_hz)


def _reach_m(record: FlightRecord) -> tuple[float, str]:
    if record.info.hose_length_m is not None:
        return REACH_MARGIN * record.info.hose_length_m, "hose_length_ft"
    return REACH_MARGIN * METADATA_RANGES["hose_length_ft"].hi * FT, "the longest hose"


def _check_tracker(record: FlightRecord, label) -> None:
    if TRACKER_TOPIC not in record.topics or not len(record.topics[TRACKER_TOPIC]):
        return
    fixes = record.tracker_fixes()
    t = fixes.index.to_numpy(float)
    xyz = fixes[["x_m", "y_m", "z_m"]].to_numpy(float)
    reach, source = _reach_m(record)
    dist = np.linalg.norm(xyz, axis=1)
    far = np.flatnonzero(dist > reach)
    if len(far):
        i = int(far[0])
        raise LogError(label, f"topic {TRACKER_TOPIC}",
                       f"fix at t_s={t[i]:.3f} is {dist[i]:.4g} m from the tow point, beyond the "
                       f"hose's reach [0, {reach:.4g}] m ({REACH_MARGIN:g} x {source})")
    step = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    jump = np.flatnonzero(step > MAX_TRACKER_STEP_M)
    if len(jump):
        i = int(jump[0])
        raise LogError(label, f"topic {TRACKER_TOPIC}",
                       f"consecutive valid fixes at t_s={t[i]:.3f} and {t[i + 1]:.3f} are "
                       f"{step[i]:.4g} m apart, over the {MAX_TRACKER_STEP_M:g} m a drogue can "
                       f"move between fixes")


def _gaps(record: FlightRecord) -> list[str]:
    out = []
    for topic, df in record.topics.items():
        rate = TOPICS[topic].nominal_rate_hz
        t = np.unique(df["t_s"].to_numpy(float)) if topic == "/video/hose" else df.index.to_numpy(float)
        if rate is None or len(t) < 2:
            continue
        gap = np.diff(t)
        i = int(np.argmax(gap))
        if gap[i] > gap_limit_s(rate):
            out.append(f"topic {topic}: no message for {gap[i]:.3g} s from t_s={t[i]:.3f} "
                       f"(nominal rate {rate:g} Hz)")
    if TRACKER_TOPIC in record.topics and len(record.topics[TRACKER_TOPIC]):
        t = record.tracker_fixes().index.to_numpy(float)
        if len(t) >= 2:
            gap = np.diff(t)
            i = int(np.argmax(gap))
            if gap[i] > MAX_TRACKER_LOST_S:
                out.append(f"topic {TRACKER_TOPIC}: no valid fix for {gap[i]:.3g} s from "
                           f"t_s={t[i]:.3f}")
    return out


def check(record: FlightRecord, label) -> list[str]:
    """Refuse (LogError naming `label`) or report (the returned warnings) what
    the record's values show together; see the module docstring."""
    _check_tracker(record, label)
    return _gaps(record)
