"""Generate a corpus of contract-breaking MCAP files, each with the error it must raise.

Small good records are generated here (no logs needed, no network); each
case then breaks one thing, either by writing the record differently
(metadata, schemas, message bytes, times) or by damaging the bytes of a good
file (magic, truncation, CRCs).  `CASES` maps a case name to (builder,
regex); the regex names the topic or key the one-line LogError must name.

Run as a script to write the corpus into a folder:
    python3 tests/flighttest/make_corrupt.py OUTDIR
"""
from __future__ import annotations

import io
import json
import math
import struct
import sys
from pathlib import Path
from typing import Callable

from mcap.writer import CompressionType, Writer

T0 = 1_600_000_000_000_000_000  # ns, an arbitrary epoch start

BENDING_META = {
    "schema_version": "1", "test_id": "FX-B-1", "test_kind": "ringdown_bending",
    "hose": "fa18_buddy", "temperature_F": "40", "section_length_m": "1.22",
    "repetition": "1",
}
TRAIL_META = {
    "schema_version": "1", "test_id": "FX-TR-1", "test_kind": "trail", "hose": "kdc10_pod",
    "altitude_ft": "15000", "airspeed_kcas": "255", "oat_F": "2.0", "hose_length_ft": "75",
    "hose_fuel": "full",
}
ENGAGE_META = dict(TRAIL_META, test_id="FX-EN-1", test_kind="engagement", closure_rate_kts="4.0")

SCHEMAS = {
    "/rig/accel/tip": ("rig.TipAcceleration", {"a_mps2": {"type": "number"}}),
    "/rig/temperature": ("rig.Temperature", {"t1_F": {"type": "number"}, "t2_F": {"type": "number"}}),
    "/air_data": ("flight.AirData", {k: {"type": "number"} for k in ("altitude_ft", "kcas", "ktas", "oat_C")}),
    "/tanker/tow_point": ("flight.TowPoint", {k: {"type": "number"} for k in ("x_m", "y_m", "z_m")}),
    "/ors/drogue": ("flight.OrsDrogue", {"x_m": {"type": ["number", "null"]}, "y_m": {"type": ["number", "null"]},
                                         "z_m": {"type": ["number", "null"]}, "valid": {"type": "boolean"}}),
    "/video/hose": ("flight.VideoHose", {"points": {"type": "array"}}),
    "/reel/hose_out": ("flight.ReelHoseOut", {"length_m": {"type": "number"}}),
    "/probe/events": ("flight.ProbeEvent", {"event": {"type": "string"}}),
    "/receiver/probe": ("flight.ReceiverProbe", {k: {"type": "number"} for k in ("x_m", "y_m", "z_m")}),
    "/foxglove/unknown": ("custom.Thing", {"anything": {"type": "number"}}),
}


def _schema_bytes(topic: str) -> bytes:
    name, props = SCHEMAS[topic]
    return json.dumps({"type": "object", "title": name, "properties": props}).encode()


def _js(obj) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode()


def bending_messages(n: int = 400) -> list[tuple[str, int, int, bytes]]:
    """A short tip ring-down at 1 kHz plus two thermocouple readings."""
    msgs = []
    for i in range(n):
        t = T0 + i * 1_000_000
        a = 3.0 * math.exp(-0.8 * i / 1000) * math.cos(2 * math.pi * 2.0 * i / 1000) if i > 20 else 0.0
        msgs.append(("/rig/accel/tip", t, t, _js({"a_mps2": round(a, 6)})))
    for k in range(2):
        t = T0 + 100_000_000 + k * 200_000_000
        msgs.append(("/rig/temperature", t, t, _js({"t1_F": 40.1 + k, "t2_F": 39.8})))
    return sorted(msgs, key=lambda m: m[1])


