"""Cases: TOML files in `cases/` that say what to simulate (data, not code).

A case names the hardware (ids in `hardware.toml`), the flight or bench
condition, the model options and the prescribed motions. Every key is checked
here; a wrong one is refused with one line naming the file, table, key and
what is wrong. `build_model` turns a checked case into a `solver.Model`.

Layout (every table but [hardware] and [condition] is optional):

    id = "..."                      title = "..."
    kind = "trail"                  # ringdown_bending | ringdown_axial | pitch_doublet | trail | engagement
    [hardware]   hose, drogue, reel, tanker
    [condition]  altitude_ft, airspeed_kcas, hose_fuel ("full" | "empty"), hose_length_ft,
                 oat_F (outside air temperature; default the ISA standard day)
    [model]      n_elements, drogue_lift_scale, drogue_drag_scale, reel ("locked" | "drum"),
                 reel_torque_law, hinge_damping_N_m_s, hinge_friction_N_m
    [model.structure]  source = "table" (default): the bench property tables
                 (cases/properties) at the hose temperature (temperature_F, else the
                 log's or the condition's outside air temperature); any other source
                 text: the constants given, EI_N_m2, EA_N, bending_damping_N_m2_s,
                 axial_damping_N_s
    [tow_motion] kind ("none" | "sine_doublet"), amplitude_m, period_s, start_s
    [run]        duration_s, record_dt_s
    [effects.NAME]  unmodelled effects by name with their parameters (`solver.effects`;
                 `workbench.effects_case`), e.g. [effects.tanker_wake] strength = 1.0
    [[variants]] id, label, drogue_lift_scale, drogue_drag_scale, reel, tune_drogue_lift_on,
                 calibrate, calibrate_on
    [[gates]]    metric, variant, logs, max | min, abs, source, part60: must pass (`workbench.gates`)
    [[findings]] metric, variant, logs, expected, band, source, band_source: what a reference
                 model gets wrong, and how far that may move before it counts as a change
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from flighttest.schema import METADATA_RANGES, Range
from solver.atmosphere import isa, kcas_to_tas
from solver.drogue import DrogueProperties
from solver.effects import EFFECTS
from solver.hose import HoseProperties
from solver.model import Model, Trajectory
from solver.reel import ReelProperties
from solver.units import FT, K_to_degF, degF_to_K
from solver.wind import freestream
from workbench.budget import MAX_DURATION_S
from workbench.config import defaults
from workbench.errors import InputError
from workbench.gates import METRICS
from workbench.hardware import Hardware, load_hardware, read_toml
from workbench.outputs import is_safe_id

KINDS = ("ringdown_bending", "ringdown_axial", "pitch_doublet", "trail", "engagement")
ARRAY_TABLES = ("variants", "gates", "findings")


@dataclass(frozen=True)
class Field:
    kind: type | tuple
    default: Any = None
    check: Optional[Callable[[Any], Optional[str]]] = None   # returns a complaint or None
    required: bool = False


def _nonneg(v):
    return None if v >= 0 else "must not be negative"


def _one_of(*opts):
    return lambda v: None if v in opts else f"must be one of {', '.join(map(repr, opts))}"


def _int_range(lo, hi):
    return lambda v: None if lo <= v <= hi else f"must lie in {lo}..{hi}"


def _within(r: Range):
    return lambda v: None if v in r else f"must lie in {r}"


def _range(lo, hi, unit, why, lo_open=False):
    return _within(Range(lo, hi, unit, why, lo_open))


def _still_or(r: Range):
    """0 (still air: a bench case) or a value in `r`."""
    return lambda v: None if v == 0 or v in r else f"must be 0 (still air) or lie in {r}"


# The test card's ranges (flighttest.schema) hold for the same keys of a case:
# a case describes a flight the logs could have recorded.
_CARD = METADATA_RANGES
# The drogue's lift and drag factors: the registry's physical range of the
# drogue_lift / drogue_drag effects' scale (solver.effects), so [model],
# [[variants]] and [effects.*] agree on what is physical.
_LIFT = EFFECTS["drogue_lift"].params["scale"]
_DRAG = EFFECTS["drogue_drag"].params["scale"]
_LIFT_RANGE = Range(_LIFT.lo, _LIFT.hi, "", "registry range of drogue_lift scale")
_DRAG_RANGE = Range(_DRAG.lo, _DRAG.hi, "", "registry range of drogue_drag scale")
# An element shorter than this (about the hose diameter) is no longer a slender
# rod, and its stable step (cost ~ 1/l^2) makes a run of minutes out of seconds.
MIN_ELEMENT_M = 0.05


def _id(v):
    return None if is_safe_id(v) else ("must be 1-100 letters, digits, '.', '_' or '-', not starting with '.' "
                                        "(it names output files)")


NUM = (int, float)
SCHEMA = {
    "": {
        "id": Field(str, required=True, check=_id),
        "title": Field(str, ""),
        "kind": Field(str, required=True, check=_one_of(*KINDS)),
        "description": Field(str, ""),
        "logs": Field(list, []),
    },
    "hardware": {
        "hose": Field(str, required=True),
        "drogue": Field(str),
        "reel": Field(str),
        "tanker": Field(str),
    },
    "condition": {
        "altitude_ft": Field(NUM, 0.0, _within(_CARD["altitude_ft"])),
        "airspeed_kcas": Field(NUM, 0.0, _still_or(_CARD["airspeed_kcas"])),
        "hose_fuel": Field(str, "full", _one_of("full", "empty")),
        "hose_length_ft": Field(NUM, None, _within(_CARD["hose_length_ft"])),
        "oat_F": Field(NUM, None, _within(_CARD["oat_F"])),
        "tanker_gross_weight_lb": Field(NUM, None, _within(_CARD["tanker_gross_weight_lb"])),
        "from_log": Field(bool, False),
    },
    "model": {
        "n_elements": Field(int, 40, _int_range(4, 200)),
        "drogue_lift_scale": Field(NUM, 1.0, _within(_LIFT_RANGE)),
        "drogue_drag_scale": Field(NUM, 1.0, _within(_DRAG_RANGE)),
        "reel": Field(str, "locked", _one_of("locked", "drum", "from_log")),
        "drogue_after_contact": Field(str, "free", _one_of("free", "from_log")),
        # probe-drogue coupling: an assumed compliance (probe mast and the coupling's
        # latch rollers), not a measured one; 0 holds the drogue rigidly on the probe
        "probe_coupling_N_m": Field(NUM, 2.0e5, _range(0.0, 1e8, "N/m", "0 rigid .. 100 MN/m, far stiffer "
                                                                        "than any probe mast")),
        "probe_coupling_damping_ratio": Field(NUM, 0.7, _range(0.0, 2.0, "", "undamped .. twice critical")),
        "reel_torque_law": Field(str, "constant_tension", _one_of("constant_tension", "constant_torque")),
        "reel_torque_N_m": Field(NUM, None, _range(0.0, 1e5, "N m", "a reel drive's torque", lo_open=True)),
        "hinge_damping_N_m_s": Field(NUM, 0.0, _range(0.0, 1e4, "N m s", "the drogue hinge: beyond this "
                                                                         "it is a clamp")),
        "hinge_friction_N_m": Field(NUM, 0.0, _range(0.0, 1e4, "N m", "the drogue hinge's friction moment")),
    },
    "model.structure": {
        "source": Field(str, "table"),
        "EI_N_m2": Field(NUM, None, _range(0.1, 1e5, "N m^2", "refuelling hoses: 10-1000 N m^2")),
        "EA_N": Field(NUM, None, _range(1e3, 1e9, "N", "refuelling hoses: about 1e6-1e7 N")),
        "bending_damping_N_m2_s": Field(NUM, 0.0, _range(0.0, 1e3, "N m^2 s", "the bench tables: below 10")),
        "axial_damping_N_s": Field(NUM, 0.0, _range(0.0, 1e6, "N s", "the bench tables: below 1e4")),
        "temperature_F": Field(NUM, None, _within(_CARD["temperature_F"])),
        "allow_extrapolation": Field(bool, False),
    },
    "tow_motion": {
        "kind": Field(str, "none", _one_of("none", "sine_doublet", "from_log")),
        "amplitude_m": Field(NUM, 0.0, _range(0.0, 10.0, "m", "a tow-point excursion a tanker flies")),
        "period_s": Field(NUM, 2.0, _range(0.1, 100.0, "s", "a pilot's doublet")),
        "start_s": Field(NUM, 1.0, _range(0.0, 3600.0, "s", "inside the longest run")),
    },
    "variants": {
        "id": Field(str, required=True, check=_id),
        "label": Field(str, ""),
        "drogue_lift_scale": Field(NUM, None, _within(_LIFT_RANGE)),
        "drogue_drag_scale": Field(NUM, None, _within(_DRAG_RANGE)),
        "reel": Field(str, None, _one_of("locked", "drum", "from_log")),
        "tune_drogue_lift_on": Field(list, []),
        "calibrate": Field(list, []),
        "calibrate_on": Field(list, []),
        # form parameters ("effect.parameter", `Effect.refined`) of the calibrated effects, fitted with them
        "refine": Field(list, []),
    },
    "gates": {
        "metric": Field(str, required=True),
        "variant": Field(str, None),
        "logs": Field(list, []),
        "max": Field(NUM, None),
        "min": Field(NUM, None),
        "abs": Field(bool, True),
        "source": Field(str, required=True),
        "part60": Field(str, None),   # the 14 CFR Part 60 objective-test tolerance, where one applies
    },
    # what a reference model gets wrong (`workbench.gates`): its mean over the
    # variant's held-out logs must stay within expected +- band
    "findings": {
        "metric": Field(str, required=True),
        "variant": Field(str, None),   # default: the case's first variant, as for a gate
        "logs": Field(list, []),
        "expected": Field(NUM, required=True),
        "band": Field(NUM, required=True, check=_nonneg),
        "source": Field(str, required=True),
        "band_source": Field(str, required=True),
    },
    "run": {
        "duration_s": Field(NUM, None, _range(0.0, MAX_DURATION_S, "s", "an hour of flight", lo_open=True)),
        # the lower bound is the finest stable step of the models the schema allows;
        # `workbench.budget` holds each run to its own model's step
        "record_dt_s": Field(NUM, 0.01, _range(1e-4, 10.0, "s", "the solver's step .. a 0.1 Hz record")),
    },
}


@dataclass(frozen=True)
class Case:
    path: str
    id: str
    kind: str
    title: str
    tables: dict = field(repr=False)

    def __getitem__(self, table: str) -> dict:
        return self.tables[table]


def _check_calibration(p: Path, v: dict) -> None:
    where = f"{p}: [[variants]] '{v['id']}'"
    if not (v["calibrate"] and v["calibrate_on"]):
        raise InputError(f"{where} needs both calibrate (effects) and calibrate_on (training logs)")
    # a transient at one log's own time (a gust's, `Param.scan_s`) is no calibration of a fleet of logs
    known = [e for e, eff in EFFECTS.items() if eff.calibrated and not eff.scanned]
    for e in v["calibrate"]:
        if e not in known:
            why = (EFFECTS[e].not_calibrated or "a transient at one log's own time") if e in EFFECTS \
                else f"known: {', '.join(known)}"
            raise InputError(f"{where} calibrate: effect {e!r} cannot be calibrated ({why})")
    for item in v["refine"]:
        e, _, name = str(item).partition(".")
        if e not in v["calibrate"] or name not in EFFECTS[e].refined:
            forms = [f"{x}.{k}" for x in v["calibrate"] for k in EFFECTS[x].refined]
            raise InputError(f"{where} refine: {item!r} is no form parameter of a calibrated effect "
                             f"(known: {', '.join(forms) or 'none'})")


def _check_table(path: str, name: str, raw: dict) -> dict:
    schema = SCHEMA[name]
    where = f"[{name}] " if name else ""
    out = {}
    for key, value in raw.items():
        if isinstance(value, dict) and f"{name}.{key}".strip(".") in SCHEMA:
            continue
        if key not in schema:
            raise InputError(f"{path}: {where}unknown key '{key}' (known: {', '.join(schema)})")
        f = schema[key]
        if f.kind is list:
            ok = isinstance(value, list) and all(isinstance(v, str) for v in value)
        else:
            ok = isinstance(value, f.kind) and not (isinstance(value, bool) and f.kind in (NUM, int))
        if not ok:
            want = {list: "a list of strings", bool: "true or false", int: "an integer",
                    str: "a string"}.get(f.kind, "a number")
            raise InputError(f"{path}: {where}{key} must be {want}, got {value!r}")
        if isinstance(value, float) and not math.isfinite(value):
            raise InputError(f"{path}: {where}{key} must be finite, got {value!r}")
        if f.check is not None:
            msg = f.check(value)
            if msg:
                raise InputError(f"{path}: {where}{key} {msg}, got {value!r}")
        out[key] = value
    for key, f in schema.items():
        if key not in out:
            if f.required:
                raise InputError(f"{path}: {where}missing required key '{key}'")
            out[key] = f.default
    return out


def load_case(path: str | Path) -> Case:
    p = Path(path)
    raw = read_toml(p, "case file")
    tables = {}
    arrays = {k: v for k, v in raw.items() if k in ARRAY_TABLES}
    for k, v in arrays.items():
        if not (isinstance(v, list) and all(isinstance(x, dict) for x in v)):
            raise InputError(f"{p}: {k} must be an array of tables ([[{k}]])")
    tables[""] = _check_table(str(p), "", {k: v for k, v in raw.items()
                                           if not isinstance(v, dict) and k not in ARRAY_TABLES})
    for key, value in raw.items():
        if key == "effects":
            from workbench.effects_case import check_effects_table
            tables["effects"] = check_effects_table(str(p), value)
            continue
        if isinstance(value, dict):
            if key not in SCHEMA or key in ARRAY_TABLES:
                known = ", ".join(k for k in SCHEMA if k and "." not in k and k not in ARRAY_TABLES)
                raise InputError(f"{p}: unknown table [{key}] (known: {known})")
            tables[key] = _check_table(str(p), key, value)
            for sub, subval in value.items():
                if isinstance(subval, dict):
                    name = f"{key}.{sub}"
                    if name not in SCHEMA:
                        raise InputError(f"{p}: unknown table [{name}]")
                    tables[name] = _check_table(str(p), name, subval)
    tables.setdefault("effects", {})
    for name in ARRAY_TABLES:
        tables[name] = [_check_table(str(p), name, item) for item in arrays.get(name, [])]
    ids = [v["id"] for v in tables["variants"]]
    if len(set(ids)) != len(ids):
        raise InputError(f"{p}: [[variants]] ids must be unique, got {ids}")
    for v in tables["variants"]:
        if v["calibrate"] or v["calibrate_on"] or v["refine"]:
            _check_calibration(p, v)
    for g in tables["gates"]:
        if g["max"] is None and g["min"] is None:
            raise InputError(f"{p}: [[gates]] metric '{g['metric']}' needs a max or a min threshold")
    kind = tables[""]["kind"]
    for name in ("gates", "findings"):
        for g in tables[name]:
            if g["metric"] not in METRICS[kind]:
                raise InputError(f"{p}: [[{name}]] metric '{g['metric']}' is not a {kind} metric "
                                 f"(known: {', '.join(sorted(METRICS[kind]))})")
            if g["variant"] is not None and g["variant"] not in ids:
                raise InputError(f"{p}: [[{name}]] metric '{g['metric']}' names unknown variant "
                                 f"'{g['variant']}'")
    for name in SCHEMA:
        if name in ARRAY_TABLES:
            continue
        if name not in tables:
            if any(f.required for f in SCHEMA[name].values()) and name != "model.structure":
                raise InputError(f"{p}: missing table [{name}]")
            if name != "model.structure":
                tables[name] = _check_table(str(p), name, {})
    if "model.structure" not in tables:
        tables["model.structure"] = _check_table(str(p), "model.structure", {})
    st = tables["model.structure"]
    if st["source"] != "table" and (st["EI_N_m2"] is None or st["EA_N"] is None):
        raise InputError(f"{p}: [model.structure] source '{st['source']}' is not 'table', so EI_N_m2 and "
                         f"EA_N must be given")
    _check_condition(p, tables)
    top = tables[""]
    return Case(str(p), top["id"], top["kind"], top["title"], tables)


FLIGHT_KINDS = ("pitch_doublet", "trail", "engagement")


def _check_condition(p: Path, tables: dict) -> None:
    """What no single key can say: a flight case not taken from a log flies at a
    subsonic airspeed it states."""
    cond = tables["condition"]
    if tables[""]["kind"] in FLIGHT_KINDS and not cond["from_log"] and cond["airspeed_kcas"] == 0:
        raise InputError(f"{p}: [condition] airspeed_kcas must be given for a {tables['']['kind']} case "
                         f"not taken from a log (must lie in {_CARD['airspeed_kcas']})")


def check_element_length(case: Case, length_m: float, n_elements: int) -> None:
    """Refuse elements shorter than MIN_ELEMENT_M (not slender; a minutes-long
    run) for the hose length the model trails."""
    el = length_m / n_elements
    if el < MIN_ELEMENT_M:
        raise InputError(f"{case.path}: [model] n_elements = {n_elements} on a {length_m:.3g} m hose gives "
                         f"{el:.3g} m elements; must be >= {MIN_ELEMENT_M} m (n_elements <= "
                         f"{int(length_m / MIN_ELEMENT_M)})")


def check_log_agrees(case: Case, record) -> None:
    """The case's hose, drogue, reel and tanker are the log's (its test card): a case
    run against another hardware's log is refused, not gated."""
    info = record.info
    h = case["hardware"]
    for key, logged in (("hose", info.hose), ("drogue", info.drogue), ("reel", info.reel),
                          ("tanker", info.tanker)):
        if h.get(key) and logged and h[key] != logged:
            raise InputError(f"{case.path}: [hardware] {key} '{h[key]}' differs from the log's {key} "
                             f"'{logged}' (test {info.test_id})")


