"""The exit-code contract of every `workbench` verb (README "Exit status"), the
top-level guard, and the contract between case gates/findings and the metrics
the comparison produces for each case kind."""
from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from flighttest import read_record
from flighttest.compare import compare
from solver.chain import DivergenceError
from solver.statics import StaticSolveError
from tests.workbench.test_validate import CASE, Z_EXPECTED
from workbench.cases import load_case
from workbench.cli import cli
from workbench.errors import EXIT_BAD_INPUT, EXIT_GATE_FAILED, EXIT_INTERNAL, EXIT_NUMERICAL
from workbench.gates import METRICS, WHIP_METRICS

ROOT = Path(__file__).resolve().parents[2]
LOGS = ROOT / "flighttest" / "logs"
DEMO = ROOT / "cases" / "demo" / "kdc10_doublet_demo.toml"

# test_validate's one-trail case (12 elements, assumed constants, half a second), passing
TRAIL = CASE.replace("{shape_max}", "5.0").replace("{z_expected}", str(Z_EXPECTED))


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def case_file(tmp_path, text=TRAIL, old=None, new=None):
    p = tmp_path / "case.toml"
    p.write_text(text if old is None else text.replace(old, new))
    return p


def bad_magic(tmp_path):
    p = tmp_path / "damaged.mcap"
    p.write_bytes(b"not an mcap file at all" * 10)
    return p


# (verb arguments, a pattern the one-line message must contain); {tmp} is the test's folder
BAD_INPUTS = {
    "validate typo'd key": (lambda t: ["validate", case_file(t, old='kind = "trail"', new='knd = "trail"')],
                            "unknown key 'knd'"),
    "validate gate metric not of its kind": (
        lambda t: ["validate", case_file(t, old='"drogue_steady_x_error_m"', new='"wave_speed_error_pct"')],
        "[[gates]] metric 'wave_speed_error_pct' is not a trail metric"),
    "validate gate metric misspelt": (
        lambda t: ["validate", case_file(t, old='"drogue_steady_x_error_m"', new='"drogue_stedy_x_error_m"')],
        "metric 'drogue_stedy_x_error_m' is not a trail metric"),
    "validate finding without band": (
        lambda t: ["validate", case_file(t, TRAIL + '[[findings]]\nmetric = "trail_shape_rms_error_m"\n'
                                         'expected = 0.3\nsource = "s"\nband_source = "b"\n')],
        "[findings] missing required key 'band'"),
    "validate finding on unknown variant": (
        lambda t: ["validate", case_file(t, TRAIL + '[[findings]]\nmetric = "trail_shape_rms_error_m"\n'
                                         'variant = "no_lift"\nexpected = 0.3\nband = 0.1\nsource = "s"\n'
                                         'band_source = "b"\n')],
        "names unknown variant 'no_lift'"),
    "validate nonexistent case file": (lambda t: ["validate", t / "nope.toml"], "nope.toml: no such case file"),
    "validate unknown case name": (lambda t: ["validate", "no_such_case"],
                                   "no_such_case: no such case file (nor cases/no_such_case.toml)"),
    "run typo'd key": (lambda t: ["run", case_file(t, old="[run]", new="[runn]")], "unknown table [runn]"),
    "run nonexistent case": (lambda t: ["run", t / "nope.toml"], "case file not found"),
    "run unknown effect": (lambda t: ["run", DEMO, "--effect", "nope", "--out", t], "--effect nope: unknown effect"),
    "logs damaged log": (lambda t: ["logs", "inspect", bad_magic(t)], "not an MCAP file"),
    "diagnose damaged log": (lambda t: ["diagnose", bad_magic(t), "--out", t / "d"], "not an MCAP file"),
    "diagnose no logs": (lambda t: ["diagnose", "--out", t / "d"], "give one or more LOG.mcap files"),
    "properties unknown hose": (lambda t: ["properties", "lookup", "nohose", "70", "0.5"], "nohose"),
}


