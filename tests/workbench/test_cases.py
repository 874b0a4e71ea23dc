"""Case files: checked at the edge, one-line errors, and the `workbench run` verb."""
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from flighttest import read_record
from workbench.cases import build_model, case_log_paths, load_case
from workbench.cli import cli
from workbench.hardware import load_hardware
from workbench.properties.store import load_library
from tests.workbench import assert_case_refused

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "cases" / "demo" / "kdc10_doublet_demo.toml"


def edited(tmp_path, old, new):
    text = DEMO.read_text()
    assert old in text
    p = tmp_path / "case.toml"
    p.write_text(text.replace(old, new))
    return p


def test_every_case_file_loads_and_builds():
    hw = load_hardware()
    files = sorted((ROOT / "cases").glob("*.toml")) + sorted((ROOT / "cases" / "demo").glob("*.toml"))
    assert files
    for f in files:
        case = load_case(f)
        logs = case_log_paths(case)
        for p in logs:
            assert p.exists(), p
        if case.kind.startswith("ringdown"):
            # bench cases model the rig from the property pipeline, not build_model
            assert case["hardware"]["hose"] in load_library().hoses
            continue
        record = read_record(logs[0]) if logs else None
        model = build_model(case, hw, record=record)
        assert model.n_elements >= 4


def test_demo_case_builds_the_data_sheet_hose():
    m = build_model(load_case(DEMO))
    # 75 ft; 2.2 kg/m dry plus JP-5 in a 44.5 mm bore
    assert m.hose.length == pytest.approx(75 * 0.3048)
    assert m.hose.mass_per_length == pytest.approx(2.2 + 810 * 3.14159265 * 0.0445 ** 2 / 4, rel=1e-6)
    assert m.drogue.lift_area == 0.0
    # 254 KCAS at 15050 ft is about 316 KTAS
    assert m.wind.mean_speed == pytest.approx(162.6, abs=0.5)


@pytest.mark.parametrize("old,new,pattern", [
    ("n_elements = 40", "n_elements = 2", r"\[model\] n_elements must lie in 4\.\.200, got 2"),
    ("n_elements = 40", "n_elements = 40.5", r"\[model\] n_elements must be an integer"),
    ("n_elements = 40", "n_elments = 40", r"\[model\] unknown key 'n_elments'"),
    ('hose_fuel = "full"', 'hose_fuel = "half"', r"\[condition\] hose_fuel must be one of"),
    ('hose = "kdc10_pod"', 'hose = "nope"', r"no hose 'nope' \(known: .*kdc10_pod"),
    ("EI_N_m2 = 50.0", "EI_N_m2 = -5.0", r"\[model.structure\] EI_N_m2 must lie in \[0.1, 100000\]"),
    ("EI_N_m2 = 50.0", "EI_N_m2 = nan", r"EI_N_m2 must (be finite|be positive)"),
    ("[run]", "[runn]", r"unknown table \[runn\]"),
    ('kind = "pitch_doublet"', 'kind = "loop"', r"kind must be one of"),
    ("altitude_ft = 15050", "altitude_ft = true", r"\[condition\] altitude_ft must be a number"),
    ("[tow_motion]", "[tow_motion\n", r"not valid TOML"),
    ("[run]", '[[variants]]\nid = "c"\ncalibrate = ["turbulence"]\ncalibrate_on = ["X"]\n\n[run]',
     r"\[\[variants\]\] 'c' calibrate: effect 'turbulence' cannot be calibrated \(a random field"),
    ("[run]", '[[variants]]\nid = "c"\ncalibrate = ["gust"]\ncalibrate_on = ["X"]\n\n[run]',
     r"'c' calibrate: effect 'gust' cannot be calibrated \(a transient at one log's own time"),
    ("[run]", '[[variants]]\nid = "c"\ncalibrate = ["drogue_lift"]\n\n[run]',
     r"'c' needs both calibrate \(effects\) and calibrate_on"),
])
def test_bad_case_gives_one_line_error(tmp_path, old, new, pattern):
    assert_case_refused(edited(tmp_path, old, new), pattern)


def test_cli_run_writes_outputs(tmp_path):
    res = CliRunner().invoke(cli, ["run", str(DEMO), "--out", str(tmp_path), "--duration", "2"])
    assert res.exit_code == 0, res.output
    assert "real time" in res.output
    summary = json.loads((tmp_path / "kdc10-doublet-demo" / "summary.json").read_text())
    assert summary["simulated_s"] == pytest.approx(2.0, abs=0.02)
    assert summary["end_static_x_m"] > 20
    assert (tmp_path / "kdc10-doublet-demo" / "timeseries.csv").stat().st_size > 1000


def test_cli_run_bad_case_is_one_line_no_traceback(tmp_path):
    p = edited(tmp_path, "n_elements = 40", "n_elements = 1000")
    res = CliRunner().invoke(cli, ["run", str(p)])
    assert res.exit_code != 0
    assert "Traceback" not in res.output
    assert res.output.strip().count("\n") == 0
    assert "n_elements must lie in 4..200" in res.output
