"""Newton's method for the equilibrium of U_B (min over vertex positions).

Each iteration assembles the sparse Hessian (exact by default, or with every
spring block projected PSD; exact pressure term; constant smoothing) on a
fixed CSR pattern and solves ``(H + mu I) dx = -g`` by a sparse Cholesky
factorization (:mod:`airmat.inflation.cholesky`: CHOLMOD, METIS ordering,
symbolic analysis once), which also tells whether ``H + mu I`` is positive
definite. ``mu`` is a Levenberg–Marquardt trust-region shift: raised until
the matrix is positive definite (compressed edges and the pressure make H
indefinite away from equilibrium), raised again when a step does not lower
U_B as its quadratic model predicted, lowered after good steps. Six degrees
of freedom of three vertices are pinned to remove the rigid motions.

The exact Hessian with the shift converges in a few tens of iterations per
ramp stage; the per-element PSD projection (``project=True``) stalls in the
folds and wrinkles, where it discards the softening the shape depends on.

Stopping rule: ``max |grad| / max_i |p dVol/dx_i| < tol`` -- the largest
out-of-balance force relative to the largest pressure force on a vertex.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from airmat.errors import ConvergenceError
from airmat.progress import residual_progress
from airmat.inflation.assembly import build_assembler
from airmat.inflation.cholesky import ShiftedCholesky
from airmat.inflation.energy import Model, block_pattern, energy_gradient_volume, hessian_blocks, smoothing_blocks

__all__ = ["SolveResult", "solve", "rigid_pins", "NewtonSystem"]

log = logging.getLogger(__name__)

#: largest edge stretch before the run is declared diverged (the membrane would have torn)
MAX_STRAIN = 0.5

#: the shift is divided by this after a step its quadratic model predicted well (rho > 0.75).
#: Measured on vault2 (large mattress) at 20 mm: 34 -> 21 Newton iterations on the finest mesh
#: for 3 -> 10; the wrinkled equilibria have soft directions along which a slowly released
#: shift only crawls. The small presets at 20 mm are within their timing noise for 3, 10, 30.
MU_DOWN = 10.0

#: the shift is multiplied by this after a step its model predicted poorly (rho < 0.25) and after a
#: refused step (no decrease)
MU_UP = 2.0

#: what a refused step does: ``"backtrack"`` (the default) halves the same step (no new factorization)
#: and leaves the raised shift to the next iteration; ``"shift"`` raises the shift by ``mu_up`` and
#: factorizes again. ``bench/bench_newton_rule.py`` inflates every preset under both rules in one run
#: (docs/benchmarks.md): halving with the shift x2 reaches the same equilibria (vertices within
#: 1e-4 mm) in fewer factorizations. The refinement's trial equilibria keep "shift" x4
#: (:data:`airmat.check.trial_equilibrium.TRIAL_REFUSED_STEP`): their path decides the refined lengths.
REFUSED_STEP = "backtrack"


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
        Cholesky factorizations so far by the linear solver used (cumulative
        when one ``linear_system`` is shared between calls).
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


def rigid_pins(uv: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Six flat DOF indices that remove the rigid motions: three side-wall vertices.

    Vertex A (middle of the side v = 0) is fixed; vertex B (middle of the side
    v = H) keeps its x and z, so it stays on the line through A along y;
    vertex C (middle of the side u = 0) keeps its z. Any deformed shape can
    be moved rigidly to satisfy these, so they do not change the equilibrium
    shape. The side-wall vertices lie half-way between the faces (z = 0), so
    a pattern and its top/bottom mirror image are solved along mirror paths.

    Parameters
    ----------
    uv : ndarray of shape (n, 2)
        Ω coordinates of all vertices (the side-wall ones after the two faces).
    top : ndarray of shape (g,)
        Top-face vertex indices (their count gives where the side wall starts).
    """
    side = np.arange(2 * len(top), len(uv))
    w, h = uv[:, 0].max(), uv[:, 1].max()
    targets = ([0.5 * w, 0.0], [0.5 * w, h], [0.0, 0.5 * h])
    a, b, c = (3 * side[int(np.argmin(np.linalg.norm(uv[side] - t, axis=1)))] for t in targets)
    return np.array([a, a + 1, a + 2, b, b + 2, c + 2])


