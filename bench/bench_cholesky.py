"""Benchmark: one factorization of the inflation solver's Newton matrix, by ordering and library.

Usage::

    .venv/bin/python bench/bench_cholesky.py            # vault1 (small) and vault2 (large) at 20 mm
    .venv/bin/python bench/bench_cholesky.py --quick    # a smoke run: vault1 at 40 mm, one factorization each

The matrix is U_B's Hessian at a slightly stretched flat mattress with the
preset's strings (the pattern is the solver's; a shift makes it positive
definite). Rows: scipy SuperLU (MMD on AᵀA + A, diagonal pivots: the
solver's former linear algebra), CHOLMOD with its default ordering (AMD) and
CHOLMOD with METIS nested dissection of the vertex graph (the solver's
choice), and that last one again in a subprocess whose OpenBLAS (cvxopt's
bundled 0.3.15) runs its Prescott (SSE3) kernels, what its own CPU detection
falls back to on recent Xeons (see :mod:`airmat.inflation.cholesky`). Median
of 3 numeric factorizations (one with ``--quick``); the symbolic analysis is timed separately (done
once per solve). The BLAS kernels in use are named in the method column.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

from airmat.units import MM  # noqa: E402
from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import design_strings  # noqa: E402
from airmat.inflation.assembly import build_assembler  # noqa: E402
from airmat.inflation.cholesky import ShiftedCholesky, cvxopt_blas_kernels  # noqa: E402
from airmat.inflation.energy import block_pattern, hessian_blocks, smoothing_blocks  # noqa: E402
from airmat.inflation.mesh import build_mattress_mesh  # noqa: E402
from airmat.inflation.model import build_model  # noqa: E402
from airmat.inflation.solver import rigid_pins  # noqa: E402


def _median_time(fn, repeat: int = 3) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm, one factorization each")
    ap.add_argument("--metis-only", action="store_true", help=argparse.SUPPRESS)   # the subprocess's rows
    args = ap.parse_args(argv)
    cases = [("vault1", 40.0)] if args.quick else [("vault1", 20.0), ("vault2", 20.0)]
    repeat = 1 if args.quick else 3
    if not args.metis_only:
        print("| preset | mattress (mm) | resolution (mm) | unknowns | method | symbolic (s) | numeric (s) "
              "| factor non-zeros |")
        print("|---|---|---|---|---|---|---|---|", flush=True)
    for preset, res in cases:
        design = designed_preset(preset)
        mesh = build_mattress_mesh(design.mattress.width, design.mattress.height, design.mattress.thickness,
                                   resolution=res * MM)
        model = build_model(mesh, design_strings(design))
        fixed = rigid_pins(mesh.uv, mesh.top)
        asm = build_assembler(block_pattern(model), model.n_vertices, fixed)
        h = asm.assemble(hessian_blocks(model, mesh.vertices * 1.001) + [smoothing_blocks(model)])
        mu = 1e-2 * float(np.mean(np.abs(h.diagonal())))
        n = h.shape[0]
        head = f"| {preset} | {design.mattress.width / MM:.0f} x {design.mattress.height / MM:.0f} | {res:g} | {n} "
        a = (h + mu * sp.identity(n, format="csr")).tocsc()
        lu = [None]

        def superlu():
            lu[0] = spla.splu(a, permc_spec="MMD_AT_PLUS_A",
                              options=dict(SymmetricMode=True, DiagPivotThresh=0.0))

        methods = [("CHOLMOD (AMD)", None), ("CHOLMOD (METIS, vertex graph)", asm.free // 3)]
        if args.metis_only:
            methods = methods[1:]
        else:
            t = _median_time(superlu, repeat)
            print(head + f"| SuperLU (MMD) | - | {t:.3f} | {lu[0].L.nnz} |", flush=True)
        for name, groups in methods:
            t0 = time.perf_counter()
            chol = ShiftedCholesky(h, groups)
            t_sym = time.perf_counter() - t0
            t = _median_time(lambda: chol.factor(h, mu), repeat)
            blas = f"OpenBLAS {cvxopt_blas_kernels() or '?'}"
            print(head + f"| {name}, {blas} | {t_sym:.3f} | {t:.3f} | {chol.factor_nnz} |",
                  flush=True)
    if not args.metis_only:
        env = dict(os.environ, OPENBLAS_CORETYPE="Prescott")
        subprocess.run([sys.executable, __file__, "--metis-only"] + (["--quick"] if args.quick else []),
                       env=env, check=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
