"""The diagnosis of a family of logs: screen the applicable effects, select
several at once by forward selection, score each held out and rank them.

1. Where: the baseline residual's where-map (`where`).
2. Which: every library effect that can change the kind's observables is
   screened by its sensitivity pattern (`screen`); forward selection
   (`select`) draws on every screened effect (the screen orders them: a
   local signature, the bow wave before contact, screens low beside a
   steady offset yet may be all that is left once that is explained),
   first fitting the model-form ones, then adding the effect that most
   cuts the held-out gap (`fit.TimeBlocks` for one log, `fit.LeaveOneLogOut`
   for several) while its gain beats the noise and the parameter penalty, up
   to `MAX_EFFECTS` effects. The selected set ranks first, then every other
   candidate fitted on the way (each step's alternatives, the singles among
   them) by held-out gap times (1 + `PARAM_PENALTY` per parameter), "none"
   last; "none" first when no effect earned its place. A candidate whose
   simulation fails is recorded with the reason and left out of the ranking.
   A fit with a value on its search bound (or within a standard error of it)
   or outside its physical range is flagged and ranked behind every
   plausible explanation (incl. "none") whose held-out gap is within the
   noise floor of its own. An explanation names its events apart from model
   form and from calibrations within a data sheet's tolerance
   (`explanation`).
   Each ranked candidate carries a probability: the deterministic ones Akaike
   weights of their held-out residuals under the log's noise model
   (`probabilities`), each against the best over the effective number of
   held-out components in which the two differ (`separating_components`); a set with turbulence shares its deterministic
   set's weight by the probability that the random motion is real and at
   least light (`random_presence`, `with_random_share`): a random effect
   leaves the residual as it is and adds variance, so its lower "gap" is no
   like-for-like evidence against the deterministic sets. Then
   turbulence from its statistics (`turbulence`): joined to the selected set
   when its random motion is real and at least light (`select.with_random`),
   a deterministic effect within what it explains by chance along the
   effect's own pattern moved behind it, or behind "none" when it is only the
   everyday air. Once that random motion is real, a deterministic event must
   beat it too: when a selected step's gain is within the noise floor and
   what the turbulence explains by chance along the step's pattern (at
   Sidak's quantile for the best of the additions the step tried,
   `accept.chance_quantile`), added in quadrature (`within_chance`,
   `turbulence.RandomEffect.chance_offset`), or it added a transient
   fitted implausibly (a gust on its bound: that motion's largest burst), the
   selection runs again with every step held to that (a random motion's low
   frequencies lie alike in both halves of a log, so an effect whose pattern
   they share cuts the held-out gap too; one whose pattern they miss, a
   lag's phase or the bow wave before contact, does not). Pairs of screened
   effects whose sensitivity patterns are parallel on the logs are recorded as
   not separable (`identify`).
3. How much: gap before, after on training data, after held out, per log and
   per family, with each parameter's standard error and each selected
   effect's share of the gap.

Compute only: `diagnose` returns a `Diagnosis`; `report` writes it.
"""
from __future__ import annotations

import math
import os

import numpy as np
import time
from pathlib import Path
from typing import Callable

from solver.effects import EFFECTS
from workbench.config import defaults
from workbench.diagnosis.accept import acceptance, widened
from workbench.diagnosis.evaluate import evaluate, gap, observed, record
from workbench.diagnosis.explanation import events_of, explain, implausibility
from workbench.diagnosis.findings import findings
from workbench.diagnosis.fit import Components, baseline_held_out, splitter_for
from workbench.diagnosis.identify import not_separable
from workbench.diagnosis.remainder import remainder
from workbench.diagnosis.reel import EFFECT, established, reel_evidence, reel_tracks, with_reel
from workbench.diagnosis.result import Candidate, Diagnosis, FamilyDiagnosis
from workbench.diagnosis.screen import screen_scores
from workbench.diagnosis.score import fitted_gap
from workbench.diagnosis.select import Selection, forward_select, implausible_transient, with_random
from workbench.diagnosis import fleet
from workbench.diagnosis.setup import (DEFAULT_ELEMENTS, GAP_DEFINITION, LIGHT_TURBULENCE_MPS, MAX_EFFECTS,
                                       NOISE_FACTOR, PARAM_PENALTY, Setup, applicable, calibrated_params, family_of,
                                       freeze, one_log_event, refinable)
