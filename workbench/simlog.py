"""A simulation run saved in the flight-log contract, so that it is measured and
compared by exactly the code that measures the logs (and opens in Foxglove)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from flighttest import FlightRecord, make_record
from solver.result import SimulationResult

VIDEO_DT = 0.1    # s, the chase-plane video rate
ORS_DT = 1 / 30   # s


def _decimate(t: np.ndarray, dt: float) -> np.ndarray:
    """Indices of records nearest a dt grid (the run records at a finer step)."""
    grid = np.arange(t[0], t[-1] + 1e-9, dt)
    idx = np.searchsorted(t, grid)
    idx = np.clip(idx, 0, len(t) - 1)
    return np.unique(idx)


def result_to_record(result: SimulationResult, like: FlightRecord, note: str = "") -> FlightRecord:
    """The run as a record of the same test kind as `like` (its test card, with
    the test id marked `-sim`). Channels the simulation does not produce (air
    data, probe events and probe track, which were its inputs) are copied."""
    raw = dict(like.info.raw)
    raw["test_id"] = raw["test_id"] + "-sim"
    raw["notes"] = ("simulation: " + note).strip()
    t = result.t
    idx = pd.Index(t, name="t_s")
    topics: dict[str, pd.DataFrame] = {}
    tow = result.hose_xyz[:, 0, :]
    topics["/tanker/tow_point"] = pd.DataFrame({"x_m": tow[:, 0], "y_m": tow[:, 1], "z_m": tow[:, 2]},
                                               index=idx)
    end = result.end_xyz
    k = _decimate(t, ORS_DT)
    topics["/ors/drogue"] = pd.DataFrame({"x_m": end[k, 0], "y_m": end[k, 1], "z_m": end[k, 2],
                                          "valid": np.ones(len(k), bool)},
                                         index=pd.Index(t[k], name="t_s"))
    if like.info.test_kind in ("trail", "engagement"):
        rows = []
        for j in _decimate(t, VIDEO_DT):
            pts = result.hose_points(j)
            for i, p in enumerate(pts):
                rows.append((t[j], i, p[0], p[2]))
        topics["/video/hose"] = pd.DataFrame(rows, columns=["t_s", "point", "x_m", "z_m"])
    if like.info.test_kind == "engagement":
        topics["/reel/hose_out"] = pd.DataFrame({"length_m": result.reel_length}, index=idx)
    for name in ("/air_data", "/probe/events", "/receiver/probe"):
        if name in like.topics:
            topics[name] = like.topics[name]
    return make_record(raw, topics, like.start_time_ns)
