"""Every benchmark in bench/ runs end to end with ``--quick`` and prints its Markdown table.

``--quick`` is each script's smoke run (one preset at a coarse resolution, tiny scans, one
repeat): the same code path as the full benchmark, a few seconds each on an idle machine.
A rename inside the package, a changed result field or a new option that the row loop
misses breaks the script itself, which no unit test runs.
"""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "bench"

#: each benchmark script and words of the header of its (first) Markdown table
HEADERS = {
    "bench_assembly.py": ["per entry (s)", "per block (s)", "same pattern"],
    "bench_calibration.py": ["vectorized (s)", "brentq loop (s)", "| step | seconds |", "| parameter | truth |"],
    "bench_check.py": ["one after the other (s)", "processes (s)", "largest vertex difference (mm)"],
    "bench_cholesky.py": ["method", "symbolic (s)", "numeric (s)", "factor non-zeros"],
    "bench_coverage.py": ["k1 hole / weak / edge band", "k2 hole / weak / edge band"],
    "bench_end_dashes.py": ["end dashes", "shortest dash (mm)", "refined % diag"],
    "bench_cylinder.py": ["scan points", "method", "radius error median (%)"],
    "bench_dash_kappa.py": ["family", "turning: median", "circle: median"],
    "bench_density.py": ["mu1 x mu2 (mm)", "mid RMS (mm)", "best face % diag"],
    "bench_design.py": ["triangulate", "relax", "total (s)", "σ min/avg/max"],
    "bench_deviation_map.py": ["RMS mm (% diag)", "edge strip", "RMS mm by thirds of Ω"],
    "bench_inflation.py": ["Newton: time (s)", "baseline: time (s)", "speed-up"],
    "bench_jacobian_solve.py": ["cvxopt, column by column (s)", "CHOLMOD, all at once (s)", "same bits"],
    "bench_monte_carlo.py": ["| run | wall time (s)", "speed-up vs direct"],
    "bench_plan.py": ["| seed | planned l/L |", "planned: measured", "| seeds | planned smaller |"],
    "bench_registration.py": ["RMS error of recovered positions (mm)", "inlier share", "success"],
    "bench_newton_rule.py": ["today (shift ×4): s", "backtrack ×2: s", "max vertex distance (mm)"],
    "bench_preconditioned.py": ["without U_B5's far couplings", "PCG: CG iterations", "max vertex distance (mm)"],
    "bench_correct_scan.py": ["`airmat correct` (s)", "one inflation (s)", "95 % intervals (mm)"],
    "bench_correct.py": ["| shape | mattress (mm) | true Δ / d (mm) |", "RMS from Ŝ before → after (mm)", "ratio"],
    "bench_refine.py": ["open loop RMS mm (% diag)", "refined RMS mm (% diag)", "ratio"],
    "bench_specimen.py": ["κ₁ polygon (1/m)", "Equation 3 (1/m)", "side / L*"],
    "bench_tolerance.py": ["| preset | jobs | mesh (mm) | strings | K |", "validation: spread error, scale s / per-sample error",
                           "seeds within 0.05 of MC",
                           "95 % band: median rel. diff"],
    "bench_ua_hessian.py": ["projected: design (s)", "exact after", "Newton iterations", "refined % diag"],
    "bench_ua_solver.py": ["SuperLU: design (s)", "CHOLMOD: design (s)", "largest Ŝ difference (mm)"],
    "bench_startup.py": ["current (s)", "loaded now", "| path | HEAD | current |"],
    "bench_zoo.py": ["| target | kind |", "open loop % diag", "to S: RMS mm (% diag)", "| exit |", "| folds |",
                     "refine / one inflation"],
}
#: modules of bench/ that are not benchmarks (imported by them)
HELPERS = {"designed_preset.py", "inflation_target.py", "kangaroo_baseline.py", "recipe_cylinder.py", "run_all.py"}


def test_every_benchmark_is_listed_here_and_in_run_all():
    """A new benchmark gets a --quick run (HEADERS) and a place in ``make bench`` (run_all.BENCHES)."""
    sys.path.insert(0, str(BENCH))
    try:
        import run_all
    finally:
        sys.path.remove(str(BENCH))
    scripts = {p.name for p in BENCH.glob("*.py")} - HELPERS
    assert scripts == set(HEADERS)
    assert sorted(run_all.BENCHES) == sorted(HEADERS)


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(HEADERS))
def test_the_benchmark_runs_quick_and_prints_its_table(script):
    proc = subprocess.run([sys.executable, str(BENCH / script), "--quick"], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, f"{script} --quick: exit {proc.returncode}\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    table = [ln for ln in proc.stdout.splitlines() if ln.startswith("|")]
    head = "\n".join(table)
    for words in HEADERS[script]:
        assert words in head, f"{script} --quick printed no table header with {words!r}:\n{proc.stdout}"
    separators = [i for i, ln in enumerate(table) if set(ln.replace(" ", "")) <= set("|-:")]
    assert separators, f"{script} --quick: no Markdown table:\n{proc.stdout}"
    body = [ln for i, ln in enumerate(table) if i not in separators and i + 1 not in separators]   # not headers
    assert body, f"{script} --quick: a table header without rows:\n{proc.stdout}"
