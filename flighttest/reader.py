"""Read flight/bench records in the MCAP contract of SCHEMA.md.

`read_record` is the one door through which logs enter the workbench.  The
file is checked (size, magic) before it is read whole, walked record by
record (`container.walk`: every chunk CRC, and *where* a damaged file is
damaged; a recording cut short has no summary, so the summary index is not
trusted), then checked against the contract: metadata keys and their
physical ranges (`schema.TestInfo`), channels and schemas, every message
(`messages.parse_topic`) and what the values show together
(`plausibility.check`: refused, or reported in `FlightRecord.warnings`).
Anything that breaks the contract raises `LogError`, whose message is a
single line naming the file, the topic or metadata key, and what is wrong;
no partial record is ever returned.
"""
from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np

from .container import MAGIC, ContainerDamage, RawRecords, walk
from .messages import TopicError, decode_json, frame_topic, parse_topic
from .plausibility import check as check_plausibility
from .record import FlightRecord, LogError
from .schema import (MESSAGE_ENCODING, METADATA_NAME, REQUIRED_TOPICS, SCHEMA_ENCODING, TOPICS,
                     MetadataError, TestInfo, hardware_ids)

# Larger than any record of the contract (the longest ring-down at 1 kHz is a
# few MB): a file beyond this is not a test record, and reading it whole to
# find out would exhaust memory first.
MAX_RECORD_BYTES = 512 * 2**20


def _read_checked(path: Path) -> bytes:
    """The file's bytes, once its size and magic say it can be a record."""
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > MAX_RECORD_BYTES:
                raise LogError(path, "file", f"is {size} bytes, over the {MAX_RECORD_BYTES} byte "
                                             f"({MAX_RECORD_BYTES >> 20} MiB) limit for one record")
            if fh.read(len(MAGIC)) != MAGIC:
                raise LogError(path, "container", "not an MCAP file (bad magic at byte 0)")
            fh.seek(0)
            return fh.read()
    except OSError as exc:
        raise LogError(path, "file", f"cannot be read ({exc.strerror or exc})") from None


def _hardware_toml(path: Path) -> Path | None:
    for folder in (path.parent, path.parent.parent):
        candidate = folder / "hardware.toml"
        if candidate.is_file():
            return candidate
    return None


def _check_schema_and_channel(path, topic: str, sid: int, msg_encoding: str, raw: RawRecords) -> None:
    where = f"topic {topic}"
    if msg_encoding != MESSAGE_ENCODING:
        raise LogError(path, where, f"message encoding is {msg_encoding!r}, contract says "
                                    f"{MESSAGE_ENCODING!r}")
    if sid == 0 or sid not in raw.schemas:
        raise LogError(path, where, f"channel has no schema (schema id {sid})")
    name, encoding, data = raw.schemas[sid]
    if encoding != SCHEMA_ENCODING:
        raise LogError(path, where, f"schema encoding is {encoding!r}, contract says "
                                    f"{SCHEMA_ENCODING!r}")
    try:
        doc = decode_json(data)
    except ValueError as exc:
        raise LogError(path, where, f"schema {name!r} {exc}") from None
    if not isinstance(doc, dict):
        raise LogError(path, where, f"schema {name!r} is not a JSON object")
    props = doc.get("properties")
    if isinstance(props, dict) and set(props) != set(TOPICS[topic].fields):
        raise LogError(path, where, f"schema {name!r} declares fields {sorted(props)}, "
                                    f"contract has {sorted(TOPICS[topic].fields)}")


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
    buf = _read_checked(path)
    return _parse(buf, path, check_required=check_required, salvage=salvage)


def read_record_bytes(buf: bytes, name: str = "<memory>", *, check_required: bool = True,
                      salvage: bool = False) -> FlightRecord:
    """`read_record` for an in-memory byte string (hardware.toml is not looked up)."""
    return _parse(bytes(buf), None, check_required=check_required, salvage=salvage, name=name)


