"""Benchmark: where on Ω the open-loop deviation from Ŝ sits (near the edge, far from strings, by thirds).

Usage::

    .venv/bin/python bench/bench_deviation_map.py [--presets vault1,saddle] [--resolution-mm 20]
    .venv/bin/python bench/bench_deviation_map.py --refine      # the same, at the refined lengths
    .venv/bin/python bench/bench_deviation_map.py --quick       # a smoke run: vault1 at 40 mm

Each preset is designed with the defaults (paper calibration values, seed 0)
and inflated at its median lengths (``airmat.check.inflation_check.check``, no
envelope); the distance of the named face from Ŝ at each of Ŝ's vertices
(after the check's rigid alignment) is split by where the vertex lies on Ω:
within ``--edge-mm`` of the mattress's edge or inside it, and within
``--near-mm`` of a string (its chord on Ω) or farther. Each row gives the
RMS of each part and its share of the squared deviation; the last column
is the RMS in each third of Ω along u and v (rows from high v to low v,
i.e. as the plan is drawn), which shows whether a design misses at its
edges or in its middle. No timing in this table.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402


def split(per_vertex, mask) -> str:
    """RMS (mm) of ``per_vertex`` (m) over ``mask`` and that part's share of the squared sum."""
    e2 = per_vertex ** 2
    return f"{1e3 * np.sqrt(np.mean(e2[mask])):.1f} ({100 * e2[mask].sum() / e2.sum():.0f} %)"


def thirds(uv, per_vertex, width, height) -> str:
    """RMS (mm) in each third of Ω, rows from high v to low v, as 'a b c / d e f / g h i'."""
    i = np.minimum((3 * uv[:, 0] / width).astype(int), 2)
    j = np.minimum((3 * uv[:, 1] / height).astype(int), 2)
    rows = [" ".join(f"{1e3 * np.sqrt(np.mean(per_vertex[(i == c) & (j == r)] ** 2)):.0f}" for c in range(3))
            for r in (2, 1, 0)]
    return " / ".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="vault1,saddle")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--edge-mm", type=float, default=100.0, help="the edge strip's width (default 100 mm)")
    ap.add_argument("--near-mm", type=float, default=80.0,
                    help="a vertex this close to a string is near one (default 80 mm, the coverage limit)")
    ap.add_argument("--refine", action="store_true", help="measure the refined designs")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm")
    args = ap.parse_args(argv)
    if args.quick:
        args.presets, args.resolution_mm = "vault1", 40.0
    print(f"| preset | lengths | face | RMS mm (% diag) | edge strip ({args.edge_mm:g} mm): share of Ω | "
          f"edge strip RMS mm (share of squared) | inside RMS mm (share) | farther than {args.near_mm:g} mm "
          "from a string: share of Ω | its RMS mm (share) | RMS mm by thirds of Ω (v high → low; u left → right) |")
    print("|---|---|---|---|---:|---|---|---:|---|---|")
    for name in args.presets.split(","):
        d = designed_preset(name, refine_at=args.resolution_mm * 1e-3 if args.refine else None)
        c = check(d, resolution=args.resolution_mm * 1e-3, envelope=False)
        dev = c.runs["median"].deviation
        uv, w, h = d.approx.uv, d.mattress.width, d.mattress.height
        strings = d.pattern.strings
        chords = np.concatenate([np.linspace(s.dash.polyline[0], s.dash.polyline[-1], 31) for s in strings])
        near = cKDTree(chords).query(uv)[0] < args.near_mm * 1e-3
        edge = np.minimum.reduce([uv[:, 0], w - uv[:, 0], uv[:, 1], h - uv[:, 1]]) < args.edge_mm * 1e-3
        far = f"{100 * np.mean(~near):.1f} % | {split(dev.per_vertex, ~near)}" if (~near).any() else "0 % | –"
        print(f"| {name} | {'refined' if args.refine else 'open loop'} | {dev.surface} "
              f"| {1e3 * dev.rms:.1f} ({dev.rms_pct_diag:.2f}) | {100 * edge.mean():.0f} % "
              f"| {split(dev.per_vertex, edge)} | {split(dev.per_vertex, ~edge)} | {far} "
              f"| {thirds(uv, dev.per_vertex, w, h)} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
