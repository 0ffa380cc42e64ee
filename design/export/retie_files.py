"""Files of a re-tie list (:mod:`airmat.design.retie`): ``retie.json``, ``retie.csv``, ``retie.png`` (mm).

``retie.csv`` has one row per string, in workshop order (keep, recut, move,
remove, add): ``action, face, id_a, id_b, nodes_a, nodes_b, l_a_mm, l_b_mm,
dl_mm, move_mm``; nodes as ``R<row>C<col>-R<row>C<col>``, ``l_b_mm`` the
length to cut, ``dl_mm`` its change (B − A), ``move_mm`` how far the two ends
move together. ``retie.json`` holds the same rows with the counts and the
cut tolerance. ``retie.png`` draws both faces on Ω, one colour per category:
kept strings grey, re-cut blue, moved ones from their old place (dotted) to
their new one (orange), removed red, added green.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from airmat.atomic import atomic_write_text
from airmat.design.retie import ACTIONS, LABELS, counts_text
from airmat.figures import new_figure, save_png
from airmat.json_doc import dumps, finish
from airmat.units import M_TO_MM

__all__ = ["retie_document", "retie_csv", "retie_figure", "write_retie", "CSV_COLUMNS", "COLOURS"]

CSV_COLUMNS = ("action", "face", "id_a", "id_b", "nodes_a", "nodes_b", "l_a_mm", "l_b_mm", "dl_mm", "move_mm")
#: colour of each category in retie.png
COLOURS = {"keep": "0.6", "recut": "tab:blue", "move": "tab:orange", "remove": "tab:red", "add": "tab:green"}


def _nodes(s) -> str:
    if s is None or s.dash.a_node is None or s.dash.b_node is None:     # no string, or one not tied to the grid
        return ""
    return f"R{s.dash.a_node[0]}C{s.dash.a_node[1]}-R{s.dash.b_node[0]}C{s.dash.b_node[1]}"


def _mm(x: float):
    return None if math.isnan(x) else round(x * M_TO_MM, 2)


def _row(step) -> dict:
    a, b = step.a, step.b
    return {"action": step.action, "face": step.face, "id_a": a.dash.id if a else None,
            "id_b": b.dash.id if b else None, "nodes_a": _nodes(a) or None, "nodes_b": _nodes(b) or None,
            "l_a_mm": round(a.l_median * M_TO_MM, 2) if a else None,
            "l_b_mm": round(b.l_median * M_TO_MM, 2) if b else None,
            "dl_mm": _mm(step.dl), "move_mm": _mm(step.move)}


def retie_document(plan, *, design_a: str, design_b: str) -> dict:
    """The retie.json content: cut tolerance, counts and one entry per string (mm); null where a field
    does not apply."""
    return finish({"design_a": design_a, "design_b": design_b,
                   "cut_tolerance_mm": round(plan.cut_tolerance * M_TO_MM, 6),
                   "counts": plan.counts, "steps": [_row(s) for s in plan.steps]})


def retie_csv(doc: dict) -> str:
    """The retie.csv text of a retie.json document (blank where JSON has null)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for r in doc["steps"]:
        w.writerow(["" if r[k] is None else (f"{r[k]:.2f}" if k.endswith("_mm") else r[k]) for k in CSV_COLUMNS])
    return buf.getvalue()


def _draw_face(ax, plan, face: str, W: float, H: float) -> None:
    ax.plot([0, W, W, 0, 0], [0, 0, H, H, 0], color="black", lw=0.8)
    for step in (s for s in plan.steps if s.face == face):
        colour = COLOURS[step.action]
        if step.action == "move":
            p = step.a.dash.polyline * M_TO_MM
            ax.plot(p[:, 0], p[:, 1], color=colour, lw=1.2, ls=":")
        s = step.b if step.b is not None else step.a
        p = s.dash.polyline * M_TO_MM
        ax.plot(p[:, 0], p[:, 1], color=colour, lw=1.6 if step.action == "keep" else 2.4)
        ax.plot(p[[0, -1], 0], p[[0, -1], 1], "o", color="black", ms=2.5)
        label = s.dash.id if step.action != "recut" else f"{s.dash.id} {step.dl * M_TO_MM:+.1f}"
        ax.annotate(label, p[len(p) // 2], xytext=(0, 4), textcoords="offset points", fontsize=6, ha="center")
    ax.set_aspect("equal")
    ax.set_xlim(-0.03 * W, 1.03 * W)
    ax.set_ylim(-0.03 * H, 1.03 * H)
    ax.set_xlabel("u (mm)")
    ax.set_ylabel("v (mm)")
    ax.set_title(f"{face} face (seen from above, Ω coordinates)", fontsize=9)


def retie_figure(plan, *, width: float, height: float):
    """Both faces on Ω (mm), one colour per category; returns a ``matplotlib.figure.Figure``.

    ``width``, ``height``: the mattress (m). Re-cut strings carry their length change (mm).
    """
    fig = new_figure((14, 6.5))
    W, H = width * M_TO_MM, height * M_TO_MM
    for ax, face in zip(fig.subplots(1, 2), ("top", "bottom")):
        _draw_face(ax, plan, face, W, H)
    for action in ACTIONS:
        fig.axes[0].plot([], [], color=COLOURS[action], lw=2, label=f"{LABELS[action]} ({plan.count(action)})")
    fig.axes[0].plot([], [], color=COLOURS["move"], lw=1.2, ls=":", label="moved: old place")
    fig.axes[0].legend(fontsize=7, loc="upper right")
    fig.suptitle(f"airmat retie: {counts_text(plan.counts)} (cut tolerance {plan.cut_tolerance * M_TO_MM:g} mm)",
                 fontsize=11)
    fig.tight_layout()
    return fig


def write_retie(folder, plan, *, design_a: str, design_b: str, width: float, height: float) -> dict:
    """Write retie.json, retie.csv and retie.png into ``folder``; return the JSON document.

    ``width``, ``height``: the mattress (m), for the figure's frame.
    """
    folder = Path(folder)
    doc = retie_document(plan, design_a=design_a, design_b=design_b)
    atomic_write_text(folder / "retie.json", dumps(doc, indent=1) + "\n")
    atomic_write_text(folder / "retie.csv", retie_csv(doc))
    save_png(retie_figure(plan, width=width, height=height), folder / "retie.png", dpi=100)
    return doc
