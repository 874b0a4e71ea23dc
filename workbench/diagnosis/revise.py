"""The selected set revised once forward selection stops (`select`): its
effects' form parameters refined where the family's hardware lets the logs
tell them (`refine`), an event the later ones made redundant dropped
(`backward`), and an event traded for a calibration within its data sheet's
tolerance where the logs cannot tell the two sets apart and the event would
not earn its place back beside the calibration (`trade`). Each
appends its steps to the selection's and keeps the shares adding up to the
set's shrink."""
from __future__ import annotations

import dataclasses
import math

from solver.effects import EFFECTS
from workbench.diagnosis.accept import acceptance, rescaled, simplest, widened
from workbench.diagnosis.evaluate import gap
from workbench.diagnosis.explanation import beyond_tolerance, implausibility, on_bound
from workbench.diagnosis.fit import ordered
from workbench.diagnosis.result import selection_step
from workbench.diagnosis.score import mapped, warm_start
from workbench.diagnosis.setup import calibrated_params


def refine(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, say, chance,
            refinable) -> tuple:
    """(the selected set, the setup it is fitted with): `chosen` refitted with
    its effects' form parameters among `refinable` free (gridded from their
    off values, the rest polished from `chosen`'s), kept when the gain earns
    their place (`acceptance`, each a new parameter) and none ends on its
    search bound (refined again without those that do). The refinement's
    gain is the refined effect's share."""
    pairs = tuple(pr for pr in refinable if pr[0] in chosen.effects and pr not in setup.refined)
    if not pairs:
        return chosen, setup
    wider = dataclasses.replace(setup, refined=setup.refined + pairs)
    (c,) = mapped(mapper, score, [(paths, tuple(chosen.effects), wider, warm_start(chosen, setup.refined))])
    if not c.success:
        failed.append(c)
        return chosen, setup
    k, what = steps[-1]["step"] + 1, ", ".join(f"{e}.{n}" for e, n in pairs)
    c.step = k
    fitted.append(c)
    current, gain = chosen.gap_after_heldout, chosen.gap_after_heldout - c.gap_after_heldout
    n_new = c.n_params - chosen.n_params
    # a form parameter the logs push onto its bound stands in for something else (on the
    # KDC-10 trails the sheet's height went to its -3 m bound beside the span position: a
    # trail's drogue moves as far down as out at any height): refined again without it
    bound = [pr for pr in pairs if on_bound(EFFECTS[pr[0]].params[pr[1]], c.params[pr[0]][pr[1]])]
    refused = (bound and "leaves " + ", ".join(f"{e}.{n} = {c.params[e][n]:.3g}" for e, n in bound)
               + " on its search bound, standing in for something else") or \
        acceptance(gain, n_new, current, widened(floor, chance, chosen, c))
    steps.append(selection_step(k, {"refined": what}, c.effect, current, c.gap_after_heldout, n_new,
                                why=refused, gap_before=gap_before))
    if refused:
        c.why_not_first = f"step {k}: refining {what} refused, it {refused}"
        say(f"step {k}: refining {what} refused")
        if bound and len(bound) < len(pairs):
            return refine(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, say, chance,
                          tuple(pr for pr in refinable if pr not in bound))
        return chosen, setup
    shares, effects = dict(chosen.shares or {}), {e for e, _ in pairs}
    for e in effects:
        shares[e] = shares.get(e, 0.0) + (steps[-1]["share"] or 0.0) / len(effects)
    c.shares = shares
    chosen.why_not_first = f"step {k}: {what} refined, held-out gap {c.gap_after_heldout:.3f} m"
    say(f"step {k}: {what} refined, held-out gap {c.gap_after_heldout:.3f} m")
    return c, wider


