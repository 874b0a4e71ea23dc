"""A candidate scored held out: fitted per fold and on all of its logs (warm
started at a set's fitted values), each fold's held-out gap (`score_candidate`,
or its fits mapped side by side: `mapped`); and fitted on all logs at once,
the lower bound of that gap (`fitted_gap`). The fits run in a worker process
(or a Dask worker)."""
from __future__ import annotations

import itertools
import math
import time
from pathlib import Path
from typing import Callable

from workbench.diagnosis.evaluate import gap
from workbench.diagnosis.fit import EffectCalibrator, effects_at, splitter_for
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.setup import calibrated_params
from workbench.errors import SimulationFailed


def warm_start(c: Candidate, refined: tuple = ()) -> dict:
    """Where a fit that adds an effect to `c` (or drops one, or refines its
    form) starts: each fold at `c`'s values fitted on that fold (`c` fitted
    with the form parameters `refined`), the all-logs fit at `c`'s own."""
    return {"folds": [effects_at(tuple(c.effects), f["params"], refined) for f in c.folds], "all": c.params}


def score_candidate(job) -> Candidate:
    """One candidate on one family: fitted per fold and on all logs (from
    `warm`, a `warm_start`, or cold when None); each fold's held-out gap. Runs
    in a worker process (or a Dask worker); `mapped` runs its fits side by
    side instead."""
    return _assembled(job, [fit_part(part) for part in _parts(job)])


def mapped(mapper: Callable, score: Callable, jobs: list, progress: Callable | None = None) -> list:
    """`[score(job) for job in jobs]` through `mapper`, `progress` called with
    each in job order. `score_candidate`'s jobs are split into their fits
    (one per fold, and the all-logs fit: `_parts`), mapped side by side and
    put together again, the same values as one job each: a lone candidate
    (the model form's step, the refinement, a trade) takes every worker
    instead of one, and a step's slowest candidate no longer sets its end
    (measured on the KDC-10 engagement family, two workers: its refinement
    alone took 40 s of its 314 s, one of the two cores idle; the family
    took 307 s with its fits side by side)."""
    jobs = list(jobs)
    if score is not score_candidate:
        return list(mapper(score, jobs, progress=progress))
    parts = [_parts(job) for job in jobs]
    ends = list(itertools.accumulate(len(ps) for ps in parts))
    got, out = [], []

    def arrived(r):
        got.append(r)
        while len(out) < len(jobs) and len(got) >= ends[len(out)]:
            i = len(out)
            out.append(_assembled(jobs[i], got[ends[i] - len(parts[i]):ends[i]]))
            if progress:
                progress(out[-1])
    results = mapper(fit_part, [part for ps in parts for part in ps], progress=arrived)
    for r in results[len(got):]:     # a mapper that reports no progress
        arrived(r)
    return out


def _parts(job) -> list:
    """The fits a candidate's score is made of, each independent of the
    others: (job, i) fold i's, and on several logs (job, None) the all-logs
    fit (one log's parameters are chosen among its folds')."""
    paths = job[0]
    n = sum(1 for _ in splitter_for(paths).split(paths))
    return [(job, i) for i in range(n)] + ([(job, None)] if len(paths) > 1 else [])


