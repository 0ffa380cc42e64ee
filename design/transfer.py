"""Carry Ŝ's principal curvatures onto the flat mattress Ω (paper §3.2, last paragraph).

Ŝ and Ω share their triangles, so the flattening f: Ŝ -> Ω is known per
triangle: a linear map J (2 × 3) taking the triangle's edge vectors on Ŝ to
those on Ω. Each vertex's principal directions are pushed through the
Jacobians of its triangles and averaged (area-weighted) as *lines*, in the
doubled-angle representation (cos 2φ, sin 2φ), where opposite vectors agree.

Families follow the physics (:func:`family_order`): a string sits on the
concave side, so the families are the algebraically larger and the smaller
principal curvature, κ_hi ≥ κ_lo, and ``k1`` is the one of the sign that
bends the design most (its area integral of |κ|). On a saddle k1 is then
one sign and k2 the other everywhere: each family keeps to one face and its
lines run on where |κ_hi| = |κ_lo|, where an order by magnitude swaps them.
Where both curvatures have the design's main sign (a vault, a dome, the
near-developable parts) this is the order by magnitude; where both have the
other sign it is not, which keeps the labels continuous across the parabolic
line between. Labels and directions mean nothing only at umbilics, κ_hi ≈ κ_lo
(a dome's crown). The line field is therefore smoothed by one screened Laplace
solve on Ω, weighted by the reliability w = a² / (a² + a0²), a = κ_hi − κ_lo:
reliable vertices keep their direction, unreliable ones take their
neighbours'. Family k2 is set exactly perpendicular to k1 on Ω (f is
nearly an isometry: σ ≈ 1), and each family's curvature is the normal
curvature of Ŝ along the smoothed line (from the curvature tensor carried
to Ω), so labels and values stay continuous across umbilics. Units: m, 1/m.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from airmat.design.field import MattressField

__all__ = ["face_jacobians", "transfer_to_mattress", "direction_weight", "family_order"]


def face_jacobians(xyz: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-triangle Jacobians (m, 2, 3) of the map Ŝ -> Ω (dimensionless).

    ``J[f] @ (x_j - x_i) == uv_j - uv_i`` for the edges of triangle f; vectors
    normal to the triangle map to 0.
    """
    p, q = xyz[faces], uv[faces]
    e = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=-1)          # (m, 3, 2)
    g = np.stack([q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]], axis=-1)          # (m, 2, 2)
    et = np.swapaxes(e, 1, 2)
    return g @ np.linalg.solve(et @ e, et)


def direction_weight(kappa: np.ndarray, anisotropy_scale: float) -> np.ndarray:
    """Reliability (n,) in [0, 1) of the family labels: a² / (a² + a0²), a = |κ1 − κ2| (1/m).

    0 only at umbilics; on a saddle a = |κ1| + |κ2|, as reliable as anywhere.
    """
    a = np.abs(kappa[:, 0] - kappa[:, 1])
    return a**2 / (a**2 + anisotropy_scale**2)


