"""Benchmark: shorter end dashes (``DesignParams(end_dashes=True)``) against whole dashes only, side by side.

Usage::

    .venv/bin/python bench/bench_end_dashes.py                     # dome, cylinder-r200-mm, vault1, saddle, hypar-1.0-k2
    .venv/bin/python bench/bench_end_dashes.py --targets dome --min-fractions 0.5 0.25 --max-iter 40
    .venv/bin/python bench/bench_end_dashes.py --quick             # cylinder-r300 at 40 mm, 2 iterations

Each target (a preset's name or a zoo target's, ``bench/designed_preset.py``) is designed with the
defaults and Ω at the resolution, once with whole dashes only (the default) and once per
``--min-fractions`` f with end dashes at least f · L long (:mod:`airmat.design.stripes`); each design
is refined at the resolution (:func:`airmat.check.refinement.refine`, ``--max-iter`` Gauss–Newton
iterations) and checked (the refinement's verification is the median run). Columns: strings of the
design and its shortest dash's arc length (the tie grid moves whole dashes' ends a few mm), the named face's RMS deviation from Ŝ in % of
Ŝ's diagonal at the open-loop and the refined lengths, whether the refinement and the check
converged, and the refinement's seconds. The promise: refined within 1.0 % of the
diagonal (the dome preset: 1.5 %).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from designed_preset import designed_preset  # noqa: E402

TARGETS = ["dome", "cylinder-r200-mm", "vault1", "saddle", "hypar-1.0-k2"]

HEADER = ("| target | end dashes | strings | shortest dash (mm) | open loop % diag | refined % diag | converged "
          "| refine (s) |")


def run(target: str, fraction: float | None, *, resolution: float, max_iter: int) -> str:
    """One row: ``target`` designed with end dashes at least ``fraction`` · L long (None: none), refined, checked."""
    from airmat.check.inflation_check import check
    from airmat.check.refinement import refine
    from airmat.design.pipeline import DesignParams

    kw = {} if fraction is None else dict(end_dashes=True, L_end_min=fraction * 0.30)
    d = designed_preset(target, DesignParams(spacing=resolution, **kw))
    shortest = min(s.dash.length for s in d.pattern.strings)
    t = time.perf_counter()
    r = refine(d, resolution=resolution, max_iter=max_iter)
    seconds = time.perf_counter() - t
    c = check(r.design, resolution=resolution, envelope=False, known=r.known_runs)
    med = c.runs["median"]
    option = "none" if fraction is None else f">= {fraction:g} L"
    return (f"| {target} | {option} | {len(d.pattern.strings)} | {shortest * 1e3:.0f} | {r.deviation_before.rms_pct_diag:.2f} "
            f"| {med.deviation.rms_pct_diag:.2f} | {'yes' if r.converged and c.converged else 'no'} | {seconds:.1f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", nargs="+", default=TARGETS, help="presets or zoo targets")
    ap.add_argument("--min-fractions", nargs="+", type=float, default=[0.5],
                    help="shortest end dash as a fraction of L, one run each (default 0.5)")
    ap.add_argument("--resolution-mm", type=float, default=20.0, help="Ω's and the inflation's mesh (default 20)")
    ap.add_argument("--max-iter", type=int, default=20, help="Gauss–Newton iterations of the refinement (default 20)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: cylinder-r300 at 40 mm, 2 iterations")
    args = ap.parse_args(argv)
    if args.quick:
        args.targets, args.resolution_mm, args.max_iter = ["cylinder-r300"], 40.0, 2
    print(HEADER)
    print("|---|---|---:|---:|---:|---:|---|---:|", flush=True)
    for target in args.targets:
        for fraction in [None, *args.min_fractions]:
            print(run(target, fraction, resolution=args.resolution_mm / 1000.0, max_iter=args.max_iter), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
