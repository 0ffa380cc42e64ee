"""Inflate a mattress with its external strings: start shape, string ramp, Newton solves.

The strings are tied at their flat span L and contract to their simulated
length l* (paper §3.4, B4: "each exterior string, with the initial length L,
contracts to its calculated length l"), in stages: the rest lengths go
from L to l* by continuation, each stage solved loosely, the last one to the
full tolerance. A stage that fails is retried with half the step.

The start shape is the flat mattress; optionally (``dent > 0``) with a
shallow inward dent of the string's face under each string (a half sine
along it), which seeds an inward fold where the membrane is modelled as
two-sided (``Parameters(compression=1)``, the literal B1 of Equation 5). The
default wrinkling membrane needs no seed.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from airmat.errors import ConvergenceError
from airmat.inflation.assembly import build_assembler
from airmat.inflation.energy import block_pattern
from airmat.inflation.mesh import MattressMesh, build_mattress_mesh
from airmat.inflation.model import Parameters, build_model
from airmat.inflation.preconditioned import MIN_UNKNOWNS, PreconditionedSystem
from airmat.inflation.prolong import coarse_resolutions, prolong
from airmat.inflation.solver import NewtonSystem, rigid_pins, solve
from airmat.inflation.strings import StringSet
from airmat.summary import Summarized

__all__ = ["Inflation", "inflate", "inflate_from", "inflate_many", "start_positions", "INFLATE_TOL"]

log = logging.getLogger(__name__)

#: final relative force residual of an inflation (the check's, and the refinement's verification)
INFLATE_TOL = 1e-6


@dataclass(frozen=True, repr=False)
class Inflation(Summarized):
    """An inflated mattress.

    Attributes
    ----------
    mesh : MattressMesh
    xyz : ndarray of shape (n, 3)
        Equilibrium positions of M′'s vertices (m).
    converged : bool
    n_iter : int
        Newton iterations over all stages.
    residual : float
        Final relative force residual.
    message : str
    seconds : float
    energy : float
        U_B (J).
    stages : int
        String-ramp stages solved.
    string_lengths : ndarray of shape (k,)
        Realized length of each external string (m).
    levels : tuple of (MattressMesh, ndarray of shape (n_l, 3))
        The coarser meshes of the continuation and their solutions (to ``level_tol``),
        finest first; empty unless :func:`inflate` was asked to keep them.
    """

    mesh: MattressMesh
    xyz: np.ndarray
    converged: bool
    n_iter: int
    residual: float
    message: str
    seconds: float
    energy: float
    stages: int
    string_lengths: np.ndarray
    levels: tuple = ()


    def _summary(self):
        return "Inflation", [("vertices", self.mesh.n_vertices), ("strings", len(self.string_lengths)),
                             ("converged", self.converged), ("iterations", self.n_iter),
                             ("residual", f"{self.residual:.2g}"), ("seconds", f"{self.seconds:.1f}")]

    @property
    def mid_surface(self) -> np.ndarray:
        """(top + bottom) / 2 at every grid point (g, 3) (m)."""
        return 0.5 * (self.xyz[self.mesh.top] + self.xyz[self.mesh.bottom])


def start_positions(mesh: MattressMesh, strings: StringSet | None, *, dent: float = 0.1) -> np.ndarray:
    """The flat mattress with a shallow inward dent under each string.

    Parameters
    ----------
    mesh : MattressMesh
    strings : StringSet or None
    dent : float
        Dent depth as a fraction of the mesh spacing (0: perfectly flat).

    Returns
    -------
    ndarray of shape (n, 3)
        Start positions (m).
    """
    x = mesh.vertices.copy()
    if strings is None or len(strings) == 0 or dent <= 0:
        return x
    a_sp = float(np.mean(mesh.spacing))
    span = np.linalg.norm(strings.b - strings.a, axis=1)
    n_samp = np.maximum(np.ceil(span / (0.5 * a_sp)).astype(int), 1) + 1
    owner = np.repeat(np.arange(len(strings)), n_samp)
    s = np.concatenate([np.linspace(0.0, 1.0, n) for n in n_samp])   # one short array per string
    pts = strings.a[owner] + s[:, None] * (strings.b - strings.a)[owner]
    tree = cKDTree(mesh.uv[mesh.top])
    dist, g = tree.query(pts, k=4, distance_upper_bound=a_sp)
    hit = np.isfinite(dist)
    depth = dent * a_sp * np.sin(np.pi * s)[:, None] * (1.0 - np.where(hit, dist, a_sp) / a_sp)
    samp = np.broadcast_to(np.arange(len(pts))[:, None], g.shape)[hit]
    top = strings.top[owner[samp]]
    vert = np.where(top, mesh.top[np.minimum(g[hit], len(mesh.top) - 1)],
                    mesh.bottom[np.minimum(g[hit], len(mesh.top) - 1)])
    sign = np.where(top, -1.0, 1.0)                     # inward: down for the top face, up for the bottom
    dz = np.zeros(len(x))
    np.maximum.at(dz, vert, depth[hit])
    faces_sign = np.zeros(len(x))
    faces_sign[vert] = sign
    x[:, 2] += faces_sign * dz
    return x


def _with_rest(model, rest: np.ndarray):
    """The model with the external strings (its last spring group) at other rest lengths (m)."""
    return replace(model, springs=model.springs[:-1] + (replace(model.springs[-1], rest=rest),))


def _ramp(mesh: MattressMesh, strings: StringSet | None, params: Parameters, x: np.ndarray, *,
          tol: float, stages: int, stage_tol: float, max_iter: int, hint_rel: float = 0.0,
          rule: tuple = (None, None), pcg_min: int | None = MIN_UNKNOWNS):
    """Solve U_B on ``mesh`` from ``x``, with the string rest lengths ramped from their
    lengths at ``x`` to l* in ``stages`` steps (1: no ramp). ``hint_rel`` seeds the Newton shift
    (see :class:`~airmat.inflation.solver.NewtonSystem`); ``rule`` is the solver's
    ``(refused_step, mu_up)`` (None: its defaults). A system of at least ``pcg_min`` unknowns takes
    its Newton steps by preconditioned conjugate gradients (:mod:`airmat.inflation.preconditioned`;
    None: never).

    Returns (SolveResult, iterations, stages, the NewtonSystem's final ``hint_rel``, the model)."""
    model = build_model(mesh, strings, params)
    fixed = rigid_pins(mesh.uv, mesh.top)
    pattern = block_pattern(model)
    asm = build_assembler(pattern, model.n_vertices, fixed)
    pcg = pcg_min is not None and asm.n_free >= pcg_min
    system = (PreconditionedSystem(pattern, model.smoothing, asm, hint_rel=hint_rel) if pcg
              else NewtonSystem(groups=asm.free // 3, hint_rel=hint_rel))       # shared by the stages
    kw = dict(fixed_dofs=fixed, max_iter=max_iter, max_move=0.5 * float(np.mean(mesh.spacing)),
              assembler=asm, linear_system=system, refused_step=rule[0], mu_up=rule[1])
    ramp = strings is not None and len(strings) > 0
    l0 = model.springs[-1].lengths(x) if ramp else None
    lam, step, n_iter, n_stages, halvings = 0.0, 1.0 / max(stages, 1), 0, 0, 0
    while True:
        nxt = min(1.0, lam + step) if ramp else 1.0
        m = _with_rest(model, l0 + nxt * (model.springs[-1].rest - l0)) if ramp else model
        try:
            r = solve(m, x, tol=tol if nxt >= 1.0 else stage_tol, desc=f"inflate {nxt:.0%}", **kw)
        except ConvergenceError:
            if not ramp or halvings >= 6:
                raise
            r = None
        n_iter += r.n_iter if r is not None else 0
        if r is None or (not r.converged and nxt < 1.0):
            if halvings >= 6:
                raise ConvergenceError(f"the string ramp stalled at {lam:.0%} of the contraction", stage=lam)
            halvings, step = halvings + 1, 0.5 * step
            log.info("inflation stage to %.0f%% failed; retrying with a step of %.1f%%", 100 * nxt, 100 * step)
            continue
        x, lam, result, n_stages = r.xyz, nxt, r, n_stages + 1
        log.debug("inflation stage to %.1f%%: %d iterations, residual %.2e", 100 * lam, r.n_iter, r.residual)
        if lam >= 1.0:
            return result, n_iter, n_stages, system.hint_rel, model


def inflate(mesh: MattressMesh, strings: StringSet | None, *, params: Parameters = Parameters(),
            tol: float = INFLATE_TOL, stages: int = 4, stage_tol: float = 3e-2, level_tol: float = 1e-3,
            coarsest: float = 0.08, dent: float = 0.0, max_iter: int = 200,
            strict: bool = False, keep_levels: bool = False, rule: tuple = (None, None),
            pcg_min: int | None = MIN_UNKNOWNS) -> Inflation:
    """Inflate ``mesh`` with ``strings`` (rest lengths l*) and return the equilibrium.

    The string ramp is solved on the coarsest mesh of the continuation
    (:func:`~airmat.inflation.prolong.coarse_resolutions`: the resolution
    doubled while it stays <= ``coarsest`` and leaves 3 edges along every
    string), then each finer mesh starts from the prolonged coarser solution
    with the strings at l*.

    Parameters
    ----------
    mesh : MattressMesh
    strings : StringSet or None
        External strings; ``strings.rest`` is the simulated length l* (m).
    params : Parameters
    tol : float
        Final relative force residual (on ``mesh``).
    stages : int
        Ramp stages of the string rest lengths (a failed stage is retried with
        half the step, up to 6 times in all).
    stage_tol : float
        Residual of the intermediate ramp stages.
    level_tol : float
        Residual of the coarser meshes of the continuation.
    coarsest : float
        Coarsest resolution of the continuation (m); at most ``mesh``'s own
        resolution turns the continuation off.
    dent : float
        Start dent, fraction of the mesh spacing (see :func:`start_positions`).
    max_iter : int
        Newton iterations per stage.
    strict : bool
        Raise :class:`ConvergenceError` when the final solve does not converge.
    keep_levels : bool
        Keep the coarser meshes' solutions in ``Inflation.levels`` (they do not change the result).
    rule : tuple
        ``(refused_step, mu_up)`` of :func:`~airmat.inflation.solver.solve` (None: the solver's
        defaults, :data:`~airmat.inflation.solver.REFUSED_STEP` and :data:`~airmat.inflation.solver.MU_UP`).
    pcg_min : int or None
        Meshes with at least this many unknowns take their Newton steps by conjugate gradients
        preconditioned by a sparser factor (:mod:`airmat.inflation.preconditioned`: the same equilibrium to
        the tolerance, sooner on the large mattress at 20 mm); the others (all: None) by a Cholesky
        factorization.

    Returns
    -------
    Inflation
        ``n_iter`` and ``stages`` count every mesh of the continuation.
    """
    t0 = time.perf_counter()
    resolution = float(max(mesh.spacing))
    span = np.linalg.norm(strings.b - strings.a, axis=1).min() if strings is not None and len(strings) else np.inf
    levels = coarse_resolutions(resolution, coarsest=coarsest, shortest_span=span, per_string=3.0)
    meshes = [mesh] + [build_mattress_mesh(mesh.width, mesh.height, mesh.thickness, resolution=r)
                       for r in levels[1:]]
    x, n_iter, n_stages, hint, kept = None, 0, 0, 0.0, []
    for k in range(len(meshes) - 1, -1, -1):
        m = meshes[k]
        x = start_positions(m, strings, dent=dent) if x is None else prolong(meshes[k + 1], x, m)
        first = k == len(meshes) - 1
        result, it, st, hint, model = _ramp(m, strings, params, x, tol=tol if k == 0 else level_tol,
                                            stages=stages if first else 1, stage_tol=stage_tol,
                                            max_iter=max_iter, hint_rel=hint, rule=rule, pcg_min=pcg_min)
        x, n_iter, n_stages = result.xyz, n_iter + it, n_stages + st
        if keep_levels and k > 0:
            kept.insert(0, (m, x))
        log.debug("inflation on the %.0f mm mesh: %d iterations, residual %.2e", 1e3 * max(m.spacing),
                  it, result.residual)
    return _inflation(mesh, result, model, strings, n_iter, n_stages, t0, strict, levels=tuple(kept))


def _inflation(mesh, result, model, strings, n_iter: int, n_stages: int, t0: float, strict: bool,
               levels: tuple = ()) -> Inflation:
    """The Inflation of ``result`` (the final solve, with ``model``), or ConvergenceError when ``strict``
    and it did not converge."""
    if not result.converged and strict:
        raise ConvergenceError(result.message, residual=result.residual, n_iter=n_iter)
    has_strings = strings is not None and len(strings) > 0
    lengths = model.springs[-1].lengths(result.xyz) if has_strings else np.zeros(0)
    return Inflation(mesh=mesh, xyz=result.xyz, converged=result.converged, n_iter=n_iter,
                     residual=result.residual, message=result.message, seconds=time.perf_counter() - t0,
                     energy=result.energy, stages=n_stages, string_lengths=lengths, levels=levels)


def inflate_from(start: Inflation, strings: StringSet | None, *, params: Parameters = Parameters(),
                 tol: float = INFLATE_TOL, max_iter: int = 200, strict: bool = False,
                 pcg_min: int | None = None) -> Inflation:
    """Carry an inflated equilibrium on to other strings, on its own mesh: Newton from ``start``, no ramp.

    How a refined design is inflated (:func:`airmat.check.inflation_check.check`): its
    open-loop strings are inflated from the flat mattress (:func:`inflate`), and
    that equilibrium is carried on to the refined lengths, the path the
    refinement's own equilibria took (each from the last one,
    :mod:`airmat.check.refinement`). The strings need not be the same set: those
    absent from ``strings`` are untied at once.

    Parameters
    ----------
    start : Inflation
        The equilibrium to start from (its ``mesh`` and ``xyz``).
    strings : StringSet or None
        The strings to carry it to (rest lengths l*, m); None: no strings.
    params : Parameters
    tol : float
        Final relative force residual.
    max_iter : int
        Newton iterations.
    strict : bool
        Raise :class:`ConvergenceError` when the solve does not converge.
    pcg_min : int or None
        As :func:`inflate`'s; by default (None) every step by a factorization: carried on from an
        equilibrium, the conjugate gradients take about twice the iterations per step they take from
        the flat mattress, and the steps are more; on four large refined designs that was 0.82–1.44×
        the factorizations' speed, two of them slower (``bench/bench_preconditioned.py --carry-on``).

    Returns
    -------
    Inflation
        ``n_iter`` and ``seconds`` count this solve only; ``stages`` is 1.
    """
    t0 = time.perf_counter()
    mesh = start.mesh
    result, n_iter, n_stages, _, model = _ramp(mesh, strings, params, start.xyz, tol=tol, stages=1,
                                               stage_tol=tol, max_iter=max_iter, pcg_min=pcg_min)
    return _inflation(mesh, result, model, strings, n_iter, n_stages, t0, strict)


def _inflate_task(shared, strings):
    """One inflation of :func:`inflate_many` (on a worker): the mesh is left out of the result (the caller has it)."""
    mesh, params, strict, start, keep_levels = shared
    if start is not None:
        return replace(inflate_from(replace(start, mesh=mesh), strings, params=params, strict=strict), mesh=None)
    return replace(inflate(mesh, strings, params=params, strict=strict, keep_levels=keep_levels), mesh=None)


def inflate_many(mesh: MattressMesh, string_sets: list, *, params: Parameters = Parameters(),
                 strict: bool = False, workers: int = 1, scheduler: str | None = None,
                 desc: str = "inflate", start: Inflation | None = None, keep_levels: bool = False) -> list:
    """:func:`inflate` ``mesh`` once per string set, through :func:`airmat.inflation.executor.map_shared`.

    Each inflation is serial (the sparse Cholesky is single-threaded), so
    independent runs (a design's median / lo95 / hi95 lengths, Monte-Carlo
    samples, the ratios of the validation) can share the cores: on Dask
    worker processes when ``workers > 1`` or ``scheduler`` is given. The
    mesh and ``params`` go to the workers once. The results are the same as
    one after the other: same code, same inputs, no random step.

    Parameters
    ----------
    mesh : MattressMesh
    string_sets : list of StringSet or None
        One inflation each (None: no strings); rest lengths l* (m).
    params : Parameters
    strict : bool
        Raise :class:`ConvergenceError` when a run does not converge (from
        the worker, as raised there; the other runs are cancelled).
    workers : int
        Local worker processes (1: one after the other, in this process).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:port``).
    desc : str
        Label of the progress bar over the runs.
    start : Inflation, optional
        An equilibrium on ``mesh`` that every run starts from (:func:`inflate_from`)
        instead of the flat mattress; it goes to the workers once.
    keep_levels : bool
        Runs from the flat mattress keep their continuation's coarser solutions (:func:`inflate`'s).

    Returns
    -------
    list of Inflation
        In the order of ``string_sets``.
    """
    from airmat.inflation.executor import map_shared

    start = None if start is None else replace(start, mesh=None, levels=())
    out = map_shared(_inflate_task, (mesh, params, strict, start, keep_levels), string_sets, workers=workers,
                     scheduler=scheduler, desc=desc)
    return [replace(r, mesh=mesh) for r in out]
