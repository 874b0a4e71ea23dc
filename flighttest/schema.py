"""The flight-log contract (SCHEMA.md, version 1) as data, and the typed test card.

Everything the reader and writer enforce lives here so that the contract is
read in one place: the test kinds, the metadata keys, the topics with their
fields, and which topics each kind of test needs.  Metadata arrives in the
units of the test cards (ft, KCAS, kts, deg F, lb); `TestInfo` converts it to
SI once, at this edge, and keeps the raw strings beside the converted values.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Mapping

from solver.units import FT, KT, LB, degF_to_K

SCHEMA_VERSION = "1"
METADATA_NAME = "test"
SCHEMA_ENCODING = "jsonschema"
MESSAGE_ENCODING = "json"

TEST_KINDS = ("ringdown_bending", "ringdown_axial", "pitch_doublet", "trail", "engagement")

REQUIRED_KEYS = ("schema_version", "test_id", "test_kind", "hose")
OPTIONAL_KEYS = (
    "tanker", "receiver", "altitude_ft", "airspeed_kcas", "oat_F", "temperature_F",
    "closure_rate_kts", "hose_length_ft", "section_length_m", "tip_mass_kg",
    "accel_lever_m", "repetition", "engagement", "tanker_gross_weight_lb",
    "hose_fuel", "drogue", "reel", "notes",
)
KNOWN_KEYS = REQUIRED_KEYS + OPTIONAL_KEYS
NUMERIC_KEYS = frozenset({
    "altitude_ft", "airspeed_kcas", "oat_F", "temperature_F", "closure_rate_kts",
    "hose_length_ft", "section_length_m", "tip_mass_kg", "accel_lever_m",
    "tanker_gross_weight_lb",
})
HOSE_FUEL_VALUES = ("full", "empty")

# Field kinds used by the message validator.
NUMBER = "number"                  # finite JSON number (not a bool)
NULLABLE_NUMBER = "number|null"    # finite number, or null while `valid` is false
BOOLEAN = "boolean"
EVENT = "event"                    # one of PROBE_EVENTS
POINTS = "points"                  # list of {"x_m": number, "z_m": number}
PROBE_EVENTS = ("contact", "disconnect")
POINT_FIELDS = ("x_m", "z_m")


@dataclass(frozen=True)
class TopicSpec:
    """One topic of the contract: its fields and the schema name we write."""

    topic: str
    schema_name: str
    fields: Mapping[str, str]
    nominal_rate_hz: float | None
    description: str


def _spec(topic, schema_name, fields, rate, description):
    return TopicSpec(topic, schema_name, MappingProxyType(dict(fields)), rate, description)


TOPICS: Mapping[str, TopicSpec] = MappingProxyType({s.topic: s for s in (
    _spec("/rig/accel/tip", "rig.TipAcceleration", {"a_mps2": NUMBER}, 1000.0,
          "Transverse (z, up) acceleration of the free end of the bench section, m/s^2"),
    _spec("/rig/accel/weight", "rig.WeightAcceleration",
          {"a1_mps2": NUMBER, "a2_mps2": NUMBER}, 1000.0,
          "z acceleration of the two accelerometers on the end weight, at +/- accel_lever_m, m/s^2"),
    _spec("/rig/temperature", "rig.Temperature", {"t1_F": NUMBER, "t2_F": NUMBER}, 1.0,
          "Thermocouples at the two ends of the section, deg F"),
    _spec("/air_data", "flight.AirData",
          {"altitude_ft": NUMBER, "kcas": NUMBER, "ktas": NUMBER, "oat_C": NUMBER}, 10.0,
          "Tanker air data computer"),
    _spec("/tanker/tow_point", "flight.TowPoint",
          {"x_m": NUMBER, "y_m": NUMBER, "z_m": NUMBER}, 100.0,
          "Displacement of the tow point from its trim position (tow-point frame), m"),
    _spec("/ors/drogue", "flight.OrsDrogue",
          {"x_m": NULLABLE_NUMBER, "y_m": NULLABLE_NUMBER, "z_m": NULLABLE_NUMBER,
           "valid": BOOLEAN}, 30.0,
          "Drogue centre relative to the tow point (optical reference system), m"),
    _spec("/video/hose", "flight.VideoHose", {"points": POINTS}, 10.0,
          "Hose centre-line points digitised from side-view video, tow point first, m"),
    _spec("/reel/hose_out", "flight.ReelHoseOut", {"length_m": NUMBER}, 50.0,
          "Hose length outside the pod, m"),
    _spec("/probe/events", "flight.ProbeEvent", {"event": EVENT}, None,
          "Probe/drogue coupling events"),
    _spec("/receiver/probe", "flight.ReceiverProbe",
          {"x_m": NUMBER, "y_m": NUMBER, "z_m": NUMBER}, 30.0,
          "Receiver probe tip relative to the tow point, m"),
)})

_FLIGHT = ("/air_data", "/tanker/tow_point", "/ors/drogue")
# What each kind of test needs to be analysed and compared with a simulation;
# a record without one of these is refused with the topic named.
REQUIRED_TOPICS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "ringdown_bending": ("/rig/accel/tip", "/rig/temperature"),
    "ringdown_axial": ("/rig/accel/weight",),
    "pitch_doublet": _FLIGHT,
    "trail": _FLIGHT + ("/video/hose",),
    "engagement": _FLIGHT + ("/video/hose", "/reel/hose_out", "/probe/events",
                             "/receiver/probe"),
})

# ISA sea-level speed of sound (340.294 m/s) in knots: the lowest calibrated
# airspeed at which Mach 1 is reached, so any CAS at or above it is supersonic.
SEA_LEVEL_SOUND_KT = 340.294 / KT


@dataclass(frozen=True)
class Range:
    """The physical range of a value in the units its key names, and why."""

    lo: float
    hi: float
    unit: str
    why: str
    lo_open: bool = False   # lo itself excluded ("positive")

    def holds(self, values):
        """Elementwise: which of `values` (a number or an array) lie in the range."""
        return ((values > self.lo) if self.lo_open else (values >= self.lo)) & (values <= self.hi)

    def __contains__(self, value: float) -> bool:
        return bool(self.holds(value))

    def __str__(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]{unit} ({self.why})"


_OAT = Range(-130.0, 140.0, "deg F", "air: coldest recorded -128.6 F, ISA at 65000 ft "
                                     "-69.7 F, hottest recorded 134 F")
_CHAMBER = Range(-100.0, 350.0, "deg F", "climatic-chamber range of a bench rig; absolute "
                                         "zero is -459.67 F")
_ALTITUDE = Range(-1000.0, 65000.0, "ft", "ISA range of the air-data tables")
_KCAS = Range(40.0, math.floor(SEA_LEVEL_SOUND_KT * 10.0) / 10.0, "KCAS",
              "in flight and subsonic: the top is the sea-level speed of sound")
_HOSE_FT = Range(10.0, 300.0, "ft", "trailed hose of a pod or centre-line unit")

# Every numeric test-card key, checked when the record is read.
METADATA_RANGES: Mapping[str, Range] = MappingProxyType({
    "altitude_ft": _ALTITUDE,
    "airspeed_kcas": _KCAS,
    "oat_F": _OAT,
    "temperature_F": _CHAMBER,
    "closure_rate_kts": Range(0.0, 30.0, "kt", "receiver closing on the drogue; ATP-56 "
                                               "asks for 2-5 kt", lo_open=True),
    "hose_length_ft": _HOSE_FT,
    "section_length_m": Range(0.1, 10.0, "m", "bench-rig hose section"),
    "tip_mass_kg": Range(0.0, 500.0, "kg", "bench-rig end weight", lo_open=True),
    "accel_lever_m": Range(0.0, 2.0, "m", "accelerometer offset on the end weight",
                           lo_open=True),
    "tanker_gross_weight_lb": Range(5000.0, 1.5e6, "lb", "lightest buddy tanker to "
                                                         "heavier than any aircraft flown"),
    "repetition": Range(1, 10000, "", "counts from 1"),
    "engagement": Range(1, 10000, "", "counts from 1"),
})

# Message fields with a physical range (the others are signed displacements and
# accelerations: finite is all the contract says of them one by one).
FIELD_RANGES: Mapping[tuple[str, str], Range] = MappingProxyType({
    ("/air_data", "altitude_ft"): _ALTITUDE,
    ("/air_data", "kcas"): _KCAS,
    ("/air_data", "ktas"): Range(40.0, 720.0, "kt", "in flight and subsonic: the speed of "
                                                  "sound in +60 C air is 711 kt"),
    ("/air_data", "oat_C"): Range(-90.0, 60.0, "deg C", _OAT.why),
    ("/rig/temperature", "t1_F"): _CHAMBER,
    ("/rig/temperature", "t2_F"): _CHAMBER,
    ("/reel/hose_out", "length_m"): Range(0.0, _HOSE_FT.hi * FT, "m",
                                          "hose outside the pod, at most the longest hose"),
})


class MetadataError(ValueError):
    """A metadata value breaks the contract; `key` names the offending key."""

    def __init__(self, key: str, problem: str):
        super().__init__(f"metadata key {key!r}: {problem}")
        self.key = key
        self.problem = problem


def _number(raw: Mapping[str, str], key: str) -> float | None:
    if key not in raw:
        return None
    text = raw[key]
    try:
        value = float(text)
    except ValueError:
        raise MetadataError(key, f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise MetadataError(key, f"{text!r} is not finite")
    return value


def _integer(raw: Mapping[str, str], key: str) -> int | None:
    if key not in raw:
        return None
    text = raw[key]
    try:
        return int(text.strip())
    except ValueError:
        raise MetadataError(key, f"{text!r} is not an integer") from None


def _scaled(value: float | None, factor: float) -> float | None:
    return None if value is None else value * factor


@dataclass(frozen=True)
class TestInfo:
    """The `test` metadata record, converted to SI.

    Absolute temperatures are kelvin (`_K`); `raw` keeps every string as
    logged, in the test-card units its key names.
    """

    __test__ = False  # keeps pytest from collecting this class as a test case

    schema_version: str
    test_id: str
    test_kind: str
    hose: str
    tanker: str | None = None
    receiver: str | None = None
    drogue: str | None = None
    reel: str | None = None
    hose_fuel: str | None = None
    notes: str | None = None
    repetition: int | None = None
    engagement: int | None = None
    altitude_m: float | None = None
    calibrated_airspeed_mps: float | None = None
    oat_K: float | None = None
    temperature_K: float | None = None
    closure_rate_mps: float | None = None
    hose_length_m: float | None = None
    section_length_m: float | None = None
    tip_mass_kg: float | None = None
    accel_lever_m: float | None = None
    tanker_gross_weight_kg: float | None = None
    raw: Mapping[str, str] = field(default_factory=dict)

    @property
    def temperature_setpoint_F(self) -> float | None:
        """The test-card temperature in deg F, the unit setpoints are grouped by."""
        return _number(self.raw, "temperature_F")

    @classmethod
    def from_metadata(cls, raw: Mapping[str, str]) -> "TestInfo":
        """Validate a `test` metadata mapping and convert it.

        Raises `MetadataError` naming the key for a missing required key, an
        unknown key, a non-string value, an unknown test kind, an unsupported
        schema version, a value that does not parse, or a number outside its
        physical range (`METADATA_RANGES`, the range named in the message).
        """
        for key, value in raw.items():
            if key not in KNOWN_KEYS:
                raise MetadataError(key, "unknown key (contract version 1 does not define it)")
            if not isinstance(value, str):
                raise MetadataError(key, f"value must be a string, got {type(value).__name__}")
        for key in REQUIRED_KEYS:
            if key not in raw:
                raise MetadataError(key, "required key is missing")
            if not raw[key].strip():
                raise MetadataError(key, "required key is empty")
        if raw["schema_version"] != SCHEMA_VERSION:
            raise MetadataError("schema_version", f"unsupported version {raw['schema_version']!r}"
                                f" (this reader knows {SCHEMA_VERSION!r})")
        if raw["test_kind"] not in TEST_KINDS:
            raise MetadataError("test_kind", f"unknown test kind {raw['test_kind']!r}"
                                f" (expected one of {', '.join(TEST_KINDS)})")
        if "hose_fuel" in raw and raw["hose_fuel"] not in HOSE_FUEL_VALUES:
            raise MetadataError("hose_fuel", f"{raw['hose_fuel']!r} is not one of "
                                f"{', '.join(HOSE_FUEL_VALUES)}")
        nums = {key: _number(raw, key) for key in NUMERIC_KEYS}
        ints = {key: _integer(raw, key) for key in ("repetition", "engagement")}
        for key, value in {**nums, **ints}.items():
            if value is not None and value not in METADATA_RANGES[key]:
                raise MetadataError(key, f"{raw[key]!r} is outside the physical range "
                                         f"{METADATA_RANGES[key]}")
        oat_F, temp_F = nums["oat_F"], nums["temperature_F"]
        return cls(
            schema_version=raw["schema_version"],
            test_id=raw["test_id"],
            test_kind=raw["test_kind"],
            hose=raw["hose"],
            tanker=raw.get("tanker"),
            receiver=raw.get("receiver"),
            drogue=raw.get("drogue"),
            reel=raw.get("reel"),
            hose_fuel=raw.get("hose_fuel"),
            notes=raw.get("notes"),
            repetition=ints["repetition"],
            engagement=ints["engagement"],
            altitude_m=_scaled(nums["altitude_ft"], FT),
            calibrated_airspeed_mps=_scaled(nums["airspeed_kcas"], KT),
            oat_K=None if oat_F is None else degF_to_K(oat_F),
            temperature_K=None if temp_F is None else degF_to_K(temp_F),
            closure_rate_mps=_scaled(nums["closure_rate_kts"], KT),
            hose_length_m=_scaled(nums["hose_length_ft"], FT),
            section_length_m=nums["section_length_m"],
            tip_mass_kg=nums["tip_mass_kg"],
            accel_lever_m=nums["accel_lever_m"],
            tanker_gross_weight_kg=_scaled(nums["tanker_gross_weight_lb"], LB),
            raw=MappingProxyType(dict(raw)),
        )


def hardware_ids(toml_text: str, section: str = "hose") -> set[str]:
    """Ids declared as `[section.<id>]` in a hardware.toml text."""
    import tomllib

    table = tomllib.loads(toml_text).get(section, {})
    return {key for key, value in table.items() if isinstance(value, dict)}
