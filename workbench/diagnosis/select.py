"""Forward selection of several effects at once: from the baseline, add the
screened effect that most cuts the held-out gap, one step at a time.

Step 0 fits the pool's model-form effects (`Effect.model_form`: the tracked
point on the drogue, a difference of definition between model and
instruments in every log of the hardware) and keeps them when they cut the
held-out gap at all: no event then stands in for them, and none is refused
because they took part of its gain. They name no event, and do not count
towards `MAX_EFFECTS`.

Step k fits every screened effect not yet selected (nor failed to simulate)
together with the k - 1 selected ones (`score_candidate`: per fold and on all logs, warm-started at the
selected set's fitted values, `fit.EffectCalibrator.fit(parts, start=...)`)
and scores it held out on the same folds. The step takes the best plausible
addition (`_take`, `choose`) of those that earn their place (all, when
none does): among additions within the noise floor of each other, the one
naming fewest events, then with fewest parameters; and a
plausible addition before an implausible one (on a search bound) of similar
gap. It is accepted when
what it explains of the held-out gap beats the noise, sqrt(current^2 -
after^2) > `NOISE_FACTOR` x the noise floor (gaps add in quadrature), and its
held-out gain over the current set (current gap minus its gap, m) beats the
parameter penalty, gain > `PARAM_PENALTY` x (its new parameters) x the
current held-out gap: each parameter must buy `PARAM_PENALTY` of what is left
(Occam's rule). Given `chance` (once a real random motion is measured), the
noise floor of each addition is `widened` by what that motion explains by
chance along the addition's own pattern, and an addition within it is set
aside before the step chooses.
Once it stops, the selected effects' form parameters that the family's
hardware lets the logs tell (`refinable`, `setup.refinable`: the tanker
wake's span position behind a wing pod) are refined on the selected set
(`_refine`), and kept when they earn one more parameter's place by the same
rule: a form parameter free at entry would let its effect mimic another (a
wake moved sideways, a steady wind) and pay a parameter more against
everything else. Then backward elimination (`_backward`) drops a selected
event that the later ones made redundant, and `_trade` trades an event for
a calibration within its data sheet's tolerance where the logs cannot tell
the two sets apart (`choose`'s rule over the whole set).
Otherwise, or at `MAX_EFFECTS` effects, the selection stops and says why.
Each accepted effect's share of the gap is its step's gain over the baseline
held-out gap: the shares add up to the selected set's held-out shrink.

The hook points are the pool (a list of effect names, best screened first)
and `score` (a function of one job, (paths, candidate, setup, warm), that
returns a `Candidate`): another candidate kind or scorer plugs in there.
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Callable

from scipy.special import erfcinv

from solver.effects import EFFECTS
from workbench.diagnosis.evaluate import gap
from workbench.diagnosis.explanation import explain, implausibility
from workbench.diagnosis.fit import EffectCalibrator, effects_at, ordered, splitter_for
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import (LIGHT_TURBULENCE_MPS, MAX_EFFECTS, NOISE_FACTOR, PARAM_PENALTY,
                                       calibrated_params)
from workbench.errors import SimulationFailed


def warm_start(c: Candidate, refined: tuple = ()) -> dict:
    """Where a fit that adds an effect to `c` (or drops one, or refines its
    form) starts: each fold at `c`'s values fitted on that fold (`c` fitted
    with the form parameters `refined`), the all-logs fit at `c`'s own."""
    return {"folds": [effects_at(tuple(c.effects), f["params"], refined) for f in c.folds], "all": c.params}


def score_candidate(job) -> Candidate:
    """One candidate on one family: fitted per fold and on all logs (from
    `warm`, a `warm_start`, or cold when None); each fold's held-out gap. Runs
    in a worker process (or a Dask worker)."""
    paths, candidate, setup, warm = job
    t_start = time.perf_counter()
    n_params = len(calibrated_params(candidate, setup.refined))
    try:
        return _fit_and_score(paths, candidate, setup, warm, n_params, t_start)
    except SimulationFailed as exc:
        return Candidate("+".join(candidate), list(candidate), n_params, success=False, message=str(exc),
                         wall_s=time.perf_counter() - t_start)


