"""Compare an inflated mattress with Ŝ: Kabsch alignment, deviation, realized curvature per dash.

The correspondence is known through Ω: the simulated mid-surface
(top + bottom) / 2 is evaluated at the Ω coordinates of Ŝ's vertices by
barycentric interpolation on the mattress grid, rigidly aligned to Ŝ
(Kabsch, :meth:`scipy.spatial.transform.Rotation.align_vectors`), and the
distances of corresponding points are the deviation. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from airmat.geometry.polyline import midpoints
from inflation.mesh import locate

__all__ = ["Deviation", "surface_at", "deviation", "realized_curvature"]


@dataclass(frozen=True)
class Deviation:
    """Distance of the aligned simulated mid-surface from Ŝ.

    Attributes
    ----------
    rms, max : float
        RMS and largest distance of corresponding points (m).
    rms_pct_diag : float
        ``rms`` as a percentage of Ŝ's bounding-box diagonal.
    per_vertex : ndarray of shape (n,)
        Distance at each vertex of Ŝ (m).
    aligned : ndarray of shape (n, 3)
        The simulated mid-surface at Ŝ's vertices after alignment (m).
    """

    rms: float
    max: float
    rms_pct_diag: float
    per_vertex: np.ndarray
    aligned: np.ndarray


def surface_at(inflation, uv):
    """Mid-surface points and top-face directions of an inflation at Ω points.

    Parameters
    ----------
    inflation : inflation.simulate.Inflation
    uv : ndarray of shape (k, 2)
        Points on Ω (m).

    Returns
    -------
    mid : ndarray of shape (k, 3)
        (top + bottom) / 2 interpolated at ``uv`` (m).
    up : ndarray of shape (k, 3)
        Unit vectors from the bottom to the top face there (the top normal).
    """
    mesh = inflation.mesh
    tri, bary = locate(mesh, uv)
    top = np.einsum("kj,kjd->kd", bary, inflation.xyz[mesh.top[tri]])
    bottom = np.einsum("kj,kjd->kd", bary, inflation.xyz[mesh.bottom[tri]])
    up = top - bottom
    return 0.5 * (top + bottom), up / np.linalg.norm(up, axis=1, keepdims=True)


def deviation(inflation, approx_xyz, approx_uv) -> Deviation:
    """Deviation of the inflated mid-surface from Ŝ after a rigid (Kabsch) alignment.

    Parameters
    ----------
    inflation : Inflation
    approx_xyz : ndarray of shape (n, 3)
        Ŝ's vertices (m).
    approx_uv : ndarray of shape (n, 2)
        Their Ω coordinates (m).
    """
    target = np.asarray(approx_xyz, float)
    mid, _ = surface_at(inflation, approx_uv)
    tc, mc = target.mean(axis=0), mid.mean(axis=0)
    rot, _ = Rotation.align_vectors(target - tc, mid - mc)
    aligned = rot.apply(mid - mc) + tc
    dist = np.linalg.norm(aligned - target, axis=1)
    diag = float(np.linalg.norm(np.ptp(target, axis=0)))
    rms = float(np.sqrt(np.mean(dist ** 2)))
    return Deviation(rms=rms, max=float(dist.max()), rms_pct_diag=100.0 * rms / diag,
                     per_vertex=dist, aligned=aligned)


def realized_curvature(inflation, a, b, polylines) -> np.ndarray:
    """Signed curvature (1/m) the simulated mid-surface realizes along each dash.

    The circle through the mid-surface points at the dash's two ends and its
    middle (Menger curvature); positive when the surface bends away from the
    top face, the sign convention of the designer.

    Parameters
    ----------
    a, b : ndarray of shape (k, 2)
        Dash ends on Ω (m).
    polylines : sequence of ndarray of shape (p, 2)
        Dash paths on Ω (m).
    """
    k = len(a)
    if k == 0:
        return np.zeros(0)
    pts = np.concatenate([np.asarray(a, float), midpoints(polylines), np.asarray(b, float)])
    xyz, up = surface_at(inflation, pts)
    p, m, q = xyz[:k], xyz[k:2 * k], xyz[2 * k:]
    area2 = np.linalg.norm(np.cross(m - p, q - p), axis=1)
    sides = np.linalg.norm(m - p, axis=1) * np.linalg.norm(q - m, axis=1) * np.linalg.norm(q - p, axis=1)
    kappa = 2.0 * area2 / np.maximum(sides, 1e-300)
    # the chord's middle lies on the concave side: toward the top face means kappa < 0
    toward_top = np.einsum("kd,kd->k", 0.5 * (p + q) - m, up[k:2 * k]) > 0
    return np.where(toward_top, -kappa, kappa)
