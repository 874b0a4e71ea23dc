"""Read and write flight/bench records in the MCAP contract of SCHEMA.md.

`read_record` is the one door through which logs enter the workbench.  It
walks the file itself, record by record, instead of trusting the summary
index: a recording cut short has no summary, and walking the data section is
also the only way to check every chunk CRC and to say *where* a damaged file
is damaged.  Anything that breaks the contract raises `LogError`, whose
message is a single line naming the file, the topic or metadata key, and what
is wrong; no partial record is ever returned.

`write_record` writes the same contract (so a simulation run can be stored
and compared through the same code) and can add Foxglove well-known schemas
for scrubbing the hose in Foxglove's 3D panel.
"""
from __future__ import annotations

import json
import math
import os
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from . import schema as S
from .schema import TestInfo

MAGIC = b"\x89MCAP0\r\n"

OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06
OP_METADATA, OP_DATA_END, OP_STATISTICS = 0x0C, 0x0F, 0x0B
_OP_NAMES = {
    0x01: "Header", 0x02: "Footer", 0x03: "Schema", 0x04: "Channel", 0x05: "Message",
    0x06: "Chunk", 0x07: "MessageIndex", 0x08: "ChunkIndex", 0x09: "Attachment",
    0x0A: "AttachmentIndex", 0x0B: "Statistics", 0x0C: "Metadata", 0x0D: "MetadataIndex",
    0x0E: "SummaryOffset", 0x0F: "DataEnd",
}
# A chunk that claims to inflate beyond this is damage, not data; refusing it
# keeps a flipped size field from exhausting memory.
_MAX_CHUNK_BYTES = 1 << 30
# Nanosecond times are held as int64 (pandas, numpy): 2**63 ns is in 2262.
_MAX_TIME_NS = 1 << 63


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


# --------------------------------------------------------------------------
# Container walk
# --------------------------------------------------------------------------

class _Damage(Exception):
    """Internal: container-level damage at a byte offset."""


class _Cursor:
    __slots__ = ("buf", "pos", "end", "base")

    def __init__(self, buf: bytes | memoryview, pos: int, end: int, base: int = 0):
        self.buf, self.pos, self.end, self.base = buf, pos, end, base

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > self.end:
            raise _Damage(f"field runs past the end of its record at byte {self.base + self.pos}")
        out = bytes(self.buf[self.pos:self.pos + n])
        self.pos += n
        return out

    def u16(self) -> int:
        return struct.unpack("<H", self.take(2))[0]

    def u32(self) -> int:
        return struct.unpack("<I", self.take(4))[0]

    def u64(self) -> int:
        return struct.unpack("<Q", self.take(8))[0]

    def string(self) -> str:
        raw = self.take(self.u32())
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError:
            raise _Damage(f"string is not UTF-8 at byte {self.base + self.pos}") from None

    def str_map(self) -> dict[str, str]:
        size = self.u32()
        sub = _Cursor(self.buf, self.pos, self.pos + size, self.base)
        if sub.end > self.end:
            raise _Damage(f"map runs past the end of its record at byte {self.base + self.pos}")
        out: dict[str, str] = {}
        while sub.pos < sub.end:
            key = sub.string()
            if key in out:
                raise _Damage(f"map repeats key {key!r}")
            out[key] = sub.string()
        self.pos = sub.end
        return out


@dataclass
class _Raw:
    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)
    channels: dict[int, tuple[int, str, str]] = field(default_factory=dict)
    metadata: list[tuple[str, dict[str, str]]] = field(default_factory=list)
    # channel id -> (log_time, publish_time, data) in file order
    messages: dict[int, list[tuple[int, int, bytes]]] = field(default_factory=dict)
    stats: tuple[int, dict[int, int]] | None = None
    had_summary: bool = False
    truncated: bool = False


