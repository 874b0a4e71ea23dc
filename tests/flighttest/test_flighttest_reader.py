"""The log contract: every shipped log reads; every breach is refused by name."""
from __future__ import annotations

import json
import re
import struct
import sys
import zlib
from functools import lru_cache
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

sys.path.insert(0, str(Path(__file__).parent))
import make_corrupt as MC  # noqa: E402

from flighttest import schema as S  # noqa: E402
from flighttest import (LogError, make_record, read_record, read_record_bytes,  # noqa: E402
                                write_record)
from flighttest.schema import TestInfo  # noqa: E402

LOGS = Path(__file__).resolve().parents[2] / "flighttest" / "logs"
ALL_LOGS = sorted(LOGS.glob("*/*.mcap"))
KIND_BY_PREFIX = {"RD": None, "PD": "pitch_doublet", "TR": "trail", "EN": "engagement"}


@lru_cache(maxsize=None)
def cached(path: Path):
    return read_record(path)


def test_logs_are_present():
    assert len(ALL_LOGS) >= 50, "flighttest/logs should hold the bench and flight records"


@pytest.mark.parametrize("path", ALL_LOGS, ids=lambda p: p.name)
def test_every_log_reads(path):
    rec = cached(path)
    info = rec.info
    assert info.test_id == path.stem
    expected = KIND_BY_PREFIX[path.stem[:2]]
    if expected is None:
        expected = "ringdown_axial" if "-A-" in path.stem else "ringdown_bending"
    assert info.test_kind == expected
    assert rec.had_summary
    for topic in S.REQUIRED_TOPICS[info.test_kind]:
        assert len(rec.topics[topic]) > 0
    for topic, df in rec.topics.items():
        if topic == "/video/hose":
            assert list(df.columns) == ["t_s", "point", "x_m", "z_m"]
            assert np.all(np.diff(df["t_s"].to_numpy()) >= 0)
            # Tow point first, then counting up within each frame.
            assert (df.groupby("t_s")["point"].first() == 0).all()
            continue
        assert df.index.name == "t_s"
        assert df.index.is_monotonic_increasing and df.index.is_unique
        assert list(df.columns) == list(S.TOPICS[topic].fields)
    first = min(float(df.index[0]) if topic != "/video/hose" else float(df["t_s"].iloc[0])
                for topic, df in rec.topics.items())
    assert first == 0.0
    if "/ors/drogue" in rec.topics:
        ors = rec.topics["/ors/drogue"]
        assert ors["valid"].dtype == bool
        lost = ~ors["valid"]
        # Dropouts are data: kept, with NaN coordinates.
        assert ors.loc[lost, ["x_m", "y_m", "z_m"]].isna().all().all()
        assert ors.loc[~lost, ["x_m", "y_m", "z_m"]].notna().all().all()


def test_metadata_converted_to_si():
    info = TestInfo.from_metadata({
        "schema_version": "1", "test_id": "X", "test_kind": "engagement", "hose": "h",
        "altitude_ft": "10000", "airspeed_kcas": "100", "oat_F": "32", "temperature_F": "-40",
        "closure_rate_kts": "3.6", "hose_length_ft": "50", "tanker_gross_weight_lb": "100000",
        "repetition": "2", "engagement": "11", "hose_fuel": "full"})
    assert info.altitude_m == pytest.approx(3048.0)
    assert info.calibrated_airspeed_mps == pytest.approx(51.4444, rel=1e-5)
    assert info.oat_K == pytest.approx(273.15)
    assert info.temperature_K == pytest.approx(233.15)     # -40 F is -40 C
    assert info.temperature_setpoint_F == -40.0
    assert info.closure_rate_mps == pytest.approx(1.852)
    assert info.hose_length_m == pytest.approx(15.24)
    assert info.tanker_gross_weight_kg == pytest.approx(45359.237)
    assert (info.repetition, info.engagement) == (2, 11)
    assert info.raw["altitude_ft"] == "10000"


def test_real_log_metadata():
    info = cached(LOGS / "flight" / "EN-KDC10-E7.mcap").info
    assert info.altitude_m == pytest.approx(15050 * 0.3048)
    assert info.hose_length_m == pytest.approx(75 * 0.3048)
    assert info.raw["airspeed_kcas"] == "254"


def _assert_same(a, b):
    assert a.start_time_ns == b.start_time_ns
    assert a.info.raw == b.info.raw
    assert set(a.topics) == set(b.topics)
    for topic in a.topics:
        pd.testing.assert_frame_equal(a.topics[topic], b.topics[topic])


