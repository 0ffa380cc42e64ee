"""The span of Equation 3 for each string: its free face's length between the ties on Ŝ.

Equation 3 describes a segment of the mattress between a string's two ties
whose free face, the face opposite the string, keeps its flat length L while
the string face folds (paper, Figure 4a). On Ŝ that face need not have length
L between the ties: Ŝ keeps the named face's metric only on average (σ ≠ 1
where the relaxation spread a strain), and on a design whose curvature has
both signs the named face carries the minority family's strings, so for
those strings the free face is the *other* face, d away from Ŝ, which is
longer or shorter than Ŝ by the bend across it (Ŝ ± d n). A segment whose
free face must be c L long is, to first order, Figure 4a's segment at span
c L: its string is Equation 3's length at that span, not at L. The membrane
wrinkles in compression but does not stretch (B1), so a free face that Ŝ would
stretch (c > 1) stays at its flat length: the span is min(c, 1) L.

:func:`free_face_ratio` measures c for each dash: the free face's arc length
along the dash on Ŝ (the named face itself, or Ŝ offset by the thickness
along its normal) over the dash's length on Ω. Measured on the saddle at
20 mm, the centre's k2 dashes need c ≈ 0.97: the mattress compresses there
rather than bend (bench_face_strain in docs/decisions.md). SI units (m).
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.interpolate import LinearNDInterpolator

from airmat.geometry.polyline import points_at_fractions

__all__ = ["free_face_ratio", "POINTS_PER_DASH"]

#: points along each dash at which the free face is sampled (ends included)
POINTS_PER_DASH = 41


def free_face_ratio(xyz, uv, faces, polylines, sides, *, named: str, thickness: float,
                    n_points: int = POINTS_PER_DASH) -> np.ndarray:
    """Length of each string's free face along its dash on Ŝ, over the dash's length on Ω.

    Parameters
    ----------
    xyz : ndarray of shape (n, 3)
        Ŝ, the named face (m).
    uv : ndarray of shape (n, 2)
        Its vertices on Ω (m).
    faces : ndarray of shape (m, 3)
        Triangles, counter-clockwise on Ω (so that their normals point to the top face).
    polylines : sequence of ndarray of shape (p_i, 2)
        Each string's dash on Ω (m).
    sides : sequence of str
        Each string's face, ``"top"`` or ``"bottom"``; its free face is the other one.
    named : {"top", "bottom"}
        The face Ŝ stands for; the other face lies ``thickness`` from it along Ŝ's normal.
    thickness : float
        Mattress thickness d (m).
    n_points : int
        Samples along each dash, ends included (>= 2).

    Returns
    -------
    ndarray of shape (k,)
        c = free-face arc on Ŝ / arc on Ω, both over the same samples (1 for a dash whose
        free face is Ŝ and keeps Ω's length; above 1 where Ŝ stretches it).

    Examples
    --------
    A cylinder of radius 0.5 m bending away from the top face (the bottom face
    concave, so its strings' free face is the top face, Ŝ itself): c = 1 along the
    bend. A top string on that mattress would have the bottom face, on the inside of
    the bend, as its free face: shorter by d / R.

    >>> u, v = np.meshgrid(np.linspace(0, 0.6, 31), np.linspace(0, 0.3, 16))
    >>> uv = np.column_stack([u.ravel(), v.ravel()])
    >>> R = 0.5
    >>> xyz = np.column_stack([R * np.sin(uv[:, 0] / R), uv[:, 1], R * np.cos(uv[:, 0] / R)])
    >>> from scipy.spatial import Delaunay
    >>> tri = Delaunay(uv).simplices
    >>> e1, e2 = uv[tri[:, 1]] - uv[tri[:, 0]], uv[tri[:, 2]] - uv[tri[:, 0]]
    >>> area = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    >>> tri[area < 0] = tri[area < 0][:, ::-1]          # counter-clockwise on Ω
    >>> dash = np.array([[0.15, 0.15], [0.45, 0.15]])
    >>> c = free_face_ratio(xyz, uv, tri, [dash, dash], ["bottom", "top"], named="top", thickness=0.07)
    >>> np.round(c, 3).tolist()    # 1, and 1 - d / R = 0.86
    [1.0, 0.86]
    """
    if named not in ("top", "bottom"):
        raise ValueError(f"named must be 'top' or 'bottom', got {named!r}")
    n_points = int(n_points)
    if n_points < 2:
        raise ValueError(f"n_points must be >= 2, got {n_points}")
    sides = np.asarray(sides)
    k = len(polylines)
    if k == 0:
        return np.zeros(0)
    xyz, uv = np.asarray(xyz, float), np.asarray(uv, float)
    up = trimesh.Trimesh(xyz, np.asarray(faces), process=False).vertex_normals     # toward the top face
    values = LinearNDInterpolator(uv, np.concatenate([xyz, up], axis=1))
    t = np.linspace(0.0, 1.0, n_points)
    pts = np.concatenate([points_at_fractions(np.asarray(p, float), t) for p in polylines])   # (k n, 2)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    eps = 1e-9 * float(np.max(hi - lo))
    sampled = values(np.clip(pts, lo + eps, hi - eps)).reshape(k, n_points, 6)
    x, n = sampled[..., :3], sampled[..., 3:]
    n = n / np.linalg.norm(n, axis=2, keepdims=True)
    free = np.where(sides == "top", "bottom", "top")
    # the other face lies below Ŝ when Ŝ is the top face, above it when Ŝ is the bottom face
    offset = np.where(free == named, 0.0, -thickness if named == "top" else thickness)
    face = x + offset[:, None, None] * n
    arc = np.linalg.norm(np.diff(face, axis=1), axis=2).sum(axis=1)
    flat = np.linalg.norm(np.diff(pts.reshape(k, n_points, 2), axis=1), axis=2).sum(axis=1)
    return arc / flat