def _decompress(compression: str, data: bytes, size: int) -> bytes:
    if size > _MAX_CHUNK_BYTES:
        raise _Damage(f"chunk claims {size} uncompressed bytes")
    if compression == "":
        out = data
    elif compression == "zstd":
        import zstandard
        try:
            # Streaming, so the output grows with the data actually present
            # rather than being allocated from a size field that may be damaged.
            out = zstandard.ZstdDecompressor().decompressobj().decompress(data)
        except zstandard.ZstdError as exc:
            raise _Damage(f"zstd data does not decompress ({exc})") from None
    elif compression == "lz4":
        import lz4.frame
        try:
            out = lz4.frame.decompress(data)
        except RuntimeError as exc:
            raise _Damage(f"lz4 data does not decompress ({exc})") from None
    else:
        raise _Damage(f"unsupported chunk compression {compression!r} (contract: zstd, lz4 or none)")
    if len(out) != size:
        raise _Damage(f"chunk inflates to {len(out)} bytes, its header says {size}")
    return out


def _add_schema(raw: _Raw, c: _Cursor) -> None:
    sid = c.u16()
    name, encoding = c.string(), c.string()
    data = c.take(c.u32())
    if sid == 0:
        raise _Damage("schema id 0 is reserved")
    entry = (name, encoding, data)
    if raw.schemas.setdefault(sid, entry) != entry:
        raise _Damage(f"schema id {sid} is declared twice with different contents")


def _add_channel(raw: _Raw, c: _Cursor) -> None:
    cid, sid = c.u16(), c.u16()
    topic, encoding = c.string(), c.string()
    c.str_map()
    entry = (sid, topic, encoding)
    if raw.channels.setdefault(cid, entry) != entry:
        raise _Damage(f"channel id {cid} is declared twice with different contents")


def _add_message(raw: _Raw, c: _Cursor) -> None:
    cid = c.u16()
    c.u32()  # sequence: informative only
    log_time, publish_time = c.u64(), c.u64()
    data = bytes(c.buf[c.pos:c.end])
    c.pos = c.end
    if cid not in raw.channels:
        raise _Damage(f"message on channel id {cid}, which no Channel record declares before it")
    raw.messages.setdefault(cid, []).append((log_time, publish_time, data))


def _walk_chunk(raw: _Raw, c: _Cursor, offset: int) -> None:
    c.u64(), c.u64()  # message start/end time: recomputed from the messages
    size, crc = c.u64(), c.u32()
    compression = c.string()
    payload = c.take(c.u64())
    data = _decompress(compression, payload, size)
    if crc != 0 and zlib.crc32(data) != crc:
        raise _Damage(f"CRC mismatch in Chunk at byte {offset}: "
                      f"stored {crc:#010x}, computed {zlib.crc32(data):#010x}")
    pos, end = 0, len(data)
    while pos < end:
        if end - pos < 9:
            raise _Damage(f"record header cut short inside Chunk at byte {offset}")
        opcode, length = struct.unpack_from("<BQ", data, pos)
        if length > end - pos - 9:
            raise _Damage(f"record inside Chunk at byte {offset} runs past the chunk end")
        if opcode == OP_MESSAGE and length >= 22:
            # Inlined fast path: messages are nearly all of a file.
            cid, _, log_time, publish_time = struct.unpack_from("<HIQQ", data, pos + 9)
            msgs = raw.messages.get(cid)
            if msgs is None:
                if cid not in raw.channels:
                    raise _Damage(f"message on channel id {cid}, which no Channel record "
                                  f"declares before it")
                msgs = raw.messages[cid] = []
            msgs.append((log_time, publish_time, data[pos + 31:pos + 9 + length]))
            pos += 9 + length
            continue
        inner = _Cursor(data, pos + 9, pos + 9 + length, base=0)
        if opcode == OP_SCHEMA:
            _add_schema(raw, inner)
        elif opcode == OP_CHANNEL:
            _add_channel(raw, inner)
        elif opcode == OP_MESSAGE:
            _add_message(raw, inner)
        elif opcode == 0:
            raise _Damage(f"invalid opcode 0x00 inside Chunk at byte {offset}")
        pos += 9 + length


