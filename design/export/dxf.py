"""``pattern.dxf``: the string pattern for CAD and cutting plotters (ezdxf, units mm).

Both faces are drawn side by side, as in the SVG: the top face as seen from
above at Ω's (u, v) in millimetres, and the bottom face to its right **as seen
from below**, mirrored left-right (x = 2 W + gap − u, y = v; see
:func:`dxf_transform`), each with its outline, its name ("TOP face, seen from
above", "BOTTOM face, seen from below (mirrored)") and its Ω origin marked.
Layers: ``OUTLINE``; ``TOP_K1``, ``TOP_K2``, ``BOTTOM_K1``, ``BOTTOM_K2`` (one
LWPOLYLINE per string along its dash and a TEXT ``<id>  l=<median> mm`` beside
it); ``TIES`` (a circle at each tie point and the grid node ``R<row>C<col>``
when the ends are tied to the grid). ``$INSUNITS`` = mm, ``$EXTMIN``/``$EXTMAX``
are the drawing's bounding box.

Byte-stable: ezdxf's fixed-metadata switch is on while writing (no time stamps
or random GUIDs), and the CLASSES section, which ezdxf fills from a set of
entity types (an order that changes with Python's hash seed), is written in
sorted order.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np

from airmat.atomic import atomic_write_bytes

__all__ = ["write_dxf", "dxf_transform", "LAYERS", "GAP_MM"]

#: layer name -> AutoCAD colour index
LAYERS = {"OUTLINE": 7, "TOP_K1": 1, "TOP_K2": 5, "BOTTOM_K1": 30, "BOTTOM_K2": 4, "TIES": 8}
TEXT_HEIGHT_MM = 8.0
TIE_RADIUS_MM = 3.0
#: gap between the two faces (mm), as in the SVG
GAP_MM = 80.0


@contextlib.contextmanager
def _fixed_metadata():
    import ezdxf

    old = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        yield
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = old


def layer_name(side: str, family: str) -> str:
    """``TOP_K1`` etc. for a string's face and family."""
    return f"{side.upper()}_{family.upper()}"


def dxf_transform(face: str, u_mm, v_mm, width_mm: float):
    """Drawing coordinates (mm) of Ω points on a face: ``(x, y)``, y up.

    The top face is Ω itself; the bottom face, seen from below, is mirrored
    left-right and placed ``GAP_MM`` to the right of the top face.

    Examples
    --------
    >>> dxf_transform("bottom", 0.0, 5.0, 830.0)
    (1740.0, 5.0)
    """
    if face == "top":
        return u_mm, v_mm
    return 2.0 * width_mm + GAP_MM - u_mm, v_mm


def _sorted_classes(dxf) -> None:
    """Fill the CLASSES section now, in sorted order (ezdxf iterates a set of entity types)."""
    dxf.classes.add_required_classes(dxf.dxfversion)
    classes = dxf.classes.classes
    items = sorted(classes.items())
    classes.clear()
    classes.update(items)


def _label_offset(pts: np.ndarray) -> tuple:
    """Where a string's label goes: beside its middle, a text height off the line, and its angle (deg)."""
    mid = pts[len(pts) // 2]
    d = pts[-1] - pts[0]
    n = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9)
    if n[1] < 0:
        n = -n
    angle = float(np.degrees(np.arctan2(d[1], d[0])))
    angle = angle - 180.0 if angle > 90.0 else angle + 180.0 if angle < -90.0 else angle   # readable
    return tuple(mid + n * 0.6 * TEXT_HEIGHT_MM), round(angle, 3)


