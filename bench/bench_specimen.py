"""Benchmark: the simulated specimen's polygon against Equation 3's, over strip lengths and meshes.

Usage::

    .venv/bin/python bench/bench_specimen.py [--series 3,4,5] [--resolutions-mm 20,12.5,10] [--l-over-L 0.4,0.9]
    .venv/bin/python bench/bench_specimen.py --quick     # a smoke run: 3 strings per row, 40 mm, l/L 0.9

Each row is one strip (``n_series`` chained strings per row, rows aligned, L =
300 mm, d = 70 mm, Δ = 0) on one mesh, inflated at one l/L, as ``airmat
validate`` makes it (:func:`airmat.check.validation.validate_equation3`). It gives the
paper's κ₁ (the circle through consecutive folds on the string face) against
Equation 3, and that polygon taken apart: its mean side (fold to fold) against
Equation 3's L* = L − (π − θ) d and its interior angle against θ
(:func:`airmat.check.validation.fold_geometry`), the string face's cross-section
circles (a scan's cylinder fit) over the middle 2L (``airmat validate``'s) and
over the strung length (:func:`airmat.check.validation.section_curvature`,
``span``), and how far the free face turns (a
strip that turns 330° or more would touch itself; the simulation has no
self-contact). Whether κ₁ depends on the strip's length or on the mesh tells a
measurement artefact from the simulator's folds. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from airmat.units import MM  # noqa: E402
from airmat.check.validation import SpecimenLayout, validate_equation3  # noqa: E402


def _floats(text: str) -> list:
    return [float(x) for x in text.split(",") if x.strip()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--series", default="3,4,5", help="strings per row (comma-separated; at least 3)")
    ap.add_argument("--resolutions-mm", default="20", help="mesh edge lengths (comma-separated)")
    ap.add_argument("--l-over-L", dest="ratios", default="0.4,0.9", help="string length ratios (comma-separated)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: 3 strings per row, 40 mm, l/L 0.9")
    args = ap.parse_args(argv)
    if args.quick:
        args.series, args.resolutions_mm, args.ratios = "3", "40", "0.9"
    ratios = _floats(args.ratios)
    print("| strings per row | strip (mm) | mesh (mm) | l/L | κ₁ polygon (1/m) | Equation 3 (1/m) | difference "
          "| side (mm) | L* (mm) | side / L* | angle (°) | θ (°) | sections, middle 2L | sections, strung length "
          "| turn | seconds |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for res in _floats(args.resolutions_mm):
        for n in (int(x) for x in _floats(args.series)):
            layout = SpecimenLayout(n_series=n)
            t0 = time.perf_counter()
            points = validate_equation3(ratios, layout=layout, resolution=res * MM)
            seconds = (time.perf_counter() - t0) / len(points)
            for p in points:
                print(f"| {n} | {layout.width / MM:.0f} | {res:g} | {p.l_over_L:g} | {p.kappa_strings:.2f} "
                      f"| {p.kappa_eq3:.2f} | {100 * (p.kappa_strings / p.kappa_eq3 - 1):+.1f} % "
                      f"| {p.fold_side / MM:.1f} | {p.model_side / MM:.1f} | {p.fold_side / p.model_side:.3f} "
                      f"| {np.degrees(p.fold_angle):.1f} | {np.degrees(p.model_angle):.1f} "
                      f"| {100 * (p.kappa_sim / p.kappa_eq3 - 1):+.1f} % | {100 * (p.kappa_sim_strung / p.kappa_eq3 - 1):+.1f} % "
                      f"| {p.turn_deg:.0f}°{', closes' if p.closes else ''} | {seconds:.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
