"""Fleet calibrations: what the program's own flights established about each
family's hardware, the baseline a new flight of that hardware is diagnosed
against.

The data sheets are what the tunnel and the bench said, not what flies: on the
G-III's three doublets the drogue flies at a few per cent of its wind-tunnel
lift, on every KDC-10 log its tracked point sits 0.2 m off the model's drogue
centre. Diagnosed against the data sheets, every new flight of that hardware
names those same differences first, whatever its own event (five G-III
doublets carrying four different effects all came out as one drogue factor).
A flight-test engineer diagnoses a new flight against the model the earlier
flights calibrated, and asks what differs from it.

`cases/fleet/fleet.toml` holds, per family (`setup.family_of`), the effects of the
committed diagnosis of the program's logs (`workbench diagnose --baseline
datasheet --update-committed`) that belong to the hardware, not to the day
(`of_hardware`), at their calibrated values, with their source. `workbench
diagnose` takes them as its baseline (`Setup.prior`) for a log of a listed
family unless told `--baseline datasheet`; the proving ground and the
selftest, whose hardware is the data sheets' by construction, never do.
"""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

from flighttest.metrics.reel import RESPONSE_BOX, RESPONSE_KEYS
from solver.effects import EFFECTS
from workbench.errors import InputError

FLEET_PATH = Path(__file__).resolve().parent.parent.parent / "cases" / "fleet" / "fleet.toml"


def of_hardware(effect: str, n_logs: int = 1) -> bool:
    """Whether a calibrated `effect`, selected on a family of `n_logs` logs, is
    the hardware's, the same on the next flight: a factor on a data sheet's
    value (a parameter with a tolerance), model form (the tracked point on the
    drogue), the tanker's wake at its weight, or a steady relative wind that
    several flights share. Weather differs from day to day; a steady wind
    selected on two or more flights together, each held out in turn (the four
    KDC-10 trails: 6 m/s down and 5.3 m/s outboard at the pod), is the local
    flow angle at the pod, the wing's upwash and sidewash there, or a
    difference of model form it stands in for: without it the fleet baseline
    left 0.37-0.45 m on each of the trails it was derived from, with it
    0.03-0.08 m. Turbulence, gusts, the receiver's bow wave and the lags of
    one flight's reel and instruments are the day's."""
    eff = EFFECTS[effect]
    return (eff.model_form or effect == "tanker_wake" or any(p.tolerance is not None for p in eff.params.values())
            or (effect == "steady_wind" and n_logs >= 2))


def entry(family) -> dict | None:
    """The fleet entry a `FamilyDiagnosis` establishes: {"effects": {effect:
    {param: value}}, "logs": [...]}, the hardware's effects of its selected
    set at their values fitted on all its logs; None when it selected none."""
    chosen = list(family.selection.get("effects") or []) if family.selection else []
    top = next((c for c in family.ranking if list(c.effects) == chosen), None) if chosen else None
    if top is None:
        return None
    effects = {e: {k: float(v) for k, v in top.params[e].items()} for e in chosen if of_hardware(e, len(family.logs))}
    return {"effects": effects, "logs": list(family.logs)} if effects else None


def _toml_value(v) -> str:
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(float(v))


def text(diagnosis, source: str) -> str:
    """`cases/fleet/fleet.toml` from a `Diagnosis` of the program's logs; `source`
    says which (command and code version)."""
    lines = ["# Fleet calibrations: what the program's flights established about each family's hardware,",
             "# the baseline `workbench diagnose` takes for a new log of that family (workbench/diagnosis/fleet.py).",
             "# Written by `workbench diagnose --baseline datasheet --update-committed`; do not edit by hand.",
             f"source = {_toml_value(source)}", ""]
    for name, fam in sorted(diagnosis.families.items()):
        e = entry(fam)
        if e is None:
            continue
        lines += [f"[families.{_toml_value(name)}]", f"logs = {_toml_value(e['logs'])}"]
        for eff, ps in e["effects"].items():
            lines.append(f"{eff} = {{ " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in ps.items()) + " }")
        lines.append("")
    reels = {fam.reel_established["reel"]: fam.reel_established for _, fam in sorted(diagnosis.families.items())
             if fam.reel_established and fam.reel_established.get("reel")}
    for reel_id, ref in sorted(reels.items()):
        lines += [f"[reels.{_toml_value(reel_id)}]", f"logs = {_toml_value(ref['logs'])}"]
        lines += [f"{k} = {_toml_value(ref[k])}" for k in (*RESPONSE_KEYS, "everyday_misfit_m")]
        lines.append("")
    return "\n".join(lines)


def _read(path: Path) -> dict:
    try:
        return tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a TOML file: {exc}") from exc


def reel_references(path: Path = FLEET_PATH) -> dict:
    """{reel id: its reference response} (`reel.established`: the response
    fitted on the program's engagements of the reel, its everyday misfit, the
    logs); {} when there is no fleet file. A value missing, not finite or
    outside the response's search box is bad input (exit 2)."""
    path = Path(path)
    if not path.exists():
        return {}
    out = {}
    for reel_id, tbl in (_read(path).get("reels") or {}).items():
        ref = {"logs": list(tbl.get("logs") or [])}
        for k, (lo, hi) in {**RESPONSE_BOX, "everyday_misfit_m": (1e-6, 10.0)}.items():
            v = tbl.get(k)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
                raise InputError(f"{path}: reels.{reel_id}.{k} = {v!r}: needs a number in {lo:g}..{hi:g}")
            ref[k] = float(v)
        out[reel_id] = ref
    return out


def load(path: Path = FLEET_PATH) -> dict:
    """{family: {effect: {param: value}}} from a fleet file; {} when there is
    none. A file naming an unknown effect or parameter, or a value outside
    its physical range, is bad input (exit 2)."""
    path = Path(path)
    if not path.exists():
        return {}
    out = {}
    for fam, tbl in (_read(path).get("families") or {}).items():
        effects = {}
        for eff, ps in tbl.items():
            if eff == "logs":
                continue
            if eff not in EFFECTS or not isinstance(ps, dict) or not of_hardware(eff, len(tbl.get("logs") or [])):
                raise InputError(f"{path}: families.{fam}.{eff}: not an effect of the hardware")
            for k, v in ps.items():
                p = EFFECTS[eff].params.get(k)
                if p is None:
                    raise InputError(f"{path}: families.{fam}.{eff}.{k}: no such parameter of {eff}")
                if not (isinstance(v, (int, float)) and math.isfinite(v) and p.lo <= v <= p.hi):
                    raise InputError(f"{path}: families.{fam}.{eff}.{k} = {v!r}: outside {p.lo:g}..{p.hi:g} {p.unit}")
            effects[eff] = {k: float(v) for k, v in ps.items()}
        out[fam] = effects
    return out
