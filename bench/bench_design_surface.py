"""Benchmark the surface side of the designer on the five presets, time by stage.

For each preset: build the target, triangulate Ω (and build the BVH),
relax to Ŝ (U_A), estimate the curvature, write the Table-1 report, carry
the field onto Ω. Prints a Markdown table of the times and one of the
Table-1 figures (σ, |κ1|, |κ2|) next to the paper's.

Usage::

    .venv/bin/python bench/bench_design_surface.py                      # all presets, default spacing
    .venv/bin/python bench/bench_design_surface.py --presets vault1 --spacing-small-mm 40   # quick
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from airmat.design.presets import PRESETS, preset  # noqa: E402
from airmat.design.surface import approximate_surface, mattress_field  # noqa: E402

#: the paper's Table 1: σ avg // max deviation, |κ1| avg // max, |κ2| avg // max
PAPER = {"vault1": "0.9988 // 0.9661 | 3.2 // 5.2 | 0.43 // 2.0",
         "saddle": "0.9933 // 0.9397 | 2.2 // 3.9 | 1.1 // 2.0",
         "dome": "0.9973 // 0.9341 | 8.6 // 35 | 0.86 // 11",
         "vault2": "0.9971 // 0.9708 | 1.8 // 3.1 | 0.15 // 1.4",
         "roof": "0.9938 // 0.9421 | 2.0 // 5.8 | 0.56 // 3.3"}


def run(name: str, spacing: float) -> dict:
    t = time.perf_counter()
    target, mattress = preset(name)
    t_build = time.perf_counter() - t
    approx = approximate_surface(target, mattress, spacing=spacing, progress=False)
    t = time.perf_counter()
    mattress_field(approx)
    t_transfer = time.perf_counter() - t
    tm = approx.timings
    return {"name": name, "n": len(approx.uv), "build": t_build, "triangulate": tm["triangulate"],
            "relax": tm["relax"], "curvature": tm["curvature"], "report": tm["report"],
            "transfer": t_transfer, "iters": approx.relax.n_iter, "converged": approx.relax.converged,
            "approx": approx}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", default=",".join(PRESETS), help="comma-separated preset names")
    parser.add_argument("--spacing-small-mm", type=float, default=20.0, help="Ω mesh spacing, 830 × 740 mm")
    parser.add_argument("--spacing-large-mm", type=float, default=25.0, help="Ω mesh spacing, 2600 × 1600 mm")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    t = time.perf_counter()
    from airmat.lazy import import_open3d

    import_open3d()       # a one-off cost of every run (as airmat imports it), kept out of the per-preset times
    print(f"import open3d: {time.perf_counter() - t:.2f} s\n")
    rows = []
    for name in args.presets.split(","):
        small = name in ("vault1", "saddle", "dome")
        spacing = 1e-3 * (args.spacing_small_mm if small else args.spacing_large_mm)
        rows.append(run(name, spacing))
    print("| preset | vertices | target build (s) | triangulate + BVH (s) | relax (s) | iterations "
          "| curvature (s) | report (s) | transfer (s) | surface side total (s) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        total = r["triangulate"] + r["relax"] + r["curvature"] + r["report"] + r["transfer"]
        print(f"| {r['name']} | {r['n']} | {r['build']:.2f} | {r['triangulate']:.2f} | {r['relax']:.2f} "
              f"| {r['iters']}{'' if r['converged'] else ' (not converged)'} | {r['curvature']:.2f} "
              f"| {r['report']:.2f} | {r['transfer']:.2f} | {total:.2f} |")
    print()
    print("| preset | σ min / avg / max | abs κ1 avg // max (1/m) | abs κ2 avg // max (1/m) | constructible "
          "| paper σ avg // max dev. | paper κ1 | paper κ2 |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        rep = r["approx"].report
        print(f"| {r['name']} | {rep.table_row()} | {'yes' if rep.constructible else 'no'} | {PAPER[r['name']]} |")
    for r in rows:
        for reason in r["approx"].report.reasons:
            print(f"- {r['name']}: {reason}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
