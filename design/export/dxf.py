"""``pattern.dxf``: the string pattern for CAD and cutting plotters (ezdxf, units mm).

Coordinates are Ω's (u, v) in millimetres for **both** faces (the bottom
face is *not* mirrored here: a CAD user mirrors with one command; the SVG
shows the mirrored view). Layers: ``TOP_K1``, ``TOP_K2``, ``BOTTOM_K1``,
``BOTTOM_K2`` (one LWPOLYLINE per string along its dash, and a TEXT with
its id) and ``OUTLINE`` (the mattress rectangle). ``$INSUNITS`` = mm.
ezdxf's fixed-metadata switch is on while writing, so the same design gives
the same bytes (no creation timestamps or random GUIDs).
"""

from __future__ import annotations

import contextlib
import io

from airmat.atomic import atomic_write_bytes

__all__ = ["write_dxf", "LAYERS"]

#: layer name -> AutoCAD colour index
LAYERS = {"OUTLINE": 7, "TOP_K1": 1, "TOP_K2": 5, "BOTTOM_K1": 30, "BOTTOM_K2": 4}
TEXT_HEIGHT_MM = 8.0


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


def write_dxf(path, doc: dict) -> None:
    """Write ``pattern.dxf`` from a design document (see :mod:`design.export.design_json`)."""
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
        msp.add_lwpolyline([(0, 0), (W, 0), (W, H), (0, H)], close=True, dxfattribs={"layer": "OUTLINE"})
        msp.add_text(f"{doc.get('name', '')} {W:.0f} x {H:.0f} mm" +
                     ("  UNCALIBRATED" if doc.get("uncalibrated") else ""),
                     height=TEXT_HEIGHT_MM * 1.5, dxfattribs={"layer": "OUTLINE"}).set_placement((0, H + 10))
        for dash in doc["dashes"]:
            layer = layer_name(dash["side"], dash["family"])
            pts = [tuple(p) for p in dash["polyline_mm"]]
            msp.add_lwpolyline(pts, dxfattribs={"layer": layer})
            mid = pts[len(pts) // 2]
            msp.add_text(dash["id"], height=TEXT_HEIGHT_MM,
                         dxfattribs={"layer": layer}).set_placement((mid[0], mid[1] + 3))
        buf = io.StringIO()
        dxf.write(buf)
    atomic_write_bytes(path, buf.getvalue().encode("utf-8"))
