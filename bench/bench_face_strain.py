"""Benchmark: how much each face of the inflated mattress keeps its length, along u and along v, against Ŝ.

Usage::

    .venv/bin/python bench/bench_face_strain.py [--preset saddle] [--resolution-mm 20]

The preset is designed with the defaults (paper values, seed 0) and inflated
at its median lengths. Along five lines of constant v (and of constant u),
from 10 % to 90 % of the mattress, the length of the top face, the
mid-surface, the bottom face and Ŝ is divided by the line's flat length on Ω.
Ŝ keeps Ω's lengths; a face with strings on it shortens across them. Prints a
Markdown table.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from scipy.interpolate import LinearNDInterpolator  # noqa: E402

from designed_preset import designed_preset  # noqa: E402
from airmat.check.compare import surface_at  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402


def _length(xyz) -> float:
    return float(np.linalg.norm(np.diff(xyz, axis=0), axis=1).sum())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="saddle")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    args = ap.parse_args(argv)
    d = designed_preset(args.preset)
    inf = check(d, resolution=args.resolution_mm * 1e-3, envelope=False).runs["median"].inflation
    s_hat = LinearNDInterpolator(d.approx.uv, d.approx.xyz)
    w, h = d.mattress.width, d.mattress.height
    print(f"| {args.preset}: line | top | mid | bottom | Ŝ |")
    print("|---|---:|---:|---:|---:|")
    for along in ("u", "v"):
        for frac in (0.15, 0.3, 0.5, 0.7, 0.85):
            t = np.linspace(0.1, 0.9, 81)
            uv = (np.column_stack([t * w, np.full_like(t, frac * h)]) if along == "u"
                  else np.column_stack([np.full_like(t, frac * w), t * h]))
            flat = float(np.linalg.norm(uv[-1] - uv[0]))
            cells = [_length(surface_at(inf, uv, face)[0]) / flat for face in ("top", "mid", "bottom")]
            cells.append(_length(s_hat(uv)) / flat)
            other = "v" if along == "u" else "u"
            print(f"| along {along} at {other} = {frac:.2f} | " + " | ".join(f"{c:.3f}" for c in cells) + " |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
