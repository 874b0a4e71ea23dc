"""The diagnosis of a family of logs: screen the applicable effects, calibrate
the best (and pairs of them), score each held out and rank them.

1. Where: the baseline residual's where-map (`where`).
2. Which: every library effect that can change the kind's observables is
   screened by its sensitivity pattern (`screen`); the best `SCREEN_KEEP` are
   calibrated (`fit.EffectCalibrator`) and scored held out (`fit.TimeBlocks`
   for one log, `fit.LeaveOneLogOut` for several); pairs of the best three
   are fitted when one effect leaves a real gap. Ranked by held-out gap
   times (1 + `PARAM_PENALTY` per parameter); a pair ranks above its better
   member only if it cuts that member's held-out gap by `PAIR_GAIN` and by
   more than the noise (Occam's rule). A candidate whose simulation fails is
   recorded with the reason and left out of the ranking. A fit with a value on
   its search bound or outside its physical range is flagged and ranked
   behind every plausible explanation (incl. "none") whose held-out gap is
   within the noise floor of its own.
   Each ranked candidate carries a probability: Akaike weights of the held-out
   residuals under the log's noise model (`probabilities`). Pairs of screened
   effects whose sensitivity patterns are parallel on the logs are recorded as
   not separable (`identify`).
3. How much: gap before, after on training data, after held out, per log and
   per family, with each parameter's standard error.

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
from workbench.diagnosis.evaluate import evaluate, gap, observed, record
from workbench.errors import SimulationFailed
from workbench.diagnosis.findings import findings
from workbench.diagnosis.fit import EffectCalibrator, splitter_for
from workbench.diagnosis.identify import not_separable
from workbench.diagnosis.result import Candidate, Diagnosis, FamilyDiagnosis
from workbench.diagnosis.screen import screen_scores
from workbench.diagnosis.setup import (DEFAULT_ELEMENTS, GAP_DEFINITION, NOISE_FACTOR, PAIR_FROM,
                                       PAIR_GAIN, PAIR_WHEN_LEFT, PARAM_PENALTY, SCREEN_KEEP, Setup, applicable,
                                       calibrated_params, family_of, to_unit)
from workbench.diagnosis.where import where_map
from workbench.parallel import Mapper


def _default_workers(workers: int | None) -> int:
    """`workers`, else one per core up to `diagnosis.max_workers`."""
    return workers or max(1, min(os.cpu_count() or 1, defaults["diagnosis.max_workers"]))


def _score_candidate(job) -> Candidate:
    """One candidate on one family: fitted per fold and on all logs; each
    fold's held-out gap. Runs in a worker process (or a Dask worker)."""
    paths, candidate, setup = job
    t_start = time.perf_counter()
    n_params = len(calibrated_params(candidate))
    try:
        return _fit_and_score(paths, candidate, setup, n_params, t_start)
    except SimulationFailed as exc:
        return Candidate("+".join(candidate), list(candidate), n_params, success=False, message=str(exc),
                         wall_s=time.perf_counter() - t_start)


def _fit_and_score(paths, candidate, setup, n_params, t_start) -> Candidate:
    folds, fitted = [], []
    for fold in splitter_for(paths).split(paths):
        cal = EffectCalibrator(candidate, setup).fit(fold.train)
        folds.append({"held_out": fold.label, "params": cal.x_, "gap_train": cal.gap_train_,
                      "gap_heldout": cal.score(fold.test)})
        fitted.append(cal)
    if len(paths) == 1:
        # one log: the parameters are the mean of the two folds' values, their
        # spread folded into the error
        a, b = fitted
        full = EffectCalibrator(candidate, setup).set_fitted(
            [0.5 * (x + y) for x, y in zip(a.x_, b.x_)],
            [math.hypot(0.5 * (sa + sb), 0.5 * (x - y))
             for x, y, sa, sb in zip(a.x_, b.x_, a.stderr_x_, b.stderr_x_)])
    else:
        full = EffectCalibrator(candidate, setup).fit(paths)
    per_log = dict(zip((Path(p).stem for p in paths), full.part_gaps(paths)))
    return Candidate("+".join(candidate), list(candidate), n_params, params=full.params_,
                     param_stderr=full.stderr_,
                     gap_after_train=gap([f["gap_train"] for f in folds]),
                     gap_after_heldout=gap([f["gap_heldout"] for f in folds]),
                     gap_after_all_fit_per_log=per_log, folds=folds, wall_s=time.perf_counter() - t_start)


