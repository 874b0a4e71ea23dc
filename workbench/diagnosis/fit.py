"""Calibration of a candidate (one or more library effects) on flight logs,
in the scikit-learn estimator shape, and the folds it is scored held out on.

`EffectCalibrator(effects, setup).fit(parts)` fits the candidate's
parameters (those with a search range in the effect registry) on `parts`: a
grid in the unit cube of the search ranges (10 points for one parameter,
5 x 5 for two, 4 per axis beyond, plus the off point: the setup's prior
value where it has one, `Setup.off`; where a free parameter is a time in
the log, `Param.scan_s`, that time every `scan_s` over the logs' span
instead, its effect's amplitudes and the other free parameters solved
linearly at each, `_scan`), then
bounded least squares from the best grid point, and for two or more
parameters from the runner-up too (for a scanned time, from the best start of
another valley, `_polish_from`). `fit(parts, start={effect: {param: value}})`
warm-starts it (forward selection adding an effect to a fitted set): the parameters given
stay at their start values on the grid, which spans only the others, and the
least squares then polishes all of them together. `score(parts)` is the
held-out gap at the fitted parameters, `held_out(parts)` its components.
A part is a log path, or (path, segment) for one of its alternate time
blocks; `LeaveOneLogOut` and `TimeBlocks` split a family into folds of parts.

A simulation that fails in a fit raises `SimulationFailed` (the candidate
failed, and its reason says where), except at a grid point, which is then no
start (`_grid_scores`).
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Iterator, Sequence, Union

import numpy as np
from scipy.optimize import least_squares

from flighttest.residual import BLOCK_S
from solver.effects import EFFECTS
from workbench.diagnosis.evaluate import evaluate, gap
from workbench.diagnosis.setup import Setup, calibrated_params, from_unit, to_unit
from workbench.errors import SimulationFailed

Part = Union[str, tuple]     # a log path, or (path, segment 0 | 1)

# The polish stops when a step changes the squared gap by less than this share
# (the gap by half of it, 0.05 %: far inside the noise floor that tells
# candidates apart) or moves the parameters by less than this share of their
# search range (far inside their standard errors). scipy's 1e-8 spent a third
# of a diagnosis's simulations on digits the logs do not hold: measured on a
# proving-ground doublet, 102 s -> 67 s, the ranking and every fitted value
# the same to three figures.
POLISH_TOL = 1e-3
# The polish's finite-difference step in the unit cube of a parameter's search
# range (a scanned time steps a quarter of its scan instead).
UNIT_STEP = 0.02
# A scanned time's second polish starts in another valley: more than this many
# scan steps from the best start's time.
VALLEY_SCANS = 2


def _polish_from(scored: list, starts: list, ps: list, free, scanned: bool) -> list[int]:
    """The starts (indices) the least squares polishes from, `scored` best
    first: the best; with a scanned time also the best start of another
    valley (its time more than `VALLEY_SCANS` scans away; the scan's off start,
    index 0, is no valley); else, with two or more free parameters, the
    runner-up."""
    if not scanned:
        return [i for _, i in scored[:1 if len(free) <= 1 else 2]]
    best = scored[0][1]
    if best == 0:
        return [best]
    (it,) = [i for i in free if ps[i].scan_s]
    p = ps[it]
    t_best = from_unit(p, starts[best][it])
    far = [i for _, i in scored[1:] if i != 0 and abs(from_unit(p, starts[i][it]) - t_best) > VALLEY_SCANS * p.scan_s]
    return [best] + far[:1]


def _grid_scores(res, starts: list) -> list[tuple[float, int]]:
    """[(gap, index into starts)] best first. A grid point whose simulation
    fails is no start (a corner of a 2-D search may hold no steady trail: a
    wake of three times the circulation with the pod at the sheet's edge); the
    fit fails only when every point does."""
    scored, failure = [], None
    for i, u in enumerate(starts):
        try:
            scored.append((gap(res(u)), i))
        except SimulationFailed as exc:
            failure = failure or exc
    if not scored:
        raise failure
    return sorted(scored)


def path_and_segment(p: Part) -> tuple[str, int | None]:
    """A fold part's log path and segment (None: the whole log)."""
    return (str(p[0]), p[1]) if isinstance(p, tuple) else (str(p), None)


def scan_times(parts: Sequence[Part], p, setup: Setup) -> np.ndarray:
    """The times (s) a scanned parameter `p` (`Param.scan_s`) is tried at on
    `parts`: every `scan_s` over their logs' compared span, from two scans
    before it (a front passing the tow point then still moves the drogue
    inside it)."""
    t = np.concatenate([evaluate(path_and_segment(part)[0], {}, setup).t for part in parts])
    return np.arange(max(float(np.nanmin(t)) - 2.0 * p.scan_s, p.search[0]), min(float(np.nanmax(t)), p.search[1]),
                     p.scan_s)


@dataclasses.dataclass(frozen=True)
class Components:
    """One part's residual components under some effects: `r` and `floor`
    (m) and `channel`, as in `flighttest.residual.Residual`; what a fold
    held out, kept to compare candidates on the same components
    (`rank.separating_components`)."""

    r: np.ndarray
    floor: np.ndarray
    channel: np.ndarray


def _of(R, seg: int | None) -> Components:
    keep = slice(None) if seg is None else R.segment == seg
    return Components(R.r[keep], R.floor[keep], R.channel[keep])


def components(part: Part, effects: dict, setup: Setup) -> Components:
    """`part`'s residual components simulated with `effects`."""
    path, seg = path_and_segment(part)
    return _of(evaluate(path, effects, setup), seg)


def baseline_held_out(paths: Sequence[str], base: dict) -> list[Components]:
    """The baseline's components (`base`: its residual per path) on every
    fold's held-out parts, in the order a candidate's `held_out` lists them
    (the folds of `splitter_for`)."""
    return [_of(base[path], seg) for fold in splitter_for(paths).split(paths)
            for path, seg in map(path_and_segment, fold.test)]


def effects_at(candidate: tuple, x, refined: tuple = ()) -> dict:
    """{effect: {param: value}} of `candidate` (with its form parameters
    `refined`, `setup.calibrated_params`) at the parameter vector `x`."""
    out: dict = {}
    for (eff, name, _), v in zip(calibrated_params(candidate, refined), x):
        out.setdefault(eff, {})[name] = float(v)
    return out


def ordered(effects) -> tuple:
    """`effects` in the registry's order: a candidate's one spelling."""
    return tuple(sorted(effects, key=list(EFFECTS).index))


class EffectCalibrator:
    """Fits `effects`' calibrated parameters to logs simulated with `setup`.

    Fitted attributes: `params_` and `stderr_` ({effect: {param: value}}; the
    standard errors from the Gauss-Newton covariance in the unit cube, mapped
    by the local slope of the search's scale), `x_` and `stderr_x_` (the same
    as vectors), `gap_train_` (the gap of all training components together),
    `gap_before_` (the baseline's: the RMS of the training parts' gaps),
    `looks_` (the times a free scanned time was tried at, `scan_times`; 1
    where none is free)."""

    def __init__(self, effects: Sequence[str], setup: Setup = Setup()):
        self.effects = effects
        self.setup = setup

    @property
    def candidate(self) -> tuple:
        return ordered(self.effects)

    def _at(self, x) -> dict:
        return effects_at(self.candidate, x, self.setup.refined)

    def _residual(self, parts, effects: dict) -> np.ndarray:
        return np.concatenate([components(part, effects, self.setup).r for part in parts])

    def fit(self, parts: Sequence[Part], start: dict | None = None, errors: bool = True) -> "EffectCalibrator":
        """Fit on `parts`; `start` ({effect: {param: value}}) holds parameters
        already fitted (warm start): they are not gridded, only polished.
        `errors` False leaves the standard errors NaN: their Jacobian costs a
        simulation per parameter and part, for a fit whose errors nobody
        reads (a fold of several logs, a prefit)."""
        candidate = self.candidate
        cal = calibrated_params(candidate, self.setup.refined)
        ps = [p for _, _, p in cal]
        n = len(ps)
        start = start or {}
        u_start = np.array([to_unit(p, start[e][k]) if k in start.get(e, {}) else np.nan for e, k, p in cal])
        free = np.flatnonzero(np.isnan(u_start))

        def res(u):
            return self._residual(parts, self._at([from_unit(p, ui) for p, ui in zip(ps, u)]))
        off = [to_unit(ps[i], self.setup.off(cal[i][0], cal[i][1])) for i in free]
        scanned = any(ps[i].scan_s for i in free)
        self.looks_ = 1
        if scanned:
            starts, scored = self._scan(parts, res, cal, free, u_start, off)
        else:
            # a dense first grid: the engagement's objective is rough in its parameters
            # (slack-hose dynamics), so the local polish only refines what the grid found;
            # it spans the free parameters only (a full grid over four to six is not
            # affordable), the started ones held at their start values
            grid_1d = np.linspace(0.0, 1.0, {1: 10, 2: 5}.get(len(free), 4))
            free_points = np.stack(np.meshgrid(*[grid_1d] * len(free)), -1).reshape(-1, len(free)) if len(free) \
                else np.empty((1, 0))
            free_points = np.vstack([free_points, [off]])
            starts = []
            for fp in free_points:
                u0 = u_start.copy()
                u0[free] = fp
                starts.append(u0)
            scored = _grid_scores(res, starts)
        # refine from the best grid point, and for two or more free parameters from
        # the runner-up too (a valley across the grid); for a scanned time from the best
        # start of another valley, more than `VALLEY_SCANS` scans from the best (the
        # runner-up is the best's neighbour in the same valley): which of two valleys a
        # run finds best flips with the log's last digits (measured on a proving-ground
        # gust doublet: a ninth-digit change of the baseline moved the gust's fit from
        # one to the other), and only the polish tells them apart. Starts are nudged off
        # the bounds, where a projected gradient can vanish at a corner that is not a
        # minimum. A scanned time steps a quarter of its scan, not a share of its range.
        step = np.array([p.scan_s / 4.0 / (p.search[1] - p.search[0]) if p.scan_s else UNIT_STEP for p in ps])
        # scipy's step test is on the whole unit vector, where a scanned time's range (an
        # hour) makes a move of half a scan a step of 1e-4: it would stop the polish as the
        # time lands, the amplitudes left where the scan's neighbour put them. So its
        # tolerance is POLISH_TOL of the finest parameter's step, not of the cube.
        xtol = POLISH_TOL * float(np.min(step)) / UNIT_STEP
        best_gap, u, sol = scored[0][0], starts[scored[0][1]], None
        for i in _polish_from(scored, starts, ps, free, scanned):
            s = least_squares(res, np.clip(starts[i], step, 1.0 - step), bounds=(np.zeros(n), np.ones(n)),
                              diff_step=step, max_nfev=8 * max(len(free), 1) + 4, x_scale=5.0 * step,
                              ftol=POLISH_TOL, xtol=xtol, gtol=POLISH_TOL)
            if sol is None or gap(s.fun) < gap(sol.fun):
                sol = s
        if gap(sol.fun) <= best_gap:
            u = sol.x
        r = res(u)
        x = [from_unit(p, ui) for p, ui in zip(ps, u)]
        se = self._errors(res, u, r, ps, step) if errors else [math.nan] * n
        self.x_, self.stderr_x_, self.gap_train_ = x, se, gap(r)
        self.gap_before_ = gap([gap(self._residual([p], {})) for p in parts])
        self.params_, self.stderr_ = self._at(x), self._at(se)
        return self

    @staticmethod
    def _errors(res, u, r, ps: list, step: np.ndarray) -> list:
        """The parameters' standard errors at the unit point `u` (residual `r`)."""
        n = len(ps)
        # standard errors: Gauss-Newton covariance in the unit cube, mapped to the
        # parameters by the local slope of the (possibly logarithmic) map; the
        # Jacobian by steps into the cube from the final point (the solver's own is
        # zeroed on a parameter that ends at its bound)
        J = np.empty((len(r), n))
        for i in range(n):
            h = step[i] if u[i] + step[i] <= 1.0 else -step[i]
            du = np.array(u, float)
            du[i] += h
            J[:, i] = (res(du) - r) / h
        dof = max(len(r) - n, 1)
        s2 = float(r @ r) / dof
        try:
            cov = np.linalg.pinv(J.T @ J) * s2
            su = np.sqrt(np.maximum(np.diag(cov), 0.0))
        except np.linalg.LinAlgError:
            su = np.full(n, np.nan)
        se = []
        for p, ui, s in zip(ps, u, su):
            d = 1e-4
            slope = (from_unit(p, min(ui + d, 1)) - from_unit(p, max(ui - d, 0))) / (min(ui + d, 1) - max(ui - d, 0))
            se.append(abs(slope) * s)
        return se

    def _scan(self, parts, res, cal: list, free, u_start, off: list) -> tuple[list, list]:
        """(starts, [(gap, index into starts)] best first) of a fit whose free
        parameters hold a scanned time (`Param.scan_s`, one per candidate):
        that time at `scan_times`, the other free parameters of its effect
        (amplitudes, off where they add nothing) solved at each time by linear
        least squares from one run at each one's probe (a small transient's
        response is linear in its amplitude: one run a time, not a grid),
        other effects' free parameters alongside them from one run each at a
        polish step from their off values, the same at every time (a
        Gauss-Newton step): a transient's ring-down is shaped by the
        hardware's own frequency and damping, and with a calibration held at
        its sheet the scan finds another valley (measured on a proving-ground
        gust doublet whose drogue drag was 8.7 % over its sheet: with the
        drag held, the gust landed 3 s early with the wrong sign). The best
        start's gap is its run's, the others' the linear prediction (they are
        not polished from)."""
        off_u = u_start.copy()
        off_u[free] = off
        (it,) = [i for i in free if cal[i][2].scan_s]
        timed = cal[it][0]
        amps = [i for i in free if cal[i][0] == timed and i != it]
        p_t = cal[it][2]
        times = scan_times(parts, p_t, self.setup)
        self.looks_ = len(times)
        r0 = res(off_u)
        starts, predicted = [off_u], [gap(r0)]

        def column(u, i, d):
            return res(np.where(np.arange(len(u)) == i, u + d, u)) - r0
        # solved beside the amplitudes only: with none free, a time's own run is its start
        others = [i for i in free if cal[i][0] != timed] if amps else []
        d_other = np.array([UNIT_STEP if off_u[i] + UNIT_STEP <= 1.0 else -UNIT_STEP for i in others])
        D_other = np.column_stack([column(off_u, i, d) for i, d in zip(others, d_other)]) if others \
            else np.empty((len(r0), 0))
        for tv in times:
            u = off_u.copy()
            u[it] = to_unit(p_t, tv)
            if not amps:
                starts.append(u)
                predicted.append(gap(res(u)))
                continue
            lin = amps + others
            du = np.concatenate([[to_unit(cal[i][2], cal[i][2].probe) - off_u[i] for i in amps], d_other])
            D = np.column_stack([column(u, i, d) for i, d in zip(amps, du)] + [D_other])
            c, *_ = np.linalg.lstsq(D, -r0, rcond=None)
            ua = np.clip(off_u[lin] + c * du, 0.0, 1.0)
            u[lin] = ua
            starts.append(u)
            predicted.append(gap(r0 + D @ ((ua - off_u[lin]) / du)))
        # the best start by its own run: a prediction that a run does not bear out
        # gives way to the next
        known = {0}
        while (best := int(np.argmin(predicted))) not in known:
            predicted[best] = gap(res(starts[best]))
            known.add(best)
        return starts, sorted((g, i) for i, g in enumerate(predicted))

    def set_fitted(self, x, stderr_x) -> "EffectCalibrator":
        """Take parameters fitted elsewhere (the mean of a one-log family's two
        folds) as this calibrator's own, to score them."""
        self.x_, self.stderr_x_ = list(x), list(stderr_x)
        self.params_, self.stderr_ = self._at(self.x_), self._at(self.stderr_x_)
        return self

    def part_gaps(self, parts: Sequence[Part]) -> list[float]:
        """The gap of each part at the fitted parameters."""
        return [gap(self._residual([p], self.params_)) for p in parts]

    def held_out(self, parts: Sequence[Part]) -> list[Components]:
        """Each part's residual components at the fitted parameters."""
        return [components(part, self.params_, self.setup) for part in parts]

    def score(self, parts: Sequence[Part]) -> float:
        """The held-out gap on `parts` at the fitted parameters (a family's:
        the RMS of the parts' gaps)."""
        return gap(self.part_gaps(parts))


@dataclasses.dataclass(frozen=True)
class Fold:
    """Train on `train`, score on `test`; `label` names what was held out."""

    train: list
    test: list
    label: str


class LeaveOneLogOut:
    """A family of several logs: train on all but one, score on the one left out."""

    scheme = "leave one log out"

    def split(self, paths: Sequence[str]) -> Iterator[Fold]:
        for p in paths:
            yield Fold([q for q in paths if q != p], [p], Path(p).stem)


@dataclasses.dataclass(frozen=True)
class TimeBlocks:
    """One log: fit on its A blocks (alternate `block_s` s blocks) and score on
    the B blocks, and the other way round."""

    block_s: float

    @property
    def scheme(self) -> str:
        return (f"two folds over alternate {self.block_s:.0f} s blocks of the one log (fit on A, score on B; "
                f"fit on B, score on A)")

    def split(self, paths: Sequence[str]) -> Iterator[Fold]:
        (p,) = paths
        for seg in (0, 1):
            yield Fold([(p, seg)], [(p, 1 - seg)], f"{Path(p).stem} segment {'BA'[seg]}")


def splitter_for(paths: Sequence[str]):
    """The folds a family is scored held out on: time blocks of its one log,
    or leaving one log out at a time."""
    return TimeBlocks(BLOCK_S) if len(paths) == 1 else LeaveOneLogOut()
