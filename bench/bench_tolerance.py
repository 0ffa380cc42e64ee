"""Benchmark: the linearized tolerance (airmat.tolerance) against a K-sample Monte-Carlo, side by side.

Usage::

    .venv/bin/python bench/bench_tolerance.py                        # vault1 and saddle at 20 mm, K = 256
    .venv/bin/python bench/bench_tolerance.py --presets vault1 --resolution-mm 40 --samples 64   # a shared machine
    .venv/bin/python bench/bench_tolerance.py --quick                # a smoke run: vault1 at 60 mm, K = 4
    .venv/bin/python bench/bench_tolerance.py --presets vault2 --samples 0 --tolerance-mm 44.2   # linear side only
    .venv/bin/python bench/bench_tolerance.py --presets vault1 saddle --samples 2 --seeds 1 --jobs 1 2   # its time
    .venv/bin/python bench/bench_tolerance.py --presets vault1 saddle --mc-seeds 3 --jobs 2   # 768 pooled samples

Per preset (designed with the paper's calibration values, seed 0, and a stated nominal scatter
``--sigma-per-m``, as ``bench_monte_carlo.py``): one check with K Monte-Carlo samples
(:func:`airmat.check.inflation_check.check`, seed 0; its median run is the linear model's
equilibrium too; with ``--mc-seeds N`` the Monte-Carlos of seeds 0..N−1 pooled into one of N × K samples,
whose median RMS pins T N times as tightly), then :func:`airmat.check.tolerance.tolerance` on that check (``--validate`` full
samples in antithetic pairs, seed 1, which also give the model's mean shift). Columns:

- ``jobs``: worker processes of the check's runs and forked processes of the validation's samples
  (``--jobs 1 2``: a row each, in turn; with 2 the samples run beside the model's Jacobian);
- times: the K runs (summed inside the runs), the median run (one inflation), the linear model
  (Jacobian, covariance, model draws), its validation (wall, from the start of its median run on the
  coarser mesh to its statistics), and the whole :func:`~airmat.check.tolerance.tolerance` call's wall
  time over one inflation;
- the validation's spread error (the verdict's measure), the scale s of the model's change (its
  variance ratio shrunk toward 1, ``Validation.spread_scale``) and its per-sample displacement error
  (``LinearTolerance.validation``);
- the median over Ŝ's vertices of |q95_linear / q95_MC − 1|, the per-vertex 95 % quantile of the
  distance from Ŝ; for scale, the same statistic's sampling error at K (one quantile's relative
  standard error sqrt(0.95 · 0.05 / K) / (2 φ(1.96) · 1.96) for a one-mode Gaussian deviation);
- the RMS median and 95th percentile, linear / MC (mm), and P(RMS <= T) both ways with T the
  MC's median RMS rounded to 0.1 mm (where a probability is most sensitive), the linear one with the
  standard error of its sampled mean shift, the MC's with its binomial standard error; and the linear
  P's mean and standard deviation over the validation seeds 1..``--seeds`` (the mean shift is sampled),
  and on how many of those seeds it lies within 0.05 of the Monte-Carlo's (the target);
- the commit the Monte-Carlo was made at.

The Monte-Carlo's per-sample results (each sample's aligned named face at Ŝ's vertices, its RMS and
per-vertex distance, converged, seconds) are saved under ``--mc-cache`` (default ``out/mc_cache``),
one ``.npz`` per preset, K, seed, resolution, σ and a hash of what the inflations depend on (the
designed strings, Ŝ, the calibration and the source of ``airmat.inflation`` and of the check's
sampling, alignment and length map). A later run with the same key reads them and inflates the median
run only, so the linear side can be re-evaluated against the same Monte-Carlo in seconds.
"""

from __future__ import annotations

import argparse
import hashlib
import logging
import subprocess
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


#: the target: the linear P(RMS <= T) within this of the Monte-Carlo's
P_TARGET = 0.05