def backward(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, stopped, say,
              chance=None):
    """Backward elimination once forward selection stops: each selected event
    refitted out of the set (the others polished from their values); the one
    whose removal costs least goes when, added back, its gain would be
    refused by the same rule (`acceptance`): an effect that entered early as
    a stand-in (a steady wind for a drag change that sinks the drogue until a
    lift within its tolerance holds it up) and that the later ones made
    redundant. Repeated while two or more events are selected (one stands on
    its own step's acceptance). The shares of those left keep their
    proportions and add up to the set's shrink."""
    while True:
        events = [e for e in chosen.effects if not EFFECTS[e].model_form]
        if len(events) < 2:
            # one event: its own step accepted it against what was there before it
            return chosen, stopped
        warm = warm_start(chosen, setup.refined)
        jobs = [(paths, ordered(x for x in chosen.effects if x != e), setup, warm) for e in events]
        out = mapped(mapper, score, [j for j in jobs if j[1]])
        by_set = {tuple(c.effects): c for c in out}
        costs = []
        for e, job in zip(events, jobs):
            c = by_set.get(tuple(job[1])) if job[1] else None
            if job[1] and (c is None or not c.success):
                continue
            without = c.gap_after_heldout if c is not None else gap_before
            n_e = chosen.n_params - (c.n_params if c is not None else 0)
            if acceptance(without - chosen.gap_after_heldout, n_e, without, widened(floor, chance, c, chosen)):
                costs.append((without - chosen.gap_after_heldout, e, c, without))
        failed += [c for c in out if not c.success]
        if not costs:
            return chosen, stopped
        cost, e, c, without = min(costs, key=lambda t: t[0])
        k = steps[-1]["step"] + 1
        steps.append(selection_step(k, {"removed": e}, c.effect if c is not None else "none",
                                    chosen.gap_after_heldout, without, 0))
        say(f"step {k}: {e} removed, held-out gap {without:.3f} m")
        stopped = f"{stopped}; then {e} removed (added back it would not earn its place)"
        chosen.why_not_first = f"step {k}: {e} removed, added back it would not earn its place"
        if c is None:
            return None, stopped
        c.step = k
        fitted.append(c)
        left = {x: s for x, s in (chosen.shares or {}).items() if x != e and s is not None}
        c.shares = rescaled(left, without, gap_before)
        chosen = c


# the effects that can be a calibration within a data sheet's tolerance (`explanation`): what an event may be traded for
CALIBRATIONS = tuple(e for e, eff in EFFECTS.items() if any(p.tolerance is not None for p in eff.params.values()))


def trade(chosen, paths, pool, dropped, setup, mapper, score, floor, gap_before, steps, fitted, failed, stopped,
           say, prefit=None, chance=None):
    """The selected set with fewer events where the logs cannot tell the
    difference: `choose`'s rule (within the noise floor of each other, the
    explanation naming fewest events) over the whole set once selection
    ends, not one step at a time. A greedy step can take an event that
    stands in for the hardware's spread about its data sheets (a vertical
    steady wind for a drogue lift within its tolerance, under a drag change
    that sinks the drogue), and later steps build on it; neither backward
    elimination (the event is not redundant: the calibration is not there)
    nor a later step (the calibration adds too little to be accepted)
    undoes it. Tried where two or more events beyond a data sheet's
    tolerance are named (`explanation.beyond_tolerance`): each such event
    traded for a screened effect that can be a calibration (`CALIBRATIONS`,
    fitted in its place, polished from its data sheet's value and the
    others' fitted values), and each such effect
    added (the refused step's fits, where they were made on this set: a
    calibration that pulls a named factor back within its tolerance). The
    trade that names fewest events, then has fewest parameters, then the
    smallest gap, is taken when it names fewer events than the set, is
    plausible (`explanation.implausibility`) and its held-out gap is within
    the noise floor of the set's as selected or below; repeated while two or
    more events are named, each trade held to the selected set's gap (not
    the last trade's: a floor conceded per trade would add up, measured on
    a proving-ground engagement, two trades 0.076 -> 0.087 -> 0.099 m
    against a floor of 0.021 m). A trade is refused where the event traded
    out, added back beside the calibration, would earn its place
    (`acceptance` against the trade, the noise floor widened by `chance`;
    judged where a step fitted the set with both, `_earns_back`): forward
    selection from the trade would take it again, as backward elimination
    keeps an event that would. Given `prefit` (`fitted_gap`), each trade
    is first fitted on all the logs at once (unless a step fitted its set
    already: `_fitted_already`), and scored held out only when that gap is
    within the bar: most trades fail, and their folds are the cost (the
    KDC-10 engagement family took 343 s with them all scored, 301-318 s with
    the prefit, 278 s without trades, on one day; 285 s with the prefit
    where a step had not fitted the set, and the fits side by side). Shares
    as `backward`'s: the traded-in effect takes the traded-out one's, an
    added one its own gain, scaled to the set's shrink."""
    prior = setup.prior_effects

    def named(c):
        return simplest(c, prior)[0]
    bar = chosen.gap_after_heldout + floor
    while len(events := beyond_tolerance(chosen.effects, chosen.params, prior)) >= 2:
        spare = [e for e in pool if e in CALIBRATIONS and e not in chosen.effects and e not in dropped]
        # a trade succeeds only with its calibration within tolerance, about its data sheet's
        # value: it is polished from there with the others from the set's values, not gridded
        # over its whole search range (the forward step's cost again)
        swaps = [(e, f, (paths, ordered([x for x in chosen.effects if x != e] + [f]), setup,
                         at_sheet(warm_start(chosen, setup.refined), f, setup))) for e in events for f in spare]
        if prefit is not None and swaps:
            # fitted on everything first: a trade that misses the bar there misses it held out
            gaps = _fitted_already(swaps, fitted, paths, setup)
            todo = [i for i, g in enumerate(gaps) if g is None]
            for i, g in zip(todo, mapper(prefit, [swaps[i][2] for i in todo])):
                gaps[i] = g if g is not None else math.inf
            swaps = [t for t, g in zip(swaps, gaps) if g <= bar]
        out = mapped(mapper, score, [job for _, _, job in swaps])
        failed += [c for c in out if not c.success]
        trades = [(e, f, c) for (e, f, _), c in zip(swaps, out) if c.success]
        # the set with each calibration added, where a step fitted it: a trade of its own,
        # and what an event traded for that calibration is judged added back against
        added = [(f, c) for f in spare for c in fitted if c.success and set(c.effects) == set(chosen.effects) | {f}]
        trades += [(None, f, c) for f, c in added]
        both = {}
        for f, c in added:
            both.setdefault(f, c)
        k = steps[-1]["step"] + 1
        for _, _, c in trades:
            if c not in fitted:
                c.step = k
                fitted.append(c)
        ok = [t for t in trades if named(t[2]) < len(events) and not implausibility(t[2])
              and t[2].gap_after_heldout <= bar and not _earns_back(t, both, floor, chance)]
        if not ok:
            return chosen, stopped
        e, f, c = min(ok, key=lambda t: simplest(t[2], prior))
        c.step = k
        what = f"{e} traded for {f}" if e else f"{f} added"
        tried = {t[2].effect: t[2].gap_after_heldout for t in trades if t[2] is not c}
        steps.append(selection_step(k, {"traded": what}, c.effect, chosen.gap_after_heldout, c.gap_after_heldout,
                                    c.n_params - chosen.n_params, alternatives=tried))
        say(f"step {k}: {what}, held-out gap {c.gap_after_heldout:.3f} m, naming {named(c)} event(s)")
        stopped = f"{stopped}; then {what} (as well held out, naming fewer events)"
        chosen.why_not_first = f"step {k}: {what}, naming fewer events within the noise floor"
        shares = {x: s for x, s in (chosen.shares or {}).items() if x != e and s is not None}
        gain = max(chosen.gap_after_heldout - c.gap_after_heldout, 0.0) / gap_before if gap_before else 0.0
        shares[f] = ((chosen.shares or {}).get(e) if e else gain) or 0.0
        c.shares = rescaled(shares, c.gap_after_heldout, gap_before)
        chosen = c
    return chosen, stopped


