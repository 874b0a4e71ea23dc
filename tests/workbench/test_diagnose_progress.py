"""`workbench diagnose` runs inside the one progress display: a step per stage
the diagnosis reports (per log in the selftest), the report writing a step
too, and a final line with the total wall time; `--quiet` prints only that."""
from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from click.testing import CliRunner

import workbench.progress
from workbench import diagnosis as D
from workbench.cli import cli
from workbench.provenance import ROOT

LOG = str(ROOT / "flighttest" / "logs" / "flight" / "PD-G3-1.mcap")
STAGES = ("baseline gap 1.5 m", "screen: drogue_lift 0.99", "fitted drogue_lift")


class _Recorded(workbench.progress.Progress):
    """The display, with every step announced and finished kept."""

    made: list = []

    def __init__(self, *a, **k):
        super().__init__(*a, **k)
        self.total, self.finished = 0, []
        _Recorded.made.append(self)

    def add(self, n, what=""):
        self.total += n
        super().add(n, what)

    def done(self, what=""):
        self.finished.append(what)
        super().done(what)


@pytest.fixture
def fake_diagnosis(monkeypatch, tmp_path):
    """The diagnosis replaced by one that reports `STAGES` and writes nothing."""
    def diagnose(paths, n_elements, workers, scheduler, progress, baseline):
        for s in STAGES:
            progress(s)
        best = SimpleNamespace(effect="drogue_lift", params={"drogue_lift": {"scale": 0.0}}, gap_after_heldout=0.13)
        return SimpleNamespace(families={"pitch_doublet/g3": SimpleNamespace(
            ranking=[best], gap_before=1.58, noise_floor=0.01, wall_s=2.0, baseline={})})

    def write_diagnosis(out, out_dir):
        return {"json": Path(out_dir) / "diagnosis.json", "html": Path(out_dir) / "diagnosis.html"}

    monkeypatch.setattr(D, "diagnose", diagnose)
    monkeypatch.setattr(D, "write_diagnosis", write_diagnosis)
    monkeypatch.setattr(workbench.progress, "Progress", _Recorded)
    _Recorded.made.clear()
    return tmp_path


def test_every_stage_and_the_report_are_steps_and_the_last_line_has_the_total_time(fake_diagnosis):
    res = CliRunner().invoke(cli, ["diagnose", LOG, "--out", str(fake_diagnosis / "d")])
    assert res.exit_code == 0, res.output
    (p,) = _Recorded.made
    assert p.finished[:len(STAGES)] == list(STAGES) and len(p.finished) == len(STAGES) + 1 == p.total
    lines = res.output.strip().splitlines()
    assert lines[0].startswith("pitch_doublet/g3: gap 1.580 m (floor 0.010); best drogue_lift")
    assert re.fullmatch(r"wrote .*diagnosis\.json and diagnosis\.html; total \d+\.\d s", lines[-1])


def test_quiet_prints_only_the_final_line(fake_diagnosis):
    res = CliRunner().invoke(cli, ["diagnose", LOG, "--out", str(fake_diagnosis / "d"), "--quiet"])
    assert res.exit_code == 0, res.output
    (line,) = res.output.strip().splitlines()
    assert line.startswith("wrote ") and " total " in line
