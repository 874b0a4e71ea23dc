"""`workbench validate`: run cases against their logs, measure, and gate.

For every case, every (variant, log) pair is one run: the model is built from
the case and the log (condition, tow-point motion, reel payout, the drogue on
the probe), solved for its steady trail, run through the log's time span,
saved in the log contract and compared with the log by `flighttest.compare`.
Variants that tune a parameter (the drogue lift) are tuned first, on the
logs they name, and gated on the others. Variants that `calibrate` effects
(what `workbench diagnose` found) have their parameters fitted by the
diagnosis's own least squares on the `calibrate_on` logs, with the case's
model, and are gated on the logs they were not fitted to. Each flight run has
an uncertainty study (`run_uncertainty`, a job of its own after the runs): the
run at half the elements for u_num, the static solve under each test-card
input's 1-sigma for u_input; it is reported (ASME V&V 20), never gated.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from flighttest import FlightRecord, LogError, analyze_record, read_record
from flighttest.compare import compare
from solver.chain import DivergenceError
from solver.result import SimulationResult
from solver.statics import StaticSolveError
from workbench import log_inputs
from workbench.cases import Case, case_log_paths, check_log_agrees, load_case
from workbench.diagnosis import EffectCalibrator, Setup, SimulationFailed
from workbench.effects_compare import apply_comparison_effects
from workbench.errors import EXIT_BAD_INPUT, InputError, exit_code_for
from workbench.gates import FindingResult, GateResult, evaluate_findings, evaluate_gates
from workbench.parallel import Mapper
from workbench.progress import Progress
from workbench.provenance import code_version, json_safe, project_path
from workbench.simlog import result_to_record
from workbench.simulate import simulate_case


@dataclass
class Run:
    case_id: str
    variant: str
    log_id: str
    log_path: str
    metrics: dict
    result: SimulationResult
    wall_s: float
    model_options: dict
    held_out: bool = True
    uncertainty: dict | None = None   # `run_uncertainty`'s answer (ASME V&V 20 u_num, u_input)


@dataclass
class CaseOutcome:
    case: Case
    runs: list[Run]
    gates: list[GateResult]
    tuned: dict = field(default_factory=dict)
    calibrated: dict = field(default_factory=dict)   # variant id -> the diagnosis fit of its effects
    error: str | None = None
    error_code: int | None = None    # the exit status the error stands for (`workbench.errors`)
    findings: list[FindingResult] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return self.error is None and all(g.passed for g in self.gates) and all(f.passed for f in self.findings)

    def to_pandas(self):
        """One row per run: case, variant, log, held_out, wall_s and its scalar metrics."""
        import pandas as pd
        rows = [{"case": r.case_id, "variant": r.variant, "log": r.log_id, "held_out": r.held_out,
                 "wall_s": r.wall_s, **{k: v for k, v in r.metrics.items() if isinstance(v, (int, float))}}
                for r in self.runs]
        return pd.DataFrame(rows)

    def plot(self, metric: str | None = None):
        """A Figure of `metric` (default: the first gate's) over the runs, with its gates' thresholds."""
        from workbench.result_plots import runs_figure
        frame = self.to_pandas()
        if metric is None:
            numeric = [c for c in frame.columns if c not in ("case", "variant", "log", "held_out", "wall_s")]
            metric = self.gates[0].metric if self.gates else (numeric[0] if numeric else "wall_s")
        gates = [(f"{g.kind} {g.threshold:g} ({g.variant})", g.threshold) for g in self.gates if g.metric == metric]
        return runs_figure(frame, metric, gates, self.case.id)


def variants_of(case: Case) -> list[dict]:
    v = case["variants"]
    return v if v else [{"id": "baseline", "label": "baseline", "tune_drogue_lift_on": [], "calibrate": [],
                         "calibrate_on": []}]


def training_logs(variant: dict) -> list[str]:
    """The test ids a variant was tuned or calibrated on (not gated on)."""
    return list(variant.get("tune_drogue_lift_on") or []) + list(variant.get("calibrate_on") or [])


def _overrides(variant: dict, tuned: dict) -> dict:
    out = {k: variant[k] for k in ("drogue_lift_scale", "drogue_drag_scale", "reel")
           if variant.get(k) is not None}
    if variant["id"] in tuned:
        out["drogue_lift_scale"] = tuned[variant["id"]]
    return out


def _whip_metrics(res: SimulationResult, rec: FlightRecord) -> dict:
    """Hose-whip measures of an engagement run (the paper's reel study and its
    future work): peak slack, wave amplitude near the tow point, peak tension,
    peak probe load."""
    t_on, t_off = log_inputs.contact_window(rec)
    eng = (res.t >= t_on) & (res.t <= min(t_off, res.t[-1]))
    pre = res.t < t_on
    out: dict[str, Any] = {}
    if not eng.any():
        return out
    slack = []
    for k in np.flatnonzero(eng):
        p = res.hose_points(k)
        arc = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
        slack.append(arc - float(np.linalg.norm(p[-1] - p[0])))
    out["peak_slack_m"] = float(max(slack))
    # 2 m down the hose from the tow point: how far the wave moves it sideways
    k0 = np.flatnonzero(pre)[-1] if pre.any() else 0
    i2 = max(1, int(round(2.0 / (res.reel_length[0] / res.n_hose_elements[0]))))
    z_ref = res.hose_xyz[k0, i2, 2]
    out["wave_amplitude_2m_from_tow_m"] = float(np.nanmax(np.abs(res.hose_xyz[eng, i2, 2] - z_ref)))
    out["peak_tension_N"] = float(np.nanmax(res.tension[eng]))
    out["tow_tension_peak_N"] = float(np.nanmax(np.linalg.norm(res.tow_force[eng], axis=1)))
    out["probe_load_peak_N"] = float(np.nanmax(np.linalg.norm(res.probe_force[eng], axis=1)))
    steady = eng & (res.t > t_on + 0.5 * (min(t_off, res.t[-1]) - t_on))
    if steady.any():
        out["probe_load_refuelling_mean_N"] = float(np.mean(np.linalg.norm(res.probe_force[steady], axis=1)))
    return out


RINGDOWN_KINDS = ("ringdown_bending", "ringdown_axial")


@dataclass
class Job:
    """One unit of a validation campaign, run in a mapper worker: a bench
    group's verification ("ringdown", `group`), a variant on a log ("run",
    `log_path`), or that run's uncertainty study ("uncertainty")."""
    kind: str
    case: Case
    variant: dict
    log_path: str | None = None
    group: dict | None = None
    tuned: dict = field(default_factory=dict)

    @property
    def where(self) -> str:
        return Path(self.log_path).name if self.log_path else f"records {', '.join(self.group['records'])}"


