"""Benchmark: Monte-Carlo inflation of vault1, serial vs 1 and 2 Dask workers, and how many samples it needs.

Usage::

    .venv/bin/python bench/bench_monte_carlo.py                      # 32 samples at 20 mm (docs/benchmarks.md)
    .venv/bin/python bench/bench_monte_carlo.py --samples 8 --resolution-mm 60   # a loaded machine
    .venv/bin/python bench/bench_monte_carlo.py --quick     # a smoke run: 2 samples at 60 mm

Rows, all on the same K string-length samples (``airmat.check.monte_carlo.draw``, seed 0):

- *direct*: :func:`airmat.inflation.simulate.inflate` called K times in this process (the baseline);
- *1 Dask worker*: the same K tasks through :func:`airmat.inflation.simulate.inflate_many` on a
  LocalCluster of one single-threaded worker process, started and warmed (one task) beforehand,
  so the row measures Dask's overhead per task: scatter, scheduling, result transfer (its wall
  time minus the time spent inside the runs, which on a loaded machine also varies);
- *2 Dask workers*: ``inflate_many(..., workers=2)`` as ``airmat inflate --samples K --jobs 2``
  runs it, the cluster's start-up included.

The results are checked to be identical to the direct ones (bytes of every vertex array).

Samples needed: the 95th-percentile RMS's bootstrap standard error ``se_K`` over the K
samples shrinks as 1/√K, so its 95 % interval is within ±1 mm (1.96 se ≤ 1 mm) from
about K × (1.96 se_K / 1 mm)² samples.

The paper's default calibration measured no scatter σ; the benchmark uses a stated
nominal σ (``--sigma-per-m``, default 0.3 1/m) for every posterior sample.
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

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402


def main(argv=None) -> int:
    from airmat.check.compare import deviation
    from airmat.check.inflation_check import design_strings, named_face
    from airmat.check.monte_carlo import draw, quantile_se
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.model import Parameters
    from airmat.inflation.simulate import inflate, inflate_many

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--sigma-per-m", type=float, default=0.3, help="nominal scatter sigma (1/m), stated")
    ap.add_argument("--quick", action="store_true", help="a smoke run: 2 samples at 60 mm")
    args = ap.parse_args(argv)
    if args.quick:
        args.samples, args.resolution_mm = 2, 60.0
    logging.getLogger().setLevel(logging.WARNING)

    design = designed_preset("vault1")
    cal = design.calibration
    design = replace(design, calibration=replace(cal, sigma=np.full(cal.n_samples, args.sigma_per_m)))
    m = design.mattress
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=args.resolution_mm * MM)
    base = design_strings(design, "median")
    dr = draw(design, args.samples, seed=0)
    sets = [replace(base, rest=r) for r in dr.rest]
    t0 = time.perf_counter()
    direct = [inflate(mesh, s, params=Parameters()) for s in sets]
    t_direct = time.perf_counter() - t0

    from airmat.inflation.executor import local_cluster

    with local_cluster(1) as cluster:
        t0 = time.perf_counter()
        inflate_many(mesh, sets[:1], scheduler=cluster.scheduler_address)    # the worker imports the solver
        t_warm = time.perf_counter() - t0
        t0 = time.perf_counter()
        one = inflate_many(mesh, sets, scheduler=cluster.scheduler_address)
        t_one = time.perf_counter() - t0
    t0 = time.perf_counter()
    two = inflate_many(mesh, sets, workers=2)
    t_two = time.perf_counter() - t0
    same = all(a.xyz.tobytes() == b.xyz.tobytes() == c.xyz.tobytes() for a, b, c in zip(direct, one, two))

    face = named_face(design, base)
    rms = np.array([deviation(r, design.approx.xyz, design.approx.uv, face).rms
                    for r in direct]) / MM
    se95 = quantile_se(rms, 0.95, seed=0)
    need = int(np.ceil(args.samples * (1.96 * se95 / 1.0) ** 2))
    k = args.samples
    print(f"vault1 at {args.resolution_mm:g} mm ({mesh.n_vertices} vertices), {k} samples, "
          f"sigma {args.sigma_per_m:g} 1/m (nominal); identical results: {same}")
    print("| run | wall time (s) | per sample (s) | speed-up vs direct |")
    print("|---|---|---|---|")
    for name, t in (("direct (inflate in this process)", t_direct), ("1 Dask worker", t_one),
                    ("2 Dask workers (start-up included)", t_two)):
        print(f"| {name} | {t:.1f} | {t / k:.2f} | {t_direct / t:.2f}x |")
    print(f"time inside the runs (Inflation.seconds, summed): direct {sum(r.seconds for r in direct):.1f} s, "
          f"1 worker {sum(r.seconds for r in one):.1f} s, 2 workers {sum(r.seconds for r in two):.1f} s")
    inside = sum(r.seconds for r in one)
    print(f"Dask overhead per task (1 warm worker: wall time minus the time inside the runs): "
          f"{(t_one - inside) / k:.3f} s ({100 * (t_one - inside) / inside:.1f} % of a run); against the direct "
          f"row's wall time: {(t_one - t_direct) / k:.3f} s ({100 * (t_one - t_direct) / t_direct:.1f} %); "
          f"the worker's first task (imports, one run): {t_warm:.1f} s")
    print(f"RMS deviation ({face} face): median {np.median(rms):.2f} mm, 95th percentile "
          f"{np.quantile(rms, 0.95):.2f} +- {se95:.2f} mm (bootstrap SE over {k}); "
          f"samples for +-1 mm (95 %) on the 95th percentile: about {max(need, 1)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
