"""Benchmark: the inflation check (median, lo95, hi95 runs) one after the other vs in worker processes.

Usage::

    .venv/bin/python bench/bench_check.py            # vault1 (small) and vault2 (large) at 20 mm
    .venv/bin/python bench/bench_check.py --quick    # a smoke run: vault1 at 40 mm

``airmat.check.inflation_check.check`` with ``workers=1`` (the three runs in
this process, the baseline) and ``workers=2`` (what ``airmat inflate`` uses on
a 2-core machine: ``--jobs`` defaults to the cores, at most 3). The sparse
Cholesky is serial, so the runs can share the cores. The table also checks
that both give the same shapes (largest vertex difference).
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
from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm only")
    ap.add_argument("--workers", type=int, default=2, help="processes of the parallel row (default 2)")
    args = ap.parse_args(argv)
    cases = [("vault1", 40.0)] if args.quick else [("vault1", 20.0), ("vault2", 20.0)]
    print("| preset | mattress (mm) | resolution (mm) | runs | one after the other (s) "
          f"| {args.workers} processes (s) | speed-up | largest vertex difference (mm) |")
    print("|---|---|---|---|---|---|---|---|", flush=True)
    for preset, res in cases:
        design = designed_preset(preset)
        times, checks = [], []
        for workers in (1, args.workers):
            t0 = time.perf_counter()
            checks.append(check(design, resolution=res * MM, workers=workers))
            times.append(time.perf_counter() - t0)
        diff = max(float(np.abs(checks[0].runs[k].inflation.xyz - checks[1].runs[k].inflation.xyz).max())
                   for k in checks[0].runs)
        print(f"| {preset} | {design.mattress.width / MM:.0f} x {design.mattress.height / MM:.0f} | {res:g} "
              f"| {len(checks[0].runs)} | {times[0]:.1f} | {times[1]:.1f} | {times[0] / times[1]:.2f}x "
              f"| {diff / MM:.1e} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
