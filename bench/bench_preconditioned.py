"""Benchmark: Newton steps by Cholesky factorizations against conjugate gradients preconditioned without U_B5's far couplings.

Usage::

    .venv/bin/python bench/bench_preconditioned.py                       # vault1, saddle, vault2, roof at 20 mm
    .venv/bin/python bench/bench_preconditioned.py --presets vault2 --repeats 3
    .venv/bin/python bench/bench_preconditioned.py --presets hypar-0.5-large vault2 --carry-on --repeats 2
    .venv/bin/python bench/bench_preconditioned.py --quick               # a smoke run: vault1 at 40 mm

Two tables, one run. First, the finest mesh's Newton matrix (each preset's open-loop design,
paper calibration, seed 0, the Hessian at the flat mattress shifted to be definite): its
unknowns, and the Cholesky factor's non-zeros, floating-point work (the sum of its squared
column counts) and numeric time (median of 3) with every term, and without the entries only
U_B5 couples (the preconditioner of :mod:`airmat.inflation.preconditioned`).

Second, one inflation from the flat mattress per preset, per way of taking the Newton steps
on the finest mesh (the coarser meshes of the continuation by factorizations either way):
Cholesky factorizations (``pcg_min`` above the unknowns), and preconditioned conjugate
gradients (``pcg_min`` = the finest mesh's unknowns), in turn; their times (median of ``--repeats``),
Newton iterations, factorizations and conjugate-gradient iterations over the whole run, and
the largest distance between the two equilibria's vertices. Targets: the large
mattress ≤ 10 s and the small ≤ 2 s at 20 mm, the same equilibrium within 0.1 mm.

``--carry-on``: the second table's runs are equilibria carried on instead
(:func:`airmat.inflation.simulate.inflate_from`, the refinement's verification and a refined
design's check): each preset (or zoo target) is refined at the resolution first
(:func:`airmat.check.refinement.refine`), its open-loop strings inflated from the flat mattress
once, and that equilibrium carried on to the refined lengths both ways.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from inflation_target import SAME_MM, largest_gap_mm, seconds_target  # noqa: E402

PRESETS = ("vault1", "saddle", "vault2", "roof")


class _Counts:
    """Factorizations and conjugate-gradient iterations of the runs (wrapping the two functions that do them)."""

    def __init__(self):
        import airmat.inflation.cholesky as cholesky
        import airmat.inflation.preconditioned as preconditioned

        self.factorizations = self.cg = 0
        factor, pcg = cholesky.ShiftedCholesky.factor, preconditioned.pcg

        def counted_factor(chol, *a, **k):
            self.factorizations += 1
            return factor(chol, *a, **k)

        def counted_pcg(*a, **k):
            out = pcg(*a, **k)
            self.cg += out[1]
            return out

        cholesky.ShiftedCholesky.factor = counted_factor
        preconditioned.pcg = counted_pcg

    def reset(self):
        self.factorizations = self.cg = 0


def factor_row(name: str, mesh, strings) -> str:
    """The finest mesh's factor with and without U_B5's far couplings."""
    from airmat.inflation.assembly import build_assembler
    from airmat.inflation.cholesky import ShiftedCholesky
    from airmat.inflation.energy import block_pattern, hessian_blocks, smoothing_blocks
    from airmat.inflation.model import Parameters, build_model
    from airmat.inflation.preconditioned import PreconditionedSystem
    from airmat.inflation.solver import rigid_pins

    model = build_model(mesh, strings, Parameters())
    pattern = block_pattern(model)
    asm = build_assembler(pattern, model.n_vertices, rigid_pins(mesh.uv, mesh.top))
    h = asm.assemble(hessian_blocks(model, mesh.vertices) + [smoothing_blocks(model)])
    mu = 10.0 * float(np.abs(h.diagonal()).max())
    cells = []
    for matrix in (h, PreconditionedSystem(pattern, model.smoothing, asm).preconditioner(h)):
        chol = ShiftedCholesky(matrix, asm.free // 3)
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            assert chol.factor(matrix, mu)
            times.append(time.perf_counter() - t0)
        cols = chol.factor_columns().astype(float)
        cells.append(f"{cols.sum() / 1e6:.1f} | {np.sum(cols ** 2) / 1e9:.2f} | {statistics.median(times):.3f}")
    return f"| {name} | {asm.n_free} | " + " | ".join(cells) + " |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--presets", nargs="+", default=list(PRESETS), help="presets or zoo targets (names)")
    ap.add_argument("--resolution", type=float, default=20.0, help="mesh edge length (mm, default 20)")
    ap.add_argument("--repeats", type=int, default=1, help="inflations per way (median time)")
    ap.add_argument("--carry-on", action="store_true",
                    help="time equilibria carried on from the open loop to the refined lengths (inflate_from)")
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm")
    args = ap.parse_args(argv)
    presets, res = (["vault1"], 40.0) if args.quick else (args.presets, args.resolution)

    from airmat.check.inflation_check import design_strings, open_loop_strings
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.simulate import inflate, inflate_from

    counts = _Counts()
    cases = []
    for preset in presets:
        design = designed_preset(preset, refine_at=res * MM if args.carry_on else None)
        m = design.mattress
        mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=res * MM)
        strings = design_strings(design)
        if args.carry_on:
            start = inflate(mesh, open_loop_strings(design))
            run_way = (lambda pcg_min, start=start, strings=strings: inflate_from(start, strings, pcg_min=pcg_min))
        else:
            run_way = (lambda pcg_min, mesh=mesh, strings=strings: inflate(mesh, strings, pcg_min=pcg_min))
        cases.append((preset, m, mesh, strings, run_way))

    print("| preset | unknowns | all terms: factor non-zeros (M) | all terms: GF | all terms: numeric (s) "
          "| without U_B5's far couplings: factor non-zeros (M) | without: GF | without: numeric (s) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for preset, m, mesh, strings, _ in cases:
        print(factor_row(preset, mesh, strings), flush=True)
    print()
    ways = ("Cholesky", "PCG")
    print("| preset | run | mattress (mm) | resolution (mm) | unknowns | " + " | ".join(
        f"{w}: s | {w}: Newton iterations | {w}: factorizations" for w in ways)
          + " | PCG: CG iterations | speed-up | max vertex distance (mm) | target (s) | met |")
    print("|---|---|---|---|---:|" + "---:|---:|---:|" * len(ways) + "---:|---:|---:|---:|---|")
    kind = "carried on to the refined lengths" if args.carry_on else "from the flat mattress"
    for preset, m, mesh, strings, run_way in cases:
        unknowns = 3 * mesh.n_vertices - 6
        times, last = {w: [] for w in ways}, {}
        for _ in range(max(args.repeats, 1)):          # the two ways in turn: a slow spell of the machine hits both
            for way, pcg_min in zip(ways, (unknowns + 1, unknowns)):
                counts.reset()
                t0 = time.perf_counter()
                run = run_way(pcg_min)
                times[way].append(time.perf_counter() - t0)
                last[way] = (run, counts.factorizations, counts.cg)
        runs = {w: (last[w][0], statistics.median(times[w]), last[w][1], last[w][2]) for w in ways}
        (a, ta, _, _), (b, tb, _, cg) = runs["Cholesky"], runs["PCG"]
        gap, target = largest_gap_mm(a, b), seconds_target(m)
        cells = " | ".join(f"{t:.1f} | {r.n_iter} | {f}" for r, t, f, _ in runs.values())
        print(f"| {preset} | {kind} | {m.width / MM:.0f} x {m.height / MM:.0f} | {res:g} | {unknowns} | {cells} | {cg} "
              f"| {ta / tb:.2f}x | {gap:.5f} | {target:g} | {'yes' if min(ta, tb) <= target and gap <= SAME_MM else 'no'} |",
              flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
