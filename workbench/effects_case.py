"""Effects in cases and on the command line: `[effects.NAME]` tables and
`--effect NAME:param=value`, checked against the registry in `solver.effects`,
and the context (tanker data sheet, weight, flight condition, probe track) the
effects are applied with.

    [effects.tanker_wake]
    strength = 1.2

    workbench run CASE --effect tanker_wake:strength=1.2 --effect turbulence
"""
from __future__ import annotations

import dataclasses
from typing import Iterable

from solver.effects import EFFECTS, EffectContext, EffectError, TankerGeometry, apply_effects, validate_effects
from solver.model import Model, Trajectory
from solver.units import LB
from workbench.errors import InputError

# Turbulence and bow-wave tables cover at least this much simulated time, so a
# run longer than the case says (`--duration`) still sees a live field.
TABLE_MIN_S = 600.0


def check_effects_table(path: str, raw) -> dict:
    """The case's [effects.*] tables, validated, defaults filled in."""
    if not isinstance(raw, dict):
        raise InputError(f"{path}: [effects] must be a table of [effects.NAME] tables")
    for name, value in raw.items():
        if not isinstance(value, dict):
            raise InputError(f"{path}: [effects] {name} must be a table [effects.{name}], got {value!r}")
    try:
        return validate_effects(raw)
    except EffectError as exc:
        where = f"[effects.{exc.effect}]" + (f" {exc.key}" if exc.key else "")
        if exc.effect not in EFFECTS:
            where = "[effects]"
            raise InputError(f"{path}: {where} unknown effect '{exc.effect}' (known: {', '.join(EFFECTS)})") from None
        raise InputError(f"{path}: {where} {exc.problem}") from None


def parse_effect_options(options: Iterable[str]) -> dict:
    """`NAME` or `NAME:key=value[,key=value...]` strings into {name: {key: value}};
    a name given twice merges its keys (the later value wins)."""
    out: dict = {}
    for opt in options:
        name, _, rest = opt.partition(":")
        name = name.strip()
        if not name:
            raise InputError(f"--effect {opt!r}: expected NAME or NAME:key=value")
        params = out.setdefault(name, {})
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, eq, val = item.partition("=")
            if not eq or not key.strip():
                raise InputError(f"--effect {opt!r}: expected key=value, got {item!r}")
            try:
                num = float(val)
            except ValueError:
                raise InputError(f"--effect {opt!r}: {key.strip()} must be a number, got {val!r}") from None
            params[key.strip()] = int(num) if num.is_integer() and "." not in val and "e" not in val.lower() else num
    return out


def with_effects(case, overrides: dict):
    """The case with `overrides` ({name: {key: value}}, e.g. from --effect) merged
    over its [effects.*] tables; checked like the file's own."""
    if not overrides:
        return case
    merged = {name: dict(vals) for name, vals in case.tables.get("effects", {}).items()}
    for name, vals in overrides.items():
        merged.setdefault(name, {}).update(vals)
    try:
        checked = validate_effects(merged)
    except EffectError as exc:
        where = exc.effect + (f":{exc.key}" if exc.key else "")
        raise InputError(f"--effect {where}: {exc.problem}") from None
    tables = dict(case.tables)
    tables["effects"] = checked
    return dataclasses.replace(case, tables=tables)


def _probe_path(record) -> Trajectory | None:
    if record is None:
        return None
    df = record.topics.get("/receiver/probe")
    if df is None or len(df) < 2:
        return None
    from workbench import log_inputs
    return Trajectory(*log_inputs.probe_track(record))


def effect_context(case, model: Model, hardware, record, true_airspeed: float, density: float,
                   altitude_m: float) -> EffectContext:
    """What the case's effects need: the data sheet of [hardware] tanker, the
    gross weight ([condition] tanker_gross_weight_lb, else the log's test card),
    the flight condition, the run's span and the log's probe track."""
    tanker = None
    tid = case["hardware"].get("tanker")
    if tid:
        try:
            ts = hardware.get("tanker", tid)
        except InputError as exc:
            raise InputError(f"{case.path}: [hardware] tanker '{tid}' is not in {exc}") from None
        tanker = TankerGeometry(ts.wing_span, ts.tow_point_aft_of_cg, ts.tow_point_below_wing_root,
                                ts.tow_point_span_station)
    weight = None
    lb = case["condition"].get("tanker_gross_weight_lb")
    if lb:
        weight = lb * LB
    elif record is not None and getattr(record.info, "tanker_gross_weight_kg", None):
        weight = float(record.info.tanker_gross_weight_kg)
    t0 = float(model.tow.t[0])
    dur = case["run"].get("duration_s") or float(model.tow.t[-1] - model.tow.t[0])
    return EffectContext(true_airspeed=true_airspeed, air_density=density, altitude_m=altitude_m,
                         t_start=t0, duration_s=max(float(dur), TABLE_MIN_S), tanker=tanker,
                         gross_weight_kg=weight, probe_path=_probe_path(record))


def apply_case_effects(case, model: Model, hardware, record, true_airspeed: float, density: float,
                       altitude_m: float) -> Model:
    """`model` with the case's [effects.*] applied (unchanged when there are none)."""
    effects = case.tables.get("effects") or {}
    if not any(not EFFECTS[n].comparison_only for n in effects):
        return model
    ctx = effect_context(case, model, hardware, record, true_airspeed, density, altitude_m)
    if "tanker_wake" in effects:
        if ctx.tanker is None:
            raise InputError(f"{case.path}: [effects.tanker_wake] needs [hardware] tanker (its data sheet)")
        if ctx.gross_weight_kg is None:
            raise InputError(f"{case.path}: [effects.tanker_wake] needs [condition] tanker_gross_weight_lb "
                             f"(or a log whose test card gives it)")
    try:
        return apply_effects(model, effects, ctx)
    except EffectError as exc:
        raise InputError(f"{case.path}: [effects.{exc.effect}] {exc.problem}") from None
    except ValueError as exc:
        raise InputError(f"{case.path}: [effects] {exc}") from None
