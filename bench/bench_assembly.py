"""Benchmark: building the Newton matrix's fixed CSR pattern, per block against per entry.

Usage::

    .venv/bin/python bench/bench_assembly.py            # vault1 (small) at 80/40/20 mm and vault2 (large) at 20 mm
    .venv/bin/python bench/bench_assembly.py --quick    # a smoke run: vault1 at 40 mm, one build each

Every inflation, every Newton system of a refinement's trial equilibria, builds
the CSR pattern of its Newton matrix once (:func:`airmat.inflation.assembly.build_assembler`).
The baseline is the former build, kept here: one ``np.unique`` over the nine
scalar entries of every block. The build in use merges the blocks by vertex
pair (nine times fewer keys) and places each block's entries by arithmetic.
Median of 3 builds each (one with ``--quick``); the last column says whether the two patterns (column
indices, row pointers and every entry's data slot) are the same arrays.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

from designed_preset import designed_preset  # noqa: E402
from airmat.check.inflation_check import design_strings  # noqa: E402
from bench_jacobian_solve import _median  # noqa: E402
from airmat.inflation.assembly import Assembler, build_assembler, reduced_dofs  # noqa: E402
from airmat.inflation.energy import block_pattern  # noqa: E402
from airmat.inflation.mesh import build_mattress_mesh  # noqa: E402
from airmat.inflation.model import build_model  # noqa: E402
from airmat.inflation.solver import rigid_pins  # noqa: E402


def per_entry(pattern: list, n_vertices: int, fixed_dofs=()) -> Assembler:
    """The former build (the baseline): one key per scalar entry, merged by ``np.unique``."""
    _, free, red = reduced_dofs(n_vertices, fixed_dofs)
    rows = np.concatenate([r for r, _ in pattern])
    cols = np.concatenate([c for _, c in pattern])
    comp = np.arange(3)
    dr = red[(3 * rows[:, None, None] + comp[None, :, None]).repeat(3, axis=2).reshape(-1)]
    dc = red[(3 * cols[:, None, None] + comp[None, None, :]).repeat(3, axis=1).reshape(-1)]
    ok = (dr >= 0) & (dc >= 0)
    n_free = len(free)
    uniq, inv = np.unique(dr[ok] * n_free + dc[ok], return_inverse=True)
    slot = np.full(len(dr), len(uniq), np.int64)
    slot[ok] = inv
    indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // n_free, minlength=n_free))])
    return Assembler(n_free=n_free, free=free, slot=slot, indices=(uniq % n_free).astype(np.int32),
                     indptr=indptr.astype(np.int32))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1 at 40 mm, one build each")
    args = ap.parse_args(argv)
    cases = ([("vault1", 40.0)] if args.quick
             else [("vault1", 80.0), ("vault1", 40.0), ("vault1", 20.0), ("vault2", 20.0)])
    repeat = 1 if args.quick else 3
    print("| preset | resolution (mm) | vertices | blocks | pattern non-zeros | per entry (s) | per block (s) "
          "| speed-up | same pattern |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|")
    designs = {}
    for name, res_mm in cases:
        d = designs.setdefault(name, designed_preset(name))
        mesh = build_mattress_mesh(d.mattress.width, d.mattress.height, d.mattress.thickness,
                                   resolution=res_mm * 1e-3)
        model = build_model(mesh, design_strings(d, "median"))
        pattern, fixed = block_pattern(model), rigid_pins(mesh.uv, mesh.top)
        t_old, a = _median(lambda: per_entry(pattern, model.n_vertices, fixed), repeat)
        t_new, b = _median(lambda: build_assembler(pattern, model.n_vertices, fixed), repeat)
        same = a.n_free == b.n_free and all(np.array_equal(getattr(a, k), getattr(b, k))
                                            for k in ("free", "slot", "indices", "indptr"))
        print(f"| {name} | {res_mm:.0f} | {model.n_vertices} | {sum(len(r) for r, _ in pattern)} | {b.nnz} "
              f"| {t_old:.3f} | {t_new:.3f} | {t_old / t_new:.1f}x | {same} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