def _sheet(case: Case, hw: Hardware, kind: str, ident: str):
    try:
        return hw.get(kind, ident)
    except InputError as exc:
        raise InputError(f"{case.path}: [hardware] {kind} '{ident}' is not in {exc}") from None


def case_log_paths(case: Case) -> list[Path]:
    """The case's logs: relative to the project's log folder unless absolute;
    glob patterns (RD-KC130-B-*.mcap) expand to the files they match."""
    from workbench.hardware import DEFAULT_PATH
    base = DEFAULT_PATH.parent
    out = []
    for p in case[""]["logs"]:
        q = Path(p) if Path(p).is_absolute() else base / p
        if any(ch in p for ch in "*?["):
            hits = sorted(q.parent.glob(q.name))
            if not hits:
                raise InputError(f"{case.path}: logs pattern '{p}' matches no file")
            out += hits
        else:
            out.append(q)
    return out


def build_model(case: Case, hardware: Hardware | None = None, record=None,
                variant: dict | None = None) -> Model:
    """The solver model a checked case describes, for one of its logs (`record`,
    a flighttest.FlightRecord, when the case takes anything from the log) and
    one of its variants (model overrides)."""
    hw = hardware if hardware is not None else load_hardware()
    h = case["hardware"]
    cond = case["condition"]
    mod = dict(case["model"])
    for key, value in (variant or {}).items():
        if key in mod and value is not None:
            mod[key] = value
    from_log = cond["from_log"] or mod["reel"] == "from_log" or case["tow_motion"]["kind"] == "from_log"
    if from_log and record is None:
        raise InputError(f"{case.path}: takes its condition or motions from a log, but none was given "
                         f"(run it with --log LOG, or validate it on its 'logs')")
    if record is not None:
        check_log_agrees(case, record)
    hs = _sheet(case, hw, "hose", h["hose"])
    if cond["from_log"]:
        from workbench import log_inputs
        fc = log_inputs.flight_condition(record)
        info = record.info
        length = info.hose_length_m if info.hose_length_m else hs.length
        fuel_full = (info.hose_fuel or cond["hose_fuel"]) == "full"
        density, nu, tas = fc["density"], fc["kinematic_viscosity"], fc["true_airspeed_mps"]
    else:
        length = cond["hose_length_ft"] * FT if cond["hose_length_ft"] else hs.length
        fuel_full = cond["hose_fuel"] == "full"
        alt_m = cond["altitude_ft"] * FT
        d_temp = 0.0
        if cond["oat_F"] is not None:
            d_temp = degF_to_K(cond["oat_F"]) - isa(alt_m).temperature
        atm = isa(alt_m, delta_temperature=d_temp)
        density, nu = atm.density, atm.kinematic_viscosity
        tas = kcas_to_tas(cond["airspeed_kcas"], cond["altitude_ft"], d_temp) if cond["airspeed_kcas"] > 0 else 0.0
    reel = ReelProperties()
    if mod["reel"] == "from_log":
        from workbench import log_inputs
        t_pay, L_pay = log_inputs.payout(record)
        # the hose out at the start of the log is the hose the model trails
        length = float(L_pay[0])
        reel = ReelProperties(mode="prescribed", payout_t=t_pay, payout_length=L_pay)
    structure = _structure(case, h["hose"], record)
    hose = HoseProperties(
        length=length, outer_diameter=hs.outer_diameter, inner_diameter=hs.inner_diameter,
        dry_mass_per_length=hs.dry_mass_per_length, fuel_density=hw.fuel_density, fuel_full=fuel_full,
        total_length=max(hs.length, length) if mod["reel"] != "locked" else None, **structure)
    drogue = None
    if h["drogue"]:
        ds = _sheet(case, hw, "drogue", h["drogue"])
        drogue = DrogueProperties(mass=ds.mass, diameter=ds.diameter, cd=ds.cd_wind_tunnel, cl=ds.cl_wind_tunnel,
                                  cp_aft_of_hinge=ds.cp_aft_of_hinge, free_play_deg=ds.free_play_deg,
                                  lift_scale=float(mod["drogue_lift_scale"]),
                                  drag_scale=float(mod["drogue_drag_scale"]),
                                  hinge_damping=float(mod["hinge_damping_N_m_s"]),
                                  hinge_friction=float(mod["hinge_friction_N_m"]))
    if mod["reel"] == "drum":
        if not h["reel"]:
            raise InputError(f"{case.path}: [model] reel = 'drum' needs [hardware] reel")
        rs = _sheet(case, hw, "reel", h["reel"])
        reel = ReelProperties(mode="drum", drum_radius_empty=rs.drum_radius_empty, drum_width=rs.drum_width,
                              drum_inertia_empty=rs.drum_inertia_empty, torque_law=mod["reel_torque_law"],
                              torque=mod["reel_torque_N_m"])
    if case["tow_motion"]["kind"] == "from_log":
        from workbench import log_inputs
        tow = log_inputs.tow_trajectory(record)
    else:
        tow = _tow_motion(case)
    check_element_length(case, length, int(mod["n_elements"]))
    model = Model(hose, int(mod["n_elements"]), density, nu, wind=freestream(tas),
                  drogue=drogue, reel=reel, tow=tow)
    from workbench.effects_case import apply_case_effects
    alt = fc["altitude_m"] if cond["from_log"] else cond["altitude_ft"] * FT
    return apply_case_effects(case, model, hw, record, tas, density, alt)


