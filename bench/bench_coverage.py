"""Benchmark: how the default pattern covers the mattress, per preset (airmat.design.coverage).

Usage::

    .venv/bin/python bench/bench_coverage.py [--presets vault1,saddle,dome,vault2,roof]
    .venv/bin/python bench/bench_coverage.py --quick      # a smoke run: vault1 only

Each preset is designed with the defaults (paper calibration values, seed 0)
and its ``pattern.coverage`` (what ``design.json`` → ``summary.coverage``
holds) printed as a Markdown table: per family, the widest hole (no line
traced), weak band (dashes whose mean κ is below the threshold) and edge band
(too narrow for a whole dash), in mm; a point within μ₂ + margin of a string
of its family is covered.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from designed_preset import designed_preset  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="vault1,saddle,dome,vault2,roof")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 only")
    args = ap.parse_args(argv)
    if args.quick:
        args.presets = "vault1"
    print("| preset | k1 hole / weak / edge band, max (mm) | k2 hole / weak / edge band, max (mm) |")
    print("|---|---|---|")
    for name in args.presets.split(","):
        cov = designed_preset(name).pattern.coverage
        cells = []
        for fam in ("k1", "k2"):
            c = cov[fam]
            cells.append("needs none" if c["need_points"] == 0 else
                         f'{c["interior_gap_max_mm"]:.0f} / {c["weak_band_max_mm"]:.0f} / {c["edge_band_max_mm"]:.0f}')
        print(f"| {name} | {cells[0]} | {cells[1]} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