from workbench.diagnosis.turbulence import random_candidate
from workbench.diagnosis.where import where_map
from workbench.parallel import Mapper


BASELINES = ("fleet", "datasheet")


def _default_workers(workers: int | None) -> int:
    """`workers`, else one per core up to `diagnosis.max_workers`."""
    return workers or max(1, min(os.cpu_count() or 1, defaults["diagnosis.max_workers"]))


def plausible_first(ranking: list, floor: float) -> list:
    """`ranking` with each implausible candidate moved behind the last
    plausible one whose held-out gap exceeds its own by no more than the noise
    floor `floor` (similar gaps: the data cannot tell them apart, physics can)."""
    for c in ranking:
        c.implausible = implausibility(c)
    pos = {}
    for i, c in enumerate(ranking):
        pos[id(c)] = float(i)
        if c.implausible:
            similar = [j for j, p in enumerate(ranking) if j > i and not p.implausible
                       and p.gap_after_heldout - c.gap_after_heldout <= floor]
            if similar:
                pos[id(c)] = max(similar) + 0.5
                c.why_not_first = (f"implausible fit ({c.implausible}); {ranking[max(similar)].effect} explains "
                                   f"the logs as well, within the noise floor {floor:.3f} m")
    return sorted(ranking, key=lambda c: pos[id(c)])


def effective_components(residuals) -> float:
    """How many independent pieces of evidence `residuals` (each a
    `Residual`) hold: per log and channel, n (1 - rho) / (1 + rho), rho the
    lag-1 autocorrelation of its components in their order (time, then
    station), at least one; Bartlett's effective sample size of an AR(1)
    series (Zwiers & von Storch 1995). A model-form remainder is smooth, so
    hundreds of its components carry the evidence of a few. Components left
    out as irreproducible (floor 0, `evaluate`) are no evidence."""
    n = 0.0
    for R in residuals:
        for ch in np.unique(R.channel):
            x = R.r[(R.channel == ch) & (R.floor > 0)]
            if len(x) < 3 or not np.any(x):
                n += len(x)
                continue
            rho = min(max(float(np.dot(x[:-1], x[1:]) / np.dot(x, x)), 0.0), 1.0)
            n += max(len(x) * (1.0 - rho) / (1.0 + rho), 1.0)
    return n


def probabilities(gaps, n_params, floor: float, n, chance=0.0) -> list[float]:
    """Akaike weights of candidates from their held-out gaps (RMS, m), the
    best's g_min, over `n` effective held-out residual components (one count
    for all, or one per candidate: `separating_components`):
    -2 ln L = n (g^2 - g_min^2) / s^2 under Gaussian noise of variance
    s^2 = max(floor^2, g_min^2) (the log's noise, widened to the best
    candidate's misfit when that is larger, so a model-form remainder is not
    read as evidence; Burnham & Anderson's quasi-likelihood), plus 2 per
    parameter. The evidence per m^2, n / s^2, is at most
    2 / (NOISE_FACTOR^2 (floor^2 + chance^2)): the selection's own test
    (`accept.acceptance`, against the floor `accept.widened` by what a real
    random motion explains by chance, `chance` in m, one for all or one per
    candidate along the pattern that tells it from the best), so that a
    candidate explaining NOISE_FACTOR x that floor more than another, with
    one parameter more, weighs the same: the probabilities and the selection
    read the evidence alike, and a smooth difference of hundreds of
    components is no more decisive than the noise rule allows. They sum to 1
    over the candidates given."""
    g = np.asarray(gaps, float)
    g_min = float(np.min(g))
    s2 = max(floor ** 2, g_min ** 2, 1e-300)
    cap = 2.0 / (NOISE_FACTOR ** 2 * np.maximum(floor ** 2 + np.asarray(chance, float) ** 2, 1e-300))
    per_m2 = np.minimum(np.asarray(n, float) / s2, cap)
    aic = per_m2 * (g ** 2 - g_min ** 2) + 2.0 * np.asarray(n_params, float)
    w = np.exp(-0.5 * (aic - aic.min()))
    return (w / w.sum()).tolist()


