"""The Python API for notebooks and scripts (`import workbench`): the verbs of
the command line as functions that take paths or objects and return results
with `.to_pandas()` and `.plot()`; nothing is written to disk."""
from __future__ import annotations

from pathlib import Path

from flighttest import FlightRecord, read_record
from workbench.cases import Case, load_case
from workbench.diagnosis import DEFAULT_ELEMENTS, Diagnosis
from workbench.diagnosis import diagnose as _diagnose
from workbench.effects_case import with_effects
from workbench.case_run import RunOutcome, run_case
from workbench.progress import Progress
from workbench.validation import CaseOutcome, validate_cases

__all__ = ["load_case", "run", "validate", "diagnose"]


def _record(log: FlightRecord | str | Path) -> FlightRecord:
    return log if isinstance(log, FlightRecord) else read_record(log)


def run(case: Case | str | Path, log: FlightRecord | str | Path | None = None, *,
        duration: float | None = None, effects: dict | None = None) -> RunOutcome:
    """Simulate a case (a `Case` or a case file), against `log` (a record or an
    .mcap path) when given: `workbench run CASE [--log LOG]`. `effects`:
    {name: {param: value}} over the case's [effects]. The outcome's
    `.result` is the `SimulationResult`; `.to_pandas()` and `.plot()` are its."""
    case = case if isinstance(case, Case) else load_case(case)
    if effects:
        case = with_effects(case, effects)
    return run_case(case, duration, _record(log) if log is not None else None)


def validate(cases: str | Path | list, *, workers: int | None = None,
             progress: bool = False) -> list[CaseOutcome]:
    """Run case files against their logs and gate them (`workbench validate`),
    one `CaseOutcome` per case (`.passed`, `.gates`, `.findings`, `.runs`,
    `.to_pandas()`, `.plot()`); no report is written."""
    paths = [Path(cases)] if isinstance(cases, (str, Path)) else [Path(c) for c in cases]
    return validate_cases(paths, workers=workers, progress=Progress("validate", enabled=progress))


def diagnose(logs: str | Path | list, *, n_elements: int = DEFAULT_ELEMENTS,
             workers: int | None = None, baseline: str = "fleet") -> Diagnosis:
    """Where the simulation departs from flight logs and which unmodelled effect
    explains it (`workbench diagnose`): a `Diagnosis` (`.ranking`, `.findings`,
    `.to_pandas()`, `.plot()`); each family against its fleet calibration
    where `cases/fleet/fleet.toml` lists it, unless `baseline="datasheet"`."""
    paths = [str(logs)] if isinstance(logs, (str, Path)) else [str(p) for p in logs]
    return _diagnose(paths, n_elements, workers, baseline=baseline)