def _fit_and_score(paths, candidate, setup, warm, n_params, t_start) -> Candidate:
    folds, fitted, held_out = [], [], []
    for i, fold in enumerate(splitter_for(paths).split(paths)):
        cal = EffectCalibrator(candidate, setup).fit(fold.train, start=warm and warm["folds"][i])
        # the fold's held-out gap from its components (`EffectCalibrator.score`'s RMS of part gaps),
        # each part simulated and compared once
        test = cal.held_out(fold.test)
        folds.append({"held_out": fold.label, "params": cal.x_, "gap_train": cal.gap_train_,
                      "gap_heldout": gap([gap(x.r) for x in test])})
        held_out += test
        fitted.append(cal)
    if len(paths) == 1:
        # one log: the parameters are whichever of the two folds' values and
        # their mean fits the whole log best (a slack hose after a large doublet
        # can fall into another motion between two good fits, so the mean alone
        # may fit neither half), the folds' spread folded into the error
        a, b = fitted
        stderr = [math.hypot(0.5 * (sa + sb), 0.5 * (x - y))
                  for x, y, sa, sb in zip(a.x_, b.x_, a.stderr_x_, b.stderr_x_)]
        options = [EffectCalibrator(candidate, setup).set_fitted(x, stderr)
                   for x in ([0.5 * (x + y) for x, y in zip(a.x_, b.x_)], a.x_, b.x_)]
        full = min(options, key=lambda c: c.score(paths))
    else:
        full = EffectCalibrator(candidate, setup).fit(paths, start=warm and warm["all"])
    per_log = dict(zip((Path(p).stem for p in paths), full.part_gaps(paths)))
    return Candidate("+".join(candidate), list(candidate), n_params, params=full.params_,
                     looks=max(cal.looks_ for cal in fitted),
                     param_stderr=full.stderr_,
                     gap_after_train=gap([f["gap_train"] for f in folds]),
                     gap_after_heldout=gap([f["gap_heldout"] for f in folds]),
                     gap_after_all_fit_per_log=per_log, folds=folds, held_out=held_out,
                     wall_s=time.perf_counter() - t_start)


def fitted_gap(job) -> float | None:
    """A candidate fitted on all of its logs at once, no part held out (from
    `warm`'s all-logs values), and its gap there (the RMS of the logs'
    gaps, as a held-out gap is); None when it fails to simulate. A lower
    bound of its held-out gap, which fits each part on the others: what
    cannot get within a bar fitted on everything will not held out. Runs in
    a worker process (or a Dask worker)."""
    paths, candidate, setup, warm = job
    try:
        return EffectCalibrator(candidate, setup).fit(paths, start=warm and warm["all"]).score(paths)
    except SimulationFailed:
        return None


def explained(gain: float, current_gap: float) -> float:
    """The part of the held-out gap `current_gap` (m) that a step cutting it
    by `gain` explains: sqrt(current^2 - after^2), gaps being RMS and
    independent parts adding in quadrature."""
    after = current_gap - gain
    return math.sqrt(max(current_gap ** 2 - after ** 2, 0.0)) if gain > 0 else 0.0


def acceptance(gain: float, n_new: int, current_gap: float, floor: float) -> str | None:
    """Why an addition that cuts the held-out gap `current_gap` by `gain` (m)
    with `n_new` new parameters is refused, or None when it is accepted.

    The noise: what the addition explains (`explained`, in quadrature) must
    beat `NOISE_FACTOR` x the noise floor, the rule a gap itself is real by.
    Not the plain difference of the gaps: beside a model-form remainder a few
    times the noise, an effect whose own signature is three times the noise
    cuts the RMS by barely one noise floor, and would be refused wherever
    anything else is left unexplained. The parameter penalty stays on the
    plain cut: each parameter must buy `PARAM_PENALTY` of the gap left."""
    part = explained(gain, current_gap)
    noise, penalty = NOISE_FACTOR * floor, PARAM_PENALTY * n_new * current_gap
    if part <= noise:
        return (f"explains {part:.4f} m of the held-out gap {current_gap:.4f} m (cutting it by {gain:.4f} m), "
                f"not more than {NOISE_FACTOR:g} x the noise floor ({noise:.4f} m)")
    if gain <= penalty:
        return (f"cuts the held-out gap by {gain:.4f} m, not more than the parameter penalty ({PARAM_PENALTY:g} x "
                f"{n_new} new parameter(s) x the held-out gap {current_gap:.4f} m = {penalty:.4f} m)")
    return None


