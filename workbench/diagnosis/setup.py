"""What a diagnosis simulates a log with, and the constants of the method.

A log alone is enough: its metadata names the hardware (`hardware.toml` ids)
and the flight condition; a template per test kind (`cases/templates/`) adds
the paper's baseline model, so the baseline is what `validate` would run.
Which effects are calibrated, over which range, from which off value and with
which probe: the effect registry's `Param` (`solver.effects`), nowhere else.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from flighttest import FlightRecord
from solver.effects import EFFECTS, Param
from workbench.cases import Case, load_case
from workbench.config import defaults
from workbench.errors import InputError
from workbench.hardware import load_hardware

TEMPLATES = Path(__file__).resolve().parent.parent.parent / "cases" / "templates"
DIAG_KINDS = ("pitch_doublet", "trail", "engagement")

# The method's constants (`workbench.config`, where each is explained) are
# fixed for a process when the diagnosis is imported: its per-process caches
# of observations and simulations are keyed by log, not by them.
NOISE_FACTOR = defaults["diagnosis.noise_factor"]
DEFAULT_ELEMENTS = defaults["diagnosis.n_elements"]
LIGHT_TURBULENCE_MPS = defaults["diagnosis.light_turbulence_mps"]
PARAM_PENALTY = 0.05    # each parameter must buy 5 % of the held-out gap left
MAX_EFFECTS = 4         # forward selection stops at this many effects at once

# every kind's components are weighted by the model's reproducibility there (`evaluate`)
_WEIGHTED = ("; each component weighted by how well the model reproduces it at all (the log's noise over the root "
             "sum square of that noise and the model's spread under imperceptible changes), m")
GAP_DEFINITION = {
    "pitch_doublet": "RMS over 0.25 s bins (2 s before the doublet to the end) of the tracker's drogue x, y, z "
                     "minus the simulation's, with the signature components (the tracker's phase against the tow "
                     "point at the drogue's fundamental, times its amplitude)" + _WEIGHTED,
    "trail": "RMS of the signed normal distances of the video hose's mean shape (1 m bins) from the simulated "
             "static hose, together with the median drogue x, y, z residuals and the signature components (the "
             "mean shape's second difference over 5 m)" + _WEIGHTED,
    "engagement": "RMS of the video hose points' normal distances from the simulated hose, averaged per 1 s and "
                  "3 m station, together with the drogue x, y, z residuals in 0.25 s bins and the signature "
                  "components (the tracker's phase against the tow point; the drogue's y, z growth over the 2 s "
                  "before contact)" + _WEIGHTED,
}


def calibrated_params(candidate: tuple, refined: tuple = ()) -> list[tuple[str, str, Param]]:
    """(effect, parameter, its registry entry) for every parameter `candidate`'s
    effects calibrate, with the form parameters `refined` ((effect, parameter)
    pairs, `Effect.refined`) of its effects, in the candidate's order then the
    registry's."""
    return [(eff, name, p) for eff in candidate for name, p in EFFECTS[eff].params.items()
            if name in EFFECTS[eff].calibrated or (eff, name) in refined]


def to_unit(p: Param, v: float) -> float:
    """`v` in the unit interval of `p`'s search range (linear or logarithmic)."""
    lo, hi = p.search
    return (math.log(v / lo) / math.log(hi / lo)) if p.log else (v - lo) / (hi - lo)


def from_unit(p: Param, u: float) -> float:
    """The value of `p` at `u` in its search range's unit interval (clipped to it)."""
    lo, hi = p.search
    u = min(max(u, 0.0), 1.0)
    return lo * (hi / lo) ** u if p.log else lo + u * (hi - lo)


def applicable(effect: str, kind: str, case: Case, rec: FlightRecord) -> str | None:
    """Why `effect` cannot change this log's observables, or None when it can."""
    if EFFECTS[effect].not_calibrated:
        return EFFECTS[effect].not_calibrated
    if effect == "bow_wave" and kind != "engagement":
        return "no receiver near the drogue"
    if effect == "bow_wave" and "/receiver/probe" not in rec.topics:
        return "the log has no probe track"
    if effect == "reel_lag" and case["model"]["reel"] != "drum":
        return "the reel is not simulated (the baseline prescribes the logged payout or locks it)"
    if effect == "sensor_lag" and kind == "trail":
        return "a steady trail does not move: a time shift of the tracker changes nothing"
    if effect == "gust" and kind == "trail":
        return "a steady trail is compared as a static shape: a transient leaves nothing in it"
    if effect == "gust" and kind == "engagement":
        # measured: a 40 s engagement at 0.25 s a simulation scans its time for about a
        # minute a step, beside the 2 min a whole engagement's diagnosis takes
        return ("its time is scanned on a doublet only: an engagement's own transient is the contact, and a "
                "scan of its whole span costs a minute a selection step")
    if effect == "tanker_wake" and not (case["hardware"].get("tanker") and rec.info.raw.get("tanker_gross_weight_lb")):
        return "needs the tanker and its gross weight on the test card"
    if effect == "hose_stiffness" and kind == "trail":
        return "a steady trail of a long hose hangs on tension, not bending"
    return None


