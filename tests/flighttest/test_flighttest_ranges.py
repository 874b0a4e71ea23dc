"""Bad values never reach the numbers: physical ranges, implausible tracks, oversized files.

Each refusal is a LogError whose one line names the file, the key or topic,
the value and the allowed range; what is legal but suspicious is reported in
the record's warnings and in `analyze_record`'s output.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).parent))
import make_corrupt as MC  # noqa: E402

from flighttest import FlightRecord, LogError, analyze_record, make_record, read_record  # noqa: E402
from flighttest import read_record_bytes, write_record  # noqa: E402
from flighttest.plausibility import MAX_TRACKER_STEP_M, REACH_MARGIN  # noqa: E402
from flighttest.reader import MAX_RECORD_BYTES  # noqa: E402
from flighttest.schema import FIELD_RANGES, METADATA_RANGES, TestInfo  # noqa: E402


def _refused(path: Path) -> str:
    with pytest.raises(LogError) as info:
        read_record(path)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


# ------------------------------------------------------------ test-card ranges

METADATA_ATTACKS = [
    ("airspeed_kcas", "1e-9"), ("airspeed_kcas", "0"), ("airspeed_kcas", "-255"),
    ("airspeed_kcas", "700"),                      # supersonic at any altitude
    ("altitude_ft", "1e6"), ("altitude_ft", "-2000"),
    ("oat_F", "-1000"),                            # below absolute zero
    ("oat_F", "-200"), ("oat_F", "200"),
    ("temperature_F", "-460"),                     # below absolute zero
    ("temperature_F", "1000"),
    ("hose_length_ft", "0.01"), ("hose_length_ft", "0"), ("hose_length_ft", "-75"),
    ("hose_length_ft", "5000"),
    ("section_length_m", "0"), ("section_length_m", "-1.22"), ("section_length_m", "100"),
    ("tip_mass_kg", "0"), ("tip_mass_kg", "-12"), ("tip_mass_kg", "1e9"),
    ("accel_lever_m", "0"), ("accel_lever_m", "5"),
    ("tanker_gross_weight_lb", "1e30"), ("tanker_gross_weight_lb", "0"),
    ("tanker_gross_weight_lb", "100"),
    ("closure_rate_kts", "0"), ("closure_rate_kts", "-4"), ("closure_rate_kts", "500"),
    ("repetition", "0"), ("repetition", "-1"), ("engagement", "0"),
]


@pytest.mark.parametrize("key,value", METADATA_ATTACKS, ids=lambda v: str(v))
def test_metadata_outside_its_physical_range_is_refused(tmp_path, key, value):
    path = tmp_path / "card.mcap"
    path.write_bytes(MC._meta("trail", **{key: value}))
    assert _refused(path) == (f"{path}: metadata key {key!r}: {value!r} is outside the physical "
                              f"range {METADATA_RANGES[key]}")


def test_every_numeric_metadata_key_has_a_range():
    from flighttest.schema import NUMERIC_KEYS
    assert NUMERIC_KEYS | {"repetition", "engagement"} == set(METADATA_RANGES)
    assert {k for k, _ in METADATA_ATTACKS} == set(METADATA_RANGES)


def test_range_edges():
    """Bounds are the stated ones: closed unless `lo_open`; "positive" excludes 0."""
    kcas = METADATA_RANGES["airspeed_kcas"]
    assert 40.0 in kcas and kcas.hi in kcas and np.nextafter(kcas.hi, 1e9) not in kcas
    # The subsonic bound is below the ISA sea-level speed of sound, 661.479 kt.
    assert kcas.hi < 340.294 / (1852.0 / 3600.0)
    assert 0.0 not in METADATA_RANGES["tip_mass_kg"] and 1e-6 in METADATA_RANGES["tip_mass_kg"]


# -------------------------------------------------------------- message ranges

FIELD_ATTACKS = [
    ("trail", "/air_data", "kcas", 1e-9, 2),
    ("trail", "/air_data", "kcas", 900.0, 2),
    ("trail", "/air_data", "altitude_ft", 1e6, 3),
    ("trail", "/air_data", "ktas", -316.0, 3),
    ("trail", "/air_data", "oat_C", -300.0, 4),
    ("bending", "/rig/temperature", "t1_F", -500.0, 1),
    ("bending", "/rig/temperature", "t2_F", 1000.0, 0),
    ("engagement", "/reel/hose_out", "length_m", -1.0, 6),
]


def _air(**change):
    return MC._js(dict({"altitude_ft": 15000.0, "kcas": 255.0, "ktas": 316.0, "oat_C": -16.7}, **change))


@pytest.mark.parametrize("kind,topic,name,value,at", FIELD_ATTACKS, ids=lambda v: str(v))
def test_message_field_outside_its_physical_range_is_refused(tmp_path, kind, topic, name, value, at):
    data = {"/air_data": lambda: _air(**{name: value}),
            "/rig/temperature": lambda: MC._js(dict({"t1_F": 40.0, "t2_F": 40.0}, **{name: value})),
            "/reel/hose_out": lambda: MC._js({name: value})}[topic]()
    path = tmp_path / "field.mcap"
    path.write_bytes(MC._with_message(topic, data, kind=kind, at=at))
    msg = _refused(path)
    rng = FIELD_RANGES[(topic, name)]
    assert re.fullmatch(rf"{re.escape(str(path))}: topic {topic}: message {at} \(log_time \d+\): "
                        rf"field '{name}' = {re.escape(f'{value:g}')} is outside the physical "
                        rf"range {re.escape(str(rng))}", msg), msg


# ----------------------------------------------------- implausible tracker fixes

def _flight(ors_xyz, valid=None, n=None, dt_ns=100_000_000, meta=None, drop_air=()):
    """A trail record whose tracker reads `ors_xyz[i]` at sample i."""
    n = len(ors_xyz) if n is None else n
    valid = [True] * n if valid is None else valid
    msgs = []
    for i in range(n):
        t = MC.T0 + i * dt_ns
        if i not in drop_air:
            msgs.append(("/air_data", t, t, _air()))
        tow = MC._js({"x_m": 0.0, "y_m": 0.0, "z_m": 0.0})
        msgs.append(("/tanker/tow_point", t + 1000, t + 1000, tow))
        x, y, z = ors_xyz[i]
        pos = {"x_m": x, "y_m": y, "z_m": z} if valid[i] else {"x_m": None, "y_m": None, "z_m": None}
        msgs.append(("/ors/drogue", t + 2000, t + 2000, MC._js(dict(pos, valid=valid[i]))))
        pts = [{"x_m": 1.5 * k, "z_m": -0.12 * k} for k in range(12)]
        msgs.append(("/video/hose", t + 3000, t + 3000, MC._js({"points": pts})))
    metas = [("test", dict(MC.TRAIL_META if meta is None else meta))]
    return MC.build(metas=metas, messages=sorted(msgs, key=lambda m: m[1]), kind="trail")


STEADY = [(22.6, 1.3 + 0.01 * (i % 3), -2.8) for i in range(40)]


def test_tracker_z_scaled_by_minus_1000_is_refused(tmp_path):
    path = tmp_path / "scaled.mcap"
    path.write_bytes(_flight([(x, y, -1000.0 * z) for x, y, z in STEADY]))
    reach = REACH_MARGIN * 75 * 0.3048
    d0 = float(np.linalg.norm(STEADY[0][:2] + (2800.0,)))
    assert _refused(path) == (f"{path}: topic /ors/drogue: fix at t_s=0.000 is {d0:.4g} m from the "
                              f"tow point, beyond the hose's reach [0, {reach:.4g}] m "
                              f"({REACH_MARGIN:g} x hose_length_ft)")


def test_reach_without_hose_length_is_that_of_the_longest_hose(tmp_path):
    meta = {k: v for k, v in MC.TRAIL_META.items() if k != "hose_length_ft"}
    fixes = list(STEADY)
    fixes[7] = (22.6, 1.3, 150.0)
    path = tmp_path / "far.mcap"
    path.write_bytes(_flight(fixes, meta=meta))
    reach = REACH_MARGIN * 300 * 0.3048
    assert _refused(path).endswith(f"fix at t_s=0.700 is {np.linalg.norm(fixes[7]):.4g} m from the tow "
                                   f"point, beyond the hose's reach [0, {reach:.4g}] m "
                                   f"({REACH_MARGIN:g} x the longest hose)")


def test_tracker_jump_between_consecutive_fixes_is_refused(tmp_path):
    fixes = list(STEADY)
    fixes[12] = (22.6, 13.3, -2.8)              # 12 m sideways, still within the hose's reach
    path = tmp_path / "jump.mcap"
    path.write_bytes(_flight(fixes))
    step = float(np.linalg.norm(np.subtract(fixes[12], fixes[11])))
    assert step > MAX_TRACKER_STEP_M
    assert _refused(path) == (f"{path}: topic /ors/drogue: consecutive valid fixes at t_s=1.100 and "
                              f"1.200 are {step:.4g} m apart, over the {MAX_TRACKER_STEP_M:g} m a "
                              f"drogue can move between fixes")


def test_a_jump_across_a_dropout_is_measured_between_the_valid_fixes(tmp_path):
    """Fixes lost in between do not hide a jump: consecutive *valid* fixes are compared."""
    fixes = list(STEADY)
    fixes[14] = (22.6, 13.3, -2.8)
    valid = [not 11 < i < 14 for i in range(40)]
    path = tmp_path / "jump2.mcap"
    path.write_bytes(_flight(fixes, valid=valid))
    assert "consecutive valid fixes at t_s=1.100 and 1.400" in _refused(path)


def test_gaps_are_reported_not_refused(tmp_path):
    valid = [not 10 <= i < 35 for i in range(40)]     # tracker lost for 2.5 s
    path = tmp_path / "gaps.mcap"
    path.write_bytes(_flight(STEADY, valid=valid, drop_air=range(5, 20)))
    rec = read_record(path)
    assert rec.warnings == [
        "topic /air_data: no message for 1.6 s from t_s=0.400 (nominal rate 10 Hz)",
        "topic /ors/drogue: no valid fix for 2.6 s from t_s=0.900",
    ]
    out = analyze_record(rec)
    assert out["warnings"] == rec.warnings
    # The figures measured from the rest are still there.
    assert out["drogue_steady_x_m"] == pytest.approx(22.6, abs=1e-12)


def test_clean_record_has_no_warnings_key():
    rec = read_record_bytes(_flight(STEADY))
    assert rec.warnings == [] and "warnings" not in analyze_record(rec)


def test_writer_refuses_what_the_reader_would(tmp_path):
    rec = read_record_bytes(_flight(STEADY))
    ors = rec.topics["/ors/drogue"].copy()
    ors.iloc[5, ors.columns.get_loc("z_m")] = 2800.0
    bad = make_record(rec.info, dict(rec.topics, **{"/ors/drogue": ors}), rec.start_time_ns)
    with pytest.raises(LogError, match=r"topic /ors/drogue: fix at t_s=0\.500 is .* beyond the hose"):
        write_record(tmp_path / "w.mcap", bad)
    assert not list(tmp_path.iterdir())


# ----------------------------------------------------- files checked before read

def test_oversized_file_refused_before_it_is_read(tmp_path):
    path = tmp_path / "huge.mcap"
    with open(path, "wb") as fh:
        fh.write(MC.build()[:64])
        fh.truncate(MAX_RECORD_BYTES + 1)           # sparse: no disk, no memory
    assert _refused(path) == (f"{path}: file: is {MAX_RECORD_BYTES + 1} bytes, over the "
                              f"{MAX_RECORD_BYTES} byte (512 MiB) limit for one record")


def test_bad_magic_refused_from_the_first_bytes(tmp_path, monkeypatch):
    path = tmp_path / "notes.mcap"
    path.write_bytes(b"time,a\n" + b"0,1\n" * 1000)
    reads = []
    import builtins
    real_open = builtins.open

    def spy(file, mode="r", *a, **k):
        fh = real_open(file, mode, *a, **k)
        if str(file) == str(path):
            real_read = fh.read
            fh.read = lambda n=-1: reads.append(n) or real_read(n)
        return fh
    monkeypatch.setattr(builtins, "open", spy)
    assert _refused(path) == f"{path}: container: not an MCAP file (bad magic at byte 0)"
    assert reads == [8]                              # only the magic was read


# ------------------------------------------------------------------ accessors

def _ors(rows):
    df = pd.DataFrame(rows, columns=["x_m", "y_m", "z_m", "valid"],
                      index=pd.Index(np.arange(len(rows)) * 0.1, name="t_s"))
    df["valid"] = df["valid"].astype(bool)
    return df


def test_tracker_fixes_are_valid_and_finite():
    ors = _ors([(1.0, 0.0, -1.0, True), (np.nan, np.nan, np.nan, False),
                (2.0, np.nan, -1.0, True), (3.0, 0.0, -1.0, False), (4.0, 0.0, -1.0, True)])
    rec = make_record(MC.TRAIL_META, {"/ors/drogue": ors}, MC.T0)
    fixes = rec.tracker_fixes()
    assert list(fixes["x_m"]) == [1.0, 4.0]
    pd.testing.assert_frame_equal(fixes, ors.iloc[[0, 4]])


def test_tracker_fixes_of_a_record_without_tracker():
    rec = read_record_bytes(MC.build())
    with pytest.raises(LogError, match=r"topic /ors/drogue: needed here but absent"):
        rec.tracker_fixes()


@pytest.mark.parametrize("events,expected", [
    ([(0.5, "contact"), (1.5, "disconnect")], (0.5, 1.5)),
    ([(0.2, "disconnect"), (0.5, "contact"), (0.9, "contact"), (1.5, "disconnect")], (0.5, 1.5)),
    ([(0.5, "contact")], (0.5, None)),
    ([(0.4, "disconnect")], (None, None)),
])
def test_contact_events(events, expected):
    ev = pd.DataFrame({"event": [e for _, e in events]},
                      index=pd.Index([t for t, _ in events], name="t_s"))
    rec = make_record(MC.ENGAGE_META, {"/probe/events": ev}, MC.T0)
    assert rec.contact_events() == expected


def test_contact_events_of_a_read_engagement():
    assert read_record_bytes(MC.build(kind="engagement")).contact_events() == pytest.approx((0.5, 1.5))


# --------------------------------------------------- random test-card values

_number_text = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.floats(-1e7, 1e7).map(lambda v: f"{v:g}"),
    st.integers(-10**6, 10**6).map(str),
    st.text(max_size=12),
)


@given(st.dictionaries(st.sampled_from(sorted(METADATA_RANGES)), _number_text, max_size=6))
@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_metadata_gives_a_record_or_one_line_logerror(changes):
    meta = dict(MC.TRAIL_META, **changes)
    try:
        rec = read_record_bytes(MC.build(metas=[("test", meta)], kind="trail"), name="random.mcap")
    except LogError as err:
        msg = str(err)
        assert "\n" not in msg and msg.startswith("random.mcap: ")
        if msg.startswith("random.mcap: metadata key '"):
            assert msg.split("'")[1] in changes
        else:
            # a legal card value the data contradict (a hose too short for the logged fixes):
            # the one line names the key it checked against
            assert any(key in msg for key in changes), msg
        return
    assert isinstance(rec, FlightRecord)
    info: TestInfo = rec.info
    for key in changes:
        value = float(info.raw[key])
        assert value in METADATA_RANGES[key], (key, value)
    assert dict(info.raw) == meta  # the card as logged, beside the SI values
