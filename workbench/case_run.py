"""`workbench run`: one case through the solver, results to a folder."""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from flighttest import FlightRecord
from solver.chain import DivergenceError
from solver.result import SimulationResult
from solver.statics import StaticSolveError
from workbench.cases import Case, check_log_agrees
from workbench.errors import InputError
from workbench.outputs import safe_name
from workbench.simulate import simulate_case

# `run` writes here, apart from the validation report (reports/out): one folder per case id
DEFAULT_OUT = Path("reports/run")


@dataclass
class RunOutcome:
    """One run of a case: the result (`.to_pandas()`, `.plot()`), its wall time,
    the static solve's time (NaN when it ran inside a log-driven run) and the
    log it ran against, if any."""

    case: Case
    result: SimulationResult
    wall_s: float
    static_ms: float
    record: FlightRecord | None = None

    def to_pandas(self):
        """The result's scalar channels, one row per record (`SimulationResult.to_pandas`)."""
        return self.result.to_pandas()

    def plot(self, kind: str = "summary", **kwargs):
        """A matplotlib Figure of the result (`SimulationResult.plot`)."""
        return self.result.plot(kind, **kwargs)

    def summary(self) -> dict:
        r = self.result
        end = r.end_xyz
        dur = float(r.t[-1] - r.t[0]) if len(r.t) > 1 else 0.0
        return {
            "case": self.case.id,
            "log": self.record.info.test_id if self.record is not None else None,
            "simulated_s": dur,
            "wall_s": self.wall_s,
            "realtime_factor": dur / self.wall_s if self.wall_s > 0 else float("inf"),
            "static_solve_ms": self.static_ms if np.isfinite(self.static_ms) else None,  # None: inside the run
            "step_ms": r.dt * 1e3,
            "end_static_x_m": float(end[0, 0]),
            "end_static_y_m": float(end[0, 1]),
            "end_static_z_m": float(end[0, 2]),
            "end_z_range_m": float(np.nanmax(end[:, 2]) - np.nanmin(end[:, 2])),
            "tow_tension_static_N": float(np.linalg.norm(r.tow_force[0])),
            "tow_tension_max_N": float(np.nanmax(np.linalg.norm(r.tow_force, axis=1))),
        }


def check_log_fits(case: Case, record: FlightRecord) -> None:
    """InputError unless the log's test card is of the case's kind and names
    the case's hardware (where both name it: `cases.check_log_agrees`)."""
    info = record.info
    if info.test_kind != case.kind:
        raise InputError(f"{record.path}: test_kind '{info.test_kind}' is not the kind '{case.kind}' of "
                         f"{case.path}")
    check_log_agrees(case, record)


def run_case(case: Case, duration_s: float | None = None, record: FlightRecord | None = None) -> RunOutcome:
    """Simulate `case` (its static trail, then `duration_s` or the case's run);
    with `record`, a flight log of the case's kind and hardware, against it as
    `validate` runs it (its model, no variant): condition, tow point, reel and
    probe from the log, through its span or `duration_s` from its start."""
    if record is not None:
        check_log_fits(case, record)
    try:
        sim = simulate_case(case, record=record, duration=duration_s)
    except (StaticSolveError, DivergenceError) as exc:
        # still a numerical failure (exit 3), now naming the case (and its log)
        on = f" on {record.path}" if record is not None else ""
        raise type(exc)(f"{case.path}{on}: {exc}") from None
    res = sim.result
    res.provenance = {"case": case.path, "case_id": case.id, "structure": case["model.structure"]["source"]}
    if record is not None:
        res.provenance.update(log=str(record.path), log_id=record.info.test_id)
    return RunOutcome(case, res, sim.run_s, sim.static_s * 1e3, record)


def write_mcap(outcome: RunOutcome, path: Path) -> Path:
    """The run in the log contract with Foxglove's 3-D scene (`simlog.result_scene`):
    its log's test card and start time, or a test card made from the case."""
    from flighttest.writer import write_record
    from workbench.simlog import case_test_card, result_scene, result_to_record
    if outcome.case.kind not in ("pitch_doublet", "trail", "engagement"):
        raise InputError(f"--mcap {path}: a {outcome.case.kind} case is a bench run, not a flight record")
    like = outcome.record if outcome.record is not None else case_test_card(outcome.case)
    rec = result_to_record(outcome.result, like, note=f"workbench run {outcome.case.id}")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    return write_record(path, rec, scene=result_scene(outcome.result))


def write_outputs(outcome: RunOutcome, out_dir: Path) -> list[Path]:
    """timeseries.csv (scalar channels), summary.json, summary.png."""
    d = Path(out_dir) / safe_name(outcome.case.id)
    d.mkdir(parents=True, exist_ok=True)
    paths = [d / "timeseries.csv", d / "summary.json", d / "summary.png"]
    outcome.result.to_pandas().to_csv(paths[0])
    paths[1].write_text(json.dumps(outcome.summary(), indent=2) + "\n")
    fig = outcome.result.plot("summary")
    fig.savefig(paths[2], dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return paths


def case_for_log(record: FlightRecord) -> Case:
    """The case a log belongs to: the case in cases/ that lists it among its
    logs (the same file, or one of the same name), else the diagnosis's
    baseline template for the log's kind with its hardware."""
    from workbench.cases import case_log_paths, load_case
    from workbench.diagnosis.setup import TEMPLATES, baseline_case
    log = Path(record.path)
    for path in sorted(TEMPLATES.parent.glob("*.toml")):
        case = load_case(path)
        if any(p.resolve() == log.resolve() or p.name == log.name for p in case_log_paths(case)):
            return case
    return baseline_case(record)


def write_comparison_mcap(outcome: RunOutcome, path: Path) -> Path:
    """The log and its simulation on the log's time base in one MCAP: the log's
    topics and scene under /log, the run's (`write_mcap`'s) under /sim, so
    that Foxglove scrubs both together."""
    from flighttest.writer import write_overlay
    from workbench.simlog import result_scene, result_to_record
    if outcome.record is None:
        raise InputError(f"{outcome.case.path}: a comparison needs the log the case ran against")
    sim = result_to_record(outcome.result, outcome.record, note=f"workbench compare, case {outcome.case.id}")
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    return write_overlay(path, {"/log": (outcome.record, None), "/sim": (sim, result_scene(outcome.result))})