def _walk(buf: bytes, salvage: bool) -> _Raw:
    """Walk every record of an MCAP byte string; raise _Damage on any fault."""
    n = len(buf)
    if n < len(MAGIC) or buf[:len(MAGIC)] != MAGIC:
        raise _Damage("not an MCAP file (bad magic at byte 0)")
    raw = _Raw()
    pos = len(MAGIC)
    first = True
    data_end_seen = False
    while True:
        if pos == n:
            # Ended cleanly between records with no Footer: a recording that
            # was stopped without its summary.  All it holds is complete.
            raw.truncated = True
            if first:
                raise _Damage("file holds only the magic bytes")
            return raw
        if n - pos < 9:
            if salvage or data_end_seen:
                raw.truncated = True
                return raw
            raise _Damage(f"file truncated in a record header at byte {pos}")
        opcode, length = struct.unpack_from("<BQ", buf, pos)
        name = _OP_NAMES.get(opcode, f"opcode {opcode:#04x}")
        if length > n - pos - 9:
            if salvage or data_end_seen:
                raw.truncated = True
                return raw
            raise _Damage(f"{name} record at byte {pos} claims {length} bytes, "
                          f"only {n - pos - 9} remain: file truncated or damaged "
                          f"(salvage reads the complete records before it)")
        if first and opcode != OP_HEADER:
            raise _Damage(f"first record is {name}, not Header")
        first = False
        c = _Cursor(buf, pos + 9, pos + 9 + length, base=0)
        if opcode == 0:
            raise _Damage(f"invalid opcode 0x00 at byte {pos}")
        if opcode == OP_CHUNK:
            _walk_chunk(raw, c, pos)
        elif opcode in (OP_SCHEMA, OP_CHANNEL):
            # Repeats in the summary must agree with the data section's.
            (_add_schema if opcode == OP_SCHEMA else _add_channel)(raw, c)
        elif opcode == OP_MESSAGE and not data_end_seen:
            _add_message(raw, c)  # an unchunked file
        elif opcode == OP_METADATA and not data_end_seen:
            raw.metadata.append((c.string(), c.str_map()))
        elif opcode == OP_STATISTICS:
            count = c.u64()
            c.u16(), c.u32(), c.u32(), c.u32(), c.u32(), c.u64(), c.u64()
            per_channel: dict[int, int] = {}
            size = c.u32()
            sub = _Cursor(buf, c.pos, c.pos + size, 0)
            if sub.end > c.end:
                raise _Damage("Statistics channel-count map runs past its record")
            while sub.pos < sub.end:
                cid = sub.u16()
                per_channel[cid] = sub.u64()
            raw.stats = (count, per_channel)
        elif opcode == OP_DATA_END:
            crc = c.u32()
            if crc != 0 and zlib.crc32(buf[:pos]) != crc:
                raise _Damage(f"data-section CRC mismatch (DataEnd at byte {pos}): "
                              f"stored {crc:#010x}, computed {zlib.crc32(buf[:pos]):#010x}")
            data_end_seen = True
        elif opcode == OP_FOOTER:
            summary_start, _, summary_crc = c.u64(), c.u64(), c.u32()
            end = pos + 9 + length
            if buf[end:] != MAGIC:
                raise _Damage(f"bytes after the Footer at byte {pos} are not the closing magic")
            if summary_start:
                if not pos >= summary_start > len(MAGIC):
                    raise _Damage(f"Footer points its summary at byte {summary_start}, "
                                  f"outside the file's summary area")
                computed = zlib.crc32(buf[summary_start:pos + 9 + 16])
                if summary_crc != 0 and computed != summary_crc:
                    raise _Damage(f"summary-section CRC mismatch: stored {summary_crc:#010x}, "
                                  f"computed {computed:#010x}")
                raw.had_summary = True
            if not data_end_seen:
                raise _Damage("Footer reached without a DataEnd record")
            return raw
        pos += 9 + length


# --------------------------------------------------------------------------
# Contract checks on the walked records
# --------------------------------------------------------------------------

def _no_constants(name: str) -> Any:
    raise ValueError(f"non-finite literal {name}")


_DECODER = json.JSONDecoder(parse_constant=_no_constants)


def _decode_json(data: bytes) -> Any:
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