@pytest.mark.parametrize("name", BAD_INPUTS)
def test_bad_input_exits_two_with_one_line(tmp_path, name):
    args, pattern = BAD_INPUTS[name]
    res = invoke(*args(tmp_path))
    assert res.exit_code == EXIT_BAD_INPUT, res.output
    assert "Traceback" not in res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    assert pattern in lines[0]


@pytest.mark.parametrize("args", [
    ["validate", "--workers", "0", "all"],
    ["run", DEMO, "--duration", "soon"],
    ["properties", "build", "--element-counts", "8,x"],
    ["logs", "inspect", "/nonexistent/x.mcap"],
    ["no-such-verb"],
])
def test_cli_usage_errors_exit_two_naming_the_option(args):
    res = invoke(*args)
    assert res.exit_code == EXIT_BAD_INPUT, res.output
    assert "Traceback" not in res.output and "Error:" in res.output


def _diverge(*_args, **_kwargs):
    raise DivergenceError("simulation diverged at t=1.2340 s: non-finite position first at node 7 "
                          "(element 7 of 12)")


def test_run_numerical_failure_exits_three_naming_time_and_element(monkeypatch, tmp_path):
    monkeypatch.setattr("workbench.simulate.simulate", _diverge)
    res = invoke("run", DEMO, "--out", tmp_path)
    assert res.exit_code == EXIT_NUMERICAL, res.output
    (line,) = res.output.strip().splitlines()
    assert line.startswith(f"workbench: numerical failure: {DEMO}: simulation diverged at t=1.2340 s")
    assert "element 7" in line


def test_run_static_failure_exits_three(monkeypatch, tmp_path):
    def stall(*_a, **_k):
        raise StaticSolveError("static solve stalled at iteration 12: residual 3.1 N (tolerance 0.01 N)")
    monkeypatch.setattr("workbench.simulate.solve_static", stall)
    res = invoke("run", DEMO, "--out", tmp_path)
    assert res.exit_code == EXIT_NUMERICAL, res.output
    assert "numerical failure" in res.output and "static solve stalled" in res.output


def test_validate_numerical_failure_exits_three(monkeypatch, tmp_path):
    monkeypatch.setattr("workbench.simulate.simulate", _diverge)
    out = tmp_path / "out"
    res = invoke("validate", case_file(tmp_path), "--out", out, "--no-progress", "--workers", "1")
    assert res.exit_code == EXIT_NUMERICAL, res.output
    assert "ERROR trail-mini: did not run: variant baseline, TR-KDC10-E7.mcap: simulation diverged at t=1.2340 s" \
        in res.output
    (case,) = json.loads((out / "results.json").read_text())["cases"]
    assert case["error_code"] == EXIT_NUMERICAL and not case["passed"]


def test_validate_gate_failure_exits_one(tmp_path):
    res = invoke("validate", case_file(tmp_path, old="max = 1.0", new="max = 0.001"), "--out", tmp_path / "o",
                 "--no-progress")
    assert res.exit_code == EXIT_GATE_FAILED, res.output
    assert "FAIL trail-mini: drogue_steady_x_error_m (baseline)" in res.output


def test_unexpected_exception_is_one_line_with_the_traceback_in_a_file(monkeypatch, tmp_path):
    def boom(*_a, **_k):
        raise KeyError("a defect\nover two lines")
    monkeypatch.setattr("workbench.case_run.run_case", boom)
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    res = invoke("run", DEMO)
    assert res.exit_code == EXIT_INTERNAL
    (line,) = res.output.strip().splitlines()
    assert line.startswith("workbench: internal error: KeyError: ")
    log = Path(line.rsplit("(traceback in ", 1)[1].rstrip(")"))
    assert log.parent == tmp_path
    text = log.read_text()
    assert text.startswith("Traceback") and "in boom" in text


