"""``pattern_A4.pdf`` / ``pattern_A3.pdf``: the 1:1 drawing of ``pattern.svg`` tiled over printer pages.

The drawing (both faces, the bottom one seen from below, strings with ids,
lengths and tie nodes, the 100 mm scale bar) is laid out as in
:mod:`airmat.design.export.svg` and cut into tiles of the printable area of a
portrait page (10 mm margins); neighbouring tiles overlap by 20 mm so that
pages can be trimmed and taped. Each page has crop marks at the corners of its
tile and a footer with its page number, its row and column in the grid of
pages, and the scale check. Printed at 100 % ("actual size"), 100 mm on the
paper are 100 mm of the mattress.
"""

from __future__ import annotations

import io
import math

import numpy as np

from airmat.atomic import atomic_write_bytes
from airmat.design.export.svg import COLOURS, LAYOUT, NODE_FONT, SCALE_BAR_MM, node_label_places, page_size, svg_transform

__all__ = ["write_pdf", "pdf_bytes", "tile_grid", "PAPER_MM", "MARGIN_MM", "OVERLAP_MM"]

#: portrait paper sizes (mm)
PAPER_MM = {"A4": (210.0, 297.0), "A3": (297.0, 420.0)}
MARGIN_MM = 10.0
OVERLAP_MM = 20.0
_PT = 72.0 / 25.4          # points per mm
_CROP_MM = 6.0


def tile_grid(drawing_mm: tuple, paper: str) -> tuple:
    """Columns and rows of pages for a drawing (mm): tiles of the printable area overlapping by 20 mm.

    Examples
    --------
    >>> tile_grid((1800.0, 900.0), "A3")
    (7, 3)
    """
    w, h = PAPER_MM[paper]
    tw, th = w - 2 * MARGIN_MM, h - 2 * MARGIN_MM
    cols = max(1, math.ceil((drawing_mm[0] - OVERLAP_MM) / (tw - OVERLAP_MM)))
    rows = max(1, math.ceil((drawing_mm[1] - OVERLAP_MM) / (th - OVERLAP_MM)))
    return cols, rows


