"""The diagnosis in words: plain sentences from a family's numbers, what was
found, how sure, what is left."""
from __future__ import annotations

import numpy as np

from solver.effects import EFFECTS
from workbench.diagnosis.explanation import events_of
from workbench.diagnosis.remainder import sentences
from workbench.diagnosis.identify import PARALLEL_COS, partners
from workbench.diagnosis.result import FamilyDiagnosis, added_label


def _bound_note(effect: str, name: str, v: float) -> str:
    """' (at the search bound ...)' when a calibrated value ended on a bound:
    the logs want it there or beyond, and its error is one-sided."""
    p = EFFECTS[effect].params.get(name)
    if p is None or p.search is None:
        return ""
    lo, hi = p.search
    if abs(v - lo) <= 1e-6 * (hi - lo) or abs(v - hi) <= 1e-6 * (hi - lo):
        return f" (at the search bound {lo:g}..{hi:g}: the logs want it there or beyond)"
    return ""


def _probability(c) -> str:
    return f" (probability {c.probability:.2f} from the held-out evidence)" if c.probability is not None else ""


def _plausibility(d: FamilyDiagnosis) -> list[str]:
    """One sentence per ranked candidate whose fit is not physically plausible."""
    out = []
    for i, c in enumerate(d.ranking):
        if c.implausible:
            moved = f" {c.why_not_first}." if c.why_not_first and "implausible" in c.why_not_first else ""
            out.append(f"{c.effect} (rank {i + 1}) is not physically plausible: {c.implausible}; it is ranked "
                       f"behind plausible explanations whose held-out gap is within the noise floor of its own."
                       + moved)
    return out


def _selection(d: FamilyDiagnosis) -> list[str]:
    """The forward selection in a sentence: each selected effect with its
    share of the gap, in the order they entered, and why it stopped."""
    sel = d.selection
    if not sel or not sel.get("effects"):
        return []
    steps = [s for s in sel["steps"] if s["accepted"] and ("added" in s or "refined" in s or "traded" in s)]

    def what(s):
        gaps = f"held-out gap {s['gap_heldout_before_m']:.3f} -> {s['gap_heldout_after_m']:.3f} m"
        if "traded" in s:
            return f"{s['traded']} for fewer events ({gaps})"
        change = added_label(s) if "added" in s else "refined " + s["refined"]
        return f"{change} ({100 * s['share']:.0f} % of the gap, {gaps})"
    return ["Forward selection added " + ", then ".join(what(s) for s in steps)
            + f"; it stopped because {sel['stopped']}."]


def _calibrations(top) -> list[str]:
    """One sentence on the best explanation's calibrations within a data
    sheet's tolerance (`explanation`): fitted, and named only when nothing
    beyond its tolerance is there."""
    if not top.calibrations:
        return []
    why = "; ".join(top.calibrations.values())
    if any(e in top.calibrations for e in top.named):
        return [f"Every event of the best explanation lies within its data sheet's tolerance ({why}): the gap "
                "may be the hardware's own spread about its data sheet rather than an unmodelled effect."]
    return [f"Fitted, and not named as an unmodelled effect, a calibration within its data sheet's tolerance "
            f"({why}); the explanation names {', '.join(top.named)}."]


def _params(c) -> str:
    se = c.param_stderr
    return ", ".join(f"{e}.{k} = {v:.3g} +/- {se[e][k]:.2g}{_bound_note(e, k, v)}"
                     for e, dd in c.params.items() for k, v in dd.items())


def _params_of(effects: dict) -> str:
    return ", ".join(f"{e}.{k} = {v:.3g}" for e, dd in effects.items() for k, v in dd.items())


def _separability(d: FamilyDiagnosis) -> list[str]:
    """One sentence naming the screened pairs these logs cannot tell apart."""
    if not d.not_separable:
        return []
    return ["Not separable on these logs (parallel sensitivity patterns, principal-angle cosine >= "
            f"{PARALLEL_COS:g}): " + ", ".join(f"{' and '.join(p['effects'])} ({p['cosine']:.3f})"
                                               for p in d.not_separable) + "."]


def _named(d: FamilyDiagnosis, top) -> list[str]:
    """How likely the events the best explanation names are, over every
    explanation naming exactly them, and the likeliest other events."""
    named = d.named_probability or {}
    mine = events_of(top)
    if mine not in named:
        return []
    others = [(k, p) for k, p in named.items() if k != mine][:2]
    return [f"The events it names ({mine}) carry probability {named[mine]:.2f} over every explanation naming "
            f"exactly them (apart only by calibrations or model form)"
            + ("; the likeliest others: " + ", ".join(f"{k} {p:.2f}" for k, p in others) if others else "") + "."]


