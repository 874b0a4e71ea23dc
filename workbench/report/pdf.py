"""The report as PDF, drawn with ReportLab's platypus from the same blocks as
the HTML (`workbench.report.document`).

Why ReportLab and not an HTML-to-PDF converter: the report is tables of
numbers with long text cells, and platypus lays a table out itself: fixed
column widths scaled to the frame, Paragraph cells that wrap inside their
column, `LongTable(repeatRows=1)` that repeats the header on every page a
table runs onto, images scaled to the frame, and outline bookmarks and
internal links. xhtml2pdf (the former path) guessed column widths from the
HTML and printed cells over each other; WeasyPrint lays out HTML well but
needs Pango, a system library a fresh pip install lacks. ReportLab is pure
pip (wheels with its C parts), and the fonts come from matplotlib's DejaVu
files, so every glyph the report uses (ζ, ±, ≤, –) is in the font.
"""
from __future__ import annotations

import io
import os
import re
from pathlib import Path
from xml.sax.saxutils import unescape

from reportlab.lib import colors
from reportlab.lib.enums import TA_LEFT
from reportlab.lib.pagesizes import A4, landscape
from reportlab.lib.styles import ParagraphStyle
from reportlab.lib.units import mm
from reportlab.pdfbase import pdfmetrics
from reportlab.pdfbase.ttfonts import TTFont
from reportlab.platypus import (CondPageBreak, Image, KeepTogether, LongTable, PageBreak as PBreak, Paragraph,
                                SimpleDocTemplate, Spacer, TableStyle)

from workbench.report.document import Contents, Document, Figure, Heading, PageBreak, Para, Table

MARGIN = 15 * mm
PAGE = landscape(A4)   # the wide tables and figures read best across the page
FONT = "DejaVuSans"


def _register_fonts() -> None:
    if FONT in pdfmetrics.getRegisteredFontNames():
        return
    import matplotlib
    ttf = Path(matplotlib.get_data_path()) / "fonts" / "ttf"
    faces = {"": FONT, "-Bold": f"{FONT}-Bold", "-Oblique": f"{FONT}-Oblique", "-BoldOblique": f"{FONT}-BoldOblique"}
    for suffix, name in faces.items():
        pdfmetrics.registerFont(TTFont(name, os.fspath(ttf / f"DejaVuSans{suffix}.ttf")))
    pdfmetrics.registerFontFamily(FONT, normal=FONT, bold=f"{FONT}-Bold", italic=f"{FONT}-Oblique",
                                  boldItalic=f"{FONT}-BoldOblique")


def _styles() -> dict[str, ParagraphStyle]:
    base = ParagraphStyle("body", fontName=FONT, fontSize=9, leading=11.5, alignment=TA_LEFT, spaceAfter=4)
    s = {"": base,
         "note": ParagraphStyle("note", base, fontName=f"{FONT}-Oblique", textColor=colors.HexColor("#444444")),
         "meta": ParagraphStyle("meta", base, fontSize=8, leading=10, textColor=colors.HexColor("#555555")),
         "pass": ParagraphStyle("pass", base, fontName=f"{FONT}-Bold", textColor=colors.HexColor("#006600")),
         "fail": ParagraphStyle("fail", base, fontName=f"{FONT}-Bold", textColor=colors.HexColor("#bb0000")),
         "cell": ParagraphStyle("cell", base, fontSize=7.2, leading=8.8, spaceAfter=0),
         "title": ParagraphStyle("title", base, fontName=f"{FONT}-Bold", fontSize=16, leading=20, spaceAfter=8),
         "caption": ParagraphStyle("caption", base, fontSize=8, leading=10, textColor=colors.HexColor("#444444")),
         "toc1": ParagraphStyle("toc1", base, fontSize=10, leading=13, spaceAfter=1),
         "toc2": ParagraphStyle("toc2", base, fontSize=8.5, leading=11, leftIndent=12, spaceAfter=0)}
    s["verdict-pass"] = ParagraphStyle("vp", s["pass"], fontSize=13, leading=16)
    s["verdict-fail"] = ParagraphStyle("vf", s["fail"], fontSize=13, leading=16)
    s["cell-pass"] = ParagraphStyle("cp", s["cell"], fontName=f"{FONT}-Bold", textColor=colors.HexColor("#006600"))
    s["cell-fail"] = ParagraphStyle("cf", s["cell"], fontName=f"{FONT}-Bold", textColor=colors.HexColor("#bb0000"))
    s["cell-small"] = ParagraphStyle("cs", s["cell"], fontSize=6.5, leading=8)
    s["cell-head"] = ParagraphStyle("ch", s["cell"], fontName=f"{FONT}-Bold")
    for level, size in ((1, 14), (2, 12), (3, 10)):
        s[f"h{level}"] = ParagraphStyle(f"h{level}", base, fontName=f"{FONT}-Bold", fontSize=size,
                                        leading=size * 1.25, spaceBefore=8, spaceAfter=4, keepWithNext=1)
    return s


