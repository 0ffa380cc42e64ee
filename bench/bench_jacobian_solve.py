"""Benchmark: the refinement's Jacobian solve, ``H X = B`` with one column per string, by cvxopt column by column vs CHOLMOD all at once, on one thread and two.

Usage::

    .venv/bin/python bench/bench_jacobian_solve.py            # vault1, vault2 and the roof at 40 mm
    .venv/bin/python bench/bench_jacobian_solve.py --quick    # a smoke run: vault1, one solve each

The refinement's Gauss–Newton iterations run on the 40 mm mesh (``refine(...,
coarsest=0.04)``), and each one solves with the factor of the Newton matrix
for as many right-hand sides as the design has strings
(:func:`airmat.check.adjoint.equilibrium_jacobian`). The matrix here is U_B's
Hessian at a slightly stretched flat mattress with the preset's strings (the
solver's pattern and ordering, a shift making it positive definite), the
right-hand sides random (a solve's cost does not depend on their values).
Columns: :meth:`~airmat.inflation.cholesky.ShiftedCholesky.solve` with ``one_call=False``
(cvxopt's ``cholmod.solve``, one CHOLMOD call per column, what it did before),
:func:`airmat.inflation.cholmod_block.solve_many` on one thread (one call for all
columns) and on two (two column blocks side by side, what it does when a core
is idle and the right-hand side is large: ``column_blocks``), median of 3; the
largest difference between the first two relative to the solution, and
whether the two-thread answer is the same bits as the one-thread one (``--quick``: vault1, one
solve each). Run it on an idle machine: the two-thread column needs the second core.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import design_strings  # noqa: E402
from airmat.inflation.assembly import build_assembler  # noqa: E402
from airmat.inflation.cholesky import ShiftedCholesky, cvxopt_blas_kernels  # noqa: E402
from airmat.inflation.cholmod_block import available, column_blocks, solve_many  # noqa: E402
from airmat.inflation.energy import block_pattern, hessian_blocks, smoothing_blocks  # noqa: E402
from airmat.inflation.mesh import build_mattress_mesh  # noqa: E402
from airmat.inflation.model import build_model  # noqa: E402
from airmat.inflation.solver import rigid_pins  # noqa: E402


def _median(fn, repeat: int = 3):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1, one solve each")
    ap.add_argument("--resolution-mm", type=float, default=40.0)
    args = ap.parse_args(argv)
    if not available():
        print("CHOLMOD's one-call solve is not available with this cvxopt: nothing to compare", file=sys.stderr)
        return 1
    print(f"OpenBLAS kernels (cvxopt's): {cvxopt_blas_kernels() or '?'}\n")
    print("| preset | mattress (mm) | unknowns | factor non-zeros | right-hand sides (strings) "
          "| cvxopt, column by column (s) | CHOLMOD, all at once (s) | speed-up | largest difference "
          "| CHOLMOD, two threads (s) | column blocks | speed-up over one thread | same bits |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    for preset in (["vault1"] if args.quick else ["vault1", "vault2", "roof"]):
        design = designed_preset(preset)
        mesh = build_mattress_mesh(design.mattress.width, design.mattress.height, design.mattress.thickness,
                                   resolution=args.resolution_mm * MM)
        strings = design_strings(design)
        model = build_model(mesh, strings)
        asm = build_assembler(block_pattern(model), model.n_vertices, rigid_pins(mesh.uv, mesh.top))
        h = asm.assemble(hessian_blocks(model, mesh.vertices * 1.001) + [smoothing_blocks(model)])
        chol = ShiftedCholesky(h, asm.free // 3)
        assert chol.factor(h, 1e-2 * float(np.mean(np.abs(h.diagonal()))))
        b = np.random.default_rng(0).normal(size=(h.shape[0], len(strings.rest)))

        repeat = 1 if args.quick else 3
        t_col, x_col = _median(lambda: chol.solve(b, one_call=False), repeat)
        t_all, x_all = _median(lambda: solve_many(chol._symbolic, b, threads=1), repeat)
        t_two, x_two = _median(lambda: solve_many(chol._symbolic, b, threads=2), repeat)
        diff = float(np.abs(x_all - x_col).max() / np.abs(x_col).max())
        blocks = column_blocks(*b.shape, threads=2)
        print(f"| {preset} | {design.mattress.width / MM:.0f} x {design.mattress.height / MM:.0f} | {h.shape[0]} "
              f"| {chol.factor_nnz} | {b.shape[1]} | {t_col:.3f} | {t_all:.3f} | {t_col / t_all:.1f}x | {diff:.1e} "
              f"| {t_two:.3f} | {' + '.join(str(b1 - b0) for b0, b1 in blocks)} | {t_all / t_two:.2f}x "
              f"| {np.array_equal(x_two, x_all)} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