def findings(d: FamilyDiagnosis) -> list[str]:
    """Plain sentences from a family's numbers: what was found, how sure, what is left."""
    top = d.ranking[0]
    out = []
    head = (f"{d.family} ({', '.join(d.logs)}): baseline gap {d.gap_before:.3f} m against a noise floor "
            f"of {d.noise_floor:.3f} m" + (f", the baseline being the fleet calibration of this hardware "
                                           f"(cases/fleet/fleet.toml: {_params_of(d.baseline)}): what follows is what "
                                           f"differs from the program's earlier flights" if d.baseline else "") + ".")
    if top.effect == "none":
        out.append(head + f" No effect needed: {top.why or ''}" + _probability(top) + ".")
        out += _separability(d)
        out += _plausibility(d)
        return out + sentences(d.remainder, "the baseline")
    out.append(head + f" Best explanation: {top.effect} ({_params(top)}); held-out gap {top.gap_before:.3f} -> "
               f"{top.gap_after_heldout:.3f} m ({100 * top.shrink_heldout:.0f} % smaller), "
               f"{d.remaining_unexplained['above_noise_m']:.3f} m of it above the noise floor"
               + _probability(top) + ".")
    twins = partners(d)
    if twins:
        # the logs cannot choose: every near-parallel explanation with its probability, not one
        alts = [top] + [c for c, _ in twins]
        out[-1] = (head + " Best explanations, which these logs cannot tell apart: "
                   + " or ".join(f"{c.effect} ({_params(c)}; held-out gap {c.gap_after_heldout:.3f} m; "
                                 f"probability {c.probability:.2f})" for c in alts)
                   + ": their sensitivity patterns are parallel (principal-angle cosine "
                   + ", ".join(f"{cos:.3f}" for _, cos in twins) + f" >= {PARALLEL_COS:g}) and their held-out "
                   f"gaps within the noise floor {d.noise_floor:.3f} m of each other; the baseline's held-out gap "
                   f"was {top.gap_before:.3f} m.")
    out += _selection(d)
    out += _named(d, top)
    out += _calibrations(top)
    out += _separability(d)
    out += _plausibility(d)
    likeliest = max(d.ranking, key=lambda c: -1.0 if c.probability is None else c.probability)
    if likeliest is not top and likeliest.probability is not None:
        out.append(f"{likeliest.effect} carries the largest probability ({likeliest.probability:.2f}) on the "
                   f"held-out evidence but ranks behind {top.effect}"
                   + (f": {likeliest.why_not_first}." if likeliest.why_not_first else "."))
    for log, w in (d.gap_after_best or {}).items():
        real = sorted((p for p in w["by_phase"] if p["real"]), key=lambda p: -p["gap_m"])
        chans = sorted(((k, v) for k, v in w["by_channel"].items() if v["real"]), key=lambda kv: -kv[1]["gap_m"])
        if not real and not chans:
            out.append(f"{log}: with {top.effect} the residual is within the noise in every phase and channel.")
            continue
        out.append(f"{log}: with {top.effect} the gap is {w['gap_m']:.3f} m; what is left lies in "
                   + ", ".join(f"{p['phase']} {p['gap_m']:.3f} m" for p in real[:3])
                   + (" and in " + ", ".join(f"{k} {v['gap_m']:.3f} m" for k, v in chans[:2]) if chans else "")
                   + ".")
    out += sentences(d.remainder, top.effect)
    folds = top.folds or []
    if len(d.logs) > 1 and folds:
        per = ", ".join(f"{f['held_out']} {f['gap_heldout']:.3f} m" for f in folds)
        out.append(f"Held out one at a time, each log's gap with {top.effect} fitted on the others: {per}.")
        # a single fitted in folds (not the reel lag alone, "none" with the reel channel's event)
        singles = [c for c in d.ranking if c.effect != "none" and len(c.effects) == 1 and c.folds]
        for c in singles[:3]:
            vals = [f["params"] for f in c.folds]
            if vals and len(vals[0]) == 1:
                v = np.array([x[0] for x in vals])
                out.append(f"{c.effect} fitted without each log in turn: "
                           + ", ".join(f"without {f['held_out']} {x:.3g}" for f, x in zip(c.folds, v))
                           + f" (held-out gap {c.gap_after_heldout:.3f} m).")
    if d.reel:
        out.append(f"Reel lag, from the reel channel: {d.reel['why']}; the probability that the reel took the "
                   f"hose up otherwise than the program's reel: {d.reel['probability']:.2f}.")
    for c in d.failed:
        out.append(f"{c.effect} could not be scored and is not ranked: {c.message}.")
    return out