def chance_quantile(tried: int) -> float:
    """How many standard deviations of its chance gain the best of `tried`
    additions must clear so that a step takes one by chance no more often
    than one addition clears `NOISE_FACTOR` of them (a two-sided normal tail,
    4.6 % at 2): Sidak's quantile, the best of several being the largest of
    their chance gains (2.0 for one, 2.7 for seven)."""
    alpha = math.erfc(NOISE_FACTOR / math.sqrt(2.0))
    return math.sqrt(2.0) * float(erfcinv(1.0 - (1.0 - alpha) ** (1.0 / max(tried, 1))))


def widened(floor: float, chance: Callable | None, before: Candidate | None, after: Candidate | None,
            tried: int = 1) -> float:
    """The noise floor a change from the set `before` to `after` (None: the
    baseline) must beat, chosen as the best of `tried` additions: `floor`,
    and where a real random motion is measured what it explains along the
    change's pattern by chance (`chance(before, after)`, m,
    `turbulence.RandomEffect.chance_offset`) at `chance_quantile(tried)`
    standard deviations over `NOISE_FACTOR`'s, in quadrature; so that
    `NOISE_FACTOR` x it is hypot(NOISE_FACTOR x floor, z x chance). A change
    that adds a transient at a scanned time (`Effect.scanned`) was tried at
    each of its `Candidate.looks` times too: the largest burst of a random
    motion is the one a scan finds."""
    if chance is None:
        return floor
    added = set(after.effects if after else ()) - set(before.effects if before else ())
    if after is not None and any(EFFECTS[e].scanned for e in added):
        tried *= after.looks
    return math.hypot(floor, chance(before, after) * chance_quantile(tried) / NOISE_FACTOR)


def choose(fits: list, floor: float, prior: dict | None = None) -> Candidate:
    """The addition a step takes among `fits`: of those whose held-out gap
    is within the noise floor `floor` of the best (the data cannot tell them
    apart), the one that names the fewest events (a calibration within its
    data sheet's tolerance is no event, `explanation.explain`), then has the
    fewest parameters, then the smallest gap."""
    least = min(c.gap_after_heldout for c in fits)
    similar = [c for c in fits if c.gap_after_heldout <= least + floor]
    return min(similar, key=lambda c: simplest(c, prior))


def simplest(c: Candidate, prior: dict | None = None) -> tuple:
    """The order in which the simplest of explanations the logs cannot tell
    apart comes first: fewest events named (`explanation.explain`), then
    fewest parameters, then the smallest held-out gap."""
    return len(explain(c.effects, c.params, prior)[0]), c.n_params, c.gap_after_heldout


def _rescaled(shares: dict, gap_after: float, gap_before: float) -> dict:
    """`shares` ({effect: share}) in their proportions, scaled to add up to
    the shrink 1 - gap_after / gap_before of the set they belong to."""
    total = 1.0 - gap_after / gap_before if gap_before else 0.0
    return {x: v * total / sum(shares.values()) for x, v in shares.items()} if sum(shares.values()) else shares


def _take(ok: list, chosen: Candidate | None, current: float, floor: float,
          prior: dict | None = None, chance: Callable | None = None) -> tuple[Candidate, str | None]:
    """(the addition a step takes, why it is refused or None). The best
    (`choose`); but when its fit is implausible (`explanation.implausibility`:
    on a search bound or outside its physical range, standing in for another
    effect) and a plausible addition's held-out gap is similar, within the
    noise floor or one parameter's worth of the gap left (`PARAM_PENALTY` x
    `current`), the plausible one first, the implausible one only if the
    plausible one is refused and it is not. An addition the rule refuses is
    set aside before the best is chosen, where another earns its place: a
    simpler addition within the noise of the best that explains no more
    than the noise itself does not stop the step (measured on a proving-ground
    doublet: a tracker lag cutting the held-out gap by 0.0015 m stood in
    front of the true gust, cutting it by 0.0049 m and explaining 2.2 x the
    noise floor, and the selection ended on a drogue lift).
    With `chance` (a function of the set before and after: what a real
    random motion explains by chance along the change's pattern), each
    addition is held to the noise floor `widened` by it (the best of all
    tried): a random motion's low frequencies may favour a steady effect
    that explains by chance more than another explains for real."""
    tried = len(ok)

    def verdict(c):
        n_new = c.n_params - (chosen.n_params if chosen else 0)
        return acceptance(current - c.gap_after_heldout, n_new, current, widened(floor, chance, chosen, c, tried))
    ok = [c for c in ok if verdict(c) is None] or ok
    best = choose(ok, floor, prior)
    plausible = [c for c in ok if not implausibility(c)]
    tries = [best]
    if plausible and implausibility(best):
        alt = choose(plausible, floor, prior)
        if alt.gap_after_heldout <= best.gap_after_heldout + max(floor, PARAM_PENALTY * current):
            tries = [alt, best]
    verdicts = []
    for c in tries:
        verdicts.append((c, verdict(c)))
        if verdicts[-1][1] is None:
            return verdicts[-1]
    return verdicts[0]