def separating_components(c: Candidate, best: Candidate, n: float) -> float:
    """How many independent pieces of held-out evidence tell `c` from `best`:
    the effective count (`effective_components`) of the difference of their
    squared held-out residuals, component by component. Two fits that differ
    by a smooth pattern (a steady wind standing in for a drag change, both
    absorbing the same model-form remainder) differ in a few pieces however
    many components the logs hold; white differences count one each. `n`
    (the count of the selected set's residual) where either has no held-out
    components kept, or they are not the same components."""
    a, b = c.held_out, best.held_out
    if c is best or a is None or b is None or len(a) != len(b) or any(len(x.r) != len(y.r) for x, y in zip(a, b)):
        return n
    return effective_components([Components(x.r ** 2 - y.r ** 2, x.floor, x.channel) for x, y in zip(a, b)])


def random_presence(estimate) -> float:
    """The probability that the turbulence `estimate` (`turbulence.SigmaEstimate`,
    or None) measured is an event: 0 unless its random motion is real (the
    selection's detection, `select.with_random`), else that sigma is at least
    light (`LIGHT_TURBULENCE_MPS`), Phi((sigma_hat - light) / its standard
    error) under the estimate's Gaussian error."""
    if estimate is None or not estimate.real or not estimate.stderr_mps > 0:
        return 0.0
    z = (estimate.sigma_mps - LIGHT_TURBULENCE_MPS) / estimate.stderr_mps
    return 0.5 * math.erfc(-z / math.sqrt(2.0))


# effects not simulated, whose evidence is their own (turbulence: its statistics;
# the reel lag: the reel channel, `reel`), each with a probability of presence
MEASURED = ("turbulence", EFFECT)


def _form(c: Candidate) -> tuple:
    """`c`'s simulated effects with the names of their fitted parameters."""
    return tuple((e, tuple(sorted(c.params.get(e, {})))) for e in c.effects if e not in MEASURED)


def with_random_share(ranking: list, weights: dict, presence: dict) -> None:
    """Set every candidate's probability from `weights` ({id: Akaike weight}
    of the simulated candidates, those without a `MEASURED` effect, summing
    to 1): the candidates over one simulated set (found in `ranking` by its
    effects and parameters; "none" for measured effects alone) share its
    weight as independent events of probability `presence` ({effect: p}):
    one with measured effects X takes the product of p over X and of 1 - p
    over the other measured effects ranked on that set; one whose simulated
    set is not ranked gets 0."""
    # a set is its effects and their fitted parameters: a refinement of its form
    # (`revise.refine`) fits the same effects with one parameter more
    by_set = {_form(c): c for c in ranking if not set(c.effects) & set(MEASURED)}
    on_set: dict = {}
    for c in ranking:
        on_set.setdefault(_form(c), set()).update(set(c.effects) & set(MEASURED))
    for c in ranking:
        measured = set(c.effects) & set(MEASURED)
        # a simulated candidate keeps its own weight: another fit of the same form (a step's
        # refit) is its own evidence; the one its measured variants stand on shares it with them
        d = by_set.get(_form(c)) if measured else c
        variants = on_set[_form(c)] if measured or by_set.get(_form(c)) is c else set()
        share = math.prod(presence.get(e, 0.0) if e in c.effects else 1.0 - presence.get(e, 0.0) for e in variants)
        c.probability = (weights.get(id(d), 0.0) if d is not None else 0.0) * share


def rank_selection(sel: Selection, none: Candidate, floor: float, n_heldout: float,
                   prior: dict | None = None, presence: dict | None = None, chance: Callable | None = None) -> list:
    """The ranking of what forward selection fitted: the selected set first,
    then the other candidates by score (held-out gap x (1 + `PARAM_PENALTY`
    per parameter)), `none` last; `none` first when no set was selected. Then
    implausible fits move behind similar plausible ones (`plausible_first`);
    each candidate gets the events it names (`explanation.explain`, about
    the setup's `prior` where it has one) and its
    probability over the `n_heldout` held-out residual components
    (`probabilities` among the deterministic candidates, each against the
    best on the evidence that separates them, `separating_components`; a set with
    measured effects taking their `presence` ({effect: p}) of its simulated set's
    weight: `with_random_share`; the evidence capped at what a real random motion
    explains by chance along the pattern that tells each from the best,
    `chance(c, best)` in m, when given)."""
    for c in sel.fitted:
        c.score = c.gap_after_heldout * (1 + PARAM_PENALTY * c.n_params)
    others = sorted((c for c in sel.fitted if c is not sel.chosen), key=lambda c: c.score)
    ranking = [none] + others if sel.chosen is None else [sel.chosen] + others + [none]
    ranking = plausible_first(ranking, floor)
    for c in ranking:
        c.named, c.calibrations = explain(c.effects, c.params, prior)
    det = [c for c in ranking if not set(c.effects) & set(MEASURED)]
    best = min(det, key=lambda c: c.gap_after_heldout)
    n = [separating_components(c, best, n_heldout) for c in det]
    offsets = [chance(c, best) if chance is not None else 0.0 for c in det]
    weights = probabilities([c.gap_after_heldout for c in det], [c.n_params for c in det], floor, n, offsets)
    with_random_share(ranking, {id(c): w for c, w in zip(det, weights)}, presence or {})
    # what each probability rests on, kept so that it can be read (and weighed again) later
    for c, k, x in zip(det, n, offsets):
        c.weighed_on = {"separating_components": float(k), "chance_m": float(x)}
    for c in ranking:
        if set(c.effects) & set(MEASURED):
            c.weighed_on = {"presence": {e: (presence or {}).get(e, 0.0) for e in c.effects if e in MEASURED}}
    return ranking