def _draw(ax, doc: dict) -> None:
    """The drawing on ``ax`` in page millimetres (y down, as the SVG), fonts in points for 1:1."""
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    font = LAYOUT["font"] * _PT
    for face in ("top", "bottom"):
        x0, y0 = svg_transform(face, 0.0, H, W, H)
        x1, y1 = svg_transform(face, W, 0.0, W, H)
        ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], color="black", lw=0.5 * _PT)
        label = "TOP face, seen from above" if face == "top" else "BOTTOM face, seen from below (mirrored)"
        ax.text(min(x0, x1), y0 - 4, label, fontsize=1.25 * font, weight="bold", va="baseline")
        ox, oy = svg_transform(face, 0.0, 0.0, W, H)
        ax.plot([ox], [oy], "o", color="black", ms=6 * _PT)
        ax.text(ox, oy + 12, "origin u=0, v=0", fontsize=font, ha="left" if face == "top" else "right")
    for dash in doc["dashes"]:
        face, colour = dash["side"], COLOURS.get(dash["family"], "black")
        pts = np.array([svg_transform(face, u, v, W, H) for u, v in dash["polyline_mm"]])
        ax.plot(pts[:, 0], pts[:, 1], color=colour, lw=2 * _PT, solid_capstyle="butt")
        ax.plot(pts[[0, -1], 0], pts[[0, -1], 1], "o", color=colour, ms=5 * _PT)
        mx, my = pts[len(pts) // 2]
        angle = _upright(math.degrees(math.atan2(pts[-1, 1] - pts[0, 1], pts[-1, 0] - pts[0, 0])))
        a = math.radians(angle)
        off = 0.6 * LAYOUT["font"]
        ax.text(mx + off * math.sin(a), my - off * math.cos(a), f"{dash['id']}  l={dash['l_mm']['median']:.1f}",
                fontsize=font, ha="center", va="baseline", rotation=-angle, rotation_mode="anchor")
        for x, y, ang, anchor, text in node_label_places(dash, pts):
            ax.text(x, y, text, fontsize=NODE_FONT * font, ha={"start": "left", "end": "right"}[anchor], va="baseline", rotation=-ang,
                    rotation_mode="anchor", color="0.25")
    pad, top = LAYOUT["pad"], LAYOUT["pad"] + LAYOUT["title"]
    y = top + H + 40
    ax.plot([pad, pad + SCALE_BAR_MM], [y, y], color="black", lw=1.0 * _PT, solid_capstyle="butt")
    for k in range(11):
        h = 4.0 if k % 5 == 0 else 2.0
        ax.plot([pad + 10 * k] * 2, [y - h, y], color="black", lw=0.5 * _PT, solid_capstyle="butt")
    ax.text(pad + SCALE_BAR_MM + 4, y, f"{SCALE_BAR_MM:.0f} mm (check the print is 1:1)", fontsize=font)
    ax.text(pad, pad + LAYOUT["title_font"], f"airmat string pattern: {doc.get('name', '')}",
            fontsize=LAYOUT["title_font"] * _PT, weight="bold")


def _upright(angle: float) -> float:
    return angle - 180.0 if angle > 90.0 else angle + 180.0 if angle < -90.0 else angle


def pdf_bytes(doc: dict, paper: str = "A4") -> bytes:
    """The tiled PDF of a design document (see the module docstring); one page per tile.

    Parameters
    ----------
    doc : dict
        The design document (:mod:`airmat.design.export.design_json`, mm).
    paper : {"A4", "A3"}
    """
    from matplotlib.backends.backend_pdf import PdfPages

    from airmat.figures import new_figure

    if paper not in PAPER_MM:
        raise ValueError(f"paper must be one of {sorted(PAPER_MM)}, got {paper!r}")
    pw, ph = PAPER_MM[paper]
    tw, th = pw - 2 * MARGIN_MM, ph - 2 * MARGIN_MM
    drawing = page_size(doc)
    cols, rows = tile_grid(drawing, paper)
    fig = new_figure((pw / 25.4, ph / 25.4))
    ax = fig.add_axes((MARGIN_MM / pw, MARGIN_MM / ph, tw / pw, th / ph))
    ax.set_axis_off()
    _draw(ax, doc)
    marks = []
    for cx, cy in ((MARGIN_MM, MARGIN_MM), (pw - MARGIN_MM, MARGIN_MM), (MARGIN_MM, ph - MARGIN_MM),
                   (pw - MARGIN_MM, ph - MARGIN_MM)):            # crop marks, in page mm (y up)
        sx, sy = (-1 if cx < pw / 2 else 1), (-1 if cy < ph / 2 else 1)
        for xs, ys in (([cx, cx + sx * _CROP_MM], [cy, cy]), ([cx, cx], [cy, cy + sy * _CROP_MM])):
            marks.append(fig.add_artist(_line(fig, xs, ys, pw, ph)))
    footer = fig.text(MARGIN_MM / pw, 4 / ph, "", fontsize=7)
    buf = io.BytesIO()
    with PdfPages(buf, metadata={"Creator": "airmat", "Producer": "airmat", "CreationDate": None}) as pdf:
        n = 0
        for r in range(rows):
            for c in range(cols):
                n += 1
                x0, y0 = c * (tw - OVERLAP_MM), r * (th - OVERLAP_MM)
                ax.set_xlim(x0, x0 + tw)
                ax.set_ylim(y0 + th, y0)                       # page y runs down, as in the SVG
                footer.set_text(f"page {n} of {rows * cols}: row {r + 1} of {rows}, column {c + 1} of {cols}  "
                                f"({paper}, print at 100 %; tiles overlap {OVERLAP_MM:.0f} mm; "
                                f"x {x0:.0f}-{x0 + tw:.0f} mm, y {y0:.0f}-{y0 + th:.0f} mm of the drawing)")
                pdf.savefig(fig)
    return buf.getvalue()


def _line(fig, xs, ys, pw, ph):
    from matplotlib.lines import Line2D

    return Line2D([x / pw for x in xs], [y / ph for y in ys], transform=fig.transFigure, color="black", lw=0.3)


def write_pdf(path, doc: dict, paper: str = "A4") -> None:
    """Write ``pattern_<paper>.pdf`` (:func:`pdf_bytes`) atomically."""
    atomic_write_bytes(path, pdf_bytes(doc, paper))
