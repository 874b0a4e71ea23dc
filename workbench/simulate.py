"""The one way a case is simulated: `simulate_case`.

`workbench run`, `validate`, the diagnosis and its selftest all come here, so
a case means the same model whichever verb flies it. The model is built once
with its end free, solved for its steady trail, and, when the case holds the
drogue on the probe from the log (`[model] drogue_after_contact = "from_log"`),
rebuilt with that end constraint: no model is changed after construction.
The held path is placed on where this model's drogue is just before contact,
so a drogue moved before contact (a reel taking up, a tow point drifting) is
held where it got to, not snapped back to the trail at the run's start.
"""
from __future__ import annotations

import dataclasses
import time
from typing import Mapping

import numpy as np

from solver.effects import EFFECTS
from solver.integrate import simulate
from solver.model import Model
from solver.result import SimulationResult
from solver.state import State
from solver.statics import solve_static
from workbench import log_inputs
from workbench.budget import check_run
from workbench.cases import Case, build_model
from workbench.config import defaults
from workbench.effects_case import with_effects


@dataclasses.dataclass(frozen=True)
class ModelOptions:
    """What a simulated model was built with (results.json's `model_options`)."""

    n_elements: int
    reel: str
    drogue_lift_scale: float | None
    drogue_drag_scale: float | None
    drogue_after_contact: str
    probe_coupling_N_m: float
    probe_coupling_damping_ratio: float
    structure: str
    true_airspeed_mps: float
    air_density: float

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclasses.dataclass
class Simulation:
    """One case simulated: the case as flown (effects merged), the model, its
    steady trail `static`, the time run `result` (None for a static-only
    call), the model options and the wall-clock cost of each part (s)."""

    case: Case
    model: Model
    static: State
    result: SimulationResult | None
    options: ModelOptions
    static_s: float
    run_s: float


def model_options(case: Case, model: Model) -> ModelOptions:
    m = case["model"]
    return ModelOptions(
        n_elements=model.n_elements, reel=model.reel.mode,
        drogue_lift_scale=model.drogue.lift_scale if model.drogue else None,
        drogue_drag_scale=model.drogue.drag_scale if model.drogue else None,
        drogue_after_contact=m["drogue_after_contact"], probe_coupling_N_m=m["probe_coupling_N_m"],
        probe_coupling_damping_ratio=m["probe_coupling_damping_ratio"],
        structure=case["model.structure"]["source"],
        true_airspeed_mps=model.wind.mean_speed, air_density=model.air_density)


def run_duration(case: Case, record=None) -> float:
    """Seconds simulated when the caller names none: the case's [run]
    duration_s, else for a log a steady trail's short check run or the span of
    the log's tracker, else `simulate.duration_s`."""
    if case["run"]["duration_s"]:
        return float(case["run"]["duration_s"])
    if record is None:
        return float(defaults["simulate.duration_s"])
    if case.kind == "trail":
        # a steady trail is the static answer; a short run checks it holds
        return float(defaults["simulate.trail_run_s"])
    return float(record.topic("/ors/drogue").index[-1])


def _held_from_contact(case: Case, model: Model, record, s0: State, dt: float, hardware,
                       variant: Mapping | None):
    """The probe-held end constraint, placed on this model's own drogue over
    the log's pre-contact window (`log_inputs.PRE_CONTACT_S`): the model runs
    free to contact under its deterministic inputs. Seeded (random) effects are
    left out of that run, so where the drogue is held does not depend on one
    draw of the turbulence: the log's pre-contact median averages its own."""
    t_on, _ = log_inputs.contact_window(record)
    t0 = float(model.tow.t[0])
    if t_on <= t0 + dt:
        return log_inputs.probe_held_drogue(case, model, record, s0.pos[-1])
    seeded = [name for name, eff in EFFECTS.items() if "seed" in eff.params]
    random_on = any(name in case.tables.get("effects", {}) for name in seeded)
    free, start = model, s0
    if random_on:
        tables = dict(case.tables)
        tables["effects"] = {k: v for k, v in tables["effects"].items() if k not in seeded}
        free = build_model(dataclasses.replace(case, tables=tables), hardware=hardware, record=record,
                           variant=dict(variant or {}))
        start = solve_static(free, t0)
    pre = simulate(free, t_on, start, record_dt=dt)
    window = pre.t >= t_on - log_inputs.PRE_CONTACT_S
    return log_inputs.probe_held_drogue(case, model, record, np.median(pre.end_xyz[window], axis=0))


def simulate_case(case: Case, record=None, variant: Mapping | None = None, effects: Mapping | None = None,
                  duration: float | None = None, until: float | None = None, record_dt: float | None = None,
                  hardware=None) -> Simulation:
    """Simulate `case` for one of its logs (`record`, a FlightRecord, when the
    case takes anything from a log) under a variant's model overrides
    (`variant`: {"drogue_lift_scale": ..., ...}) with `effects` ({name: {param:
    value}}) merged over the case's own.

    `duration`: seconds from the model's start (default `run_duration`); 0 solves
    the steady trail only (`result` None). `until`: the time the run ends (s,
    on the log's clock), in place of a duration. `record_dt`: the result's sample
    step (default the case's [run] record_dt_s). Raises the solver's
    StaticSolveError / DivergenceError, InputError for a case the model refuses."""
    case = with_effects(case, dict(effects or {}))
    model = build_model(case, hardware=hardware, record=record, variant=dict(variant or {}))
    t0 = float(model.tow.t[0])
    if until is not None:
        t_end = float(until)
    else:
        t_end = t0 + (run_duration(case, record) if duration is None else float(duration))
    dt = float(case["run"]["record_dt_s"]) if record_dt is None else float(record_dt)
    if t_end != t0:
        # refused before any computing when its output or run time would pass the limits
        check_run(model, t_end - t0, dt, case.path)
    clock = time.perf_counter()
    s0 = solve_static(model, t0)
    static_s = time.perf_counter() - clock
    if t_end == t0:
        return Simulation(case, model, s0, None, model_options(case, model), static_s, 0.0)
    if case["model"]["drogue_after_contact"] == "from_log" and record is not None:
        model = dataclasses.replace(model, end=_held_from_contact(case, model, record, s0, dt, hardware, variant))
    clock = time.perf_counter()
    res = simulate(model, t_end, s0, record_dt=dt)
    run_s = time.perf_counter() - clock
    return Simulation(case, model, s0, res, model_options(case, model), static_s, run_s)