def named_probability(ranking: list) -> dict[str, float]:
    """{events named: the summed probability of the ranked explanations that
    name exactly them}, likeliest first: explanations apart only by their
    calibrations within a data sheet's tolerance or their model form say the
    same thing about the flight, and an engineer asks how likely that is."""
    out: dict[str, float] = {}
    for c in ranking:
        out[events_of(c)] = out.get(events_of(c), 0.0) + (c.probability or 0.0)
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def within_chance(sel: Selection, turb, floor: float) -> list[str]:
    """The events `sel` selected whose step `acceptance` refuses against the
    noise floor `widened` by what the turbulence (`turb`, a
    `turbulence.RandomEffect`) explains by chance along the step's own
    pattern (`RandomEffect.chance_offset`), the step's pick the best of all
    it tried, or that added a transient event fitted implausibly (beside a
    real random motion, its largest burst: `select.implausible_transient`);
    none unless its random motion is real."""
    if sel.chosen is None or turb.estimate is None or not turb.estimate.real:
        return []
    return [s["added"] for s, before, after in sel.additions()
            if not s.get("standing") and s["added"] in sel.chosen.effects
            and (acceptance(s["gain_m"], s["new_params"], s["gap_heldout_before_m"],
                            widened(floor, turb.chance_offset, before, after, 1 + len(s["alternatives"])))
                 or implausible_transient(after, before.effects if before else ()))]


def _simulated(c: Candidate | None) -> dict:
    """The effects of `c` a simulation can carry: all but the `MEASURED` ones
    (no realisation of a random one to simulate; the reel lag on a prescribed
    payout); {} for none."""
    return {e: v for e, v in (c.params if c else {}).items() if e not in MEASURED}


