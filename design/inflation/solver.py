"""Newton's method for the equilibrium of U_B (min over vertex positions).

Each iteration assembles the sparse Hessian (exact, or with every spring
block projected PSD; exact pressure term; constant smoothing) on a fixed CSR
pattern and solves ``(H + mu I) dx = -g`` with a sparse LU (scipy SuperLU
with diagonal pivots, whose pivot signs tell whether the matrix is positive
definite). ``mu`` is a Levenberg–Marquardt trust-region shift: raised until
the matrix is positive definite (compressed edges and the pressure make H
indefinite away from equilibrium), raised again when a step does not lower
U_B as the quadratic model predicted, lowered after good steps. Six degrees
of freedom of three vertices are pinned to remove the rigid motions.

Stopping rule: ``max |grad| / max_i |p dVol/dx_i| < tol`` -- the largest
out-of-balance force relative to the largest pressure force on a vertex.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from airmat.errors import ConvergenceError
from airmat.progress import progress
from design.inflation.assembly import build_assembler
from design.inflation.energy import (Model, block_pattern, energy, energy_and_gradient, hessian_blocks,
                                     pressure_forces, smoothing_blocks)

__all__ = ["SolveResult", "solve", "rigid_pins"]

log = logging.getLogger(__name__)

#: largest edge stretch before the run is declared diverged (the membrane would have torn)
MAX_STRAIN = 0.5


@dataclass(frozen=True)
class SolveResult:
    """Equilibrium of U_B.

    Attributes
    ----------
    xyz : ndarray of shape (n, 3)
        Vertex positions (m).
    converged : bool
    n_iter : int
        Newton iterations (over all ramp stages).
    residual : float
        Final ``max |grad| / max pressure force per vertex`` (dimensionless).
    message : str
    seconds : float
        Wall-clock time.
    energy : float
        U_B at ``xyz`` (J, without the constant U_0,B2).
    history : tuple of float
        Residual after each iteration.
    n_factorizations : int
        Sparse LU factorizations (more than ``n_iter`` when shifts were needed).
    """

    xyz: np.ndarray
    converged: bool
    n_iter: int
    residual: float
    message: str
    seconds: float
    energy: float
    history: tuple = field(default=(), repr=False)
    n_factorizations: int = 0


def rigid_pins(uv: np.ndarray, top: np.ndarray, spacing: tuple) -> np.ndarray:
    """Six flat DOF indices that remove the rigid motions: three top vertices near the centre of Ω.

    Vertex A (closest to the centre) is fixed; vertex B, a few cells along u
    from A, keeps its y and z; vertex C, a few cells along v, keeps its z.
    Any deformed shape can be moved rigidly to satisfy these, so they do not
    change the equilibrium shape.
    """
    g = uv[top]
    c = g.mean(axis=0)
    step = 2.0 * np.asarray(spacing)
    pick = [int(np.argmin(np.linalg.norm(g - p, axis=1))) for p in (c, c + [step[0], 0], c + [0, step[1]])]
    a, b, cc = (3 * top[i] for i in pick)
    return np.array([a, a + 1, a + 2, b + 1, b + 2, cc + 2])


def _residual(model: Model, x: np.ndarray, g_free: np.ndarray) -> float:
    f_ref = float(np.max(np.linalg.norm(pressure_forces(model, x), axis=1)))
    return float(np.max(np.abs(g_free))) / max(f_ref, np.finfo(float).tiny)


def _factor(a: sp.csr_matrix):
    """Sparse LU with diagonal pivots; returns (lu, positive definite?) or (None, False) if singular."""
    try:
        lu = spla.splu(a.tocsc(), permc_spec="MMD_AT_PLUS_A",
                       options=dict(SymmetricMode=True, DiagPivotThresh=0.0))
    except RuntimeError:                   # exactly singular
        return None, False
    # with diagonal pivots (perm_r == perm_c) the pivots are the D of an LDL^T: their signs give the inertia
    pd = np.array_equal(lu.perm_r, lu.perm_c) and bool(np.all(lu.U.diagonal() > 0))
    return lu, pd


def _shifted_step(h: sp.csr_matrix, g: np.ndarray, mu: float, mu_min: float):
    """Solve (H + mu I) dx = -g with mu raised (x10) until the matrix is positive definite.

    Returns (dx, mu, n_factorizations).
    """
    eye = sp.identity(h.shape[0], format="csr")
    for k in range(1, 20):
        lu, pd = _factor(h + mu * eye if mu > 0 else h)
        if pd:
            dx = lu.solve(-g)
            if np.all(np.isfinite(dx)):
                return dx, mu, k
        mu = max(10.0 * mu, mu_min)
    raise ConvergenceError("the Newton matrix stays indefinite even with a large shift", mu=mu)


def _full(dx_free: np.ndarray, free: np.ndarray, shape) -> np.ndarray:
    out = np.zeros(int(np.prod(shape)))
    out[free] = dx_free
    return out.reshape(shape)


def _check_sane(model: Model, x: np.ndarray, e: float, it: int) -> None:
    if not np.isfinite(e) or not np.all(np.isfinite(x)):
        raise ConvergenceError(f"diverged at iteration {it}: non-finite energy or positions", iteration=it)
    b1 = model.springs[0]
    strain = float(np.max(b1.lengths(x) / b1.rest - 1.0))
    if strain > MAX_STRAIN:
        raise ConvergenceError(f"diverged at iteration {it}: an edge is stretched by {strain:.0%} "
                               f"(> {MAX_STRAIN:.0%}); the pressure is far too high for the membrane "
                               f"stiffness", iteration=it, strain=strain)


def solve(model: Model, x0: np.ndarray, *, fixed_dofs=(), tol: float = 1e-6, max_iter: int = 200,
          max_move: float = np.inf, assembler=None, project: bool = False, strict: bool = False,
          desc: str = "inflate") -> SolveResult:
    """Minimise U_B from ``x0`` by damped, shifted Newton iterations.

    Parameters
    ----------
    model : Model
    x0 : ndarray of shape (n, 3)
        Start positions (m); not modified.
    fixed_dofs : sequence of int
        Flat DOF indices held at their start value (see :func:`rigid_pins`).
    tol : float
        Stop when max |grad| < tol × the largest pressure force on a vertex.
    max_iter : int
    max_move : float
        Largest vertex displacement of one Newton step (m); longer steps are
        scaled down (a simple trust region against wild first steps).
    assembler : Assembler, optional
        The CSR pattern of ``block_pattern(model)`` with ``fixed_dofs``
        removed, to reuse across calls on models of the same structure.
    project : bool
        Project every spring's Hessian to be PSD (Gauss-Newton-like) instead of
        the exact Hessian with a global shift (default; converges much faster
        through the folds, where compressed edges soften the structure).
    strict : bool
        Raise :class:`ConvergenceError` instead of returning unconverged.

    Returns
    -------
    SolveResult

    Raises
    ------
    airmat.errors.ConvergenceError
        On divergence (non-finite values, an edge strained > 50 %, no descent
        direction), or on non-convergence with ``strict=True``.
    """
    t0 = time.perf_counter()
    x = np.array(x0, dtype=float, copy=True)
    asm = assembler or build_assembler(block_pattern(model), model.n_vertices, fixed_dofs)
    q_blocks = smoothing_blocks(model)
    free = asm.free
    history, converged, message, n_fact, it = [], False, "", 0, 0
    h = asm.assemble(hessian_blocks(model, x, project=project) + [q_blocks])
    mu_min = 1e-8 * float(np.mean(np.abs(h.diagonal())))
    mu = 0.0
    e, g = energy_and_gradient(model, x)
    with progress(total=max_iter, desc=desc, unit="it") as bar:
        while True:
            _check_sane(model, x, e, it)
            gf = g.reshape(-1)[free]
            res = _residual(model, x, gf)
            history.append(res)
            bar.set_postfix_str(f"residual {res:.2e}")
            if res < tol:
                converged, message = True, f"converged: residual {res:.3g} < {tol:g}"
                break
            if it >= max_iter:
                message = f"not converged after {it} iterations: residual {res:.3g} >= {tol:g}"
                break
            h = asm.assemble(hessian_blocks(model, x, project=project) + [q_blocks])
            for _ in range(30):                        # trust-region loop: shrink until the step pays
                dx, mu, nf = _shifted_step(h, gf, mu, mu_min)
                n_fact += nf
                longest = float(np.max(np.linalg.norm(_full(dx, free, x.shape), axis=1)))
                cap = min(1.0, max_move / longest) if longest > 0 else 1.0
                dx *= cap
                predicted = -(gf @ dx + 0.5 * dx @ (h @ dx))
                xn = x.copy()
                xn.reshape(-1)[free] += dx
                en, gn = energy_and_gradient(model, xn)
                actual = e - en
                noise = 1e-12 * (abs(e) + abs(en))
                rho = actual / predicted if predicted > noise else (1.0 if abs(actual) <= noise else -1.0)
                if np.isfinite(en) and rho > 1e-4:
                    break
                mu = max(4.0 * mu, mu_min * 1e2)
            else:
                message = f"stalled at iteration {it}: no energy decrease even with a large shift"
                break
            log.debug("iteration %d: U=%.12g J, residual %.3e, rho %.3g, shift %.1e, cap %.2g",
                      it, en, res, rho, mu, cap)
            x, e, g = xn, en, gn
            if rho < 0.25:
                mu = max(4.0 * mu, mu_min * 1e2)
            elif rho > 0.75 and cap == 1.0:
                mu = mu / 3.0 if mu > mu_min * 1e2 else 0.0
            it += 1
            bar.update(1)
    if not converged:
        log.warning("inflation solver: %s", message)
        if strict:
            raise ConvergenceError(message, residual=history[-1], n_iter=it)
    return SolveResult(xyz=x, converged=converged, n_iter=it, residual=history[-1], message=message,
                       seconds=time.perf_counter() - t0, energy=float(e), history=tuple(history),
                       n_factorizations=n_fact)
