"""Benchmark: the whole designer on every preset, time split by stage.

Usage::

    .venv/bin/python bench/bench_design.py                      # all presets, 20 mm mesh
    .venv/bin/python bench/bench_design.py --presets vault1 --spacing-mm 40
    .venv/bin/python bench/bench_design.py --repeats 3          # medians of 3 runs and the spread
    .venv/bin/python bench/bench_design.py --repeats 3 --bvh-threads 1 auto   # the closest-point threads
    .venv/bin/python bench/bench_design.py --presets dome --repeats 3 --jobs 1 2 --early off on   # the fold route
    .venv/bin/python bench/bench_design.py --presets dome-r450 --jobs 2 --early off on            # a zoo target
    .venv/bin/python bench/bench_design.py --quick          # a smoke run: vault1, 40 mm mesh, once

Prints a Markdown table: seconds per stage (preset build, the surface
side's triangulate / relax / curvature / report, transfer to Ω, stripes,
string lengths, export of all files) and the totals, with the Table-1
figures and string counts. With ``--repeats N`` each preset is designed N
times in turn (all presets once, then again) and every time is the median,
with the totals' range beside it. ``--bvh-threads 1 auto`` designs every
preset with the closest-point queries on one thread and on the cores other
processes leave idle (airmat.design.closest_point, the default), one row each,
interleaved in every round. ``--jobs 1 2`` designs with one process and with two
(the fold route's relaxations side by side, :func:`airmat.design.fold_route.fold_route`),
and ``--early off on`` without and with the route's first relaxations started beside the
plain one where folds are forecast (:func:`airmat.design.fold_route.folds_likely`; off: the
forecast patched to no), one row each. Targets on the 2-core reference machine: small
presets (830 × 740 mm) < 10 s, large (2600 × 1600 mm) < 60 s in total.
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from airmat.design.presets import PRESETS, preset  # noqa: E402
from airmat.design.design_io import write_design  # noqa: E402
from airmat.design.pipeline import DesignParams, design  # noqa: E402

def load_target(name: str):
    """A preset's target and mattress, or a zoo target's (``airmat.synthetic.zoo``) by name."""
    if name in PRESETS:
        return preset(name)
    from airmat.design.mattress import Mattress
    from airmat.synthetic.zoo import by_name

    target = by_name(name)
    return target, Mattress(*target.mattress)


STAGES = ("preset", "triangulate", "relax", "curvature", "report", "fold_route", "transfer", "stripes", "lengths",
          "export")
LIMITS = {"small": 10.0, "large": 60.0}


def bench_one(name: str, spacing: float, seed: int = 0, threads: str = "auto", jobs: int = 1,
              early: str = "on") -> dict:
    """Design one preset end to end; returns the timings (s), the totals and a few results.

    ``threads``: "auto" (the default of airmat.design.closest_point) or a number of closest-point threads;
    ``jobs``: the design's processes (``workers``); ``early``: "on" (the default) or "off" (the fold route's
    first relaxations not started beside the plain one: the forecast patched to no)."""
    if threads != "auto":
        with mock.patch("airmat.design.closest_point.idle_cores", lambda *a, **k: int(threads)):
            return {**bench_one(name, spacing, seed, jobs=jobs, early=early), "threads": threads}
    if early == "off":
        with mock.patch("airmat.design.pipeline.folds_likely", lambda target: False):
            return {**bench_one(name, spacing, seed, jobs=jobs), "early": early}
    t = time.perf_counter()
    target, mattress = load_target(name)
    times = {"preset": time.perf_counter() - t}
    result = design(target, mattress, params=DesignParams(spacing=spacing), seed=seed, progress=False, workers=jobs)
    times.update(result.timings)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        write_design(result, tmp, workers=jobs)
        times["export"] = time.perf_counter() - t
    size = "small" if max(mattress.width, mattress.height) < 1.0 else "large"
    r = result.approx.report
    return {"name": name, "size": size, "times": times, "total": sum(times.values()),
            "n_vertices": len(result.approx.uv), "converged": result.approx.relax.converged,
            "strings": len(result.pattern.strings), "sigma": r.sigma, "kappa1": r.kappa1, "kappa2": r.kappa2,
            "constructible": r.constructible, "threads": threads, "jobs": jobs, "early": early,
            "xyz": result.approx.xyz}


def median_row(repeats: list[dict]) -> dict:
    """One preset's runs as one row: the median of every stage and of the total, and all totals."""
    row = dict(repeats[0])
    row["times"] = {k: float(np.median([r["times"].get(k, 0.0) for r in repeats])) for k in STAGES}
    row["totals"] = [r["total"] for r in repeats]
    row["total"] = float(np.median(row["totals"]))
    return row


