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
from dataclasses import dataclass, field
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
    arrow = {"type": "object", "title": "foxglove.ArrowPrimitive",
             "properties": {"pose": pose, "shaft_length": num, "shaft_diameter": num, "head_length": num,
                            "head_diameter": num, "color": color}}
    entity = {"type": "object", "title": "foxglove.SceneEntity", "properties": {
        "timestamp": time, "frame_id": {"type": "string"}, "id": {"type": "string"},
        "lifetime": duration, "frame_locked": {"type": "boolean"},
        "metadata": {"type": "array", "items": {"type": "object", "title": "foxglove.KeyValuePair",
                                                "properties": {"key": {"type": "string"},
                                                               "value": {"type": "string"}}}},
        "lines": {"type": "array", "items": line},
        "spheres": {"type": "array", "items": sphere},
        "arrows": {"type": "array", "items": arrow}}}
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
FOXGLOVE_TOW_POINT_TOPIC = "/foxglove/tow_point"
ROOT_FRAME = "tanker"     # the tow-point frame of SCHEMA.md: origin at the trim tow point
ARROW_M_PER_N = 1e-3      # force arrows: 1 m per kN (hose tensions are a few kN)
_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
_ORIGIN = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": _IDENTITY}


@dataclass(frozen=True)
class Scene:
    """What Foxglove's 3D panel draws of one record, in the tow-point frame of
    SCHEMA.md (origin at the trim tow point, x aft, y starboard, z up), SI.

    hose_t (nf,) s and hose, nf arrays (n_i, 3) of centre-line points, tow
    point first; drogue_t (nd,) and drogue (nd, 3); arrows: name ->
    (t (na,), anchor (na, 3), force (na, 3) in N), drawn ARROW_M_PER_N long
    per newton on /foxglove/<name>; note: what the scene shows (entity
    metadata, e.g. that a side-view video has no y); hose_color: r, g, b, a.
    """

    hose_t: np.ndarray
    hose: list
    drogue_t: np.ndarray
    drogue: np.ndarray
    arrows: dict = field(default_factory=dict)
    note: str = ""
    hose_color: tuple = (0.1, 0.1, 0.1, 1.0)


def record_scene(record: FlightRecord) -> Scene:
    """The scene a record holds: its video hose and its tracker's drogue.

    The video is a side view: its points have x and z only, so this hose lies
    in the y = 0 plane (a projection, said in the note). A simulated run has
    the hose in 3-D: give write_record its own Scene (workbench.simlog)."""
    hose_t, hose = np.empty(0), []
    video = record.topics.get("/video/hose")
    if video is not None:
        frames = list(video.groupby("t_s", sort=True))
        hose_t = np.array([t for t, _ in frames], float)
        for _, g in frames:
            g = g.sort_values("point")
            x, z = g["x_m"].to_numpy(float), g["z_m"].to_numpy(float)
            hose.append(np.column_stack([x, np.zeros_like(x), z]))
    drogue_t, drogue = np.empty(0), np.empty((0, 3))
    if len(record.topics.get("/ors/drogue", ())):  # an empty topic draws no drogue
        fixes = record.tracker_fixes()
        drogue_t, drogue = fixes.index.to_numpy(float), fixes[["x_m", "y_m", "z_m"]].to_numpy(float)
    return Scene(hose_t, hose, drogue_t, drogue, note="hose: side-view video, x-z projection (y not measured)")


def _point(p) -> dict:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _rgba(c) -> dict:
    return dict(zip("rgba", map(float, c)))


def _x_to(d: np.ndarray) -> dict:
    """The quaternion turning +x (an arrow's axis) onto the unit vector d."""
    w = 1.0 + float(d[0])
    if w < 1e-9:                                   # d = -x: half a turn about z
        return {"x": 0.0, "y": 0.0, "z": 1.0, "w": 0.0}
    q = np.array([0.0, -d[2], d[1], w])            # (x cross d, 1 + x . d), normalised
    q /= np.linalg.norm(q)
    return {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}


def _entity(ns: int, frame: str, ident: str, note: str, **primitives) -> dict:
    return {"timestamp": _time(ns), "frame_id": frame, "id": ident, "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": True, "metadata": [{"key": "note", "value": note}] if note else [],
            # every primitive list of foxglove.SceneEntity, empty where unused, for strict readers
            **{kind: primitives.get(kind, []) for kind in ("arrows", "cubes", "spheres", "cylinders", "lines",
                                                           "triangles", "texts", "models")}}