@dataclasses.dataclass
class Selection:
    """What forward selection found: `chosen` the selected set (None: no
    effect earned its place), `fitted` every candidate scored on the way (each
    step's alternatives, the accepted sets among them), `failed` those whose
    simulation failed, `steps` one dict per step, `stopped` why it ended,
    `refined` the form parameters ((effect, parameter), ...) `chosen` was
    fitted with besides the calibrated ones (`_refine`)."""

    chosen: Candidate | None
    fitted: list
    failed: list
    steps: list
    stopped: str
    refined: tuple = ()

    def additions(self) -> list[tuple[dict, Candidate | None, Candidate]]:
        """(step, the set before it, the set it made) for every accepted step
        that added an effect (the model-form step 0 included), in order; None
        for the baseline."""
        out, current = [], None
        for s in self.steps:
            if not s.get("accepted"):
                continue
            made = next((c for c in self.fitted if c.step == s["step"] and c.effect == s["candidate"]), None)
            if "added" in s and made is not None:
                out.append((s, current, made))
            current = made
        return out

    def to_json(self) -> dict:
        return {"effects": list(self.chosen.effects) if self.chosen else [],
                "shares": dict(self.chosen.shares) if self.chosen else {}, "steps": self.steps,
                "stopped": self.stopped, "max_effects": MAX_EFFECTS,
                "refined": [f"{e}.{n}" for e, n in self.refined]}


def forward_select(paths: list, pool: list, setup, mapper: Callable, gap_before: float, floor: float,
                   score: Callable = score_candidate, say: Callable[[str], None] = lambda s: None,
                   chance: Callable | None = None, refinable: tuple = (),
                   prefit: Callable | None = None) -> Selection:
    """Forward selection over `pool` (effect names) from the baseline, whose
    held-out gap is `gap_before` (m), against the noise floor `floor` (m),
    each step's widened by `chance` when given (`widened`); then the form
    parameters `refinable` ((effect, parameter), ...) of the selected set
    refined (`_refine`), redundant events dropped (`_backward`) and events
    traded for calibrations (`_trade`, each trade first fitted by `prefit`
    where given: `fitted_gap` with the default `score`)."""
    chosen, current, fitted, failed, steps, dropped = None, gap_before, [], [], [], set()
    stopped = f"{MAX_EFFECTS} effects selected (the most forward selection adds)"
    standing = ordered(e for e in pool if EFFECTS[e].model_form)
    if standing:
        # step 0: the model-form effects (the tracked point on the drogue) differ
        # by definition between model and instruments, in every log of the
        # hardware; fitted first so that no event has to stand in for them and
        # none is refused for sharing the gap with them. Kept when they cut the
        # held-out gap at all: what they leave is the events' to explain.
        (c,) = mapper(score, [(paths, standing, setup, None)])
        if not c.success:
            failed.append(c)
        else:
            c.step = 0
            fitted.append(c)
            gain = current - c.gap_after_heldout
            steps.append({"step": 0, "added": "+".join(standing), "candidate": c.effect, "standing": True,
                          "gap_heldout_before_m": current, "gap_heldout_after_m": c.gap_after_heldout,
                          "gain_m": gain, "new_params": c.n_params, "accepted": gain > 0.0,
                          "share": gain / gap_before if gap_before else None, "alternatives": {}})
            if gain > 0.0:
                c.shares = {e: steps[-1]["share"] / len(standing) for e in standing}
                chosen, current = c, c.gap_after_heldout
                say(f"step 0: model form {c.effect}, held-out gap {current:.3f} m")
            else:
                c.why_not_first = "model form that does not cut the held-out gap"
        dropped |= set(standing)
    for k in range(1, MAX_EFFECTS + 1):
        selected = tuple(chosen.effects) if chosen else ()
        # an effect whose fit failed to simulate is out of the pool: it failed
        rest = [e for e in pool if e not in selected and e not in dropped]
        if not rest:
            stopped = "every screened effect is selected"
            break
        warm = warm_start(chosen) if chosen else None
        jobs = [(paths, ordered(selected + (e,)), setup, warm) for e in rest]
        say(f"step {k}: " + ", ".join("+".join(j[1]) for j in jobs))
        out = list(mapper(score, jobs, progress=lambda c: say(f"fitted {c.effect}")))
        failed += [c for c in out if not c.success]
        dropped |= {next(e for e in c.effects if e not in selected) for c in out if not c.success}
        ok = [c for c in out if c.success]
        for c in ok:
            c.step = k
        fitted += ok
        if not ok:
            stopped = f"step {k}: no addition could be simulated"
            break
        best, refused = _take(ok, chosen, current, floor, setup.prior_effects, chance)
        added = next(e for e in best.effects if e not in selected)
        n_new = best.n_params - (chosen.n_params if chosen else 0)
        gain = current - best.gap_after_heldout
        steps.append({"step": k, "added": added, "candidate": best.effect, "gap_heldout_before_m": current,
                      "gap_heldout_after_m": best.gap_after_heldout, "gain_m": gain, "new_params": n_new,
                      "accepted": refused is None, "share": gain / gap_before if gap_before else None,
                      "alternatives": {c.effect: c.gap_after_heldout for c in ok if c is not best}})
        for c in ok:
            if c is not best:
                c.why_not_first = f"step {k}: adding {added} cut the held-out gap more"
        if refused:
            best.why_not_first = f"step {k}: adding {added} refused, it {refused}"
            stopped = f"step {k}: the best addition, {added}, {refused}"
            break
        best.shares = {**(chosen.shares if chosen else {}), added: steps[-1]["share"]}
        chosen, current = best, best.gap_after_heldout
        say(f"step {k}: {added} accepted, held-out gap {current:.3f} m")
    if chosen is not None:
        chosen, setup = _refine(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, say,
                                chance, refinable)
        chosen, stopped = _backward(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed,
                                    stopped, say, chance)
        chosen, stopped = _trade(chosen, paths, pool, dropped, setup, mapper, score, floor, gap_before, steps,
                                 fitted, failed, stopped, say, prefit)
    return Selection(chosen, fitted, failed, steps, stopped, setup.refined)


