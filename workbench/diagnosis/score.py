"""A candidate scored held out: fitted per fold and on all of its logs (warm
started at a set's fitted values), each fold's held-out gap (`score_candidate`);
and fitted on all logs at once, the lower bound of that gap (`fitted_gap`).
Both run in a worker process (or a Dask worker)."""
from __future__ import annotations

import math
import time
from pathlib import Path

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