def refinable(case: Case) -> tuple:
    """((effect, parameter), ...): the form parameters (`Effect.refined`) a
    diagnosis of this hardware refines once their effect is selected. The
    tanker wake's span position is held for a tow point on the tanker's centre
    line (a buddy store): there the sheet's roll-up is symmetric about the
    hose and moves no sidewash, so a sideways offset could only stand in for
    something else (a steady wind). Its sheet's height is refined on any
    hardware: the sheet descends behind the wing whatever the store's span
    station."""
    tid = case["hardware"].get("tanker")
    centre_line = bool(tid) and load_hardware().get("tanker", tid).tow_point_span_station == 0.0
    return tuple((e, name) for e, eff in EFFECTS.items() for name in eff.refined
                 if not (e == "tanker_wake" and name == "lateral_offset_m" and centre_line))


def one_log_event(effect: str) -> str | None:
    """Why `effect` is ranked on one log at a time, or None: a parameter of
    it is a time in the log (`Effect.scanned`, a gust), which another log of
    the family does not share."""
    if EFFECTS[effect].scanned:
        return "a transient of one log, at that log's own time: ranked on a family of one log"
    return None


def baseline_case(rec: FlightRecord, n_elements: int | None = None) -> Case:
    """The kind's template with the log's hardware ids."""
    kind = rec.info.test_kind
    if kind not in DIAG_KINDS:
        raise InputError(f"{rec.path}: diagnose handles {', '.join(DIAG_KINDS)} logs, not {kind!r}")
    case = load_case(TEMPLATES / f"{kind}.toml")
    raw = rec.info.raw
    if not raw.get("hose"):
        raise InputError(f"{rec.path}: the test card names no hose")
    tables = dict(case.tables)
    tables["hardware"] = {k: raw.get(k) or None for k in ("hose", "drogue", "reel", "tanker")}
    case = dataclasses.replace(case, id=f"{case.id}:{rec.info.test_id}", path=str(rec.path), tables=tables)
    return _with_elements(case, n_elements)


def _with_elements(case: Case, n_elements: int | None) -> Case:
    """The case with `n_elements` hose elements (None: its own)."""
    if not n_elements:
        return case
    tables = dict(case.tables)
    tables["model"] = dict(tables["model"], n_elements=int(n_elements))
    return dataclasses.replace(case, tables=tables)


@dataclasses.dataclass(frozen=True)
class Setup:
    """What a diagnosis simulates a log with: the kind's template with the
    log's hardware ids (`case_path` None), or one case file with a variant's
    model overrides (a validation variant calibrated on its training logs);
    `n_elements` None keeps the case's own. `signatures`: the residual with
    its signature components (`flighttest.signatures`), which tell effects
    apart; a validation variant's calibration leaves them out, its gates
    being set on the comparison's own components. `prior`: effects every
    simulation carries under a candidate's own (`prior_effects`), frozen as
    ((effect, ((param, value), ...)), ...). `refined`: the form parameters
    ((effect, parameter), ...) calibrated besides the registry's
    `Effect.calibrated`, once forward selection has refined them on its set
    (or a validation variant names them)."""

    n_elements: int | None = DEFAULT_ELEMENTS
    case_path: str | None = None
    overrides: tuple = ()
    signatures: bool = True
    prior: tuple = ()
    refined: tuple = ()

    @property
    def prior_effects(self) -> dict:
        """{effect: {param: value}} every simulation of this setup carries: a
        fleet calibration (`fleet`), what the program's earlier flights of the
        hardware established; () is the data sheets' baseline."""
        return {e: dict(ps) for e, ps in self.prior}

    def off(self, effect: str, name: str) -> float:
        """Where `effect`'s parameter `name` stands before a candidate moves
        it: the prior's value, else the registry's off value."""
        return float(self.prior_effects.get(effect, {}).get(name, EFFECTS[effect].params[name].off))

    def case_for(self, rec: FlightRecord) -> Case:
        if self.case_path is None:
            return baseline_case(rec, self.n_elements)
        return _with_elements(load_case(self.case_path), self.n_elements)


def freeze(effects: dict) -> tuple:
    """{effect: {param: value}} as a hashable, ordered tuple (`Setup.prior`)."""
    return tuple(sorted((e, tuple(sorted((k, float(v)) for k, v in ps.items()))) for e, ps in effects.items()))


def family_of(rec: FlightRecord) -> str:
    """Logs of one kind on one hose, drogue and tanker form a family."""
    r = rec.info.raw
    return f"{rec.info.test_kind}/{r.get('tanker') or '-'}/{r.get('hose')}"
