"""The report as a list of blocks that the HTML and the PDF writers both render,
so the two files carry the same content.

Text is "inline markup": escaped text with only <b>, <i>, <br/> and
<a href="#anchor"> tags, which HTML and ReportLab's Paragraph both read. Use
`esc` on every value that comes from data.
"""
from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass, field
from xml.sax.saxutils import escape


def esc(v) -> str:
    return escape(str(v))


def fmt(v) -> str:
    """A value as the report prints it: 4 significant digits, '–' for none."""
    if v is None:
        return "–"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        a = abs(v)
        if a != 0 and (a >= 1e5 or a < 1e-3):
            return f"{v:.3g}"
        return f"{v:.4g}" if a < 100 else f"{v:.1f}"
    return str(v)


def anchor(text: str) -> str:
    """An id for a heading: lower case letters, digits and dashes."""
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "section"


@dataclass
class Heading:
    level: int          # 1: a page of its own in the PDF and an entry of the contents; 2, 3 within
    text: str           # inline markup
    anchor: str


@dataclass
class Para:
    text: str           # inline markup
    style: str = ""     # "", "note", "meta", "pass", "fail", "verdict-pass", "verdict-fail"


@dataclass
class Cell:
    text: str           # inline markup
    style: str = ""     # "", "pass", "fail", "small"


@dataclass
class Table:
    header: list[str]
    rows: list[list]            # cells: Cell, or a value printed with `fmt` and escaped
    widths: list[float]         # relative column widths (scaled to the page)
    title: str = ""
    row_class: str = ""         # an HTML class on every body row (tests and style sheets find rows by it)
    note: str = ""              # inline markup printed between the title and the table

    def cell(self, v) -> Cell:
        return v if isinstance(v, Cell) else Cell(esc(fmt(v)))


@dataclass
class Figure:
    png: bytes
    caption: str                # inline markup
    name: str                   # a file-name-like id (alt text)


@dataclass
class Contents:
    """The table of contents: filled by the writers from the level-1 and 2 headings."""


@dataclass
class PageBreak:
    pass


@dataclass
class Document:
    title: str
    blocks: list = field(default_factory=list)

    def add(self, *blocks) -> "Document":
        self.blocks.extend(blocks)
        return self

    def headings(self) -> list[Heading]:
        return [b for b in self.blocks if isinstance(b, Heading) and b.level <= 2]


def legend_below(fig, axes, ncol: int = 3) -> None:
    """One legend for the figure, under its axes (never over the data), each label once."""
    import numpy as np
    seen = {}
    for ax in np.atleast_1d(axes).ravel():
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    if seen:
        fig.legend(list(seen.values()), list(seen.keys()), loc="upper center", bbox_to_anchor=(0.5, 0.0),
                   ncol=min(ncol, len(seen)), fontsize=8, frameon=False)


def figure_png(fig, dpi: int = 110) -> bytes:
    """A matplotlib figure as PNG bytes (the figure is closed)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    import matplotlib.pyplot as plt
    plt.close(fig)      # a no-op for a Figure made without pyplot
    return buf.getvalue()
