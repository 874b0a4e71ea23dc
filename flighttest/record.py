"""The in-memory test record every reader, writer and measurement shares.

`FlightRecord` holds the typed test card and one DataFrame per contract topic;
`LogError` is the one error a record that breaks the contract raises.  The
accessors here (`tracker_fixes`, `contact_events`) are the one definition of
"a valid tracker fix" and of "the contact and disconnect times", so that
analysis, comparison and diagnosis read the same samples.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from .schema import TestInfo

TRACKER_TOPIC = "/ors/drogue"
EVENTS_TOPIC = "/probe/events"


class LogError(ValueError):
    """A record that breaks the log contract.  str() is one line:
    ``<file>: <topic, key or container>: <what is wrong>``."""

    def __init__(self, path: str | os.PathLike | None, where: str, problem: str):
        self.path = str(path) if path is not None else "<memory>"
        self.where = where
        self.problem = problem
        text = f"{self.path}: {where}: {problem}"
        super().__init__(" ".join(text.split()))

    def __reduce__(self):
        return (type(self), (self.path, self.where, self.problem))


@dataclass
class FlightRecord:
    """One test record: the typed test card and one DataFrame per known topic.

    Time-series topics are indexed by `t_s`, seconds from `start_time_ns`
    (the earliest log_time of any known topic).  `/video/hose` is long and
    tidy: columns t_s, point, x_m, z_m, one row per digitised point.
    `/probe/events` is indexed by t_s with one column `event`.
    """

    info: TestInfo
    topics: dict[str, pd.DataFrame]
    start_time_ns: int
    path: Path | None = None
    had_summary: bool = True
    warnings: list[str] = field(default_factory=list)

    def topic(self, name: str) -> pd.DataFrame:
        """The DataFrame of `name`, or LogError naming the topic if the record lacks it."""
        df = self.topics.get(name)
        if df is None or len(df) == 0:
            raise LogError(self.path, f"topic {name}",
                           f"needed here but absent or empty in this {self.info.test_kind} record")
        return df

    def tracker_fixes(self) -> pd.DataFrame:
        """The `/ors/drogue` rows that are data: `valid` true and x, y, z finite.

        The reader already nulls the coordinates of a lost track, so for a
        read record this is the `valid` rows; the finite check also covers
        records assembled in memory (`make_record`).  LogError naming the
        topic if the record lacks it.
        """
        ors = self.topic(TRACKER_TOPIC)
        xyz = ors[["x_m", "y_m", "z_m"]].to_numpy(float)
        return ors[ors["valid"].to_numpy(bool) & np.isfinite(xyz).all(axis=1)]

    def contact_events(self) -> tuple[float | None, float | None]:
        """(first contact, first disconnect after it) in t_s, None where absent.

        LogError naming the topic if the record has no `/probe/events`.
        """
        ev = self.topic(EVENTS_TOPIC)
        times, kinds = ev.index.to_numpy(float), ev["event"].to_numpy()
        contact = times[kinds == "contact"]
        if not len(contact):
            return None, None
        disconnect = times[(kinds == "disconnect") & (times > contact[0])]
        return float(contact[0]), (float(disconnect[0]) if len(disconnect) else None)


def make_record(info: TestInfo | Mapping[str, str], topics: Mapping[str, pd.DataFrame],
                start_time_ns: int) -> FlightRecord:
    """Assemble a FlightRecord (e.g. from a simulation run) for `write_record`."""
    if not isinstance(info, TestInfo):
        info = TestInfo.from_metadata(dict(info))
    return FlightRecord(info=info, topics=dict(topics), start_time_ns=int(start_time_ns))
