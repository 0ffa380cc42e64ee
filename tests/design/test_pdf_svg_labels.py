"""pattern.svg's node labels and the tiled 1:1 PDFs (pattern_A4.pdf / pattern_A3.pdf)."""

import math
import re
import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pytest

from airmat.design.export.pdf import MARGIN_MM, OVERLAP_MM, PAPER_MM, pdf_bytes, tile_grid
from airmat.design.export.svg import LAYOUT, NODE_FONT, node_label_places, page_size, svg_transform, write_svg

PT = 72 / 25.4


def _dash(i, a, b, side, family, a_node, b_node):
    poly = np.linspace(a, b, 5).round(2).tolist()
    return {"id": f"{family}-{i:03d}-00", "family": family, "side": side, "polyline_mm": poly,
            "a_mm": list(a), "b_mm": list(b), "L_mm": 100.0, "chord_mm": 100.0, "kappa_per_m": 3.0,
            "l_mm": {"median": 90.0, "lo95": 89.0, "hi95": 91.0}, "flags": [],
            "a_node": None if a_node is None else {"row": a_node[0], "col": a_node[1], "u_mm": a[0], "v_mm": a[1]},
            "b_node": None if b_node is None else {"row": b_node[0], "col": b_node[1], "u_mm": b[0], "v_mm": b[1]}}


@pytest.fixture
def doc():
    """A small mattress (240 x 160 mm) with strings in several directions, one with free ends."""
    dashes = [_dash(0, (20, 20), (220, 20), "top", "k1", (1, 1), (1, 11)),
              _dash(1, (20, 60), (220, 140), "top", "k1", (3, 1), (7, 11)),
              _dash(2, (200, 140), (40, 100), "bottom", "k2", (7, 10), (5, 2)),
              _dash(3, (120, 20), (120, 140), "bottom", "k1", (1, 6), (7, 6)),
              _dash(4, (40, 40), (100, 40), "top", "k2", None, None)]
    return {"name": "labels", "mattress": {"width_mm": 240.0, "height_mm": 160.0, "thickness_mm": 70.0},
            "calibration": {"L_mm": 300.0, "uncalibrated": True}, "dashes": dashes}


def _segment_distance(p, a, b):
    ab, ap = b - a, p - a
    t = np.clip(ap @ ab / (ab @ ab), 0, 1)
    return np.linalg.norm(ap - t * ab)


def test_svg_prints_each_tie_node_beside_its_end_clear_of_the_string(doc, tmp_path):
    write_svg(tmp_path / "p.svg", doc)
    root = ET.parse(tmp_path / "p.svg").getroot()
    ns = {"s": "http://www.w3.org/2000/svg"}
    labels = {g.get("id"): [t.text for t in g.findall("s:text[@class='node']", ns)] for g in root.iter(f"{{{ns['s']}}}g")}
    assert labels["k1-000-00"] == ["R1C1", "R1C11"] and labels["k2-002-00"] == ["R7C10", "R5C2"]
    assert labels["k2-004-00"] == []                       # free ends: no node to print
    W, H = 240.0, 160.0
    size = NODE_FONT * LAYOUT["font"]
    for dash in doc["dashes"]:
        pts = np.array([svg_transform(dash["side"], u, v, W, H) for u, v in dash["polyline_mm"]])
        for x, y, angle, anchor, text in node_label_places(dash, pts):
            # the text's box: along its direction from the anchor (inward), up to one font size above the baseline
            a = math.radians(angle)
            t, up = np.array([math.cos(a), math.sin(a)]), np.array([math.sin(a), -math.cos(a)])
            length = 0.6 * size * len(text) * (1 if anchor == "start" else -1)
            box = [np.array([x, y]) + s * length * t + h * size * up for s in np.linspace(0, 1, 9) for h in (0, 1)]
            gap = min(_segment_distance(p, pts[0], pts[-1]) for p in box)
            assert gap > 0.25 * LAYOUT["font"], (dash["id"], text, gap)   # clear of its own string
            # and on its string's side of the ends: between a and b along the string
            s = [(p - pts[0]) @ (pts[-1] - pts[0]) / np.sum((pts[-1] - pts[0]) ** 2) for p in box]
            assert 0 < min(s) and max(s) < 1, (dash["id"], text)


def _pages(data):
    return re.findall(rb"/MediaBox \[ 0 0 ([\d.]+) ([\d.]+) \]", data)


def _segments(data):
    """Every straight segment ``x1 y1 m x2 y2 l`` of the PDF's content streams (points)."""
    out = []
    for s in re.findall(rb"stream\r?\n(.*?)\r?\nendstream", data, re.S):
        try:
            text = zlib.decompress(s)
        except zlib.error:
            continue
        out += [tuple(map(float, m)) for m in re.findall(rb"([-\d.]+) ([-\d.]+) m\s+([-\d.]+) ([-\d.]+) l", text)]
    return out


@pytest.mark.parametrize("paper", ["A4", "A3"])
def test_tiled_pdf_has_one_page_per_tile_of_the_paper_size(doc, paper):
    data = pdf_bytes(doc, paper)
    cols, rows = tile_grid(page_size(doc), paper)
    w, h = PAPER_MM[paper]
    # tiles of the printable area overlapping by 20 mm cover the drawing, and one tile fewer would not
    tw, th = w - 2 * MARGIN_MM, h - 2 * MARGIN_MM
    dw, dh = page_size(doc)
    assert cols * tw - (cols - 1) * OVERLAP_MM >= dw > (cols - 1) * tw - max(cols - 2, 0) * OVERLAP_MM
    assert rows * th - (rows - 1) * OVERLAP_MM >= dh
    pages = _pages(data)
    assert len(pages) == cols * rows == {"A4": 4, "A3": 3}[paper]   # a 600 x 276 mm drawing
    for pw, ph in pages:
        assert (float(pw) / PT, float(ph) / PT) == pytest.approx((w, h), abs=0.01)


def test_the_100_mm_scale_bar_is_100_mm_in_pdf_units(doc):
    segs = _segments(pdf_bytes(doc, "A3"))
    bars = [s for s in segs if abs(s[1] - s[3]) < 1e-6 and abs(abs(s[2] - s[0]) - 100 * PT) < 0.01]
    assert bars, "no horizontal segment of 100 mm (283.46 pt) in the PDF"
    # the 10 mm ticks of the bar are 10 mm apart on the page as well
    ticks = sorted({round(s[0], 3) for s in segs if abs(s[0] - s[2]) < 1e-6 and 0 < abs(s[3] - s[1]) < 5 * PT
                    and min(bars[0][0], bars[0][2]) - 0.01 <= s[0] <= max(bars[0][0], bars[0][2]) + 0.01})
    assert len(ticks) == 11 and np.allclose(np.diff(ticks), 10 * PT, atol=0.01)


def test_crop_marks_at_the_tile_corners(doc):
    segs = _segments(pdf_bytes(doc, "A4"))
    w, h = PAPER_MM["A4"]
    corner = (MARGIN_MM * PT, MARGIN_MM * PT)
    marks = [s for s in segs if (s[0], s[1]) == pytest.approx(corner, abs=0.01) and math.hypot(s[2] - s[0], s[3] - s[1])
             == pytest.approx(6 * PT, abs=0.01)]
    assert len(marks) == 2 * 4                             # two strokes per corner, on each of the 4 pages
