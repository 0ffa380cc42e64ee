"""Benchmark: the curvature each dash realizes on the named face against its target, per preset.

Usage::

    .venv/bin/python bench/bench_dash_kappa.py [--presets vault1,saddle,dome,vault2,roof] [--resolution-mm 20]
    .venv/bin/python bench/bench_dash_kappa.py --refine     # the same, at the refined lengths
    .venv/bin/python bench/bench_dash_kappa.py --calibrated-map   # checked through the calibrated length map
    .venv/bin/python bench/bench_dash_kappa.py --quick    # a smoke run: vault1 at 40 mm

Each preset is designed with the defaults (paper calibration values, seed 0),
inflated at its median lengths (``airmat.check.inflation_check.check``, no envelope)
and, over the dashes with |κ| >= 1 1/m, the ratio realized / target is
summarized per family: median, 10th and 90th percentiles, and the share of
dashes within 10 %. ``--refine`` first refines the lengths through the inflation
(:func:`airmat.check.refinement.refine`, defaults) and measures the refined design. Two measures of the realized curvature
(:func:`airmat.check.compare.realized_curvature`): the turn of the face's normal
over the dash (the check's) and the circle through its ends and middle.
``--calibrated-map`` checks the open-loop designs with the calibrated length map
(``check(..., calibrated_map=True)``: each real length simulated at the rest length at
which the simulated specimen bends as the calibrated Equation 3 says).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from designed_preset import designed_preset  # noqa: E402
from airmat.check.compare import realized_curvature  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402


def _stats(q) -> str:
    return (f"{np.median(q):.2f} | {np.percentile(q, 10):.2f} – {np.percentile(q, 90):.2f} "
            f"| {100 * np.mean(np.abs(q - 1) <= 0.1):.0f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="vault1,saddle,dome,vault2,roof")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--refine", action="store_true", help="measure the refined designs")
    ap.add_argument("--calibrated-map", action="store_true",
                    help="check through the calibrated length map (open loop only)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm")
    args = ap.parse_args(argv)
    if args.quick:
        args.presets, args.resolution_mm = "vault1", 40.0
    if args.refine and args.calibrated_map:
        ap.error("--calibrated-map measures the open-loop designs; drop --refine")
    print("| preset | family | dashes with \\|κ\\| ≥ 1 | turning: median | p10 – p90 | within 10 % "
          "| circle: median | p10 – p90 | within 10 % |")
    print("|---|---|---:|---:|---|---:|---:|---|---:|")
    for name in args.presets.split(","):
        d = designed_preset(name, refine_at=args.resolution_mm * 1e-3 if args.refine else None)
        c = check(d, resolution=args.resolution_mm * 1e-3, envelope=False, calibrated_map=args.calibrated_map)
        run = c.runs["median"]
        strings = d.pattern.strings
        kappa = np.array([s.kappa for s in strings])
        fam = np.array([s.dash.family for s in strings])
        a = np.array([s.dash.polyline[0] for s in strings])
        b = np.array([s.dash.polyline[-1] for s in strings])
        circle = realized_curvature(run.inflation, a, b, [s.dash.polyline for s in strings], c.surface,
                                    method="circle")
        for f in ("k1", "k2"):
            m = (np.abs(kappa) >= 1.0) & (fam == f)
            if not m.any():
                continue
            print(f"| {name} | {f} | {m.sum()} | {_stats(run.kappa_realized[m] / kappa[m])} "
                  f"| {_stats(circle[m] / kappa[m])} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