class _Doc(SimpleDocTemplate):
    """Outline bookmarks from the headings (the PDF reader's side panel)."""

    def afterFlowable(self, flowable):
        h = getattr(flowable, "_heading", None)
        if h is not None:
            self.canv.bookmarkPage(h.anchor)
            self.canv.addOutlineEntry(getattr(flowable, "_plain", h.anchor), h.anchor, level=h.level - 1,
                                      closed=h.level > 1)


def _plain(markup: str) -> str:
    return unescape(re.sub(r"<[^>]+>", "", markup))


TABLE_START = 35 * mm    # a table's title, note, header and first rows


def _table(t: Table, st, width: float) -> list:
    scale = width / sum(t.widths)
    head = [Paragraph(h, st["cell-head"]) for h in t.header]
    body = []
    for row in t.rows:
        cells = [t.cell(v) for v in row]
        body.append([Paragraph(c.text, st[f"cell-{c.style}"] if c.style else st["cell"]) for c in cells])
    tbl = LongTable([head] + body, colWidths=[w * scale for w in t.widths], repeatRows=1, hAlign="LEFT")
    tbl.setStyle(TableStyle([("GRID", (0, 0), (-1, -1), 0.4, colors.HexColor("#bbbbbb")),
                             ("BACKGROUND", (0, 0), (-1, 0), colors.HexColor("#eeeeee")),
                             ("VALIGN", (0, 0), (-1, -1), "TOP"),
                             ("LEFTPADDING", (0, 0), (-1, -1), 2.5), ("RIGHTPADDING", (0, 0), (-1, -1), 2.5),
                             ("TOPPADDING", (0, 0), (-1, -1), 1.5), ("BOTTOMPADDING", (0, 0), (-1, -1), 2)]))
    # the title starts a page only where its table's first rows would not
    # follow it: kept with the whole table (keepWithNext) a table shorter than
    # a page but longer than what was left moved whole and left that empty
    out = [CondPageBreak(TABLE_START)]
    if t.title:
        out.append(Paragraph(f"<b>{t.title}</b>", st[""]))
    if t.note:
        out.append(Paragraph(t.note, st["note"]))
    out.append(tbl)
    out.append(Spacer(1, 4))
    return out


def _figure(f: Figure, st, width: float, height: float) -> list:
    img = Image(io.BytesIO(f.png))
    w, h = img.imageWidth, img.imageHeight
    k = min(width / w, 0.8 * height / h)
    img.drawWidth, img.drawHeight = w * k, h * k
    img.hAlign = "LEFT"
    return [KeepTogether([img, Paragraph(f.caption, st["caption"])]), Spacer(1, 6)]


def write_pdf(doc: Document, path: Path, meta: str = "") -> None:
    _register_fonts()
    st = _styles()
    pdf = _Doc(str(path), pagesize=PAGE, leftMargin=MARGIN, rightMargin=MARGIN, topMargin=MARGIN,
               bottomMargin=MARGIN + 4 * mm, title=doc.title, author="workbench validate")
    width, height = pdf.width, pdf.height
    story = [Paragraph(doc.title, st["title"])]
    if meta:
        story.append(Paragraph(meta, st["meta"]))
    first = True
    for b in doc.blocks:
        if isinstance(b, Heading):
            if b.level == 1 and not first:
                story.append(PBreak())
            elif b.level == 2:
                story.append(CondPageBreak(60 * mm))
            first = False
            p = Paragraph(f'<a name="{b.anchor}"/>{b.text}', st[f"h{min(b.level, 3)}"])
            p._heading, p._plain = b, _plain(b.text)
            story.append(p)
        elif isinstance(b, Para):
            story.append(Paragraph(b.text, st[b.style] if b.style in st else st[""]))
        elif isinstance(b, Table):
            story.extend(_table(b, st, width))
        elif isinstance(b, Figure):
            story.extend(_figure(b, st, width, height))
        elif isinstance(b, Contents):
            story.extend(Paragraph(f'<a href="#{h.anchor}" color="#1a4d99">{h.text}</a>', st[f"toc{h.level}"])
                         for h in doc.headings())
        elif isinstance(b, PageBreak):
            story.append(PBreak())

    def footer(canvas, d):
        canvas.saveState()
        canvas.setFont(FONT, 7)
        canvas.setFillColor(colors.HexColor("#666666"))
        canvas.drawString(MARGIN, MARGIN * 0.6, doc.title)
        canvas.drawRightString(PAGE[0] - MARGIN, MARGIN * 0.6, f"page {d.page}")
        canvas.restoreState()
    pdf.build(story, onFirstPage=footer, onLaterPages=footer)
