"""Compare an inflated mattress with Ŝ on a named face: Kabsch alignment, deviation, realized curvature.

Which surface Ŝ stands for: Ŝ keeps Ω's edge lengths (σ ≈ 1). In the
paper's model of a bend (§2.2, Figure 4a) the membrane *without* the string
keeps its length L around the wrinkle ((π − θ)d = 2h), while the face with
the string shortens to L* = L − 2h; the simulator agrees (σ ≈ 0.999 on the
face opposite the strings, ≈ 0.89 on the string face). So Ŝ is the
**length-keeping face**: the face opposite the strings. A design with
strings on both faces (a saddle) is compared on the face opposite the larger
share of bending, |κ| times the string's span (:func:`airmat.design.face_metric.length_keeping_face`;
a string face shortens by about |κ| d per unit length, so this face is the
one whose lengths Ŝ misses least); the other surfaces (top, bottom, mid) are
reported for reference.

The correspondence is known through Ω: the simulated face is evaluated at
the Ω coordinates of Ŝ's vertices by barycentric interpolation on the
mattress grid, rigidly aligned to Ŝ (Kabsch,
:meth:`scipy.spatial.transform.Rotation.align_vectors`), and the distances
of corresponding points are the deviation. SI units.

:func:`distance_to_target` (:mod:`airmat.design.target_distance`, where Ŝ's own distance is measured too)
measures the same aligned face against the user's target S
(Ŝ's guide): each point's distance to the closest point of S's mesh
(:class:`airmat.design.closest_point.MeshProjector`), as a percentage of Ŝ's diagonal
like the deviation, so the two read side by side. Distance to a set is 1-Lipschitz,
so per point |d_S(face) − d_S(Ŝ)| ≤ the deviation from Ŝ (the triangle inequality).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from airmat.errors import InputError
from airmat.geometry.polyline import midpoints, points_at_fractions
from airmat.inflation.mesh import locate
from airmat.summary import Summarized, mm

__all__ = ["SURFACES", "Deviation", "TargetDistance", "surface_at", "deviation", "distance_to_target",
           "realized_curvature", "menger_signed"]

def __getattr__(name):
    """:class:`TargetDistance` and :func:`distance_to_target`, from :mod:`airmat.design.target_distance` when first
    asked for (importing this module loads no design stage)."""
    if name in ("TargetDistance", "distance_to_target"):
        from airmat.design import target_distance

        return getattr(target_distance, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: the surfaces of an inflated mattress a comparison can name
SURFACES = ("top", "bottom", "mid")


@dataclass(frozen=True, repr=False)
class Deviation(Summarized):
    """Distance of a face of the aligned simulated mattress from Ŝ.

    Attributes
    ----------
    rms, max : float
        RMS and largest distance of corresponding points (m).
    rms_pct_diag : float
        ``rms`` as a percentage of Ŝ's bounding-box diagonal.
    per_vertex : ndarray of shape (n,)
        Distance at each vertex of Ŝ (m).
    aligned : ndarray of shape (n, 3)
        The simulated face at Ŝ's vertices after alignment (m).
    surface : str
        The face compared: ``"top"``, ``"bottom"`` or ``"mid"``.
    rotation : ndarray of shape (3, 3)
        The alignment x -> rotation @ x + translation (simulation frame to Ŝ's frame).
    translation : ndarray of shape (3,)
        (m).
    """

    rms: float
    max: float
    rms_pct_diag: float
    per_vertex: np.ndarray
    aligned: np.ndarray
    surface: str = "mid"
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))


    def _summary(self):
        return "Deviation", [("face", self.surface), ("RMS", mm(self.rms)), ("max", mm(self.max)),
                             ("% of the diagonal", f"{self.rms_pct_diag:.2f}")]

    def apply(self, xyz) -> np.ndarray:
        """Points of the simulation frame, shape (k, 3) (m), moved into Ŝ's frame."""
        return np.asarray(xyz, float) @ self.rotation.T + self.translation


def _check_surface(which: str) -> str:
    if which not in SURFACES:
        raise InputError(f"surface {which!r}: expected one of {', '.join(SURFACES)}", surface=which)
    return which


def surface_at(inflation, uv, which: str = "mid"):
    """Points of one face of an inflation at Ω points, and the top-face directions there.

    Parameters
    ----------
    inflation : airmat.inflation.simulate.Inflation
    uv : ndarray of shape (k, 2)
        Points on Ω (m).
    which : {"mid", "top", "bottom"}
        The top face, the bottom face, or the mid-surface (top + bottom) / 2.

    Returns
    -------
    xyz : ndarray of shape (k, 3)
        The face interpolated at ``uv`` (m).
    up : ndarray of shape (k, 3)
        Unit vectors from the bottom to the top face there (the top normal).
    """
    _check_surface(which)
    mesh = inflation.mesh
    tri, bary = locate(mesh, uv)
    top = np.einsum("kj,kjd->kd", bary, inflation.xyz[mesh.top[tri]])
    bottom = np.einsum("kj,kjd->kd", bary, inflation.xyz[mesh.bottom[tri]])
    up = top - bottom
    xyz = {"top": top, "bottom": bottom}.get(which)
    return (0.5 * (top + bottom) if xyz is None else xyz), up / np.linalg.norm(up, axis=1, keepdims=True)


def deviation(inflation, approx_xyz, approx_uv, surface: str = "mid") -> Deviation:
    """Deviation of one face of the inflation from Ŝ after a rigid (Kabsch) alignment.

    Parameters
    ----------
    inflation : Inflation
    approx_xyz : ndarray of shape (n, 3)
        Ŝ's vertices (m).
    approx_uv : ndarray of shape (n, 2)
        Their Ω coordinates (m).
    surface : {"mid", "top", "bottom"}
        The face compared with Ŝ.
    """
    target = np.asarray(approx_xyz, float)
    face, _ = surface_at(inflation, approx_uv, surface)
    tc, mc = target.mean(axis=0), face.mean(axis=0)
    rot, _ = Rotation.align_vectors(target - tc, face - mc)
    matrix = rot.as_matrix()
    aligned = (face - mc) @ matrix.T + tc
    dist = np.linalg.norm(aligned - target, axis=1)
    diag = float(np.linalg.norm(np.ptp(target, axis=0)))
    rms = float(np.sqrt(np.mean(dist ** 2)))
    return Deviation(rms=rms, max=float(dist.max()), rms_pct_diag=100.0 * rms / diag,
                     per_vertex=dist, aligned=aligned, surface=surface, rotation=matrix,
                     translation=tc - matrix @ mc)


def realized_curvature(inflation, a, b, polylines, surface: str = "mid", *, method: str = "turning",
                       n: int = 21) -> np.ndarray:
    """Signed curvature (1/m) one face of the simulation realizes along each dash.

    ``method="turning"`` (the default): the mean normal curvature of the face
    along the dash, the angle by which the face's normal turns from the
    dash's one end to the other divided by the dash's arc length on that face.
    For a dash along a line of curvature this is exactly the mean of κₙ along
    it (Rodrigues: dN/ds = −κₙ T), the same kind of number as the designer's
    κ (the mean of the field at points along the dash), and it is what the
    paper's model of a bend predicts: the face turns by π − θ over one
    string's span, the turn concentrated at the wrinkles at the string's ends
    (§2.2, Figure 4). The normal is the drop-stitch direction (bottom to top),
    the same on both faces; the faces differ in arc length.

    ``method="circle"``: the circle through the face's points at the dash's
    two ends and its middle (Menger curvature). Where the bend concentrates
    at the string ends, this reads the shape between the wrinkles, not the
    turn the string makes (a polygon's side reads 0 however sharp its
    corners), so it swings above and below the target with the position of
    the neighbouring strings' ends; kept for comparison.

    Positive when the surface bends away from the top face, the sign
    convention of the designer.

    Parameters
    ----------
    a, b : ndarray of shape (k, 2)
        Dash ends on Ω (m).
    polylines : sequence of ndarray of shape (p, 2)
        Dash paths on Ω (m).
    surface : {"mid", "top", "bottom"} or ndarray of shape (k,) of str
        The face to measure on, for all dashes or per dash.
    method : {"turning", "circle"}
    n : int
        Points along each dash for its arc length (``"turning"``).
    """
    k = len(a)
    if k == 0:
        return np.zeros(0)
    faces = np.broadcast_to(np.asarray(surface, dtype=object), (k,))
    if method == "circle":
        pts = np.concatenate([np.asarray(a, float), midpoints(polylines), np.asarray(b, float)])
        xyz = np.empty((3 * k, 3))
        for name in set(faces):               # at most three faces
            sel = np.tile(faces == name, 3)
            xyz[sel], _ = surface_at(inflation, pts[sel], name)
        _, up = surface_at(inflation, pts[k:2 * k])
        return menger_signed(xyz[:k], xyz[k:2 * k], xyz[2 * k:], up)
    if method != "turning":
        raise ValueError(f"method must be 'turning' or 'circle', got {method!r}")
    t = np.linspace(0.0, 1.0, int(n))
    pts = np.stack([points_at_fractions(np.asarray(p, float), t) for p in polylines])     # (k, n, 2)
    xyz, up = np.empty((k, len(t), 3)), np.empty((k, len(t), 3))
    for name in set(faces):
        sel = faces == name
        face, normal = surface_at(inflation, pts[sel].reshape(-1, 2), name)
        xyz[sel], up[sel] = face.reshape(-1, len(t), 3), normal.reshape(-1, len(t), 3)
    arc = np.linalg.norm(np.diff(xyz, axis=1), axis=2).sum(axis=1)
    ua, ub = up[:, 0], up[:, -1]
    angle = np.arctan2(np.linalg.norm(np.cross(ua, ub), axis=1), np.einsum("kd,kd->k", ua, ub))
    # normals that spread apart along the dash: the top face is convex, the surface bends away from it
    sign = np.where(np.einsum("kd,kd->k", ub - ua, xyz[:, -1] - xyz[:, 0]) >= 0, 1.0, -1.0)
    return sign * angle / np.maximum(arc, 1e-300)


def menger_signed(p, m, q, up) -> np.ndarray:
    """Signed curvature of the circle through p, m, q, each of shape (k, 3) (m): 1/m.

    Negative when the chord's middle lies on the side of ``up`` from ``m``
    (the surface bends toward the top face).

    Examples
    --------
    >>> p, m, q = np.array([[-1.0, 0, 0]]), np.array([[0.0, 0, -1]]), np.array([[1.0, 0, 0]])
    >>> menger_signed(p, m, q, np.array([[0.0, 0, 1]]))
    array([-1.])
    """
    area2 = np.linalg.norm(np.cross(m - p, q - p), axis=1)
    sides = np.linalg.norm(m - p, axis=1) * np.linalg.norm(q - m, axis=1) * np.linalg.norm(q - p, axis=1)
    kappa = 2.0 * area2 / np.maximum(sides, 1e-300)
    # the chord's middle lies on the concave side: toward the top face means kappa < 0
    toward_top = np.einsum("kd,kd->k", 0.5 * (p + q) - m, up) > 0
    return np.where(toward_top, -kappa, kappa)