#: the sources the Monte-Carlo's inflations and deviations depend on (beside the design's arrays)
MC_SOURCES = ("inflation", "check/inflation_check.py", "check/monte_carlo.py", "check/compare.py",
              "check/length_map.py", "check/string_world.py", "check/calibrated_map.py")


def mc_key(preset: str, design, resolution: float, k: int, seed: int, sigma: float) -> str:
    """The cache key of a Monte-Carlo: preset, K, seed, mesh, σ and a hash of the inflations' inputs."""
    h = hashlib.sha256()
    root = HERE.parent
    for src in MC_SOURCES:
        files = sorted((root / src).rglob("*.py")) if (root / src).is_dir() else [root / src]
        for f in files:
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    from airmat.check.inflation_check import design_strings

    st, cal = design_strings(design), design.calibration
    for arr in (design.approx.xyz, design.approx.faces, st.a, st.b, st.rest, st.top, cal.delta, cal.d,
                np.zeros(0) if cal.sigma is None else cal.sigma):
        h.update(np.ascontiguousarray(arr).tobytes())
    return f"{preset}_K{k}_seed{seed}_{resolution / MM:g}mm_sigma{sigma:g}_{h.hexdigest()[:12]}"


def commit() -> str:
    """HEAD's short hash, with "+dirty" when the Monte-Carlo's sources differ from it."""
    def git(*a):
        return subprocess.run(["git", *a], cwd=HERE.parent, capture_output=True, text=True).stdout.strip()
    dirty = git("status", "--porcelain", "--", *MC_SOURCES)
    return git("rev-parse", "--short", "HEAD") + ("+dirty" if dirty else "")


def monte_carlo_run(design, preset: str, resolution: float, k: int, sigma: float, workers: int, cache: Path,
                    seed: int = 0):
    """The check with K Monte-Carlo samples (``seed``), from ``cache`` when it holds it: (run, wall s, commit).

    A cached Monte-Carlo comes back as a check of the median run only (one inflation) with the
    cached samples' MonteCarloResult; a fresh one is written to the cache, per sample: the aligned
    face (K, N, 3), RMS (K,), per-vertex distance (K, N), converged, seconds (m, s)."""
    import airmat.check.inflation_check as ic
    from airmat.check.monte_carlo import MonteCarloResult, draw

    path = cache / (mc_key(preset, design, resolution, k, seed, sigma) + ".npz")
    if path.exists():
        z = np.load(path)
        run = ic.check(design, resolution=resolution, envelope=False, workers=workers)
        per = z["per_vertex"]
        mc = MonteCarloResult(draws=draw(design, k, seed, lengths=run.lengths), rms=z["rms"],
                              per_vertex_q=np.quantile(per, [0.5, 0.95], axis=0), converged=z["converged"],
                              seconds=float(z["seconds"]))
        return replace(run, monte_carlo=mc), float(z["wall"]), str(z["commit"]), per
    captured = {}
    summarize = ic.summarize

    def keep(draws, deviations, **kw):
        captured["devs"] = list(deviations)
        return summarize(draws, deviations, **kw)
    ic.summarize = keep
    try:
        t0 = time.perf_counter()
        run = ic.check(design, resolution=resolution, envelope=False, samples=k, seed=seed, workers=workers)
        wall = time.perf_counter() - t0
    finally:
        ic.summarize = summarize
    devs, mc, made = captured["devs"], run.monte_carlo, commit()
    cache.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, aligned=np.stack([d.aligned for d in devs]), rms=mc.rms,
                        per_vertex=np.stack([d.per_vertex for d in devs]), converged=mc.converged,
                        seconds=mc.seconds, wall=wall, commit=made, preset=preset, k=k, seed=seed,
                        resolution=resolution, sigma=sigma)
    tmp.replace(path)
    return run, wall, made, np.stack([d.per_vertex for d in devs])


