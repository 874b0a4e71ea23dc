"""Qualification-style objective tests per log, with the validation uncertainty
of each comparison (ASME V&V 20).

For each quantity: the flight (or bench) value D, the model's S, the
comparison error E = S - D, and u_val = sqrt(u_D² + u_num² + u_input²):

- u_D, the data's uncertainty: the spread (sample standard deviation) of D
  over the repetitions: the bench repetitions of a setpoint, or the case's
  logs of the same test (the three doublets, the four trails, the two
  engagements). For a quantity that is itself an error (an RMS over a time
  history or a shape), the spread of that error over the case's logs.
- u_num, the numerical error: for a flight run, validate's discretisation
  study (`workbench.validation.run_uncertainty`): the run again at half the
  elements, Roache's GCI = 3 |S - S_coarse| / (2² - 1), u_num = GCI / 2. For
  a bench ring-down, the property tables' verification bound
  (`verification_tolerance_pct` of cases/properties/hose_properties.json:
  frequency 0.5 %, damping 2 % of the value).
- u_input: the steady drogue position moved by each test-card input's
  1-sigma (airspeed, altitude, OAT, tanker weight) through the static solve,
  root-sum-squared (`workbench.validation.INPUT_SIGMA`); not measured ('–') for
  the other quantities.

A per-metric u of S carries to a quantity through the quantity's own
accessor (first order: period = 1/f gives u_f / f²). Where |E| <= u_val the
model is validated to the level of u_val (V&V 20 §1-5: the model error is then
within the noise of the validation); where |E| is well above u_val, E
measures the model's error. The 14 CFR Part 60 objective-test tolerances
(flight simulator qualification: period within 10 %, damping ratio within
0.02, time histories within stated bands) are shown beside the paper's gates.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from workbench.report.document import Cell, Table, esc, fmt



@dataclass(frozen=True)
class Quantity:
    label: str
    log: Callable[[dict], float | None]       # D from a run's metrics
    sim: Callable[[dict], float | None]       # S
    u_num: str | None                         # the verification bound of S (a key of the bounds), None: 0
    part60: Callable[[float], float] | None   # allowed |E| at D, None where Part 60 has no tolerance
    part60_text: str
    gate_metric: str | None                   # the case's gate on this comparison
    error_only: bool = False                  # the quantity is itself an error (D = 0, S = the error)


def _m(key: str):
    get = lambda m: _num(m.get(key))
    get.key = key                 # the metric its uncertainties are stored under
    return get


def _num(v):
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) else None


def _period(key: str):
    def get(m):
        f = _num(m.get(key))
        return 1.0 / f if f else None
    get.key = key
    return get


def _error_only(key: str) -> tuple:
    """A quantity that is itself a comparison error: D is 0, S is the error."""
    return (lambda m: 0.0 if _num(m.get(key)) is not None else None), _m(key)


_PERIOD_10PCT = (lambda d: 0.10 * abs(d)), "±10 % of the period"
_DAMPING_002 = (lambda d: 0.02), "±0.02"
_NONE = None, "no Part 60 tolerance"
_TIME_HISTORY = None, "time history: within a stated band (none stated)"

QUANTITIES: dict[str, list[Quantity]] = {
    "pitch_doublet": [
        Quantity("period (s)", _period("drogue_frequency_hz_log"), _period("drogue_frequency_hz_sim"),
                 "frequency", *_PERIOD_10PCT, "drogue_frequency_error_pct"),
        Quantity("damping ratio (-)", _m("drogue_damping_ratio_log"), _m("drogue_damping_ratio_sim"),
                 "damping", *_DAMPING_002, "drogue_damping_error_pct"),
        Quantity("steady drogue z (m)", _m("drogue_steady_z_m_log"), _m("drogue_steady_z_m_sim"), None, *_NONE,
                 "drogue_steady_z_error_m"),
        Quantity("z response RMS error (m)", *_error_only("drogue_z_response_rms_error_m"), None, *_TIME_HISTORY,
                 "drogue_z_response_rms_error_m", error_only=True),
    ],
    "trail": [
        Quantity("steady drogue x (m)", _m("drogue_steady_x_m_log"), _m("drogue_steady_x_m_sim"), None, *_NONE,
                 "drogue_steady_x_error_m"),
        Quantity("steady drogue y (m)", _m("drogue_steady_y_m_log"), _m("drogue_steady_y_m_sim"), None, *_NONE,
                 "drogue_steady_y_error_m"),
        Quantity("steady drogue z (m)", _m("drogue_steady_z_m_log"), _m("drogue_steady_z_m_sim"), None, *_NONE,
                 "drogue_steady_z_error_m"),
        Quantity("hose shape RMS error (m)", *_error_only("trail_shape_rms_error_m"), None, *_TIME_HISTORY,
                 "trail_shape_rms_error_m", error_only=True),
    ],
    "engagement": [
        Quantity("transverse wave speed (m/s)", _m("wave_speed_mps_log"), _m("wave_speed_mps_sim"), None, *_NONE,
                 "wave_speed_error_pct"),
        Quantity("reel delay behind the drogue (s)", _m("reel_delay_s_log"), _m("reel_delay_s_sim"), None, *_NONE,
                 None),
        Quantity("shape RMS error before contact (m)", *_error_only("shape_rms_error_pre_contact_m"), None,
                 *_TIME_HISTORY, "shape_rms_error_pre_contact_m", error_only=True),
        Quantity("shape RMS error engaged (m)", *_error_only("shape_rms_error_engaged_m"), None, *_TIME_HISTORY,
                 "shape_rms_error_engaged_m", error_only=True),
    ],
    "ringdown": [
        Quantity("period (s)", _period("frequency_measured_hz"), _period("frequency_simulated_hz"),
                 "frequency", *_PERIOD_10PCT, "frequency_error_pct"),
        Quantity("damping ratio (-)", _m("damping_measured"), _m("damping_simulated"),
                 "damping", *_DAMPING_002, "damping_error_pct"),
    ],
}


def _u_data(q: Quantity, runs: list, run) -> float | None:
    """The spread of D (or of an error-only quantity's S) over the repetitions."""
    m = run["metrics"]
    if q.label.startswith("period") and "frequency_measured_std_hz" in m:
        f, sd = _num(m["frequency_measured_hz"]), _num(m["frequency_measured_std_hz"])
        return sd / f ** 2 if f and sd is not None else None
    if q.label.startswith("damping") and "damping_measured_std" in m:
        return _num(m["damping_measured_std"])
    side = q.sim if q.error_only else q.log
    same = [r for r in runs if r["variant"] == run["variant"]] if q.error_only else \
        list({r["log"]: r for r in runs}.values())
    vals = [v for v in (side(r["metrics"]) for r in same) if v is not None]
    return float(np.std(vals, ddof=1)) if len(vals) >= 2 else None


def _u_of_s(q: Quantity, metrics: dict, per_metric: dict | None) -> float | None:
    """A per-metric uncertainty of the run (u_num or u_input, by metric name)
    carried to the quantity S through its accessor, first order."""
    key = getattr(q.sim, "key", None)
    u = _num((per_metric or {}).get(key))
    s = q.sim(metrics)
    if u is None or s is None:
        return None
    moved = q.sim({**metrics, key: metrics[key] + u})
    return abs(moved - s) if moved is not None else None


def rss(*us: float | None) -> float:
    """The root sum of squares of the uncertainties given (None: not measured, left out)."""
    return math.sqrt(sum(u * u for u in us if u is not None))


def _gate_text(case: dict, q: Quantity, variant: str, log_id: str) -> Cell:
    gates = [g for g in case["gates"] if g["metric"] == q.gate_metric and g["variant"] == variant
             and log_id in g["logs"]]
    if not gates:
        return Cell("–")
    g = gates[0]
    op = "≤" if g["kind"] == "max" else "≥"
    return Cell(f"{esc(g['metric'])} {op} {esc(fmt(g['threshold']))}: {'pass' if g['passed'] else 'FAIL'}",
                "pass" if g["passed"] else "fail")


def objective_tables(case: dict, bounds_pct: dict[str, float]) -> list[Table]:
    """One table per log (per bench setpoint for ring-downs): each variant's
    quantities with E, its uncertainties and the tolerances beside it.
    `bounds_pct`: the property tables' verification bounds in % of the value
    ({"frequency": .., "damping": ..}), taken as u_num."""
    kind = "ringdown" if case["kind"].startswith("ringdown") else case["kind"]
    qs = QUANTITIES.get(kind)
    if not qs or not case["runs"]:
        return []
    by_log: dict[str, list] = {}
    for r in case["runs"]:
        by_log.setdefault(r["log"], []).append(r)
    tables = []
    for log_id, runs in by_log.items():
        rows = []
        for r in runs:
            for q in qs:
                d, s = q.log(r["metrics"]), q.sim(r["metrics"])
                if d is None or s is None:
                    continue
                e = s - d
                unc = r.get("uncertainty") or {}
                u_d = _u_data(q, case["runs"], r)
                u_n = _u_of_s(q, r["metrics"], unc.get("u_num"))
                if u_n is None and q.u_num and not unc:    # a bench ring-down: no study, the bound
                    u_n = bounds_pct[q.u_num] / 100.0 * abs(s)
                u_i = _u_of_s(q, r["metrics"], unc.get("u_input"))
                u_val = rss(u_d, u_n, u_i)
                if q.part60 is None:
                    p60 = Cell(esc(q.part60_text), "small")
                else:
                    tol = q.part60(d)
                    ok = abs(e) <= tol
                    p60 = Cell(f"{esc(q.part60_text)} ({esc(fmt(tol))}): {'within' if ok else 'outside'}",
                               "pass" if ok else "fail")
                within = Cell("yes", "pass") if abs(e) <= u_val else Cell("no")
                rows.append([r["variant"] + ("" if r["held_out"] else " (training)"), q.label,
                             None if q.error_only else d, None if q.error_only else s, e,
                             u_d, u_n, u_i, u_val, Cell(f"{esc(fmt(e))} ± {esc(fmt(u_val))}"), within,
                             _gate_text(case, q, r["variant"], log_id), p60])
        if rows:
            tables.append(Table(
                ["variant", "quantity", "flight D", "model S", "E = S − D", "u_D", "u_num", "u_input", "u_val",
                 "E ± u_val", "|E| ≤ u_val", "paper gate", "14 CFR Part 60"], rows,
                [12, 15, 7, 7, 7, 6, 6, 6, 6, 10, 6, 13, 13],
                title=f"Objective tests: {esc(log_id)}", row_class="objective-row",
                note="E ± u_val per ASME V&V 20; u_D, u_num, u_input and u_val as defined in the glossary "
                     "('–': not measured, left out of u_val). |E| ≤ u_val: the model is validated to the level "
                     "of u_val. For an RMS error E is the error itself."))
    return tables