@pytest.mark.parametrize("name", ["flight/EN-KDC10-E11.mcap", "flight/PD-G3-2.mcap",
                                  "flight/TR-KDC10-E8.mcap", "ringdown/RD-KC130-A-70F-r2.mcap",
                                  "ringdown/RD-FA18-B-m20F-r3.mcap"])
@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_write_read_round_trip(tmp_path, name, compression):
    rec = cached(LOGS / name)
    out = write_record(tmp_path / "copy.mcap", rec, compression=compression)
    _assert_same(rec, read_record(out))


def test_write_refuses_what_cannot_be_read(tmp_path):
    rec = cached(LOGS / "ringdown" / "RD-FA18-A-70F-r1.mcap")
    bad = dict(rec.topics)
    df = bad["/rig/accel/weight"].copy()
    df.iloc[3, 0] = np.inf
    bad["/rig/accel/weight"] = df
    with pytest.raises(LogError, match=r"topic /rig/accel/weight: .*non-finite"):
        write_record(tmp_path / "x.mcap", make_record(rec.info, bad, rec.start_time_ns))
    assert not (tmp_path / "x.mcap").exists() and not list(tmp_path.iterdir())
    unknown = dict(rec.topics, **{"/rig/strain": rec.topics["/rig/temperature"]})
    with pytest.raises(LogError, match=r"topic /rig/strain: not a topic of the contract"):
        write_record(tmp_path / "y.mcap", make_record(rec.info, unknown, rec.start_time_ns))


def test_simulation_record_written_from_arrays(tmp_path):
    """A solver run stored through make_record/write_record reads back through the same door."""
    t = np.arange(0, 5, 0.01)
    start = 1_700_000_000_000_000_000
    ors = pd.DataFrame({"x_m": 22.6 + 0 * t, "y_m": 0 * t, "z_m": -2.8 + 0.01 * np.sin(t),
                        "valid": np.ones_like(t, dtype=bool)}, index=pd.Index(t, name="t_s"))
    tow = pd.DataFrame({"x_m": 0 * t, "y_m": 0 * t, "z_m": 0 * t}, index=pd.Index(t, name="t_s"))
    air = pd.DataFrame({"altitude_ft": 15000 + 0 * t, "kcas": 255 + 0 * t, "ktas": 316 + 0 * t,
                        "oat_C": -17 + 0 * t}, index=pd.Index(t, name="t_s"))
    frames = t[::10]
    xs = np.linspace(0, 22.6, 30)
    hose = pd.DataFrame({"t_s": np.repeat(frames, len(xs)), "point": np.tile(np.arange(len(xs)), len(frames)),
                         "x_m": np.tile(xs, len(frames)), "z_m": np.tile(-0.12 * xs, len(frames))})
    rec = make_record({"schema_version": "1", "test_id": "SIM-TR-1", "test_kind": "trail",
                       "hose": "kdc10_pod", "notes": "simulation"},
                      {"/ors/drogue": ors, "/tanker/tow_point": tow, "/air_data": air,
                       "/video/hose": hose}, start)
    back = read_record(write_record(tmp_path / "sim.mcap", rec, foxglove=True))
    assert back.start_time_ns == start
    pd.testing.assert_frame_equal(back.topics["/ors/drogue"], ors)
    pd.testing.assert_frame_equal(back.topics["/video/hose"], hose, check_dtype=False)


def test_foxglove_topics(tmp_path):
    rec = cached(LOGS / "flight" / "TR-KDC10-E7.mcap")
    out = write_record(tmp_path / "fox.mcap", rec, foxglove=True)
    hose = rec.topics["/video/hose"]
    n_frames = hose["t_s"].nunique()
    seen = {}
    with open(out, "rb") as fh:
        reader = make_reader(fh)
        for schema, channel, message in reader.iter_messages(
                topics=["/foxglove/hose", "/foxglove/tf", "/foxglove/drogue"]):
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            doc = json.loads(schema.data)
            assert doc["title"] == schema.name
            seen.setdefault(channel.topic, []).append((schema.name, json.loads(message.data)))
    assert [n for n, _ in seen["/foxglove/hose"]] == ["foxglove.SceneUpdate"] * n_frames
    first_frame = hose[hose["t_s"] == hose["t_s"].iloc[0]]
    line = seen["/foxglove/hose"][0][1]["entities"][0]["lines"][0]
    assert line["type"] == 0                                   # LINE_STRIP
    assert [p["x"] for p in line["points"]] == list(first_frame["x_m"])
    assert seen["/foxglove/tf"][0][0] == "foxglove.FrameTransform"
    tf = seen["/foxglove/tf"][0][1]
    assert (tf["parent_frame_id"], tf["child_frame_id"]) == ("tanker", "tow_point")
    assert len(seen["/foxglove/drogue"]) == int(rec.topics["/ors/drogue"]["valid"].sum())
    # The contract reader ignores the extra topics and sees the same record.
    _assert_same(rec, read_record(out))


