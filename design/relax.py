"""U_A relaxation of Ω toward the target S: the near-developable surface Ŝ (paper §3.2, Eq. 4).

The mesh M (Ω's triangulation) starts flat on S and minimises

    U_A = Σ_edges ½ k_A1 (ε − ε0)²  +  Σ_vertices ½ k_A2 ‖x − x_closest‖²  +  Σ_vertices ½ k_A3 ‖x − x_avg‖²

(A1: edges keep their Ω length ε0; A2: vertices move to their closest point
on S, where S is continued across its rim by the rim faces' tangent planes,
airmat.design.closest_point.MeshProjector.closest_extended; A3: vertices move toward their neighbours' average, with the cotangent
weights of flat Ω, so that flat Ω is a rest state of A3). The fine mesh is
solved by projected Newton (airmat.design.ua_newton) with Ω's place on S held:
U_A does not fix where Ω lies on a target larger than it, and its minimum over
that slide is on S's flattest part or off its rim (Ω on a symmetric saddle
slides 0.3 m off it), not the design that was placed. The coarse grids use the
local-global iteration (airmat.design.local_global, which also holds the problem's
data, its stopping rule and its resolution-independent weights);
this module chooses where it starts and reports Ŝ.
Wrapping a fine flat mesh around a strongly curved S in one go can crumple
it, so coarser grids of Ω are solved first, each starting the next.

Rim: a target that does not cover the whole mattress leaves some of Ω
overhanging S. Pulling those vertices to their closest point of S (on its
rim) would strain Ŝ for nothing (σ far from 1 on a developable S, no
convergence), so A2 pulls them only along the rim face's normal: S is
continued by its tangent plane there. Ŝ reports, per vertex, how far it
lies beyond S (``off_target``).

Placement: unless given, Ω is tried in four orientations on S
(airmat.design.placement.candidate_placements), each relaxed briefly on a coarse
grid, and the one that leaves the least of Ω off S is kept (the default
one unless another is clearly better; a target that covers the mattress
keeps it without trying the others). Lowest U_A is not the criterion: with
the rim-aware A2 overhanging costs nothing, and with the plain one it
picked the 90° turn of the vault1 and saddle presets, whose Ŝ is no better
(the saddle's σ max rose from 1.093 to 1.104).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from airmat.errors import ConvergenceError, InputError
from airmat.geometry.topology import mesh_edges
from airmat.progress import residual_progress
from airmat.design.closest_point import MeshProjector
from airmat.design.local_global import REFERENCE_SPACING, STALL_WINDOW, UAProblem, iterate, umbrella_operator
from airmat.design.placement import apply_placement, candidate_placements, placement_matrix
from airmat.design.ua_newton import newton

__all__ = ["RelaxResult", "relax_to_target", "relax_from", "mesh_edges", "umbrella_operator", "REFERENCE_SPACING",
           "SOLVERS"]

log = logging.getLogger(__name__)

#: force tolerance (k_A1·h) of the coarse grids, whose Ŝ is only a start
COARSE_TOL = 1e-3
#: iterations of the coarse relaxation that scores a candidate placement
PLACEMENT_ITER = 100
#: share of Ω's area by which a candidate placement must beat an earlier one
PLACEMENT_MARGIN = 0.01
#: a vertex further beyond S's rim than this (in mean edge lengths) is off S
OFF_TARGET = 0.1
#: solvers of the fine mesh: projected Newton (airmat.design.ua_newton), local-global (airmat.design.local_global)
SOLVERS = ("newton", "local-global")


@dataclass(frozen=True)
class RelaxResult:
    """Outcome of :func:`relax_to_target`.

    Attributes
    ----------
    xyz : ndarray of shape (n, 3)
        Vertex positions of Ŝ (m).
    converged : bool
        Whether the largest unbalanced force on a vertex fell below ``tol`` × k_A1 × h
        (h the mean rest edge length): the pull of an edge strained by ``tol``.
    n_iter : int
        Iterations done.
    residual : float
        That largest force, in units of k_A1 × h (a strain).
    message : str
    energy : dict
        Final ``U_A1``, ``U_A2``, ``U_A3`` and ``U_A`` (with the scaled weights; J for weights in N/m).
    distance : dict
        ``mean`` and ``max`` distance (m) from Ŝ's vertices to S.
    placement : ndarray of shape (4, 4)
        The start placement of Ω used (see airmat.design.placement).
    off_target : ndarray of shape (n,)
        Distance (m) from each vertex of Ŝ to S where its closest point on S lies on S's rim
        (the vertex overhangs S, A2 only pulls it onto the rim face's tangent plane), else 0.
    """

    xyz: np.ndarray
    converged: bool
    n_iter: int
    residual: float
    message: str
    energy: dict
    distance: dict
    placement: np.ndarray
    history: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    off_target: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))


def relax_to_target(uv, faces, target, *, placement=None, k_a1: float = 1.0, k_a2: float = 0.2,
                    k_a3: float = 0.02, tol: float = 1e-4, stall: float = 1e-7, max_iter: int = 1000,
                    anderson: int = 5, levels: int | None = None,
                    progress: bool = True, strict: bool = False,
                    projector: MeshProjector | None = None, solver: str = "newton") -> RelaxResult:
    """Relax Ω's mesh onto the target S by minimising U_A (Equation 4).

    Parameters
    ----------
    uv : ndarray of shape (n, 2)
        Vertices of Ω's triangulation (m); their distances are the rest lengths.
    faces : ndarray of shape (m, 3)
        Triangles, counter-clockwise on Ω (so Ŝ's face normals are the top normal).
    target : airmat.design.target.Target
        The guide surface S (m).
    placement : (4, 4) ndarray or (offset, rotation), optional
        Where flat Ω starts (airmat.design.placement.placement_matrix); default: the one of
        :func:`airmat.design.placement.candidate_placements` that leaves the least of Ω off S
        after a short coarse relaxation (the first, :func:`airmat.design.placement.auto_placement`,
        unless another one is better by more than 1 % of Ω's area).
    k_a1 : float, default 1.0
        Weight of A1, edges keeping their length (per edge).
    k_a2 : float, default 0.2
        Weight of A2, vertices pulled to their closest point on S (per vertex,
        at 20 mm spacing; scaled by (h / 20 mm)²). Larger: Ŝ follows S closer and
        stretches more (σ further from 1).
    k_a3 : float, default 0.02
        Weight of A3, smoothing toward the neighbours' average (per vertex, at
        20 mm spacing; scaled like k_a2). It suppresses wrinkles but flattens Ŝ a
        little near the rim (bias ∝ k_a3 / k_a2; see the tests).
    tol : float, default 1e-4
        Converged when the largest unbalanced force on a vertex, |∂U_A/∂x_i|, is below
        ``tol`` × k_a1 × h (h the mean edge length): the pull of one edge strained by
        ``tol``. It stays a little above 0 (the closest-point map is only piecewise
        smooth on a triangle mesh), so do not ask for much below 1e-5.
    stall : float, default 1e-7
        Also converged when U_A decreased by less than ``stall`` (relative) over the
        last 50 iterations: the force is then at the floor the target's facets set
        (the message says so).
    max_iter : int, default 1000
    anderson : int, default 5
        Window of the Anderson acceleration (0: plain local-global iterations).
        An accelerated step that raises U_A is replaced by the plain step.
    levels : int, optional
        Coarser grids (spacing 2h, 4h, ...) solved first, each starting the next
        (default: as many as leave about 10 cells across Ω, at most 3; 0 starts the
        fine mesh flat). Wrapping a fine flat mesh around a strongly curved S in
        one go can crumple it.
    progress : bool, default True
        Show a progress bar (only when stderr is a terminal).
    strict : bool, default False
        Raise ConvergenceError instead of returning unconverged.
    projector : airmat.design.closest_point.MeshProjector, optional
        A BVH over the target to reuse.
    solver : {"newton", "local-global"}, default "newton"
        The fine mesh's solver: projected Newton with Ω's place on S held
        (airmat.design.ua_newton; ``max_iter`` counts Newton iterations), or the
        Anderson-accelerated local-global iteration (airmat.design.local_global), which
        lets Ω slide along S and crawls where the target is far from developable. The
        coarse grids and the placement's scoring use the local-global iteration.

    Returns
    -------
    RelaxResult

    Raises
    ------
    airmat.errors.ConvergenceError
        When the iteration diverges (non-finite positions), or with ``strict``
        when it does not converge in ``max_iter`` iterations.
    """
    if solver not in SOLVERS:
        raise InputError(f"unknown U_A solver {solver!r}: choose one of {', '.join(SOLVERS)}", solver=solver)
    uv = np.asarray(uv, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    lo = uv.min(axis=0)
    width, height = uv.max(axis=0) - lo
    projector = projector or MeshProjector(target.vertices, target.faces)
    prob = UAProblem(uv, faces, projector, k_a1, k_a2, k_a3)
    spacing = float(np.median(prob.rest))
    t0 = time.perf_counter()
    settled = None   # the chosen candidate's coarse Ŝ, when its scoring relaxation converged
    if placement is None:
        mat, settled = _best_placement(target, projector, width, height, spacing=spacing,
                                       k=(k_a1, k_a2, k_a3), stall=stall, anderson=anderson)
    else:
        mat = placement_matrix(placement, width, height)
    levels = _coarse_levels(spacing, width, height) if levels is None else int(levels)
    x0 = apply_placement(mat, uv - lo)
    if levels:
        x0 = _coarse_start(uv - lo, mat, projector, spacing=spacing, levels=levels, k=(k_a1, k_a2, k_a3),
                           stall=stall, max_iter=max_iter, anderson=anderson, settled=settled)
    with residual_progress(tol, desc="relax Ŝ") as bar:
        x, it, status, residual, history = _solve(prob, x0, solver=solver, tol=tol, stall=stall,
                                                  max_iter=max_iter, anderson=anderson,
                                                  bar=bar if progress else None)
    converged = status != "max_iter"
    closest = projector.closest(x)
    energy = prob.energy(x, prob.project(x))
    off_target = np.where(closest.on_rim, closest.distance, 0.0)
    msg = _message(status, it, residual, tol=tol, stall=stall, solver=solver)
    log.info("U_A relaxation %s, %.2f s; distance to S mean %.2f mm, max %.2f mm (%d of %d vertices "
             "beyond S's rim)", msg, time.perf_counter() - t0, 1e3 * closest.distance.mean(),
             1e3 * closest.distance.max(), int(np.count_nonzero(off_target > OFF_TARGET * prob.h)), len(x))
    if not converged:
        if strict:
            raise ConvergenceError(f"U_A relaxation {msg}", n_iter=it, residual=residual)
        log.warning("U_A relaxation %s", msg)
    return RelaxResult(xyz=x, converged=converged, n_iter=it, residual=residual, message=msg,
                       energy=energy, placement=mat,
                       distance={"mean": float(closest.distance.mean()), "max": float(closest.distance.max())},
                       history=np.asarray(history), off_target=off_target)


def relax_from(x0, uv, faces, projector: MeshProjector, *, rest=None, k_a1: float = 1.0, k_a2: float = 0.2,
               k_a3: float = 0.02, tol: float = 1e-4, stall: float = 1e-7, max_iter: int = 1000,
               anderson: int = 5, solver: str = "newton"):
    """Minimise U_A from ``x0`` on the fine mesh only, optionally with other A1 rest lengths.

    The building block of a relaxation in another metric (airmat.design.face_metric):
    no placement, no coarse start.

    Parameters
    ----------
    x0 : ndarray of shape (n, 3)
        Start positions (m), e.g. a relaxed Ŝ.
    uv, faces : ndarray of shape (n, 2), (m, 3)
        Ω's triangulation (m).
    projector : airmat.design.closest_point.MeshProjector
        The target S.
    rest : ndarray of shape (e,), optional
        A1 rest length (m) of each edge of ``mesh_edges(faces)``; default its length on Ω.
    k_a1, k_a2, k_a3, tol, stall, max_iter, anderson, solver
        As in :func:`relax_to_target` (Newton holds Ω's place on S where ``x0`` has it).

    Returns
    -------
    x : ndarray of shape (n, 3)
    n_iter : int
    converged : bool
    residual : float
        Largest unbalanced force in units of k_A1 × h.
    energy : dict
        ``U_A1``, ``U_A2``, ``U_A3``, ``U_A`` at ``x`` (with these rest lengths).
    """
    prob = UAProblem(np.asarray(uv, float), np.asarray(faces, np.int64), projector, k_a1, k_a2, k_a3)
    if rest is not None:
        rest = np.asarray(rest, float)
        if rest.shape != prob.rest.shape or not np.all(rest > 0):
            raise ValueError(f"rest lengths: expected {prob.rest.shape[0]} positive values, got shape {rest.shape}")
        prob.rest = rest
    x, it, status, residual, _ = _solve(prob, np.array(x0, float), solver=solver, tol=tol, stall=stall,
                                        max_iter=max_iter, anderson=anderson, bar=None)
    return x, it, status != "max_iter", residual, prob.energy(x, prob.project(x))


def _solve(prob, x0, *, solver, tol, stall, max_iter, anderson, bar):
    """The fine mesh's relaxation by ``solver``: (x, n_iter, status, residual, history)."""
    if solver == "newton":
        x, it, status, residual, history, slide = newton(prob, x0, tol=tol, max_iter=max_iter, bar=bar)
        log.debug("U_A Newton: %s after %d iterations; Ω pushes to slide along S with at most %.2g k_A1·h "
                  "per vertex (held)", status, it, slide)
        return x, it, status, residual, history
    if solver == "local-global":
        return iterate(prob, x0, tol=tol, stall=stall, max_iter=max_iter, window=anderson, bar=bar)
    raise InputError(f"unknown U_A solver {solver!r}: choose one of {', '.join(SOLVERS)}", solver=solver)


def _message(status, it, residual, *, tol, stall, solver):
    """The relaxation's one-line outcome."""
    if status == "force":
        return f"converged in {it} iterations (largest force {residual:.2g} k_A1·h)"
    if status == "stall":
        why = ("no Newton step lowers it" if solver == "newton"
               else f"changed < {stall:g} in {STALL_WINDOW} iterations")
        return (f"converged in {it} iterations: U_A stationary ({why}) with the largest force "
                f"{residual:.2g} k_A1·h above tol {tol:g} (a coarse target mesh or folds in Ŝ keep it from 0)")
    return f"not converged after {it} iterations (largest force {residual:.2g} k_A1·h, tol {tol:g})"


def _coarse_levels(h, width, height):
    """How many coarser grids (spacing 2h, 4h, ...) to solve first: down to ~10 cells across."""
    n = 0
    while n < 3 and h * 2 ** (n + 1) <= min(width, height) / 10:
        n += 1
    return n


def _best_placement(target, projector, width, height, *, spacing, k, stall, anderson):
    """The candidate placement (airmat.design.placement.candidate_placements) that S covers best.

    Each candidate is relaxed for at most PLACEMENT_ITER iterations on the coarsest grid
    of the coarse start; its score is the share of Ω's area then beyond S's rim. The first
    candidate (the default) is kept unless another one leaves more than PLACEMENT_MARGIN
    less of Ω off S; when nothing of it is off S, the others are not tried.

    Returns the placement (4, 4) and, when the chosen candidate's relaxation converged
    (so the coarse start would compute the same), its coarse grid and positions (cuv, x).
    """
    from airmat.design.mattress import Mattress, triangulate_mattress

    candidates = candidate_placements(target, width, height, projector=projector)
    coarse = spacing * 2 ** _coarse_levels(spacing, width, height)
    cuv, cfaces = triangulate_mattress(Mattress(float(width), float(height)), spacing=coarse)
    prob = UAProblem(cuv, cfaces, projector, *k)
    d1, d2 = cuv[cfaces[:, 1]] - cuv[cfaces[:, 0]], cuv[cfaces[:, 2]] - cuv[cfaces[:, 0]]
    area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    best, best_share, settled = candidates[0], np.inf, None
    for i, mat in enumerate(candidates):
        x, _, status, *_ = iterate(prob, apply_placement(mat, cuv), tol=COARSE_TOL, stall=stall,
                                   max_iter=PLACEMENT_ITER, window=anderson, bar=None)
        near = projector.closest(x)
        off = near.on_rim & (near.distance > OFF_TARGET * prob.h)
        share = float(area @ off[cfaces].mean(axis=1) / area.sum())
        log.debug("placement candidate %d (u axis %s): %.1f %% of Ω off S after a coarse relaxation",
                  i, np.round(mat[:3, 0], 3), 100 * share)
        if share < best_share - PLACEMENT_MARGIN:
            best, best_share, settled = mat, share, (cuv, x) if status != "max_iter" else None
        if best_share <= PLACEMENT_MARGIN:
            break
    return best, settled


def _coarse_start(uv, mat, projector, *, spacing, levels, k, stall, max_iter, anderson, settled=None):
    """Start positions (n, 3) for the mesh ``uv`` from Ŝ solved on coarser grids of Ω.

    Wrapping a fine flat mesh around a strongly curved S in one go can crumple it;
    a coarse grid wraps cleanly, and each finer grid starts from the coarser Ŝ
    (interpolated linearly over Ω), so it only needs to settle. ``settled`` (cuv, x):
    the coarsest grid already solved from ``mat`` (by the placement choice), used when
    its grid is the coarsest level's.
    """
    from scipy.interpolate import LinearNDInterpolator

    from airmat.design.mattress import Mattress, triangulate_mattress

    width, height = uv.max(axis=0)
    mattress = Mattress(float(width), float(height))
    prev_uv, prev_x = None, None
    for level in range(levels, 0, -1):
        cuv, cfaces = triangulate_mattress(mattress, spacing=spacing * 2**level)
        x = (apply_placement(mat, cuv) if prev_uv is None
             else projector.closest_extended(LinearNDInterpolator(prev_uv, prev_x)(cuv)).points)
        if prev_uv is None and settled is not None and np.array_equal(settled[0], cuv):
            prev_uv, prev_x = settled
            continue
        prob = UAProblem(cuv, cfaces, projector, *k)
        x, it, status, residual, _ = iterate(prob, x, tol=COARSE_TOL, stall=stall, max_iter=max_iter,
                                             window=anderson, bar=None)
        log.debug("coarse level %d (%.0f mm): %s after %d iterations, force %.2g", level,
                  1e3 * prob.h, status, it, residual)
        prev_uv, prev_x = cuv, x
    # the coarse grid is a polyhedron: put the fine vertices back onto S (or its continuation)
    return projector.closest_extended(LinearNDInterpolator(prev_uv, prev_x)(uv)).points
