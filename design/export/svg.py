"""``pattern.svg``: both faces of the mattress at 1:1 in millimetres, for printing or a plotter.

The top face is drawn as seen from above (u to the right, v up). The bottom
face, to its right, is drawn **as seen from below**, i.e. mirrored left-right
(u → W − u), the way it lies in front of you once the mattress is turned over
about its v axis; the caption says so, and each face marks its Ω origin corner.
Each string is a line from end a to end b along its dash, with dots at the
tie points and its id and length to cut (``k1-003-02  l=212.4``) beside it,
along the string and offset from it; k1 and k2 have different colours. A
100 mm scale bar in the caption band checks the print is 1:1. Every label
stays on the page: the origin labels run inward from the faces' outer corners.
The grid node each end is tied to (``R12C3``: row 12, column 3 of the tie grid)
is printed beside its end, on the other side of the string from the id, running
inward along the string (:func:`node_label_places`), so it covers neither its
string nor a neighbour chained to the same node. ``pattern_A4.pdf`` /
``pattern_A3.pdf`` tile this drawing over printer pages (:mod:`airmat.design.export.pdf`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from airmat.atomic import atomic_write_bytes

__all__ = ["write_svg", "svg_transform", "node_label_places", "page_size", "LAYOUT", "NODE_FONT"]

#: page layout (mm): outer padding, gap between the faces, title and caption bands, text sizes
LAYOUT = {"pad": 20.0, "gap": 80.0, "title": 40.0, "caption": 56.0, "font": 8.0, "title_font": 14.0}
SCALE_BAR_MM = 100.0
#: size of the node labels, in font sizes of LAYOUT["font"]
NODE_FONT = 0.75
COLOURS = {"k1": "#c0392b", "k2": "#1f5fa8"}
_NS = "http://www.w3.org/2000/svg"


def svg_transform(face: str, u_mm, v_mm, width_mm: float, height_mm: float):
    """Page coordinates (mm) of Ω points on a face: ``(x, y)`` with y down, as drawn in the SVG.

    Parameters
    ----------
    face : {"top", "bottom"}
    u_mm, v_mm : float or ndarray
        Ω coordinates (mm).
    width_mm, height_mm : float
        W and H (mm).
    """
    pad, top = LAYOUT["pad"], LAYOUT["pad"] + LAYOUT["title"]
    y = top + (height_mm - v_mm)
    if face == "top":
        return pad + u_mm, y
    return pad + width_mm + LAYOUT["gap"] + (width_mm - u_mm), y


def page_size(doc: dict) -> tuple:
    """Width and height (mm) of the drawing of a design document."""
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    L = LAYOUT
    return 2 * W + L["gap"] + 2 * L["pad"], H + L["title"] + L["caption"] + L["pad"]


def node_label_places(dash: dict, pts) -> list:
    """Where the tie-node labels of a string go: ``[(x, y, angle_deg, anchor, text)]`` in page mm.

    Each label runs along the string from 3 mm inside its end, on the side
    opposite the id label, its baseline ``0.6 + 0.75`` font sizes off the line
    (the text's height towards the line stays clear of it). ``anchor`` is
    ``"start"``/``"end"`` so that the text extends inward. Free ends (no tie
    grid) get no label.
    """
    (x0, y0), (x1, y1) = pts[0], pts[-1]
    length = math.hypot(x1 - x0, y1 - y0)
    if length == 0:
        return []
    dx, dy = (x1 - x0) / length, (y1 - y0) / length
    _, _, angle = _label_place([pts[0], pts[-1]])
    a = math.radians(angle)
    tx, ty = math.cos(a), math.sin(a)                    # the text's direction on the page
    off = (0.6 + NODE_FONT) * LAYOUT["font"]
    nx, ny = -math.sin(a) * off, math.cos(a) * off        # down on the page: opposite the id label
    out = []
    for end, (px, py), inward in (("a", pts[0], 1.0), ("b", pts[-1], -1.0)):
        node = dash.get(f"{end}_node")
        if not node:
            continue
        along = inward * (dx * tx + dy * ty) > 0
        out.append((px + inward * 3 * dx + nx, py + inward * 3 * dy + ny, angle, "start" if along else "end",
                    f"R{node['row']}C{node['col']}"))
    return out


def _fmt(x: float) -> str:
    return f"{x:.2f}"


def _text(parent, x, y, s, size, *, anchor="start", weight=None):
    el = ET.SubElement(parent, "text", {"x": _fmt(x), "y": _fmt(y), "font-size": _fmt(size),
                                        "font-family": "sans-serif", "text-anchor": anchor})
    if weight:
        el.set("font-weight", weight)
    el.text = s
    return el


def _face(svg, doc, face):
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    g = ET.SubElement(svg, "g", {"id": f"face-{face}"})
    x0, y0 = svg_transform(face, 0.0, H, W, H)
    x1, _ = svg_transform(face, W, H, W, H)
    ET.SubElement(g, "rect", {"x": _fmt(min(x0, x1)), "y": _fmt(y0), "width": _fmt(W), "height": _fmt(H),
                              "fill": "none", "stroke": "black", "stroke-width": "0.5"})
    ox, oy = svg_transform(face, 0.0, 0.0, W, H)
    ET.SubElement(g, "circle", {"cx": _fmt(ox), "cy": _fmt(oy), "r": "3", "fill": "black"})
    # the origin is the top face's left corner and the bottom face's right corner: label inward
    _text(g, ox, oy + 12, "origin u=0, v=0", LAYOUT["font"], anchor="start" if face == "top" else "end")
    label = "TOP face, seen from above" if face == "top" else "BOTTOM face, seen from below (mirrored)"
    _text(g, min(x0, x1), y0 - 4, label, LAYOUT["font"] * 1.25, weight="bold")
    for dash in doc["dashes"]:
        if dash["side"] != face:
            continue
        pts = [svg_transform(face, u, v, W, H) for u, v in dash["polyline_mm"]]
        colour = COLOURS.get(dash["family"], "black")
        dg = ET.SubElement(g, "g", {"id": dash["id"], "class": f"{face} {dash['family']}"})
        nodes = [dash.get(f"{end}_node") for end in ("a", "b")]
        ties = (" tied at " + " - ".join(f"R{n['row']}C{n['col']}" for n in nodes)) if all(nodes) else ""
        ET.SubElement(dg, "title").text = (f"{dash['id']}: l = {dash['l_mm']['median']:.1f} mm "
                                           f"[{dash['l_mm']['lo95']:.1f}, {dash['l_mm']['hi95']:.1f}]{ties}")
        ET.SubElement(dg, "polyline", {"points": " ".join(f"{_fmt(x)},{_fmt(y)}" for x, y in pts),
                                       "fill": "none", "stroke": colour, "stroke-width": "2"})
        for x, y in (pts[0], pts[-1]):
            ET.SubElement(dg, "circle", {"cx": _fmt(x), "cy": _fmt(y), "r": "2.5", "fill": colour})
        x, y, angle = _label_place(pts)
        el = _text(dg, x, y, f"{dash['id']}  l={dash['l_mm']['median']:.1f}", LAYOUT["font"], anchor="middle")
        el.set("transform", f"rotate({angle:.2f} {_fmt(x)} {_fmt(y)})")
        for nx_, ny_, ang, anchor, text in node_label_places(dash, pts):
            el = _text(dg, nx_, ny_, text, NODE_FONT * LAYOUT["font"], anchor=anchor)
            el.set("class", "node")
            el.set("fill", "#404040")
            el.set("transform", f"rotate({ang:.2f} {_fmt(nx_)} {_fmt(ny_)})")


def _label_place(pts):
    """Label anchor beside a string's middle (offset by 0.6 font sizes) and its angle (deg), upright."""
    (x0, y0), (x1, y1) = pts[0], pts[-1]
    mx, my = pts[len(pts) // 2]
    angle = math.degrees(math.atan2(y1 - y0, x1 - x0))
    if angle > 90.0:
        angle -= 180.0
    elif angle < -90.0:
        angle += 180.0
    # the normal pointing up on the page (y down): the text's baseline sits off the line
    a = math.radians(angle)
    off = 0.6 * LAYOUT["font"]
    return mx + off * math.sin(a), my - off * math.cos(a), angle


def _scale_bar(svg, x, y):
    g = ET.SubElement(svg, "g", {"id": "scale-bar"})
    ET.SubElement(g, "line", {"x1": _fmt(x), "y1": _fmt(y), "x2": _fmt(x + SCALE_BAR_MM), "y2": _fmt(y),
                              "stroke": "black", "stroke-width": "1"})
    for k in range(11):
        h = 4.0 if k % 5 == 0 else 2.0
        ET.SubElement(g, "line", {"x1": _fmt(x + 10 * k), "y1": _fmt(y - h), "x2": _fmt(x + 10 * k), "y2": _fmt(y),
                                  "stroke": "black", "stroke-width": "0.5"})
    _text(g, x + SCALE_BAR_MM + 4, y, f"{SCALE_BAR_MM:.0f} mm (check the print is 1:1)", LAYOUT["font"])


def write_svg(path, doc: dict) -> None:
    """Write ``pattern.svg`` from a design document (see :mod:`airmat.design.export.design_json`).

    The page is ``2 W + gap + 2 pad`` by ``H + title + caption + pad`` millimetres,
    ``width``/``height`` in mm and the ``viewBox`` in mm, so it prints at 1:1.
    """
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    L = LAYOUT
    page_w, page_h = page_size(doc)
    ET.register_namespace("", _NS)
    svg = ET.Element("svg", {"xmlns": _NS, "version": "1.1", "width": f"{_fmt(page_w)}mm",
                             "height": f"{_fmt(page_h)}mm", "viewBox": f"0 0 {_fmt(page_w)} {_fmt(page_h)}"})
    title = f"airmat string pattern: {doc.get('name', '')}"
    if doc.get("uncalibrated", doc["calibration"].get("uncalibrated")):
        title += "  UNCALIBRATED (paper values, nominal tolerances)"
    ET.SubElement(svg, "title").text = title
    _text(svg, L["pad"], L["pad"] + L["title_font"], title, L["title_font"], weight="bold")
    cal = doc["calibration"]
    sub = (f"mattress {W:.0f} x {H:.0f} x {doc['mattress']['thickness_mm']:.0f} mm; L = {cal['L_mm']:.0f} mm; "
           f"{len(doc['dashes'])} strings; scale 1:1, units mm; colours: k1 red, k2 blue")
    _text(svg, L["pad"], L["pad"] + L["title_font"] + 12, sub, L["font"])
    for face in ("top", "bottom"):
        _face(svg, doc, face)
    cap = ("Bottom face drawn as seen from below: mirrored left-right (u -> W - u), as it lies after turning the "
           "mattress over about its v axis. Dots are tie points; lengths in cutting_list.csv.")
    _text(svg, L["pad"], L["pad"] + L["title"] + H + 28, cap, L["font"])
    _scale_bar(svg, L["pad"], L["pad"] + L["title"] + H + 40)
    ET.indent(svg)
    atomic_write_bytes(path, ET.tostring(svg, encoding="utf-8", xml_declaration=True) + b"\n")
