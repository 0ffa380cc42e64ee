"""The energy U_B of Equation 5: its terms, gradient and Hessian blocks.

U_B = U_B1 (edge springs) + U_B2 (-p Vol) + U_B3 (internal strings)
+ U_B4 (external clamp strings) + U_B5 (Laplacian smoothing).

U_B1, U_B3 and U_B4 are all springs on a vector ``r = sum_k c_k x_{i_k}``
that combines a few vertices: an edge is ``x_j - x_i``; an external string
joins two points fixed on the face by barycentric coordinates,
``r = sum_a w_a x_a - sum_b w_b x_b`` (six vertices). One vectorized kernel
evaluates every spring group. A spring is ``1/2 k (|r| - r0)^2`` in
tension and may be softer in compression (:func:`spring_profile`): a string
is tension-only (``u_m`` of Equation 5, the ClampLength goal), a membrane
edge may wrinkle; the switch is smoothed over a small stretch so that
forces and stiffnesses are continuous.

Hessians come as dense 3 × 3 blocks per vertex pair, assembled into a sparse
matrix by :mod:`airmat.inflation.assembly`: exact, or with each spring block
projected to be positive semi-definite (``project=True``: the transverse
term ``f(|r|)/|r|`` clamped at 0 for a compressed spring); the pressure term
``-p Vol`` is always exact (indefinite: the solver shifts when needed).
All quantities are SI: metres, newtons, pascals, joules.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from airmat.geometry.topology import boundary_vertices, cotangent_umbrella

__all__ = ["Springs", "Model", "spring_profile", "spring_terms", "volume_terms", "smoothing_matrix",
           "energy", "energy_and_gradient", "energy_gradient_volume", "hessian_blocks", "pressure_forces"]


@dataclass(frozen=True)
class Springs:
    """A group of springs on combinations of vertices.

    Attributes
    ----------
    idx : ndarray of shape (s, k)
        Vertex indices combined by each spring.
    coef : ndarray of shape (s, k)
        Their coefficients: ``r = sum_k coef[:, k] * x[idx[:, k]]``.
    rest : ndarray of shape (s,)
        Rest length r0 (m).
    stiffness : ndarray of shape (s,)
        Spring constant k (N/m) in tension.
    compression : float
        Stiffness ratio in compression: 1 for a linear spring, 0 for a
        string (tension-only, the ClampLength goal).
    name : str
        Label of the term (``"B1"``, ``"B3"``, ``"B4"``).
    smooth : float or ndarray of shape (s,)
        Width (m) of the smooth switch between compression and tension (see
        :func:`spring_profile`); 0 for a sharp switch.
    """

    idx: np.ndarray
    coef: np.ndarray
    rest: np.ndarray
    stiffness: np.ndarray
    compression: float
    name: str
    smooth: object = 0.0

    def lengths(self, x: np.ndarray) -> np.ndarray:
        """Current length |r| (m) of every spring at positions ``x`` (n, 3)."""
        return np.linalg.norm(np.einsum("sk,skc->sc", self.coef, x[self.idx]), axis=1)


@dataclass(frozen=True)
class Model:
    """Everything U_B needs besides the positions.

    Attributes
    ----------
    n_vertices : int
    faces : ndarray of shape (m, 3)
        Closed, outward-oriented triangles (for the enclosed volume).
    springs : tuple of Springs
        B1 (edges), B3 (internal strings), B4 (external strings).
    pressure : float
        p (Pa).
    smoothing : scipy.sparse.csr_matrix of shape (n, n)
        ``k5 A^T A`` with ``A = I - W`` the per-face Laplacian with the
        cotangent weights of the flat mesh (:func:`smoothing_matrix`), so
        that ``U_B5 = 1/2 tr(X^T Q X)`` (N/m).
    """

    n_vertices: int
    faces: np.ndarray
    springs: tuple
    pressure: float
    smoothing: sp.csr_matrix


def spring_profile(stretch: np.ndarray, width, compression: float) -> tuple:
    """Energy/k, force/k and stiffness/k of a spring softer in compression, with a smooth switch.

    The stiffness is 1 in tension and ``c`` (the compression ratio: 0 for a
    string, which goes slack, 1 for a plain linear spring) in compression,
    changing linearly over a stretch interval of length ``2 w`` so that the
    force and its derivative are continuous (Newton's method does not cycle
    on springs switching between slack and taut). The interval is
    ``[0, 2w]`` for a string (``c = 0``: no force when slack, the taut
    string acts from ``w`` longer than its rest length) and ``[-2w, 0]``
    otherwise (exact in tension, a compressive force bounded by about
    ``k w`` plus ``c k |s|``). ``w = 0`` gives the sharp switch (``u_m`` of
    Equation 5 for ``c = 0``).
    """
    c = float(compression)
    if c == 1.0:
        return 0.5 * stretch ** 2, stretch, np.ones_like(stretch)
    w = np.broadcast_to(np.asarray(width, float), stretch.shape)
    ws = np.maximum(w, 1e-300)
    z = stretch + 2.0 * w if c > 0 else stretch             # position above the start of the switch
    f0 = -w * (1.0 + c) if c > 0 else np.zeros_like(w)      # force at the start: f(0) = 0 for c > 0
    below, above = z <= 0, z >= 2.0 * w
    ramp_f = np.where(above, z - w, np.where(below, 0.0, z ** 2 / (4 * ws)))
    ramp_e = np.where(above, 0.5 * z ** 2 - w * z + 2.0 * w ** 2 / 3.0,
                      np.where(below, 0.0, z ** 3 / (12 * ws)))
    df = np.where(above, 1.0, np.where(below, c, c + (1.0 - c) * z / (2 * ws)))
    f = f0 + c * z + (1.0 - c) * ramp_f
    e = f0 * z + 0.5 * c * z ** 2 + (1.0 - c) * ramp_e
    return e, f, df


def spring_terms(x: np.ndarray, s: Springs, *, gradient: bool = True, hessian: bool = False,
                 project: bool = False):
    """Energy, gradient and Hessian blocks of a spring group.

    Parameters
    ----------
    x : ndarray of shape (n, 3)
        Vertex positions (m).
    s : Springs
    project : bool
        Clamp each spring's transverse stiffness ``psi'(|r|)/|r|`` at 0, which
        makes every element block positive semi-definite.

    Returns
    -------
    energy : float
        J.
    grad : ndarray of shape (n, 3) or None
        N.
    blocks : ndarray of shape (s, k, k, 3, 3) or None
        ``blocks[q, a, b]`` is d²U/dx_{idx[q,a]} dx_{idx[q,b]} (N/m).
    """
    r = np.einsum("sk,skc->sc", s.coef, x[s.idx])
    length = np.linalg.norm(r, axis=1)
    stretch = length - s.rest
    e_k, f_k, df_k = spring_profile(stretch, s.smooth, s.compression)
    e = float(np.sum(s.stiffness * e_k))
    if not (gradient or hessian):
        return e, None, None
    rhat = r / np.maximum(length, 1e-300)[:, None]
    grad = None
    if gradient:
        g_r = (s.stiffness * f_k)[:, None] * rhat
        contrib = s.coef[:, :, None] * g_r[:, None, :]
        grad = np.column_stack([np.bincount(s.idx.ravel(), weights=contrib[..., c].ravel(),
                                            minlength=len(x)) for c in range(3)])
    blocks = None
    if hessian:
        geo = f_k / np.maximum(length, 1e-300)
        if project:                               # PSD: no negative transverse stiffness
            geo = np.clip(geo, 0.0, None)
        dfh = df_k
        if s.compression < 1 and np.all(np.asarray(s.smooth) == 0):
            dfh = np.where(stretch >= 0, 1.0, s.compression)   # a sharp switch exactly at rest counts as taut
        rr = rhat[:, :, None] * rhat[:, None, :]
        h_r = s.stiffness[:, None, None] * (dfh[:, None, None] * rr + geo[:, None, None] * (np.eye(3) - rr))
        cc = s.coef[:, :, None] * s.coef[:, None, :]
        blocks = cc[:, :, :, None, None] * h_r[:, None, None, :, :]
    return e, grad, blocks


def _skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices [v]x, shape (m, 3, 3), of vectors (m, 3)."""
    out = np.zeros((len(v), 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


#: ordered vertex pairs (a, b) of a triangle with the third vertex c and the sign
#: of d²Vol/dx_a dx_b = sign [x_c]x / 6
VOLUME_PAIRS = ((0, 1, 2, -1.0), (1, 0, 2, 1.0), (1, 2, 0, -1.0), (2, 1, 0, 1.0),
                (2, 0, 1, -1.0), (0, 2, 1, 1.0))


def volume_terms(x: np.ndarray, faces: np.ndarray, *, gradient: bool = True, hessian: bool = False):
    """Enclosed volume of a closed mesh, its exact gradient and Hessian blocks.

    ``Vol = sum_f x_a . (x_b × x_c) / 6`` (computed about the centroid, which
    a closed mesh allows, for round-off); ``dVol/dx_a = sum_f x_b × x_c / 6``.

    Returns
    -------
    vol : float
        m³.
    grad : ndarray of shape (n, 3) or None
        m².
    blocks : ndarray of shape (m, 6, 3, 3) or None
        d²Vol/dx_a dx_b for the ordered pairs of :data:`VOLUME_PAIRS` (m).
    """
    xc = x - x.mean(axis=0)
    a, b, c = xc[faces[:, 0]], xc[faces[:, 1]], xc[faces[:, 2]]
    vol = float(np.einsum("ij,ij->", a, np.cross(b, c))) / 6.0
    grad = None
    if gradient:
        per_corner = np.stack([np.cross(b, c), np.cross(c, a), np.cross(a, b)], axis=1) / 6.0
        grad = np.column_stack([np.bincount(faces.ravel(), weights=per_corner[..., k].ravel(),
                                            minlength=len(x)) for k in range(3)])
    blocks = None
    if hessian:
        skew6 = [_skew(corner) / 6.0 for corner in (a, b, c)]   # ±[x]x/6 = ±([x]x/6) exactly
        blocks = np.stack([skew6[k] if sign > 0 else -skew6[k] for _, _, k, sign in VOLUME_PAIRS], axis=1)
    return vol, grad, blocks


def smoothing_matrix(uv_grid: np.ndarray, grid_faces: np.ndarray, top: np.ndarray, bottom: np.ndarray,
                     n_vertices: int, weight: float) -> sp.csr_matrix:
    """``k5 A^T A`` for U_B5, with ``(A x)_i = x_i - x_i,avg`` on each face separately.

    ``x_i,avg`` is the average of the neighbours of vertex i weighted by the
    cotangent weights of the flat mesh, for the interior vertices of each
    face only: on the flat mattress every ``A x`` row is exactly 0 (linear
    precision), so U_B5 vanishes at rest and pulls neither the boundary
    inward nor the faces together; ``A (R x + t) = R A x``, so U_B5 does not
    change under rigid motions.

    Parameters
    ----------
    uv_grid : ndarray of shape (g, 2)
        Ω coordinates of the grid points (m).
    grid_faces : ndarray of shape (t, 3)
        Triangulation of Ω on grid indices.
    top, bottom : ndarray of shape (g,)
        Vertex indices of the grid points on each face.
    n_vertices : int
    weight : float
        k5 (N/m).

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n, n)
        Constant Hessian (per coordinate) of U_B5 (N/m).
    """
    g = len(top)
    interior = np.setdiff1d(np.arange(g), boundary_vertices(grid_faces))
    lap = cotangent_umbrella(uv_grid, grid_faces)[interior]      # rows: x_i - weighted average
    both = np.concatenate([top, bottom])
    rows = sp.block_diag([lap, lap], format="csr")
    a = rows @ sp.coo_matrix((np.ones(2 * g), (np.arange(2 * g), both)), shape=(2 * g, n_vertices)).tocsr()
    return (weight * (a.T @ a)).tocsr()


def energy(model: Model, x: np.ndarray) -> float:
    """U_B (J) at positions ``x`` (n, 3), without the constant U_0,B2."""
    e = sum(spring_terms(x, s, gradient=False)[0] for s in model.springs)
    e -= model.pressure * volume_terms(x, model.faces, gradient=False)[0]
    return e + 0.5 * float(np.einsum("ij,ij->", x, model.smoothing @ x))


def energy_and_gradient(model: Model, x: np.ndarray) -> tuple:
    """U_B (J) and its gradient (n, 3) (N)."""
    return energy_gradient_volume(model, x)[:2]


def energy_gradient_volume(model: Model, x: np.ndarray) -> tuple:
    """U_B (J), its gradient (n, 3) (N) and the volume's gradient dVol/dx (n, 3) (m²).

    The last gives the pressure forces ``p dVol/dx`` (:func:`pressure_forces`, the same bits)
    without computing the volume terms again.
    """
    e, g = 0.0, model.smoothing @ x
    e += 0.5 * float(np.einsum("ij,ij->", x, g))
    for s in model.springs:
        es, gs, _ = spring_terms(x, s)
        e, g = e + es, g + gs
    vol, gv, _ = volume_terms(x, model.faces)
    return e - model.pressure * vol, g - model.pressure * gv, gv


def pressure_forces(model: Model, x: np.ndarray) -> np.ndarray:
    """Pressure force on every vertex, ``p dVol/dx`` (n, 3) (N)."""
    return model.pressure * volume_terms(x, model.faces)[1]


def hessian_blocks(model: Model, x: np.ndarray, *, project: bool = False) -> list:
    """Hessian blocks of every non-constant term, in the order of :func:`block_pattern`.

    Parameters
    ----------
    project : bool
        Project each spring's blocks to be positive semi-definite.

    Returns
    -------
    list of ndarray of shape (b_i, 3, 3)
        Spring groups, then the exact pressure term ``-p d²Vol``.
    """
    out = [spring_terms(x, s, gradient=False, hessian=True, project=project)[2].reshape(-1, 3, 3)
           for s in model.springs]
    out.append(-model.pressure * volume_terms(x, model.faces, gradient=False, hessian=True)[2]
               .reshape(-1, 3, 3))
    return out


def block_pattern(model: Model) -> list:
    """Vertex (row, col) of every Hessian block of :func:`hessian_blocks`, plus the smoothing term last.

    Returns
    -------
    list of (ndarray, ndarray)
        Row and column vertex indices, one pair of arrays per term.
    """
    out = []
    for s in model.springs:
        kk = s.idx.shape[1]
        out.append((np.repeat(s.idx, kk, axis=1).ravel(), np.tile(s.idx, (1, kk)).ravel()))
    f = model.faces
    out.append((np.stack([f[:, a] for a, _, _, _ in VOLUME_PAIRS], axis=1).ravel(),
                np.stack([f[:, b] for _, b, _, _ in VOLUME_PAIRS], axis=1).ravel()))
    q = model.smoothing.tocoo()
    out.append((q.row.astype(np.int64), q.col.astype(np.int64)))
    return out


def smoothing_blocks(model: Model) -> np.ndarray:
    """Constant U_B5 Hessian blocks ``Q_ij I3`` (nnz(Q), 3, 3), matching :func:`block_pattern`'s last entry."""
    q = model.smoothing.tocoo()
    return q.data[:, None, None] * np.eye(3)[None]
