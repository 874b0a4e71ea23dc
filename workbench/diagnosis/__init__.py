"""`workbench diagnose`: where the simulation departs from flight logs, which
unmodelled effect explains it, and how far the gap shrinks once it is added.

Modules by concern, data flowing down the list:

* `setup`: the method's constants, the baseline case from a log (`Setup`),
  which effects apply to a log; calibration metadata comes from the effect
  registry (`solver.effects.Param`).
* `evaluate`: the simulation of a log under effects, as a record, and its
  residual (`flighttest.residual`, the comparison validation uses too; the gap).
* `where`: the residual's where-map (channel, station, phase, band; channel x
  phase and station x band tables; the log and simulation thinned for overlays).
* `fit`: `EffectCalibrator` (fit / score) and the folds (`LeaveOneLogOut`,
  `TimeBlocks`).
* `screen`: each effect's sensitivity directions and the share of the
  residual they span.
* `identify`: which screened effects the logs cannot tell apart (principal
  angles between their noise-weighted sensitivity patterns).
* `score`: a candidate fitted per fold and scored held out (warm-started
  at a set's fitted values); fitted on all logs, the bound of that gap.
* `accept`: the acceptance rule (the noise floor, widened by what a random
  motion explains by chance; the parameter penalty) and which of
  explanations the logs cannot tell apart comes first.
* `select`: forward selection of several effects at once (each selected
  effect's share of the gap).
* `revise`: the selected set revised once selection stops (form parameters
  refined, redundant events dropped, an event traded for a calibration).
* `turbulence`: turbulence from its statistics (the drogue's random motion
  above the tracker noise against a seeded Dryden ensemble): its candidate,
  sigma with its error, and the steady floor a deterministic effect must beat.
* `fleet`: fleet calibrations, what the program's flights established about
  each family's hardware: the baseline a new log of it is diagnosed against.
* `rank`: one family's diagnosis and the `diagnose` of many logs.
* `result`: `Diagnosis`, `FamilyDiagnosis`, `Candidate` (typed, `to_pandas()`).
* `remainder`: what the best explanation leaves, per channel and station;
  model form when it is the same in every log.
* `findings`: the diagnosis in words.
* `report`: the reporters (diagnosis.json / .html, selftest.json, the section
  of validate's report); compute never writes files.
* `selftest`: the method proven on generated logs whose effect it is not told.
"""
from workbench.errors import SimulationFailed
from workbench.diagnosis.fit import EffectCalibrator, LeaveOneLogOut, TimeBlocks
from workbench.diagnosis.rank import diagnose, diagnose_family
from workbench.diagnosis.fleet import FLEET_PATH
from workbench.diagnosis.report import report_blocks, write_diagnosis, write_fleet, write_selftest
from workbench.diagnosis.result import Candidate, Diagnosis, FamilyDiagnosis
from workbench.diagnosis.setup import DEFAULT_ELEMENTS, Setup

__all__ = ["Candidate", "DEFAULT_ELEMENTS", "Diagnosis", "EffectCalibrator", "FLEET_PATH", "FamilyDiagnosis",
           "LeaveOneLogOut", "Setup", "SimulationFailed", "TimeBlocks", "diagnose", "diagnose_family", "report_blocks",
           "write_diagnosis", "write_fleet", "write_selftest"]
