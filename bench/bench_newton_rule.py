"""Benchmark: one inflation per preset under the Newton method's two rules for a refused step, in one run.

Usage::

    .venv/bin/python bench/bench_newton_rule.py                  # every preset at 20 mm
    .venv/bin/python bench/bench_newton_rule.py --presets vault1 vault2 --resolution 25
    .venv/bin/python bench/bench_newton_rule.py --quick          # a smoke run: vault1 at 40 mm

A step of the trust-region Newton method (:func:`airmat.inflation.solver.solve`) that does not
lower U_B is either retried with a larger shift (``"shift"``: a new Cholesky factorization, the
shift ×4) or halved along the same direction (``"backtrack"``: no new
factorization, the shift ×2 for the next iteration: the check's inflations). Each
preset's open-loop design (paper calibration, seed 0) is inflated from the flat mattress under
both rules, one after the other; the table gives their times, Newton iterations, residuals and
the largest distance between the two equilibria's vertices (the same rigid pins: no alignment).
Targets: small mattress ≤ 2 s, large ≤ 10 s at 20 mm, the same equilibrium within 0.1 mm.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from inflation_target import SAME_MM, largest_gap_mm, seconds_target  # noqa: E402
from airmat.check.inflation_check import design_strings  # noqa: E402
from airmat.inflation.mesh import build_mattress_mesh  # noqa: E402
from airmat.inflation.simulate import inflate  # noqa: E402

RULES = {"today (shift ×4)": ("shift", 4.0), "backtrack ×2": ("backtrack", 2.0)}
PRESETS = ("vault1", "saddle", "dome", "vault2", "roof")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=list(PRESETS), choices=PRESETS)
    ap.add_argument("--resolution", type=float, default=20.0, help="mesh edge length (mm, default 20)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm")
    args = ap.parse_args(argv)
    presets, res = (["vault1"], 40.0) if args.quick else (args.presets, args.resolution)
    names = list(RULES)
    print("| preset | mattress (mm) | resolution (mm) | vertices | " + " | ".join(
        f"{n}: s | {n}: iterations | {n}: residual" for n in names)
          + " | speed-up | max vertex distance (mm) | target (s) | met |")
    print("|---|---|---|---|" + "---|---|---|" * len(names) + "---|---|---|---|")
    for preset in presets:
        design = designed_preset(preset)
        strings = design_strings(design)
        m = design.mattress
        mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=res * MM)
        runs = {}
        for name, rule in RULES.items():
            t0 = time.perf_counter()
            runs[name] = (inflate(mesh, strings, rule=rule), time.perf_counter() - t0)
        (a, ta), (b, tb) = runs[names[0]], runs[names[1]]
        gap, target = largest_gap_mm(a, b), seconds_target(m)
        cells = " | ".join(f"{t:.1f} | {r.n_iter} | {r.residual:.1e}" for r, t in runs.values())
        print(f"| {preset} | {m.width / MM:.0f} x {m.height / MM:.0f} | {res:g} | {mesh.n_vertices} | {cells} "
              f"| {ta / tb:.2f}x | {gap:.4f} | {target:g} | {'yes' if tb <= target and gap <= SAME_MM else 'no'} |",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