def _parse(buf: bytes, path: Path | None, *, check_required: bool, salvage: bool,
           name: str | None = None) -> FlightRecord:
    label = path if path is not None else name
    try:
        raw = walk(buf, salvage)
    except ContainerDamage as exc:
        raise LogError(label, "container", str(exc)) from None
    except (struct.error, MemoryError, OverflowError) as exc:  # belt and braces
        raise LogError(label, "container", f"damaged ({type(exc).__name__})") from None

    warnings: list[str] = []
    if raw.truncated:
        warnings.append("no summary section: file was read by scanning its data section")
    if raw.stats is not None and not raw.truncated:
        held = sum(len(v) for v in raw.messages.values())
        if raw.stats.message_count != held:
            raise LogError(label, "container", f"summary statistics count "
                                               f"{raw.stats.message_count} messages, "
                                               f"the data section holds {held}")
        for cid, k in raw.stats.channel_message_counts.items():
            got = len(raw.messages.get(cid, ()))
            if got != k:
                topic = raw.channels.get(cid, (0, f"channel {cid}", ""))[1]
                raise LogError(label, f"topic {topic}", f"summary statistics count {k} "
                                                        f"messages, the data section holds {got}")

    tests = [md for nm, md in raw.metadata if nm == METADATA_NAME]
    if not tests:
        raise LogError(label, "metadata 'test'", "record has no 'test' metadata")
    if len(tests) > 1:
        raise LogError(label, "metadata 'test'", f"record has {len(tests)} 'test' metadata "
                                                 f"records, the contract allows exactly one")
    try:
        info = TestInfo.from_metadata(tests[0])
    except MetadataError as exc:
        raise LogError(label, f"metadata key {exc.key!r}", exc.problem) from None
    if path is not None:
        hw = _hardware_toml(path)
        if hw is not None:
            try:
                hoses = hardware_ids(hw.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise LogError(hw, "hardware.toml", f"cannot be read ({exc})") from None
            if info.hose not in hoses:
                raise LogError(label, "metadata key 'hose'", f"{info.hose!r} is not a hose id of "
                                                             f"{hw} ({', '.join(sorted(hoses))})")

    by_topic: dict[str, int] = {}
    for cid, (sid, topic, enc) in raw.channels.items():
        if topic not in TOPICS:
            continue  # the contract says unknown topics are ignored
        if topic in by_topic:
            raise LogError(label, f"topic {topic}", f"declared on two channels "
                                                    f"(ids {by_topic[topic]} and {cid})")
        by_topic[topic] = cid
        _check_schema_and_channel(label, topic, sid, enc, raw)

    if check_required:
        for topic in REQUIRED_TOPICS[info.test_kind]:
            if topic not in by_topic:
                raise LogError(label, f"topic {topic}",
                               f"absent, but test_kind {info.test_kind!r} needs it")
            if not raw.messages.get(by_topic[topic]):
                raise LogError(label, f"topic {topic}",
                               f"has no messages, but test_kind {info.test_kind!r} needs it")

    parsed: dict[str, tuple[np.ndarray, dict[str, list]]] = {}
    for topic, cid in by_topic.items():
        try:
            parsed[topic] = parse_topic(topic, raw.messages.get(cid, []))
        except TopicError as exc:
            raise LogError(label, exc.where, exc.problem) from None
    firsts = [int(t[0]) for t, _ in parsed.values() if len(t)]
    if not firsts:
        raise LogError(label, "container", "no messages on any topic of the contract")
    start_ns = min(firsts)
    topics = {topic: frame_topic(topic, t, cols, start_ns) for topic, (t, cols) in parsed.items()}
    record = FlightRecord(info=info, topics=topics, start_time_ns=start_ns, path=path,
                          had_summary=raw.had_summary, warnings=warnings)
    record.warnings.extend(check_plausibility(record, label))
    return record
