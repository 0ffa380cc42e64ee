"""Benchmark: string-pattern density against how far the inflated mattress lands from Ŝ.

Usage::

    .venv/bin/python bench/bench_density.py                               # vault1, saddle at 20 mm
    .venv/bin/python bench/bench_density.py --presets vault1 --resolution-mm 40 --patterns 400x100,300x50
    .venv/bin/python bench/bench_density.py --quick       # a smoke run: vault1, 300x50, 40 mm

Each pattern ``MU1xMU2`` (mm; L stays the calibration's 300 mm) designs the
preset (paper calibration values, seed 0), inflates it at its median string
lengths and measures, against Ŝ after a rigid alignment, the RMS deviation of
the simulated mid-surface and of each face. ``gap`` is how far (mm, on Ω) the
point of Ω that needs a family's strings (|κ| above the threshold) lies from
the nearest string of that family, at its 95th percentile and its maximum: a
band left unstrung shows as a large gap. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from scipy.spatial import cKDTree  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from airmat.geometry.polyline import points_at_fractions  # noqa: E402
from airmat.check.inflation_check import check  # noqa: E402
from airmat.design.pipeline import DesignParams, design  # noqa: E402
from airmat.design.presets import preset  # noqa: E402
from airmat.inflation.mesh import locate  # noqa: E402

MM = 1e-3


def face_rms(inflation, xyz, uv) -> dict:
    """RMS distance (m) of the aligned mid-surface, top face and bottom face from Ŝ."""
    mesh = inflation.mesh
    tri, bary = locate(mesh, uv)
    top = np.einsum("kj,kjd->kd", bary, inflation.xyz[mesh.top[tri]])
    bottom = np.einsum("kj,kjd->kd", bary, inflation.xyz[mesh.bottom[tri]])
    out = {}
    for name, pts in (("mid", 0.5 * (top + bottom)), ("top", top), ("bottom", bottom)):
        tc, pc = xyz.mean(axis=0), pts.mean(axis=0)
        rot, _ = Rotation.align_vectors(xyz - tc, pts - pc)
        out[name] = float(np.sqrt(np.mean(np.sum((rot.apply(pts - pc) + tc - xyz) ** 2, axis=1))))
    return out


def gaps(result) -> dict:
    """95th percentile and largest distance (m) on Ω from a point needing a family to its strings."""
    uv, out = result.approx.uv, {}
    for f, fam in enumerate(("k1", "k2")):
        need = np.abs(result.mfield.kappa_at(f, uv)) >= result.params.kappa_min
        polys = [s.dash.polyline for s in result.pattern.strings if s.dash.family == fam]
        if not need.any():
            out[fam] = (0.0, 0.0)
            continue
        if not polys:
            out[fam] = (np.inf, np.inf)
            continue
        pts = np.concatenate([points_at_fractions(p, np.linspace(0, 1, 61)) for p in polys])
        d, _ = cKDTree(pts).query(uv[need])
        out[fam] = (float(np.percentile(d, 95)), float(d.max()))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", default="vault1,saddle")
    ap.add_argument("--patterns", default="400x100,300x100,400x50,300x50",
                    help="comma-separated MU1xMU2 in mm (default: the old default 400x100 and denser ones)")
    ap.add_argument("--resolution-mm", type=float, default=20.0)
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1, the default 300x50, 40 mm")
    args = ap.parse_args(argv)
    if args.quick:
        args.presets, args.patterns, args.resolution_mm = "vault1", "300x50", 40.0
    print("| preset | mu1 x mu2 (mm) | strings | k1 gap p95 // max (mm) | k2 gap p95 // max (mm) "
          "| mid RMS (mm) | top RMS (mm) | bottom RMS (mm) | best face % diag | converged | s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    for name in args.presets.split(","):
        target, mattress = preset(name)
        for pat in args.patterns.split(","):
            mu1, mu2 = (float(v) * MM for v in pat.split("x"))
            t0 = time.perf_counter()
            result = design(target, mattress, params=DesignParams(mu1=mu1, mu2=mu2), progress=False)
            run = check(result, resolution=args.resolution_mm * MM, envelope=False).runs["median"]
            rms = face_rms(run.inflation, result.approx.xyz, result.approx.uv)
            diag = float(np.linalg.norm(np.ptp(result.approx.xyz, axis=0)))
            g = gaps(result)
            best = min(rms["top"], rms["bottom"])
            print(f"| {name} | {pat} | {len(result.pattern.strings)} | "
                  + " | ".join(f"{g[f][0] / MM:.0f} // {g[f][1] / MM:.0f}" for f in ("k1", "k2"))
                  + f" | {rms['mid'] / MM:.1f} | {rms['top'] / MM:.1f} | {rms['bottom'] / MM:.1f} "
                  f"| {100 * best / diag:.2f} | {run.inflation.converged} | {time.perf_counter() - t0:.0f} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
