"""`workbench logs inspect|analyze`: output on good logs, one-line errors on bad ones."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

sys.path.insert(0, str(Path(__file__).parent))
import make_corrupt as MC  # noqa: E402

from workbench.cli import cli  # noqa: E402

LOGS = Path(__file__).resolve().parents[2] / "flighttest" / "logs"
ALL_LOGS = sorted(LOGS.glob("*/*.mcap"))


def run(*args):
    return CliRunner().invoke(cli, ["logs", *map(str, args)])


def test_inspect_every_log():
    res = run("inspect", *ALL_LOGS)
    assert res.exit_code == 0, res.output
    for path in ALL_LOGS:
        assert f"{path.name}: test {path.stem}  kind " in res.output
    assert res.output.count("  metadata:") == len(ALL_LOGS)


def test_inspect_reports_rates_gaps_and_dropouts():
    res = run("inspect", LOGS / "flight" / "EN-KDC10-E7.mcap")
    assert res.exit_code == 0
    lines = {ln.split()[0]: ln for ln in res.output.splitlines() if ln.strip().startswith("/")}
    assert "30.00 Hz" in lines["/ors/drogue"]
    assert "dropouts " in lines["/ors/drogue"] and "%" in lines["/ors/drogue"]
    assert "100.00 Hz" in lines["/tanker/tow_point"]
    assert "gaps 0" in lines["/reel/hose_out"]
    assert "contact at" in lines["/probe/events"] and "disconnect at" in lines["/probe/events"]
    assert "points/frame" in lines["/video/hose"]
    assert "    altitude_ft = 15050" in res.output


def test_analyze_json_one_object_per_file():
    files = [LOGS / "ringdown" / "RD-FA18-A-70F-r1.mcap", LOGS / "flight" / "TR-KDC10-E9.mcap"]
    res = run("analyze", "--json", *files)
    assert res.exit_code == 0, res.output
    objs = [json.loads(line) for line in res.output.splitlines()]
    assert [list(o) for o in objs] == [[f.name] for f in files]
    axial = objs[0][files[0].name]
    assert axial["test_kind"] == "ringdown_axial" and axial["axial_frequency_hz"] > 0
    trail = objs[1][files[1].name]
    assert len(trail["hose_shape"]["x_m"]) == len(trail["hose_shape"]["z_m"]) > 5


def test_analyze_text():
    res = run("analyze", LOGS / "flight" / "EN-KDC10-E11.mcap")
    assert res.exit_code == 0, res.output
    assert "  reel_delay_s = " in res.output and "  wave_speed_mps = " in res.output


@pytest.mark.parametrize("case", ["bad_magic", "truncated_mid_chunk", "missing_hose", "nan_literal",
                                  "missing_video_topic", "time_backwards"])
@pytest.mark.parametrize("verb", ["inspect", "analyze"])
def test_bad_input_is_one_line_error(tmp_path, case, verb):
    builder, regex = MC.CASES[case]
    path = tmp_path / f"{case}.mcap"
    path.write_bytes(builder())
    res = run(verb, path)
    assert res.exit_code == 2   # bad input (README "Exit status")
    assert "Traceback" not in res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"Error: {path}: ")
    assert __import__("re").search(regex, lines[0])


def test_missing_file_is_one_line_error(tmp_path):
    res = run("inspect", tmp_path / "nope.mcap")
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert len(res.output.strip().splitlines()) == 1


def test_recording_without_summary(tmp_path):
    buf = MC.build(messages=MC.bending_messages(400))
    data_end = next(off for op, off, _ in MC.records(buf) if op == 0x0F)
    path = tmp_path / "stopped.mcap"
    path.write_bytes(buf[:data_end])        # recording stopped before its summary
    res = run("inspect", path)
    assert res.exit_code == 0, res.output
    assert "summary no (data section scanned)" in res.output


def test_salvage_flag(tmp_path):
    buf = MC.build(messages=MC.bending_messages(5000))
    chunks = [off for op, off, _ in MC.records(buf) if op == 0x06]
    assert len(chunks) >= 2
    path = tmp_path / "cut.mcap"
    path.write_bytes(buf[:chunks[-1] + 50])  # cut inside the last chunk
    refused = run("inspect", path)
    assert refused.exit_code == 2 and "file truncated or damaged" in refused.output
    salvaged = run("inspect", "--salvage", path)
    assert salvaged.exit_code == 0, salvaged.output
    assert "/rig/accel/tip" in salvaged.output
