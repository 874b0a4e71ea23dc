"""Forward selection of several effects at once: from the baseline, add the
screened effect that most cuts the held-out gap, one step at a time.

Step 0 fits the pool's model-form effects (`Effect.model_form`: the tracked
point on the drogue, a difference of definition between model and
instruments in every log of the hardware) and keeps them when they cut the
held-out gap at all: no event then stands in for them, and none is refused
because they took part of its gain. They name no event, and do not count
towards `MAX_EFFECTS`.

Step k fits every screened effect not yet selected (nor failed to simulate)
together with the k - 1 selected ones (`score.score_candidate`: per fold
and on all logs, warm-started at the selected set's fitted values,
`fit.EffectCalibrator.fit(parts, start=...)`) and scores it held out on
the same folds. The step takes the best plausible
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
chance along the addition's own pattern, and an addition within it, or
adding a transient fitted implausibly (`implausible_transient`), is set
aside before the step chooses. A transient event whose fitted amplitude the
two halves of a log do not establish (`unestablished`: within
`NOISE_FACTOR` standard errors of none, their spread folded in) is refused
whatever it explains.
Where the step's best addition is an event fitted implausibly (a value on
its search bound: it stands in for what the library's form lacks), a field among the
additions whose form the hardware lets the logs refine (the tanker wake's
sheet) is fitted again with its form free before the step chooses
(`_field_look`); taken so, its form stays free in the later steps.
Otherwise, the refused step is looked at once more (`_second_look`): its
best transient event (a gust, at a time in the log) fitted beside each
calibration within a data sheet's tolerance not selected (the hardware's
spread sets the response an event leaves), a pair taken as one step when it
earns its place against the set and against the set with the calibration
alone. Otherwise, or at `MAX_EFFECTS` effects, the selection stops and says
why.
Once it stops, the selected set is revised (`revise`): its form parameters
refined where the family's hardware lets the logs tell them, an event the
later ones made redundant dropped, an event traded for a calibration within
its data sheet's tolerance where the logs cannot tell the two sets apart and
the event would not earn its place back beside the calibration.
Each accepted effect's share of the gap is its step's gain over the baseline
held-out gap: the shares add up to the selected set's held-out shrink.

The hook points are the pool (a list of effect names, best screened first)
and `score` (a function of one job, (paths, candidate, setup, warm), that
returns a `Candidate`): another candidate kind or scorer plugs in there.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable

from solver.effects import EFFECTS
from workbench.diagnosis.accept import acceptance, bar, choose, widened
from workbench.diagnosis.explanation import implausibility
from workbench.diagnosis.fit import ordered
from workbench.diagnosis.result import Candidate, added_label, selection_step
from workbench.diagnosis.revise import CALIBRATIONS, at_sheet, backward, refine, trade
from workbench.diagnosis.score import mapped, score_candidate, warm_start
from workbench.diagnosis.setup import (LIGHT_TURBULENCE_MPS, MAX_EFFECTS, NOISE_FACTOR, PARAM_PENALTY,
                                       calibrated_params)


def _take(ok: list, chosen: Candidate | None, current: float, floor: float,
          prior: dict | None = None, chance: Callable | None = None) -> tuple[Candidate, str | None]:
    """(the addition a step takes, why it is refused or None). The best
    (`choose`); but when its fit is implausible (`explanation.implausibility`:
    on a search bound, within a standard error of it or outside its physical
    range, standing in for another effect) and a plausible addition's
    held-out gap is similar, within the noise floor or one parameter's worth
    of the gap left (`PARAM_PENALTY` x
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
    that explains by chance more than another explains for real; and a
    transient event fitted implausibly is refused outright
    (`implausible_transient`). With or without it, so is a transient
    event the logs do not establish (`unestablished`)."""
    tried = len(ok)
    selected = tuple(chosen.effects) if chosen else ()

    def verdict(c):
        n_new = c.n_params - (chosen.n_params if chosen else 0)
        why = acceptance(current - c.gap_after_heldout, n_new, current, widened(floor, chance, chosen, c, tried))
        bound = implausible_transient(c, selected) if chance is not None else None
        return why or unestablished(c, selected) or (
            bound and f"is implausible beside a real random motion ({bound}): a transient the logs "
                      f"push to its bound is the largest burst of that motion, not an event")
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


def _second_look(ok: list, chosen: Candidate | None, current: float, floor: float, pool: list, dropped: set,
                 paths: list, setup, mapper: Callable, score: Callable, prefit: Callable | None,
                 chance: Callable | None, k: int) -> tuple[list, tuple | None]:
    """The refused step `k` looked at once more, its best event fitted with a
    calibration freed beside it: (the fits made, (the pair, its event, the
    calibration) or None). The hardware is never exactly its data sheet, and
    where an event's signature is a response (a gust's ring-down), the
    hardware's own spread sets its frequency and damping: measured on a
    proving-ground gust doublet, the gust alone explained 0.0148 m of a
    0.0306 m held-out gap against a 0.0152 m bar, while with the drogue's
    drag freed (fitted 4.5 % above its sheet, within its 10 % tolerance) it
    explained 0.0255 m, near its true amplitude and time; the drag alone cut
    nothing, so no step took it first. Only a transient event is looked at:
    one with an onset time in the log (`Param.scan_s`: a gust), whose
    signature is the free response it excites. A steady offset, a lag or a
    field is matched by its own magnitude and pattern whatever the hardware's
    spread, and the look costs a polish per calibration: on the KDC-10
    families, whose refused steps' best events were a steady wind (doublets)
    and the bow wave (engagements), looking beside them took the doublets from
    258 to 337-409 s and named nothing. The best transient event (the step's
    addition with the smallest held-out gap among those that cut the gap at
    all, plausibly) is fitted with each screened calibration
    not selected (`revise.CALIBRATIONS`), polished from the event's own fit
    in the step and the calibration's sheet value; given `prefit`, each is fitted on
    all logs first and scored held out only when that can beat the bar. A
    pair is taken when, as one change, it earns its place against the set
    (`acceptance`, its new parameters all counted, the noise floor widened
    by chance over every addition tried) and against the set with the
    calibration alone, fitted in the step: the event must earn its place
    beside the freed calibration, not the calibration beside nothing."""
    if chosen is None:
        return [], None
    selected = tuple(chosen.effects)
    events = [c for c in ok if _transient(_added(c, selected)[0]) and c.gap_after_heldout < current
              and not implausibility(c)]
    if not events or _event_slots(selected) + 2 > MAX_EFFECTS:
        return [], None
    own = min(events, key=lambda c: c.gap_after_heldout)
    (event,) = _added(own, selected)
    spare = [f for f in pool if f in CALIBRATIONS and f not in selected and f not in dropped and f != event]
    # polished from the event's own fit in the step: no grid nor scan again, the pair's cost
    # is a polish (on the KDC-10 families a fresh scan and grid of every pair took their
    # doublets from 258 to 409 s and their engagements from 226 to 349 s)
    warm = warm_start(own, setup.refined)
    jobs = [(paths, ordered(selected + (event, f)), setup, at_sheet(warm, f, setup)) for f in spare]
    if prefit is not None and jobs:
        jobs = [jobs[i] for i in _within_bar(jobs, chosen, current, floor, mapper, prefit)]
    out = mapped(mapper, score, jobs)
    tried = len(ok) + len(out)
    taken = []
    for c in out:
        if not c.success:
            continue
        c.step = k
        # the event's time was scanned in the step: the pair's polish stands on every look of it
        c.looks = max(c.looks, own.looks)
        f = next(x for x in c.effects if x not in selected and x != event)
        alone = next((a for a in ok if set(a.effects) == set(selected) | {f}), None)
        why = acceptance(current - c.gap_after_heldout, c.n_params - chosen.n_params, current,
                         widened(floor, chance, chosen, c, tried))
        if why is None and alone is not None:
            why = acceptance(alone.gap_after_heldout - c.gap_after_heldout, c.n_params - alone.n_params,
                             alone.gap_after_heldout, widened(floor, chance, alone, c, tried))
        why = why or implausibility(c) or unestablished(c, selected)
        if why is None:
            taken.append((c, event, f))
        else:
            c.why_not_first = f"step {k}: {event} with {f} freed beside it refused, it {why}"
    return out, (min(taken, key=lambda t: t[0].gap_after_heldout) if taken else None)


def _field_look(ok: list, chosen: Candidate | None, current: float, floor: float, paths: list, setup,
                mapper: Callable, score: Callable, prefit: Callable | None, refinable: tuple,
                k: int) -> tuple[list, list, dict]:
    """(the step's additions, each field among them refitted with its form
    freed where that cuts its held-out gap; the refits made; {id(refit): the
    setup it was fitted with}). Only where the step's best addition is an
    event fitted implausibly (`explanation.implausibility`: a value on its
    search bound, standing in for what the library's form lacks): a field whose form the
    hardware lets the logs refine (`refinable`: the tanker wake's sheet,
    its height and span position) is fitted once more from its own fit in
    the step, its form parameters gridded from their off values and all
    polished; given `prefit`, fitted on all logs first and scored held out
    only when that can beat the bar of the step. Measured on a
    proving-ground engagement with a drogue lift and a wake whose sheet lay
    0.68 m lower than the model's: with the sheet held, the wake cut the
    held-out gap to 0.109 m while a steady wind on its 6 m/s bound cut it to
    0.034 m; refitted with the sheet's height free, the wake cut it to
    0.023 m (strength 1.42-1.49, the sheet 0.73-0.84 m low over the two
    folds; the generator's 1.45 and 0.68). Refining only the selected set
    (`revise.refine`) never reaches a field the held form kept out."""
    selected = tuple(chosen.effects) if chosen else ()
    best = choose(ok, floor, setup.prior_effects)
    # a calibration on its bound is the hardware off its sheet, no flow's stand-in (the G-III
    # doublets' drogue lift at 0.03 x its tunnel value: refitting their wake beside it took
    # 38 s of the family's 5 minutes and changed nothing)
    events = [e for e in _added(best, selected) if e not in CALIBRATIONS]
    if not events or not implausibility(best, events):
        return ok, [], {}
    jobs, olds = [], []
    for c in ok:
        pairs = tuple(pr for pr in refinable if pr[0] in _added(c, selected) and pr not in setup.refined)
        if pairs:
            wider = dataclasses.replace(setup, refined=setup.refined + pairs)
            jobs.append((paths, tuple(c.effects), wider, warm_start(c, setup.refined)))
            olds.append(c)
    if jobs and prefit is not None:
        keep = _within_bar(jobs, chosen, current, floor, mapper, prefit)
        jobs, olds = [jobs[i] for i in keep], [olds[i] for i in keep]
    if not jobs:
        return ok, [], {}
    refits, setups, ok = mapped(mapper, score, jobs), {}, list(ok)
    for old, new, job in zip(olds, refits, jobs):
        if not new.success:
            continue
        new.step = k
        if new.gap_after_heldout < old.gap_after_heldout:
            what = ", ".join(f"{e}.{n}" for e, n in job[2].refined if (e, n) not in setup.refined)
            old.why_not_first = f"step {k}: fitted again with {what} free, held-out gap {new.gap_after_heldout:.3f} m"
            ok[ok.index(old)] = new
            setups[id(new)] = job[2]
        else:
            new.why_not_first = f"step {k}: its form freed cut the held-out gap no more than held"
    return ok, refits, setups


def _within_bar(jobs: list, chosen: Candidate | None, current: float, floor: float, mapper: Callable,
                prefit: Callable) -> list[int]:
    """The indices of `jobs` whose fit on all logs (`prefit`, a lower bound
    of the held-out gap) gets below the bar of their new parameters over
    `chosen` (`accept.bar`): a fit that misses it there misses it held out."""
    n_before = chosen.n_params if chosen else 0
    gaps = mapper(prefit, jobs)
    return [i for i, (j, g) in enumerate(zip(jobs, gaps))
            if g is not None and g < bar(current, len(calibrated_params(j[1], j[2].refined)) - n_before, floor)]


def implausible_transient(c: Candidate, selected) -> str | None:
    """Why the fit of a transient event (`_transient`: a gust, scanned over
    the log) that `c` adds to the `selected` effects is implausible
    (`explanation.implausibility`), or None. Beside a real random motion such
    a fit is its largest burst, not an event: the scan finds that burst and
    the amplitude goes where it leads (measured on an own-solver doublet in
    1.05 m/s turbulence: a gust fitted at -5.6 +/- 0.8 m/s against its 6 m/s
    search bound explained 0.114 m of a 0.202 m held-out gap, beyond the
    0.105 m bar its chance offset set). Not a calibration or a steady
    effect on its bound, which may be the hardware: a proving-ground
    engagement's drogue lift of 0.086 x its sheet, fitted at 0.02 on the
    bound 0, was refused beside the day's 0.29 m/s air and the selection
    named a tanker wake."""
    return implausibility(c, [e for e in _added(c, tuple(selected)) if _transient(e)])


def unestablished(c: Candidate, selected) -> str | None:
    """Why a transient event (`_transient`: a gust) that `c` adds to the
    `selected` effects is not established by the logs, or None: none of its
    fitted amplitudes (its calibrated parameters but the time) lies beyond
    `NOISE_FACTOR` standard errors of its off value, the errors holding the
    folds' spread (`score._one_log_fit`: two fits on alternate blocks of one
    log). An event is one thing in the log, so both halves of it must see it
    alike; a fit whose sign the halves disagree on is a different burst in
    each (measured on a proving-ground doublet with no event withheld: the
    halves put a gust at -2.24 m/s at 16.96 s and +1.79 m/s at 18.61 s, the
    whole log's -2.24 +/- 2.02 m/s, and it explained 0.0348 m of a 0.0551 m
    held-out gap, over its 0.0312 m bar; the true gusts named in the single
    campaign stood 5.4 and 19.7 standard errors from none). No standard
    error (NaN) is no evidence either way. Of several logs the errors are the
    all-logs fit's, with no fold spread in them, and the reason says so."""
    out = []
    for e in (e for e in _added(c, tuple(selected)) if _transient(e)):
        ps = EFFECTS[e].params
        amps = [(k, v, (c.param_stderr or {}).get(e, {}).get(k, math.nan), ps[k])
                for k, v in c.params.get(e, {}).items() if not ps[k].scan_s and ps[k].off is not None]
        if amps and all(se > 0 and abs(v - p.off) <= NOISE_FACTOR * se for k, v, se, p in amps):
            out.append(", ".join(f"{e}.{k} = {v:.3g} +/- {se:.2g} {p.unit}" for k, v, se, p in amps))
    if not out:
        return None
    if len(c.gap_after_all_fit_per_log or {}) > 1:
        return (f"is not established: {'; '.join(out)}, within {NOISE_FACTOR:g} standard errors (of the fit on "
                f"all the family's logs) of none; the logs do not tell the event from no event")
    return (f"is not established: {'; '.join(out)}, within {NOISE_FACTOR:g} standard errors (the folds' spread "
            f"in them) of none; an event the halves of a log see differently is a burst of each, not one event")


def _transient(effect: str) -> bool:
    """Whether `effect` is an event at a time in the log (a parameter scanned
    over the log's span, `Param.scan_s`) rather than a calibration."""
    return effect not in CALIBRATIONS and any(p.scan_s for p in EFFECTS[effect].params.values())


def _added(c: Candidate, selected: tuple) -> list:
    """The effects `c` adds to the `selected` ones."""
    return [e for e in c.effects if e not in selected]


def _event_slots(effects) -> int:
    """How many of `MAX_EFFECTS` `effects` take (model form takes none)."""
    return sum(not EFFECTS[e].model_form for e in effects)


@dataclasses.dataclass
class Selection:
    """What forward selection found: `chosen` the selected set (None: no
    effect earned its place), `fitted` every candidate scored on the way (each
    step's alternatives, the accepted sets among them), `failed` those whose
    simulation failed, `steps` one dict per step, `stopped` why it ended,
    `refined` the form parameters ((effect, parameter), ...) `chosen` was
    fitted with besides the calibrated ones (`refine`)."""

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
    each step's widened by `chance` when given (`widened`), the refused step
    looked at once more with a calibration freed beside its best transient
    event (`_second_look`, each pair first fitted by `prefit` where given); then the form
    parameters `refinable` ((effect, parameter), ...) of the selected set
    refined (`refine`), redundant events dropped (`backward`) and events
    traded for calibrations (`trade`, each trade first fitted by `prefit`
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
        (c,) = mapped(mapper, score, [(paths, standing, setup, None)])
        if not c.success:
            failed.append(c)
        else:
            c.step = 0
            fitted.append(c)
            gain = current - c.gap_after_heldout
            steps.append(selection_step(0, {"added": "+".join(standing), "standing": True}, c.effect, current,
                                        c.gap_after_heldout, c.n_params, gap_before=gap_before,
                                        why=None if gain > 0.0 else "does not cut the held-out gap"))
            if gain > 0.0:
                c.shares = {e: steps[-1]["share"] / len(standing) for e in standing}
                chosen, current = c, c.gap_after_heldout
                say(f"step 0: model form {c.effect}, held-out gap {current:.3f} m")
            else:
                c.why_not_first = "model form that does not cut the held-out gap"
        dropped |= set(standing)
    for k in range(1, MAX_EFFECTS + 1):
        selected = tuple(chosen.effects) if chosen else ()
        if _event_slots(selected) >= MAX_EFFECTS:
            break
        # an effect whose fit failed to simulate is out of the pool: it failed
        rest = [e for e in pool if e not in selected and e not in dropped]
        if not rest:
            stopped = "every screened effect is selected"
            break
        warm = warm_start(chosen, setup.refined) if chosen else None
        jobs = [(paths, ordered(selected + (e,)), setup, warm) for e in rest]
        say(f"step {k}: " + ", ".join("+".join(j[1]) for j in jobs))
        out = mapped(mapper, score, jobs, progress=lambda c: say(f"fitted {c.effect}"))
        failed += [c for c in out if not c.success]
        dropped |= {next(e for e in c.effects if e not in selected) for c in out if not c.success}
        ok = [c for c in out if c.success]
        for c in ok:
            c.step = k
        fitted += ok
        if not ok:
            stopped = f"step {k}: no addition could be simulated"
            break
        ok, refits, setups = _field_look(ok, chosen, current, floor, paths, setup, mapper, score, prefit, refinable,
                                         k)
        failed += [c for c in refits if not c.success]
        fitted += [c for c in refits if c.success]
        best, refused = _take(ok, chosen, current, floor, setup.prior_effects, chance)
        (added,), freed, shares = _added(best, selected), None, {}
        if refused:
            pairs, look = _second_look(ok, chosen, current, floor, pool, dropped, paths, setup, mapper, score, prefit,
                                       chance, k)
            failed += [c for c in pairs if not c.success]
            fitted += [c for c in pairs if c.success]
            if look is not None:
                best.why_not_first = f"step {k}: adding {added} refused, it {refused}"
                (best, added, freed), refused = look, None
                ok = ok + [c for c in pairs if c.success]
                # the calibration's share: what it cut alone in the step, the event the rest
                alone = next((c for c in ok if set(c.effects) == set(selected) | {freed}), None)
                shares = {freed: max(current - alone.gap_after_heldout, 0.0) / gap_before
                          if alone is not None and gap_before else 0.0}
        steps.append(selection_step(k, {"added": added, **({"freed": freed} if freed else {})}, best.effect, current,
                                    best.gap_after_heldout, best.n_params - (chosen.n_params if chosen else 0),
                                    why=refused, gap_before=gap_before,
                                    alternatives={c.effect: c.gap_after_heldout for c in ok if c is not best}))
        what = added_label(steps[-1])
        for c in ok:
            if c is not best and not c.why_not_first:
                c.why_not_first = f"step {k}: adding {what} cut the held-out gap more"
        if refused:
            best.why_not_first = f"step {k}: adding {added} refused, it {refused}"
            stopped = f"step {k}: the best addition, {added}, {refused}"
            break
        share = steps[-1]["share"]
        shares = {**shares, added: share - sum(shares.values()) if share is not None else None}
        best.shares = {**(chosen.shares if chosen else {}), **shares}
        chosen, current = best, best.gap_after_heldout
        # a field accepted with its form freed: the later steps fit it so
        setup = setups.get(id(best), setup)
        say(f"step {k}: {what} accepted, held-out gap {current:.3f} m")
    if chosen is not None:
        chosen, setup = refine(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed, say,
                                chance, refinable)
        chosen, stopped = backward(chosen, paths, setup, mapper, score, floor, gap_before, steps, fitted, failed,
                                    stopped, say, chance)
        chosen, stopped = trade(chosen, paths, pool, dropped, setup, mapper, score, floor, gap_before, steps,
                                 fitted, failed, stopped, say, prefit, chance)
    return Selection(chosen, fitted, failed, steps, stopped, setup.refined)


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
    sigma, se = estimate.sigma_mps, estimate.stderr_mps
    refused = ((not estimate.real and f"shows no random motion above the noise: {estimate.why}") or (
        sigma < LIGHT_TURBULENCE_MPS
        and f"has sigma {sigma:.2f} +/- {se:.2f} m/s, calmer than light turbulence ({LIGHT_TURBULENCE_MPS:g} m/s, "
            f"MIL-HDBK-1797): the air of every flight")) or None
    k = sel.steps[-1]["step"] + 1 if sel.steps else 1
    step = selection_step(k, {"added": "turbulence"}, cand.effect, current, cand.gap_after_heldout, 1, why=refused,
                          gap_before=gap_before)
    cand.step = k
    if refused:
        cand.why_not_first = cand.why_not_first or f"adding turbulence refused, it {refused}"
        return dataclasses.replace(sel, fitted=sel.fitted + extra, steps=sel.steps + [step])
    cand.shares = {**(sel.chosen.shares if sel.chosen else {}), "turbulence": step["share"]}
    return dataclasses.replace(sel, chosen=cand, fitted=sel.fitted + extra, steps=sel.steps + [step],
                               stopped=f"{sel.stopped}; then turbulence accepted from its statistics")