# ------------------------------------------------------ truncated recordings

def test_file_without_summary_is_scanned():
    good = MC.build(kind="engagement", compression="zstd")
    data_end = next(off for op, off, _ in MC.records(good) if op == 0x0F)
    full = read_record_bytes(good)
    cut = read_record_bytes(good[:data_end])       # recorder stopped before DataEnd/summary
    assert not cut.had_summary and cut.warnings
    for topic in full.topics:
        pd.testing.assert_frame_equal(full.topics[topic], cut.topics[topic])


def test_cut_inside_a_record_refused_unless_salvaged():
    msgs = MC.bending_messages(3000)
    buf = io_build(msgs)
    chunks = [off for op, off, _ in MC.records(buf) if op == 0x06]
    assert len(chunks) > 2
    cut = buf[:chunks[-1] + 100]                   # inside the last chunk
    with pytest.raises(LogError, match=r"container: Chunk record at byte \d+ claims"):
        read_record_bytes(cut)
    rec = read_record_bytes(cut, salvage=True)
    tip = rec.topics["/rig/accel/tip"]
    assert 0 < len(tip) < 3000
    full = read_record_bytes(buf).topics["/rig/accel/tip"]
    pd.testing.assert_frame_equal(tip, full.iloc[:len(tip)])


def io_build(msgs):
    import io
    from mcap.writer import CompressionType, Writer
    b = io.BytesIO()
    w = Writer(b, compression=CompressionType.NONE, chunk_size=20_000)
    w.start()
    ids = {}
    for topic in ("/rig/accel/tip", "/rig/temperature"):
        sid = w.register_schema(MC.SCHEMAS[topic][0], "jsonschema", MC._schema_bytes(topic))
        ids[topic] = w.register_channel(topic, "json", sid)
    w.add_metadata("test", MC.BENDING_META)
    for topic, lt, pt, data in msgs:
        w.add_message(ids[topic], log_time=lt, publish_time=pt, data=data)
    w.finish()
    return b.getvalue()


def test_unchunked_and_data_crc_files_read():
    for buf in (MC.build(chunked=False), MC.build(data_crc=True, compression="zstd")):
        rec = read_record_bytes(buf)
        assert len(rec.topics["/rig/accel/tip"]) == 400


def test_statistics_must_match_data():
    good = MC.build()
    off, _ = MC._first(good, 0x0B)
    b = bytearray(good)
    count = struct.unpack_from("<Q", b, off + 9)[0]
    struct.pack_into("<Q", b, off + 9, count + 1)
    # Re-sign the summary so only the count is wrong.
    footer = len(b) - 8 - 9 - 20
    summary_start = struct.unpack_from("<Q", b, footer + 9)[0]
    struct.pack_into("<I", b, footer + 9 + 16, zlib.crc32(bytes(b[summary_start:footer + 9 + 16])))
    with pytest.raises(LogError, match=rf"container: summary statistics count {count + 1} messages"):
        read_record_bytes(bytes(b))


def test_unknown_topics_ignored_and_dropouts_kept():
    msgs = MC.flight_messages()
    msgs.append(("/foxglove/unknown", MC.T0 + 7, MC.T0 + 7, b"not even json"))
    rec = read_record_bytes(MC.build(messages=sorted(msgs, key=lambda m: m[1]), kind="trail"))
    assert "/foxglove/unknown" not in rec.topics
    ors = rec.topics["/ors/drogue"]
    assert (~ors["valid"]).sum() == 3 and ors["x_m"].isna().sum() == 3
    assert rec.start_time_ns == MC.T0


def test_hose_id_checked_against_hardware_toml(tmp_path):
    (tmp_path / "hardware.toml").write_text('[hose.fa18_buddy]\nlength_ft = 50.0\n')
    sub = tmp_path / "ringdown"
    sub.mkdir()
    (sub / "ok.mcap").write_bytes(MC.build())
    assert read_record(sub / "ok.mcap").info.hose == "fa18_buddy"
    (sub / "bad.mcap").write_bytes(MC._meta(hose="kc135_boom"))
    with pytest.raises(LogError, match=r"bad\.mcap: metadata key 'hose': 'kc135_boom' is not a hose id"):
        read_record(sub / "bad.mcap")