def _face(msp, doc: dict, face: str) -> None:
    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    x0, _ = dxf_transform(face, 0.0, 0.0, W)
    x1, _ = dxf_transform(face, W, 0.0, W)
    lo = min(x0, x1)
    msp.add_lwpolyline([(lo, 0), (lo + W, 0), (lo + W, H), (lo, H)], close=True, dxfattribs={"layer": "OUTLINE"})
    label = "TOP face, seen from above" if face == "top" else "BOTTOM face, seen from below (mirrored)"
    msp.add_text(label, height=TEXT_HEIGHT_MM * 1.25, dxfattribs={"layer": "OUTLINE"}).set_placement((lo, H + 6))
    msp.add_circle((x0, 0.0), radius=TIE_RADIUS_MM * 1.5, dxfattribs={"layer": "OUTLINE"})
    msp.add_text("origin u=0, v=0", height=TEXT_HEIGHT_MM * 0.75,
                 dxfattribs={"layer": "OUTLINE"}).set_placement((x0, -14.0), align=_align("TOP_CENTER"))
    for dash in doc["dashes"]:
        if dash["side"] != face:
            continue
        layer = layer_name(dash["side"], dash["family"])
        u, v = np.asarray(dash["polyline_mm"], float).T
        pts = np.column_stack(dxf_transform(face, u, v, W))
        msp.add_lwpolyline([tuple(p) for p in pts.tolist()], dxfattribs={"layer": layer})
        where, angle = _label_offset(pts)
        msp.add_text(f"{dash['id']}  l={dash['l_mm']['median']:.1f} mm", height=TEXT_HEIGHT_MM,
                     dxfattribs={"layer": layer, "rotation": angle}).set_placement(where,
                                                                                    align=_align("BOTTOM_CENTER"))
        for end, p in (("a", pts[0]), ("b", pts[-1])):
            msp.add_circle(tuple(p), radius=TIE_RADIUS_MM, dxfattribs={"layer": "TIES"})
            node = dash.get(f"{end}_node")
            if node:
                msp.add_text(f"R{node['row']}C{node['col']}", height=TEXT_HEIGHT_MM * 0.5,
                             dxfattribs={"layer": "TIES"}).set_placement((p[0] + 4.0, p[1] - 6.0))


def _align(name: str):
    from ezdxf.enums import TextEntityAlignment

    return getattr(TextEntityAlignment, name)


def _set_extents(dxf, msp) -> None:
    from ezdxf import bbox

    box = bbox.extents(msp, fast=True)
    extmin, extmax = (round(x, 3) for x in box.extmin), (round(x, 3) for x in box.extmax)
    extmin, extmax = tuple(extmin), tuple(extmax)
    msp.dxf.extmin, msp.dxf.extmax = extmin, extmax
    dxf.header["$EXTMIN"], dxf.header["$EXTMAX"] = extmin, extmax


def write_dxf(path, doc: dict) -> None:
    """Write ``pattern.dxf`` from a design document (see :mod:`airmat.design.export.design_json`)."""
    import ezdxf  # here, not at the top: importing the designer must not load ezdxf
    from ezdxf import units

    W, H = doc["mattress"]["width_mm"], doc["mattress"]["height_mm"]
    with _fixed_metadata():
        dxf = ezdxf.new("R2010", setup=False)
        dxf.units = units.MM
        dxf.header["$INSUNITS"] = units.MM
        dxf.header["$MEASUREMENT"] = 1  # metric
        for name, colour in LAYERS.items():
            dxf.layers.add(name, color=colour)
        msp = dxf.modelspace()
        msp.add_text(f"{doc.get('name', '')} {W:.0f} x {H:.0f} mm, {len(doc['dashes'])} strings, lengths l in mm "
                     "(tie to tie)" + ("  UNCALIBRATED" if doc.get("uncalibrated") else ""),
                     height=TEXT_HEIGHT_MM * 1.5, dxfattribs={"layer": "OUTLINE"}).set_placement((0, H + 30))
        for face in ("top", "bottom"):
            _face(msp, doc, face)
        _set_extents(dxf, msp)
        _sorted_classes(dxf)
        buf = io.StringIO()
        dxf.write(buf)
    atomic_write_bytes(path, buf.getvalue().encode("utf-8"))