def pooled_monte_carlo(design, preset: str, resolution: float, k: int, sigma: float, workers: int, cache: Path,
                       mc_seeds: int):
    """The Monte-Carlos of seeds 0..``mc_seeds`` − 1 (K samples each, :func:`monte_carlo_run`) as one of
    ``mc_seeds`` × K samples: (run of seed 0 with the pooled MonteCarloResult, wall s summed, commits)."""
    from airmat.check.monte_carlo import MonteCarloResult

    parts = [monte_carlo_run(design, preset, resolution, k, sigma, workers, cache, seed=s) for s in range(mc_seeds)]
    run = parts[0][0]
    if mc_seeds == 1:
        return run, parts[0][1], parts[0][2]
    mcs = [p[0].monte_carlo for p in parts]
    per = np.concatenate([p[3] for p in parts])
    mc = MonteCarloResult(draws=mcs[0].draws, rms=np.concatenate([m.rms for m in mcs]),
                          per_vertex_q=np.quantile(per, [0.5, 0.95], axis=0),
                          converged=np.concatenate([m.converged for m in mcs]),
                          seconds=float(sum(m.seconds for m in mcs)))
    return (replace(run, monte_carlo=mc), float(sum(p[1] for p in parts)),
            " ".join(sorted({p[2] for p in parts})))


