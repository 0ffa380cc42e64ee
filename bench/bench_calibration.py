"""Benchmark the calibration: end to end on synthetic scans, and Equation 3 vectorized vs scalar.

1. Writes a synthetic calibration set once (``airmat.synthetic.calibration_set``:
   by default 12 specimens of 100k points), then times ``airmat.calib.calibrate``
   end to end, split into reading the scans, fitting the cylinders, MCMC and
   the curve, and reports the recovered Delta, d against the truth.
2. Times ``airmat.calib.model.kappa1`` on n random (l, L, Delta, d) in one call
   against a per-element scalar root solve (``scipy.optimize.brentq`` in a
   Python loop) on the same inputs, and checks they agree.

Prints Markdown tables. Usage::

    .venv/bin/python bench/bench_calibration.py                  # the full benchmark
    .venv/bin/python bench/bench_calibration.py --points 20000 --model-n 2000   # smaller
    .venv/bin/python bench/bench_calibration.py --quick     # a smoke run: 4 specimens x 20000 points, 300 MCMC steps
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from airmat.calib.calibrate import calibrate  # noqa: E402
from airmat.calib.model import kappa1  # noqa: E402
from airmat.synthetic.calibration_set import DEFAULT_L_OVER_L, calibration_set  # noqa: E402


def kappa1_scalar(l: float, L: float, delta: float, d: float) -> float:
    """Equation 3 for one string with a scalar bracketed root solve (the baseline)."""
    from scipy.optimize import brentq

    lstar = l + 2.0 * delta
    if lstar >= L:
        return 0.0
    lo = max(math.pi - L / d, 0.0)
    theta = brentq(lambda t: (L - (math.pi - t) * d) * math.sin(t / 2.0) - lstar, lo, math.pi,
                   xtol=1e-14, rtol=4 * np.finfo(float).eps)
    return 2.0 * math.cos(theta / 2.0) / (L - (math.pi - theta) * d)


def bench_model(n: int, seed: int, repeats: int) -> list[tuple]:
    rng = np.random.default_rng(seed)
    L = rng.uniform(0.2, 0.4, n)
    l = rng.uniform(0.0, 1.0, n) * L
    delta = rng.uniform(0.0, 0.04, n)
    d = rng.uniform(0.03, 0.12, n)
    t_vec = min(_timed(lambda: kappa1(l, L, delta, d)) for _ in range(repeats))
    k_vec = kappa1(l, L, delta, d)
    t0 = time.perf_counter()
    k_loop = np.array([kappa1_scalar(*x) for x in zip(l, L, delta, d)])
    t_loop = time.perf_counter() - t0
    err = float(np.max(np.abs(k_vec - k_loop) / np.maximum(np.abs(k_loop), 1.0)))
    # the MCMC-shaped batch: half an ensemble of 32 walkers x 12 specimens, per call
    lw, Lw = rng.uniform(0.09, 0.285, (1, 12)), 0.3
    dw, ddw = rng.uniform(0.015, 0.02, (16, 1)), rng.uniform(0.06, 0.08, (16, 1))
    t_batch = min(_timed(lambda: kappa1(lw, Lw, dw, ddw)) for _ in range(20 * repeats))
    return [(n, t_vec, t_loop, t_loop / t_vec, err, t_batch)]


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def bench_calibration(points: int, n_specimens: int, seed: int, folder: Path, max_steps: int = 4000) -> dict:
    ratios = DEFAULT_L_OVER_L if n_specimens == 12 else np.round(np.linspace(0.3, 0.95, n_specimens), 4)
    t0 = time.perf_counter()
    cs = calibration_set(folder, l_over_L=ratios, n_points=points, seed=seed)
    t_synth = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    cal = calibrate(cs.manifest, seed=seed, max_steps=max_steps)
    total, cpu = time.perf_counter() - t0, time.process_time() - c0
    return dict(cal=cal, truth=cs.truth, total=total, cpu=cpu, synth=t_synth)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=100_000, help="points per scan (default 100000)")
    ap.add_argument("--specimens", type=int, default=12, help="specimens (default 12)")
    ap.add_argument("--model-n", type=int, default=10_000, help="elements of the model comparison")
    ap.add_argument("--repeats", type=int, default=3, help="repeats of the vectorized timing (best of)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-steps", type=int, default=4000, help="cap of the MCMC chain (calibrate's max_steps)")
    ap.add_argument("--skip-calibration", action="store_true", help="only the model comparison")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: 4 specimens x 20000 points, 300 MCMC steps (not converged), 1000 elements")
    args = ap.parse_args(argv)
    if args.quick:
        args.points, args.specimens, args.model_n, args.repeats, args.max_steps = 20000, 4, 1000, 1, 300

    print("## Equation 3: vectorized `kappa1` vs scalar `brentq` loop\n")
    print("| n | vectorized (s) | brentq loop (s) | speed-up | max rel. diff | one (16 x 12) MCMC call (ms) |")
    print("|---|---|---|---|---|---|")
    for n, tv, tl, sp, err, tb in bench_model(args.model_n, args.seed, args.repeats):
        print(f"| {n} | {tv:.4f} | {tl:.3f} | {sp:.0f}x | {err:.1e} | {tb * 1e3:.2f} |")

    if args.skip_calibration:
        return 0
    with tempfile.TemporaryDirectory(prefix="bench_calibration_") as tmp:
        r = bench_calibration(args.points, args.specimens, args.seed, Path(tmp) / "set", args.max_steps)
    cal, truth, t = r["cal"], r["truth"], r["cal"].timings
    p = cal.posterior
    print(f"\n## Calibration end to end: {args.specimens} specimens x {args.points} points\n")
    print("| step | seconds |")
    print("|---|---|")
    print(f"| (writing the synthetic set, not timed below) | {r['synth']:.2f} |")
    for k in ("read", "fit", "mcmc", "curve"):
        print(f"| {k} | {t[k]:.2f} |")
    print(f"| **total `calibrate`** | **{r['total']:.2f}** |")
    print(f"| (CPU time of this process during `calibrate`, all threads) | {r['cpu']:.2f} |")
    if hasattr(os, "getloadavg"):
        print(f"\nload average during the run: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores "
              "(wall times grow with the load of a shared machine)")
    print(f"\nMCMC: {p.n_walkers} walkers x {p.n_steps} steps, tau {np.round(p.tau, 1).tolist()}, "
          f"acceptance {p.acceptance_fraction:.2f}, converged {p.converged}\n")
    print("| parameter | truth | median | 95% interval | inside |")
    print("|---|---|---|---|---|")
    for name, s, scale, true in (("Delta (mm)", p.delta, 1e3, truth["delta_mm"]),
                                 ("d (mm)", p.d, 1e3, truth["d_mm"]),
                                 ("sigma (1/m)", p.sigma, 1.0, truth["sigma_per_m"])):
        lo, hi = s.lo95 * scale, s.hi95 * scale
        print(f"| {name} | {true:.3f} | {s.median * scale:.3f} | {lo:.3f} .. {hi:.3f} | "
              f"{'yes' if lo <= true <= hi else 'NO'} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
