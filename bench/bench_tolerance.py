"""Benchmark: the linearized tolerance (airmat.tolerance) against a K-sample Monte-Carlo, side by side.

Usage::

    .venv/bin/python bench/bench_tolerance.py                        # vault1 and saddle at 20 mm, K = 256
    .venv/bin/python bench/bench_tolerance.py --presets vault1 --resolution-mm 40 --samples 64   # a shared machine
    .venv/bin/python bench/bench_tolerance.py --quick                # a smoke run: vault1 at 60 mm, K = 4

Per preset (designed with the paper's calibration values, seed 0, and a stated nominal scatter
``--sigma-per-m``, as ``bench_monte_carlo.py``): one check with K Monte-Carlo samples
(:func:`airmat.check.inflation_check.check`, seed 0; its median run is the linear model's
equilibrium too), then :func:`airmat.check.tolerance.tolerance` on that check (``--validate`` full
samples in antithetic pairs, seed 1, which also give the model's mean shift). Columns:

- times: the K runs (summed inside the runs), the median run (one inflation), the linear model
  (Jacobian, covariance, model draws) and its validation runs (wall), and linear + validation over
  one inflation;
- the validation's spread error (the verdict's measure) and its per-sample displacement error
  (``LinearTolerance.validation``);
- the median over Ŝ's vertices of |q95_linear / q95_MC − 1|, the per-vertex 95 % quantile of the
  distance from Ŝ; for scale, the same statistic's sampling error at K (one quantile's relative
  standard error sqrt(0.95 · 0.05 / K) / (2 φ(1.96) · 1.96) for a one-mode Gaussian deviation);
- the RMS median and 95th percentile, linear / MC (mm), and P(RMS <= T) both ways with T the
  MC's median RMS rounded to 0.1 mm (where a probability is most sensitive), the linear one with the
  standard error of its sampled mean shift, the MC's with its binomial standard error; and the linear
  P's mean and standard deviation over the validation seeds 1..``--seeds`` (the mean shift is sampled).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from airmat.check.tolerance_validation import VALIDATION_SAMPLES  # noqa: E402
from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402


def row(preset: str, resolution: float, k: int, validate: int, sigma: float, workers: int, seeds: int) -> str:
    from scipy.stats import norm

    from airmat.check.inflation_check import check
    from airmat.check.tolerance import tolerance

    design = designed_preset(preset)
    cal = design.calibration
    design = replace(design, calibration=replace(cal, sigma=np.full(cal.n_samples, sigma)))
    t0 = time.perf_counter()
    run = check(design, resolution=resolution, envelope=False, samples=k, seed=0, workers=workers)
    t_check = time.perf_counter() - t0
    mc = run.monte_carlo
    t_med = run.runs["median"].inflation.seconds
    T = round(float(np.median(mc.rms)) / MM, 1) * MM
    lin = tolerance(design, run=run, validate=validate, seed=1, tolerance=T, workers=workers)
    mst, lst = replace(mc, tolerance=T).stats(), lin.stats()
    rel = float(np.median(np.abs(lin.per_vertex_q[1] / np.maximum(mc.per_vertex_q[1], 1e-12) - 1)))
    rel_se = np.sqrt(0.95 * 0.05 / k) / (2 * norm.pdf(1.96) * 1.96)
    ps = [lin.stats()["p_within"]] + [tolerance(design, run=run, validate=validate, seed=s, tolerance=T,
                                                 workers=workers).stats()["p_within"] for s in range(2, seeds + 1)]
    v = lin.validation
    if v is None:
        val, p_se, total = "n/a", "", lin.seconds
    else:
        val = (f"{100 * v.spread_error:+.1f} % / {100 * v.relative_error:.0f} % ({v.samples}, {v.seconds:.1f} s)")
        p_se = "" if v.p_within_se is None else f" ± {v.p_within_se:.2f}"
        total = lin.seconds + v.seconds
    return (f"| {preset} | {resolution / MM:g} | {len(lin.ids)} | {k} | {mc.seconds:.1f} ({t_check:.1f} wall) "
            f"| {t_med:.1f} | {lin.seconds:.2f} | {val} | {total / t_med:.1f}x "
            f"| {100 * rel:.1f} % (sampling {100 * rel_se:.0f} %) "
            f"| {lst['rms_median'] / MM:.2f} / {mst['rms_median'] / MM:.2f} | {lst['rms_p95'] / MM:.2f} / "
            f"{mst['rms_p95'] / MM:.2f} | {T / MM:.1f}: {lst['p_within']:.2f}{p_se} / {mst['p_within']:.2f} "
            f"± {mst['p_within_se']:.2f} | {np.mean(ps):.2f} ± {np.std(ps, ddof=1) if len(ps) > 1 else 0:.2f} "
            f"| {lin.reliable} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=["vault1", "saddle"])
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--samples", type=int, default=256, help="Monte-Carlo samples K")
    ap.add_argument("--validate", type=int, default=VALIDATION_SAMPLES,
                    help="full samples (antithetic pairs: even) that check the model and give its mean shift")
    ap.add_argument("--seeds", type=int, default=8,
                    help="validation seeds 1..N whose P(RMS <= T) the last column summarizes (the shift is sampled)")
    ap.add_argument("--sigma-per-m", type=float, default=0.3, help="nominal scatter sigma (1/m), stated")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes of the inflations")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 60 mm, K = 4, 2 validation samples")
    args = ap.parse_args(argv)
    if args.quick:
        args.presets, args.resolution_mm, args.samples, args.validate, args.seeds = ["vault1"], 60.0, 4, 2, 2
    logging.getLogger().setLevel(logging.WARNING)
    print(f"linear tolerance against {args.samples} Monte-Carlo samples at {args.resolution_mm:g} mm, "
          f"sigma {args.sigma_per_m:g} 1/m (nominal), {args.validate} validation samples")
    print("| preset | mesh (mm) | strings | K | MC runs (s) | one inflation (s) | linear (s) "
          "| validation: spread / per-sample error (samples, s) | linear + validation / one inflation "
          "| 95 % band: median rel. diff | RMS median lin / MC (mm) | RMS p95 lin / MC (mm) "
          f"| T (mm): P(RMS <= T) lin / MC | P lin over validation seeds 1-{args.seeds}: mean ± sd | reliable |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.presets:
        print(row(name, args.resolution_mm * MM, args.samples, args.validate, args.sigma_per_m, args.jobs, args.seeds),
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
