"""Layout checks of a PDF with pdfplumber: glyphs drawn over other glyphs, and
glyphs or images that leave the page."""
from __future__ import annotations

import numpy as np

# Two glyph boxes overlap when they share more than this much width (pt) and
# more than this share of the smaller glyph's height: kerning and italic
# overhang stay under 1 pt; a glyph printed over another shares most of its box.
MIN_OVERLAP_PT = 1.0
MIN_OVERLAP_HEIGHT = 0.3


def overprinted_glyphs(path) -> list[tuple[int, str, str]]:
    """(page, glyph, other glyph) for every visible glyph whose box overlaps another's."""
    import pdfplumber
    out = []
    with pdfplumber.open(str(path)) as pdf:
        for n, page in enumerate(pdf.pages, 1):
            chars = [c for c in page.chars if c["text"].strip()]
            if len(chars) < 2:
                continue
            box = np.array([[c["x0"], c["x1"], c["top"], c["bottom"]] for c in chars])
            w = np.minimum(box[:, None, 1], box[None, :, 1]) - np.maximum(box[:, None, 0], box[None, :, 0])
            h = np.minimum(box[:, None, 3], box[None, :, 3]) - np.maximum(box[:, None, 2], box[None, :, 2])
            hmin = np.minimum.outer(box[:, 3] - box[:, 2], box[:, 3] - box[:, 2])
            hit = (w > MIN_OVERLAP_PT) & (h > MIN_OVERLAP_HEIGHT * hmin)
            np.fill_diagonal(hit, False)
            for i, j in zip(*np.nonzero(np.triu(hit))):
                out.append((n, chars[i]["text"], chars[j]["text"]))
    return out


def off_page(path) -> list[tuple[int, str]]:
    """(page, what) for every glyph or image not wholly inside its page."""
    import pdfplumber
    out = []
    with pdfplumber.open(str(path)) as pdf:
        for n, page in enumerate(pdf.pages, 1):
            x0, top, x1, bottom = page.bbox
            for c in page.chars:
                if c["text"].strip() and (c["x0"] < x0 or c["x1"] > x1 or c["top"] < top or c["bottom"] > bottom):
                    out.append((n, c["text"]))
            for im in page.images:
                if im["x0"] < x0 - 0.5 or im["x1"] > x1 + 0.5 or im["top"] < top - 0.5 or im["bottom"] > bottom + 0.5:
                    out.append((n, "image"))
    return out
