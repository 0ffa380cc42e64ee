"""Benchmark: deviation from Ŝ on the named (length-keeping) face against the mid-surface, per preset.

Usage::

    .venv/bin/python bench/bench_surfaces.py                       # the five presets at 20 mm
    .venv/bin/python bench/bench_surfaces.py --large-mm 40         # vault2 and roof at 40 mm
    .venv/bin/python bench/bench_surfaces.py --presets vault1 --resolution-mm 40
    .venv/bin/python bench/bench_surfaces.py --presets vault1 --pattern-mm 300,300,50   # a denser pattern

Each preset is designed in memory with the default pattern and the paper's
calibration values (seed 0, :mod:`designed_preset`), inflated once at the
median string lengths (``airmat.check.inflation_check.check``, ``envelope=False``)
and compared with Ŝ on every face. The named face is the one the check
reports as its headline (the face opposite the larger share of bending, |κ| × span);
``mid`` was the headline before. The curvature columns give, over the dashes
with |κ| ≥ 1 1/m, the median of realized/target on the named face and on the
mid-surface, and the share within 10 % of the target on the named face.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from airmat.units import MM  # noqa: E402
from airmat.check.compare import realized_curvature  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402
from designed_preset import designed_preset  # noqa: E402

LARGE = ("vault2", "roof")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="vault1,saddle,dome,vault2,roof")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--large-mm", type=float, default=None, help="resolution for vault2 and roof (default: same)")
    ap.add_argument("--pattern-mm", default=None, metavar="L,MU1,MU2",
                    help="a denser pattern than the default, e.g. 300,300,50 (DesignParams L, mu1, mu2)")
    args = ap.parse_args(argv)
    print("| preset | res. (mm) | named face | named RMS mm (% diag) | mid RMS mm (% diag) | top RMS mm "
          "| bottom RMS mm | κ real/target, named (median) | mid (median) | |κ|≥1 dashes within 10 % (named) "
          "| seconds |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.presets.split(","):
        t0 = time.perf_counter()
        res = args.large_mm if (name in LARGE and args.large_mm) else args.resolution_mm
        if args.pattern_mm:
            from airmat.design.pipeline import DesignParams, design
            from airmat.design.presets import preset

            L, mu1, mu2 = (float(x) * MM for x in args.pattern_mm.split(","))
            result = design(*preset(name), params=DesignParams(L=L, mu1=mu1, mu2=mu2), progress=False)
        else:
            result = designed_preset(name)
        c = check(result, resolution=res * MM, envelope=False)
        run = c.runs["median"]
        devs = run.deviations
        kappa = np.array([s.kappa for s in result.pattern.strings])
        strong = np.abs(kappa) >= 1.0
        a = np.array([s.dash.a for s in result.pattern.strings]).reshape(-1, 2)
        b = np.array([s.dash.b for s in result.pattern.strings]).reshape(-1, 2)
        k_mid = realized_curvature(run.inflation, a, b, [s.dash.polyline for s in result.pattern.strings], "mid")
        r_named = run.kappa_realized[strong] / kappa[strong]
        r_mid = k_mid[strong] / kappa[strong]
        within = np.mean(np.abs(r_named - 1) <= 0.1) if strong.any() else float("nan")
        med = (lambda r: f"{np.median(r):.2f}" if len(r) else "-")
        f = (lambda d: f"{d.rms / MM:.1f} ({d.rms_pct_diag:.2f} %)")
        print(f"| {name} | {res:g} | {c.surface} | {f(run.deviation)} | {f(devs['mid'])} | {devs['top'].rms / MM:.1f} "
              f"| {devs['bottom'].rms / MM:.1f} | {med(r_named)} | {med(r_mid)} | {within:.0%} of {strong.sum()} "
              f"| {time.perf_counter() - t0:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
