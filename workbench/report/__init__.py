"""The validation report: one self-contained report.html (figures inline), the
same content as report.pdf, results.json and junit.xml.

`content` says what the report holds as blocks (`document`); `html` and `pdf`
render the blocks; `figures` draws the paper's figures; `objective` builds the
objective-test tables with their validation uncertainty; `junit` writes the
JUnit XML and the one-line gate and finding messages."""
from __future__ import annotations

import json
import platform
from pathlib import Path
from typing import Callable

from workbench.report.document import fmt
from workbench.report.junit import finding_message, gate_message, junit_xml

__all__ = ["finding_message", "fmt", "gate_message", "junit_xml", "report_steps", "run_provenance", "write_report"]


def report_steps(n_cases: int) -> int:
    """The steps `write_report` reports: each case's figures, the HTML, the PDF, results.json with junit.xml."""
    return n_cases + 3


def run_provenance() -> dict:
    """Code version and dirty flag, Python and dependency versions, and the
    property tables' build with whether the code that built them has changed."""
    from workbench.properties.store import read_properties
    from workbench.provenance import ROOT, code_version, dependency_versions, file_sha256
    version = code_version()
    doc = read_properties()
    built = doc.get("code_version", {})
    changed = sorted(f for f, h in built.get("source_sha256", {}).items()
                     if not (ROOT / f).is_file() or file_sha256(ROOT / f) != h)
    return {"code_version": version, "dirty": version.endswith("-dirty"), "python": platform.python_version(),
            "dependencies": dependency_versions(("numpy", "scipy", "numba", "pandas", "matplotlib", "reportlab",
                                                 "jinja2", "mcap")),
            "property_table": {"file": "cases/properties/hose_properties.json",
                               "code_version": built.get("git", "unknown"), "code_changed_since": changed}}


def write_report(outcomes, results: dict, out_dir: Path, wall_s: float, extra_sections=(),
                 step: Callable[[str], None] | None = None) -> dict[str, Path]:
    """Write report.html, report.pdf, results.json and junit.xml under out_dir
    (and the figures as PNG files under figures/, for slides). `extra_sections`
    are lists of blocks, each starting with a level-1 heading. `step(what)` is
    called as each of the `report_steps` steps finishes."""
    from workbench.report.content import build_document, log_hashes
    from workbench.report.figures import case_figures, save_pngs
    from workbench.report.html import render_html
    from workbench.report.pdf import write_pdf
    step = step or (lambda what: None)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results["provenance"] = {**run_provenance(), "log_sha256": log_hashes(results["cases"])}
    figures = {}
    for oc, cj in zip(outcomes, results["cases"]):
        figures[cj["id"]] = case_figures(oc)
        save_pngs(figures[cj["id"]], out_dir / "figures")
        step(f"the figures of {cj['id']}")
    doc = build_document(results["cases"], results, wall_s, sections=extra_sections, case_figures=figures)
    paths = {"html": out_dir / "report.html", "pdf": out_dir / "report.pdf",
             "json": out_dir / "results.json", "junit": out_dir / "junit.xml"}
    paths["html"].write_text(render_html(doc), encoding="utf-8")
    step("report.html")
    write_pdf(doc, paths["pdf"])
    step("report.pdf")
    paths["json"].write_text(json.dumps(results, indent=1) + "\n")
    paths["junit"].write_text(junit_xml(results))
    step("results.json, junit.xml")
    return paths