def _one_ringdown(job: Job) -> Run:
    """Paper Fig. 9 for one measured group (a setpoint's repetitions): the
    case's N-element bench rig with the property table at the group's mean
    temperature, simulated and measured like the bench records."""
    from workbench.hardware import load_hardware
    from workbench.properties.rig import BenchRig
    from workbench.properties.store import load_library
    from workbench.properties.verify import verify_group
    case, variant, group = job.case, job.variant, job.group
    sheet = load_hardware().get("hose", group["hose"])
    hanging = group["test_kind"] == "ringdown_axial"
    rig = BenchRig.from_sheet(sheet, group["section_length_m"], hanging=hanging, tip_mass=group["tip_mass_kg"])
    table = load_library().table(group["hose"])
    t0 = time.perf_counter()
    row = verify_group(table, rig, group, int(case["model"]["n_elements"]),
                       allow_extrapolation=case["model.structure"]["allow_extrapolation"])
    wall = time.perf_counter() - t0
    metrics = {k: v for k, v in row.items() if k not in ("records",)}
    label = f"{group['hose']} {row['test']} {row['temperature_F']:.1f}F"
    return Run(case.id, variant["id"], label, ", ".join(group["records"]), metrics, None, wall,
               {"n_elements": row["n_elements"], "structure": "property table"})