def _parse_topic(topic: str, msgs: list[tuple[int, int, bytes]]) -> tuple[np.ndarray, dict[str, list]]:
    """Validate one topic's messages; return log times and columns."""
    spec = S.TOPICS[topic].fields
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
                obj = _decode_json(data)
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
                if kind == S.NUMBER:
                    cols[name].append(_check_number(v, name))
                elif kind == S.NULLABLE_NUMBER:
                    if v is None and valid:
                        raise ValueError(f"field {name!r} is null while 'valid' is true")
                    f = _check_number(v, name, nullable=True)
                    # Coordinates of a lost track are not data, whatever was logged.
                    cols[name].append(f if valid else math.nan)
                elif kind == S.BOOLEAN:
                    cols[name].append(v)
                elif kind == S.EVENT:
                    if v not in S.PROBE_EVENTS:
                        raise ValueError(f"field {name!r} is {v!r}, not one of "
                                         f"{', '.join(S.PROBE_EVENTS)}")
                    cols[name].append(v)
                elif kind == S.POINTS:
                    if not isinstance(v, list):
                        raise ValueError(f"field {name!r} must be an array, got {_json_type(v)}")
                    pts = []
                    for j, p in enumerate(v):
                        _check_fields(p, dict.fromkeys(S.POINT_FIELDS, S.NUMBER), f"point {j}")
                        pts.append((_check_number(p["x_m"], f"points[{j}].x_m"),
                                    _check_number(p["z_m"], f"points[{j}].z_m")))
                    cols[name].append(pts)
        except ValueError as exc:
            raise _TopicError(where, f"message {i} (log_time {log_time}): {exc}") from None
    times = np.fromiter((m[0] for m in msgs), dtype=np.int64, count=len(msgs))
    return times, cols


class _TopicError(Exception):
    def __init__(self, where: str, problem: str):
        super().__init__(problem)
        self.where, self.problem = where, problem


def _frame(topic: str, times_ns: np.ndarray, cols: dict[str, list], start_ns: int) -> pd.DataFrame:
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
    for name, kind in S.TOPICS[topic].fields.items():
        if kind == S.BOOLEAN:
            data[name] = np.asarray(cols[name], dtype=bool)
        elif kind == S.EVENT:
            data[name] = pd.Series(cols[name], dtype=object).to_numpy()
        else:
            data[name] = np.asarray(cols[name], dtype=float)
    return pd.DataFrame(data, index=pd.Index(t_s, name="t_s"))


def _hardware_toml(path: Path) -> Path | None:
    for folder in (path.parent, path.parent.parent):
        candidate = folder / "hardware.toml"
        if candidate.is_file():
            return candidate
    return None


def _check_schema_and_channel(path, topic: str, sid: int, msg_encoding: str, raw: _Raw) -> None:
    where = f"topic {topic}"
    if msg_encoding != S.MESSAGE_ENCODING:
        raise LogError(path, where, f"message encoding is {msg_encoding!r}, contract says "
                                    f"{S.MESSAGE_ENCODING!r}")
    if sid == 0 or sid not in raw.schemas:
        raise LogError(path, where, f"channel has no schema (schema id {sid})")
    name, encoding, data = raw.schemas[sid]
    if encoding != S.SCHEMA_ENCODING:
        raise LogError(path, where, f"schema encoding is {encoding!r}, contract says "
                                    f"{S.SCHEMA_ENCODING!r}")
    try:
        doc = _decode_json(data)
    except ValueError as exc:
        raise LogError(path, where, f"schema {name!r} {exc}") from None
    if not isinstance(doc, dict):
        raise LogError(path, where, f"schema {name!r} is not a JSON object")
    props = doc.get("properties")
    if isinstance(props, dict) and set(props) != set(S.TOPICS[topic].fields):
        raise LogError(path, where, f"schema {name!r} declares fields {sorted(props)}, "
                                    f"contract has {sorted(S.TOPICS[topic].fields)}")


def read_record(path: str | os.PathLike, *, check_required: bool = True,
                salvage: bool = False) -> FlightRecord:
    """Read one record and check it against the contract.

    check_required: refuse a record that lacks a topic its test_kind needs.
    salvage: for a file cut inside a record, keep the complete records
        before the cut instead of refusing the file.  A file that ends
        cleanly between records is always read (truncated recording).
    Raises LogError (one line: file, topic/key, problem) on any breach.
    """
    path = Path(path)
    try:
        buf = path.read_bytes()
    except OSError as exc:
        raise LogError(path, "file", f"cannot be read ({exc.strerror or exc})") from None
    return _parse(buf, path, check_required=check_required, salvage=salvage)


