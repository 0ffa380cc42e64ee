"""U_A's data and its local-global solver (paper §3.2, Eq. 4), with Anderson acceleration.

U_A = Σ_edges ½ k_A1 (ε − ε0)² + Σ_vertices ½ k_A2 ‖x − x_closest‖² + Σ_vertices ½ k_A3 ‖L x‖²
(airmat.design.relax says what each term stands for and where the iteration starts).
The solver is a local-global (projective dynamics) iteration: the local step
projects each edge onto its rest length and each vertex onto S (one BVH query
for all vertices), the global step solves one linear system whose matrix
``k_A1 AᵀA + k_A2 I + k_A3 LᵀL`` never changes, so it is factorised once.
Anderson acceleration (airmat.design.anderson) speeds it up; an accelerated step
that raises U_A is replaced by the plain step, so U_A never increases. Each
iteration is cheap, but it holds every vertex to its last closest point in all
directions, so where Ω must slide along S (a target far from developable) it
crawls: the relaxation uses it for the coarse grids and the placement's
scoring, and projected Newton (airmat.design.ua_newton) for the fine mesh.

Stopping rule: the largest unbalanced force on a vertex, |∂U_A/∂x_i|, below
``tol`` × k_A1 × h (h the mean edge length): the pull of one edge strained by
``tol``. On a triangulated target the force cannot reach 0 (the closest-point
map is only piecewise smooth), so an energy that stops decreasing also ends
the iteration, and the message says so. Lengths in metres.

Resolution independence: the A1 term per unit area does not depend on the
mesh spacing h, the per-vertex A2 and A3 terms grow as 1/h². The weights
k_A2 and k_A3 are therefore stated for the reference spacing of 20 mm and
multiplied by (h / 20 mm)² (h: mean rest edge length), so Ŝ stays the same
when the mesh is refined.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from airmat.errors import ConvergenceError
from airmat.geometry.topology import boundary_edge_mask, cotangent_matrix, mesh_edges
from airmat.design.anderson import AndersonAcceleration

__all__ = ["UAProblem", "iterate", "umbrella_operator", "REFERENCE_SPACING", "STALL_WINDOW"]

#: spacing (m) at which k_A2 and k_A3 apply as given
REFERENCE_SPACING = 0.02
#: iterations over which a stalled energy is detected
STALL_WINDOW = 50


def umbrella_operator(uv: np.ndarray, faces: np.ndarray, weights: str = "cotan") -> sp.csr_matrix:
    """The A3 operator L with (L x)_i = x_i − mean of i's neighbours, shape (r, n).

    Interior vertices average all their neighbours, boundary vertices their two
    boundary neighbours (averaging inner neighbours would pull the rim inward).
    Only vertices where the term vanishes on the flat Ω get a row (this drops the
    corners): the flat mattress is a rest state of U_A3.

    ``weights="cotan"`` (default) weighs an interior vertex's neighbours with the
    cotangent weights of flat Ω (on the chequerboard grid: its four axis neighbours
    equally), which also makes ``LᵀL x`` nearly vanish on surfaces of constant curvature away
    from the rim, so A3 smooths without biasing curvature there; ``"uniform"``
    averages all neighbours (on the 4-8 grid that biases curvature in a chequerboard).
    """
    n = len(uv)
    e = mesh_edges(faces)
    on_rim = boundary_edge_mask(faces)  # same order as mesh_edges
    rim_vertex = np.zeros(n, bool)
    rim_vertex[e[on_rim].ravel()] = True
    # an interior vertex uses every edge; a rim vertex only rim edges
    ij = np.concatenate([e, e[:, ::-1]])
    rim_edge = np.concatenate([on_rim, on_rim])
    keep = ~rim_vertex[ij[:, 0]] | rim_edge
    ij = ij[keep]
    w = np.ones(len(ij))
    if weights == "cotan":
        cot = cotangent_matrix(uv, faces)
        wc = np.asarray(cot[ij[:, 0], ij[:, 1]]).ravel()
        w = np.where(rim_edge[keep], 1.0, np.where(np.abs(wc) < 1e-12, 0.0, wc))
    adj = sp.csr_matrix((w, (ij[:, 0], ij[:, 1])), shape=(n, n))
    adj.eliminate_zeros()
    deg = np.asarray(adj.sum(axis=1)).ravel()
    lap = sp.identity(n, format="csr") - sp.diags(1.0 / np.maximum(deg, 1)) @ adj
    rest = np.linalg.norm(lap @ uv, axis=1)
    h = np.linalg.norm(uv[e[:, 0]] - uv[e[:, 1]], axis=1).mean()
    rows = np.flatnonzero((rest < 1e-6 * h) & (deg > 0))
    return lap[rows]


class UAProblem:
    """U_A's fixed data: the local step (projections) and the prefactorised global step."""

    def __init__(self, uv, faces, projector, k1, k2, k3, *, extend_rim=True):
        n = len(uv)
        self.edges = mesh_edges(faces)
        self.rest = np.linalg.norm(uv[self.edges[:, 0]] - uv[self.edges[:, 1]], axis=1)
        self.h = float(self.rest.mean())
        scale = (self.h / REFERENCE_SPACING) ** 2   # per-vertex weights are given at 20 mm spacing
        k2, k3 = k2 * scale, k3 * scale
        self.lap = umbrella_operator(uv, faces)
        m = len(self.edges)
        rows = np.r_[np.arange(m), np.arange(m)]
        self.inc = sp.csr_matrix((np.r_[np.ones(m), -np.ones(m)],
                                  (rows, np.r_[self.edges[:, 0], self.edges[:, 1]])), shape=(m, n))
        self.gmat = (k1 * (self.inc.T @ self.inc) + k2 * sp.identity(n) + k3 * (self.lap.T @ self.lap)).tocsc()
        # SuperLU by name: scipy's ``factorized`` would switch to UMFPACK wherever scikit-umfpack is
        # installed, and every design's last bits with it
        self.solve = splu(self.gmat).solve
        self._inc_t = self.inc.T               # (n, m), CSC: transposed once, not at every step
        self.k = (k1, k2, k3)
        self.projector = projector
        self.extend_rim = extend_rim

    def project(self, x):
        """A2's targets (n, 3): closest points on S, continued across its rim by tangent planes
        (``extend_rim``, airmat.design.closest_point.MeshProjector.closest_extended) or not."""
        return (self.projector.closest_extended(x) if self.extend_rim else self.projector.closest(x)).points

    def energy(self, x, cp) -> dict:
        k1, k2, k3 = self.k
        length = np.linalg.norm(self.inc @ x, axis=1)
        u1 = 0.5 * k1 * np.sum((length - self.rest) ** 2)
        u2 = 0.5 * k2 * np.sum((x - cp) ** 2)
        u3 = 0.5 * k3 * np.sum((self.lap @ x) ** 2)
        return {"U_A1": float(u1), "U_A2": float(u2), "U_A3": float(u3), "U_A": float(u1 + u2 + u3)}

    def global_step(self, x, cp):
        """The projective-dynamics step G(x) (edges projected to rest length, one linear solve)
        and the force -∇U_A(x), both (n, 3)."""
        k1, k2, _ = self.k
        d = self.inc @ x
        length = np.linalg.norm(d, axis=1)
        d *= (self.rest / np.maximum(length, 1e-12 * self.h))[:, None]
        rhs = k1 * (self._inc_t @ d) + k2 * cp
        # one coordinate per solve: SuperLU's blocked solve of the three at once rounds otherwise
        # (the dome's Ŝ moved in its last bits), and every measured design would move with it
        g = np.column_stack([self.solve(np.ascontiguousarray(rhs[:, c])) for c in range(3)])
        return g, rhs - self.gmat @ x


