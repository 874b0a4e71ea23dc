"""Bench ring-down records -> per-element hose property tables (paper III.B, IV.A).

The pipeline, in the order `build_properties` runs it:

1. Measure every ring-down record (`measure`), averaging the repetitions at
   each setpoint.
2. Tune, for each element count N, the constants of an N-element model of the
   bench rig so that its first linear mode has the measured damped frequency
   and damping ratio (`rig`, `tune`, `solver.linear`).
3. Carry the room-temperature axial constants to the bending temperatures like
   the bending ones (an assumption, recorded), and derive the hoses never
   bench tested from one of like construction (`tune`).
4. Verify (paper Fig. 9): simulate the N=8 bench model with table constants in
   time and measure it like a record (`verify`).

The result is one JSON document (`store`) holding the tables and the
provenance of every number: files and their SHA-256, per-record measurements,
group statistics, tuning residuals, the assumptions and the verification.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Callable, Iterable

import flighttest.analyze
import flighttest.metrics
import solver.integrate
import solver.kernel
import solver.linear
import solver.model
import solver.properties
import solver.statics
from solver.properties import PropertyTable
from workbench.errors import InputError
from workbench.hardware import Hardware, load_hardware
from workbench.properties import measure, rig, tune, verify
from workbench.properties.measure import group_measurements, measure_records
from workbench.properties.store import FORMAT
from workbench.properties.tune import TUNE_TOL, build_hose, derive_hose
from workbench.properties.verify import (DAMPING_TOLERANCE, FREQUENCY_TOLERANCE, VERIFY_ELEMENTS,
                                         interpolation_checks, verify_hose)
from workbench.provenance import ROOT, code_version, dependency_versions, source_sha256

# The modules whose code made the numbers, hashed into the document.
_CODE = (measure, rig, tune, verify, sys.modules[__name__], solver.properties, solver.kernel, solver.model,
         solver.statics, solver.integrate, solver.linear, flighttest.metrics, flighttest.analyze)
DEFAULT_LOGS = ROOT / "flighttest" / "logs" / "ringdown"
ELEMENT_COUNTS = (4, 6, 8, 12, 16, 24, 32, 48, 64)
# Hoses derived from a tested one: (derived, source). The paper's KDC-10 pod hose
# (section V.B): "similar construction to the KC-130 hose".
DERIVED_HOSES = (("kdc10_pod", "kc130_long"),)


METHOD = {
    "measurement": (
        "free decay = flighttest.analyze window (one period after the release, the largest "
        "excursion, until the band-passed envelope falls below 2 % or 3x the noise floor); "
        "frequency = FFT peak of that window (metrics.dominant_frequency: Hann, zero-padded, "
        "log-parabolic peak); damping ratio = logarithmic decrement (metrics.log_decrement via "
        "analyze_record 'damping_ratio_logdec'); axial records: (a1 + a2)/2 (metrics.axial_rocking); "
        "temperature = mean of both thermocouples over the record; repetitions at one setpoint "
        "averaged (sample std as spread)"),
    "tuning": (
        "per element count N: linear modes of the N-element bench model about its static "
        "equilibrium (stiffness and damping by central differences of solver.kernel.compute_forces, "
        "lumped masses, quadratic eigenproblem); lowest oscillatory mode with the free end moving "
        "mostly along z; Broyden iteration on (ln k, ln c) until damped frequency and damping ratio "
        f"match the measured means to {TUNE_TOL:g} (log residual)"),
    "interpolation": (
        "cubic spline (not-a-knot) in measured temperature per tabulated element length, then "
        "log-log linear in element length; beyond the tabulated lengths constant x length is held "
        "(continuum scaling); a temperature outside the tested range is refused unless "
        "allow_extrapolation"),
    "axial_temperature": (
        "paper III.B assumption: axial constants scale with temperature in the same ratio as the "
        "bending ones relative to room temperature (the axial test temperature); untested"),
    "derived_hoses": "scaled from a tested hose by the ratio of cross-section second moments of area",
    "interpolation_checks": (
        "linear modes of the bench model with table constants at element counts between the "
        "tuned ones, and at each interior tested temperature with that temperature left out of "
        "the spline; against the measured means"),
    "verification": (
        f"paper Fig. 9: N={VERIFY_ELEMENTS} bench model with table constants, static equilibrium, "
        "tip pushed down by the measured release amplitude (linear static shape under a tip load) "
        "or end weight struck, solver.integrate.simulate, tip acceleration written as a ring-down "
        "record and measured as above; tolerance "
        f"{100 * FREQUENCY_TOLERANCE:g} % frequency, {100 * DAMPING_TOLERANCE:g} % damping ratio"),
}


def build_properties(logs_dir: str | Path = DEFAULT_LOGS, hardware: Hardware | None = None,
                     element_counts: Iterable[int] = ELEMENT_COUNTS,
                     verify_elements: int = VERIFY_ELEMENTS,
                     derived: Iterable[tuple[str, str]] = DERIVED_HOSES,
                     progress: Callable[[str], None] | None = None) -> dict:
    """The property document (JSON-ready) from the ring-down records in `logs_dir`."""
    hw = hardware if hardware is not None else load_hardware()
    logs = Path(logs_dir)
    paths = sorted(logs.glob("*.mcap"))
    if not paths:
        raise InputError(f"{logs}: no .mcap records")
    counts = sorted({int(n) for n in element_counts})
    if not counts or counts[0] < 2:
        raise InputError(f"element counts must be integers >= 2, got {counts}")
    if verify_elements not in counts:
        raise InputError(f"the verification element count {verify_elements} is not among {counts}")
    meas = measure_records(paths, progress)
    if not meas:
        raise InputError(f"{logs}: no ring-down records")
    groups = group_measurements(meas)
    hoses = sorted({g["hose"] for g in groups if g["test_kind"] == "ringdown_bending"})
    tables: dict[str, PropertyTable] = {}
    provs: dict[str, dict] = {}
    verification: list[dict] = []
    checks: list[dict] = []
    for hose in hoses:
        sheet = hw.get("hose", hose)
        table, prov = build_hose(hose, groups, sheet, counts, progress)
        prov["records"] = sorted({r for g in prov["bending_groups"] + [prov["axial_group"]]
                                  for r in g["records"]})
        tables[hose], provs[hose] = table, prov
        verification += verify_hose(table, prov, sheet, verify_elements, progress)
        checks += interpolation_checks(table, prov, sheet)
    for name, source in derived:
        if name in tables or source not in tables or name not in hw.hoses:
            continue
        tables[name], provs[name] = derive_hose(tables[source], hw.get("hose", source), hw.get("hose", name))
    try:
        logs_label = str(logs.resolve().relative_to(ROOT))
    except ValueError:
        logs_label = str(logs)
    return {
        "format": FORMAT,
        "generated_by": "workbench properties build",
        "code_version": {"git": code_version(), "source_sha256": source_sha256(_CODE),
                         "dependencies": dependency_versions()},
        "inputs": {"logs": logs_label, "hardware": Path(hw.path).name,
                   "records": [{"file": m["file"], "sha256": m["sha256"]} for m in meas]},
        "element_counts": counts,
        "method": METHOD,
        "tables": {h: t.to_dict() for h, t in sorted(tables.items())},
        "hoses": provs,
        "measurements": meas,
        "verification": verification,
        "verification_tolerance_pct": {"frequency": 100 * FREQUENCY_TOLERANCE,
                                       "damping": 100 * DAMPING_TOLERANCE},
        "interpolation_checks": checks,
    }

