"""Inflate a mattress with its external strings: start shape, string ramp, Newton solves.

The strings are tied at their flat span L and contract to their simulated
length l* (paper §3.4, B4: "each exterior string, with the initial length L,
contracts to its calculated length l"), in stages: the rest lengths go
from L to l* by continuation, each stage solved loosely, the last one to the
full tolerance. A stage that fails is retried with half the step.

The start shape is the flat mattress with, under each string, a shallow
inward dent of the string's face (a half sine along the string, amplitude a
fraction of the mesh resolution). The flat state with a compressed face
is an equilibrium too (a saddle): the dent seeds the inward wrinkle the
paper describes (Fig. 2 and 4) at the middle of each string, and keeps a
symmetric pattern symmetric. It is far smaller than the folds it seeds.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from airmat.errors import ConvergenceError
from design.inflation.assembly import build_assembler
from design.inflation.energy import block_pattern
from design.inflation.mesh import MattressMesh
from design.inflation.model import Parameters, build_model
from design.inflation.solver import SolveResult, rigid_pins, solve
from design.inflation.strings import StringSet

__all__ = ["Inflation", "inflate", "start_positions"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Inflation:
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
    import os
    if os.environ.get("DENT") == "local":
        prof = np.exp(-(((s - 0.5) * span[owner]) / a_sp) ** 2)
    else:
        prof = np.sin(np.pi * s)
    depth = dent * a_sp * prof[:, None] * (1.0 - np.where(hit, dist, a_sp) / a_sp)
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


def _stage_rest(l0: np.ndarray, target: np.ndarray, lam: float) -> np.ndarray:
    return l0 + lam * (target - l0)


def inflate(mesh: MattressMesh, strings: StringSet | None, *, params: Parameters = Parameters(),
            tol: float = 1e-6, stages: int = 6, stage_tol: float = 1e-3, dent: float = 0.1,
            max_iter: int = 300, strict: bool = False) -> Inflation:
    """Inflate ``mesh`` with ``strings`` (rest lengths l*) and return the equilibrium.

    Parameters
    ----------
    mesh : MattressMesh
    strings : StringSet or None
        External strings; ``strings.rest`` is the simulated length l* (m).
    params : Parameters
    tol : float
        Final relative force residual.
    stages : int
        Ramp stages of the string rest lengths (halved on failure, up to 4 times).
    stage_tol : float
        Residual of the intermediate stages.
    dent : float
        Start dent, fraction of the mesh spacing (see :func:`start_positions`).
    max_iter : int
        Newton iterations per stage.
    strict : bool
        Raise :class:`ConvergenceError` when the final solve does not converge.

    Returns
    -------
    Inflation
    """
    t0 = time.perf_counter()
    model = build_model(mesh, strings, params)
    fixed = rigid_pins(mesh.uv, mesh.top, mesh.spacing)
    asm = build_assembler(block_pattern(model), model.n_vertices, fixed)
    x = start_positions(mesh, strings, dent=dent)
    max_move = 0.5 * float(np.mean(mesh.spacing))
    has_strings = strings is not None and len(strings) > 0
    target = model.springs[-1].rest if has_strings else None
    l0 = model.springs[-1].lengths(x) if has_strings else None
    lam, step, n_iter, n_stages, halvings = 0.0, 1.0 / max(stages, 1), 0, 0, 0
    result: SolveResult | None = None
    while True:
        nxt = min(1.0, lam + step) if has_strings else 1.0
        last = nxt >= 1.0
        m = model
        if has_strings:
            b4 = replace(model.springs[-1], rest=_stage_rest(l0, target, nxt))
            m = replace(model, springs=model.springs[:-1] + (b4,))
        try:
            r = solve(m, x, fixed_dofs=fixed, tol=tol if last else stage_tol, max_iter=max_iter,
                      max_move=max_move, assembler=asm, desc=f"inflate {nxt:.0%}")
        except ConvergenceError:
            if not has_strings or halvings >= 4:
                raise
            r = None
        n_iter += r.n_iter if r is not None else 0
        if r is None or (not r.converged and not last):
            if halvings >= 6:
                raise ConvergenceError(f"the string ramp stalled at {lam:.0%} of the contraction",
                                       stage=lam)
            halvings += 1
            step *= 0.5
            log.info("inflation stage to %.0f%% failed; retrying with a step of %.1f%%", 100 * nxt, 100 * step)
            continue
        x, lam, result, n_stages = r.xyz, nxt, r, n_stages + 1
        log.debug("inflation stage to %.1f%%: %d iterations, residual %.2e", 100 * lam, r.n_iter, r.residual)
        if last:
            break
    if not result.converged and strict:
        raise ConvergenceError(result.message, residual=result.residual, n_iter=n_iter)
    lengths = model.springs[-1].lengths(x) if has_strings else np.zeros(0)
    return Inflation(mesh=mesh, xyz=x, converged=result.converged, n_iter=n_iter, residual=result.residual,
                     message=result.message, seconds=time.perf_counter() - t0, energy=result.energy,
                     stages=n_stages, string_lengths=lengths)