def _residual(model: Model, grad_volume: np.ndarray, g_free: np.ndarray) -> float:
    """max |grad| over the largest pressure force ``p |dVol/dx_i|`` (``grad_volume``: dVol/dx, (n, 3))."""
    f_ref = float(np.max(np.linalg.norm(model.pressure * grad_volume, axis=1)))
    return float(np.max(np.abs(g_free))) / max(f_ref, np.finfo(float).tiny)


class NewtonSystem:
    """Solves ``(H + mu I) dx = -g`` by a sparse Cholesky factorization (:mod:`~airmat.inflation.cholesky`),
    with ``mu`` raised until ``H + mu I`` is positive definite.

    After a failure ``mu`` jumps to ``max(10 mu, mu_min, hint / 10)``, ``hint``
    being the last shift that was needed (indefiniteness tends to persist over
    a few iterations). One instance can be shared by successive solves on
    models of the same structure (the ramp stages): the symbolic analysis is
    done once. ``hint_rel`` is that shift relative to the mean diagonal of the
    matrix, so that it can seed the solver of a finer mesh.
    """

    def __init__(self, mu_min: float | None = None, groups: np.ndarray | None = None,
                 hint_rel: float = 0.0):
        self.mu_min, self.hint_rel, self.chol, self.groups, self.scale = mu_min, hint_rel, None, groups, None

    @property
    def n_factorizations(self) -> int:
        return 0 if self.chol is None else self.chol.n_factorizations

    def step(self, h: sp.csr_matrix, g: np.ndarray, mu: float):
        """Returns (dx, mu) with the shift actually used."""
        if self.scale is None:
            self.scale = float(np.mean(np.abs(h.diagonal())))
        mu0 = mu
        for _ in range(20):
            dx = self.attempt(h, g, mu)
            if dx is not None:
                if mu > mu0:
                    self.hint_rel = mu / self.scale
                return dx, mu
            mu = max(10.0 * mu, self.mu_min, 0.1 * self.hint_rel * self.scale)
        raise ConvergenceError("the Newton matrix stays indefinite even with a large shift", mu=mu)

    def attempt(self, h: sp.csr_matrix, g: np.ndarray, mu: float) -> np.ndarray | None:
        """dx with ``(h + mu I) dx = -g``, or None when ``h + mu I`` is not positive definite."""
        if self.chol is None:
            self.chol = ShiftedCholesky(h, self.groups)
        if not self.chol.factor(h, mu):
            return None
        dx = self.chol.solve(-g)
        return dx if np.all(np.isfinite(dx)) else None


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


class _TrustRegion:
    """The Levenberg–Marquardt shift ``mu`` and one accepted step of it."""

    def __init__(self, model: Model, free: np.ndarray, max_move: float, mu_min: float,
                 refused: str | None = None, mu_up: float | None = None):
        self.model, self.free, self.max_move, self.mu_min, self.mu = model, free, max_move, mu_min, 0.0
        self.refused = REFUSED_STEP if refused is None else refused
        self.mu_up = MU_UP if mu_up is None else mu_up

    def step(self, system: NewtonSystem, h, x, e, gf):
        """Shrink (raise mu, or halve the step: ``REFUSED_STEP``) until a step lowers U_B; returns
        (x, U, grad, dVol/dx) or None."""
        dx = None
        for _ in range(30):
            if dx is None:
                dx, self.mu = system.step(h, gf, self.mu)
                longest = float(np.max(np.linalg.norm(_full(dx, self.free, x.shape), axis=1)))
                cap = min(1.0, self.max_move / longest) if longest > 0 else 1.0
                dx *= cap
            predicted = -(gf @ dx + 0.5 * dx @ (h @ dx))
            xn = x.copy()
            xn.reshape(-1)[self.free] += dx
            en, gn, gvn = energy_gradient_volume(self.model, xn)
            actual = e - en
            noise = 1e-12 * (abs(e) + abs(en))   # U ~ p Vol: its round-off can exceed tiny decreases
            rho = actual / predicted if predicted > noise else (1.0 if abs(actual) <= noise else -1.0)
            if np.isfinite(en) and rho > 1e-4:
                if rho < 0.25:
                    self.mu = max(self.mu_up * self.mu, 1e2 * self.mu_min)
                elif rho > 0.75 and cap == 1.0:
                    self.mu = self.mu / MU_DOWN if self.mu > 1e2 * self.mu_min else 0.0
                return xn, en, gn, gvn
            self.mu = max(self.mu_up * self.mu, 1e2 * self.mu_min)
            if self.refused == "backtrack":
                dx, cap = 0.5 * dx, 0.5 * cap     # the same direction, half as far: no new factorization
            else:
                dx = None
        return None