def _one_run(job: Job) -> Run | dict:
    if job.kind == "ringdown":
        return _one_ringdown(job)
    if job.kind == "uncertainty":
        return run_uncertainty(job.case, job.variant, job.log_path, job.tuned)
    case, variant, log_path, tuned = job.case, job.variant, job.log_path, job.tuned
    rec = read_record(log_path)
    t0 = time.perf_counter()
    # a calibrated variant carries its fitted effects over the case's own
    sim = simulate_case(case, rec, variant=_overrides(variant, tuned), effects=variant.get("effects"))
    wall = time.perf_counter() - t0
    held_out = rec.info.test_id not in training_logs(variant)
    return Run(case.id, variant["id"], rec.info.test_id, str(log_path), _run_metrics(sim, rec), sim.result, wall,
               sim.options.to_dict(), held_out)


def _run_metrics(sim, rec: FlightRecord) -> dict:
    case, res = sim.case, sim.result
    sim_rec = result_to_record(res, rec, note=f"case {case.id}")
    # comparison-only effects (the tracker's delay) act on the log as compared, not on the physics
    metrics = compare(apply_comparison_effects(rec, case["effects"]), sim_rec).metrics
    if case.kind == "engagement":
        metrics.update(_whip_metrics(res, rec))
    return metrics


# --- the validation uncertainty of a run (ASME V&V 20-2009) -----------------
# u_num: Roache's grid-convergence index from two element counts, the case's n
# and n/2. Two grids give no observed order, so the solver's verified one is
# used: second order in the element length (tests/solver/test_structure.py,
# the cantilever's frequency error 4.9, 1.3, 0.28, 0.10 % at 4..32 elements;
# tests/solver/test_effects.py, an error ratio > 3 from 40 to 80 elements).
GCI_SAFETY = 3.0      # Roache's factor of safety for a two-grid study (no observed order)
GCI_ORDER = 2.0
GCI_COVERAGE = 2.0    # the GCI read as a ~95 % expanded uncertainty: u_num = GCI / 2

# u_input: the test card's measured inputs, each moved by its 1-sigma one at a
# time through the static solve. flighttest/logs/SCHEMA.md states no
# accuracies; these are a typical flight-test installation's.
INPUT_SIGMA = {
    "calibrated_airspeed_mps": (1.0 * 0.514444, 0.0,
                                "calibrated airspeed ±1 kt (a calibrated flight-test pitot-static air-data "
                                "system)"),
    "altitude_m": (25 * 0.3048, 0.0, "pressure altitude ±25 ft (the same air-data system)"),
    "oat_K": (1.0, 0.0, "outside air temperature ±1 °C (a total-temperature probe)"),
    "tanker_gross_weight_kg": (0.0, 0.01, "tanker gross weight ±1 % (fuel totaliser and weight and balance)"),
}
STEADY_KEYS = ("drogue_steady_x_m", "drogue_steady_y_m", "drogue_steady_z_m")
U_INPUT_UNMEASURED = ("frequency, damping, response and shape errors, wave speed and reel delay: a propagation "
                      "needs a full run per input; only the steady positions are propagated (static solves)")


def gci(fine: float, coarse: float, ratio: float, order: float = GCI_ORDER, safety: float = GCI_SAFETY) -> float:
    """Roache's grid-convergence index of the fine solution: Fs |S_fine - S_coarse| / (r^p - 1),
    r the ratio of the element lengths (coarse over fine)."""
    return safety * abs(fine - coarse) / (ratio ** order - 1.0)


def _scalars(metrics: dict) -> dict:
    return {k: float(v) for k, v in metrics.items()
            if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)}


