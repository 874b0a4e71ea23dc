"""Write records in the MCAP contract of SCHEMA.md.

`write_record` writes the same contract `read_record` reads (so a simulation
run can be stored and compared through the same code), checking every
message with the reader's own checks first, and can add Foxglove well-known
schemas for scrubbing the hose in Foxglove's 3D panel.
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .messages import TopicError, parse_topic
from .plausibility import check as check_plausibility
from .record import FlightRecord, LogError
from .schema import (BOOLEAN, EVENT, MESSAGE_ENCODING, METADATA_NAME, NULLABLE_NUMBER, NUMBER,
                     POINT_FIELDS, POINTS, PROBE_EVENTS, SCHEMA_ENCODING, TOPICS, MetadataError,
                     TestInfo)


def topic_jsonschema(topic: str) -> dict:
    """The jsonschema this package writes for a contract topic."""
    spec = TOPICS[topic]
    num = {"type": "number"}
    props: dict[str, Any] = {}
    for name, kind in spec.fields.items():
        if kind == NUMBER:
            props[name] = dict(num)
        elif kind == NULLABLE_NUMBER:
            props[name] = {"type": ["number", "null"]}
        elif kind == BOOLEAN:
            props[name] = {"type": "boolean"}
        elif kind == EVENT:
            props[name] = {"type": "string", "enum": list(PROBE_EVENTS)}
        elif kind == POINTS:
            props[name] = {"type": "array", "items": {
                "type": "object", "properties": {"x_m": num, "z_m": num},
                "required": list(POINT_FIELDS)}}
    return {"type": "object", "title": spec.schema_name, "description": spec.description,
            "properties": props, "required": list(spec.fields)}


def _topic_messages(topic: str, df: pd.DataFrame) -> list[tuple[float, dict]]:
    spec = TOPICS[topic].fields
    out: list[tuple[float, dict]] = []
    if topic == "/video/hose":
        for t, g in df.groupby("t_s", sort=True):
            g = g.sort_values("point")
            pts = [{"x_m": float(x), "z_m": float(z)} for x, z in zip(g["x_m"], g["z_m"])]
            out.append((float(t), {"points": pts}))
        return out
    t_s = df.index.to_numpy(float)
    columns = {name: df[name].to_numpy() for name in spec}
    for i, t in enumerate(t_s):
        msg: dict[str, Any] = {}
        valid = bool(columns["valid"][i]) if "valid" in spec else True
        for name, kind in spec.items():
            v = columns[name][i]
            if kind == BOOLEAN:
                msg[name] = bool(v)
            elif kind == EVENT:
                msg[name] = str(v)
            elif kind == NULLABLE_NUMBER:
                msg[name] = float(v) if valid and np.isfinite(v) else None
            else:
                msg[name] = float(v)
        out.append((float(t), msg))
    return out


def _time(ns: int) -> dict:
    return {"sec": int(ns // 1_000_000_000), "nsec": int(ns % 1_000_000_000)}


def _fox_schemas() -> dict[str, dict]:
    num = {"type": "number"}
    vec3 = {"type": "object", "title": "foxglove.Vector3",
            "properties": {"x": num, "y": num, "z": num}}
    point3 = {"type": "object", "title": "foxglove.Point3",
              "properties": {"x": num, "y": num, "z": num}}
    quat = {"type": "object", "title": "foxglove.Quaternion",
            "properties": {"x": num, "y": num, "z": num, "w": num}}
    color = {"type": "object", "title": "foxglove.Color",
             "properties": {"r": num, "g": num, "b": num, "a": num}}
    time = {"type": "object", "title": "time", "properties": {
        "sec": {"type": "integer", "minimum": 0},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}
    duration = {"type": "object", "title": "duration", "properties": {
        "sec": {"type": "integer"},
        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}
    pose = {"type": "object", "title": "foxglove.Pose",
            "properties": {"position": vec3, "orientation": quat}}
    line = {"type": "object", "title": "foxglove.LinePrimitive", "properties": {
        "type": {"title": "foxglove.LineType", "oneOf": [
            {"title": "LINE_STRIP", "const": 0}, {"title": "LINE_LOOP", "const": 1},
            {"title": "LINE_LIST", "const": 2}]},
        "pose": pose, "thickness": num, "scale_invariant": {"type": "boolean"},
        "points": {"type": "array", "items": point3}, "color": color,
        "colors": {"type": "array", "items": color},
        "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}}}}
    sphere = {"type": "object", "title": "foxglove.SpherePrimitive",
              "properties": {"pose": pose, "size": vec3, "color": color}}
    entity = {"type": "object", "title": "foxglove.SceneEntity", "properties": {
        "timestamp": time, "frame_id": {"type": "string"}, "id": {"type": "string"},
        "lifetime": duration, "frame_locked": {"type": "boolean"},
        "metadata": {"type": "array", "items": {"type": "object", "title": "foxglove.KeyValuePair",
                                                "properties": {"key": {"type": "string"},
                                                               "value": {"type": "string"}}}},
        "lines": {"type": "array", "items": line},
        "spheres": {"type": "array", "items": sphere}}}
    deletion = {"type": "object", "title": "foxglove.SceneEntityDeletion", "properties": {
        "timestamp": time,
        "type": {"title": "foxglove.SceneEntityDeletionType", "oneOf": [
            {"title": "MATCHING_ID", "const": 0}, {"title": "ALL", "const": 1}]},
        "id": {"type": "string"}}}
    scene = {"title": "foxglove.SceneUpdate",
             "description": "An update to the entities displayed in a 3D scene",
             "type": "object", "properties": {
                 "deletions": {"type": "array", "items": deletion},
                 "entities": {"type": "array", "items": entity}}}
    tf = {"title": "foxglove.FrameTransform",
          "description": "A transform between two reference frames in 3D space",
          "type": "object", "properties": {
              "timestamp": time, "parent_frame_id": {"type": "string"},
              "child_frame_id": {"type": "string"}, "translation": vec3, "rotation": quat}}
    return {"foxglove.SceneUpdate": scene, "foxglove.FrameTransform": tf}


FOXGLOVE_HOSE_TOPIC = "/foxglove/hose"
FOXGLOVE_DROGUE_TOPIC = "/foxglove/drogue"
FOXGLOVE_TF_TOPIC = "/foxglove/tf"
_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def _foxglove_messages(record: FlightRecord) -> list[tuple[str, str, int, dict]]:
    """(topic, schema name, log_time, message) for the 3D-panel view.

    Frame "tanker" is the trim tow point; "tow_point" follows the measured
    tow-point displacement; hose and drogue are drawn in "tow_point", which
    is the frame the contract gives them in.
    """
    out: list[tuple[str, str, int, dict]] = []
    start = record.start_time_ns
    tp = record.topics.get("/tanker/tow_point")
    if tp is not None:
        for t, x, y, z in zip(tp.index, tp["x_m"], tp["y_m"], tp["z_m"]):
            ns = start + int(round(t * 1e9))
            out.append((FOXGLOVE_TF_TOPIC, "foxglove.FrameTransform", ns, {
                "timestamp": _time(ns), "parent_frame_id": "tanker", "child_frame_id": "tow_point",
                "translation": {"x": float(x), "y": float(y), "z": float(z)},
                "rotation": dict(_IDENTITY)}))
    hose = record.topics.get("/video/hose")
    if hose is not None:
        for t, g in hose.groupby("t_s", sort=True):
            ns = start + int(round(t * 1e9))
            g = g.sort_values("point")
            out.append((FOXGLOVE_HOSE_TOPIC, "foxglove.SceneUpdate", ns, {"deletions": [], "entities": [{
                "timestamp": _time(ns), "frame_id": "tow_point", "id": "hose",
                "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": True, "metadata": [],
                "lines": [{"type": 0, "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                                               "orientation": dict(_IDENTITY)},
                           "thickness": 0.07, "scale_invariant": False,
                           "points": [{"x": float(x), "y": 0.0, "z": float(z)}
                                      for x, z in zip(g["x_m"], g["z_m"])],
                           "color": {"r": 0.1, "g": 0.1, "b": 0.1, "a": 1.0},
                           "colors": [], "indices": []}],
                "spheres": []}]}))
    if len(record.topics.get("/ors/drogue", ())):  # an empty topic draws no drogue
        fixes = record.tracker_fixes()
        for t, x, y, z in zip(fixes.index, fixes["x_m"], fixes["y_m"], fixes["z_m"]):
            ns = start + int(round(t * 1e9))
            out.append((FOXGLOVE_DROGUE_TOPIC, "foxglove.SceneUpdate", ns, {"deletions": [], "entities": [{
                "timestamp": _time(ns), "frame_id": "tow_point", "id": "drogue",
                "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": True, "metadata": [],
                "lines": [],
                "spheres": [{"pose": {"position": {"x": float(x), "y": float(y), "z": float(z)},
                                      "orientation": dict(_IDENTITY)},
                             "size": {"x": 0.6, "y": 0.6, "z": 0.6},
                             "color": {"r": 0.9, "g": 0.4, "b": 0.1, "a": 0.8}}]}]}))
    return out


def write_record(path: str | os.PathLike, record: FlightRecord, *, compression: str = "zstd",
                 chunk_size: int = 1 << 20, foxglove: bool = False,
                 library: str = "workbench flighttest") -> Path:
    """Write `record` in the contract; return the path.

    compression: "zstd", "lz4" or "none".  foxglove: also write
    /foxglove/hose and /foxglove/drogue (foxglove.SceneUpdate: a line strip
    of the hose points, a sphere at the drogue) and /foxglove/tf
    (foxglove.FrameTransform, tanker -> tow_point), JSON-encoded with their
    jsonschema, for Foxglove's 3D panel.  Readers of the contract ignore them.
    The record is checked as it is written: what cannot be read back
    (non-finite values, unknown topics or fields, times that do not
    increase, values outside their physical range, implausible tracker
    fixes) raises LogError and leaves no file behind.
    """
    from mcap.writer import CompressionType, Writer

    path = Path(path)
    comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
            "none": CompressionType.NONE}.get(compression)
    if comp is None:
        raise LogError(path, "writer", f"unknown compression {compression!r} (zstd, lz4, none)")
    info = record.info
    try:
        TestInfo.from_metadata(dict(info.raw))
    except MetadataError as exc:
        raise LogError(path, f"metadata key {exc.key!r}", exc.problem) from None

    rows: list[tuple[int, str, bytes]] = []
    for topic, df in record.topics.items():
        if topic not in TOPICS:
            raise LogError(path, f"topic {topic}", "not a topic of the contract")
        missing = [c for c in (("t_s", "point", "x_m", "z_m") if topic == "/video/hose"
                               else TOPICS[topic].fields) if c not in df.columns]
        if missing:
            raise LogError(path, f"topic {topic}", f"DataFrame lacks column {missing[0]!r}")
        msgs = _topic_messages(topic, df)
        encoded: list[tuple[int, int, bytes]] = []
        for t, msg in msgs:
            if not math.isfinite(t):
                raise LogError(path, f"topic {topic}", f"time {t!r} is not finite")
            ns = record.start_time_ns + int(round(t * 1e9))
            try:
                data = json.dumps(msg, separators=(",", ":"), allow_nan=False).encode()
            except ValueError:
                raise LogError(path, f"topic {topic}", f"message at t_s={t:.6f} holds a "
                                                       f"non-finite value") from None
            encoded.append((ns, ns, data))
        try:
            parse_topic(topic, encoded)  # the reader's own checks, before anything is written
        except TopicError as exc:
            raise LogError(path, exc.where, exc.problem) from None
        rows.extend((ns, topic, data) for ns, _, data in encoded)

    check_plausibility(record, path)  # the reader's refusals too; its warnings are not an error
    fox: list[tuple[str, str, int, dict]] = _foxglove_messages(record) if foxglove else []
    rows.sort(key=lambda r: r[0])
    tmp = path.with_name(path.name + ".part")
    try:
        with open(tmp, "wb") as fh:
            w = Writer(fh, chunk_size=chunk_size, compression=comp)
            w.start(profile="", library=library)
            channel_ids: dict[str, int] = {}
            for topic in sorted(record.topics):
                sid = w.register_schema(name=TOPICS[topic].schema_name,
                                        encoding=SCHEMA_ENCODING,
                                        data=json.dumps(topic_jsonschema(topic)).encode())
                channel_ids[topic] = w.register_channel(topic=topic,
                                                        message_encoding=MESSAGE_ENCODING,
                                                        schema_id=sid)
            if fox:
                fox_schemas = _fox_schemas()
                sids = {name: w.register_schema(name=name, encoding=SCHEMA_ENCODING,
                                                data=json.dumps(doc).encode())
                        for name, doc in fox_schemas.items()}
                for topic in sorted({f[0] for f in fox}):
                    schema_name = next(f[1] for f in fox if f[0] == topic)
                    channel_ids[topic] = w.register_channel(topic=topic,
                                                            message_encoding=MESSAGE_ENCODING,
                                                            schema_id=sids[schema_name])
                rows.extend((ns, topic, json.dumps(msg, separators=(",", ":")).encode())
                            for topic, _, ns, msg in fox)
                rows.sort(key=lambda r: r[0])
            w.add_metadata(METADATA_NAME, dict(info.raw))
            seq: dict[str, int] = {}
            for ns, topic, data in rows:
                k = seq.get(topic, 0)
                seq[topic] = k + 1
                w.add_message(channel_id=channel_ids[topic], log_time=ns, publish_time=ns,
                              data=data, sequence=k)
            w.finish()
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
