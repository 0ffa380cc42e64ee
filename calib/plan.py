"""Files of a specimen plan (:mod:`airmat.calib.experiment_design`): plan.json, plan.csv, plan.png, the summary.

Lengths in millimetres, the credible area in mm², curvatures in 1/m.
``plan.csv`` has one row per number of added specimens, 0 (now) to N:
``n_added, l_over_L, l_mm, planned_<target>, evenly_spaced_<target>`` with
``<target>`` ``area_mm2`` or ``band_mm``; ``l_over_L`` and ``l_mm`` are the
specimen added in that row (blank in row 0). ``plan.json`` holds the same
with the scans per ratio, the candidates' scores at the first step and the
settings. ``plan.png`` draws the expected target against the number of
added specimens for the plan and for evenly spaced ratios, and the first
step's score of every candidate ratio.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from airmat.atomic import atomic_write_text
from airmat.figures import new_figure, save_png
from airmat.json_doc import dumps, finish
from airmat.units import M_TO_MM

__all__ = ["TARGET_WORDS", "plan_document", "plan_csv", "plan_figure", "summary_text", "write_plan"]

#: target -> (words, unit in files, factor from SI)
TARGET_WORDS = {"area": ("the (Δ, d) 95 % credible area", "mm2", 1e6),
                "band": ("the design strings' mean 95 % length band", "mm", 1e3)}


def _scale(plan):
    words, unit, factor = TARGET_WORDS[plan.target]
    return words, unit, factor


def plan_document(plan, *, calibration: str | None = None, design: str | None = None) -> dict:
    """The plan.json content (mm, mm², 1/m)."""
    words, unit, f = _scale(plan)
    L_mm = plan.L * M_TO_MM
    return finish({
        "calibration": calibration, "design": design, "target": plan.target, "target_words": words,
        "target_unit": unit, "L_mm": L_mm, "kappa_se_per_m": plan.kappa_se, "sigma_per_m": plan.sigma,
        "n_draws": plan.n_draws, "n_sims": plan.n_sims, "seed": plan.seed,
        "now": plan.predicted[0] * f,
        "specimens": [{"order": i + 1, "l_over_L": float(x), "l_mm": round(float(x) * L_mm, 1),
                       "predicted": plan.predicted[i + 1] * f, "effective_draws": float(plan.ess[i])}
                      for i, x in enumerate(plan.l_over_L)],
        "scans": [{"l_over_L": x, "l_mm": round(x * L_mm, 1), "n": n} for x, n in plan.counts.items()],
        "evenly_spaced": {"l_over_L": [float(x) for x in plan.even_l_over_L],
                          "predicted": [float(v) * f for v in plan.even]},
        "candidates": {"l_over_L": [float(x) for x in plan.candidates],
                       "first_step": [float(v) * f for v in plan.scores[0]]},
    })


def plan_csv(doc: dict) -> str:
    """The plan.csv text of a plan.json document."""
    unit = f"{doc['target']}_{doc['target_unit']}"
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["n_added", "l_over_L", "l_mm", f"planned_{unit}", f"evenly_spaced_{unit}"])
    even = doc["evenly_spaced"]["predicted"]
    w.writerow([0, "", "", f"{doc['now']:.4g}", f"{even[0]:.4g}"])
    for s in doc["specimens"]:
        w.writerow([s["order"], f"{s['l_over_L']:g}", f"{s['l_mm']:.1f}", f"{s['predicted']:.4g}",
                    f"{even[s['order']]:.4g}"])
    return buf.getvalue()


def plan_figure(plan):
    """The expected target against added specimens (plan and evenly spaced), and the first step's scores."""
    words, unit, f = _scale(plan)
    label = "mm²" if unit == "mm2" else unit
    fig = new_figure((9.0, 3.6), layout="constrained")
    ax, bx = fig.subplots(1, 2)
    k = np.arange(plan.predicted.size)
    ax.plot(k, plan.predicted * f, "o-", color="tab:blue", label="planned l/L")
    ax.plot(k, plan.even * f, "s--", color="0.45", label="evenly spaced l/L")
    for i, x in enumerate(plan.l_over_L, 1):
        ax.annotate(f"{x:g}", (i, plan.predicted[i] * f), xytext=(0, 6), textcoords="offset points",
                    fontsize=7, ha="center", color="tab:blue")
    ax.set_yscale("log")
    ax.set_xticks(k)
    ax.set_xlabel("specimens added")
    ax.set_ylabel(f"expected {label}")
    ax.set_title(words, fontsize=9)
    ax.legend(fontsize=8)
    bx.plot(plan.candidates, plan.scores[0] * f, "-", color="tab:blue")
    bx.axvline(plan.l_over_L[0], color="tab:red", lw=0.8, ls=":")
    bx.set_xlabel("l/L of the first added specimen")
    bx.set_ylabel(f"expected {label} after it")
    bx.set_title("every candidate, first step", fontsize=9)
    return fig


def summary_text(plan, *, now_words: str = "") -> str:
    """The one-screen summary of a plan (mm, mm², 1/m)."""
    words, unit, f = _scale(plan)
    u = "mm²" if unit == "mm2" else unit
    L_mm = plan.L * M_TO_MM
    lines = [f"airmat plan: {plan.l_over_L.size} more specimens at L = {L_mm:g} mm to shrink {words}",
             f"  now: {plan.predicted[0] * f:.3g} {u}" + (f" ({now_words})" if now_words else ""),
             "  build and scan, in this order (expected after each):"]
    for i, x in enumerate(plan.l_over_L):
        lines.append(f"    {i + 1}. l/L {x:.3f}  l = {x * L_mm:6.1f} mm  -> {plan.predicted[i + 1] * f:.3g} {u}")
    scans = ", ".join(f"{n} at l/L {x:g}" for x, n in plan.counts.items())
    even = ", ".join(f"{x:.3g}" for x in plan.even_l_over_L)
    lines += [f"  scans: {scans}",
              f"  evenly spaced instead (l/L {even}): {plan.even[-1] * f:.3g} {u}; the plan "
              f"{plan.predicted[-1] / plan.even[-1]:.2f} of it",
              f"  (expected over {plan.n_sims} simulated measurements per candidate, {plan.n_draws} posterior "
              f"draws reweighted, {plan.ess.min():.0f} effective at the end; new specimens' error "
              f"{plan.kappa_se:.3g} 1/m, scatter σ {plan.sigma:.3g} 1/m)"]
    return "\n".join(lines)


def write_plan(plan, folder, *, calibration: str | None = None, design: str | None = None) -> list[Path]:
    """Write plan.json, plan.csv and plan.png into ``folder`` (staged by the caller); return the paths."""
    folder = Path(folder)
    doc = plan_document(plan, calibration=calibration, design=design)
    atomic_write_text(folder / "plan.json", dumps(doc))
    atomic_write_text(folder / "plan.csv", plan_csv(doc))
    save_png(plan_figure(plan), folder / "plan.png", dpi=120)
    return [folder / "plan.json", folder / "plan.csv", folder / "plan.png"]