@pytest.mark.parametrize("flag", ["-h", "--help"])
def test_help_documents_the_exit_codes(flag):
    res = invoke(flag)
    assert res.exit_code == 0
    for code, words in [(0, "success"), (1, "a gate failed"), (2, "bad input"), (3, "numerical failure"),
                        (4, "internal error")]:
        assert f"  {code}  " in res.output and words in res.output
    assert invoke("validate", flag).exit_code == 0


def test_python_m_workbench_is_the_command_and_keeps_the_codes(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    ok = subprocess.run([sys.executable, "-m", "workbench", "-h"], capture_output=True, text=True, env=env)
    assert ok.returncode == 0 and "Exit status of every command" in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "workbench", "logs", "analyze", str(bad_magic(tmp_path))],
                         capture_output=True, text=True, env=env)
    assert bad.returncode == EXIT_BAD_INPUT
    assert bad.stdout == "" and len(bad.stderr.strip().splitlines()) == 1 and "not an MCAP file" in bad.stderr


# ---- contract: what a case may gate is what its kind's comparison produces --------------------

LOG_OF_KIND = {"pitch_doublet": "flight/PD-G3-1.mcap", "trail": "flight/TR-KDC10-E7.mcap",
               "engagement": "flight/EN-KDC10-E7.mcap"}


@pytest.mark.parametrize("kind", sorted(LOG_OF_KIND))
def test_every_metric_named_for_a_flight_kind_is_produced_by_its_comparison(kind):
    # a log compared with itself: the comparison's keys, all finite
    rec = read_record(LOGS / LOG_OF_KIND[kind])
    assert rec.info.test_kind == kind
    metrics = compare(rec, rec).metrics
    for name in METRICS[kind] - WHIP_METRICS:
        assert isinstance(metrics.get(name), float) and math.isfinite(metrics[name]), name
    # the errors of a record against itself vanish, the trail's mean-shape error too
    for name in METRICS[kind]:
        if name.endswith(("_error_pct", "_error_m")) and name.startswith(("drogue_", "shape_", "wave_", "trail_")):
            assert metrics[name] == pytest.approx(0.0, abs=1e-12), name


def test_every_ringdown_metric_is_a_verification_row_field():
    doc = json.loads((ROOT / "cases" / "properties" / "hose_properties.json").read_text())
    for row in doc["verification"]:
        for name in METRICS["ringdown_bending"]:
            assert math.isfinite(row[name]), name


@pytest.mark.parametrize("path", sorted((ROOT / "cases").glob("*.toml")), ids=lambda p: p.stem)
def test_every_gate_and_finding_of_the_committed_cases_names_a_metric_of_its_kind(path):
    case = load_case(path)
    for check in case["gates"] + case["findings"]:
        assert check["metric"] in METRICS[case.kind], check["metric"]
    for f in case["findings"]:
        # findings are about the reference models, never the diagnosed ones
        assert f["variant"] in ("no_lift", "wt_lift", "tuned_lift"), f
        assert f["band"] > 0 and f["source"].startswith("paper") and f["band_source"]
    for g in case["gates"]:
        # gates hold the product's model or a diagnosed one (the diagnosis's set, calibrated
        # on some logs: `diagnosed`, or `diagnosed_<log>` for one left out), never a reference model
        assert g["variant"] in (None, "diagnosed") or g["variant"].startswith("diagnosed_"), g


def test_every_engagement_metric_with_the_hose_whip_is_produced_by_a_validate_run(tmp_path):
    # the committed engagement case, one log, 12 elements, no variants: its one run's metrics
    from workbench.validation import validate_cases
    src = (ROOT / "cases" / "kdc10_engagement7.toml").read_text()
    src = src[:src.index("[[variants]]")].replace("n_elements = 40", "n_elements = 12")
    src = re.sub(r"(?m)^logs = .*$", 'logs = ["flight/EN-KDC10-E7.mcap"]', src)
    (oc,) = validate_cases([case_file(tmp_path, src)], workers=1)
    assert oc.error is None, oc.error
    (run,) = oc.runs
    for name in METRICS["engagement"]:
        assert isinstance(run.metrics.get(name), float) and math.isfinite(run.metrics[name]), name
