"""The validation report: the PDF lays out cleanly (no glyph over another,
nothing off the page), the HTML is one file (figures inline, anchors that
resolve, no absolute paths), the objective tests carry E ± u_val, and the
progress display and the final line."""
import io
import json
import math
import re
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner
from numpy.testing import assert_allclose

from workbench.cli import cli
from workbench.progress import Progress
from workbench.provenance import ROOT
from workbench.report.document import fmt
from workbench.report.objective import objective_tables

sys.path.insert(0, str(Path(__file__).parent))
from pdf_layout import off_page, overprinted_glyphs  # noqa: E402
from test_validate import CASE as VALIDATE_CASE  # noqa: E402

pdfplumber = pytest.importorskip("pdfplumber")

# test_validate's one-trail case (12 elements, 0.5 s), with a gate whose long
# source wraps over several lines of its cell, as the committed cases' do
CASE = VALIDATE_CASE.replace("{shape_max}", "5.0").replace("{z_expected}", "-0.70") + """
[[gates]]
metric = "trail_shape_max_error_m"
max = 5.0
source = "a loose check with a long source text, to make the gate table's cells wrap over several lines the way the real cases' sources do in the committed case files"
part60 = "time histories within stated bands"
"""


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A quiet validation of one small case with the committed diagnosis folded in."""
    tmp = tmp_path_factory.mktemp("report")
    case = tmp / "trail_mini.toml"
    case.write_text(CASE)
    out = tmp / "out"
    res = CliRunner().invoke(cli, ["validate", str(case), "--out", str(out), "--quiet", "--diagnosis",
                                   str(ROOT / "reports" / "diagnose" / "diagnosis.json")])
    return res, out, tmp


def test_pdf_has_no_glyph_over_another_and_nothing_off_the_page(report):
    res, out, _ = report
    assert res.exit_code == 0, res.output
    pdf = out / "report.pdf"
    assert overprinted_glyphs(pdf) == []
    assert off_page(pdf) == []


def test_pdf_carries_the_headings_of_the_html(report):
    _, out, _ = report
    html = (out / "report.html").read_text()
    headings = [re.sub(r"<[^>]+>", "", h) for h in re.findall(r"<h[23] id=\"[^\"]+\">(.*?)</h[23]>", html)]
    assert {"Verdict", "Contents", "Glossary", "Sim-to-real gap diagnosis", "Provenance"} <= set(headings)
    with pdfplumber.open(str(out / "report.pdf")) as doc:
        text = re.sub(r"\s+", " ", " ".join(p.extract_text() or "" for p in doc.pages))
    for h in headings:
        assert re.sub(r"\s+", " ", h.replace("&amp;", "&")) in text, h


def test_html_is_one_file_with_inline_figures_resolving_anchors_and_no_absolute_paths(report):
    _, out, tmp = report
    html = (out / "report.html").read_text()
    srcs = re.findall(r'<img src="([^"]*)"', html)
    assert len(srcs) >= 4   # the trail's figure and the diagnosis's
    assert all(s.startswith("data:image/png;base64,") for s in srcs)
    ids = set(re.findall(r' id="([^"]+)"', html))
    links = set(re.findall(r'href="#([^"]+)"', html))
    assert links and links <= ids
    for absolute in (str(ROOT), str(tmp), "/tmp/"):
        assert absolute not in html
    results = (out / "results.json").read_text()
    assert str(ROOT) not in results and str(tmp) not in results
    prov = json.loads(results)["provenance"]
    assert prov["code_version"] and isinstance(prov["dirty"], bool)
    assert prov["dependencies"]["reportlab"] and "code_changed_since" in prov["property_table"]
    assert "SHA-256" in html and "flighttest/logs/flight/TR-KDC10-E7.mcap" in html


def test_diagnosis_html_has_the_report_style_figures_and_provenance():
    from workbench.diagnosis.report import diagnosis_html
    js = json.loads((ROOT / "reports" / "diagnose" / "diagnosis.json").read_text())
    js["selftest"] = json.loads((ROOT / "reports" / "diagnose" / "selftest.json").read_text())
    html = diagnosis_html(js)
    assert "<style>" in html and "table-layout: fixed" in html
    srcs = re.findall(r'<img src="([^"]*)"', html)
    # per family: ranking, where-map, before/after; per log its heat maps and overlay
    # (a diagnosis.json with the where-map tables); and the selftest's confusion matrix
    per_log = sum(2 * len(f["logs"]) for f in js["families"].values()
                  if all("channel_phase" in w for w in f["gap"].values()))
    assert len(srcs) == 3 * len(js["families"]) + per_log + 1
    assert all(s.startswith("data:image/png;base64,") for s in srcs)
    assert "Provenance" in html and "SHA-256" in html and "flighttest/logs/flight/PD-G3-1.mcap" in html
    assert str(ROOT) not in html and "/tmp/" not in html


def test_quiet_prints_only_the_final_line_with_the_total_time(report):
    res, out, _ = report
    (line,) = res.output.strip().splitlines()
    assert line.startswith("1 cases, 3/3 gates pass, 1/1 findings as expected") and re.search(r"total \d+\.\d s", line)


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_is_on_screen_when_made_and_silent_in_a_pipe():
    term, pipe = _Terminal(), io.StringIO()
    for stream in (term, pipe):
        p = Progress("validate", stream=stream)
        p.add(2, "tuning")
        p.done()
        p.close()
    assert "validate: 0/0 steps" in term.getvalue() and "1/2 steps" in term.getvalue()
    assert "tuning" in term.getvalue()
    assert pipe.getvalue() == ""


def test_layout_checks_find_overprinted_and_off_page_text(tmp_path):
    # the checks themselves must be able to fail: the old PDF printed one cell over another
    from reportlab.pdfgen import canvas
    path = tmp_path / "bad.pdf"
    c = canvas.Canvas(str(path))
    c.drawString(100, 700, "bench-ringdown-fa18")
    c.drawString(110, 700, "baseline")
    c.drawString(-20, 600, "outside")
    c.save()
    assert len(overprinted_glyphs(path)) >= 5
    assert {n for n, _ in off_page(path)} == {1}


def _doublet_run(variant, log, f_log, f_sim, z_log, z_sim, held_out=True):
    return {"variant": variant, "log": log, "held_out": held_out,
            "metrics": {"drogue_frequency_hz_log": f_log, "drogue_frequency_hz_sim": f_sim,
                        "drogue_damping_ratio_log": 0.10, "drogue_damping_ratio_sim": 0.13,
                        "drogue_steady_z_m_log": z_log, "drogue_steady_z_m_sim": z_sim,
                        "drogue_z_response_rms_error_m": 0.05}}


def test_objective_table_gives_e_and_its_validation_uncertainty():
    logs = {"L1": (0.40, -2.60), "L2": (0.41, -2.64), "L3": (0.39, -2.62)}
    runs = [_doublet_run("m", k, f, 0.44, z, -2.5) for k, (f, z) in logs.items()]
    case = {"kind": "pitch_doublet", "runs": runs,
            "gates": [{"metric": "drogue_steady_z_error_m", "variant": "m", "logs": ["L1"], "kind": "max",
                       "threshold": 0.3, "passed": True}]}
    bounds = {"frequency": 0.5, "damping": 2.0}   # u_num in % of the model's value
    tables = objective_tables(case, bounds)
    assert [t.title for t in tables] == ["Objective tests: L1", "Objective tests: L2", "Objective tests: L3"]
    rows = {r[1]: r for r in tables[0].rows}
    # period: D = 1/0.40 s, S = 1/0.44 s; u_D the spread of the three logs' periods
    _, _, d, s, e, u_d, u_num, u_input, u_val, e_pm, within, gate, p60 = rows["period (s)"]
    periods = [1 / f for f, _ in logs.values()]
    sd = math.sqrt(sum((p - sum(periods) / 3) ** 2 for p in periods) / 2)
    assert_allclose([d, s, e, u_d, u_num], [2.5, 1 / 0.44, 1 / 0.44 - 2.5, sd, 0.005 / 0.44], rtol=1e-12)
    assert_allclose(u_val, math.hypot(sd, 0.005 / 0.44), rtol=1e-12)
    # no study stored with these runs: u_input not measured, left out of u_val; |E| 0.227 s > u_val
    assert u_input is None and within.text == "no" and e_pm.text == f"{fmt(e)} ± {fmt(u_val)}"
    # Part 60: period within 10 % (0.25 s); E = -0.227 s is within
    assert p60.style == "pass" and "within" in p60.text
    # damping: E = 0.03 is outside Part 60's 0.02
    _, _, d, s, e, u_d, u_num, *_, p60 = rows["damping ratio (-)"]
    assert_allclose([e, u_num], [0.03, 0.02 * 0.13], rtol=1e-12)
    # equal damping on the three logs: no spread, to the rounding of np.std
    assert_allclose(u_d, 0.0, atol=1e-15)
    assert p60.style == "fail"
    # the steady height carries the case's gate on this log
    assert "pass" in rows["steady drogue z (m)"][11].text
    # a time-history error is E itself, with the spread of that error over the logs (all 0.05: 0)
    _, _, d, s, e, u_d, *_ = rows["z response RMS error (m)"]
    assert d is None and s is None and e == 0.05
    assert_allclose(u_d, 0.0, atol=1e-15)


def test_a_long_table_starts_where_its_title_is_and_runs_on_with_its_header(tmp_path):
    # a table longer than what is left of a page but shorter than a page: kept
    # whole with its title it went to the next page and left half a page empty
    # after the family's heading (the diagnosis's ranking)
    import pdfplumber
    from workbench.report.document import Document, Heading, Para, Table
    from workbench.report.pdf import write_pdf
    filler = " ".join(["The held-out gap per family, before and after each candidate."] * 60)
    rows = [[f"row{i:02d}", "x " * 30] for i in range(40)]
    doc = Document("t", [Heading(1, "Diagnosis", "d"), Para(filler),
                         Table(["name", "text"], rows, [1, 4], title="Ranking")])
    path = tmp_path / "t.pdf"
    write_pdf(doc, path)
    with pdfplumber.open(str(path)) as pdf:
        pages = [p.extract_text() or "" for p in pdf.pages]
    on = lambda s: [n for n, text in enumerate(pages) if s in text]
    assert on("Ranking") == on("row00") == on("The held-out gap")[-1:]
    assert len(on("name")) >= 2 and on("row39") != on("row00")     # the header again where it runs on
