"""`workbench run`: one case through the solver, results to a folder."""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from solver.chain import DivergenceError
from solver.integrate import simulate
from solver.result import SimulationResult
from solver.statics import StaticSolveError, solve_static
from workbench.budget import check_run
from workbench.cases import DEFAULT_DURATION_S, Case, build_model
from workbench.outputs import safe_name


@dataclass
class RunOutcome:
    case: Case
    result: SimulationResult
    wall_s: float
    static_ms: float

    def summary(self) -> dict:
        r = self.result
        end = r.end_xyz
        dur = float(r.t[-1] - r.t[0]) if len(r.t) > 1 else 0.0
        return {
            "case": self.case.id,
            "simulated_s": dur,
            "wall_s": self.wall_s,
            "realtime_factor": dur / self.wall_s if self.wall_s > 0 else float("inf"),
            "static_solve_ms": self.static_ms,
            "step_ms": r.dt * 1e3,
            "end_static_x_m": float(end[0, 0]),
            "end_static_y_m": float(end[0, 1]),
            "end_static_z_m": float(end[0, 2]),
            "end_z_range_m": float(np.nanmax(end[:, 2]) - np.nanmin(end[:, 2])),
            "tow_tension_static_N": float(np.linalg.norm(r.tow_force[0])),
            "tow_tension_max_N": float(np.nanmax(np.linalg.norm(r.tow_force, axis=1))),
        }


def run_case(case: Case, duration_s: float | None = None) -> RunOutcome:
    model = build_model(case)
    dur = float(duration_s if duration_s is not None else case["run"]["duration_s"] or DEFAULT_DURATION_S)
    check_run(model, dur, float(case["run"]["record_dt_s"]), case.path)
    try:
        t0 = time.perf_counter()
        s0 = solve_static(model)
        static_ms = (time.perf_counter() - t0) * 1e3
        t0 = time.perf_counter()
        res = simulate(model, dur, s0, record_dt=float(case["run"]["record_dt_s"]))
        wall = time.perf_counter() - t0
    except (StaticSolveError, DivergenceError) as exc:
        # still a numerical failure (exit 3), now naming the case
        raise type(exc)(f"{case.path}: {exc}") from None
    res.provenance = {"case": case.path, "case_id": case.id, "structure": case["model.structure"]["source"]}
    return RunOutcome(case, res, wall, static_ms)


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
