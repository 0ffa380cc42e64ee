"""Benchmark: U_A's Newton with the exact A1 Hessian after the first iterations, against projected Newton throughout.

Usage::

    .venv/bin/python bench/bench_ua_hessian.py                       # three presets and six zoo targets
    .venv/bin/python bench/bench_ua_hessian.py --targets dome --refine --exact-after 0 10 15 20
    .venv/bin/python bench/bench_ua_hessian.py --quick               # a smoke run: vault1

Every design relaxes Ŝ by Newton on U_A (:func:`airmat.design.ua_newton.newton`). The default, projected
Newton, drops a compressed edge's negative transverse stiffness at every iteration (the matrix stays positive
semi-definite, and a Ŝ that contracts converges linearly); ``exact_after=k`` does so for the first k iterations
of each relaxation, then takes the exact A1 Hessian, which the shift keeps definite. The same design runs with
each (the whole designer, one process, one after the other): seconds, Newton iterations and numeric
factorizations of the design, the strings, the fold route's choice, Ŝ's σ range and the largest difference
between the two Ŝ (a relaxation that ends within k iterations gives the same bits). ``--refine``: each design's
lengths refined at 20 mm (:func:`airmat.check.refinement.refine`) and the refined inflation's RMS distance
from Ŝ in % of its diagonal.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

import airmat.design.relax as relax_module  # noqa: E402
import airmat.design.ua_newton as ua  # noqa: E402
from airmat.check.refinement import refine  # noqa: E402
from airmat.design.pipeline import design  # noqa: E402
from bench_ua_solver import PRESETS, commit, target_and_mattress  # noqa: E402

ZOO = ("hypar-1.0-k2", "helicoid-p500", "wave-once", "egg-crate", "dome-r450", "hypar-1.0-strong")
#: the switch compared with projected Newton by default
EXACT_AFTER = 15


def _designed(name, exact_after, refined: bool) -> dict:
    """One design of ``name`` with the switch after ``exact_after`` iterations: its figures."""
    counts = {"iterations": 0, "factorizations": 0}
    original_newton, original_cholesky = relax_module.newton, ua._Pattern.cholesky

    def cholesky(pattern):
        made = original_cholesky(pattern)
        factor = made.factor

        def counted(*a, **k):
            counts["factorizations"] += 1
            return factor(*a, **k)

        made.factor = counted
        return made

    def newton(prob, x, **kw):
        out = original_newton(prob, x, **{**kw, "exact_after": exact_after})
        counts["iterations"] += out[1]
        return out

    relax_module.newton, ua._Pattern.cholesky = newton, cholesky
    try:
        target, mattress = target_and_mattress(name)
        t0 = time.perf_counter()
        d = design(target, mattress, progress=False)
        seconds = time.perf_counter() - t0
        refined_pct = refine(d, resolution=0.02).deviation_after.rms_pct_diag if refined else None
    finally:
        relax_module.newton, ua._Pattern.cholesky = original_newton, original_cholesky
    rep, route = d.approx.report, d.fold_route
    folds = "–" if route is None else f"× {route.trial.ratio:g}" if route.found else "none found"
    return {**counts, "seconds": seconds, "xyz": d.approx.xyz, "strings": len(d.pattern.strings), "folds": folds,
            "sigma": f"{rep.sigma['min']:.3f}–{rep.sigma['max']:.3f}", "constructible": rep.constructible,
            "converged": bool(d.approx.relax.converged), "refined": refined_pct}


def _pair(a, b, fmt="{}"):
    return fmt.format(a) if a == b else f"{fmt.format(a)} / {fmt.format(b)}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1")
    ap.add_argument("--targets", nargs="+", default=None, help="presets or zoo names (default: all above)")
    ap.add_argument("--exact-after", nargs="+", type=int, default=[EXACT_AFTER], metavar="K",
                    help=f"projected iterations before the exact Hessian, one row each (default {EXACT_AFTER})")
    ap.add_argument("--refine", action="store_true", help="refine each design at 20 mm and give its refined %% diag")
    ap.add_argument("--machine", default=f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
                    help="the machine column's text")
    args = ap.parse_args(argv)
    names = ["vault1"] if args.quick else (args.targets or list(PRESETS + ZOO))
    rev, machine = commit(), args.machine
    _designed("vault1", None, False)          # imports and caches warmed before any timed design
    print("| target | exact after | projected: design (s) | exact: design (s) | speed-up "
          "| Newton iterations | factorizations | strings | folds | σ min–max | constructible | converged "
          "| refined % diag | largest Ŝ difference (mm) | commit | machine |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|---|---:|---|---|")
    for name in names:
        old = _designed(name, None, args.refine)
        for k in args.exact_after:
            new = _designed(name, k, args.refine)
            diff = (float(np.abs(old["xyz"] - new["xyz"]).max()) * 1e3 if old["xyz"].shape == new["xyz"].shape
                    else float("nan"))
            row = [name, str(k), f"{old['seconds']:.1f}", f"{new['seconds']:.1f}",
                   f"{old['seconds'] / new['seconds']:.1f}x"]
            row += [_pair(old[c], new[c]) for c in ("iterations", "factorizations", "strings", "folds", "sigma")]
            row += [_pair(*("yes" if r[c] else "no" for r in (old, new))) for c in ("constructible", "converged")]
            row += [_pair(old["refined"], new["refined"], "{:.2f}") if args.refine else "–"]
            row += [f"{diff:.1e}", f"`{rev}`", machine]
            print("| " + " | ".join(row) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