def flight_messages(engagement: bool = False) -> list[tuple[str, int, int, bytes]]:
    """A few seconds of steady trail (or an engagement) at reduced rates."""
    msgs = []
    for i in range(20):
        t = T0 + i * 100_000_000
        msgs.append(("/air_data", t, t, _js({"altitude_ft": 15000.0, "kcas": 255.0, "ktas": 316.0,
                                             "oat_C": -16.7})))
        msgs.append(("/tanker/tow_point", t + 1000, t + 1000, _js({"x_m": 0.001, "y_m": 0.0,
                                                                   "z_m": -0.002})))
        valid = i % 7 != 3
        pos = {"x_m": 22.6, "y_m": 1.3, "z_m": -2.8} if valid else {"x_m": None, "y_m": None, "z_m": None}
        msgs.append(("/ors/drogue", t + 2000, t + 2000, _js(dict(pos, valid=valid))))
        pts = [{"x_m": round(1.5 * k, 3), "z_m": round(-0.12 * k, 3)} for k in range(12 + i % 3)]
        msgs.append(("/video/hose", t + 3000, t + 3000, _js({"points": pts})))
        if engagement:
            msgs.append(("/reel/hose_out", t + 4000, t + 4000, _js({"length_m": 22.8 - 0.05 * i})))
            msgs.append(("/receiver/probe", t + 5000, t + 5000, _js({"x_m": 23.0 - 0.1 * i, "y_m": 1.3,
                                                                     "z_m": -2.8})))
    if engagement:
        msgs.append(("/probe/events", T0 + 500_000_000, T0 + 500_000_000, _js({"event": "contact"})))
        msgs.append(("/probe/events", T0 + 1_500_000_000, T0 + 1_500_000_000, _js({"event": "disconnect"})))
    return sorted(msgs, key=lambda m: m[1])


def build(metas: list[tuple[str, dict]] | None = None,
          messages: list[tuple[str, int, int, bytes]] | None = None, *,
          kind: str = "bending", compression: str = "none",
          channel_override: dict[str, dict] | None = None,
          extra_channels: list[str] = (), duplicate_channel: str | None = None,
          data_crc: bool = False, chunked: bool = True) -> bytes:
    """Write an MCAP byte string; every argument can break one part of the contract.

    channel_override[topic] may set schema_encoding, message_encoding,
    schema_data or no_schema=True.
    """
    if metas is None:
        meta = {"bending": BENDING_META, "trail": TRAIL_META, "engagement": ENGAGE_META}[kind]
        metas = [("test", dict(meta))]
    if messages is None:
        messages = bending_messages() if kind == "bending" else flight_messages(kind == "engagement")
    comp = {"none": CompressionType.NONE, "zstd": CompressionType.ZSTD,
            "lz4": CompressionType.LZ4}[compression]
    buf = io.BytesIO()
    w = Writer(buf, compression=comp, chunk_size=1 << 16, enable_data_crcs=data_crc,
               use_chunking=chunked)
    w.start(library="make_corrupt")
    channel_override = channel_override or {}
    topics = sorted({m[0] for m in messages} | set(extra_channels))
    ids: dict[str, int] = {}
    for topic in topics:
        ov = channel_override.get(topic, {})
        sid = 0
        if not ov.get("no_schema"):
            sid = w.register_schema(SCHEMAS.get(topic, ("x", {}))[0], ov.get("schema_encoding", "jsonschema"),
                                    ov.get("schema_data", _schema_bytes(topic) if topic in SCHEMAS else b"{}"))
        ids[topic] = w.register_channel(topic, ov.get("message_encoding", "json"), sid)
        if topic == duplicate_channel:
            w.register_channel(topic, "json", sid)
    for name, data in metas:
        w.add_metadata(name, data)
    seq: dict[str, int] = {}
    for topic, log_time, publish_time, data in messages:
        seq[topic] = seq.get(topic, 0) + 1
        w.add_message(ids[topic], log_time=log_time, data=data, publish_time=publish_time,
                      sequence=seq[topic])
    w.finish()
    return buf.getvalue()


def records(buf: bytes) -> list[tuple[int, int, int]]:
    """(opcode, offset, body length) of each top-level record."""
    out, pos = [], 8
    while pos + 9 <= len(buf):
        op, length = struct.unpack_from("<BQ", buf, pos)
        out.append((op, pos, length))
        pos += 9 + length
    return out


def _first(buf: bytes, opcode: int) -> tuple[int, int]:
    for op, off, length in records(buf):
        if op == opcode:
            return off, length
    raise LookupError(opcode)


def _with_message(topic: str, data: bytes, kind: str = "bending", at: int = 5,
                  log_dt: int = 0, publish_dt: int = 0) -> bytes:
    msgs = bending_messages() if kind == "bending" else flight_messages(kind == "engagement")
    idx = [i for i, m in enumerate(msgs) if m[0] == topic][at]
    _, lt, pt, _ = msgs[idx]
    msgs[idx] = (topic, lt + log_dt, pt + log_dt + publish_dt, data)
    return build(messages=msgs, kind=kind)