def _earns_back(trade: tuple, both: dict, floor: float, chance) -> bool:
    """Whether the event a `trade` ((event, calibration, the traded set))
    takes out of the selected set would earn its place added back beside the
    calibration: the set with both (`both`, {calibration: the selected set
    with it}, where a step fitted it: the refused step tried every
    calibration on the set) against the trade (`acceptance`). Measured on a
    proving-ground engagement: a tracker lag of 0.13 s traded for a drogue
    lift within its tolerance, 0.042 -> 0.046 m held out against a floor of
    0.014 m, while beside the lift the lag took the gap to 0.033 m,
    explaining 0.032 m against a bar of 0.028 m."""
    e, f, c = trade
    if e is None or f not in both:
        return False
    b = both[f]
    return acceptance(c.gap_after_heldout - b.gap_after_heldout, b.n_params - c.n_params,
                      c.gap_after_heldout, widened(floor, chance, c, b)) is None


def _fitted_already(swaps: list, fitted: list, paths: list, setup) -> list:
    """Each trade's gap fitted on all of several logs where a step fitted its
    set already, with as many parameters (trading the last event selected
    gives that step's alternatives), else None: that set is not fitted on
    everything again to learn whether it can reach the bar (measured on the
    KDC-10 engagement family, half of its six trades). One log has no
    all-logs fit (its parameters are chosen among its folds')."""
    if len(paths) == 1:
        return [None] * len(swaps)
    known = {frozenset(c.effects): c for c in fitted if c.success and c.gap_after_all_fit_per_log}
    out = []
    for _, _, job in swaps:
        c = known.get(frozenset(job[1]))
        ok = c is not None and c.n_params == len(calibrated_params(job[1], setup.refined))
        out.append(gap(list(c.gap_after_all_fit_per_log.values())) if ok else None)
    return out


def at_sheet(warm: dict, effect: str, setup) -> dict:
    """`warm` (a `warm_start`) with `effect`'s calibrated parameters at their
    off values (the data sheet's, or the fleet's, `Setup.off`)."""
    sheet = {effect: {k: setup.off(effect, k) for e, k, _ in calibrated_params((effect,), setup.refined)}}
    return {"folds": [{**f, **sheet} for f in warm["folds"]], "all": {**warm["all"], **sheet}}
