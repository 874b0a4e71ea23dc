"""The interfaces of issue 15 item 6: `run --log`, Foxglove MCAPs (`run --mcap`,
`compare`), the hose animation, `logs inspect --json`, default output folders
and the Python API (`import workbench`)."""
from __future__ import annotations

import dataclasses
import json
import re

import matplotlib
import numpy as np
import pytest
from click.testing import CliRunner
from mcap.reader import make_reader

import workbench
from flighttest import read_record
from tests.workbench.test_cli import DEMO, LOGS, ROOT, TRAIL
from workbench.cli import cli
from workbench.errors import EXIT_BAD_INPUT, InputError
from workbench.case_run import check_log_fits

matplotlib.use("Agg")

TRAIL_LOG = LOGS / "flight" / "TR-KDC10-E7.mcap"
ENGAGEMENT_LOG = LOGS / "flight" / "EN-KDC10-E7.mcap"
ENGAGEMENT_CASE = ROOT / "cases" / "kdc10_engagement7.toml"
FOXGLOVE_SCHEMAS = {"foxglove.SceneUpdate", "foxglove.FrameTransform"}


def invoke(*args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def mcap_messages(path) -> tuple[dict, dict, list]:
    """{topic: (schema name, schema encoding, message encoding)}, {topic: [(log_time, message)]},
    metadata names; every schema checked to be the jsonschema its name says."""
    channels, messages = {}, {}
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        metadata = [m.name for m in reader.iter_metadata()]
        for schema, channel, message in reader.iter_messages():
            doc = json.loads(schema.data)
            assert doc["title"] == schema.name
            channels[channel.topic] = (schema.name, schema.encoding, channel.message_encoding)
            messages.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    return channels, messages, metadata


# ---------------------------------------------------------------- run --log

def test_log_driven_case_without_a_log_names_the_option():
    res = invoke("run", ENGAGEMENT_CASE)
    assert res.exit_code == EXIT_BAD_INPUT
    assert "--log" in res.output and "Traceback" not in res.output


def test_run_refuses_a_log_of_another_kind():
    res = invoke("run", ENGAGEMENT_CASE, "--log", TRAIL_LOG)
    assert res.exit_code == EXIT_BAD_INPUT
    assert "test_kind 'trail' is not the kind 'engagement'" in res.output


def test_run_refuses_a_log_of_other_hardware():
    case = workbench.load_case(ROOT / "cases" / "kdc10_trail.toml")
    other = dataclasses.replace(case, tables={**case.tables, "hardware": {**case["hardware"], "drogue": "fa18_buddy"}})
    with pytest.raises(InputError, match="\\[hardware\\] drogue 'fa18_buddy' differs from the log's drogue 'kdc10_pod'"):
        check_log_fits(other, read_record(TRAIL_LOG))


def test_run_against_a_log_writes_its_folder(tmp_path):
    case = tmp_path / "case.toml"
    case.write_text(TRAIL)
    res = invoke("run", case, "--log", TRAIL_LOG, "--out", tmp_path / "out")
    assert res.exit_code == 0, res.output
    assert "against TR-KDC10-E7" in res.output
    summary = json.loads((tmp_path / "out" / "trail-mini" / "summary.json").read_text())
    assert summary["log"] == "TR-KDC10-E7"
    # the log's time base: the run starts where the log's tow-point channel does
    assert summary["simulated_s"] == pytest.approx(0.5, abs=0.011)   # [run] duration_s, to a record step


def test_run_writes_into_its_own_folder_by_default(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = invoke("run", DEMO, "--duration", "0.1")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "reports" / "run" / "kdc10-doublet-demo" / "summary.json").is_file()
    assert not (tmp_path / "reports" / "out").exists()      # the validation report's folder is left alone


# ---------------------------------------------------------------- Foxglove

def test_run_mcap_draws_the_hose_in_3d(tmp_path):
    """A sidewind moves the hose sideways: every hose line in the scene has y != 0
    (the contract's /video/hose is a side view; the scene is the run's 3-D hose)."""
    path = tmp_path / "demo.mcap"
    res = invoke("run", DEMO, "--duration", "0.3", "--effect", "steady_wind:lateral_mps=3", "--out",
                 tmp_path / "out", "--mcap", path)
    assert res.exit_code == 0, res.output
    channels, messages, metadata = mcap_messages(path)
    assert metadata == ["test"]
    for topic, (schema, encoding, msg_encoding) in channels.items():
        assert encoding == "jsonschema" and msg_encoding == "json"
        assert (schema in FOXGLOVE_SCHEMAS) == topic.startswith("/foxglove/")
    assert channels["/foxglove/tf"][0] == "foxglove.FrameTransform"
    for topic in ("/foxglove/hose", "/foxglove/drogue", "/foxglove/tow_point", "/foxglove/tow_force",
                  "/foxglove/probe_force"):
        assert channels[topic][0] == "foxglove.SceneUpdate", topic
    hose = messages["/foxglove/hose"]
    tow_ns = [ns for ns, _ in messages["/tanker/tow_point"]]         # every record of the run
    assert len(hose) == int((tow_ns[-1] - tow_ns[0]) * 30e-9 + 1e-6) + 1   # at the tracker's 30 Hz
    for _, msg in hose:
        (entity,) = msg["entities"]
        assert entity["frame_id"] == "tanker"
        (line,) = entity["lines"]
        y = np.array([p["y"] for p in line["points"]])
        assert len(y) == 41 and y[0] == 0.0                  # 40 elements, tow point first
        assert np.abs(y[1:]).min() > 0.0 and np.abs(y).max() > 0.1
    # the tow force arrow: a few kN, pointing aft (+x) from the tow point, 1 m per kN
    (arrow,) = messages["/foxglove/tow_force"][0][1]["entities"][0]["arrows"]
    assert 2.0 < arrow["shaft_length"] < 6.0
    q = arrow["pose"]["orientation"]
    x_axis_x = 1 - 2 * (q["y"] ** 2 + q["z"] ** 2)           # the arrow's axis, x component
    assert x_axis_x > 0.9
    # no probe in a doublet: the probe-force entity draws nothing
    assert all(m["entities"][0]["arrows"] == [] for _, m in messages["/foxglove/probe_force"])
    # the contract topics are there and read back
    assert {"/tanker/tow_point", "/ors/drogue"} <= set(channels)


def test_compare_puts_log_and_simulation_on_one_time_base(tmp_path):
    path = tmp_path / "cmp.mcap"
    res = invoke("compare", ENGAGEMENT_LOG, "--mcap", path, "--duration", "0.5")
    assert res.exit_code == 0, res.output
    assert "case kdc10-engagement-7" in res.output            # the case in cases/ that lists the log
    channels, messages, metadata = mcap_messages(path)
    assert sorted(metadata) == ["test/log", "test/sim"]
    for side in ("/log", "/sim"):
        assert channels[f"{side}/foxglove/hose"][0] == "foxglove.SceneUpdate"
        assert channels[f"{side}/foxglove/tf"][0] == "foxglove.FrameTransform"
        assert channels[f"{side}/tanker/tow_point"][0] == "flight.TowPoint"
    rec = read_record(ENGAGEMENT_LOG)
    t_tow = rec.topics["/tanker/tow_point"].index.to_numpy(float)
    # both sides start with the log's first tow-point sample, in the log's own clock
    first = {side: messages[f"{side}/foxglove/tf"][0][0] for side in ("/log", "/sim")}
    assert first["/log"] == first["/sim"] == rec.start_time_ns + int(round(t_tow[0] * 1e9))
    tf = messages["/sim/foxglove/tf"][0][1]
    assert (tf["parent_frame_id"], tf["child_frame_id"]) == ("tanker", "sim/tow_point")
    assert len(messages["/log/foxglove/hose"]) == rec.topics["/video/hose"]["t_s"].nunique()


def test_compare_refuses_a_case_of_another_kind(tmp_path):
    res = invoke("compare", ENGAGEMENT_LOG, "--mcap", tmp_path / "x.mcap", "--case", "kdc10_trail")
    assert res.exit_code == EXIT_BAD_INPUT
    assert not (tmp_path / "x.mcap").exists()


def test_animation_has_a_frame_per_video_frame(tmp_path):
    from PIL import Image
    gif = tmp_path / "hose.gif"
    out = workbench.run(ENGAGEMENT_CASE, log=ENGAGEMENT_LOG, duration=0.5)
    from workbench.animate import animate
    animate(out.result, gif, record=out.record, title="E7")
    video_t = np.unique(out.record.topics["/video/hose"]["t_s"])
    inside = ((video_t >= out.result.t[0]) & (video_t <= out.result.t[-1])).sum()
    assert inside >= 4                                       # 0.5 s of 10 Hz video
    with Image.open(gif) as im:
        assert im.n_frames == inside and im.size == (800, 600)


# ---------------------------------------------------------------- logs inspect --json

def test_logs_inspect_json_carries_what_the_text_says():
    text = invoke("logs", "inspect", ENGAGEMENT_LOG).output
    res = invoke("logs", "inspect", "--json", ENGAGEMENT_LOG)
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)["EN-KDC10-E7.mcap"]
    assert doc["test_kind"] == "engagement" and doc["metadata"]["engagement"] == "7"
    for topic, st in doc["topics"].items():
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(topic + " "))
        assert int(re.search(r"(\d+) msgs", line).group(1)) == st["messages"]
    assert [e["event"] for e in doc["topics"]["/probe/events"]["events"]] == ["contact", "disconnect"]
    d = doc["topics"]["/ors/drogue"]["dropouts"]
    assert f"dropouts {d['samples']} ({100 * d['share']:.1f} %)" in text


