"""Messages of the contract topics: strict JSON, field checks, DataFrames.

Shared by the reader (every message read is checked here) and the writer
(every message is checked here before anything is written), so the two can
never disagree about what a valid message is.
"""
from __future__ import annotations

import json
import math
from typing import Any, Mapping

import numpy as np
import pandas as pd

from .schema import (BOOLEAN, EVENT, FIELD_RANGES, NULLABLE_NUMBER, NUMBER, POINT_FIELDS, POINTS,
                     PROBE_EVENTS, TOPICS)

# Nanosecond times are held as int64 (pandas, numpy): 2**63 ns is in 2262.
_MAX_TIME_NS = 1 << 63


def _no_constants(name: str) -> Any:
    raise ValueError(f"non-finite literal {name}")


_DECODER = json.JSONDecoder(parse_constant=_no_constants)


def decode_json(data: bytes) -> Any:
    """Strict JSON: UTF-8, no NaN/Infinity literals.  Errors read "is not ..."."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError("is not UTF-8 text") from None
    try:
        return _DECODER.decode(text)
    except RecursionError:
        raise ValueError("nests too deeply") from None
    except ValueError as exc:
        raise ValueError(f"is not valid JSON ({str(exc).splitlines()[0]})") from None


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check_number(v: Any, name: str, nullable: bool = False) -> float:
    if v is None and nullable:
        return math.nan
    if not _is_number(v):
        raise ValueError(f"field {name!r} must be a number, got {_json_type(v)}")
    f = float(v)
    if not math.isfinite(f):
        raise ValueError(f"field {name!r} is not finite ({v!r})")
    return f


def _json_type(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "boolean"
    if isinstance(v, str):
        return "string"
    if isinstance(v, list):
        return "array"
    if isinstance(v, dict):
        return "object"
    return "number"


def _check_fields(obj: Any, spec: Mapping[str, str], what: str = "message") -> None:
    if not isinstance(obj, dict):
        raise ValueError(f"{what} must be a JSON object, got {_json_type(obj)}")
    if obj.keys() != spec.keys():
        missing = sorted(spec.keys() - obj.keys())
        extra = sorted(obj.keys() - spec.keys())
        if missing:
            raise ValueError(f"{what} lacks field {missing[0]!r}")
        raise ValueError(f"{what} has unknown field {extra[0]!r}")


def parse_topic(topic: str, msgs: list[tuple[int, int, bytes]]) -> tuple[np.ndarray, dict[str, list]]:
    """Validate one topic's messages; return log times and columns."""
    spec = TOPICS[topic].fields
    cols: dict[str, list] = {name: [] for name in spec}
    last = None
    for i, (log_time, publish_time, data) in enumerate(msgs):
        where = f"topic {topic}"
        try:
            if publish_time != log_time:
                raise ValueError(f"publish_time {publish_time} differs from log_time {log_time}")
            if log_time >= _MAX_TIME_NS:
                raise ValueError("log_time is beyond the year 2262 (damaged time field)")
            if last is not None and log_time <= last:
                raise ValueError(f"log_time does not increase ({log_time} after {last})")
            last = log_time
            try:
                obj = decode_json(data)
            except ValueError as exc:
                raise ValueError(f"message {exc}") from None
            _check_fields(obj, spec)
            valid = True
            if "valid" in spec:
                valid = obj["valid"]
                if not isinstance(valid, bool):
                    raise ValueError(f"field 'valid' must be a boolean, got {_json_type(valid)}")
            for name, kind in spec.items():
                v = obj[name]
                if kind == NUMBER:
                    cols[name].append(_check_number(v, name))
                elif kind == NULLABLE_NUMBER:
                    if v is None and valid:
                        raise ValueError(f"field {name!r} is null while 'valid' is true")
                    f = _check_number(v, name, nullable=True)
                    # Coordinates of a lost track are not data, whatever was logged.
                    cols[name].append(f if valid else math.nan)
                elif kind == BOOLEAN:
                    cols[name].append(v)
                elif kind == EVENT:
                    if v not in PROBE_EVENTS:
                        raise ValueError(f"field {name!r} is {v!r}, not one of "
                                         f"{', '.join(PROBE_EVENTS)}")
                    cols[name].append(v)
                elif kind == POINTS:
                    if not isinstance(v, list):
                        raise ValueError(f"field {name!r} must be an array, got {_json_type(v)}")
                    pts = []
                    for j, p in enumerate(v):
                        _check_fields(p, dict.fromkeys(POINT_FIELDS, NUMBER), f"point {j}")
                        pts.append((_check_number(p["x_m"], f"points[{j}].x_m"),
                                    _check_number(p["z_m"], f"points[{j}].z_m")))
                    cols[name].append(pts)
        except ValueError as exc:
            raise TopicError(where, f"message {i} (log_time {log_time}): {exc}") from None
    for name in spec:
        rng = FIELD_RANGES.get((topic, name))
        if rng is None or not cols[name]:
            continue
        values = np.asarray(cols[name], dtype=float)
        bad = np.flatnonzero(~rng.holds(values))
        if len(bad):
            i = int(bad[0])
            raise TopicError(f"topic {topic}", f"message {i} (log_time {msgs[i][0]}): field "
                                               f"{name!r} = {values[i]:g} is outside the physical "
                                               f"range {rng}")
    times = np.fromiter((m[0] for m in msgs), dtype=np.int64, count=len(msgs))
    return times, cols


class TopicError(Exception):
    """A message that breaks the contract: `where` names the topic, `problem` the message and fault."""

    def __init__(self, where: str, problem: str):
        super().__init__(problem)
        self.where, self.problem = where, problem


def frame_topic(topic: str, times_ns: np.ndarray, cols: dict[str, list], start_ns: int) -> pd.DataFrame:
    t_s = (times_ns - start_ns) / 1e9
    if topic == "/video/hose":
        frames = cols["points"]
        counts = np.fromiter((len(p) for p in frames), dtype=np.int64, count=len(frames))
        flat = [xy for pts in frames for xy in pts]
        xz = np.array(flat, dtype=float).reshape(-1, 2)
        df = pd.DataFrame({
            "t_s": np.repeat(t_s, counts),
            "point": np.concatenate([np.arange(k) for k in counts]) if len(counts) else
            np.zeros(0, dtype=np.int64),
            "x_m": xz[:, 0], "z_m": xz[:, 1],
        })
        # A frame with no points has no rows: the long format cannot hold it.
        return df
    data: dict[str, Any] = {}
    for name, kind in TOPICS[topic].fields.items():
        if kind == BOOLEAN:
            data[name] = np.asarray(cols[name], dtype=bool)
        elif kind == EVENT:
            data[name] = pd.Series(cols[name], dtype=object).to_numpy()
        else:
            data[name] = np.asarray(cols[name], dtype=float)
    return pd.DataFrame(data, index=pd.Index(t_s, name="t_s"))
