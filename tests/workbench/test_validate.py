"""`workbench validate`: runs, gates, results.json, JUnit XML, report files, exit codes."""
import json
from pathlib import Path

from click.testing import CliRunner

from workbench.cli import cli

ROOT = Path(__file__).resolve().parents[2]

CASE = """
id = "trail-mini"
title = "one steady trail, baseline model"
kind = "trail"
logs = ["flight/TR-KDC10-E7.mcap"]

[hardware]
hose = "kdc10_pod"
drogue = "kdc10_pod"

[condition]
from_log = true

[model]
n_elements = 12
drogue_lift_scale = 0.0

[model.structure]
EI_N_m2 = 50.0
EA_N = 2.0e6
bending_damping_N_m2_s = 2.0
axial_damping_N_s = 300.0

[tow_motion]
kind = "from_log"

[run]
duration_s = 0.5

[[gates]]
metric = "drogue_steady_x_error_m"
max = 1.0
source = "loose check that the trail is in the right place"

[[gates]]
metric = "trail_shape_rms_error_m"
max = {shape_max}
source = "test threshold"
"""


def run_validate(tmp_path, shape_max):
    case = tmp_path / "trail_mini.toml"
    case.write_text(CASE.replace("{shape_max}", str(shape_max)))
    out = tmp_path / "out"
    res = CliRunner().invoke(cli, ["validate", str(case), "--out", str(out), "--no-progress"])
    return res, out


def test_validate_writes_results_and_passes(tmp_path):
    res, out = run_validate(tmp_path, 5.0)
    assert res.exit_code == 0, res.output
    results = json.loads((out / "results.json").read_text())
    assert results["passed"] is True
    (case,) = results["cases"]
    assert case["id"] == "trail-mini" and case["passed"]
    assert {g["metric"] for g in case["gates"]} == {"drogue_steady_x_error_m", "trail_shape_rms_error_m"}
    for g in case["gates"]:
        assert g["value"] is not None and g["threshold"] is not None and g["passed"]
    m = case["metrics"]
    # the no-lift baseline trails below the log (paper Fig. 14): the drogue z error is negative
    assert m["baseline/TR-KDC10-E7/drogue_steady_z_error_m"] < 0
    assert 0 < m["baseline/TR-KDC10-E7/trail_shape_rms_error_m"] < 2.0
    assert (out / "report.html").stat().st_size > 1000
    assert (out / "report.pdf").read_bytes()[:4] == b"%PDF"
    assert "<testsuite" in (out / "junit.xml").read_text()
    assert list((out / "figures").glob("*.png"))


def test_failing_gate_exits_one_and_names_it(tmp_path):
    res, out = run_validate(tmp_path, 0.001)
    assert res.exit_code == 1
    assert "trail-mini: trail_shape_rms_error_m (baseline)" in res.output
    assert "needs <= 0.001" in res.output
    junit = (out / "junit.xml").read_text()
    assert 'failures="1"' in junit