def _meta(kind: str = "bending", drop: str | None = None, **changes) -> bytes:
    meta = dict({"bending": BENDING_META, "trail": TRAIL_META, "engagement": ENGAGE_META}[kind])
    if drop:
        meta.pop(drop)
    meta.update(changes)
    return build(metas=[("test", meta)], kind=kind)


def _flip(buf: bytes, offset: int) -> bytes:
    b = bytearray(buf)
    b[offset] ^= 0xFF
    return bytes(b)


def _chunk_payload_flip() -> bytes:
    good = build()
    off, length = _first(good, 0x06)
    return _flip(good, off + 9 + length - 20)   # inside the last message of the chunk


def _zstd_payload_flip() -> bytes:
    good = build(compression="zstd")
    off, length = _first(good, 0x06)
    return _flip(good, off + 9 + length // 2)


def _summary_flip() -> bytes:
    good = build()
    off, _ = _first(good, 0x0B)                  # Statistics lives in the summary
    return _flip(good, off + 9 + 2)


def _data_section_flip() -> bytes:
    good = build(data_crc=True)
    off, _ = _first(good, 0x07)                  # a MessageIndex: outside any chunk CRC
    return _flip(good, off + 9 + 2)


def _compression_name() -> bytes:
    good = build(compression="zstd")
    i = good.index(b"zstd")
    return good[:i] + b"zstx" + good[i + 4:]


def _truncate_mid_chunk() -> bytes:
    good = build()
    off, length = _first(good, 0x06)
    return good[:off + 9 + length // 2]


def _truncate_header() -> bytes:
    good = build()
    off, _ = _first(good, 0x06)
    return good[:off + 4]


def _trailing_garbage() -> bytes:
    return build()[:-8] + b"NOTMAGIC"


def _seq(kind="bending"):
    return bending_messages() if kind == "bending" else flight_messages(kind == "engagement")


def _nonincreasing() -> bytes:
    msgs = _seq()
    tips = [i for i, m in enumerate(msgs) if m[0] == "/rig/accel/tip"]
    a, b = tips[10], tips[11]
    msgs[b] = (msgs[b][0], msgs[a][1], msgs[a][2], msgs[b][3])   # same time twice
    return build(messages=msgs)


def _backwards() -> bytes:
    msgs = _seq()
    tips = [i for i, m in enumerate(msgs) if m[0] == "/rig/accel/tip"]
    a, b = tips[30], tips[31]
    msgs[a], msgs[b] = (msgs[a][0], msgs[b][1], msgs[b][2], msgs[a][3]), \
        (msgs[b][0], msgs[a][1], msgs[a][2], msgs[b][3])
    return build(messages=msgs)


def _drop_topic(topic: str, kind: str) -> bytes:
    return build(messages=[m for m in _seq(kind) if m[0] != topic], kind=kind)


def _empty_topic(topic: str, kind: str) -> bytes:
    return build(messages=[m for m in _seq(kind) if m[0] != topic], kind=kind, extra_channels=[topic])


def _metadata_repeats_key() -> bytes:
    """A recording without its summary whose `test` map names `hose` twice."""
    good = build()
    buf = good[:_first(good, 0x0F)[0]]
    off, length = _first(buf, 0x0C)
    pairs = list(BENDING_META.items()) + [("hose", "kc135_boom")]
    kv = b"".join(struct.pack("<I", len(k)) + k.encode() + struct.pack("<I", len(v)) + v.encode()
                  for k, v in pairs)
    body = struct.pack("<I", 4) + b"test" + struct.pack("<I", len(kv)) + kv
    return buf[:off] + struct.pack("<BQ", 0x0C, len(body)) + body + buf[off + 9 + length:]


def _schema_fields() -> bytes:
    data = json.dumps({"type": "object", "properties": {"a_g": {"type": "number"}}}).encode()
    return build(channel_override={"/rig/accel/tip": {"schema_data": data}})


CASES: dict[str, tuple[Callable[[], bytes], str]] = {
    # container
    "bad_magic": (lambda: b"\x89MCAX0\r\n" + build()[8:], r"container: not an MCAP file"),
    "empty_file": (lambda: b"", r"container: not an MCAP file"),
    "magic_only": (lambda: build()[:8], r"container: file holds only the magic"),
    "text_file": (lambda: b"time,a\n0,1\n", r"container: not an MCAP file"),
    "truncated_mid_chunk": (_truncate_mid_chunk, r"container: Chunk record at byte \d+ claims"),
    "truncated_record_header": (_truncate_header, r"container: file truncated in a record header"),
    "chunk_crc": (_chunk_payload_flip, r"container: CRC mismatch in Chunk"),
    "zstd_damage": (_zstd_payload_flip, r"container: (zstd data does not decompress|CRC mismatch)"),
    "summary_crc": (_summary_flip, r"container: summary-section CRC mismatch"),
    "data_section_crc": (_data_section_flip, r"container: data-section CRC mismatch"),
    "unknown_compression": (_compression_name, r"container: unsupported chunk compression 'zstx'"),
    "trailing_garbage": (_trailing_garbage, r"container: bytes after the Footer"),
    # metadata
    "no_test_metadata": (lambda: build(metas=[("other", {"a": "b"})]),
                         r"metadata 'test': record has no 'test' metadata"),
    "metadata_repeats_key": (_metadata_repeats_key, r"container: Metadata record at byte \d+ repeats a key"),
    "two_test_metadata": (lambda: build(metas=[("test", BENDING_META), ("test", BENDING_META)]),
                          r"metadata 'test': record has 2 'test' metadata"),
    "unknown_test_kind": (lambda: _meta(test_kind="ringdown_torsion"),
                          r"metadata key 'test_kind': unknown test kind 'ringdown_torsion'"),
    "missing_hose": (lambda: _meta(drop="hose"), r"metadata key 'hose': required key is missing"),
    "missing_test_id": (lambda: _meta(drop="test_id"), r"metadata key 'test_id': required key is missing"),
    "missing_schema_version": (lambda: _meta(drop="schema_version"),
                               r"metadata key 'schema_version': required key is missing"),
    "future_schema_version": (lambda: _meta(schema_version="2"),
                              r"metadata key 'schema_version': unsupported version '2'"),
    "unknown_metadata_key": (lambda: _meta(pilot="Maverick"), r"metadata key 'pilot': unknown key"),
    "altitude_not_number": (lambda: _meta("trail", altitude_ft="FL150"),
                            r"metadata key 'altitude_ft': 'FL150' is not a number"),
    "temperature_nan": (lambda: _meta(temperature_F="nan"),
                        r"metadata key 'temperature_F': 'nan' is not finite"),
    "bad_hose_fuel": (lambda: _meta("trail", hose_fuel="half"), r"metadata key 'hose_fuel': 'half'"),
    "repetition_not_int": (lambda: _meta(repetition="first"),
                           r"metadata key 'repetition': 'first' is not an integer"),
    # topics and channels
    "missing_temperature_topic": (lambda: _drop_topic("/rig/temperature", "bending"),
                                  r"topic /rig/temperature: absent, but test_kind 'ringdown_bending'"),
    "missing_video_topic": (lambda: _drop_topic("/video/hose", "trail"),
                            r"topic /video/hose: absent, but test_kind 'trail'"),
    "missing_events_topic": (lambda: _drop_topic("/probe/events", "engagement"),
                             r"topic /probe/events: absent, but test_kind 'engagement'"),
    "empty_tip_topic": (lambda: _empty_topic("/rig/accel/tip", "bending"),
                        r"topic /rig/accel/tip: has no messages"),
    "message_encoding_cbor": (lambda: build(channel_override={"/rig/accel/tip": {"message_encoding": "cbor"}}),
                              r"topic /rig/accel/tip: message encoding is 'cbor'"),
    "schema_encoding_protobuf": (lambda: build(channel_override={"/rig/temperature": {"schema_encoding": "protobuf"}}),
                                 r"topic /rig/temperature: schema encoding is 'protobuf'"),
    "no_schema": (lambda: build(channel_override={"/rig/accel/tip": {"no_schema": True}}),
                  r"topic /rig/accel/tip: channel has no schema"),
    "schema_not_json": (lambda: build(channel_override={"/rig/accel/tip": {"schema_data": b"a_mps2: float"}}),
                        r"topic /rig/accel/tip: schema 'rig.TipAcceleration' is not valid JSON"),
    "schema_fields_differ": (_schema_fields, r"topic /rig/accel/tip: schema .* declares fields \['a_g'\]"),
    "topic_on_two_channels": (lambda: build(duplicate_channel="/rig/temperature"),
                              r"topic /rig/temperature: declared on two channels"),
    # messages
    "message_not_json": (lambda: _with_message("/rig/accel/tip", b"a_mps2=0.1"),
                         r"topic /rig/accel/tip: message 5 .*not valid JSON"),
    "message_not_utf8": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": "\xff\xfe"}'),
                         r"topic /rig/accel/tip: message 5 .*not UTF-8"),
    "message_is_array": (lambda: _with_message("/rig/accel/tip", b"[0.1]"),
                         r"topic /rig/accel/tip: message 5 .*must be a JSON object, got array"),
    "missing_field": (lambda: _with_message("/rig/temperature", b'{"t1_F": 40.0}', at=1),
                      r"topic /rig/temperature: message 1 .*lacks field 't2_F'"),
    "unknown_field": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": 0.1, "b_mps2": 0.2}'),
                      r"topic /rig/accel/tip: message 5 .*unknown field 'b_mps2'"),
    "string_value": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": "0.1"}'),
                     r"topic /rig/accel/tip: message 5 .*field 'a_mps2' must be a number, got string"),
    "bool_value": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": true}'),
                   r"topic /rig/accel/tip: message 5 .*must be a number, got boolean"),
    "null_value": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": null}'),
                   r"topic /rig/accel/tip: message 5 .*must be a number, got null"),
    "nan_literal": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": NaN}'),
                    r"topic /rig/accel/tip: message 5 .*non-finite literal NaN"),
    "infinity_literal": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": -Infinity}'),
                         r"topic /rig/accel/tip: message 5 .*non-finite literal -Infinity"),
    "overflow_number": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": 1e999}'),
                        r"topic /rig/accel/tip: message 5 .*'a_mps2' is not finite"),
    "time_repeats": (_nonincreasing, r"topic /rig/accel/tip: message 11 .*log_time does not increase"),
    "time_backwards": (_backwards, r"topic /rig/accel/tip: message 31 .*log_time does not increase"),
    "publish_time_differs": (lambda: _with_message("/rig/accel/tip", b'{"a_mps2": 0.1}', publish_dt=5),
                             r"topic /rig/accel/tip: message 5 .*publish_time \d+ differs from log_time"),
    "ors_null_while_valid": (lambda: _with_message("/ors/drogue", b'{"x_m":null,"y_m":1.0,"z_m":-2.0,"valid":true}',
                                                   kind="trail", at=2),
                             r"topic /ors/drogue: message 2 .*'x_m' is null while 'valid' is true"),
    "ors_valid_string": (lambda: _with_message("/ors/drogue", b'{"x_m":1.0,"y_m":1.0,"z_m":-2.0,"valid":"yes"}',
                                               kind="trail", at=2),
                         r"topic /ors/drogue: message 2 .*'valid' must be a boolean"),
    "hose_point_missing_z": (lambda: _with_message("/video/hose", b'{"points":[{"x_m":0,"z_m":0},{"x_m":1}]}',
                                                   kind="trail", at=4),
                             r"topic /video/hose: message 4 .*point 1 lacks field 'z_m'"),
    "hose_points_not_list": (lambda: _with_message("/video/hose", b'{"points":{"x_m":0,"z_m":0}}',
                                                   kind="trail", at=4),
                             r"topic /video/hose: message 4 .*'points' must be an array"),
    "unknown_probe_event": (lambda: _with_message("/probe/events", b'{"event":"hook"}', kind="engagement", at=1),
                            r"topic /probe/events: message 1 .*'hook', not one of contact, disconnect"),
}


def write_corpus(outdir: str | Path) -> list[tuple[Path, str]]:
    """Write every case as <name>.mcap in outdir; return (path, expected regex) pairs."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    out = []
    for name, (builder, regex) in CASES.items():
        path = outdir / f"{name}.mcap"
        path.write_bytes(builder())
        out.append((path, regex))
    return out


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: make_corrupt.py OUTDIR")
    for path, regex in write_corpus(sys.argv[1]):
        print(f"{path}\t{regex}")
