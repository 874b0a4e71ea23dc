"""The simulation of a log under a candidate's effects, and its residual.

The residual is `flighttest.residual.residual` (the one comparison, shared
with validation): the log's observation against the simulated record, each
component then weighted by how well the model can reproduce it at all
(`reproducibility_weight`). A slack hose whipping after disconnect, or in the
refuelling phase, is chaotic: a change of a drogue coefficient by one part in
a thousand moves the model's realisation of it by decimetres, so a fit there
would chase the realisation (on an own-model engagement a lift of 1.002
against 1.000 cut the gap by 15 %, on both halves of the log, and any effect
fitted was credited with it). The model's spread under such imperceptible
changes (`model_spread`) is added to the log's noise for those components,
which keeps a perfect model's weighted gap at the log's floor; a component
that spreads by more than the log's noise is left out, floor and all. The gap (one
scalar per log, in metres; a family's is the RMS over its logs) is the RMS
of the weighted components; a gap within `NOISE_FACTOR` times its noise
floor is noise. Its components' time segments are the blocks the
time-block folds (`fit.TimeBlocks`) train and score on.

Caches: a worker process reads each log once (`record`, `observed`: keyed by
path), simulates each (log, effects, setup) once (`_simulate_frozen`) and
measures the model's spread about each (log, setup) once (`model_spread`);
all are `functools.lru_cache`s, bounded, per process.
"""
from __future__ import annotations

import dataclasses
import functools
from typing import Mapping

import numpy as np

from flighttest import FlightRecord, read_record
from flighttest.residual import Observation, Residual, observe, residual, rms
from solver.effects import EFFECTS
from solver.chain import DivergenceError
from solver.statics import StaticSolveError
from workbench.diagnosis.setup import Setup
from workbench.errors import InputError, SimulationFailed
from workbench.simlog import result_to_record, static_to_record
from workbench.simulate import simulate_case

# what a simulation of a candidate can fail with: the solver diverging or
# finding no static shape, or a parameter combination the model refuses
SIM_FAILURES = (DivergenceError, StaticSolveError, ValueError, FloatingPointError)


# ---- simulation of one log under effects ------------------------------------------------

@functools.lru_cache(maxsize=16)
def record(path: str) -> FlightRecord:
    """The log at `path`, read once per process."""
    return read_record(path)


@functools.lru_cache(maxsize=16)
def observed(path: str) -> Observation:
    """Everything the residual measures once from the log at `path`."""
    return observe(record(path))


def _freeze(effects: Mapping) -> tuple:
    return tuple(sorted((k, tuple(sorted((p, round(float(v), 9)) for p, v in d.items())))
                        for k, d in effects.items()))


@functools.lru_cache(maxsize=256)
def _simulate_frozen(path: str, frozen: tuple, setup: Setup):
    effects = {k: dict(v) for k, v in frozen}
    rec = record(path)
    kind = rec.info.test_kind
    # a trail is compared with its steady line (no time run); the others up to the tracker's last fix
    until = None if kind == "trail" else float(rec.topic("/ors/drogue").index[-1])
    sim = simulate_case(setup.case_for(rec), rec, variant=dict(setup.overrides), effects=effects,
                        duration=0.0 if kind == "trail" else None, until=until)
    if kind == "trail":
        pts = sim.static.pos.copy()
        # the hose line the video sees ends at the drogue's hinge, i.e. the last hose node
        line = pts[:-1] if sim.model.drogue is not None else pts
        return static_to_record(float(sim.model.tow.t[0]), line, pts[-1], rec, note="static solution")
    # the tracker's every record: the drogue residual interpolates the simulation at the log's fixes
    return result_to_record(sim.result, rec, note="diagnosis", ors_dt=None)


def with_prior(effects: Mapping, setup: Setup) -> dict:
    """`effects` over the setup's prior (`Setup.prior_effects`): a
    candidate's effect replaces the prior's parameters it names, the others
    stay at the prior's values. What every simulation of the setup carries."""
    return {e: {**setup.prior_effects.get(e, {}), **dict(v)} for e, v in
            {**setup.prior_effects, **effects}.items()} if setup.prior else dict(effects)


def unweighted(path: str, effects: Mapping, setup: Setup) -> Residual:
    """The one comparison of the log with the baseline under `effects` (the
    setup's prior under them), unweighted."""
    effects = with_prior(effects, setup)
    phys = {k: v for k, v in effects.items() if not EFFECTS[k].comparison_only}
    delay = float(effects.get("sensor_lag", {}).get("delay_s", 0.0))
    offset = float(effects.get("drogue_reference", {}).get("offset_m", 0.0))
    try:
        return residual(observed(path), _simulate_frozen(path, _freeze(phys), setup), delay_s=delay,
                        tracker_offset_m=offset, signatures=setup.signatures)
    except InputError:
        raise
    except SIM_FAILURES as exc:
        raise SimulationFailed(path, effects, exc) from exc


