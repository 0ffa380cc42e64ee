"""``cutting_list.csv``: one row per string, sorted for the workshop (face, family, id).

Columns: ``id, face, family, l_median_mm, l_lo95_mm, l_hi95_mm, kappa_per_m, L_mm,
a_u_mm, a_v_mm, b_u_mm, b_v_mm, a_node, b_node, flags``. Cut each string to ``l_median_mm``
(the tie-to-tie length); the 95 % interval is the tolerance from the
calibration. ``a``/``b`` are the tie points on Ω (mm); ``a_node``/``b_node`` the
grid nodes they are tied to as ``R<row>C<col>`` (node at u = col · g, v = row · g;
empty for free ends).
"""

from __future__ import annotations

import csv
import io

from airmat.atomic import atomic_write_text

__all__ = ["write_cutting_list", "node_label", "COLUMNS"]

COLUMNS = ("id", "face", "family", "l_median_mm", "l_lo95_mm", "l_hi95_mm", "kappa_per_m", "L_mm",
           "a_u_mm", "a_v_mm", "b_u_mm", "b_v_mm", "a_node", "b_node", "flags")


def node_label(node) -> str:
    """``R12C7`` for the node {row: 12, col: 7} of design.json; "" for a free end (None)."""
    return "" if not node else f"R{node['row']}C{node['col']}"


def write_cutting_list(path, doc: dict) -> None:
    """Write ``cutting_list.csv`` from a design document (see :mod:`airmat.design.export.design_json`)."""
    rows = sorted(doc["dashes"], key=lambda d: (d["side"], d["family"], d["id"]))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for d in rows:
        w.writerow([d["id"], d["side"], d["family"], f"{d['l_mm']['median']:.2f}", f"{d['l_mm']['lo95']:.2f}",
                    f"{d['l_mm']['hi95']:.2f}", f"{d['kappa_per_m']:.4f}", f"{d['L_mm']:.2f}",
                    f"{d['a_mm'][0]:.2f}", f"{d['a_mm'][1]:.2f}", f"{d['b_mm'][0]:.2f}", f"{d['b_mm'][1]:.2f}",
                    node_label(d.get("a_node")), node_label(d.get("b_node")), ";".join(d["flags"])])
    atomic_write_text(path, buf.getvalue())
