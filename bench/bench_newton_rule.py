"""Benchmark: what Newton's method does with a refused step, side by side, on the presets' inflations and refinements.

Usage::

    .venv/bin/python bench/bench_newton_rule.py                          # vault1, saddle, dome; both rules
    .venv/bin/python bench/bench_newton_rule.py --presets all --refine
    .venv/bin/python bench/bench_newton_rule.py --rules shift:4 backtrack:4 backtrack:2

A step of the inflation's Newton method that does not lower U_B is refused
(:class:`airmat.inflation.solver._TrustRegion`). The rule in use raises the
Levenberg–Marquardt shift (× ``MU_UP``, 4) and factorizes again; the
alternative halves the same step (no new factorization) and leaves the
raised shift to the next iteration (``airmat.inflation.solver.REFUSED_STEP =
"backtrack"``). Each rule ``RULE:UP`` is applied to the whole run (the
check's inflation and every equilibrium of the refinement, whose own rule
``airmat.check.trial_equilibrium.TRIAL_REFUSED_STEP`` is set to the same). Per preset (paper
calibration values, seed 0, defaults) and rule: the open-loop inflation at
its median lengths (the check's path, 20 mm), its Newton iterations over
every level and its named face's RMS deviation from Ŝ; with ``--refine``, the
refinement (defaults) and its ratio to its own first inflation. Prints a
Markdown table; times are one run each, in this process, one rule after
the other per preset.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from unittest import mock

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import airmat.inflation.solver as solver  # noqa: E402
from bench_refine import trial_refused, trial_rule  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402
from airmat.check.refinement import refine  # noqa: E402
from airmat.design.presets import PRESETS  # noqa: E402

MM = 1e-3


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=["vault1", "saddle", "dome"],
                    help=f"names, or all ({', '.join(PRESETS)})")
    ap.add_argument("--rules", nargs="+", type=trial_rule, default=[("shift", 4.0), ("backtrack", 2.0)],
                    help="RULE:MU_UP, one row each (default: shift:4, the rule in use, and backtrack:2)")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--refine", action="store_true", help="also refine each design (airmat.check.refinement.refine)")
    args = ap.parse_args(argv)
    names = list(PRESETS) if args.presets == ["all"] else args.presets
    res = args.resolution_mm * MM
    print("| preset | refused step | shift × | inflation (s) | Newton iterations | open loop RMS mm (% diag) | max mm "
          + ("| refine (s) | its first inflation (s) | verification (s) | ratio | refined RMS mm (% diag) "
             "| iterations | converged " if args.refine else "") + "|")
    print("|---|---|---:|---:|---:|---|---:|" + ("---:|---:|---:|---:|---|---:|---|" if args.refine else ""))
    for name in names:
        design = designed_preset(name)
        for name_rule, up in args.rules:
            with mock.patch.object(solver, "REFUSED_STEP", name_rule), mock.patch.object(solver, "MU_UP", up), \
                    trial_refused((name_rule, up)):
                t0 = time.perf_counter()
                run = check(design, resolution=res, envelope=False).runs["median"]
                seconds = time.perf_counter() - t0
                dev = run.deviation
                row = (f"| {name} | {name_rule} | {up:g} | {seconds:.1f} | {run.inflation.n_iter} "
                       f"| {dev.rms / MM:.2f} ({dev.rms_pct_diag:.2f}) | {dev.max / MM:.1f} |")
                if args.refine:
                    r = refine(design, resolution=res)
                    a = r.deviation_after
                    row += (f" {r.seconds:.1f} | {r.inflation_seconds:.1f} | {r.verification_seconds:.1f} "
                            f"| {r.seconds / r.inflation_seconds:.1f}× | {a.rms / MM:.2f} ({a.rms_pct_diag:.2f}) "
                            f"| {r.iterations} | {'yes' if r.converged else 'no'} |")
            print(row, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