# Imperceptible changes of the baseline: a data-sheet drogue coefficient moved by
# one part in a thousand either way, far inside its tolerance and the logs'
# noise. Where the model's response to them is larger than that (a hose whipping
# after disconnect, slack dynamics that amplify any difference), the model cannot
# reproduce the log's realisation, only its statistics.
REPRODUCIBILITY_PROBES = (("drogue_lift", "scale", 1.001), ("drogue_lift", "scale", 0.999),
                          ("drogue_drag", "scale", 1.001), ("drogue_drag", "scale", 0.999))


def irreproducible(base, probes) -> np.ndarray:
    """The spread (m) of two independent realisations of the model, per
    component, from the `base` run's residual and the `probes'` (consecutive
    +/- pairs, None for one that failed): a smooth response to a probe is
    odd in its sign and cancels in each pair's mean; what is left of the mean's
    departure from the base, d, is realisation, of variance 3/4 of that of two
    realisations' difference. RMS over the pairs; zeros without a whole pair.
    What the turbulence test leaves out bins by, against a bin mean's tracker
    noise, which is far below a probe's smooth response."""
    d2 = [(0.5 * (a + b) - base) ** 2 for a, b in zip(probes[0::2], probes[1::2]) if a is not None and b is not None]
    return np.sqrt(4.0 / 3.0 * np.mean(d2, axis=0)) if d2 else np.zeros_like(base)


# Time neighbours either side of a component its spread is pooled over: one
# realisation's departure passes through zero now and then while its envelope
# does not, and a +/- pair's mean cancels a chaotic departure where it still
# grows in proportion to the change; its neighbours show what it grows into.
POOL_NEIGHBOURS = 2


def pooled_spread(base, probes) -> np.ndarray:
    """`irreproducible` per component of the `base` Residual under the
    `probes'` residual vectors, each component then given the largest of its
    own and its `POOL_NEIGHBOURS` time neighbours' on either side (same
    channel, station and band): the envelope of the realisation's spread."""
    m = irreproducible(base.r, probes)
    pooled = np.empty_like(m)
    key = np.array([f"{c}|{s!r}|{b}" for c, s, b in zip(base.channel, base.station, base.band)], dtype=object)
    for k in np.unique(key):
        idx = np.flatnonzero(key == k)
        idx = idx[np.argsort(base.t[idx], kind="stable")]
        padded = np.pad(m[idx], POOL_NEIGHBOURS, mode="edge")
        pooled[idx] = np.lib.stride_tricks.sliding_window_view(padded, 2 * POOL_NEIGHBOURS + 1).max(axis=1)
    return pooled


@functools.lru_cache(maxsize=16)
def model_spread(path: str, setup: Setup) -> np.ndarray:
    """Per residual component, the model's own irreproducibility (m) about
    the baseline (`pooled_spread` under `REPRODUCIBILITY_PROBES`, each
    relative to the setup's prior value)."""
    runs = []
    for effect, name, factor in REPRODUCIBILITY_PROBES:
        try:
            runs.append(unweighted(path, {effect: {name: setup.off(effect, name) * factor}}, setup).r)
        except SimulationFailed:
            runs.append(None)
    return pooled_spread(unweighted(path, {}, setup), runs)


def reproducibility_weight(floor, spread) -> np.ndarray:
    """Per component, f the log's noise floor and m the model's spread:
    w = f / sqrt(f^2 + m^2) where m <= f, so a perfect model leaves w r with
    the log's own floor f (w^2 (f^2 + m^2) = f^2) and the gap keeps its
    metres; 0 where m > f, a component the model reproduces worse than the
    log measures it: weighted down only, it would still add a random draw of
    the floor's size to the gap, which moves under any change at all (an
    engagement's gap by a sixth of its floor under a lift change of 1e-3).
    Such a component is left out of the floor as well (`evaluate`)."""
    f, m = np.asarray(floor, float), np.asarray(spread, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(m > f, 0.0, np.where(m > 0, f / np.sqrt(f ** 2 + m ** 2), 1.0))


@functools.lru_cache(maxsize=16)
def reproducibility_weights(path: str, setup: Setup) -> np.ndarray:
    """The log's components' `reproducibility_weight` under `model_spread`,
    once per (log, setup) and process (read-only): every evaluation needs
    them, and the baseline's residual they are read from cost an engagement
    evaluation as much as its own."""
    w = reproducibility_weight(unweighted(path, {}, setup).floor, model_spread(path, setup))
    w.flags.writeable = False
    return w


def evaluate(path: str, effects: Mapping, setup: Setup = Setup()) -> Residual:
    """The residual of the log at `path` against the baseline with `effects`
    ({name: {param: value}}; comparison-only ones act on the comparison),
    each component weighted by the model's reproducibility there
    (`reproducibility_weights`; the floors stay the log's, but for the
    components left out, whose floor is left out with them). Raises
    `SimulationFailed` when the simulation fails. The setup's prior
    (`Setup.prior_effects`) is under them: a candidate's effect replaces the
    prior's parameters it names, the others stay at the prior's values."""
    R = unweighted(path, effects, setup)
    w = reproducibility_weights(path, setup)
    return dataclasses.replace(R, r=R.r * w, floor=np.where(w > 0, R.floor, 0.0))


# a residual's gap (m) is the RMS of its components
gap = rms
