"""Benchmark the specimen plan: does adding specimens at the planned l/L shrink (Delta, d) more than evenly spaced?

Synthetic truth Delta = 18 mm, d = 70 mm, L = 300 mm, specimen scatter sigma and fit error s
(1/m). For each seed: a starting calibration of 4 specimens at clustered l/L (curvatures drawn
from the posterior's own model, ``|kappa1 + Normal(0, s**2 + sigma**2)|``, straight into
:func:`airmat.calib.posterior.specimen_data`, no scans), its posterior by emcee
(:func:`airmat.calib.posterior.sample_posterior`, a short run), the plan of N more
(:func:`airmat.calib.experiment_design.plan_specimens`), then N new specimens measured at the
truth once at the planned ratios and once at N evenly spaced ones (the i-th new specimen of both
draws the same noise), and the posterior re-sampled for each. The measured figure is the 95 %
credible area of (Delta, d) (:func:`airmat.calib.experiment_design.credible_area`, mm²).

Prints Markdown tables. Usage::

    .venv/bin/python bench/bench_plan.py                 # 10 seeds, N = 4
    .venv/bin/python bench/bench_plan.py --seeds 3       # the test's size
    .venv/bin/python bench/bench_plan.py --quick         # a smoke run: 2 seeds, short chains
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from airmat.calib.experiment_design import credible_area, plan_specimens  # noqa: E402
from airmat.calib.model import kappa1  # noqa: E402
from airmat.calib.posterior import sample_posterior, specimen_data  # noqa: E402
from airmat.constants import PAPER_D, PAPER_DELTA, PAPER_L  # noqa: E402

START = (0.55, 0.60, 0.65, 0.70)


def measure(x, noise, *, sigma: float, se: float):
    """Curvatures (1/m) of specimens at ratios x, at the truth, with standard-normal noise draws."""
    x = np.asarray(x, float)
    return np.abs(kappa1(x * PAPER_L, PAPER_L, PAPER_DELTA, PAPER_D) + noise * np.hypot(se, sigma))


def area_after(x, k, *, se: float, max_steps: int, seed: int) -> float:
    """95 % credible area (mm²) of (Delta, d) from the posterior of specimens at ratios x with curvatures k."""
    x = np.asarray(x, float)
    post = sample_posterior(specimen_data(k, se, x * PAPER_L, PAPER_L), max_steps=max_steps, tau_multiple=20.0,
                            seed=seed)
    return float(credible_area(post.samples[:, :2])) * 1e6, post


def one_seed(seed: int, *, n_add: int, sigma: float, se: float, max_steps: int, n_draws: int) -> dict:
    rng = np.random.default_rng(seed)
    start_noise, new_noise = rng.standard_normal(len(START)), rng.standard_normal(n_add)
    k0 = measure(START, start_noise, sigma=sigma, se=se)
    area0, post = area_after(START, k0, se=se, max_steps=max_steps, seed=seed)
    t0 = time.perf_counter()
    plan = plan_specimens(post.samples, L=PAPER_L, n_add=n_add, kappa_se=se, n_draws=n_draws, seed=seed)
    t_plan = time.perf_counter() - t0
    row = {"seed": seed, "start": area0, "plan": plan, "t_plan": t_plan}
    for name, x in (("planned", plan.l_over_L), ("even", plan.even_l_over_L)):
        xs = np.concatenate([START, x])
        k = np.concatenate([k0, measure(x, new_noise, sigma=sigma, se=se)])
        row[name], _ = area_after(xs, k, se=se, max_steps=max_steps, seed=seed)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0 ... n-1 (default 10)")
    ap.add_argument("--n-add", type=int, default=4, help="specimens added (default 4)")
    ap.add_argument("--sigma", type=float, default=0.10, help="true specimen scatter (1/m, default 0.10)")
    ap.add_argument("--se", type=float, default=0.03, help="cylinder fit standard error (1/m, default 0.03)")
    ap.add_argument("--max-steps", type=int, default=1000, help="emcee steps per run (default 1000)")
    ap.add_argument("--draws", type=int, default=2000, help="posterior draws the plan reweights (default 2000)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: 2 seeds, 300 steps, 500 draws")
    args = ap.parse_args(argv)
    if args.quick:
        args.seeds, args.max_steps, args.draws = 2, 300, 500
    rows = [one_seed(s, n_add=args.n_add, sigma=args.sigma, se=args.se, max_steps=args.max_steps,
                     n_draws=args.draws) for s in range(args.seeds)]
    print(f"Start: {len(START)} specimens at l/L {', '.join(map(str, START))}; truth Δ = {PAPER_DELTA * 1e3:g} mm, "
          f"d = {PAPER_D * 1e3:g} mm, L = {PAPER_L * 1e3:g} mm; σ = {args.sigma:g} 1/m, s = {args.se:g} 1/m; "
          f"{args.n_add} specimens added; emcee {args.max_steps} steps; the plan reweights {args.draws} draws.\n")
    print("| seed | planned l/L | evenly spaced l/L | area now (mm²) | planned: predicted | planned: measured "
          "| even: predicted | even: measured | planned / even | plan (s) |")
    print("|---:|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        p = r["plan"]
        print(f"| {r['seed']} | {', '.join(f'{x:g}' for x in p.l_over_L)} | "
              f"{', '.join(f'{x:.3g}' for x in p.even_l_over_L)} | {r['start']:.1f} | {p.predicted[-1] * 1e6:.1f} | "
              f"{r['planned']:.1f} | {p.even[-1] * 1e6:.1f} | {r['even']:.1f} | {r['planned'] / r['even']:.2f} | "
              f"{r['t_plan']:.1f} |")
    planned, even = np.array([r["planned"] for r in rows]), np.array([r["even"] for r in rows])
    print("\n| seeds | planned smaller | mean area planned (mm²) | mean area evenly spaced (mm²) | "
          "geometric mean of planned / even |")
    print("|---:|---:|---:|---:|---:|")
    print(f"| {len(rows)} | {int(np.sum(planned < even))} | {planned.mean():.1f} | {even.mean():.1f} | "
          f"{np.exp(np.mean(np.log(planned / even))):.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