def hose_temperature_F(case: Case, record=None) -> float | None:
    """The hose's temperature for its properties: given in [model.structure], else
    the outside air temperature of the log or of the condition."""
    st = case["model.structure"]
    if st["temperature_F"] is not None:
        return float(st["temperature_F"])
    if record is not None and case["condition"]["from_log"] and record.info.oat_K is not None:
        return K_to_degF(record.info.oat_K)
    return case["condition"]["oat_F"]


def _structure(case: Case, hose_id: str, record) -> dict:
    """HoseProperties' structural arguments: the constants given, or the bench
    property table at the hose temperature. Elements longer than the table's
    longest tuned element take the continuum values (k = EI/l from the
    best-resolved element): the tuned corrections of coarse elements belong to
    the bench cantilever's mode shape, not to a hose in flight."""
    st = case["model.structure"]
    if st["source"] != "table":
        return {"EI": float(st["EI_N_m2"]), "EA": float(st["EA_N"]),
                "bending_damping": float(st["bending_damping_N_m2_s"]),
                "axial_damping": float(st["axial_damping_N_s"])}
    from workbench.properties.store import load_library
    temp = hose_temperature_F(case, record)
    if temp is None:
        raise InputError(f"{case.path}: [model.structure] uses the property table but no hose temperature "
                         f"is known (give temperature_F, [condition] oat_F, or a log with oat_F)")
    try:
        table = load_library().table(hose_id)
        cont = table.continuum(temp, allow_extrapolation=st["allow_extrapolation"])
        per_element = table.element_constants(temp, allow_extrapolation=st["allow_extrapolation"])
    except (ValueError, KeyError) as exc:
        raise InputError(f"{case.path}: [model.structure] property table: {exc}") from None
    l_max = float(max(table.element_lengths))

    def constants(l, per_element=per_element, cont=cont, l_max=l_max):
        if l <= l_max:
            return per_element(l)
        return (cont["EA"] / l, cont["axial_damping"] / l, cont["EI"] / l, cont["bending_damping"] / l)
    return {"EI": cont["EI"], "EA": cont["EA"], "bending_damping": cont["bending_damping"],
            "axial_damping": cont["axial_damping"], "element_constants": constants}


def _tow_motion(case: Case) -> Trajectory:
    tm = case["tow_motion"]
    if tm["kind"] == "none":
        return Trajectory.fixed()
    dur = float(case["run"]["duration_s"] or defaults["simulate.duration_s"])
    t = np.linspace(0.0, max(dur, tm["start_s"] + tm["period_s"]), int(max(dur, 1.0) * 200) + 1)
    phase = (t - tm["start_s"]) / tm["period_s"]
    z = np.where((phase > 0) & (phase < 1), tm["amplitude_m"] * np.sin(2 * np.pi * phase), 0.0)
    return Trajectory(t, np.column_stack([np.zeros_like(t), np.zeros_like(t), z]))
