"""`workbench validate`: runs, gates, results.json, JUnit XML, report files, exit codes."""
import json
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from numpy.testing import assert_allclose

from workbench.cli import cli
from workbench.report import fmt

ROOT = Path(__file__).resolve().parents[2]

# the KDC-10 pod hose and drogue at each log's condition, 12 elements
TRAIL = """
[hardware]
hose = "kdc10_pod"
drogue = "kdc10_pod"

[condition]
from_log = true

[model]
n_elements = 12
"""

CASE = """
id = "trail-mini"
title = "one steady trail, baseline model"
kind = "trail"
logs = ["flight/TR-KDC10-E7.mcap"]
""" + TRAIL + """drogue_lift_scale = 0.0

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

[[findings]]
metric = "drogue_steady_z_error_m"
expected = {z_expected}
band = 0.05
source = "paper Fig. 14: without lift the trail hangs low; cases/kdc10_trail.toml's 40-element no-lift model is 0.706 m low on E7"
band_source = "this 12-element model with assumed constants differs from the 40-element one"
"""
# the no-lift trail's drogue height error on E7 (kdc10-trail finding: -0.706 m at 40 elements)
Z_EXPECTED = -0.70


def run_validate(tmp_path, shape_max, z_expected=Z_EXPECTED):
    case = tmp_path / "trail_mini.toml"
    case.write_text(CASE.replace("{shape_max}", str(shape_max)).replace("{z_expected}", str(z_expected)))
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
    (f,) = case["findings"]
    assert f["metric"] == "drogue_steady_z_error_m" and f["variant"] == "baseline"
    assert f["status"] == "as expected" and f["passed"] and f["logs"] == ["TR-KDC10-E7"]
    assert f["value"] == m["baseline/TR-KDC10-E7/drogue_steady_z_error_m"]
    assert abs(f["value"] - Z_EXPECTED) <= f["band"]
    # the run's V&V 20 uncertainty study: the half-element run and the inputs' static solves
    (run,) = case["runs"]
    u = run["uncertainty"]
    assert (u["n_elements"], u["n_elements_coarse"], u["refinement_ratio"]) == (12, 6, 2.0)
    key = "drogue_steady_z_m_sim"
    # u_num = GCI / 2 = 3 |S - S_coarse| / (2^2 - 1) / 2, to rounding
    assert_allclose(u["u_num"][key], abs(run["metrics"][key] - u["coarse_metrics"][key]) / 2, rtol=1e-12)
    assert set(u["input_sigma"]) >= {"calibrated_airspeed_mps", "altitude_m", "oat_K"}
    # u_input: the root sum of squares of each input's effect on the static drogue height
    assert_allclose(u["u_input"][key], np.linalg.norm([e[2] for e in u["input_effect_m"].values()]), rtol=1e-12)
    assert u["u_input"]["drogue_steady_z_error_m"] == u["u_input"][key] > 0
    assert "frequency" in u["u_input_unmeasured"]
    # the report: a gate row and a finding row each, with their values
    html = (out / "report.html").read_text()
    gate_rows = html.split('<tr class="gate-row">')[1:]
    finding_rows = html.split('<tr class="finding-row">')[1:]
    assert len(gate_rows) == 2 and len(finding_rows) == 1
    shape = next(r for r in gate_rows if "trail_shape_rms_error_m" in r)
    assert fmt(case["gates"][1]["value"]) in shape and "max 5" in shape and ">pass<" in shape
    assert fmt(f["value"]) in finding_rows[0] and "as expected" in finding_rows[0] and "&plusmn; 0.05" in finding_rows[0]
    assert "2 of 2 gates pass; 1 of 1 findings as expected" in html
    assert "Overall: PASS" in html
    assert (out / "report.pdf").read_bytes()[:4] == b"%PDF"
    junit = (out / "junit.xml").read_text()
    assert 'tests="3" failures="0"' in junit
    assert 'classname="trail-mini.findings" name="baseline.drogue_steady_z_error_m"' in junit
    assert list((out / "figures").glob("*.png"))


def test_failing_gate_exits_one_and_names_it(tmp_path):
    res, out = run_validate(tmp_path, 0.001)
    assert res.exit_code == 1
    assert "trail-mini: trail_shape_rms_error_m (baseline)" in res.output
    assert "needs <= 0.001" in res.output
    junit = (out / "junit.xml").read_text()
    assert 'failures="1"' in junit
    assert "Overall: FAIL" in (out / "report.html").read_text()


def test_finding_that_moved_out_of_its_band_exits_one_as_changed(tmp_path):
    # expected 0.5 m away from the measured -0.70 m: the reference model "moved"
    res, out = run_validate(tmp_path, 5.0, z_expected=-0.2)
    assert res.exit_code == 1, res.output
    assert "CHANGED trail-mini: finding drogue_steady_z_error_m (baseline)" in res.output
    assert "expected -0.2 +- 0.05 (changed" in res.output
    (case,) = json.loads((out / "results.json").read_text())["cases"]
    assert all(g["passed"] for g in case["gates"])
    assert case["findings"][0]["status"] == "changed" and not case["passed"]
    junit = (out / "junit.xml").read_text()
    assert 'failures="1"' in junit and 'classname="trail-mini.findings"' in junit


CALIBRATED = """
id = "trail-calibrated"
title = "lift calibrated on one trail, gated on another"
kind = "trail"
logs = ["flight/TR-KDC10-E7.mcap", "flight/TR-KDC10-E11.mcap"]
""" + TRAIL + """
[tow_motion]
kind = "from_log"

[run]
duration_s = 0.5

[[variants]]
id = "calibrated"
calibrate = ["drogue_lift"]
calibrate_on = ["TR-KDC10-E7"]

[[variants]]
id = "wt_lift"
drogue_lift_scale = 1.0

[[gates]]
metric = "trail_shape_rms_error_m"
variant = "calibrated"
max = 1.0
source = "test threshold"
"""


def test_calibrated_variant_is_fitted_on_its_training_log_and_gated_on_the_other(tmp_path):
    # The diagnosis's fit of the lift on E7 (its shape and drogue) must carry to
    # E11, flown at another condition: the held-out shape error falls below the
    # wind-tunnel lift's (which puts the drogue ~2.8 m high, paper Fig. 14).
    case = tmp_path / "cal.toml"
    case.write_text(CALIBRATED)
    out = tmp_path / "out"
    res = CliRunner().invoke(cli, ["validate", str(case), "--out", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    (c,) = json.loads((out / "results.json").read_text())["cases"]
    cal = c["calibrated"]["calibrated"]
    assert cal["on"] == ["TR-KDC10-E7"]
    scale = cal["effects"]["drogue_lift"]["scale"]
    assert 0.0 <= scale < 1.0 and 0.0 < cal["stderr"]["drogue_lift"]["scale"] < 0.5
    assert cal["gap_train"] < 0.5 * cal["gap_before"]
    held = {(r["variant"], r["log"]): r for r in c["runs"]}
    assert not held[("calibrated", "TR-KDC10-E7")]["held_out"] and held[("calibrated", "TR-KDC10-E11")]["held_out"]
    err = {v: held[(v, "TR-KDC10-E11")]["metrics"]["trail_shape_rms_error_m"] for v in ("calibrated", "wt_lift")}
    assert err["calibrated"] < 0.5 * err["wt_lift"]
    assert c["gates"][0]["logs"] == ["TR-KDC10-E11"]
    assert "calibrated on TR-KDC10-E7" in (out / "report.html").read_text()
