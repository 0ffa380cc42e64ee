"""Benchmark: the inflation solver (Newton, sparse Hessian) against a Kangaroo-style baseline.

Usage::

    .venv/bin/python bench/bench_inflation.py             # vault1 (small) at 20 mm, vault2 (large) at 25, 20 mm
    .venv/bin/python bench/bench_inflation.py --resolutions 30,20 --large-resolutions 25
    .venv/bin/python bench/bench_inflation.py --quick      # a smoke run: 40 mm, small only, baseline capped at 1x

For each mesh resolution: the vault1 preset's string pattern (designed once,
uncalibrated) on the small mattress (830 x 740 mm) is inflated by the
project's solver (``airmat.inflation.simulate.inflate``: coarse-to-fine
continuation, string ramp, Newton with a CHOLMOD Cholesky); then the
Kangaroo-style baseline (``bench/kangaroo_baseline.py``) relaxes the same
final model from the flat start to the same relative force residual, with a
time cap of ``--baseline-factor`` (10) times the Newton time, at most
``--baseline-seconds``: a baseline that has not converged by then is at least
that many times slower. The vault2 preset on the large mattress
(2600 x 1600 mm) follows. Prints a Markdown table. Targets: small mattress at
20 mm converged in < 10 s, large in < 60 s, at least 10x faster than the
baseline.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import design_strings  # noqa: E402
from airmat.inflation.mesh import build_mattress_mesh  # noqa: E402
from airmat.inflation.model import Parameters, build_model  # noqa: E402
from airmat.inflation.simulate import inflate, start_positions  # noqa: E402
from airmat.inflation.solver import rigid_pins  # noqa: E402
from kangaroo_baseline import kangaroo_solve  # noqa: E402


def _rows(design, res_list, factor, cap_max):
    """One Markdown row per resolution: Newton (string ramp) vs the baseline on the final model."""
    strings = design_strings(design)
    for res in res_list:
        mesh = build_mattress_mesh(design.mattress.width, design.mattress.height, design.mattress.thickness,
                                   resolution=res * MM)
        t0 = time.perf_counter()
        newton = inflate(mesh, strings)
        t_newton = time.perf_counter() - t0
        model = build_model(mesh, strings, Parameters())
        fixed = rigid_pins(mesh.uv, mesh.top)
        cap = min(factor * t_newton, cap_max)
        base = kangaroo_solve(model, start_positions(mesh, strings), fixed_dofs=fixed,
                              tol=newton.residual if newton.converged else 1e-6, time_limit=cap)
        a0, b0 = base.xyz - base.xyz.mean(axis=0), newton.xyz - newton.xyz.mean(axis=0)
        rot, _ = Rotation.align_vectors(b0, a0)             # the two runs pin different vertices
        gap = np.linalg.norm(rot.apply(a0) - b0, axis=1).max() / MM
        speed = (f"{base.seconds / t_newton:.1f}x" if base.converged
                 else f"> {base.seconds / t_newton:.1f}x")
        print(f"| {design.mattress.width / MM:.0f} x {design.mattress.height / MM:.0f} | {res:g} | {mesh.n_vertices} "
              f"| {t_newton:.1f} | {newton.n_iter} | {newton.converged} "
              f"| {newton.residual:.1e} | {base.seconds:.1f} | {base.n_iter} | {base.residual:.1e} "
              f"| {base.converged} | {speed} | {gap:.1f} |", flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="vault1")
    ap.add_argument("--resolutions", default="20", help="mesh edge lengths in mm (default 20)")
    ap.add_argument("--large-preset", default="vault2", help="design on the large mattress ('' to skip)")
    ap.add_argument("--large-resolutions", default="25,20", help="its mesh edge lengths in mm (default 25,20)")
    ap.add_argument("--baseline-factor", type=float, default=10.0,
                    help="time cap of the baseline, in multiples of the Newton time (default 10)")
    ap.add_argument("--baseline-seconds", type=float, default=600.0, help="largest time cap of the baseline")
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run: vault1 at 40 mm, no large, the baseline capped at 1x the Newton time")
    args = ap.parse_args(argv)
    if args.quick:
        args.baseline_factor = min(args.baseline_factor, 1.0)
    res_list = [40.0] if args.quick else [float(r) for r in args.resolutions.split(",")]
    runs = [(args.preset, res_list)]
    if args.large_preset and not args.quick:
        runs.append((args.large_preset, [float(r) for r in args.large_resolutions.split(",")]))
    designs = []
    for preset, _ in runs:
        designs.append(designed_preset(preset))
    for (preset, _), design in zip(runs, designs):
        print(f"{preset}: {len(design_strings(design))} strings on {design.mattress.width / MM:.0f} x "
              f"{design.mattress.height / MM:.0f} mm")
    print("\n| mattress (mm) | resolution (mm) | vertices | Newton: time (s) | Newton iterations | converged "
          "| residual | baseline: time (s) | baseline iterations | baseline residual | reached | speed-up "
          "| max distance of the two solutions (mm) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for (_, res), design in zip(runs, designs):
        _rows(design, res, args.baseline_factor, args.baseline_seconds)
    print(f"\nbaseline: Kangaroo-style goal averaging with momentum (damping 0.9), same final U_B, flat "
          f"start, stopped at the Newton run's residual or after {args.baseline_factor:g} x the Newton "
          f"time (at most {args.baseline_seconds:g} s). Distance: after a rigid alignment.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
