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


def _frames_at(t: np.ndarray, like: FlightRecord) -> np.ndarray:
    """Indices of the records nearest each of `like`'s video frames (those the
    run covers): the simulation sampled when the chase plane's camera was, so
    that each video frame is compared with the simulated hose of its moment.
    A card without video (a case run without a log) gets the chase video's rate."""
    if "/video/hose" not in like.topics:
        return _decimate(t, VIDEO_DT)
    frames = np.unique(like.topic("/video/hose")["t_s"].to_numpy(float))
    frames = frames[(frames >= t[0]) & (frames <= t[-1])]
    k = np.clip(np.searchsorted(t, frames), 1, len(t) - 1)
    return np.where(np.abs(t[k - 1] - frames) <= np.abs(t[k] - frames), k - 1, k)


def _video(t: np.ndarray, hose_xyz: np.ndarray, n_points: np.ndarray, frames: np.ndarray) -> pd.DataFrame:
    """The long `/video/hose` table of `hose_xyz` at record indices `frames`,
    each frame's first `n_points` nodes (tow point first)."""
    n = n_points[frames]
    rec = np.repeat(frames, n)
    point = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    p = hose_xyz[rec, point]
    return pd.DataFrame({"t_s": t[rec], "point": point, "x_m": p[:, 0], "z_m": p[:, 2]})


def _card(like: FlightRecord, note: str) -> dict:
    raw = dict(like.info.raw)
    raw["test_id"] = raw["test_id"] + "-sim"
    raw["notes"] = ("simulation: " + note).strip()
    return raw


def _copied_inputs(like: FlightRecord, topics: dict) -> None:
    """Channels a simulation does not produce (air data, probe events and probe
    track, which were its inputs), copied from the log."""
    for name in ("/air_data", "/probe/events", "/receiver/probe"):
        if name in like.topics:
            topics[name] = like.topics[name]


def result_to_record(result: SimulationResult, like: FlightRecord, note: str = "",
                     ors_dt: float | None = ORS_DT) -> FlightRecord:
    """The run as a record of the same test kind as `like` (its test card, with
    the test id marked `-sim`). The tracker reads the drogue every `ors_dt`
    (None: at every record, as the diagnosis compares); the video shows the
    hose at `like`'s frame times. Channels the simulation does not produce are
    copied."""
    t = result.t
    idx = pd.Index(t, name="t_s")
    topics: dict[str, pd.DataFrame] = {}
    tow = result.hose_xyz[:, 0, :]
    topics["/tanker/tow_point"] = pd.DataFrame({"x_m": tow[:, 0], "y_m": tow[:, 1], "z_m": tow[:, 2]},
                                               index=idx)
    end = result.end_xyz
    k = _decimate(t, ors_dt) if ors_dt else np.arange(len(t))
    topics["/ors/drogue"] = pd.DataFrame({"x_m": end[k, 0], "y_m": end[k, 1], "z_m": end[k, 2],
                                          "valid": np.ones(len(k), bool)},
                                         index=pd.Index(t[k], name="t_s"))
    if like.info.test_kind in ("trail", "engagement"):
        topics["/video/hose"] = _video(t, result.hose_xyz, np.asarray(result.n_hose_elements) + 1,
                                       _frames_at(t, like))
    if like.info.test_kind == "engagement":
        topics["/reel/hose_out"] = pd.DataFrame({"length_m": result.reel_length}, index=idx)
    _copied_inputs(like, topics)
    return make_record(_card(like, note), topics, like.start_time_ns)


def static_to_record(t0: float, line: np.ndarray, drogue: np.ndarray, like: FlightRecord,
                     note: str = "") -> FlightRecord:
    """A static solution as a one-sample record of `like`'s test kind: the hose
    centre line `line` (m, 3), tow point first, ending where the video sees it
    end, and the drogue at `drogue` (3,), both at time `t0`."""
    idx = pd.Index([t0], name="t_s")
    topics: dict[str, pd.DataFrame] = {
        "/tanker/tow_point": pd.DataFrame({"x_m": [line[0, 0]], "y_m": [line[0, 1]], "z_m": [line[0, 2]]},
                                          index=idx),
        "/ors/drogue": pd.DataFrame({"x_m": [drogue[0]], "y_m": [drogue[1]], "z_m": [drogue[2]],
                                     "valid": [True]}, index=idx),
        "/video/hose": _video(np.array([t0]), line[None], np.array([len(line)]), np.array([0])),
    }
    _copied_inputs(like, topics)
    return make_record(_card(like, note), topics, like.start_time_ns)


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