def iterate(prob: UAProblem, x, *, tol, stall, max_iter, window, bar):
    """Anderson-accelerated local-global iterations from x.

    Returns (x, n_iter, status, residual, history); status is "force", "stall" or "max_iter".
    """
    acc = AndersonAcceleration(window)
    cp = prob.project(x)
    e = e0 = prob.energy(x, cp)["U_A"]
    g, force = prob.global_step(x, cp)
    history, energies, status, residual, it = [], [e], "max_iter", np.inf, 0
    for it in range(1, max_iter + 1):
        residual = float(np.linalg.norm(force, axis=1).max() / (prob.k[0] * prob.h))
        history.append(residual)
        if residual < tol:
            status = "force"
            break
        if len(energies) > STALL_WINDOW and energies[-STALL_WINDOW - 1] - e <= stall * e:
            status = "stall"
            break
        if not np.isfinite(g).all():
            raise ConvergenceError(f"U_A relaxation diverged at iteration {it} (non-finite positions)",
                                   n_iter=it)
        x_new = acc.propose(x, g)
        cp_new = prob.project(x_new)
        e_new = prob.energy(x_new, cp_new)["U_A"]
        if e_new > e and x_new is not g:  # the accelerated step went uphill: take the plain one
            acc.reset()
            acc.propose(x, g)
            x_new, cp_new = g, prob.project(g)
            e_new = prob.energy(x_new, cp_new)["U_A"]
        if not (np.isfinite(x_new).all() and np.isfinite(e_new)) or e_new > 1e3 * e0 + 1e-30:
            raise ConvergenceError(f"U_A relaxation diverged at iteration {it} "
                                   f"(energy {e_new:.3g}, started at {e0:.3g})", n_iter=it)
        x, cp, e = x_new, cp_new, e_new
        energies.append(e)
        g, force = prob.global_step(x, cp)
        if bar is not None:
            bar.residual(residual)
    return x, it, status, residual, history
