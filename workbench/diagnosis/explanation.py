"""What an explanation names as events of the flight, and whether its fit is
physically plausible.

A fitted set of effects is not all news. Two kinds of member are told apart
from the events it names:

* a model-form effect (`solver.effects.Effect.model_form`, the tracked point
  on the drogue) is a difference of definition between the model and the
  instruments, in every log of the hardware: reported as model form;
* a calibration within a data sheet's tolerance: a factor on a known value
  (the drogue's wind-tunnel C_L and C_D, the hose's handbook C_Dn, a bench
  EI) fitted within that value's own plausible spread
  (`solver.effects.Param.tolerance`) says the flight sits where the data
  sheet could have put it. It stays in the fit (the logs want it, and the
  other effects are measured on top of it) but is named only when nothing
  beyond its tolerance explains the gap: then it is the only explanation
  there is, and is said to lie within the data sheet's spread.
"""
from __future__ import annotations

import math

from solver.effects import EFFECTS, Param
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import to_unit


def within_tolerance(p: Param, v: float, about: float) -> bool:
    """Whether `v` lies within `p`'s data-sheet tolerance about `about`,
    |v - about| <= tolerance x |about|, to the round-off: a factor drawn at
    the clip of a spread equal to its tolerance is at it, not beyond it."""
    return p.tolerance is not None and round(abs(v - about), 9) <= p.tolerance * abs(about)


def calibration(effect: str, params: dict, ref: dict | None = None) -> str | None:
    """Why `effect` fitted at `params` ({param: value}) is a calibration
    within its data sheet's tolerance, or None: every parameter it
    calibrates has a tolerance and lies within it, about its off value or,
    where `ref` ({param: value}, a fleet calibration) gives one, about that."""
    eff = EFFECTS[effect]
    ref = ref or {}
    parts = []
    for name in eff.calibrated:
        p, v = eff.params[name], params.get(name)
        about = float(ref.get(name, p.off))
        if v is None or not within_tolerance(p, v, about):
            return None
        parts.append(f"{effect}.{name} = {v:.3g}, within the data sheet's +/- {100 * p.tolerance:.0f} % "
                     f"({p.doc})" + (f" of the fleet's {about:.3g}" if name in ref else ""))
    return "; ".join(parts) or None


def explain(effects: list, params: dict, prior: dict | None = None) -> tuple[list, dict]:
    """(the events an explanation of `effects` fitted at `params`
    ({effect: {param: value}}) names, {effect: why it is a calibration within
    its tolerance}), tolerances about the `prior`'s values where it has them
    (a fleet calibration, `Setup.prior_effects`). Model-form effects are
    never named; calibrations only when no other event is there."""
    prior = prior or {}
    events = [e for e in effects if not EFFECTS[e].model_form]
    cals = {e: why for e in events if (why := calibration(e, params.get(e, {}), prior.get(e)))}
    return [e for e in events if e not in cals] or events, cals


def beyond_tolerance(effects: list, params: dict, prior: dict | None = None) -> list:
    """The events of `effects` fitted at `params` that no data sheet's
    tolerance covers: `explain`'s events less its calibrations (none for a
    set of calibrations within tolerance, which `explain` names as the only
    explanation there is). What the trade trades."""
    events, cals = explain(effects, params, prior)
    return [e for e in events if e not in cals]


def event_count(effects: list, params: dict, prior: dict | None = None) -> int:
    """What an explanation counts for where the one naming fewest events is
    taken (`accept.simplest`: `choose`, the trade): each event beyond a data
    sheet's tolerance one, and its calibrations within tolerance together
    one where nothing beyond tolerance is there: the hardware's spread about
    its data sheets is one explanation, however many of its factors the logs
    want. Counted by `explain`'s names, two calibrations within tolerance
    were two events and the same set with a real event added one (measured
    on a proving-ground doublet with no event withheld: a drogue lift and
    drag within tolerance were traded for the two with a hose stiffness of
    0.13 x its bench value, a false alarm)."""
    events, cals = explain(effects, params, prior)
    return sum(e not in cals for e in events) or min(len(cals), 1)


BOUND_SHARE = 0.01   # a value within 1 % of its search range (in the search's scale) of a bound is on it


def implausibility(c: Candidate, effects=None) -> str | None:
    """Why `c`'s fit (of `effects` only, where given) is not physically plausible, or None: a value outside its
    parameter's physical range lo..hi, or on a bound of its search range (the
    logs want it there or beyond: the effect is standing in for another), or
    within one standard error of it (`Candidate.param_stderr`: the logs cannot
    tell it from the bound; a fit left just inside where the gap is flat in
    it, as a hose bending of 0.108 +/- 2.2 against the bound 0.1 beside a
    proving-ground doublet's steady wind); a time in the log (`Param.scan_s`)
    is bounded by the log, not the physics."""
    out = []
    # every fitted value, a refined form parameter's (`Effect.refined`) too
    for eff, name, v in ((e, k, v) for e, ps in c.params.items() for k, v in ps.items()
                         if effects is None or e in effects):
        p = EFFECTS[eff].params[name]
        if not (p.lo <= v <= p.hi):
            out.append(f"{eff}.{name} = {v:.3g} outside its physical range {p.lo:g}..{p.hi:g} {p.unit}")
        elif p.search and not p.scan_s:
            lo, hi = p.search
            se = (c.param_stderr or {}).get(eff, {}).get(name, math.nan)
            if on_bound(p, v):
                out.append(f"{eff}.{name} = {v:.3g} on its search bound ({lo:g}..{hi:g})")
            elif se > 0 and (v - se <= lo or v + se >= hi):    # no standard error (NaN): no evidence
                out.append(f"{eff}.{name} = {v:.3g} +/- {se:.2g}, within a standard error of its search bound "
                           f"({lo:g}..{hi:g})")
    return "; ".join(out) or None


def on_bound(p: Param, v: float) -> bool:
    """Whether `v` lies within `BOUND_SHARE` of a bound of `p`'s search range
    (in the search's scale): the logs want it there or beyond."""
    return not (BOUND_SHARE < to_unit(p, v) < 1 - BOUND_SHARE)


def events_of(c) -> str:
    """The events the candidate `c` names (`c.named`), in the registry's
    order, "+"-joined; "none" for none."""
    return "+".join(sorted(c.named or [], key=list(EFFECTS).index)) or "none"