def fit_part(part) -> dict:
    """One of a candidate's fits (`_parts`): fold i fitted on its training
    parts from `warm`'s fold values and scored on its held-out ones, or (i
    None) fitted on all logs from `warm`'s own; {"failed": why} where it
    fails to simulate. Runs in a worker process (or a Dask worker)."""
    (paths, candidate, setup, warm), i = part
    t_start = time.perf_counter()
    try:
        if i is None:
            full = EffectCalibrator(candidate, setup).fit(paths, start=warm and warm["all"])
            out = {"params": full.params_, "stderr": full.stderr_, "per_log": full.part_gaps(paths)}
        else:
            fold = list(splitter_for(paths).split(paths))[i]
            # a fold's standard errors make one log's (`_one_log_fit`); of several, the all-logs fit's
            cal = EffectCalibrator(candidate, setup).fit(fold.train, start=warm and warm["folds"][i],
                                                         errors=len(paths) == 1)
            # the fold's held-out gap from its components (`EffectCalibrator.score`'s RMS of part gaps),
            # each part simulated and compared once
            test = cal.held_out(fold.test)
            out = {"fold": {"held_out": fold.label, "params": cal.x_, "gap_train": cal.gap_train_,
                            "gap_heldout": gap([gap(x.r) for x in test])},
                   "test": test, "stderr_x": cal.stderr_x_, "looks": cal.looks_}
    except SimulationFailed as exc:
        out = {"failed": str(exc)}
    return {**out, "wall_s": time.perf_counter() - t_start}


def _assembled(job, fits: list) -> Candidate:
    """The `Candidate` of `job` from its fits (`fit_part`, in `_parts`'
    order); failed where one of them failed to simulate. Its `wall_s` is
    the sum of its fits'."""
    paths, candidate, setup, _ = job
    n_params = len(calibrated_params(candidate, setup.refined))
    wall_s = sum(f["wall_s"] for f in fits)
    failed = next((f["failed"] for f in fits if "failed" in f), None)
    folds = [f for f in fits if "fold" in f]
    try:
        if failed is None and len(paths) == 1:
            full = _one_log_fit(paths, candidate, setup, folds)
            per_log = full.part_gaps(paths)
            params, stderr = full.params_, full.stderr_
        elif failed is None:
            (full,) = [f for f in fits if "per_log" in f]
            per_log, params, stderr = full["per_log"], full["params"], full["stderr"]
    except SimulationFailed as exc:
        failed = str(exc)
    if failed is not None:
        return Candidate("+".join(candidate), list(candidate), n_params, success=False, message=failed,
                         wall_s=wall_s)
    return Candidate("+".join(candidate), list(candidate), n_params, params=params,
                     looks=max(f["looks"] for f in folds), param_stderr=stderr,
                     gap_after_train=gap([f["fold"]["gap_train"] for f in folds]),
                     gap_after_heldout=gap([f["fold"]["gap_heldout"] for f in folds]),
                     gap_after_all_fit_per_log=dict(zip((Path(p).stem for p in paths), per_log)),
                     folds=[f["fold"] for f in folds], held_out=[x for f in folds for x in f["test"]],
                     wall_s=wall_s)


def _one_log_fit(paths, candidate, setup, folds) -> EffectCalibrator:
    """One log's parameters: whichever of the two folds' values and their mean
    fits the whole log best (a slack hose after a large doublet can fall into
    another motion between two good fits, so the mean alone may fit neither
    half), the folds' spread folded into the error."""
    (xa, sa_), (xb, sb_) = [(f["fold"]["params"], f["stderr_x"]) for f in folds]
    stderr = [math.hypot(0.5 * (sa + sb), 0.5 * (x - y)) for x, y, sa, sb in zip(xa, xb, sa_, sb_)]
    options = [EffectCalibrator(candidate, setup).set_fitted(x, stderr)
               for x in ([0.5 * (x + y) for x, y in zip(xa, xb)], xa, xb)]
    return min(options, key=lambda c: c.score(paths))


def fitted_gap(job) -> float | None:
    """A candidate fitted on all of its logs at once, no part held out (from
    `warm`'s all-logs values), and its gap there (the RMS of the logs'
    gaps, as a held-out gap is); None when it fails to simulate. A lower
    bound of its held-out gap, which fits each part on the others: what
    cannot get within a bar fitted on everything will not held out. Runs in
    a worker process (or a Dask worker)."""
    paths, candidate, setup, warm = job
    try:
        return EffectCalibrator(candidate, setup).fit(paths, start=warm and warm["all"], errors=False).score(paths)
    except SimulationFailed:
        return None
