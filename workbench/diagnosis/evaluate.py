"""The simulation of a log under a candidate's effects, and its residual.

The residual is `flighttest.residual.residual` (the one comparison, shared
with validation): the log's observation against the simulated record. The gap
(one scalar per log, in metres; a family's is the RMS over its logs) is the
RMS of its components; a gap within `NOISE_FACTOR` times its noise floor is
noise. Its components' time segments are the blocks the time-block folds
(`fit.TimeBlocks`) train and score on.

Caches: a worker process reads each log once (`record`, `observed`: keyed by
path) and simulates each (log, effects, setup) once (`_simulate_frozen`);
all three are `functools.lru_cache`s, bounded, per process.
"""
from __future__ import annotations

import functools
from typing import Mapping

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


def evaluate(path: str, effects: Mapping, setup: Setup = Setup()) -> Residual:
    """The residual of the log at `path` against the baseline with `effects`
    ({name: {param: value}}; comparison-only ones act on the comparison).
    Raises `SimulationFailed` when the simulation fails. The setup's prior
    (`Setup.prior_effects`) is under them: a candidate's effect replaces the
    prior's parameters it names, the others stay at the prior's values."""
    effects = {e: {**setup.prior_effects.get(e, {}), **dict(v)} for e, v in
               {**setup.prior_effects, **effects}.items()} if setup.prior else effects
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


# a residual's gap (m) is the RMS of its components
gap = rms