def family_order(kappa: np.ndarray, uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Which principal curvature is family k1 at each vertex: the signed order, the design's main sign first.

    Parameters
    ----------
    kappa : ndarray of shape (n, 2)
        Signed principal curvatures (1/m), in any order per vertex.
    uv, faces : ndarray of shape (n, 2), (m, 3)
        Ω's triangulation (m): the area weights.

    Returns
    -------
    ndarray of shape (n,) of int
        Column of ``kappa`` that is family k1 at each vertex: the larger κ when the
        area integral of |max κ| is at least that of |min κ| (the design bends mostly
        toward the bottom face's strings), else the smaller.

    Examples
    --------
    A saddle whose two curvatures swap magnitude: k1 stays the positive one.

    >>> uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    >>> k = np.array([[3.0, -1.0], [-3.0, 1.0], [2.2, -2.1]])
    >>> family_order(k, uv, np.array([[0, 1, 2]])).tolist()
    [0, 1, 0]
    """
    from airmat.geometry.topology import flat_vertex_areas

    kappa = np.asarray(kappa, float)
    hi = np.argmax(kappa, axis=1)
    area = flat_vertex_areas(uv, faces)
    if area @ np.abs(kappa.max(axis=1)) >= area @ np.abs(kappa.min(axis=1)):
        return hi
    return 1 - hi


def _cross2(a, b):
    """z component of the cross product of 2-vectors (k, 2)."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _doubled(v):
    """(cos 2φ, sin 2φ) of 2-vectors v (..., 2), any length."""
    n2 = np.maximum(np.sum(v * v, axis=-1), 1e-300)
    return np.stack([(v[..., 0] ** 2 - v[..., 1] ** 2) / n2, 2 * v[..., 0] * v[..., 1] / n2], axis=-1)


def _pushed_lines(xyz, uv, faces, dirs3d):
    """Per-vertex doubled-angle line field (n, 2) of family k1 on Ω, before smoothing."""
    jac = face_jacobians(xyz, uv, faces)
    area = 0.5 * np.abs(_cross2(uv[faces[:, 1]] - uv[faces[:, 0]], uv[faces[:, 2]] - uv[faces[:, 0]]))
    z = np.zeros((len(uv), 2))
    for c in range(3):  # the three corners of every triangle at once
        d = dirs3d[faces[:, c]]                                            # (m, 2, 3)
        pushed = np.einsum("fij,fkj->fki", jac, d)                          # (m, 2, 2)
        # k1 as is, k2 turned by 90 degrees: a negated doubled angle
        zc = _doubled(pushed[:, 0]) - _doubled(pushed[:, 1])
        np.add.at(z, faces[:, c], area[:, None] * zc)
    return z


def _smooth(z0, w, uv, faces, length):
    """Screened smoothing: argmin Σ M w |z − z0|² + ℓ² ∫|∇z|² (one sparse solve)."""
    import igl

    v3 = np.column_stack([uv, np.zeros(len(uv))])
    stiff = -igl.cotmatrix(v3, faces)
    mass = igl.massmatrix(v3, faces, igl.MASSMATRIX_TYPE_VORONOI).diagonal()
    screen = sp.diags(mass * np.maximum(w, 1e-3))
    lhs = (screen + length**2 * stiff).tocsc()
    return spsolve(lhs, screen @ z0)


def transfer_to_mattress(xyz, uv, faces, kappa, dirs3d, *, width: float, height: float,
                         smoothing_length: float = 0.03, anisotropy_scale: float = 0.5,
                         meta: dict | None = None) -> MattressField:
    """The principal-curvature field of Ŝ carried onto Ω.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Vertices of Ŝ (m).
    uv : ndarray of shape (n, 2)
        The same vertices on Ω (m).
    faces : ndarray of shape (m, 3)
        Shared triangles.
    kappa : ndarray of shape (n, 2)
        Signed principal curvatures of Ŝ (1/m), in any order (:func:`family_order`
        names the families).
    dirs3d : ndarray of shape (n, 2, 3)
        Their unit directions in space.
    width, height : float
        W and H of Ω (m).
    smoothing_length : float, default 0.03
        Length (m) over which unreliable directions are filled in from their
        neighbours (reliable ones barely move).
    anisotropy_scale : float, default 0.5
        a0 (1/m) of the reliability weight: families whose |κ| differ by much
        less than a0 cannot be told apart.
    meta : dict, optional
        Extra information stored in the field's ``meta``.

    Returns
    -------
    airmat.design.field.MattressField
        ``kappa`` (n, 2): normal curvatures along the smoothed k1 and k2 lines;
        ``direction`` (n, 2, 2): unit lines on Ω, k2 ⟂ k1; ``weight`` (n,): the
        reliability w.
    """
    xyz, uv = np.asarray(xyz, float), np.asarray(uv, float)
    faces, kappa, dirs3d = np.asarray(faces, np.int64), np.asarray(kappa, float), np.asarray(dirs3d, float)
    first = family_order(kappa, uv, faces)
    swap = first == 1
    kappa = np.where(swap[:, None], kappa[:, ::-1], kappa)
    dirs3d = np.where(swap[:, None, None], dirs3d[:, ::-1], dirs3d)
    z0 = _pushed_lines(xyz, uv, faces, dirs3d)
    raw = 0.5 * np.arctan2(z0[:, 1], z0[:, 0])
    w = direction_weight(kappa, anisotropy_scale)
    z = _smooth(z0 / np.maximum(np.linalg.norm(z0, axis=1, keepdims=True), 1e-300), w, uv, faces,
                smoothing_length)
    phi = 0.5 * np.arctan2(z[:, 1], z[:, 0])
    d1 = np.column_stack([np.cos(phi), np.sin(phi)])
    d2 = np.column_stack([-d1[:, 1], d1[:, 0]])
    # normal curvature along the smoothed lines, from the tensor κ1 e1e1ᵀ + κ2 e2e2ᵀ on Ω
    c2 = np.cos(phi - raw) ** 2
    k_along1 = kappa[:, 0] * c2 + kappa[:, 1] * (1 - c2)
    k_along2 = kappa[:, 0] * (1 - c2) + kappa[:, 1] * c2
    info = {"smoothing_length": smoothing_length, "anisotropy_scale": anisotropy_scale}
    info.update(meta or {})
    return MattressField(width=float(width), height=float(height), uv=uv,
                         kappa=np.column_stack([k_along1, k_along2]),
                         direction=np.stack([d1, d2], axis=1), weight=w, meta=info)