def test_unreadable_path(tmp_path):
    with pytest.raises(LogError, match=r"missing\.mcap: file: cannot be read"):
        read_record(tmp_path / "missing.mcap")
    with pytest.raises(LogError, match=r"file: cannot be read"):
        read_record(tmp_path)


# ------------------------------------------------------------ corrupt corpus

@pytest.mark.parametrize("case", sorted(MC.CASES))
def test_corrupt_case_refused_by_name(tmp_path, case):
    builder, regex = MC.CASES[case]
    path = tmp_path / f"{case}.mcap"
    path.write_bytes(builder())
    with pytest.raises(LogError) as info:
        read_record(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(str(path) + ": ")
    assert re.search(regex, msg), msg


def test_corpus_script_writes_enough_cases(tmp_path):
    corpus = MC.write_corpus(tmp_path / "corpus")
    assert len(corpus) >= 30
    for path, regex in corpus:
        with pytest.raises(LogError, match=regex):
            read_record(path)


GOOD = [MC.build(kind=k, compression=c) for k, c in
        [("bending", "none"), ("trail", "zstd"), ("engagement", "lz4")]]


@st.composite
def damaged(draw):
    buf = bytearray(draw(st.sampled_from(GOOD)))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "truncate", "delete", "insert", "length"]))
        if len(buf) < 9:
            break
        i = draw(st.integers(0, len(buf) - 1))
        if op == "flip":
            buf[i] = draw(st.integers(0, 255))
        elif op == "length":
            # Lengths and times are 8-byte fields: make one absurd.
            i = min(i, len(buf) - 8)
            buf[i:i + 8] = draw(st.sampled_from([b"\xff" * 8, (1 << 63).to_bytes(8, "little"),
                                                 (1 << 40).to_bytes(8, "little")]))
        elif op == "truncate":
            del buf[i:]
        elif op == "delete":
            del buf[i:i + draw(st.integers(1, 64))]
        else:
            buf[i:i] = draw(st.binary(min_size=1, max_size=32))
    return bytes(buf)


@given(damaged())
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_damage_only_ever_raises_logerror(data):
    try:
        rec = read_record_bytes(data, name="damaged.mcap")
    except LogError as err:
        assert "\n" not in str(err) and str(err).startswith("damaged.mcap: ")
    else:
        # Damage the format cannot see (an index, a sequence number) may
        # leave a readable record; it must still honour the contract.
        assert rec.info.test_kind in S.TEST_KINDS
        for topic in S.REQUIRED_TOPICS[rec.info.test_kind]:
            assert len(rec.topics[topic]) > 0


finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
# Tracker fixes within a 2 m cube: inside any hose's reach, and no two of them
# farther apart than plausibility.MAX_TRACKER_STEP_M (the reader refuses both).
fix = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)


@given(st.lists(st.tuples(st.integers(1, 10**9), finite), min_size=1, max_size=40),
       st.lists(st.tuples(fix, fix, fix, st.booleans()), min_size=1, max_size=20),
       st.sampled_from(["zstd", "lz4", "none"]))
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_round_trip_property(tmp_path, tips, fixes, compression):
    """Whatever finite (and, for the tracker, plausible) values and increasing times a
    record holds, it reads back unchanged."""
    start = 1_650_000_000_000_000_000
    steps = np.cumsum([d for d, _ in tips])
    tip = pd.DataFrame({"a_mps2": [v for _, v in tips]}, index=pd.Index(steps / 1e9, name="t_s"))
    temp = pd.DataFrame({"t1_F": [40.0], "t2_F": [41.0]}, index=pd.Index([0.0], name="t_s"))
    valid = np.array([f[3] for f in fixes])
    ors = pd.DataFrame({k: [f[i] if f[3] else np.nan for f in fixes] for i, k in enumerate(("x_m", "y_m", "z_m"))},
                       index=pd.Index(np.arange(len(fixes)) * 0.033, name="t_s"))
    ors["valid"] = valid
    rec = make_record(MC.BENDING_META, {"/rig/accel/tip": tip, "/rig/temperature": temp,
                                        "/ors/drogue": ors}, start)
    back = read_record(write_record(tmp_path / "p.mcap", rec, compression=compression))
    for topic in rec.topics:
        got, want = back.topics[topic], rec.topics[topic]
        # Times go through integer nanoseconds: equal to the ns.
        np.testing.assert_allclose(got.index, want.index, rtol=0, atol=1e-9)
        pd.testing.assert_frame_equal(got.reset_index(drop=True), want.reset_index(drop=True))
