"""A simulation run saved in the flight-log contract, so that it is measured and
compared by exactly the code that measures the logs (and opens in Foxglove)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from flighttest import FlightRecord, make_record
from flighttest.writer import Scene
from solver.result import SimulationResult

VIDEO_DT = 0.1    # s, the chase-plane video rate
ORS_DT = 1 / 30   # s
SIM_HOSE_COLOR = (0.1, 0.35, 0.85, 1.0)   # the simulated hose, apart from the log's dark one


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


def result_scene(result: SimulationResult) -> Scene:
    """What Foxglove draws of a run: its hose in 3-D (the contract's /video/hose
    keeps x and z only, the side view a video sees, so a scene drawn from
    the record would lie flat at y = 0), the drogue, and the forces on the
    tow point and on the probe as arrows, at the tracker's rate."""
    k = _decimate(result.t, ORS_DT)
    t = result.t[k]
    end = result.end_xyz[k]
    return Scene(hose_t=t, hose=[result.hose_points(j) for j in k], drogue_t=t, drogue=end,
                 arrows={"tow_force": (t, result.hose_xyz[k, 0, :], result.tow_force[k]),
                         "probe_force": (t, end, result.probe_force[k])},
                 note="simulated hose centre line, 3-D", hose_color=SIM_HOSE_COLOR)


def case_test_card(case) -> FlightRecord:
    """A record with only a test card, for a case run without a log: the case's
    kind, hardware and condition in the units of a test card."""
    cond = case["condition"]
    raw = {"schema_version": "1", "test_id": case.id, "test_kind": case.kind}
    raw.update({k: v for k, v in case["hardware"].items() if v})
    raw.update({k: f"{cond[k]:g}" for k in ("altitude_ft", "airspeed_kcas", "oat_F", "hose_length_ft")
                if cond.get(k) is not None})
    raw["hose_fuel"] = cond["hose_fuel"]
    return make_record(raw, {}, 0)