def run_uncertainty(case: Case, variant: dict, log_path, tuned: dict) -> dict:
    """The uncertainty study of one (variant, log) run: the same run at half
    the elements through `simulate_case` ("coarse_metrics"; `attach_u_num`
    turns them into the GCI of each metric), and the steady drogue position's
    static solve with each test-card input moved by its 1-sigma (`INPUT_SIGMA`).
    A coarse run that fails leaves u_num unmeasured ("error") rather than
    failing the case's gates."""
    rec = read_record(log_path)
    over, effects = _overrides(variant, tuned), variant.get("effects")
    n = int(case["model"]["n_elements"])
    n_c = max(2, n // 2)
    out: dict[str, Any] = {"n_elements": n, "n_elements_coarse": n_c, "refinement_ratio": n / n_c,
                           "gci_safety": GCI_SAFETY, "gci_order": GCI_ORDER, "gci_coverage": GCI_COVERAGE}
    t0 = time.perf_counter()
    try:
        coarse = simulate_case(case, rec, variant={**over, "n_elements": n_c}, effects=effects)
        out["coarse_metrics"] = _scalars(_run_metrics(coarse, rec))
    except (StaticSolveError, DivergenceError) as exc:
        out["error"] = f"the half-element run: {exc}"
    out["coarse_wall_s"] = time.perf_counter() - t0
    out.update(_input_uncertainty(case, rec, over, effects))
    out["wall_s"] = time.perf_counter() - t0      # the study's whole cost, beside the run's own wall_s
    return out


def attach_u_num(run: Run, study: dict) -> None:
    """`study` (`run_uncertainty`'s) on `run`, with u_num per metric: GCI / GCI_COVERAGE
    of the run's metric against the coarse run's."""
    fine, coarse = _scalars(run.metrics), study.get("coarse_metrics", {})
    run.uncertainty = dict(study, u_num={k: gci(fine[k], coarse[k], study["refinement_ratio"]) / GCI_COVERAGE
                                         for k in fine if k in coarse})


def _input_uncertainty(case: Case, rec: FlightRecord, over: dict, effects) -> dict:
    if not case["condition"]["from_log"]:
        return {"u_input_unmeasured": "the case's condition is not the log's test card: not propagated"}
    static = lambda r: simulate_case(case, r, variant=over, effects=effects, duration=0.0).static.pos[-1]
    try:
        p0 = static(rec)
        effect, sigma = {}, {}
        for key, (absolute, relative, _) in INPUT_SIGMA.items():
            value = getattr(rec.info, key, None)
            if value is None:
                continue
            sigma[key] = absolute + relative * abs(value)
            moved = dataclasses.replace(rec, info=dataclasses.replace(rec.info, **{key: value + sigma[key]}))
            effect[key] = (static(moved) - p0).tolist()
    except (StaticSolveError, DivergenceError) as exc:
        return {"u_input_unmeasured": f"static solve failed: {exc}"}
    u = {}
    for axis, key in enumerate(STEADY_KEYS):
        # the error S - D moves with S
        u_key = math.hypot(*(e[axis] for e in effect.values()))
        u[f"{key}_sim"] = u[key.removesuffix("_m") + "_error_m"] = u_key
    return {"input_sigma": sigma, "input_sigma_source": {k: INPUT_SIGMA[k][2] for k in sigma},
            "input_effect_m": effect, "u_input": u, "u_input_unmeasured": U_INPUT_UNMEASURED}


def steady_drogue_z(rec: FlightRecord) -> float:
    """The log's steady drogue height: the analysed steady value, or for an
    engagement the median of the valid fixes before contact."""
    if rec.info.test_kind == "engagement":
        t_on, _ = log_inputs.contact_window(rec)
        fixes = rec.tracker_fixes()
        return float(np.median(fixes["z_m"].to_numpy(float)[fixes.index < t_on]))
    return float(analyze_record(rec)["drogue_steady_z_m"])


def tune_drogue_lift(case: Case, variant: dict, records: list[FlightRecord]) -> float:
    """The drogue lift scale that puts the model's steady drogue height on the
    logs' (least squares over the tuning logs), by bounded scalar search on the
    static solution (each evaluation one static solve)."""
    targets = [(r, steady_drogue_z(r)) for r in records]

    def cost(scale):
        err = 0.0
        for rec, z_log in targets:
            sim = simulate_case(case, rec, variant={**_overrides(variant, {}), "drogue_lift_scale": scale},
                                duration=0.0)
            err += (sim.static.pos[-1, 2] - z_log) ** 2
        return err
    res = minimize_scalar(cost, bounds=(0.0, 2.0), method="bounded", options={"xatol": 1e-3})
    return float(res.x)


def validate_cases(case_paths: list[Path], workers: int | None = None, progress: Progress | None = None,
                   scheduler: str | None = None) -> list[CaseOutcome]:
    """Run every case's runs (in parallel over local processes, or on the Dask
    cluster at `scheduler`) and gate them; each tuning, calibration and run is
    a step of `progress`."""
    bar = progress or Progress("validate", enabled=False)
    cases = [load_case(p) for p in case_paths]
    seen: dict[str, str] = {}
    for c in cases:
        if c.id in seen:
            # one id, one set of results and figures: the second would overwrite the first
            raise InputError(f"{c.path}: case id '{c.id}' is also the id of {seen[c.id]}; ids must be unique")
        seen[c.id] = c.path
    outcomes: dict[str, CaseOutcome] = {}
    jobs = []
    for case in cases:
        bar.doing(f"{case.id}: reading its logs")
        paths = case_log_paths(case)
        if not paths:
            outcomes[case.id] = CaseOutcome(case, [], [], error="the case names no logs")
            continue
        if case.kind in RINGDOWN_KINDS:
            from workbench.properties.measure import group_measurements, measure_records
            try:
                groups = group_measurements(measure_records(paths))
                other = sorted({g["hose"] for g in groups} - {case["hardware"]["hose"]})
                if other:
                    raise InputError(f"{case.path}: [hardware] hose '{case['hardware']['hose']}' differs from "
                                     f"the logs' hose '{other[0]}'")
            except (LogError, InputError, ValueError) as exc:
                outcomes[case.id] = CaseOutcome(case, [], [], error=str(exc), error_code=EXIT_BAD_INPUT)
                continue
            outcomes[case.id] = CaseOutcome(case, [], [])
            jobs += [Job("ringdown", case, variants_of(case)[0], group=g) for g in groups]
            continue
        try:
            records = {p: read_record(p) for p in paths}
            for r in records.values():
                check_log_agrees(case, r)      # refused before any simulation, not gated
            tuned, calibrated, variants = {}, {}, []
            for v in variants_of(case):
                for key in ("tune_drogue_lift_on", "calibrate_on"):
                    if v.get(key) and not set(v[key]) <= {r.info.test_id for r in records.values()}:
                        raise InputError(f"{case.path}: variant '{v['id']}' {key} names logs {v[key]} not all "
                                         f"among the case's logs")
                if v.get("tune_drogue_lift_on"):
                    bar.add(1, f"{case.id}: tuning {v['id']}")
                    tr = [r for r in records.values() if r.info.test_id in v["tune_drogue_lift_on"]]
                    tuned[v["id"]] = tune_drogue_lift(case, v, tr)
                    bar.done()
                if v.get("calibrate"):
                    bar.add(1, f"{case.id}: calibrating {v['id']}")
                    tr = [p for p, r in records.items() if r.info.test_id in v["calibrate_on"]]
                    calibrated[v["id"]] = calibrate_variant(case, v, tr)
                    bar.done()
                    v = dict(v, effects=calibrated[v["id"]]["effects"])
                variants.append(v)
        except (LogError, InputError, StaticSolveError, DivergenceError, SimulationFailed) as exc:
            outcomes[case.id] = CaseOutcome(case, [], [], error=str(exc), error_code=exit_code_for(exc))
            continue
        outcomes[case.id] = CaseOutcome(case, [], [], tuned=tuned, calibrated=calibrated)
        for v in variants:
            for p in paths:
                jobs.append(Job("run", case, v, log_path=str(p), tuned=tuned))
    # each run's uncertainty study (`run_uncertainty`) after all runs, so that
    # the gated runs come first
    jobs += [dataclasses.replace(job, kind="uncertainty") for job in jobs if job.kind == "run"]
    bar.add(len(jobs), f"{len(jobs)} runs")
    with Mapper(workers, scheduler) as mapper:
        done = mapper(_guarded_run, jobs, progress=lambda _: bar.done())
    for job, (run, error) in zip(jobs, done):
        _collect(outcomes, job, run, error)
    for oc in outcomes.values():
        if oc.error is None:
            default_variant = variants_of(oc.case)[0]["id"]
            oc.gates = evaluate_gates(oc.case["gates"], default_variant, oc.runs)
            oc.findings = evaluate_findings(oc.case["findings"], default_variant, oc.runs)
    return [outcomes[c.id] for c in cases]


def calibrate_variant(case: Case, v: dict, paths: list[str]) -> dict:
    """A variant's `calibrate` effects fitted on its training logs (`paths`)
    with the case's own model and the variant's overrides: the diagnosis's
    calibrator on the comparison's components of those logs (not the
    signature components: the gates were set on these). {"effects": {name: {param:
    value}}, "stderr": {...}, "gap_before", "gap_train" (m), "on": test ids}.
    The effects are fitted one more at a time in the order `calibrate` lists
    them (the order forward selection added them), each fit starting at the
    last one's values (the grid spans only the new effect's parameters), as
    the diagnosis fitted them: a cold grid over four or five effects'
    parameters at once would cost thousands of simulations. The form
    parameters the variant's `refine` names ("effect.parameter") are fitted
    with their effect, as the diagnosis's refinement fitted them."""
    setup = Setup(None, str(case.path), tuple(sorted(_overrides(v, {}).items())), signatures=False,
                  refined=tuple(tuple(str(x).split(".", 1)) for x in v.get("refine") or ()))
    cal = None
    for k in range(1, len(v["calibrate"]) + 1):
        cal = EffectCalibrator(v["calibrate"][:k], setup).fit(paths, start=cal.params_ if cal else None)
    return {"effects": cal.params_, "stderr": cal.stderr_, "gap_train": cal.gap_train_,
            "gap_before": cal.gap_before_, "on": [Path(p).stem for p in paths]}


def _guarded_run(job) -> tuple[Run | None, tuple[str, int] | None]:
    """`_one_run`, with a failure returned as (message, exit code) so that one
    bad run leaves the others' results (and a worker's exception need not
    pickle)."""
    try:
        return _one_run(job), None
    except (LogError, InputError, StaticSolveError, DivergenceError, ValueError) as exc:
        # a ValueError here is a record the comparison refuses: bad input
        return None, (str(exc), EXIT_BAD_INPUT if isinstance(exc, ValueError) else exit_code_for(exc))


def _collect(outcomes, job: Job, run: Run | None, error: tuple[str, int] | None):
    oc = outcomes[job.case.id]
    if job.kind == "uncertainty":
        # an uncertainty study: its run's, never a failure of the case
        fine = [r for r in oc.runs if r.variant == job.variant["id"] and r.log_path == job.log_path]
        if fine:
            attach_u_num(fine[0], run if run is not None else {"error": error[0]})
        return
    if run is not None:
        oc.runs.append(run)
    elif oc.error is None:
        oc.error = f"variant {job.variant['id']}, {job.where}: {error[0]}"
        oc.error_code = error[1]


def results_dict(outcomes: list[CaseOutcome]) -> dict:
    """The machine-readable results (results.json)."""
    cases = []
    for oc in outcomes:
        cases.append({
            "id": oc.case.id, "title": oc.case.title, "kind": oc.case.kind, "file": project_path(oc.case.path),
            "passed": oc.passed, "error": oc.error, "error_code": oc.error_code, "tuned": oc.tuned,
            "calibrated": oc.calibrated,
            "metrics": {f"{r.variant}/{r.log_id}/{k}": v for r in oc.runs for k, v in r.metrics.items()
                        if not isinstance(v, (list, dict))},
            "runs": [{"variant": r.variant, "log": r.log_id, "log_file": project_path(r.log_path), "held_out": r.held_out,
                      "wall_s": r.wall_s, "model_options": r.model_options, "metrics": r.metrics,
                      "uncertainty": r.uncertainty}
                     for r in oc.runs],
            "gates": [{"metric": g.metric, "variant": g.variant, "value": g.value, "threshold": g.threshold,
                       "kind": g.kind, "passed": g.passed, "margin": g.margin, "source": g.source,
                       "part60": g.part60, "logs": g.logs} for g in oc.gates],
            "findings": [{"metric": f.metric, "variant": f.variant, "value": f.value, "expected": f.expected,
                          "band": f.band, "status": f.status, "passed": f.passed, "source": f.source,
                          "band_source": f.band_source, "logs": f.logs} for f in oc.findings],
        })
    return json_safe({"passed": all(c["passed"] for c in cases), "code_version": code_version(),
                  "data_note": "Flight and bench records stand in for non-public program data: they come "
                               "from an independent higher-fidelity model.",
                  "cases": cases})
