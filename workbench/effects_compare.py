"""Comparison-side effects: corrections applied to flight data before it is held
against a simulation, never to the physics: `sensor_lag` and `drogue_reference`
(their parameters live in the registry, `solver.effects.EFFECTS`).

A tracker with latency `delay_s` stamps each fix `delay_s` after the moment it
describes. The correction moves its time stamps back by `delay_s`; on a common
time base that is the tracker channel read at t + delay_s.
"""
from __future__ import annotations

import dataclasses

import numpy as np

TRACKER_TOPIC = "/ors/drogue"


def shift_series(t: np.ndarray, y: np.ndarray, delay_s: float) -> np.ndarray:
    """The series y(t) read `delay_s` later, y(t + delay_s), on the same samples
    (linear interpolation; held at the ends). Works column-wise on 2D y."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    tq = t + float(delay_s)
    if y.ndim == 1:
        return np.interp(tq, t, y)
    return np.column_stack([np.interp(tq, t, y[:, c]) for c in range(y.shape[1])])


def restamp(t: np.ndarray, delay_s: float) -> np.ndarray:
    """Time stamps of a channel with latency `delay_s`, moved to the moments they describe."""
    return np.asarray(t, dtype=float) - float(delay_s)


def with_tracker_delay(record, delay_s: float, topic: str = TRACKER_TOPIC):
    """A copy of a flighttest.FlightRecord whose `topic` time stamps are moved back
    by `delay_s` (the other topics untouched)."""
    if delay_s == 0 or topic not in record.topics:
        return record
    df = record.topics[topic].copy()
    df.index = df.index - float(delay_s)
    topics = dict(record.topics)
    topics[topic] = df
    return dataclasses.replace(record, topics=topics)


def with_tracker_offset(record, offset_m: float, topic: str = TRACKER_TOPIC):
    """A copy of a flighttest.FlightRecord whose tracked drogue point is moved
    `offset_m` forward in x: a tracker whose target lies `offset_m` aft of the
    model's drogue centre, seen as the model's point."""
    if offset_m == 0 or topic not in record.topics:
        return record
    df = record.topics[topic].copy()
    df["x_m"] = df["x_m"] - float(offset_m)
    return dataclasses.replace(record, topics=dict(record.topics, **{topic: df}))


def apply_comparison_effects(record, effects: dict):
    """The flight record as the comparison should see it under the case's
    comparison-only effects ({name: {param: value}}, validated)."""
    lag = effects.get("sensor_lag")
    if lag:
        record = with_tracker_delay(record, lag["delay_s"])
    ref = effects.get("drogue_reference")
    if ref:
        record = with_tracker_offset(record, ref["offset_m"])
    return record
