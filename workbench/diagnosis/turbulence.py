"""Turbulence as a diagnosis candidate, identified from its statistics.

A random field's realisation cannot be fitted to a time history; what it
leaves that a deterministic fit cannot is random motion. Per log:

* the drogue tracker's residual, log minus the (best deterministic) model's
  time run at every fix, averaged in `BIN_S` bins (the drogue band: below
  2 Hz), with what a deterministic fit can take projected off: a constant
  (the steady offset is not the random effect's) and the run's own drogue
  motion with its first two derivatives (a gain, phase or damping error of
  the model's response to the test's input);
* bins where the deterministic run is no deterministic answer left out: its
  spread under the diagnosis's imperceptible probes (`evaluate.irreproducible`)
  above the tracker noise of the bin mean (a drogue released at disconnect
  whipping on a slack hose): the log's departure there is a realisation the
  model cannot match, not random air;
* the tracker's own noise, from the log itself: a robust (median absolute)
  second difference of consecutive fixes, var(x[i+1] - 2 x[i] + x[i-1]) / 6
  for white noise, which a drogue moving below 2 Hz barely enters at 30 Hz;
  a bin mean of n fixes keeps 1/n of its variance;
* every run over the setup's prior (a fleet calibration), as the diagnosis
  simulates the log (`evaluate.with_prior`);
* the model's response to Dryden turbulence (the registry's `turbulence`) at
  `SIGMA_REF_MPS`, `N_SEEDS` seeded runs at the log's length minus the
  deterministic run, through the same bins and projection: the band variance per unit
  sigma^2 (the response is linear in sigma for small sigma: the tests check
  it) and the spread one realisation leaves.

sigma_hat^2 = (log's band variance - its noise) / (ensemble's per unit
sigma^2), pooled over the axes and parts; its variance is the realisation
spread (ensemble, at sigma_hat, with the ensemble mean's own error) plus
the noise term's (chi-square of the binned noise, and the noise estimate's
error). The length scale is not fitted: the registry's default, L_u = 533.4 m
(1750 ft, MIL-HDBK-1797 above 2000 ft), which a record of tens of seconds
(a few L_u of air) cannot resolve.

The candidate (`turbulence_candidate`): sigma fitted on each fold's training
parts; each held-out part's gap is what remains of the baseline's once the
random mean square the fitted sigma predicts there is removed,
sqrt(max(g^2 - sigma^2 u, floor^2)), u the ensemble's mean square per unit
sigma^2 of the part's gap components (turbulence run minus deterministic run).
It is named (credited anything) only when its random motion is real: sigma^2
detected at two standard errors of its estimate under sigma = 0 (the noise
term's alone) and its band RMS above `NOISE_FACTOR` times
the tracker noise left in the band; otherwise it explains nothing (its gap is
the baseline's). Like every candidate it then ranks above "none" only if it
shrinks the held-out gap by more than its parameter penalty (a real share of
the gap). It explains random variance only: never a steady offset, and it
has no realisation to simulate (the where-map after a candidate with it
simulates its deterministic effects only).

The steady floor (`steady_floor`): the RMS of the gap components' shift a
turbulence of sigma_hat leaves by chance (from the same ensemble; over a
trail's steady components that is the mean offset over the test's window,
its low-frequency content). What a deterministic change explains of it by
chance is only its projection on the change's own pattern
(`RandomEffect.chance_offset`, over the ensemble's held-out shifts), at the
random motion the larger model leaves (`RandomEffect.sigma_under`: sigma_hat
measured again about the changed set's time runs, at most sigma_hat), as an
F-test's denominator is the larger model's residual variance: a transient
the selected set misses (a gust's ring-down) is in sigma_hat, and a yardstick
measured with it refused the transient for being as large as itself. A steady
effect's pattern shares the random motion's low frequencies, a lag's phase
or the bow wave before contact barely does. A deterministic candidate is
credited (`RandomEffect.credit_steady`) only when the held-out gap it
explains beats `NOISE_FACTOR` times that, as a gap beats its noise floor;
when the turbulence itself is the everyday air (refused as an event), a
candidate within it ranks behind "none".
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from flighttest.residual import BIN_S, residual, segment_of
from solver.effects import EFFECTS
from workbench.diagnosis.evaluate import (REPRODUCIBILITY_PROBES, SIM_FAILURES, evaluate, gap, irreproducible,
                                          observed, record, reproducibility_weights, with_prior)
from workbench.diagnosis.reel import EFFECT as REEL_LAG
from workbench.diagnosis.result import Candidate
from workbench.diagnosis.fit import baseline_held_out, path_and_segment, splitter_for
from workbench.diagnosis.setup import NOISE_FACTOR, Setup
from workbench.errors import SimulationFailed
from workbench.simlog import result_to_record
from workbench.simulate import simulate_case

SIGMA_REF_MPS = 1.0     # the ensemble's intensity: MIL-HDBK-1797's 'light' is 1.4 m/s at 15 000 ft
# ensemble members per log. Their mean power per unit sigma^2 is every estimate's yardstick, and a
# log diagnosed alone always draws the same first seeds: with 8, that mean (members' spread 30-40 %)
# was 15-20 % high on a proving-ground trail and engagement alike (against 32 members), which biased
# sigma_hat low on every log the same way. 32 bring the mean to ~6 %, at a few seconds a log.
N_SEEDS = 32
LENGTH_SCALE_M = EFFECTS["turbulence"].params["length_scale_m"].default
MAD_SIGMA = 1.4826      # sigma of a normal distribution per median absolute deviation
# sd of the MAD-based noise sd over itself, times sqrt(second differences): 1.166 for
# independent normal samples, widened by sqrt(1 + 2 (rho1^2 + rho2^2)) for the second
# differences' own correlation (lag 1: -2/3, lag 2: 1/6), as for a variance estimate
MAD_REL_SD = 1.166 * math.sqrt(1.0 + 2.0 * ((2.0 / 3.0) ** 2 + (1.0 / 6.0) ** 2))
DETECT_Z = 2.0          # sigma^2 at two standard errors from zero is detected


# ---- statistics of one record -------------------------------------------------------------

def tracker_noise(t: np.ndarray, xyz: np.ndarray) -> tuple[np.ndarray, int]:
    """Each axis's white-noise sd (m) from the fixes `xyz` at times `t`, and
    the number of second differences it rests on: consecutive triples at the
    record's usual step (a dropout breaks a triple), robust to the odd jump."""
    t = np.asarray(t, float)
    dt = np.diff(t)
    step = float(np.median(dt))
    ok = (np.abs(dt[:-1] - step) < 0.5 * step) & (np.abs(dt[1:] - step) < 0.5 * step)
    d2 = (xyz[2:] - 2.0 * xyz[1:-1] + xyz[:-2])[ok]
    if len(d2) < 10:
        return np.full(3, np.nan), len(d2)
    mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
    return MAD_SIGMA * mad / math.sqrt(6.0), len(d2)


