"""Gates and findings of a validation case, and the metric names they may use.

A *gate* is an acceptance check the product must pass: the bench
verification, the diagnosed (calibrated on training logs, scored on held-out
ones) variants, regression bounds on the best model. It has a threshold and
cites its source; where a 14 CFR Part 60 objective-test tolerance exists it is
shown beside the paper's (`part60`).

A *finding* documents what a reference model (the paper's no-lift,
wind-tunnel-lift and tuned-lift baselines) gets wrong: its expected value, the
band it may move in and where both come from. A finding whose value leaves its
band is "changed": the model moved, which fails validation like a gate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

# Per case kind, the run metrics a gate or finding may name: what
# `flighttest.compare.compare` (and, for engagements, validate's hose
# whip measures; for ring-downs, `properties.verify_group`) produces per run.
_SIDE = ("_log", "_sim")
METRICS: dict[str, frozenset[str]] = {
    "pitch_doublet": frozenset(
        [f"{k}{s}" for k in ("drogue_frequency_hz", "drogue_damping_ratio", "drogue_steady_x_m",
                             "drogue_steady_z_m") for s in _SIDE]
        + ["drogue_frequency_error_pct", "drogue_damping_error_pct", "drogue_steady_x_error_m",
           "drogue_steady_z_error_m", "drogue_z_response_rms_error_m", "drogue_z_response_peak_error_m",
           "drogue_z_response_lag_s"]),
    "trail": frozenset(
        [f"drogue_steady_{c}_m{s}" for c in "xyz" for s in _SIDE]
        + [f"drogue_steady_{c}_error_m" for c in "xyz"]
        + ["drogue_steady_cross_error_m", "trail_shape_rms_error_m", "trail_shape_max_error_m", "trail_vertical_rms_error_m"]),
    "engagement": frozenset(
        [f"{k}{s}" for k in ("wave_speed_mps", "reel_delay_s") for s in _SIDE]
        + ["wave_speed_error_pct", "shape_rms_error_engaged_m", "shape_rms_error_pre_contact_m"]
        + [f"shape_rms_error_at_{m}_m" for m in ("contact", "slack", "max_slack_wave", "max_reel_takeup",
                                                 "refuelling_steady", "disconnect")]),
    "ringdown_bending": frozenset(
        ["frequency_error_pct", "damping_error_pct", "frequency_measured_hz", "frequency_simulated_hz",
         "damping_measured", "damping_simulated"]),
}
METRICS["ringdown_axial"] = METRICS["ringdown_bending"]
# the hose-whip measures validate adds to an engagement run from the simulation alone
WHIP_METRICS = frozenset(["peak_slack_m", "wave_amplitude_2m_from_tow_m", "peak_tension_N",
                          "tow_tension_peak_N", "probe_load_peak_N", "probe_load_refuelling_mean_N"])
METRICS["engagement"] = METRICS["engagement"] | WHIP_METRICS


@dataclass
class GateResult:
    metric: str
    variant: str
    value: float | None
    threshold: float
    kind: str           # "max" or "min"
    passed: bool
    source: str
    logs: list
    part60: str | None = None   # the 14 CFR Part 60 objective-test tolerance, where one exists

    @property
    def margin(self) -> float | None:
        if self.value is None:
            return None
        return self.threshold - self.value if self.kind == "max" else self.value - self.threshold


@dataclass
class FindingResult:
    metric: str
    variant: str
    value: float | None     # mean over the finding's held-out logs (signed)
    expected: float
    band: float             # the value may lie in expected +- band
    source: str             # where the expected value comes from (the paper's figure or table)
    band_source: str        # where the band comes from
    logs: list

    @property
    def status(self) -> str:
        """'as expected', 'changed' (left its band: the model moved) or 'missing' (no value)."""
        if self.value is None:
            return "missing"
        return "as expected" if abs(self.value - self.expected) <= self.band else "changed"

    @property
    def passed(self) -> bool:
        return self.status == "as expected"


def _values(runs, variant: str, metric: str, logs: list) -> tuple[list[float], list[str]]:
    """The finite values of `metric` over the variant's held-out runs (on `logs`, if given)."""
    sel = [r for r in runs if r.variant == variant and r.held_out and (not logs or r.log_id in logs)]
    vals = [r.metrics.get(metric) for r in sel]
    return ([float(v) for v in vals if isinstance(v, (int, float)) and math.isfinite(v)],
            [r.log_id for r in sel])


def evaluate_gates(gates: list[dict], default_variant: str, runs) -> list[GateResult]:
    """Each gate on the worst of its held-out runs (largest for a max, smallest for a min)."""
    out = []
    for g in gates:
        var = g["variant"] or default_variant
        vals, logs = _values(runs, var, g["metric"], g["logs"])
        kind = "max" if g["max"] is not None else "min"
        thr = float(g["max"] if kind == "max" else g["min"])
        value = passed = None
        if vals:
            vals = [abs(v) for v in vals] if g["abs"] else vals
            value = max(vals) if kind == "max" else min(vals)
            passed = value <= thr if kind == "max" else value >= thr
        out.append(GateResult(g["metric"], var, value, thr, kind, bool(passed), g["source"], logs, g["part60"]))
    return out


def evaluate_findings(findings: list[dict], default_variant: str, runs) -> list[FindingResult]:
    """Each finding's mean over its held-out runs, against its expected value and band."""
    out = []
    for f in findings:
        var = f["variant"] or default_variant
        vals, logs = _values(runs, var, f["metric"], f["logs"])
        value = sum(vals) / len(vals) if vals else None
        out.append(FindingResult(f["metric"], var, value, float(f["expected"]), float(f["band"]),
                                 f["source"], f["band_source"], logs))
    return out