def read_record_bytes(buf: bytes, name: str = "<memory>", *, check_required: bool = True,
                      salvage: bool = False) -> FlightRecord:
    """`read_record` for an in-memory byte string (hardware.toml is not looked up)."""
    return _parse(bytes(buf), None, check_required=check_required, salvage=salvage, name=name)


def _parse(buf: bytes, path: Path | None, *, check_required: bool, salvage: bool,
           name: str | None = None) -> FlightRecord:
    label = path if path is not None else name
    try:
        raw = _walk(buf, salvage)
    except _Damage as exc:
        raise LogError(label, "container", str(exc)) from None
    except (struct.error, MemoryError, OverflowError) as exc:  # belt and braces
        raise LogError(label, "container", f"damaged ({type(exc).__name__})") from None

    warnings: list[str] = []
    if raw.truncated:
        warnings.append("no summary section: file was read by scanning its data section")
    if raw.stats is not None and not raw.truncated:
        count, per_channel = raw.stats
        held = sum(len(v) for v in raw.messages.values())
        if count != held:
            raise LogError(label, "container", f"summary statistics count {count} messages, "
                                               f"the data section holds {held}")
        for cid, k in per_channel.items():
            got = len(raw.messages.get(cid, ()))
            if got != k:
                topic = raw.channels.get(cid, (0, f"channel {cid}", ""))[1]
                raise LogError(label, f"topic {topic}", f"summary statistics count {k} "
                                                        f"messages, the data section holds {got}")

    tests = [md for nm, md in raw.metadata if nm == S.METADATA_NAME]
    if not tests:
        raise LogError(label, "metadata 'test'", "record has no 'test' metadata")
    if len(tests) > 1:
        raise LogError(label, "metadata 'test'", f"record has {len(tests)} 'test' metadata "
                                                 f"records, the contract allows exactly one")
    try:
        info = TestInfo.from_metadata(tests[0])
    except S.MetadataError as exc:
        raise LogError(label, f"metadata key {exc.key!r}", exc.problem) from None
    if path is not None:
        hw = _hardware_toml(path)
        if hw is not None:
            try:
                hoses = S.hardware_ids(hw.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise LogError(hw, "hardware.toml", f"cannot be read ({exc})") from None
            if info.hose not in hoses:
                raise LogError(label, "metadata key 'hose'", f"{info.hose!r} is not a hose id of "
                                                             f"{hw} ({', '.join(sorted(hoses))})")

    by_topic: dict[str, int] = {}
    for cid, (sid, topic, enc) in raw.channels.items():
        if topic not in S.TOPICS:
            continue  # the contract says unknown topics are ignored
        if topic in by_topic:
            raise LogError(label, f"topic {topic}", f"declared on two channels "
                                                    f"(ids {by_topic[topic]} and {cid})")
        by_topic[topic] = cid
        _check_schema_and_channel(label, topic, sid, enc, raw)

    if check_required:
        for topic in S.REQUIRED_TOPICS[info.test_kind]:
            if topic not in by_topic:
                raise LogError(label, f"topic {topic}",
                               f"absent, but test_kind {info.test_kind!r} needs it")
            if not raw.messages.get(by_topic[topic]):
                raise LogError(label, f"topic {topic}",
                               f"has no messages, but test_kind {info.test_kind!r} needs it")

    parsed: dict[str, tuple[np.ndarray, dict[str, list]]] = {}
    for topic, cid in by_topic.items():
        try:
            parsed[topic] = _parse_topic(topic, raw.messages.get(cid, []))
        except _TopicError as exc:
            raise LogError(label, exc.where, exc.problem) from None
    firsts = [int(t[0]) for t, _ in parsed.values() if len(t)]
    if not firsts:
        raise LogError(label, "container", "no messages on any topic of the contract")
    start_ns = min(firsts)
    topics = {topic: _frame(topic, t, cols, start_ns) for topic, (t, cols) in parsed.items()}
    return FlightRecord(info=info, topics=topics, start_time_ns=start_ns, path=path,
                        had_summary=raw.had_summary, warnings=warnings)


# --------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------

def topic_jsonschema(topic: str) -> dict:
    """The jsonschema this package writes for a contract topic."""
    spec = S.TOPICS[topic]
    num = {"type": "number"}
    props: dict[str, Any] = {}
    for name, kind in spec.fields.items():
        if kind == S.NUMBER:
            props[name] = dict(num)
        elif kind == S.NULLABLE_NUMBER:
            props[name] = {"type": ["number", "null"]}
        elif kind == S.BOOLEAN:
            props[name] = {"type": "boolean"}
        elif kind == S.EVENT:
            props[name] = {"type": "string", "enum": list(S.PROBE_EVENTS)}
        elif kind == S.POINTS:
            props[name] = {"type": "array", "items": {
                "type": "object", "properties": {"x_m": num, "z_m": num},
                "required": list(S.POINT_FIELDS)}}
    return {"type": "object", "title": spec.schema_name, "description": spec.description,
            "properties": props, "required": list(spec.fields)}


def _topic_messages(topic: str, df: pd.DataFrame) -> list[tuple[float, dict]]:
    spec = S.TOPICS[topic].fields
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
            if kind == S.BOOLEAN:
                msg[name] = bool(v)
            elif kind == S.EVENT:
                msg[name] = str(v)
            elif kind == S.NULLABLE_NUMBER:
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
    ors = record.topics.get("/ors/drogue")
    if ors is not None:
        for t, x, y, z, ok in zip(ors.index, ors["x_m"], ors["y_m"], ors["z_m"], ors["valid"]):
            if not ok:
                continue
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
    increase) raises LogError and leaves no file behind.
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
    except S.MetadataError as exc:
        raise LogError(path, f"metadata key {exc.key!r}", exc.problem) from None

    rows: list[tuple[int, str, bytes]] = []
    for topic, df in record.topics.items():
        if topic not in S.TOPICS:
            raise LogError(path, f"topic {topic}", "not a topic of the contract")
        missing = [c for c in (("t_s", "point", "x_m", "z_m") if topic == "/video/hose"
                               else S.TOPICS[topic].fields) if c not in df.columns]
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
            _parse_topic(topic, encoded)  # the reader's own checks, before anything is written
        except _TopicError as exc:
            raise LogError(path, exc.where, exc.problem) from None
        rows.extend((ns, topic, data) for ns, _, data in encoded)

    fox: list[tuple[str, str, int, dict]] = _foxglove_messages(record) if foxglove else []
    rows.sort(key=lambda r: r[0])
    tmp = path.with_name(path.name + ".part")
    try:
        with open(tmp, "wb") as fh:
            w = Writer(fh, chunk_size=chunk_size, compression=comp)
            w.start(profile="", library=library)
            channel_ids: dict[str, int] = {}
            for topic in sorted(record.topics):
                sid = w.register_schema(name=S.TOPICS[topic].schema_name,
                                        encoding=S.SCHEMA_ENCODING,
                                        data=json.dumps(topic_jsonschema(topic)).encode())
                channel_ids[topic] = w.register_channel(topic=topic,
                                                        message_encoding=S.MESSAGE_ENCODING,
                                                        schema_id=sid)
            if fox:
                fox_schemas = _fox_schemas()
                sids = {name: w.register_schema(name=name, encoding=S.SCHEMA_ENCODING,
                                                data=json.dumps(doc).encode())
                        for name, doc in fox_schemas.items()}
                for topic in sorted({f[0] for f in fox}):
                    schema_name = next(f[1] for f in fox if f[0] == topic)
                    channel_ids[topic] = w.register_channel(topic=topic,
                                                            message_encoding=S.MESSAGE_ENCODING,
                                                            schema_id=sids[schema_name])
                rows.extend((ns, topic, json.dumps(msg, separators=(",", ":")).encode())
                            for topic, _, ns, msg in fox)
                rows.sort(key=lambda r: r[0])
            w.add_metadata(S.METADATA_NAME, dict(info.raw))
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


def make_record(info: TestInfo | Mapping[str, str], topics: Mapping[str, pd.DataFrame],
                start_time_ns: int) -> FlightRecord:
    """Assemble a FlightRecord (e.g. from a simulation run) for `write_record`."""
    if not isinstance(info, TestInfo):
        info = TestInfo.from_metadata(dict(info))
    return FlightRecord(info=info, topics=dict(topics), start_time_ns=int(start_time_ns))