def row(preset: str, resolution: float, k: int, validate: int, sigma: float, workers: int, seeds: int,
        cache: Path, t_mm: float | None = None, mc_seeds: int = 1) -> str:
    from scipy.stats import norm

    from airmat.check.inflation_check import check
    from airmat.check.tolerance import tolerance

    design = designed_preset(preset)
    cal = design.calibration
    design = replace(design, calibration=replace(cal, sigma=np.full(cal.n_samples, sigma)))
    if k == 0:                 # the linear side alone, at a given T (a Monte-Carlo made elsewhere)
        t0 = time.perf_counter()
        run = check(design, resolution=resolution, envelope=False, workers=workers)
        t_check, made, mc = time.perf_counter() - t0, "none", None
        T = t_mm * MM
    else:
        run, t_check, made = pooled_monte_carlo(design, preset, resolution, k, sigma, workers, cache, mc_seeds)
        mc = run.monte_carlo
        k = mc.rms.size
        T = round(float(np.median(mc.rms)) / MM, 1) * MM
    t_med = run.runs["median"].inflation.seconds
    started = time.perf_counter()
    lin = tolerance(design, run=run, validate=validate, seed=1, tolerance=T, workers=workers)
    wall = time.perf_counter() - started
    lst = lin.stats()
    if mc is None:
        nan = float("nan")
        mst = {"rms_median": nan, "rms_p95": nan, "p_within": nan, "p_within_se": nan}
        rel = rel_se = nan
        mc_seconds = nan
    else:
        mst = replace(mc, tolerance=T).stats()
        rel = float(np.median(np.abs(lin.per_vertex_q[1] / np.maximum(mc.per_vertex_q[1], 1e-12) - 1)))
        rel_se = np.sqrt(0.95 * 0.05 / k) / (2 * norm.pdf(1.96) * 1.96)
        mc_seconds = mc.seconds
    ps = [lin.stats()["p_within"]] + [tolerance(design, run=run, validate=validate, seed=s, tolerance=T,
                                                 workers=workers).stats()["p_within"] for s in range(2, seeds + 1)]
    within = ("–" if mc is None else
              f"{int(np.sum(np.abs(np.array(ps) - mst['p_within']) <= P_TARGET))} of {len(ps)}")
    v = lin.validation
    if v is None:
        val, p_se = "n/a", ""
    else:
        val = (f"{100 * v.spread_error:+.1f} %, s {v.spread_scale:.3f} / {100 * v.relative_error:.0f} % "
               f"({v.samples}, {v.seconds:.1f} s)")
        p_se = "" if v.p_within_se is None else f" ± {v.p_within_se:.2f}"
    total = wall                        # the model and its validation's samples overlap with workers > 1
    return (f"| {preset} | {workers} | {resolution / MM:g} | {len(lin.ids)} | {k} | {mc_seconds:.1f} ({t_check:.1f} wall) "
            f"| {t_med:.2f} | {lin.seconds:.2f} | {val} | {total / t_med:.2f}x "
            f"| {100 * rel:.1f} % (sampling {100 * rel_se:.0f} %) "
            f"| {lst['rms_median'] / MM:.2f} / {mst['rms_median'] / MM:.2f} | {lst['rms_p95'] / MM:.2f} / "
            f"{mst['rms_p95'] / MM:.2f} | {T / MM:.1f}: {lst['p_within']:.2f}{p_se} / {mst['p_within']:.2f} "
            f"± {mst['p_within_se']:.2f} | {np.mean(ps):.2f} ± {np.std(ps, ddof=1) if len(ps) > 1 else 0:.2f} "
            f"| {within} | {lin.reliable} | `{made}` |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=["vault1", "saddle"])
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--samples", type=int, default=256,
                    help="Monte-Carlo samples K; 0: the linear side alone at --tolerance-mm (no Monte-Carlo)")
    ap.add_argument("--tolerance-mm", type=float, default=None, help="T (mm) of P(RMS <= T) with --samples 0")
    ap.add_argument("--validate", type=int, default=VALIDATION_SAMPLES,
                    help="full samples (antithetic pairs: even) that check the model and give its mean shift")
    ap.add_argument("--seeds", type=int, default=8,
                    help="validation seeds 1..N whose P(RMS <= T) the last column summarizes (the shift is sampled)")
    ap.add_argument("--sigma-per-m", type=float, default=0.3, help="nominal scatter sigma (1/m), stated")
    ap.add_argument("--jobs", type=int, nargs="+", default=[1],
                    help="worker processes of the inflations and forked processes of the validation's samples; "
                         "several: one row each, in turn")
    ap.add_argument("--mc-seeds", type=int, default=1,
                    help="Monte-Carlos of seeds 0..N-1, K samples each, pooled into one of N x K samples")
    ap.add_argument("--mc-cache", type=Path, default=HERE.parent / "out" / "mc_cache",
                    help="folder of the Monte-Carlos' per-sample results, read when the key matches")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 60 mm, two Monte-Carlos of K = 4 pooled, 2 validation samples")
    args = ap.parse_args(argv)
    if args.samples == 0 and args.tolerance_mm is None:
        ap.error("--samples 0 needs --tolerance-mm")
    if args.quick:
        args.presets, args.resolution_mm, args.samples, args.validate, args.seeds = ["vault1"], 60.0, 4, 2, 2
        args.mc_seeds = 2
    logging.getLogger().setLevel(logging.WARNING)
    print(f"linear tolerance against {args.samples} Monte-Carlo samples at {args.resolution_mm:g} mm, "
          f"sigma {args.sigma_per_m:g} 1/m (nominal), {args.validate} validation samples")
    print("| preset | jobs | mesh (mm) | strings | K | MC runs (s) | one inflation (s) | linear (s) "
          "| validation: spread error, scale s / per-sample error (samples, s) "
          "| linear tolerance, wall / one inflation "
          "| 95 % band: median rel. diff | RMS median lin / MC (mm) | RMS p95 lin / MC (mm) "
          f"| T (mm): P(RMS <= T) lin / MC | P lin over validation seeds 1-{args.seeds}: mean ± sd "
          f"| seeds within {P_TARGET:g} of MC | reliable "
          "| MC made at |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.presets:
        for jobs in args.jobs:
            print(row(name, args.resolution_mm * MM, args.samples, args.validate, args.sigma_per_m, jobs, args.seeds,
                      args.mc_cache, args.tolerance_mm, args.mc_seeds),
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
