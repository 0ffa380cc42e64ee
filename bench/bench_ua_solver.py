"""Benchmark: the linear solves of U_A's projected Newton, CHOLMOD against scipy's SuperLU.

Usage::

    .venv/bin/python bench/bench_ua_solver.py            # vault1, saddle, dome presets and four zoo targets
    .venv/bin/python bench/bench_ua_solver.py --quick    # a smoke run: vault1

Every design relaxes Ŝ by projected Newton on U_A (:func:`airmat.design.ua_newton.newton`), one
factorization of ``H + μ I`` per iteration on a fixed pattern, twice more in the named face's metric,
and the fold route relaxes again per trial weight. The solver in use is the inflation's sparse
Cholesky (:class:`airmat.inflation.cholesky.ShiftedCholesky`: ordering and symbolic analysis once per
pattern); the baseline, kept here, is scipy's SuperLU in symmetric mode factorizing each matrix from
scratch. The same design runs with each (the whole designer, one process, one after the other);
"factorizations" counts the numeric ones, "largest Ŝ difference" compares the two designs' Ŝ
vertices.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
from scipy.sparse.linalg import splu  # noqa: E402

import airmat.design.ua_newton as ua  # noqa: E402
from airmat.design.mattress import Mattress  # noqa: E402
from airmat.design.pipeline import design  # noqa: E402
from airmat.design.presets import preset  # noqa: E402
from airmat.synthetic.zoo import zoo  # noqa: E402

PRESETS = ("vault1", "saddle", "dome")
ZOO = ("hypar-1.0-k2", "egg-crate", "dome-r450", "helicoid-p500")


class SuperLUBaseline:
    """The baseline with :class:`~airmat.inflation.cholesky.ShiftedCholesky`'s interface: SuperLU of
    ``H + μ I`` from scratch at every factorization (a minimum-degree ordering of AᵀA, no pivoting)."""

    def __init__(self):
        self.n_factorizations, self._lu = 0, None

    def factor(self, h, mu=0.0) -> bool:
        self.n_factorizations += 1
        shifted = (h + mu * sp.identity(h.shape[0], format="csr")).tocsc()
        self._lu = splu(shifted, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                        options={"SymmetricMode": True})
        return True

    def solve(self, b):
        return self._lu.solve(np.asarray(b, dtype=float))


def target_and_mattress(name):
    """A preset or a zoo entry by name, and its mattress."""
    if name in PRESETS:
        return preset(name)
    entry = next(e for e in zoo() if e.name == name)
    return entry, Mattress(*entry.mattress)


def _designed(name, solver: str):
    """(seconds, factorizations, Ŝ vertices, strings) of one design of ``name`` with ``solver``."""
    made = []
    original = ua._Pattern.cholesky

    def cholesky(pattern):
        made.append(original(pattern) if solver == "cholmod" else SuperLUBaseline())
        return made[-1]

    ua._Pattern.cholesky = cholesky
    try:
        target, mattress = target_and_mattress(name)
        t0 = time.perf_counter()
        d = design(target, mattress, progress=False)
        seconds = time.perf_counter() - t0
    finally:
        ua._Pattern.cholesky = original
    return seconds, sum(m.n_factorizations for m in made), d.approx.xyz, len(d.pattern.strings)


def commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a smoke run: vault1")
    ap.add_argument("--targets", nargs="+", default=None, help="presets or zoo names (default: all above)")
    ap.add_argument("--machine", default=f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores",
                    help="the machine column's text")
    args = ap.parse_args(argv)
    names = ["vault1"] if args.quick else (args.targets or list(PRESETS + ZOO))
    rev, machine = commit(), args.machine
    print("| target | strings | factorizations | SuperLU: design (s) | CHOLMOD: design (s) | speed-up "
          "| largest Ŝ difference (mm) | commit | machine |")
    print("|---|---:|---:|---:|---:|---:|---:|---|---|")
    for name in names:
        t_old, n_old, x_old, k_old = _designed(name, "superlu")
        t_new, n_new, x_new, k_new = _designed(name, "cholmod")
        diff = float(np.abs(x_old - x_new).max()) * 1e3 if x_old.shape == x_new.shape else float("nan")
        strings = k_new if k_old == k_new else f"{k_old} / {k_new}"
        factorizations = n_new if n_old == n_new else f"{n_old} / {n_new}"
        print(f"| {name} | {strings} | {factorizations} | {t_old:.1f} | {t_new:.1f} | {t_old / t_new:.1f}x "
              f"| {diff:.1e} | `{rev}` | {machine} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