def _ranked(results: list, singles: list, floor: float) -> list:
    """Occam's rule for pairs: the second effect must earn its place on held-out
    data, cutting the better member's gap by PAIR_GAIN and by more than the
    noise; a pair that only polishes a single effect's fit ranks behind that
    single effect."""
    by_effect = {c.effects[0]: c for c in singles}
    for c in results:
        if len(c.effects) < 2:
            continue
        member = min((by_effect[e] for e in c.effects if e in by_effect), key=lambda m: m.score, default=None)
        if member is None:
            continue
        gain = member.gap_after_heldout - c.gap_after_heldout
        if not (gain > PAIR_GAIN * member.gap_after_heldout and gain > NOISE_FACTOR * floor):
            c.score = max(c.score, member.score * (1 + 1e-9))
            c.why_not_first = (f"does not cut {member.effects[0]}'s held-out gap by "
                               f"{PAIR_GAIN:.0%} and more than the noise")
    return sorted(results, key=lambda c: c.score)


BOUND_SHARE = 0.01   # a value within 1 % of its search range (in the search's scale) of a bound is on it


def implausibility(c: Candidate) -> str | None:
    """Why `c`'s fit is not physically plausible, or None: a value outside its
    parameter's physical range lo..hi, or on a bound of its search range (the
    logs want it there or beyond: the effect is standing in for another)."""
    out = []
    for eff, name, p in calibrated_params(tuple(c.effects)):
        v = c.params.get(eff, {}).get(name)
        if v is None:
            continue
        if not (p.lo <= v <= p.hi):
            out.append(f"{eff}.{name} = {v:.3g} outside its physical range {p.lo:g}..{p.hi:g} {p.unit}")
        elif p.search and not (BOUND_SHARE < to_unit(p, v) < 1 - BOUND_SHARE):
            out.append(f"{eff}.{name} = {v:.3g} on its search bound ({p.search[0]:g}..{p.search[1]:g})")
    return "; ".join(out) or None


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