def _sphere(p, size: float, color) -> dict:
    return {"pose": {"position": _point(p), "orientation": dict(_IDENTITY)},
            "size": {"x": size, "y": size, "z": size}, "color": _rgba(color)}


def _foxglove_messages(record: FlightRecord, scene: Scene, prefix: str = "") -> list[tuple[str, str, int, dict]]:
    """(topic, schema name, log_time, message) for the 3D-panel view, topics
    under `prefix` (e.g. "/sim"), frames under its name (e.g. "sim/tow_point").

    Frame "tanker" is the trim tow point, the frame of every position in the
    contract: hose, drogue and arrows are drawn in it. "tow_point" follows
    the tow point's displacement (/tanker/tow_point) and carries a marker.
    """
    out: list[tuple[str, str, int, dict]] = []
    start = record.start_time_ns
    tow_frame = f"{prefix.strip('/')}/tow_point" if prefix else "tow_point"

    def ns_of(t: float) -> int:
        return start + int(round(t * 1e9))

    def scene_update(topic: str, t: float, entity: dict) -> None:
        out.append((prefix + topic, "foxglove.SceneUpdate", ns_of(t), {"deletions": [], "entities": [entity]}))

    tp = record.topics.get("/tanker/tow_point")
    if tp is not None and len(tp):
        for t, x, y, z in zip(tp.index, tp["x_m"], tp["y_m"], tp["z_m"]):
            ns = ns_of(t)
            out.append((prefix + FOXGLOVE_TF_TOPIC, "foxglove.FrameTransform", ns, {
                "timestamp": _time(ns), "parent_frame_id": ROOT_FRAME, "child_frame_id": tow_frame,
                "translation": {"x": float(x), "y": float(y), "z": float(z)},
                "rotation": dict(_IDENTITY)}))
        # frame-locked: one message keeps the marker on the moving frame
        t0 = float(tp.index[0])
        scene_update(FOXGLOVE_TOW_POINT_TOPIC, t0, _entity(ns_of(t0), tow_frame, "tow_point", "",
                                                           spheres=[_sphere((0, 0, 0), 0.3, (0.2, 0.5, 0.9, 1))]))
    for t, pts in zip(scene.hose_t, scene.hose):
        line = {"type": 0, "pose": dict(_ORIGIN), "thickness": 0.07, "scale_invariant": False,
                "points": [_point(p) for p in pts], "color": _rgba(scene.hose_color), "colors": [],
                "indices": []}
        scene_update(FOXGLOVE_HOSE_TOPIC, t, _entity(ns_of(t), ROOT_FRAME, "hose", scene.note, lines=[line]))
    for t, p in zip(scene.drogue_t, scene.drogue):
        scene_update(FOXGLOVE_DROGUE_TOPIC, t, _entity(ns_of(t), ROOT_FRAME, "drogue", "",
                                                       spheres=[_sphere(p, 0.6, (0.9, 0.4, 0.1, 0.8))]))
    for name, (ts, anchors, forces) in scene.arrows.items():
        for t, a, f in zip(ts, anchors, forces):
            size = float(np.linalg.norm(f))
            arrows = [] if size == 0.0 else [{  # no force (the probe before contact): nothing drawn
                "pose": {"position": _point(a), "orientation": _x_to(np.asarray(f) / size)},
                "shaft_length": size * ARROW_M_PER_N, "shaft_diameter": 0.08, "head_length": 0.4,
                "head_diameter": 0.25, "color": _rgba((0.8, 0.1, 0.1, 1.0))}]
            scene_update(f"/foxglove/{name}", t, _entity(ns_of(t), ROOT_FRAME, name,
                                                         f"{size:.0f} N; {ARROW_M_PER_N * 1e3:g} m per kN",
                                                         arrows=arrows))
    return out


def _contract_rows(path: Path, record: FlightRecord) -> list[tuple[int, str, bytes]]:
    """(log_time, topic, JSON) of every contract message of `record`, checked
    as the reader checks them: what cannot be read back raises LogError."""
    try:
        TestInfo.from_metadata(dict(record.info.raw))
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
    return rows