def markdown(rows: list[dict], threads_column: bool = False, jobs_columns: bool = False) -> str:
    """The results as a Markdown table (with ``jobs_columns``: the processes, the early start and whether Ŝ is the
    first row's of the same preset to the bit)."""
    head = ["preset", "vertices", *STAGES, "total (s)", "total min – max (s)", "target", "strings", "σ min/avg/max",
            "abs κ1 avg/max", "abs κ2 avg/max", "relax conv."] + (["BVH threads"] if threads_column else [])
    head += ["jobs", "fold trials beside the plain Ŝ", "same Ŝ"] if jobs_columns else []
    first = {}
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        t, s = r["times"], r["sigma"]
        ok = "ok" if r["total"] < LIMITS[r["size"]] else "SLOW"
        lines.append("| " + " | ".join([
            r["name"], str(r["n_vertices"]), *(f"{t.get(k, 0.0):.2f}" for k in STAGES), f"{r['total']:.1f}",
            f"{min(r['totals']):.1f} – {max(r['totals']):.1f}",
            f"< {LIMITS[r['size']]:.0f} s {ok}", str(r["strings"]),
            f"{s['min']:.4f} / {s['avg']:.4f} / {s['max']:.4f}",
            f"{r['kappa1']['avg']:.2f} / {r['kappa1']['max']:.2f}",
            f"{r['kappa2']['avg']:.2f} / {r['kappa2']['max']:.2f}", str(r["converged"])]
            + ([r["threads"]] if threads_column else [])
            + ([str(r["jobs"]), r["early"], "yes" if np.array_equal(first.setdefault(r["name"], r["xyz"]), r["xyz"])
                else "no"] if jobs_columns else [])) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="+", default=list(PRESETS), metavar="NAME",
                        help="presets or zoo targets (airmat.synthetic.zoo) by name (default: every preset)")
    parser.add_argument("--spacing-mm", type=float, default=20.0, help="Ω mesh spacing (default 20 mm)")
    parser.add_argument("--repeats", type=int, default=1, help="runs of every preset (medians reported)")
    parser.add_argument("--bvh-threads", nargs="+", default=None, metavar="N|auto",
                        help="closest-point threads, one row each (a number, or auto: the default)")
    parser.add_argument("--jobs", nargs="+", type=int, default=None, metavar="N",
                        help="the design's processes, one row each (default 1)")
    parser.add_argument("--early", nargs="+", default=None, choices=("off", "on"),
                        help="the fold route's first relaxations beside the plain one, one row each (default on)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: vault1 on a 40 mm mesh, once")
    args = parser.parse_args(argv)
    if args.quick:
        args.presets, args.spacing_mm, args.repeats = ["vault1"], 40.0, 1
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    cases = [(name, th, jobs, early) for name in args.presets for th in (args.bvh_threads or ["auto"])
             for jobs in (args.jobs or [1]) for early in (args.early or ["on"])]
    runs = [[bench_one(name, args.spacing_mm * 1e-3, threads=th, jobs=jobs, early=early)
             for name, th, jobs, early in cases] for _ in range(max(1, args.repeats))]
    rows = [median_row([run[i] for run in runs]) for i in range(len(cases))]
    print(markdown(rows, threads_column=args.bvh_threads is not None,
                   jobs_columns=args.jobs is not None or args.early is not None))
    return 0


if __name__ == "__main__":
    sys.exit(main())