def bin_means(t: np.ndarray, y: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The means of `y` (rows at `t`) in the bins `edges`, the samples per bin
    and the bins' mid times; bins without a sample are left out."""
    idx = np.digitize(t, edges) - 1
    ok = (idx >= 0) & (idx < len(edges) - 1)
    n = np.bincount(idx[ok], minlength=len(edges) - 1)
    sums = np.stack([np.bincount(idx[ok], weights=y[ok, c], minlength=len(edges) - 1) for c in range(y.shape[1])], 1)
    keep = n > 0
    mid = 0.5 * (edges[:-1] + edges[1:])
    return sums[keep] / n[keep, None], n[keep], mid[keep]


def band_power(y_bins: np.ndarray, mid: np.ndarray, segment: int | None = None) -> float:
    """Sum over the bins (of `segment`, or all) and axes of `y_bins`, bin means
    already projected off the deterministic directions: the band's power, m^2."""
    sel = np.ones(len(mid), bool) if segment is None else segment_of(mid) == segment
    return float(np.sum(y_bins[sel] ** 2))


def deterministic_directions(y0_bins: np.ndarray, mid: np.ndarray) -> np.ndarray:
    """The bin-mean directions a deterministic fit can take up: a constant
    (the steady offset) and the deterministic run's drogue x, y, z with their
    first and second time derivatives (a gain, phase or damping error of the
    model's own response); orthonormal columns."""
    cols = [np.ones(len(mid))]
    for c in range(3):
        y = y0_bins[:, c] - np.mean(y0_bins[:, c])
        dy = np.gradient(y, mid)
        cols += [y, dy, np.gradient(dy, mid)]
    A = np.column_stack(cols)
    A = A / np.maximum(np.linalg.norm(A, axis=0), 1e-300)
    u, s, _ = np.linalg.svd(A, full_matrices=False)
    # directions the run does not excite (a steady trail's tiny tow motion) are
    # still directions a deterministic model could take: kept unless degenerate
    return u[:, s > 1e-9 * s[0]]


# ---- one log: the residual, its noise and the ensemble ------------------------------------

@dataclasses.dataclass
class LogStatistics:
    """What the random test needs of one log, in the drogue bins (`mid`: the
    bins' mid times, `n`: fixes per bin) with the deterministic directions
    projected off (`lev`: each bin's leverage on them).

    `d` (bins, 3): log minus deterministic run; `noise_sd` (3,) and
    `n_noise`: the tracker noise and the triples it rests on; `response`
    (K, bins, 3): each member minus the deterministic run at SIGMA_REF_MPS;
    `gap_resp` (K, m): the same on the diagnosis's gap components,
    `gap_segment` (m,) their segments; `fixes` what they were measured from,
    (t, xyz, deterministic run, members, probes) at the fixes, to measure
    them again about another deterministic run (`about`)."""

    path: str
    mid: np.ndarray
    n: np.ndarray
    lev: np.ndarray
    d: np.ndarray
    noise_sd: np.ndarray
    n_noise: int
    response: np.ndarray
    gap_resp: np.ndarray
    gap_segment: np.ndarray
    fixes: tuple | None = None

    def about(self, y: np.ndarray) -> "LogStatistics":
        """These statistics about another deterministic run `y` (at the fixes,
        (n, 3)): the log's residual from it, its own deterministic directions
        projected off; the members' and probes' departures from the run the
        same (the response to the air is the model's, not the set's)."""
        t, xyz, y0, members, probes = self.fixes
        dy = y - y0
        return statistics_of(self.path, t, xyz, y, [m + dy for m in members], self.gap_resp, self.gap_segment,
                             [None if p is None else p + dy for p in probes])

    def selected(self, segment: int | None = None) -> np.ndarray:
        return np.ones(len(self.mid), bool) if segment is None else segment_of(self.mid) == segment

    def excess(self, segment: int | None = None) -> tuple[float, float, float]:
        """The log's band power above its noise, the noise power removed, and
        the variance the noise leaves in that difference (its chi-square in the
        bins, its product with the motion, the noise estimate's own error),
        m^2, m^2, m^4."""
        sel = self.selected(segment)
        var_bin = self.noise_sd ** 2 / self.n[sel, None]          # (bins, 3) noise variance of a bin mean
        noise = float(np.sum((1.0 - self.lev[sel, None]) * var_bin))
        chi = 2.0 * float(np.sum(var_bin ** 2))
        cross = 4.0 * float(np.sum(self.d[sel] ** 2 * var_bin))
        est = (2.0 * MAD_REL_SD / math.sqrt(max(self.n_noise, 1)) * noise) ** 2
        return band_power(self.d, self.mid, segment) - noise, noise, chi + cross + est

    def unit_powers(self, segment: int | None = None) -> np.ndarray:
        """Each member's band power per unit sigma^2, m^2 / (m/s)^2."""
        return np.array([band_power(r, self.mid, segment) for r in self.response]) / SIGMA_REF_MPS ** 2

    def unit_gap(self, segment: int | None = None) -> np.ndarray:
        """Each gap component's mean square per unit sigma^2 over the ensemble."""
        g = self.gap_resp if segment is None else self.gap_resp[:, self.gap_segment == segment]
        return np.mean(g ** 2, axis=0) / SIGMA_REF_MPS ** 2


def _run(path: str, effects: dict, setup: Setup):
    """The time run of the log under `effects` over the setup's prior, as the
    diagnosis simulates it (`evaluate.with_prior`); its physical effects only."""
    rec = record(path)
    until = float(rec.tracker_fixes().index[-1])
    phys = {k: v for k, v in with_prior(effects, setup).items() if not EFFECTS[k].comparison_only}
    try:
        sim = simulate_case(setup.case_for(rec), rec, variant=dict(setup.overrides), effects=phys, until=until)
    except SIM_FAILURES as exc:
        raise SimulationFailed(path, effects, exc) from exc
    return result_to_record(sim.result, rec, note="turbulence ensemble", ors_dt=None)


def _at_fixes(sim, t) -> np.ndarray:
    fx = sim.tracker_fixes()
    ts, xyz = fx.index.to_numpy(float), fx[["x_m", "y_m", "z_m"]].to_numpy(float)
    return np.column_stack([np.interp(t, ts, xyz[:, c]) for c in range(3)])


def statistics_of(path: str, t, xyz, y0, members, gap_resp, gap_segment, probes=()) -> LogStatistics:
    """A log's statistics from its fixes (`t`, `xyz` (n, 3)), the deterministic
    run at them (`y0`), each ensemble member's run at them (`members`,
    (K, n, 3), at SIGMA_REF_MPS) and the members' gap-component shifts.
    `probes`: runs at them under imperceptible changes of the deterministic
    model (`evaluate.REPRODUCIBILITY_PROBES`); a bin where they spread by more
    than the tracker noise of its mean is left out: there the deterministic
    run does not stand for the deterministic part of the motion (a slack hose
    whipping after disconnect), and the log's departure from it is no
    evidence of random air."""
    edges = np.arange(t[0], t[-1] + BIN_S, BIN_S)
    d, n, mid = bin_means(t, xyz - y0, edges)
    noise, n_noise = tracker_noise(t, xyz)
    keep = np.ones(len(mid), bool)
    if len(probes):
        spread = irreproducible(np.zeros_like(d), [None if p is None else bin_means(t, p - y0, edges)[0]
                                                    for p in probes])
        keep = np.all(spread ** 2 <= noise ** 2 / n[:, None], axis=1)
    d, n, mid = d[keep], n[keep], mid[keep]
    Q = deterministic_directions(bin_means(t, y0, edges)[0][keep], mid)

    def off(y):   # bin means with the deterministic directions projected off
        return y - Q @ (Q.T @ y)
    resp = [off(bin_means(t, m - y0, edges)[0][keep]) for m in members]
    return LogStatistics(path, mid, n, np.sum(Q ** 2, axis=1), off(d), noise, n_noise, np.array(resp),
                         np.asarray(gap_resp, float), np.asarray(gap_segment), (t, xyz, y0, members, probes))


def log_statistics(job) -> LogStatistics:
    """(path, deterministic effects, setup, first seed): the log's residual
    against the deterministic time run, its noise, and the ensemble. A
    module-level function: the diagnosis maps it over a family's logs."""
    path, effects, setup, seed0 = job
    ob = observed(path)
    base = _run(path, effects, setup)
    r0 = residual(ob, base, signatures=setup.signatures)
    over = with_prior(effects, setup)
    probes = []
    for effect, name, factor in REPRODUCIBILITY_PROBES:
        value = over.get(effect, {}).get(name, EFFECTS[effect].params[name].off) * factor
        try:
            probes.append(_at_fixes(_run(path, {**effects, effect: {**effects.get(effect, {}), name: value}}, setup),
                                    ob.fix_t))
        except SimulationFailed:
            probes.append(None)
    # the gap components in the diagnosis's own measure (`evaluate`)
    w = reproducibility_weights(path, setup)
    members, gresp = [], []
    for k in range(N_SEEDS):
        turb = {"sigma_mps": SIGMA_REF_MPS, "length_scale_m": LENGTH_SCALE_M, "seed": seed0 + k}
        sim = _run(path, {**effects, "turbulence": turb}, setup)
        members.append(_at_fixes(sim, ob.fix_t))
        gresp.append(w * (residual(ob, sim, signatures=setup.signatures).r - r0.r))
    return statistics_of(path, ob.fix_t, ob.fix_xyz, _at_fixes(base, ob.fix_t), members, gresp, r0.segment, probes)


# ---- sigma from the statistics ------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class SigmaEstimate:
    """sigma_hat (m/s) and its standard error; `band_rms_m` the random motion
    it explains in the drogue band and `noise_rms_m` the tracker noise left
    there (RMS per bin and axis); `real`: detected and above the noise."""

    sigma_mps: float
    stderr_mps: float
    band_rms_m: float
    noise_rms_m: float
    real: bool
    why: str


def estimate_sigma(stats: list[LogStatistics], parts: list | None = None) -> SigmaEstimate:
    """sigma_hat from the `parts` ((stats index, segment or None); all logs
    whole by default): pooled excess band power over pooled power per unit
    sigma^2, with the error of one realisation (the ensemble's spread of its
    pooled power, at sigma_hat, and of its mean) and of the noise removal."""
    parts = parts if parts is not None else [(i, None) for i in range(len(stats))]
    ex = np.array([stats[i].excess(s) for i, s in parts])
    units = np.sum([stats[i].unit_powers(s) for i, s in parts], axis=0)     # per member, pooled
    e, noise, noise_var = float(ex[:, 0].sum()), float(ex[:, 1].sum()), float(ex[:, 2].sum())
    u = float(np.mean(units))
    if not u > 0:
        return SigmaEstimate(0.0, float("nan"), 0.0, 0.0, False, "the model's drogue does not respond to turbulence")
    s2 = max(e / u, 0.0)
    rel = float(np.std(units, ddof=1) / u)
    var_s2 = (s2 * rel) ** 2 * (1.0 + 1.0 / len(units)) + noise_var / u ** 2
    se_s2 = math.sqrt(var_s2)
    sigma = math.sqrt(s2)
    # delta method away from zero; at zero the square root of sigma^2's error
    se = se_s2 / (2.0 * sigma) if sigma > 0.5 * math.sqrt(se_s2) else math.sqrt(se_s2)
    n_bins = sum(int(np.sum(stats[i].selected(s))) for i, s in parts) * 3
    band, noise_rms = math.sqrt(s2 * u / n_bins), math.sqrt(noise / n_bins)
    # detection is a test against sigma = 0, where only the noise term is left
    se_zero = math.sqrt(noise_var) / u
    if s2 < DETECT_Z * se_zero:
        why = f"sigma^2 {s2:.3g} (m/s)^2 within {DETECT_Z:g} standard errors ({se_zero:.2g}) of zero"
    elif band < NOISE_FACTOR * noise_rms:
        why = (f"its drogue-band motion {band:.3f} m is below {NOISE_FACTOR:g} x the tracker noise left "
               f"there ({noise_rms:.3f} m)")
    else:
        why = ""
    return SigmaEstimate(sigma, se, band, noise_rms, not why, why)


def _parts_of(fold_parts, index) -> list:
    """(stats index, segment or None) of each fold part (`fit.Part`)."""
    return [(index[path], seg) for path, seg in map(path_and_segment, fold_parts)]


def _part_gap(st: LogStatistics, base, seg, s2: float) -> tuple[float, float]:
    """One part's gap left once the random mean square of sigma^2 `s2` is
    removed, and its baseline gap."""
    r = base.r if seg is None else base.r[base.segment == seg]
    fl = base.floor if seg is None else base.floor[base.segment == seg]
    g2, u = float(np.mean(r ** 2)), float(np.mean(st.unit_gap(seg)))
    return math.sqrt(max(g2 - s2 * u, gap(fl) ** 2)), math.sqrt(g2)


def turbulence_candidate(stats: list[LogStatistics], base: dict, folds) -> tuple[Candidate, SigmaEstimate]:
    """The turbulence Candidate of a family (`stats` per log, `base` the
    baseline residual per path, `folds` the family's held-out folds) and the
    sigma estimate on all its logs. Its score and probability are the
    ranking's to set."""
    index = {st.path: i for i, st in enumerate(stats)}
    full = estimate_sigma(stats)
    fold_rows, held, train = [], [], []
    for fold in folds:
        est = estimate_sigma(stats, _parts_of(fold.train, index))
        s2 = est.sigma_mps ** 2 if est.real else 0.0
        gaps_test = [_part_gap(stats[i], base[stats[i].path], s, s2)[0] for i, s in _parts_of(fold.test, index)]
        gaps_train = [_part_gap(stats[i], base[stats[i].path], s, s2)[0] for i, s in _parts_of(fold.train, index)]
        fold_rows.append({"held_out": fold.label, "params": [est.sigma_mps], "gap_train": gap(gaps_train),
                          "gap_heldout": gap(gaps_test)})
        held.append(gap(gaps_test))
        train.append(gap(gaps_train))
    s2_all = full.sigma_mps ** 2 if full.real else 0.0
    per_log = {Path(st.path).stem: _part_gap(st, base[st.path], None, s2_all)[0] for st in stats}
    c = Candidate("turbulence", ["turbulence"], 1,
                  params={"turbulence": {"sigma_mps": full.sigma_mps, "length_scale_m": LENGTH_SCALE_M}},
                  # the length scale is held, not fitted: no error of its own
                  param_stderr={"turbulence": {"sigma_mps": full.stderr_mps, "length_scale_m": 0.0}},
                  gap_after_train=gap(train), gap_after_heldout=gap(held), gap_after_all_fit_per_log=per_log,
                  folds=fold_rows)
    if not full.real:
        c.why_not_first = f"no random motion above the noise: {full.why}"
    return c, full


# ---- the steady floor ---------------------------------------------------------------------

def steady_floor(stats: list[LogStatistics], sigma_mps: float) -> float:
    """The RMS (m) over a family's gap components of the shift a turbulence
    of `sigma_mps` leaves by chance over each test's window: its
    low-frequency content (a trail's steady components: the mean offset)."""
    u = np.concatenate([st.unit_gap() for st in stats])
    return sigma_mps * math.sqrt(float(np.mean(u))) if len(u) else 0.0


def held_out_shift(stats: list[LogStatistics], folds, sigma_mps: float) -> np.ndarray:
    """(members, components): each ensemble member's shift of the gap
    components at `sigma_mps` on the `folds`' held-out parts, in the order a
    candidate's held-out components list them (`fit.baseline_held_out`)."""
    index = {st.path: i for i, st in enumerate(stats)}
    cols = [stats[i].gap_resp if s is None else stats[i].gap_resp[:, stats[i].gap_segment == s]
            for i, s in _parts_of([p for f in folds for p in f.test], index)]
    return np.concatenate(cols, axis=1) * (sigma_mps / SIGMA_REF_MPS)


@dataclasses.dataclass
class RandomEffect:
    """The turbulence of a family: its `candidate` alone (against the
    baseline) and `joint`, the selected deterministic set with turbulence
    (None unless the turbulence is real and a set was selected), both ranked
    with the others; the sigma `estimate` on all logs and the
    `steady_floor_m` a deterministic candidate must beat (NOISE_FACTOR times
    it) to be credited."""

    candidate: Candidate
    estimate: SigmaEstimate | None
    steady_floor_m: float
    joint: Candidate | None = None
    shift: np.ndarray | None = None
    baseline: list | None = None
    stats: list | None = None       # the family's `LogStatistics`, to measure again about a set (`sigma_under`)
    setup: Setup | None = None
    _under: dict = dataclasses.field(default_factory=dict, repr=False)

    def sigma_under(self, c: Candidate | None) -> float:
        """The random motion (m/s) the set `c` leaves: sigma_hat measured again
        about `c`'s time runs (its fitted parameters on all logs), at most
        sigma_hat. A set that takes up a transient sigma_hat holds (a gust's
        ring-down the selected set misses) leaves less; a steady effect's
        change is mostly the constant the statistics project off, and leaves
        it as it was. sigma_hat itself for the baseline, a set with
        turbulence, or where `c`'s run fails."""
        sigma = self.estimate.sigma_mps
        if c is None or "turbulence" in c.effects or not self.stats or self.setup is None:
            return sigma
        key = repr(sorted((e, sorted(v.items())) for e, v in c.params.items()))
        if key not in self._under:
            try:
                runs = [_at_fixes(_run(st.path, c.params, self.setup), st.fixes[0]) for st in self.stats]
                self._under[key] = min(estimate_sigma([st.about(y) for st, y in zip(self.stats, runs)]).sigma_mps,
                                       sigma)
            except SimulationFailed:
                self._under[key] = sigma
        return self._under[key]

    def chance_offset(self, a: Candidate | None, b: Candidate | None) -> float:
        """The part of the held-out gap (m) a deterministic change from `a` to
        `b` (candidates; None the baseline, `baseline` its held-out
        components) explains by chance when the random motion the larger set
        leaves (`sigma_under`, of `b`, or of `a` where `b` is None) is all
        there is: sqrt(E[(u . d)^2] / N) over the ensemble's held-out shifts u
        (`shift`, the members at sigma_hat, scaled to it), d the unit pattern of
        the change (a's held-out components minus b's), N the components. A
        random motion's low frequencies lie alike in both halves of a log, so
        an effect whose pattern they share cuts the held-out gap by chance;
        one whose pattern they miss (a lag's phase, the bow wave before
        contact) does not. One direction: the pattern the fit found, which a
        fit of several parameters widens little where the random motion's
        low-frequency content is a few modes. The whole steady floor where
        the pattern is unknown (no held-out components kept, or not the
        same components); 0 unless the random motion is real."""
        if self.estimate is None or not self.estimate.real:
            return 0.0
        x, y = (c.held_out if c is not None else self.baseline for c in (a, b))
        if self.shift is None or x is None or y is None or len(x) != len(y) \
                or any(len(p.r) != len(q.r) for p, q in zip(x, y)):
            return self.steady_floor_m
        d = np.concatenate([p.r - q.r for p, q in zip(x, y)]) if x else np.empty(0)
        if len(d) != self.shift.shape[1]:
            return self.steady_floor_m
        norm = float(np.linalg.norm(d))
        if norm == 0.0:
            return 0.0
        scale = self.sigma_under(b if b is not None else a) / self.estimate.sigma_mps
        return scale * math.sqrt(float(np.mean((self.shift @ (d / norm)) ** 2)) / len(d))

    def credit_steady(self, ranking: list, accepted: bool = True) -> list:
        """`ranking` with every deterministic candidate ahead of the turbulence
        whose held-out gain over the baseline, sqrt(g_before^2 - g_after^2), is
        within NOISE_FACTOR x the offset the random motion leaves by chance
        along its pattern (`chance_offset`) moved right behind it (the
        others keep their order): a steady effect must not absorb a random
        motion. When the selection did not accept the turbulence (`accepted`
        False: the everyday air of a flight, calmer than light), the yardstick
        stands all the same, but what falls within it goes behind "none" (the
        first candidate without effects), and so does every candidate with the
        refused turbulence: the day's air did it by chance, and that is no
        event. Nothing moves unless the turbulence is real."""
        turb, est = self.candidate, self.estimate
        if est is None or not est.real or turb not in ranking:
            return ranking
        anchor = turb if accepted else next((c for c in ranking if not c.effects), None)
        if anchor is None:
            return ranking
        moved = []
        for c in ranking[:ranking.index(anchor)]:
            # "none", or none with the reel lag (measured on the reel's own channel, `reel`):
            # no steady effect that could absorb the random motion
            if set(c.effects) <= {REEL_LAG}:
                continue
            if "turbulence" in c.effects:
                if not accepted:
                    c.why_not_first = c.why_not_first or (f"turbulence of {est.sigma_mps:.2f} m/s is the air of every "
                                                          f"flight, not accepted as an event")
                    moved.append(c)
                continue
            gain = math.sqrt(max(c.gap_before ** 2 - c.gap_after_heldout ** 2, 0.0))
            chance = self.chance_offset(None, c)
            if gain <= NOISE_FACTOR * chance:
                c.score = max(c.score, anchor.score * (1 + 1e-9))
                c.why_not_first = (f"its held-out gain {gain:.3f} m is within {NOISE_FACTOR:g} x the offset a "
                                   f"turbulence of {self.sigma_under(c):.2f} m/s leaves by chance along its pattern "
                                   f"({chance:.3f} m)")
                moved.append(c)
        rest = [c for c in ranking if not any(c is m for m in moved)]
        at = rest.index(anchor) + 1
        return rest[:at] + moved + rest[at:]


def _joined(chosen: Candidate, turb: Candidate) -> Candidate:
    """`chosen`'s effects with turbulence: its parameters, and the gaps
    `turb` leaves of `chosen`'s residuals (`turbulence_candidate` on them)."""
    effects = list(chosen.effects) + ["turbulence"]
    return Candidate("+".join(effects), effects, chosen.n_params + 1,
                     params={**chosen.params, **turb.params}, param_stderr={**chosen.param_stderr, **turb.param_stderr},
                     gap_after_train=turb.gap_after_train, gap_after_heldout=turb.gap_after_heldout,
                     gap_after_all_fit_per_log=turb.gap_after_all_fit_per_log, folds=turb.folds,
                     shares=dict(chosen.shares or {}))


def random_candidate(paths: list[str], base: dict, chosen: Candidate | None, setup: Setup, mapper) -> RandomEffect:
    """The turbulence of a family of logs (`base`: the baseline residual per
    path), its random motion measured against the time runs of the selected
    deterministic set `chosen` (None: the baseline): one ensemble per log,
    mapped over the logs. When it is real and a set was selected, also that
    set with turbulence: the random mean square removed from the set's own
    residuals (its parameters fitted on all logs; the set's held-out folds
    refit them, this does not)."""
    t_start = time.perf_counter()
    deterministic = dict(chosen.params) if chosen is not None else {}
    try:
        stats = list(mapper(log_statistics, [(p, deterministic, setup, 1 + N_SEEDS * i) for i, p in enumerate(paths)]))
        folds = list(splitter_for(paths).split(paths))
        cand, est = turbulence_candidate(stats, base, folds)
        joint = None
        if chosen is not None and est.real:
            after = {p: evaluate(p, chosen.params, setup) for p in paths}
            joint = _joined(chosen, turbulence_candidate(stats, after, folds)[0])
    except SimulationFailed as exc:
        return RandomEffect(Candidate("turbulence", ["turbulence"], 1, success=False, message=str(exc),
                                      wall_s=time.perf_counter() - t_start), None, 0.0)
    cand.wall_s = time.perf_counter() - t_start
    if not est.real:
        return RandomEffect(cand, est, 0.0, joint)
    return RandomEffect(cand, est, steady_floor(stats, est.sigma_mps), joint,
                        held_out_shift(stats, folds, est.sigma_mps), baseline_held_out(paths, base), stats, setup)