def diagnose_family(paths: list[str], setup: Setup = Setup(), mapper: Callable | None = None,
                    progress: Callable[[str], None] | None = None) -> FamilyDiagnosis:
    """The where-map, ranking and gaps of one family of logs."""
    mapper = mapper or Mapper(_default_workers(None))
    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    paths = [str(p) for p in paths]
    recs = {p: record(p) for p in paths}
    kind = recs[paths[0]].info.test_kind
    case = setup.case_for(recs[paths[0]])
    base = {p: evaluate(p, {}, setup) for p in paths}
    gap_before = gap([gap(base[p].r) for p in paths])
    floor = gap([gap(base[p].floor) for p in paths])
    # one log: its gap before is that of both segments (every component held
    # out once); several: the RMS of the logs' gaps
    gap_before_heldout = gap_before_train = gap(base[paths[0]].r) if len(paths) == 1 else gap_before
    where = {Path(p).stem: where_map(observed(p), base[p]) for p in paths}
    say(f"{family_of(recs[paths[0]])}: baseline gap {gap_before:.3f} m, noise floor {floor:.3f} m"
        + (f" (against the fleet calibration: {', '.join(sorted(setup.prior_effects))})" if setup.prior else ""))

    excluded = {}
    cands = []
    for e in EFFECTS:
        why = applicable(e, kind, case, recs[paths[0]]) or (len(paths) > 1 and one_log_event(e))
        if why:
            excluded[e] = why
        else:
            cands.append(e)
    reel, est = _reel(paths, recs, kind, case, excluded)
    scores, screen_failed, columns = screen_scores(paths, cands, setup, base, mapper)
    failed = [Candidate(e, [e], len(calibrated_params((e,))), success=False, message=f"screen probe: {why}")
              for e, why in screen_failed.items()]
    order = sorted(scores, key=lambda e: -scores[e])
    say("screen: " + ", ".join(f"{e} {scores[e]:.2f}" for e in order))
    # every screened effect: the screen's share of the baseline residual orders
    # the pool but does not cut it, for an effect whose signature is local (the
    # bow wave in the seconds before contact) spans a few per cent of a baseline
    # dominated by a steady offset, yet may be all that is left once that is explained
    pool = order
    forms = refinable(case)
    sel = forward_select(paths, pool, setup, mapper, gap_before_heldout, floor, say=say, refinable=forms,
                         prefit=fitted_gap)
    # turbulence from its statistics, its random motion measured about the selected set's time runs
    turb = random_candidate(paths, base, sel.chosen, setup, mapper)
    chance = within_chance(sel, turb, floor)
    if chance:
        # a random motion's low frequencies lie alike in both halves of a log: an effect
        # whose pattern they share cuts the held-out gap by chance too, so once the motion
        # is real each step must beat what it explains along that step's pattern as well
        say(f"{', '.join(chance)} within what turbulence of at most {turb.estimate.sigma_mps:.2f} m/s explains by "
            f"chance along its pattern, or implausible beside it: selecting again, each step against the noise "
            f"floor and that")
        sel = forward_select(paths, pool, setup, mapper, gap_before_heldout, floor, say=say,
                             chance=turb.chance_offset, refinable=forms, prefit=fitted_gap)
        sel.stopped += (f" (each step against the noise floor and what the random motion explains by chance "
                        f"along its pattern, and plausible: {', '.join(chance)} had been accepted within it or "
                        f"implausible)")
        turb = random_candidate(paths, base, sel.chosen, setup, mapper)
    failed += sel.failed
    excluded.pop("turbulence", None)
    if turb.candidate.success:
        sel = with_random(sel, turb.candidate, turb.joint, gap_before_heldout, turb.estimate)
    else:
        failed.append(turb.candidate)
    say(f"selection: {'+'.join(sel.chosen.effects) if sel.chosen else 'none'} ({sel.stopped})")
    for c in failed:
        say(f"failed, not ranked: {c.effect}: {c.message}")
    for c in sel.fitted:
        c.gap_before = gap_before_heldout if len(paths) == 1 else gap_before
        c.gap_before_train = gap_before_train
        c.shrink_heldout = 1.0 - c.gap_after_heldout / gap_before_heldout if gap_before_heldout else None
        c.screen_share = {e: scores.get(e) for e in c.effects}
    none = Candidate("none", [], 0, gap_before=gap_before_heldout if len(paths) == 1 else gap_before,
                     gap_after_train=gap_before_train, gap_after_heldout=gap_before_heldout, shrink_heldout=0.0,
                     score=gap_before_heldout, held_out=baseline_held_out(paths, base))
    if reel is not None:
        sel = with_reel(sel, none, reel)
        say(f"reel: {reel.why()}")
    within_noise = gap_before <= NOISE_FACTOR * floor
    if sel.chosen is None:
        none.why = ("the baseline explains the logs to within their noise" if within_noise else
                    f"no effect earns its place: {sel.stopped}")
    # the evidence's independent pieces, counted in what the selected set leaves
    n_eff = effective_components([evaluate(p, _simulated(sel.chosen), setup) for p in paths])
    ranking = turb.credit_steady(rank_selection(sel, none, floor, n_eff, setup.prior_effects,
                                                {"turbulence": random_presence(turb.estimate),
                                                 **({EFFECT: reel.presence} if reel is not None else {})},
                                                turb.chance_offset),
                                 accepted=sel.chosen is not None and "turbulence" in sel.chosen.effects)
    if reel is not None and not reel.event:
        # the refused reel lag alone is "none" with an event the reel channel did not bear out
        alone = [c for c in ranking if c.effects == [EFFECT]]
        rest = [c for c in ranking if c.effects != [EFFECT]]
        ranking = rest[:rest.index(none) + 1] + alone + rest[rest.index(none) + 1:]
    if ranking[0] is none and not none.why:
        none.why = (f"what the selected set explains is within {NOISE_FACTOR:g} x what the day's air "
                    f"(turbulence of {turb.sigma_under(sel.chosen):.2f} m/s) explains by chance along its pattern "
                    f"({turb.chance_offset(None, sel.chosen):.3f} m)")
    remaining = ranking[0].gap_after_heldout
    # where the gap lies once the best explanation's deterministic effects are in
    # (their parameters fitted on all logs): what is left for the next effect to
    # explain; a random effect has no realisation to simulate
    after = {}
    det = _simulated(ranking[0])
    left = {Path(p).stem: evaluate(p, det, setup) for p in paths}
    if det:
        after = {Path(p).stem: where_map(observed(p), R) for p, R in zip(paths, left.values())}
    return FamilyDiagnosis(
        family=family_of(recs[paths[0]]), kind=kind, logs=[Path(p).stem for p in paths],
        n_elements=setup.n_elements, gap_definition=GAP_DEFINITION[kind], gap_before=gap_before,
        noise_floor=floor, gap_real=not within_noise,
        held_out_scheme=splitter_for(paths).scheme,
        screen={e: scores[e] for e in order}, not_applicable=excluded,
        ranking=ranking, failed=failed, selection=sel.to_json(),
        remaining_unexplained={"gap_m": remaining,
                               "above_noise_m": math.sqrt(max(remaining ** 2 - floor ** 2, 0.0))},
        gap=where, gap_after_best=after, wall_s=time.perf_counter() - t_start, steady_floor_m=turb.steady_floor_m,
        remainder=remainder(left), named_probability=named_probability(ranking),
        not_separable=not_separable(columns, np.concatenate([base[p].floor for p in paths])),
        baseline=setup.prior_effects, reel=reel.to_json() if reel is not None else None, reel_established=est)


