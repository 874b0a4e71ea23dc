"""Effects in case files and on the command line: [effects.NAME] tables and
`workbench run CASE --effect NAME:param=value`, checked with one-line errors."""
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from solver import wind as W
from solver.statics import solve_static
from workbench.cases import build_model, load_case
from workbench.cli import cli
from workbench.effects_case import parse_effect_options, with_effects
from workbench.effects_compare import apply_comparison_effects, shift_series, with_tracker_delay
from workbench.errors import InputError
from tests.workbench import assert_case_refused

ROOT = Path(__file__).resolve().parents[2]
DEMO = ROOT / "cases" / "demo" / "kdc10_doublet_demo.toml"


def with_text(tmp_path, extra, drop=None):
    text = DEMO.read_text()
    if drop:
        assert drop in text
        text = text.replace(drop, "")
    p = tmp_path / "case.toml"
    p.write_text(text + "\n" + extra)
    return p


def test_case_turns_effects_on_by_name_and_they_compose(tmp_path):
    p = with_text(tmp_path, """
[effects.tanker_wake]
strength = 1.0

[effects.steady_wind]
vertical_mps = 2.0

[effects.drogue_drag]
scale = 1.2
""")
    case = load_case(p)
    assert case["effects"]["tanker_wake"]["core_radius_m"] == 1.0      # default filled in
    m = build_model(case)
    assert m.wind.kinds() == [W.UNIFORM, W.UNIFORM, W.VORTEX_WAKE]
    assert m.drogue.drag_scale == pytest.approx(1.2)
    base = build_model(load_case(DEMO))
    assert base.wind.kinds() == [W.UNIFORM]                             # off by default
    # the updraft lifts the drogue, the wake's downwash and sidewash push it down
    # and outboard: together, outboard and less far down than the wake alone
    d0 = solve_static(base).pos[-1]
    d_all = solve_static(m).pos[-1] - d0
    wake_only = with_effects(load_case(DEMO), {"tanker_wake": {}})
    d_wake = solve_static(build_model(wake_only)).pos[-1] - d0
    assert d_all[1] > 0.3 and d_wake[1] > 0.3
    assert d_wake[2] < d_all[2]


@pytest.mark.parametrize("extra,pattern", [
    ("[effects.tanker_wak]\nstrength = 1.0\n", r"\[effects\] unknown effect 'tanker_wak' \(known: .*tanker_wake"),
    ("[effects.tanker_wake]\nstrenght = 1.0\n", r"\[effects.tanker_wake\] strenght unknown parameter"),
    ("[effects.tanker_wake]\nstrength = 7.0\n", r"\[effects.tanker_wake\] strength must lie in 0..3, got 7"),
    ("[effects.turbulence]\nseed = 1.5\n", r"\[effects.turbulence\] seed must be an integer"),
    ("[effects.gust]\nlength_m = \"long\"\n", r"\[effects.gust\] length_m must be a number"),
    ("[effects]\nturbulence = 3\n", r"\[effects\] turbulence must be a table"),
    ("[effects.reel_lag]\n", r"\[effects.reel_lag\] needs the drum reel mode"),
])
def test_bad_effects_give_one_line_errors_naming_file_table_key(tmp_path, extra, pattern):
    assert_case_refused(with_text(tmp_path, extra), pattern)


def test_tanker_wake_needs_the_weight_and_the_data_sheet(tmp_path):
    p = with_text(tmp_path, "[effects.tanker_wake]\n",
                  drop="tanker_gross_weight_lb = 410000   # engagement 7 test card (tanker wake effect)\n")
    with pytest.raises(InputError, match=r"\[effects.tanker_wake\] needs \[condition\] tanker_gross_weight_lb"):
        build_model(load_case(p))
    p = with_text(tmp_path, "[effects.tanker_wake]\n", drop='tanker = "kdc10"\n')
    with pytest.raises(InputError, match=r"\[effects.tanker_wake\] needs \[hardware\] tanker"):
        build_model(load_case(p))


