"""Benchmark: how close an open-loop design comes when each string family's curvature is scaled by one gain.

Usage::

    .venv/bin/python bench/bench_family_gain.py                                  # the saddle, a 3 x 4 grid
    .venv/bin/python bench/bench_family_gain.py --presets vault1 --bottom 0.9,1,1.1,1.2 --top 1

An open-loop rule for the interaction of the two families (the k1 bend that
stiffens the saddle's middle against the k2 bend, README "Where the deviation
sits") would at its simplest be one gain per family: each dash's κ under the
strings on the bottom face (κ > 0) scaled by ``bottom``, under those on the
top face (κ < 0) by ``top``, before Equation 3 gives the lengths. This
designs the preset (paper calibration values, seed 0, defaults otherwise)
with every pair of gains, inflates it at the median lengths at 20 mm and
prints the named face's RMS deviation from Ŝ (the check's measure, ``airmat
inflate``), as a Markdown table. Gains 1, 1 are the default design. The
gains are an experiment, not an option of the designer: the best pair says
how far any per-family rule could take the open loop.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from unittest import mock

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import airmat.design.string_lengths as string_lengths  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402
from designed_preset import designed_preset  # noqa: E402

MM = 1e-3


def gained(bottom: float, top: float):
    """``airmat.design.string_lengths.dash_kappa`` with κ > 0 scaled by ``bottom`` and κ < 0 by ``top``."""
    plain = string_lengths.dash_kappa

    def dash_kappa(*args, **kwargs):
        kappa = plain(*args, **kwargs)
        return np.where(kappa > 0, bottom * kappa, top * kappa)

    return mock.patch.object(string_lengths, "dash_kappa", dash_kappa)


def floats(text: str) -> list:
    return [float(v) for v in text.split(",")]


def open_loop_cells(result, resolution: float) -> str:
    """Inflate ``result`` at its median lengths (``resolution`` m, no envelope); the table's last cells:
    strings, named face, RMS mm (% diag), max mm, converged."""
    run = check(result, resolution=resolution, envelope=False)
    med = run.runs["median"]
    dev = med.deviation
    return (f"| {len(result.pattern.strings)} | {run.surface} | {dev.rms / MM:.1f} ({dev.rms_pct_diag:.2f}) "
            f"| {dev.max / MM:.1f} | {med.inflation.converged} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="saddle", help="comma-separated preset names")
    ap.add_argument("--bottom", type=floats, default=[0.9, 1.0, 1.1],
                    help="gains on κ > 0 (the strings on the bottom face), comma-separated")
    ap.add_argument("--top", type=floats, default=[1.0, 1.2, 1.4, 1.6],
                    help="gains on κ < 0 (the strings on the top face), comma-separated")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    args = ap.parse_args(argv)
    print("| preset | gain, bottom strings (κ > 0) | gain, top strings (κ < 0) | strings | named face "
          "| RMS mm (% diag) | max mm | converged |")
    print("|---|---:|---:|---:|---|---|---:|---|")
    for name in args.presets.split(","):
        for b in args.bottom:
            for t in args.top:
                with gained(b, t):
                    result = designed_preset(name)
                print(f"| {name} | {b:g} | {t:g} " + open_loop_cells(result, args.resolution_mm * MM), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