def _refine(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, say, chance,
            refinable) -> tuple:
    """(the selected set, the setup it is fitted with): `chosen` refitted with
    its effects' form parameters among `refinable` free (gridded from their
    off values, the rest polished from `chosen`'s), kept when the gain earns
    their place (`acceptance`, each a new parameter). The refinement's gain
    is the refined effect's share."""
    pairs = tuple(pr for pr in refinable if pr[0] in chosen.effects and pr not in setup.refined)
    if not pairs:
        return chosen, setup
    wider = dataclasses.replace(setup, refined=setup.refined + pairs)
    (c,) = mapper(score, [(paths, tuple(chosen.effects), wider, warm_start(chosen, setup.refined))])
    if not c.success:
        failed.append(c)
        return chosen, setup
    k, what = steps[-1]["step"] + 1, ", ".join(f"{e}.{n}" for e, n in pairs)
    c.step = k
    fitted.append(c)
    current, gain = chosen.gap_after_heldout, chosen.gap_after_heldout - c.gap_after_heldout
    n_new = c.n_params - chosen.n_params
    refused = acceptance(gain, n_new, current, widened(floor, chance, chosen, c))
    steps.append({"step": k, "refined": what, "candidate": c.effect, "gap_heldout_before_m": current,
                  "gap_heldout_after_m": c.gap_after_heldout, "gain_m": gain, "new_params": n_new,
                  "accepted": refused is None, "share": gain / gap_before if gap_before else None,
                  "alternatives": {}})
    if refused:
        c.why_not_first = f"step {k}: refining {what} refused, it {refused}"
        say(f"step {k}: refining {what} refused")
        return chosen, setup
    shares, effects = dict(chosen.shares or {}), {e for e, _ in pairs}
    for e in effects:
        shares[e] = shares.get(e, 0.0) + (steps[-1]["share"] or 0.0) / len(effects)
    c.shares = shares
    chosen.why_not_first = f"step {k}: {what} refined, held-out gap {c.gap_after_heldout:.3f} m"
    say(f"step {k}: {what} refined, held-out gap {c.gap_after_heldout:.3f} m")
    return c, wider