def _write(path: Path, parts: list[tuple[str, FlightRecord, Scene | None]], compression: str,
           chunk_size: int, library: str) -> Path:
    """Write each (prefix, record, scene) part, its contract topics and (scene
    not None) its Foxglove topics under `prefix`, into one file, atomically."""
    from mcap.writer import CompressionType, Writer

    comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
            "none": CompressionType.NONE}.get(compression)
    if comp is None:
        raise LogError(path, "writer", f"unknown compression {compression!r} (zstd, lz4, none)")
    rows: list[tuple[int, str, bytes]] = []
    schemas: dict[str, tuple[str, dict]] = {}        # topic -> (schema name, jsonschema)
    fox_docs = _fox_schemas()
    for prefix, record, scene in parts:
        rows += [(ns, prefix + topic, data) for ns, topic, data in _contract_rows(path, record)]
        schemas.update({prefix + topic: (TOPICS[topic].schema_name, topic_jsonschema(topic))
                        for topic in record.topics})
        for topic, name, ns, msg in (_foxglove_messages(record, scene, prefix) if scene is not None else []):
            schemas[topic] = (name, fox_docs[name])
            rows.append((ns, topic, json.dumps(msg, separators=(",", ":")).encode()))
    rows.sort(key=lambda r: r[0])
    tmp = path.with_name(path.name + ".part")
    try:
        with open(tmp, "wb") as fh:
            w = Writer(fh, chunk_size=chunk_size, compression=comp)
            w.start(profile="", library=library)
            schema_ids: dict[str, int] = {}
            channel_ids: dict[str, int] = {}
            for topic in sorted(schemas):
                name, doc = schemas[topic]
                if name not in schema_ids:
                    schema_ids[name] = w.register_schema(name=name, encoding=SCHEMA_ENCODING,
                                                         data=json.dumps(doc).encode())
                channel_ids[topic] = w.register_channel(topic=topic, message_encoding=MESSAGE_ENCODING,
                                                        schema_id=schema_ids[name])
            for prefix, record, _ in parts:
                w.add_metadata(METADATA_NAME + prefix, dict(record.info.raw))
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


def write_record(path: str | os.PathLike, record: FlightRecord, *, compression: str = "zstd",
                 chunk_size: int = 1 << 20, foxglove: bool = False, scene: Scene | None = None,
                 library: str = "workbench flighttest") -> Path:
    """Write `record` in the contract; return the path.

    compression: "zstd", "lz4" or "none".  foxglove: also write Foxglove's
    3D-panel topics (JSON-encoded with their jsonschema; readers of the
    contract ignore them): /foxglove/hose (foxglove.SceneUpdate, a line
    strip), /foxglove/drogue (a sphere), /foxglove/tow_point (a marker on
    the tow_point frame), /foxglove/<arrow> (force arrows) and /foxglove/tf
    (foxglove.FrameTransform, tanker -> tow_point).  scene: what those
    topics draw (default `record_scene(record)`, whose video hose is a
    side-view projection; a simulation gives its 3-D hose); giving one
    implies foxglove.
    The record is checked as it is written: what cannot be read back
    (non-finite values, unknown topics or fields, times that do not
    increase, values outside their physical range, implausible tracker
    fixes) raises LogError and leaves no file behind.
    """
    if scene is None and foxglove:
        scene = record_scene(record)
    return _write(Path(path), [("", record, scene)], compression, chunk_size, library)


def write_overlay(path: str | os.PathLike, parts: dict[str, tuple[FlightRecord, Scene | None]], *,
                  compression: str = "zstd", library: str = "workbench flighttest") -> Path:
    """Several records on one time base in one file, for scrubbing together in
    Foxglove: parts maps a topic prefix ("/log", "/sim") to (record, scene);
    every topic and frame is written under its prefix, each test card as
    metadata "test/<prefix>" (so the file is not itself a contract record).
    The records' times must share one start (`workbench.simlog` gives a
    simulated record its log's start)."""
    starts = {rec.start_time_ns for rec, _ in parts.values()}
    if len(starts) > 1:
        raise LogError(path, "writer", "the records of an overlay must share one start time")
    return _write(Path(path), [(prefix, rec, scene if scene is not None else record_scene(rec))
                               for prefix, (rec, scene) in parts.items()], compression, 1 << 20, library)
