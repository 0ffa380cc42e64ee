"""Benchmark: how the seed-stability check's tolerance grows as its check fits get fewer points.

airmat.calib.cylinder_stability compares the main fit's kappa with check fits from
other seeds on random subsets; they agree when ``|dkappa| <= 3 hypot(se_main,
se_check)``. That tolerance is the smallest seed disagreement the check
notices. For synthetic specimen scans (airmat.synthetic.specimen_scan: floor,
clutter, holes, grooves, random pose) of N points, each subset size n gets
``--seeds`` check fits (different subsets and seeds): median time of one
check fit, the standard deviation of their kappas, the median standard error
and tolerance (all % of kappa), and the largest ``|dkappa| / tolerance`` (a
value above 1 would widen kappa_se on a clean scan).

Run:  .venv/bin/python bench/bench_check_subset.py --n 1280000 --subsets 50000,25000,20000 --seeds 10
      .venv/bin/python bench/bench_check_subset.py --n 100000 --subsets 50000 --seeds 10
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from airmat.calib.cylinder_fit import fit_cylinder  # noqa: E402
from airmat.synthetic.specimen_scan import specimen_scan  # noqa: E402

#: (kappa 1/m, visible arc degrees) of the specimens
CASES = ((5.0, 90.0), (2.0, 60.0), (10.0, 120.0))


def rows(n_points, subsets, n_seeds):
    """[(kappa, arc, n_points, n, time s, sd %, se %, tol %, max d/tol)] over CASES and subset sizes."""
    out = []
    for kappa, arc in CASES:
        scan = specimen_scan(kappa, n_points=n_points, arc_deg=arc, seed=0)
        main = fit_cylinder(scan.points, seed=0)
        for n in subsets:
            ks, ses, ts = [], [], []
            for s in range(n_seeds):
                sub = scan.points[np.random.default_rng(1000 + s).choice(n_points, n, replace=False)]
                t0 = time.perf_counter()
                fit = fit_cylinder(sub, seed=1000 + s)
                ts.append(time.perf_counter() - t0)
                ks.append(fit.kappa)
                ses.append(fit.kappa_se)
            ks, ses = np.array(ks), np.array(ses)
            tol = 3 * np.hypot(main.kappa_se, ses)
            pct = 100 / kappa
            out.append((kappa, arc, n_points, n, float(np.median(ts)), ks.std(ddof=1) * pct,
                        float(np.median(ses)) * pct, float(np.median(tol)) * pct,
                        float(np.max(np.abs(ks - main.kappa) / tol))))
    return out


def markdown(table, n_seeds):
    head = (f"Check fits on subsets of synthetic specimen scans, {n_seeds} subsets and seeds each "
            "(% of kappa; tolerance = 3 hypot(se_main, se_check))\n\n"
            "| kappa (1/m) | arc (deg) | scan points | check points | time per check (s) | sd of kappa (%) "
            "| se (%) | tolerance (%) | max dkappa / tolerance |\n"
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n")
    return head + "".join(f"| {k:g} | {a:g} | {N:,} | {n:,} | {t:.3f} | {sd:.4f} | {se:.4f} | {tol:.4f} | {r:.2f} |\n"
                          for k, a, N, n, t, sd, se, tol, r in table)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=1_280_000, help="points of each scan")
    p.add_argument("--subsets", default="50000,25000,20000", help="check-fit subset sizes, comma-separated")
    p.add_argument("--seeds", type=int, default=10, help="check fits per subset size")
    args = p.parse_args(argv)
    print(markdown(rows(args.n, [int(s) for s in args.subsets.split(",")], args.seeds), args.seeds))


if __name__ == "__main__":
    main()