def _reel(paths, recs, kind: str, case, excluded: dict):
    """(the family's reel evidence, or None; the reference its own logs
    establish for its reel, or None): on an engagement whose baseline
    prescribes the logged payout, the take-up against the fleet file's
    reference response of its reel (`reel`), the reel lag then no longer
    excluded; without a reference it stays excluded, saying so."""
    if kind != "engagement" or case["model"]["reel"] != "from_log":
        return None, None
    reel_id = recs[paths[0]].info.raw.get("reel")
    tracks = reel_tracks(paths, recs)
    est = established(tracks, reel_id)
    ref = fleet.reel_references().get(reel_id)
    evidence = reel_evidence(tracks, reel_id, ref) if ref is not None else None
    if evidence is not None:
        excluded.pop(EFFECT, None)
    elif EFFECT in excluded:
        excluded[EFFECT] += (f"; its evidence, the payout against a reference response of reel {reel_id}, "
                             f"has no such reference ({fleet.FLEET_PATH.name}) or no reel track in the logs")
    return evidence, est


def group_families(paths) -> dict[str, list[str]]:
    fam: dict[str, list[str]] = {}
    for p in paths:
        fam.setdefault(family_of(record(str(p))), []).append(str(p))
    return {k: sorted(v) for k, v in fam.items()}


def diagnose(paths, n_elements: int = DEFAULT_ELEMENTS, workers: int | None = None, scheduler: str | None = None,
             progress: Callable[[str], None] | None = None, baseline: str = "fleet") -> Diagnosis:
    """Diagnose every family among `paths` (local processes, or the Dask
    cluster at `scheduler`), each against its fleet calibration where the
    fleet file lists its family and `baseline` is "fleet" (`fleet`), else
    against the data sheets ("datasheet")."""
    if baseline not in BASELINES:
        raise ValueError(f"baseline must be one of {BASELINES}, got {baseline!r}")
    calibrated = fleet.load() if baseline == "fleet" else {}
    with Mapper(_default_workers(workers), scheduler) as mapper:
        fams = {name: diagnose_family(ps, Setup(n_elements, prior=freeze(calibrated.get(name, {}))), mapper,
                                      progress)
                for name, ps in group_families(paths).items()}
    return Diagnosis(logs=[str(p) for p in paths], families=fams,
                     findings=[f for d in fams.values() for f in findings(d)],
                     scheduler=scheduler or "local processes", gap_definition=GAP_DEFINITION,
                     noise_factor=NOISE_FACTOR, param_penalty=PARAM_PENALTY, max_effects=MAX_EFFECTS,
                     baseline=baseline)
