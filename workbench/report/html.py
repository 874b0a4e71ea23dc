"""The report as one self-contained HTML file: the style sheet inline, every
figure a PNG data URI, every link an anchor within the file."""
from __future__ import annotations

import base64
from pathlib import Path

import jinja2

from workbench.report.document import Contents, Document, Figure, Heading, PageBreak, Para, Table

TEMPLATES = Path(__file__).resolve().parents[2] / "reports" / "templates"


def _kind(block) -> str:
    return {Heading: "heading", Para: "para", Table: "table", Figure: "figure", Contents: "contents",
            PageBreak: "pagebreak"}[type(block)]


def _data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _percent(table: Table) -> list[float]:
    return [100.0 * w / sum(table.widths) for w in table.widths]


def render_html(doc: Document, meta: str = "") -> str:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(TEMPLATES)), autoescape=False,
                             trim_blocks=True, lstrip_blocks=True)
    return env.get_template("report.html.j2").render(
        title=doc.title, meta=meta, blocks=doc.blocks, kind=_kind, headings=doc.headings(),
        css=(TEMPLATES / "style.css").read_text(), data_uri=_data_uri, pct=_percent)
