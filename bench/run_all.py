"""Run every benchmark under bench/ in one go and collect their Markdown tables.

Usage: ``python bench/run_all.py [--quick]`` (``make bench``). Each benchmark is
a script printing a Markdown table; the tables are written to
``bench/results/<name>.md`` and echoed. Run it on a quiet machine: the tables
in ``docs/benchmarks.md`` are produced this way. ``--quick`` passes ``--quick`` to every
benchmark: a smoke run on tiny inputs (one preset at a coarse resolution, one
repeat) through the same code path, a few seconds each
(``tests/test_bench_quick.py`` runs them so). Experiments whose answer is in the
code are not kept as benchmarks; their results: ``docs/decisions.md``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
BENCHES = ["bench_cylinder.py", "bench_calibration.py", "bench_cholesky.py", "bench_design.py",
           "bench_density.py", "bench_coverage.py", "bench_dash_kappa.py", "bench_deviation_map.py",
           "bench_specimen.py", "bench_inflation.py", "bench_check.py", "bench_refine.py", "bench_monte_carlo.py",
           "bench_startup.py", "bench_assembly.py", "bench_jacobian_solve.py", "bench_zoo.py",
           "bench_plan.py", "bench_tolerance.py", "bench_registration.py", "bench_newton_rule.py", "bench_preconditioned.py",
           "bench_correct.py",
           "bench_correct_scan.py",
           "bench_end_dashes.py", "bench_ua_solver.py", "bench_ua_hessian.py"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="pass --quick to every benchmark (tiny inputs, a few seconds each)")
    ap.add_argument("names", nargs="*", help="only these benchmarks (file names)")
    args = ap.parse_args(argv)
    out = HERE / "results"
    out.mkdir(exist_ok=True)
    failed = []
    for name in args.names or BENCHES:
        script = HERE / name
        if not script.exists():
            print(f"## {name}: missing", flush=True)
            failed.append(name)
            continue
        cmd = [sys.executable, str(script)] + (["--quick"] if args.quick else [])
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=HERE.parent)
        dt = time.perf_counter() - t0
        text = proc.stdout + (f"\n(stderr tail)\n{proc.stderr[-2000:]}" if proc.returncode else "")
        (out / f"{script.stem}.md").write_text(text)
        print(f"## {name} ({dt:.0f} s, exit {proc.returncode})\n\n{text}", flush=True)
        if proc.returncode:
            failed.append(name)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