# ---------------------------------------------------------------- Python API

def test_python_api_run_to_pandas_and_plot():
    from matplotlib.figure import Figure
    out = workbench.run(DEMO, duration=0.2)
    df = out.to_pandas()
    assert df.shape == (len(out.result.t), 16) and df.index.name == "t_s"
    assert len(out.result.t) >= 20                           # 0.2 s at the case's record_dt 0.01 s
    assert isinstance(out.plot(), Figure)


def test_python_api_validate_gives_outcomes_with_frames_and_figures(tmp_path):
    from matplotlib.figure import Figure
    case = tmp_path / "trail_mini.toml"
    from tests.workbench.test_cli import TRAIL as text
    case.write_text(text)
    (outcome,) = workbench.validate([case], workers=1)
    assert outcome.passed
    df = outcome.to_pandas()
    assert df.shape[0] == 1 and {"variant", "log", "drogue_steady_x_error_m"} <= set(df.columns)
    assert isinstance(outcome.plot(), Figure)


def test_diagnosis_plot_has_a_panel_per_family():
    from matplotlib.figure import Figure
    from workbench.diagnosis import Candidate, Diagnosis, FamilyDiagnosis
    fams = {}
    for name in ("trail/kdc10/kdc10_pod", "pitch_doublet/g3/fa18_buddy"):
        ranking = [Candidate("tanker_wake", ["tanker_wake"], 1, gap_after_heldout=0.1),
                   Candidate("none", [], 0, gap_after_heldout=1.6)]
        fams[name] = FamilyDiagnosis(name, name.split("/")[0], [], 20, "", 1.6, 0.01, True, "", {}, {},
                                     ranking, [], {}, {}, {}, 1.0)
    diag = Diagnosis([], fams, [], "local", {}, 2.0, 0.05, 4)
    fig = diag.plot()
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    assert diag.to_pandas().shape[0] == 4