def test_effect_options_parse_and_override_the_case(tmp_path):
    assert parse_effect_options(["tanker_wake:strength=1.2,vertical_offset_m=-0.5", "turbulence",
                                 "turbulence:seed=7"]) == {
        "tanker_wake": {"strength": 1.2, "vertical_offset_m": -0.5}, "turbulence": {"seed": 7}}
    case = load_case(with_text(tmp_path, "[effects.tanker_wake]\nstrength = 1.0\n"))
    c2 = with_effects(case, {"tanker_wake": {"strength": 1.5}})
    assert c2["effects"]["tanker_wake"]["strength"] == 1.5
    assert case["effects"]["tanker_wake"]["strength"] == 1.0           # the case itself is untouched
    with pytest.raises(InputError, match=r"--effect tanker_wake:strength: must lie in 0..3"):
        with_effects(case, {"tanker_wake": {"strength": 9.0}})
    for bad in ("tanker_wake:strength", "tanker_wake:strength=abc", ":x=1"):
        with pytest.raises(InputError, match=r"--effect"):
            parse_effect_options([bad])


def test_cli_run_with_effects(tmp_path):
    res = CliRunner().invoke(cli, ["run", str(DEMO), "--out", str(tmp_path), "--duration", "1",
                                   "--effect", "tanker_wake:strength=1.2", "--effect", "gust:start_s=0.2"])
    assert res.exit_code == 0, res.output
    assert "effect tanker_wake: strength=1.2" in res.output
    s = json.loads((tmp_path / "kdc10-doublet-demo" / "summary.json").read_text())
    assert s["end_static_y_m"] > 0.3                                    # the wake's sidewash
    bad = CliRunner().invoke(cli, ["run", str(DEMO), "--effect", "tanker_wake:strength=9"])
    assert bad.exit_code != 0
    assert "must lie in 0..3" in bad.output and "Traceback" not in bad.output


def test_sensor_lag_shifts_the_tracker_channel():
    # A tracker that reports `delay` late: reading it at t + delay recovers the
    # signal (exact on a sine away from the ends, up to linear interpolation:
    # (2 pi f dt)^2 / 8 = 2e-4 of the amplitude at 0.4 Hz sampled at 30 Hz).
    t = np.arange(0, 20, 1 / 30)
    f, delay = 0.4, 0.2
    truth = np.sin(2 * np.pi * f * t)
    tracker = np.sin(2 * np.pi * f * (t - delay))
    fixed = shift_series(t, tracker, delay)
    inner = t < t[-1] - delay
    assert np.max(np.abs(fixed[inner] - truth[inner])) < 3e-4

    import pandas as pd
    from flighttest import FlightRecord
    from flighttest.schema import TestInfo
    info = TestInfo.__new__(TestInfo)
    ors = pd.DataFrame({"x_m": truth, "valid": True}, index=pd.Index(t, name="t_s"))
    tow = pd.DataFrame({"z_m": truth}, index=pd.Index(t, name="t_s"))
    rec = FlightRecord(info=info, topics={"/ors/drogue": ors, "/tanker/tow_point": tow}, start_time_ns=0)
    r2 = apply_comparison_effects(rec, {"sensor_lag": {"delay_s": delay}})
    assert np.allclose(r2.topics["/ors/drogue"].index.to_numpy(), t - delay)
    assert r2.topics["/tanker/tow_point"] is tow
    assert with_tracker_delay(rec, 0.0) is rec


def test_the_tracked_drogue_point_corrects_the_log_not_the_model():
    """drogue_reference: a tracker whose target lies offset_m aft of the model's
    drogue centre; the comparison moves the logged fixes forward by it (and the
    residual takes it off the fixes the same way, tests/flighttest/test_residual.py)."""
    from flighttest import read_record
    from solver.effects import validate_effects
    rec = read_record(Path(__file__).resolve().parents[2] / "flighttest" / "logs" / "flight" / "PD-G3-1.mcap")
    out = apply_comparison_effects(rec, validate_effects({"drogue_reference": {"offset_m": -0.2}}))
    a, b = rec.topic("/ors/drogue"), out.topic("/ors/drogue")
    np.testing.assert_allclose((b["x_m"] - a["x_m"]).dropna(), 0.2, atol=1e-12)
    np.testing.assert_array_equal(b[["y_m", "z_m"]].to_numpy(), a[["y_m", "z_m"]].to_numpy())
    assert out.topic("/tanker/tow_point") is rec.topic("/tanker/tow_point")