def probabilities(gaps, n_params, floor: float, n: int) -> list[float]:
    """Akaike weights of candidates from their held-out gaps (RMS, m) over `n`
    held-out residual components: -2 ln L = n g^2 / s^2 under Gaussian noise of
    variance s^2 = max(floor^2, g_min^2) (the log's noise, widened to the best
    candidate's misfit when that is larger, so a model-form remainder is not
    read as evidence; Burnham & Anderson's quasi-likelihood), plus 2 per
    parameter. They sum to 1 over the candidates given."""
    g = np.asarray(gaps, float)
    s2 = max(floor ** 2, float(np.min(g)) ** 2, 1e-300)
    aic = n * g ** 2 / s2 + 2.0 * np.asarray(n_params, float)
    w = np.exp(-0.5 * (aic - aic.min()))
    return (w / w.sum()).tolist()


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
    say(f"{family_of(recs[paths[0]])}: baseline gap {gap_before:.3f} m, noise floor {floor:.3f} m")

    excluded = {}
    cands = []
    for e in EFFECTS:
        why = applicable(e, kind, case, recs[paths[0]])
        if why:
            excluded[e] = why
        else:
            cands.append(e)
    scores, screen_failed, columns = screen_scores(paths, cands, setup, base, mapper)
    failed = [Candidate(e, [e], len(calibrated_params((e,))), success=False, message=f"screen probe: {why}")
              for e, why in screen_failed.items()]
    order = sorted(scores, key=lambda e: -scores[e])
    keep = order[:SCREEN_KEEP]
    say("screen: " + ", ".join(f"{e} {scores[e]:.2f}" for e in order))
    singles = list(mapper(_score_candidate, [(paths, (e,), setup) for e in keep],
                          progress=lambda c: say(f"fitted {c.effect}")))
    failed += [c for c in singles if not c.success]
    singles = [c for c in singles if c.success]
    singles.sort(key=lambda c: c.gap_after_heldout * (1 + PARAM_PENALTY * c.n_params))
    results = list(singles)
    best = singles[0] if singles else None
    if best and best.gap_after_heldout > PAIR_WHEN_LEFT * gap_before_heldout and \
            best.gap_after_heldout > NOISE_FACTOR * floor and len(singles) > 1:
        top = [c.effects[0] for c in singles[:PAIR_FROM]]
        pairs = [(a, b) for i, a in enumerate(top) for b in top[i + 1:]]
        pairs = [tuple(sorted(pr, key=list(EFFECTS).index)) for pr in pairs]
        say("pairs: " + ", ".join("+".join(p) for p in pairs))
        fitted = list(mapper(_score_candidate, [(paths, pr, setup) for pr in pairs],
                             progress=lambda c: say(f"fitted {c.effect}")))
        failed += [c for c in fitted if not c.success]
        results += [c for c in fitted if c.success]
    for c in failed:
        say(f"failed, not ranked: {c.effect}: {c.message}")
    for c in results:
        c.gap_before = gap_before_heldout if len(paths) == 1 else gap_before
        c.gap_before_train = gap_before_train
        c.shrink_heldout = 1.0 - c.gap_after_heldout / gap_before_heldout if gap_before_heldout else None
        c.score = c.gap_after_heldout * (1 + PARAM_PENALTY * c.n_params)
        c.screen_share = {e: scores.get(e) for e in c.effects}
    results = _ranked(results, singles, floor)
    none = Candidate("none", [], 0, gap_before=gap_before_heldout if len(paths) == 1 else gap_before,
                     gap_after_train=gap_before_train, gap_after_heldout=gap_before_heldout, shrink_heldout=0.0,
                     score=gap_before_heldout)
    within_noise = gap_before <= NOISE_FACTOR * floor
    if within_noise or not results or results[0].score >= none.score:
        none.why = ("the baseline explains the logs to within their noise" if within_noise else
                    "no effect shrinks the held-out gap by more than its parameter penalty")
        ranking = [none] + results
    else:
        ranking = results + [none]
    ranking = plausible_first(ranking, floor)
    n_heldout = sum(len(base[p].r) for p in paths)
    for c, w in zip(ranking, probabilities([c.gap_after_heldout for c in ranking], [c.n_params for c in ranking],
                                           floor, n_heldout)):
        c.probability = w
    remaining = ranking[0].gap_after_heldout
    # where the gap lies once the best explanation is in (its parameters fitted
    # on all logs): what is left for the next effect to explain
    after = {}
    if ranking[0].effect != "none":
        after = {Path(p).stem: where_map(observed(p), evaluate(p, ranking[0].params, setup)) for p in paths}
    return FamilyDiagnosis(
        family=family_of(recs[paths[0]]), kind=kind, logs=[Path(p).stem for p in paths],
        n_elements=setup.n_elements, gap_definition=GAP_DEFINITION[kind], gap_before=gap_before,
        noise_floor=floor, gap_real=not within_noise,
        held_out_scheme=splitter_for(paths).scheme,
        screen={e: scores[e] for e in order}, screened_out=order[SCREEN_KEEP:], not_applicable=excluded,
        ranking=ranking, failed=failed,
        remaining_unexplained={"gap_m": remaining,
                               "above_noise_m": math.sqrt(max(remaining ** 2 - floor ** 2, 0.0))},
        gap=where, gap_after_best=after, wall_s=time.perf_counter() - t_start,
        not_separable=not_separable(columns, np.concatenate([base[p].floor for p in paths])))


def group_families(paths) -> dict[str, list[str]]:
    fam: dict[str, list[str]] = {}
    for p in paths:
        fam.setdefault(family_of(record(str(p))), []).append(str(p))
    return {k: sorted(v) for k, v in fam.items()}


def diagnose(paths, n_elements: int = DEFAULT_ELEMENTS, workers: int | None = None, scheduler: str | None = None,
             progress: Callable[[str], None] | None = None) -> Diagnosis:
    """Diagnose every family among `paths` (local processes, or the Dask
    cluster at `scheduler`)."""
    with Mapper(_default_workers(workers), scheduler) as mapper:
        fams = {name: diagnose_family(ps, Setup(n_elements), mapper, progress)
                for name, ps in group_families(paths).items()}
    return Diagnosis(logs=[str(p) for p in paths], families=fams,
                     findings=[f for d in fams.values() for f in findings(d)],
                     scheduler=scheduler or "local processes", gap_definition=GAP_DEFINITION,
                     noise_factor=NOISE_FACTOR, param_penalty=PARAM_PENALTY, pair_gain=PAIR_GAIN)