def solve(model: Model, x0: np.ndarray, *, fixed_dofs=(), tol: float = 1e-6, max_iter: int = 200,
          max_move: float = np.inf, assembler=None, project: bool = False, strict: bool = False,
          desc: str = "inflate", linear_system=None, refused_step: str | None = None,
          mu_up: float | None = None, warn: bool = True) -> SolveResult:
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
        scaled down (against wild first steps).
    assembler : Assembler, optional
        The CSR pattern of ``block_pattern(model)`` with ``fixed_dofs``
        removed, to reuse across calls on models of the same structure.
    linear_system : NewtonSystem, optional
        Reuse the linear solver (its ordering and symbolic factorization) of a
        previous call on a model of the same structure, e.g. the previous ramp stage.
    project : bool
        Project every spring's Hessian to be PSD (per-element, Gauss-Newton-like)
        instead of the exact Hessian with the global shift (the default, which
        converges much faster where compressed edges soften the structure).
    strict : bool
        Raise :class:`ConvergenceError` instead of returning unconverged.
    refused_step : {"shift", "backtrack"}, optional
        What a step that does not lower U_B does (default :data:`REFUSED_STEP`): raise the
        shift and factorize again, or halve the same step.
    mu_up : float, optional
        Factor of the shift after a poorly predicted or refused step (default :data:`MU_UP`).
    warn : bool
        Log a run that does not converge as a warning (False: at debug level, for callers to
        whom it is an expected outcome, such as the refinement's trial equilibria).

    Returns
    -------
    SolveResult

    Raises
    ------
    airmat.errors.ConvergenceError
        On divergence (non-finite values, an edge strained > 50 %) or a Newton
        matrix that stays indefinite however far it is shifted. With
        ``strict=True`` also when no step lowers U_B (no descent direction)
        or ``max_iter`` runs out; without it those return
        ``converged=False`` with the reason in ``message`` (and a warning logged).
    """
    if refused_step not in (None, "shift", "backtrack"):
        raise ValueError(f"refused_step must be 'shift' or 'backtrack', got {refused_step!r}")
    t0 = time.perf_counter()
    x = np.array(x0, dtype=float, copy=True)
    asm = assembler or build_assembler(block_pattern(model), model.n_vertices, fixed_dofs)
    q_blocks = smoothing_blocks(model)
    history, converged, message, it = [], False, "", 0
    h = asm.assemble(hessian_blocks(model, x, project=project) + [q_blocks])
    tr = _TrustRegion(model, asm.free, max_move, 1e-8 * float(np.mean(np.abs(h.diagonal()))), refused_step, mu_up)
    system = linear_system if linear_system is not None else NewtonSystem(groups=asm.free // 3)
    if system.mu_min is None:
        system.mu_min = tr.mu_min
    e, g, gv = energy_gradient_volume(model, x)
    h_at_x = True   # h is the Hessian at x (the first iteration uses the one assembled above)
    with residual_progress(tol, desc=desc) as bar:
        while True:
            _check_sane(model, x, e, it)
            gf = g.reshape(-1)[asm.free]
            res = _residual(model, gv, gf)
            history.append(res)
            bar.residual(res)
            if res < tol:
                converged, message = True, f"converged: residual {res:.3g} < {tol:g}"
                break
            if it >= max_iter:
                message = f"not converged after {it} iterations: residual {res:.3g} >= {tol:g}"
                break
            if not h_at_x:
                h = asm.assemble(hessian_blocks(model, x, project=project) + [q_blocks])
            step = tr.step(system, h, x, e, gf)
            if step is None:
                message = f"stalled at iteration {it}: no energy decrease even with a large shift"
                break
            x, e, g, gv = step
            h_at_x = False
            log.debug("iteration %d: U=%.12g J, residual %.3e, shift %.1e", it, e, res, tr.mu)
            it += 1
    log.debug("%s: %d iterations, %d Cholesky factorizations", desc, it, system.n_factorizations)
    if not converged:
        (log.warning if warn else log.debug)("inflation solver: %s", message)
        if strict:
            raise ConvergenceError(message, residual=history[-1], n_iter=it)
    return SolveResult(xyz=x, converged=converged, n_iter=it, residual=history[-1], message=message,
                       seconds=time.perf_counter() - t0, energy=float(e), history=tuple(history),
                       n_factorizations=system.n_factorizations)
