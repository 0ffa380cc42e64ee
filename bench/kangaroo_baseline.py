"""A Kangaroo2-style solver of the same energy U_B: the baseline of bench_inflation.py.

Kangaroo2 (Piker) moves particles by goals: each goal proposes a move for
its particles, each particle moves by the stiffness-weighted average of the
moves proposed to it, and velocities carry momentum between iterations
(dynamic relaxation with damping). For a spring goal of stiffness k the
proposed move of an end is half the length error along the spring, so the
weighted average is -grad U / (2 sum k): this baseline uses exactly that,
with the gradient of the same U_B the Newton solver minimizes (vectorized),
and stops on the same relative force residual.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from airmat.inflation.energy import energy_and_gradient, pressure_forces

__all__ = ["KangarooResult", "kangaroo_solve"]


@dataclass(frozen=True)
class KangarooResult:
    xyz: np.ndarray
    converged: bool
    n_iter: int
    residual: float
    seconds: float


def _vertex_weights(model) -> np.ndarray:
    """Sum of the goal strengths acting on each vertex (N/m)."""
    w = np.asarray(model.smoothing.diagonal(), float).copy()
    for s in model.springs:
        np.add.at(w, s.idx.ravel(), (np.asarray(s.stiffness)[:, None] * s.coef ** 2).ravel())
    return np.maximum(w, np.finfo(float).tiny)


def kangaroo_solve(model, x0, *, fixed_dofs=(), tol=1e-6, damping=0.9, time_limit=120.0,
                   max_iter=10_000_000) -> KangarooResult:
    """Relax ``x0`` (n, 3) under ``model`` Kangaroo-style until max|grad| < tol x the largest pressure force."""
    t0 = time.perf_counter()
    x = np.array(x0, float)
    v = np.zeros_like(x)
    free = np.ones(x.size, bool)
    free[np.asarray(fixed_dofs, int)] = False
    free = free.reshape(x.shape)
    w = 2.0 * _vertex_weights(model)[:, None]
    res, it = np.inf, 0
    for it in range(1, max_iter + 1):
        _, g = energy_and_gradient(model, x)
        g = np.where(free, g, 0.0)
        if it % 10 == 1:
            res = float(np.abs(g).max() / np.linalg.norm(pressure_forces(model, x), axis=1).max())
            if res < tol or time.perf_counter() - t0 > time_limit or not np.isfinite(res):
                break
        v = damping * v - g / w
        x += v
    return KangarooResult(x, bool(res < tol), it, res, time.perf_counter() - t0)