def _backward(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, stopped, say,
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
        out = list(mapper(score, [j for j in jobs if j[1]])) if any(j[1] for j in jobs) else []
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
        steps.append({"step": k, "removed": e, "candidate": c.effect if c is not None else "none",
                      "gap_heldout_before_m": chosen.gap_after_heldout, "gap_heldout_after_m": without,
                      "gain_m": -cost, "new_params": 0, "accepted": True, "share": None, "alternatives": {}})
        say(f"step {k}: {e} removed, held-out gap {without:.3f} m")
        stopped = f"{stopped}; then {e} removed (added back it would not earn its place)"
        chosen.why_not_first = f"step {k}: {e} removed, added back it would not earn its place"
        if c is None:
            return None, stopped
        c.step = k
        fitted.append(c)
        left = {x: s for x, s in (chosen.shares or {}).items() if x != e and s is not None}
        c.shares = _rescaled(left, without, gap_before)
        chosen = c


# the effects that can be a calibration within a data sheet's tolerance (`explanation`): what an event may be traded for
CALIBRATIONS = tuple(e for e, eff in EFFECTS.items() if any(p.tolerance is not None for p in eff.params.values()))


def _trade(chosen, paths, pool, dropped, setup, mapper, score, floor, gap_before, steps, fitted, failed, stopped,
           say, prefit=None):
    """The selected set with fewer events where the logs cannot tell the
    difference: `choose`'s rule (within the noise floor of each other, the
    explanation naming fewest events) over the whole set once selection
    ends, not one step at a time. A greedy step can take an event that
    stands in for the hardware's spread about its data sheets (a vertical
    steady wind for a drogue lift within its tolerance, under a drag change
    that sinks the drogue), and later steps build on it; neither backward
    elimination (the event is not redundant: the calibration is not there)
    nor a later step (the calibration adds too little to be accepted)
    undoes it. Tried where two or more events are named: each named event
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
    against a floor of 0.021 m). Given `prefit` (`fitted_gap`), each trade
    is first fitted on all the logs at once, and scored held out only when
    that gap is within the bar: most trades fail, and their folds are the
    cost (the KDC-10 engagement family took 343 s with them all scored,
    301-318 s with the prefit, 278 s without trades, on one day). Shares as `_backward`'s: the traded-in
    effect takes the traded-out one's, an added one its own gain, scaled to
    the set's shrink."""
    prior = setup.prior_effects

    def named(c):
        return simplest(c, prior)[0]
    bar = chosen.gap_after_heldout + floor
    while len(events := explain(chosen.effects, chosen.params, prior)[0]) >= 2:
        spare = [e for e in pool if e in CALIBRATIONS and e not in chosen.effects and e not in dropped]
        # a trade succeeds only with its calibration within tolerance, about its data sheet's
        # value: it is polished from there with the others from the set's values, not gridded
        # over its whole search range (the forward step's cost again)
        swaps = [(e, f, (paths, ordered([x for x in chosen.effects if x != e] + [f]), setup,
                         _at_sheet(warm_start(chosen, setup.refined), f, setup))) for e in events for f in spare]
        if prefit is not None and swaps:
            # fitted on everything first: a trade that misses the bar there misses it held out
            swaps = [t for t, g in zip(swaps, mapper(prefit, [job for _, _, job in swaps]))
                     if g is not None and g <= bar]
        out = list(mapper(score, [job for _, _, job in swaps])) if swaps else []
        failed += [c for c in out if not c.success]
        trades = [(e, f, c) for (e, f, _), c in zip(swaps, out) if c.success]
        trades += [(None, f, c) for f in spare for c in fitted
                   if c.success and set(c.effects) == set(chosen.effects) | {f}]
        k = steps[-1]["step"] + 1
        for _, _, c in trades:
            if c not in fitted:
                c.step = k
                fitted.append(c)
        ok = [t for t in trades if named(t[2]) < len(events) and not implausibility(t[2])
              and t[2].gap_after_heldout <= bar]
        if not ok:
            return chosen, stopped
        e, f, c = min(ok, key=lambda t: simplest(t[2], prior))
        c.step = k
        what = f"{e} traded for {f}" if e else f"{f} added"
        steps.append({"step": k, "traded": what, "candidate": c.effect,
                      "gap_heldout_before_m": chosen.gap_after_heldout, "gap_heldout_after_m": c.gap_after_heldout,
                      "gain_m": chosen.gap_after_heldout - c.gap_after_heldout,
                      "new_params": c.n_params - chosen.n_params, "accepted": True, "share": None,
                      "alternatives": {t[2].effect: t[2].gap_after_heldout for t in trades if t[2] is not c}})
        say(f"step {k}: {what}, held-out gap {c.gap_after_heldout:.3f} m, naming {named(c)} event(s)")
        stopped = f"{stopped}; then {what} (as well held out, naming fewer events)"
        chosen.why_not_first = f"step {k}: {what}, naming fewer events within the noise floor"
        shares = {x: s for x, s in (chosen.shares or {}).items() if x != e and s is not None}
        gain = max(chosen.gap_after_heldout - c.gap_after_heldout, 0.0) / gap_before if gap_before else 0.0
        shares[f] = ((chosen.shares or {}).get(e) if e else gain) or 0.0
        c.shares = _rescaled(shares, c.gap_after_heldout, gap_before)
        chosen = c
    return chosen, stopped


def _at_sheet(warm: dict, effect: str, setup) -> dict:
    """`warm` (a `warm_start`) with `effect`'s calibrated parameters at their
    off values (the data sheet's, or the fleet's, `Setup.off`)."""
    sheet = {effect: {k: setup.off(effect, k) for e, k, _ in calibrated_params((effect,), setup.refined)}}
    return {"folds": [{**f, **sheet} for f in warm["folds"]], "all": {**warm["all"], **sheet}}


def with_random(sel: Selection, alone: Candidate, joint: Candidate | None, gap_before: float,
                estimate) -> Selection:
    """`sel` with the random effect's candidates among the fitted: turbulence
    `alone` (against the baseline) and `joint` (the selected set with it, or
    None), whose sigma `estimate` (`turbulence.SigmaEstimate`) is the
    evidence. It joins the selected set (none selected: alone) when its
    random motion is real (sigma^2 detected at two standard errors from zero,
    its drogue-band motion above the tracker noise) and at least light,
    sigma >= `LIGHT_TURBULENCE_MPS` (MIL-HDBK-1797): the calmer air of every
    flight keeps its sigma in the ranking but is not named. Not by the gap's
    acceptance rule: a random effect's evidence is the random motion, and the
    gap's components barely see it (a trail's are its steady shape and
    position; a 1.2 m/s turbulence on a trail cut them by 0.014 m against a
    0.043 m bar and was refused), while beside a large steady offset it cuts
    the RMS by next to nothing (gaps add in quadrature). Its share is its gain
    on top of the set over the baseline held-out gap."""
    extra = [c for c in (alone, joint) if c is not None]
    current = sel.chosen.gap_after_heldout if sel.chosen else gap_before
    cand = joint if sel.chosen is not None else alone
    if cand is None:
        return dataclasses.replace(sel, fitted=sel.fitted + extra)
    gain = current - cand.gap_after_heldout
    sigma, se = estimate.sigma_mps, estimate.stderr_mps
    refused = ((not estimate.real and f"shows no random motion above the noise: {estimate.why}") or (
        sigma < LIGHT_TURBULENCE_MPS
        and f"has sigma {sigma:.2f} +/- {se:.2f} m/s, calmer than light turbulence ({LIGHT_TURBULENCE_MPS:g} m/s, "
            f"MIL-HDBK-1797): the air of every flight"))
    k = sel.steps[-1]["step"] + 1 if sel.steps else 1
    step = {"step": k, "added": "turbulence", "candidate": cand.effect, "gap_heldout_before_m": current,
            "gap_heldout_after_m": cand.gap_after_heldout, "gain_m": gain, "new_params": 1,
            "accepted": not refused, "share": gain / gap_before if gap_before else None, "alternatives": {}}
    cand.step = k
    if refused:
        cand.why_not_first = cand.why_not_first or f"adding turbulence refused, it {refused}"
        return dataclasses.replace(sel, fitted=sel.fitted + extra, steps=sel.steps + [step])
    cand.shares = {**(sel.chosen.shares if sel.chosen else {}), "turbulence": step["share"]}
    return dataclasses.replace(sel, chosen=cand, fitted=sel.fitted + extra, steps=sel.steps + [step],
                               stopped=f"{sel.stopped}; then turbulence accepted from its statistics")
