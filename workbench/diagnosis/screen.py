"""Which effects can explain a family's residual: each effect's sensitivity
directions (probe runs below and above its off value per calibrated
parameter) and the share of the baseline residual they span: the order
forward selection tries them in (it tries them all).

A probe whose simulation fails raises `SimulationFailed`: `rank` records the
effect as failed, with the reason, and screens it out.
"""
from __future__ import annotations

import numpy as np

from workbench.diagnosis.evaluate import evaluate
from workbench.errors import SimulationFailed
from workbench.diagnosis.setup import calibrated_params, from_unit, to_unit


def _screen_job(job):
    """One effect's sensitivity directions on one log: per parameter, the
    residual change at its probe value and at the probe mirrored about the
    baseline (in the search's own scale), so that a response that bends, or
    differs below and above the baseline, still spans the residual."""
    path, effect, setup = job
    base = evaluate(path, {}, setup)
    cols = []
    for _, name, p in calibrated_params((effect,)):
        # the registry's probe step (in the search's own scale), about where the
        # parameter stands: its off value, or the setup's prior value
        u0 = to_unit(p, setup.off(effect, name))
        step = to_unit(p, p.probe) - to_unit(p, p.off)
        for u in (u0 + step, u0 - step):
            if not 0.0 <= u <= 1.0 or abs(u - u0) < 1e-9:
                continue
            try:
                R = evaluate(path, {effect: {name: from_unit(p, u)}}, setup)
            except SimulationFailed as exc:
                return path, effect, str(exc)
            cols.append((R.r - base.r) / (u - u0))
    return path, effect, np.column_stack(cols)


def screen_scores(paths, effects, setup, base: dict, mapper) -> tuple[dict, dict, dict]:
    """Share of the baseline residual (all logs together) that each effect's
    sensitivity directions span: 1 - |r - S a|^2 / |r|^2 at the least-squares a;
    {effect: why} for the effects whose probe simulation failed (no score);
    and {effect: S}, each scored effect's sensitivity columns over the logs'
    components, in `paths` order (what `identify` compares)."""
    jobs = [(p, e, setup) for e in effects for p in paths]
    sens: dict = {}
    failed: dict = {}
    for p, e, S in mapper(_screen_job, jobs):
        if isinstance(S, str):
            failed.setdefault(e, S)
        sens.setdefault(e, {})[p] = S
    r = np.concatenate([base[p].r for p in paths])
    out, columns = {}, {}
    for e in effects:
        if e in failed:
            continue
        S = columns[e] = np.vstack([sens[e][p] for p in paths])
        if not np.any(np.abs(S) > 0):
            out[e] = 0.0
            continue
        a, *_ = np.linalg.lstsq(S, -r, rcond=None)
        out[e] = float(1.0 - np.sum((r + S @ a) ** 2) / max(np.sum(r ** 2), 1e-30))
    return out, failed, columns
